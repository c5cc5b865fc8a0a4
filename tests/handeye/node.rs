//! End to end over DDS on loopback: a rendered eye-in-hand session replayed into the
//! built `handeye_node` (on this test's own ROS domain), the robot's poses once on a
//! PoseStamped topic and once on `/tf`. Each frame is sent after the robot's poses
//! around it; the node pairs it with the robot's pose at its stamp, finds the robot
//! still, and `~/take_sample` keeps it. The node is SIGKILLed mid-session and restarted
//! next to a damaged sample file: the samples are back and the damaged file is named.
//! `~/compute` publishes `tool -> camera` on `/tf_static`, equal to what
//! `stereocal handeye` computes offline from the same bag and near the truth; `~/save`
//! writes it; bad requests get a clear refusal. In automatic mode every new still pose
//! is sampled without a call, and a frame without the target, one without a robot pose
//! at its stamp and one where a sample was already taken are each refused with their
//! reason. pose_node's poses (`target_source: pose`) calibrate as `stereocal pose` then
//! `stereocal handeye` do.

use std::path::Path;
use std::process::Command;
use std::time::{Duration, Instant};

use nalgebra::{Isometry3, Quaternion, Translation3, UnitQuaternion};
use ros2_client::{Publisher, Subscription};
use stereocal::cli::handeye::{HandEyeArgs, SetupArg, handeye_bag};
use stereocal::cli::pose::{PoseArgs, pose_bag};
use stereocal::cli::synth::{SceneArg, SynthArgs};
use stereocal::handeye::report::HandEyeReport;
use stereocal::pose::record::{isometry_of, seconds};
use stereocal_msgs::geometry_msgs::{PoseStamped, Transform};
use stereocal_msgs::sensor_msgs::{CameraInfo, Image};
use stereocal_msgs::std_msgs;
use stereocal_msgs::std_srvs::srv::{TriggerRequest, TriggerResponse};
use stereocal_msgs::stereocal_msgs::srv::{RemoveSampleRequest, RemoveSampleResponse};
use stereocal_msgs::tf2_msgs::TFMessage;
use stereocal_rosbag::{BagReader, TopicFilter};
use stereocal_runtime::qos;
use stereocal_runtime::service::{ServiceClient, call, create_client, wait_for_server};
use stereocal_runtime::testing::{DomainLease, NodeProcess, PeerNode};

use crate::common;
use crate::pose::pose_error;

/// Longest wait for the node to answer one frame or call; frames are sent again every
/// second meanwhile (they are best-effort to the node).
const DEADLINE: Duration = Duration::from_secs(60);
/// Frames of the session.
const FRAMES: usize = 9;
/// Samples taken before the node is killed.
const KILL_AFTER: usize = 4;

/// Where the robot's poses come from.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Robot {
    Topic,
    Tf,
}

/// A rendered session read back from its bag.
struct Session {
    dir: tempfile::TempDir,
    truth: stereocal_vision::synth::GroundTruth,
    frames: Vec<(Image, CameraInfo)>,
    robot_poses: Vec<PoseStamped>,
    tf: Vec<TFMessage>,
}

fn decode<M: serde::de::DeserializeOwned>(reader: &BagReader, topic: &str) -> Vec<M> {
    reader
        .messages(&TopicFilter::only([topic]))
        .map(|m| stereocal_msgs::cdr::from_bytes(&m.expect("message").data).expect("decodes"))
        .collect()
}

fn session() -> Session {
    let dir = tempfile::tempdir().expect("temp dir");
    let args = SynthArgs::new(
        SceneArg::HandeyeInHand,
        dir.path().join("synth"),
        91,
        FRAMES,
    );
    let truth = common::synthesize_session(&args, None);
    let reader = BagReader::open(dir.path().join("synth/bag")).expect("bag");
    let images: Vec<Image> = decode(&reader, "/camera/image_raw");
    let infos: Vec<CameraInfo> = decode(&reader, "/camera/camera_info");
    Session {
        frames: images.into_iter().zip(infos).collect(),
        robot_poses: decode(&reader, "/robot/tool_pose"),
        tf: decode(&reader, "/tf"),
        truth,
        dir,
    }
}

/// A rendered session, its board (columns, rows, square), the node's state folder, a
/// ROS domain of the test's own, and the test's side of the node on it.
fn setup() -> (
    Session,
    (usize, usize, f64),
    std::path::PathBuf,
    DomainLease,
    Player,
) {
    let session = session();
    let board = &session.truth.board;
    let board = (board.cols, board.rows, board.square_size);
    let state_dir = session.dir.path().join("state");
    let domain = DomainLease::for_test().expect("a ROS domain");
    let player = Player::new(&domain);
    (session, board, state_dir, domain, player)
}

/// The test's side of the node.
struct Player {
    image: Publisher<Image>,
    info: Publisher<CameraInfo>,
    robot_pose: Publisher<PoseStamped>,
    tf: Publisher<TFMessage>,
    status: Subscription<std_msgs::String>,
    tf_static: Subscription<TFMessage>,
    take_sample: ServiceClient<TriggerRequest, TriggerResponse>,
    compute: ServiceClient<TriggerRequest, TriggerResponse>,
    save: ServiceClient<TriggerRequest, TriggerResponse>,
    remove_sample: ServiceClient<RemoveSampleRequest, RemoveSampleResponse>,
    last_status: serde_json::Value,
    received_tf_static: Vec<TFMessage>,
    peer: PeerNode,
}

const NODE: &str = "/robot/handeye_node";

impl Player {
    fn new(domain: &DomainLease) -> Self {
        let mut peer = common::test_node(domain, "handeye_player");
        let node = peer.node_mut();
        let take_sample = create_client(node, &format!("{NODE}/take_sample")).expect("client");
        let compute = create_client(node, &format!("{NODE}/compute")).expect("client");
        let save = create_client(node, &format!("{NODE}/save")).expect("client");
        let remove_sample = create_client(node, &format!("{NODE}/remove_sample")).expect("client");
        Self {
            image: peer
                .publisher("/camera/image_raw", qos::reliable(10))
                .unwrap(),
            info: peer
                .publisher("/camera/camera_info", qos::reliable(10))
                .unwrap(),
            robot_pose: peer
                .publisher("/robot/tool_pose", qos::reliable(1000))
                .unwrap(),
            tf: peer.publisher("/tf", qos::reliable(1000)).unwrap(),
            status: peer
                .subscription(
                    &format!("{NODE}/status"),
                    qos::reliable(10).durability(ros2_client::qos::Durability::TransientLocal),
                )
                .unwrap(),
            tf_static: peer.subscription("/tf_static", qos::tf_static()).unwrap(),
            take_sample,
            compute,
            save,
            remove_sample,
            last_status: serde_json::Value::Null,
            received_tf_static: Vec::new(),
            peer,
        }
    }

    fn poll(&mut self) {
        while let Ok(Some((m, _))) = self.status.take() {
            self.last_status = serde_json::from_str(&m.data).expect("status is JSON");
        }
        while let Ok(Some((m, _))) = self.tf_static.take() {
            self.received_tf_static.push(m);
        }
    }

    /// Waits until `done` holds, polling; panics naming `what` after the deadline.
    fn wait_for(&mut self, what: &str, mut done: impl FnMut(&Self) -> bool) {
        let deadline = Instant::now() + DEADLINE;
        loop {
            self.poll();
            if done(self) {
                return;
            }
            assert!(
                Instant::now() < deadline,
                "{what}: not in {DEADLINE:?}; status {}",
                self.last_status
            );
            std::thread::sleep(Duration::from_millis(10));
        }
    }

    fn samples(&self) -> usize {
        self.last_status["samples"].as_array().map_or(0, Vec::len)
    }

    /// Publishes the robot's poses stamped up to `until` (seconds) that are not sent yet.
    fn send_robot(&mut self, session: &Session, robot: Robot, sent: &mut usize, until: f64) {
        match robot {
            Robot::Topic => {
                while let Some(pose) = session.robot_poses.get(*sent)
                    && seconds(&pose.header.stamp) <= until
                {
                    self.robot_pose.publish(pose.clone()).unwrap();
                    *sent += 1;
                }
            }
            Robot::Tf => {
                while let Some(tf) = session.tf.get(*sent)
                    && seconds(&tf.transforms[0].header.stamp) <= until
                {
                    self.tf.publish(tf.clone()).unwrap();
                    *sent += 1;
                }
            }
        }
    }

    /// Sends the robot's poses up to a little after `frame` (as a driver streams them),
    /// then the frame until the node's status shows its verdict.
    fn show(
        &mut self,
        session: &Session,
        robot: Robot,
        sent: &mut usize,
        frame: &(Image, CameraInfo),
    ) {
        let stamp = seconds(&frame.0.header.stamp);
        self.send_robot(session, robot, sent, stamp + 0.1);
        self.send_frame(frame);
    }

    /// Sends a frame until the node's status shows its verdict.
    fn send_frame(&mut self, (image, info): &(Image, CameraInfo)) {
        let stamp = seconds(&image.header.stamp);
        let deadline = Instant::now() + DEADLINE;
        loop {
            self.info.publish(info.clone()).unwrap();
            self.image.publish(image.clone()).unwrap();
            let resend = Instant::now() + Duration::from_secs(1);
            while Instant::now() < resend {
                self.poll();
                if self.last_status["latest"]["stamp"].as_f64() == Some(stamp) {
                    return;
                }
                std::thread::sleep(Duration::from_millis(10));
            }
            assert!(
                Instant::now() < deadline,
                "the frame at {stamp} s: no verdict in {DEADLINE:?}; status {}",
                self.last_status
            );
        }
    }

    fn trigger(&mut self, which: &str) -> TriggerResponse {
        let client = match which {
            "take_sample" => &self.take_sample,
            "compute" => &self.compute,
            "save" => &self.save,
            other => panic!("no service {other}"),
        };
        assert!(
            wait_for_server(self.peer.node(), client, DEADLINE),
            "no ~/{which} server"
        );
        let response = call(client, &TriggerRequest::default(), DEADLINE)
            .expect("call")
            .unwrap_or_else(|| panic!("~/{which} did not answer"));
        self.poll();
        response
    }

    fn remove(&mut self, index: u32) -> RemoveSampleResponse {
        assert!(
            wait_for_server(self.peer.node(), &self.remove_sample, DEADLINE),
            "no ~/remove_sample server"
        );
        call(
            &self.remove_sample,
            &RemoveSampleRequest { index },
            DEADLINE,
        )
        .expect("call")
        .expect("~/remove_sample answers")
    }
}

fn start_node(
    domain: &DomainLease,
    state_dir: &Path,
    robot: Robot,
    board: (usize, usize, f64),
    extra: &[&str],
) -> NodeProcess {
    let mut command = Command::new(env!("CARGO_BIN_EXE_handeye_node"));
    command.args([
        "--ros-args",
        "-r",
        "__ns:=/robot",
        "-r",
        "image:=/camera/image_raw",
        "-r",
        "camera_info:=/camera/camera_info",
        "-r",
        "robot_pose:=/robot/tool_pose",
        "-r",
        "target_pose:=/camera/target_pose",
        "-p",
        &format!("size:={}x{}", board.0, board.1),
        "-p",
        &format!("square:={}", board.2),
        "-p",
        &format!("state_dir:={}", state_dir.display()),
        "-p",
        "base_frame:=base",
        "-p",
        "tool_frame:=tool",
        "-p",
        &format!(
            "robot_source:={}",
            match robot {
                Robot::Topic => "topic",
                Robot::Tf => "tf",
            }
        ),
    ]);
    for parameter in extra {
        command.args(["-p", parameter]);
    }
    NodeProcess::spawn(command, domain.id()).expect("handeye_node starts")
}

fn isometry_of_transform(t: &Transform) -> Isometry3<f64> {
    let (p, q) = (t.translation, t.rotation);
    Isometry3::from_parts(
        Translation3::new(p.x, p.y, p.z),
        UnitQuaternion::from_quaternion(Quaternion::new(q.w, q.x, q.y, q.z)),
    )
}

fn run_session(robot: Robot) {
    let (session, board, state_dir, domain, mut player) = setup();
    let mut node = start_node(&domain, &state_dir, robot, board, &[]);
    player.wait_for("the node's first status", |p| !p.last_status.is_null());

    // Nothing seen yet: refused, and said why.
    let early = player.trigger("take_sample");
    assert!(
        !early.success && early.message.contains("no target frame yet"),
        "{early:?}"
    );
    let too_few = player.trigger("compute");
    assert!(
        !too_few.success && too_few.message.contains("at least 3"),
        "{too_few:?}"
    );

    let mut robot_sent = 0;
    for (k, frame) in session.frames.iter().enumerate() {
        player.show(&session, robot, &mut robot_sent, frame);
        let latest = player.last_status["latest"].clone();
        assert_eq!(latest["ready"], true, "frame {k}: {latest}");
        let taken = player.trigger("take_sample");
        assert!(taken.success, "frame {k}: {taken:?}");
        player.wait_for("the sample in the status", |p| p.samples() == k + 1);
        // The same pose again is refused: the robot has not moved.
        if k == 0 {
            let again = player.trigger("take_sample");
            assert!(
                !again.success && again.message.contains("sample 0"),
                "{again:?}"
            );
        }
        if k + 1 == KILL_AFTER {
            let logs = node.kill();
            assert!(logs.contains("take_sample"), "{logs}");
            std::fs::write(state_dir.join("sample-000099.yaml"), "stamp: [damaged").unwrap();
            player.last_status = serde_json::Value::Null;
            node = start_node(&domain, &state_dir, robot, board, &[]);
            player.wait_for("the restarted node's status", |p| !p.last_status.is_null());
            assert_eq!(player.samples(), KILL_AFTER, "{}", player.last_status);
            let damaged = &player.last_status["damaged"];
            assert!(
                damaged[0]["path"]
                    .as_str()
                    .is_some_and(|p| p.ends_with("sample-000099.yaml")),
                "{damaged}"
            );
        }
    }

    let computed = player.trigger("compute");
    assert!(computed.success, "{computed:?}");
    assert!(
        computed.message.contains("tool -> camera_optical_frame"),
        "{computed:?}"
    );
    player.wait_for("the result on /tf_static", |p| {
        !p.received_tf_static.is_empty()
    });
    let published = &player.received_tf_static[0].transforms[0];
    assert_eq!(published.header.frame_id, "tool");
    assert_eq!(published.child_frame_id, "camera_optical_frame");
    let tool_from_camera = isometry_of_transform(&published.transform);

    // The offline command on the same bag gives the same result.
    let offline = handeye_bag(&HandEyeArgs::from_images(
        session.dir.path().join("synth/bag"),
        SetupArg::EyeInHand,
        "/camera/image_raw",
        board,
        "/robot/tool_pose",
        session.dir.path().join("offline"),
    ))
    .expect("stereocal handeye");
    assert_eq!(offline.chosen, "refined");
    let offline_transform = isometry_of(&offline.results["refined"]);
    let (deg, mm) = pose_error(&tool_from_camera, &offline_transform);
    assert!(
        deg < 1e-6 && mm < 1e-6,
        "node against offline: {deg} deg, {mm} mm"
    );
    // And near the truth, within the offline result's predicted uncertainty.
    let truth = session
        .truth
        .extrinsics
        .tool_from_camera
        .as_ref()
        .unwrap()
        .isometry();
    let (deg, mm) = pose_error(&tool_from_camera, &truth);
    let uncertainty = offline.uncertainty.as_ref().unwrap();
    println!("{robot:?}: {deg:.4} deg, {mm:.3} mm against {uncertainty:?}");
    assert!(
        deg < 3.0 * uncertainty.rotation_deg && mm < 3.0 * uncertainty.translation_mm,
        "node against the truth: {deg} deg, {mm} mm ({uncertainty:?})"
    );

    let saved = player.trigger("save");
    assert!(saved.success, "{saved:?}");
    let written: HandEyeReport = serde_yaml::from_str(
        &std::fs::read_to_string(state_dir.join("handeye.yaml")).expect("handeye.yaml"),
    )
    .expect("a report");
    assert_eq!(written.samples, FRAMES);
    assert!(state_dir.join("report.html").exists());

    let missing = player.remove(FRAMES as u32);
    assert!(
        !missing.success && missing.message.contains("no sample"),
        "{missing:?}"
    );
    let removed = player.remove(0);
    assert!(removed.success, "{removed:?}");
    assert_eq!(removed.samples as usize, FRAMES - 1);
    assert!(state_dir.join("removed/sample-000001.yaml").exists());

    let exit = node.terminate();
    assert!(exit.clean(), "{}", exit.logs);
}

#[test]
fn a_session_with_robot_poses_on_a_topic_survives_a_kill_and_matches_the_offline_command() {
    run_session(Robot::Topic);
}

#[test]
fn a_session_with_robot_poses_on_tf_survives_a_kill_and_matches_the_offline_command() {
    run_session(Robot::Tf);
}

/// The newest frame's reason in the status, once it is about the frame at `stamp`.
fn latest_reason(player: &Player) -> String {
    player.last_status["latest"]["reason"]
        .as_str()
        .unwrap_or_default()
        .to_owned()
}

#[test]
fn automatic_mode_samples_each_new_still_pose_and_says_why_a_frame_cannot_be_sampled() {
    let (session, board, state_dir, domain, mut player) = setup();
    let node = start_node(
        &domain,
        &state_dir,
        Robot::Topic,
        board,
        &["auto_sample:=true", "auto_min_rotation:=0.1"],
    );
    player.wait_for("the node's first status", |p| !p.last_status.is_null());

    // A frame before any robot pose: no partner for its stamp, said after the wait.
    let first = &session.frames[0];
    player.send_frame(first);
    player.wait_for("the unpaired frame's reason", |p| {
        latest_reason(p).contains("no robot pose has arrived on robot_pose")
    });
    let refused = player.trigger("take_sample");
    assert!(
        !refused.success
            && refused
                .message
                .contains("no robot pose at the newest frame's stamp"),
        "{refused:?}"
    );

    // An image without the target.
    let (mut blank, info) = first.clone();
    blank.data.fill(200);
    blank.header.stamp.sec -= 1;
    let mut blank_info = info.clone();
    blank_info.header.stamp = blank.header.stamp;
    player.send_frame(&(blank, blank_info));
    let reason = latest_reason(&player);
    assert!(reason.contains("not visible"), "{reason}");
    let refused = player.trigger("take_sample");
    assert!(
        !refused.success
            && refused
                .message
                .contains("no target pose in the newest frame"),
        "{refused:?}"
    );

    // Every still pose sampled without a call.
    let mut robot_sent = 0;
    for (k, frame) in session.frames.iter().enumerate() {
        player.show(&session, Robot::Topic, &mut robot_sent, frame);
        player.wait_for("the automatic sample", |p| p.samples() == k + 1);
    }
    // The last pose again: the robot stands where a sample was taken; nothing new.
    let (mut again, mut again_info) = session.frames[FRAMES - 1].clone();
    again.header.stamp.nanosec += 50_000_000;
    again_info.header.stamp = again.header.stamp;
    player.send_frame(&(again, again_info));
    let reason = latest_reason(&player);
    assert!(
        reason.contains(&format!("stands where sample {} was taken", FRAMES - 1)),
        "{reason}"
    );
    assert_eq!(player.samples(), FRAMES);
    let computed = player.trigger("compute");
    assert!(computed.success, "{computed:?}");
    let exit = node.terminate();
    assert!(exit.clean(), "{}", exit.logs);
    assert!(exit.logs.contains("automatic sample"), "{}", exit.logs);
}

/// pose_node measures the target; handeye_node takes its poses (`target_source: pose`)
/// and the robot's from /tf: the result equals `stereocal handeye` on the poses
/// `stereocal pose` finds in the same bag.
#[test]
fn pose_node_feeds_handeye_node_and_the_result_matches_the_offline_commands() {
    let (session, board, state_dir, domain, mut player) = setup();
    let mut pose_node = Command::new(env!("CARGO_BIN_EXE_pose_node"));
    pose_node.args([
        "--ros-args",
        "-r",
        "__ns:=/camera",
        "-r",
        "image:=image_raw",
        "-p",
        &format!("size:={}x{}", board.0, board.1),
        "-p",
        &format!("square:={}", board.2),
        "-p",
        "publish_tf:=false",
    ]);
    let pose_node = NodeProcess::spawn(pose_node, domain.id()).expect("pose_node starts");
    let node = start_node(
        &domain,
        &state_dir,
        Robot::Tf,
        board,
        &["target_source:=pose"],
    );
    player.wait_for("the node's first status", |p| !p.last_status.is_null());
    let mut robot_sent = 0;
    for (k, frame) in session.frames.iter().enumerate() {
        player.show(&session, Robot::Tf, &mut robot_sent, frame);
        let taken = player.trigger("take_sample");
        assert!(taken.success, "frame {k}: {taken:?}");
    }
    let computed = player.trigger("compute");
    assert!(computed.success, "{computed:?}");
    player.wait_for("the result on /tf_static", |p| {
        !p.received_tf_static.is_empty()
    });
    let tool_from_camera =
        isometry_of_transform(&player.received_tf_static[0].transforms[0].transform);

    let posed = session.dir.path().join("posed");
    pose_bag(
        &PoseArgs::chessboard(
            session.dir.path().join("synth/bag"),
            posed.clone(),
            board.0,
            board.1,
            board.2,
        ),
        &indicatif::ProgressBar::hidden(),
    )
    .expect("stereocal pose");
    let offline = handeye_bag(&HandEyeArgs::from_poses(
        posed,
        SetupArg::EyeInHand,
        "/camera/target_pose",
        "/robot/tool_pose",
        session.dir.path().join("offline"),
    ))
    .expect("stereocal handeye");
    let status_result = &player.last_status["result"];
    assert_eq!(status_result["chosen"], offline.chosen.as_str());
    let (deg, mm) = pose_error(
        &tool_from_camera,
        &isometry_of(&offline.results[&offline.chosen]),
    );
    assert!(
        deg < 1e-6 && mm < 1e-6,
        "node against offline: {deg} deg, {mm} mm"
    );
    let truth = session
        .truth
        .extrinsics
        .tool_from_camera
        .as_ref()
        .unwrap()
        .isometry();
    let (deg, mm) = pose_error(&tool_from_camera, &truth);
    println!(
        "pose_node -> handeye_node ({}): {deg:.4} deg, {mm:.3} mm",
        offline.chosen
    );
    assert!(deg < 0.1 && mm < 2.0, "{deg} deg, {mm} mm");
    for process in [node, pose_node] {
        let exit = process.terminate();
        assert!(exit.clean(), "{}", exit.logs);
    }
}
