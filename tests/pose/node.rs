//! End to end over DDS on loopback: a rendered eye-in-hand session replayed into the
//! built `pose_node` (on this test's own ROS domain). Every frame's pose arrives as
//! PoseStamped, PoseWithCovarianceStamped and `/tf`, stamped with the image's stamp and
//! equal to what the stage (and so `stereocal pose`) computes offline; bad frames
//! publish nothing and are counted with their reason in `~/status`; the node stops
//! cleanly.

use std::process::Command;
use std::time::{Duration, Instant};

use nalgebra::{Isometry3, Quaternion, Translation3, UnitQuaternion};
use ros2_client::{Publisher, Subscription};
use stereocal::cli::synth::ModelArg;
use stereocal::pose::stage::PoseStage;
use stereocal_msgs::builtin_interfaces::Time;
use stereocal_msgs::geometry_msgs::{Pose, PoseStamped, PoseWithCovarianceStamped};
use stereocal_msgs::sensor_msgs::{CameraInfo, Image};
use stereocal_msgs::std_msgs;
use stereocal_msgs::tf2_msgs::TFMessage;
use stereocal_runtime::qos;
use stereocal_runtime::testing::{DomainLease, NodeProcess, PeerNode};
use stereocal_vision::board::{Chessboard, Target};
use stereocal_vision::pnp::PoseOptions;

use super::{pose_error, session};
use crate::common;

/// Longest wait for the node to answer one frame; frames are sent again every second
/// meanwhile (they are best-effort to the node).
const FRAME_DEADLINE: Duration = Duration::from_secs(30);
/// How long a status counting a lone image may take after the frame that reveals it:
/// statuses go out at most once a second.
const STATUS_WAIT: Duration = Duration::from_secs(5);
/// Lone images sent before the test gives up on one being counted.
const LONE_IMAGE_ATTEMPTS: i32 = 5;

fn isometry(pose: &Pose) -> Isometry3<f64> {
    let q = pose.orientation;
    Isometry3::from_parts(
        Translation3::new(pose.position.x, pose.position.y, pose.position.z),
        UnitQuaternion::from_quaternion(Quaternion::new(q.w, q.x, q.y, q.z)),
    )
}

/// The test's side of the node.
struct Player {
    image: Publisher<Image>,
    info: Publisher<CameraInfo>,
    poses: Subscription<PoseStamped>,
    with_covariance: Subscription<PoseWithCovarianceStamped>,
    tf: Subscription<TFMessage>,
    status: Subscription<std_msgs::String>,
    received: Vec<PoseStamped>,
    received_with_covariance: Vec<PoseWithCovarianceStamped>,
    received_tf: Vec<TFMessage>,
    last_status: serde_json::Value,
    _peer: PeerNode,
}

impl Player {
    fn new(domain: &DomainLease) -> Self {
        let mut peer = common::test_node(domain, "pose_player");
        Self {
            image: peer
                .publisher("/camera/image_raw", qos::reliable(10))
                .unwrap(),
            info: peer
                .publisher("/camera/camera_info", qos::reliable(10))
                .unwrap(),
            poses: peer
                .subscription("/camera/target_pose", qos::reliable(50))
                .unwrap(),
            with_covariance: peer
                .subscription("/camera/target_pose_with_covariance", qos::reliable(50))
                .unwrap(),
            tf: peer.subscription("/tf", qos::reliable(100)).unwrap(),
            status: peer
                .subscription(
                    "/camera/pose_node/status",
                    qos::reliable(10).durability(ros2_client::qos::Durability::TransientLocal),
                )
                .unwrap(),
            received: Vec::new(),
            received_with_covariance: Vec::new(),
            received_tf: Vec::new(),
            last_status: serde_json::Value::Null,
            _peer: peer,
        }
    }

    fn poll(&mut self) {
        while let Ok(Some((m, _))) = self.poses.take() {
            self.received.push(m);
        }
        while let Ok(Some((m, _))) = self.with_covariance.take() {
            self.received_with_covariance.push(m);
        }
        while let Ok(Some((m, _))) = self.tf.take() {
            self.received_tf.push(m);
        }
        while let Ok(Some((m, _))) = self.status.take() {
            self.last_status = serde_json::from_str(&m.data).unwrap();
        }
    }

    fn status(&self, group: &str, key: &str) -> u64 {
        self.last_status[group][key].as_u64().unwrap_or(0)
    }

    /// Waits until `done` holds, polling; panics naming `what` after the deadline.
    fn wait_for(&mut self, what: &str, mut done: impl FnMut(&Self) -> bool) {
        let deadline = Instant::now() + FRAME_DEADLINE;
        loop {
            self.poll();
            if done(self) {
                return;
            }
            assert!(
                Instant::now() < deadline,
                "{what}: nothing in {FRAME_DEADLINE:?}; status {}",
                self.last_status
            );
            std::thread::sleep(Duration::from_millis(10));
        }
    }

    /// Waits up to `limit` for `done` to hold, polling; whether it did.
    fn wait_until(&mut self, limit: Duration, mut done: impl FnMut(&Self) -> bool) -> bool {
        let deadline = Instant::now() + limit;
        loop {
            self.poll();
            if done(self) {
                return true;
            }
            if Instant::now() >= deadline {
                return false;
            }
            std::thread::sleep(Duration::from_millis(10));
        }
    }

    /// Sends a frame (its camera_info first, when given) until `answered` holds.
    fn send_until(
        &mut self,
        image: &Image,
        info: Option<&CameraInfo>,
        what: &str,
        answered: impl Fn(&Self) -> bool,
    ) {
        let deadline = Instant::now() + FRAME_DEADLINE;
        loop {
            if let Some(info) = info {
                self.info.publish(info.clone()).unwrap();
            }
            self.image.publish(image.clone()).unwrap();
            let resend = Instant::now() + Duration::from_secs(1);
            while Instant::now() < resend {
                self.poll();
                if answered(self) {
                    return;
                }
                std::thread::sleep(Duration::from_millis(10));
            }
            assert!(
                Instant::now() < deadline,
                "{what}: no answer in {FRAME_DEADLINE:?}; status {}",
                self.last_status
            );
        }
    }

    fn has_pose(&self, stamp: Time) -> bool {
        self.received.iter().any(|p| p.header.stamp == stamp)
    }
}

fn start_node(domain: &DomainLease, board: &stereocal_vision::synth::Chessboard) -> NodeProcess {
    let mut command = Command::new(env!("CARGO_BIN_EXE_pose_node"));
    command.args([
        "--ros-args",
        "-r",
        "__ns:=/camera",
        "-r",
        "image:=image_raw",
        "-p",
        &format!("size:={}x{}", board.cols, board.rows),
        "-p",
        &format!("square:={}", board.square_size),
        "-p",
        "queue_size:=20",
    ]);
    NodeProcess::spawn(command, domain.id()).expect("pose_node starts")
}

fn shifted(stamp: Time, seconds: i32) -> Time {
    Time {
        sec: stamp.sec + seconds,
        ..stamp
    }
}

#[test]
fn a_replayed_session_gets_every_pose_over_dds_as_the_stage_computes_it() {
    let session = session(71, 8, ModelArg::PlumbBob, 0.0, None);
    let board = &session.truth.board;
    let stage = PoseStage::new(
        Target::Chessboard(Chessboard::new(board.cols, board.rows, board.square_size).unwrap()),
        PoseOptions::default(),
        false,
    )
    .unwrap();
    let domain = DomainLease::for_test().unwrap();
    let mut player = Player::new(&domain);
    let node = start_node(&domain, board);
    player.wait_for("the node's first status", |p| !p.last_status.is_null());

    for (image, info) in &session.frames {
        let stamp = image.header.stamp;
        player.send_until(image, Some(info), "a good frame", |p| p.has_pose(stamp));
    }

    // Bad frames, each stamped apart from the good ones: an uncalibrated camera_info,
    // a target out of view, and an image whose camera_info never comes (found out when
    // the next frame's camera_info arrives).
    let (image, info) = &session.frames[0];
    let bad = |seconds: i32| {
        let (mut image, mut info) = (image.clone(), info.clone());
        image.header.stamp = shifted(image.header.stamp, seconds);
        info.header.stamp = image.header.stamp;
        (image, info)
    };
    let (uncalibrated_image, mut uncalibrated) = bad(100);
    uncalibrated.k[0] = 0.0;
    player.send_until(
        &uncalibrated_image,
        Some(&uncalibrated),
        "an uncalibrated frame",
        |p| p.status("rejections", "camera_info") > 0,
    );
    let (mut blank, blank_info) = bad(101);
    blank.data.iter_mut().for_each(|v| *v = 200);
    player.send_until(
        &blank,
        Some(&blank_info),
        "a frame without the target",
        |p| p.status("rejections", "not_visible") > 0,
    );
    // The node reads images best-effort: a lone image lost on the way is sent again,
    // with a new stamp, until one is counted.
    let mut bad_stamps = vec![uncalibrated_image.header.stamp, blank.header.stamp];
    let unpaired = |p: &Player| {
        p.status("rejections", "unpaired_camera_info") + p.status("frames", "unpaired") > 0
    };
    for attempt in 0.. {
        let (lonely, _) = bad(102 + 2 * attempt);
        bad_stamps.push(lonely.header.stamp);
        player.image.publish(lonely).unwrap();
        let (last, last_info) = bad(103 + 2 * attempt);
        let last_stamp = last.header.stamp;
        player.send_until(&last, Some(&last_info), "the frame after", |p| {
            p.has_pose(last_stamp)
        });
        if player.wait_until(STATUS_WAIT, unpaired) {
            break;
        }
        assert!(
            attempt < LONE_IMAGE_ATTEMPTS,
            "the frame without camera_info: not counted after {LONE_IMAGE_ATTEMPTS} tries; status {}",
            player.last_status
        );
    }
    for stamp in bad_stamps {
        assert!(
            !player.has_pose(stamp),
            "a pose was published for a bad frame"
        );
    }
    assert!(
        player.last_status["last_rejection"]
            .as_str()
            .is_some_and(|r| !r.is_empty()),
        "{}",
        player.last_status
    );

    let exit = node.terminate();
    assert!(
        exit.clean(),
        "pose_node did not stop cleanly:\n{}",
        exit.logs
    );
    player.poll();

    // Every good frame's pose, equal to the stage's, near the truth, in all three forms.
    for (index, (image, info)) in session.frames.iter().enumerate() {
        let stamp = image.header.stamp;
        let offline = stage.estimate(image, info).0.unwrap();
        let pose = player
            .received
            .iter()
            .find(|p| p.header.stamp == stamp)
            .unwrap();
        assert_eq!(pose.header.frame_id, image.header.frame_id);
        let online = isometry(&pose.pose);
        let (deg, mm) = pose_error(&online, &offline.estimate.camera_from_target);
        assert!(
            deg < 1e-9 && mm < 1e-9,
            "frame {index}: {deg} deg, {mm} mm from the offline pose"
        );
        let (deg, mm) = pose_error(&online, &session.truth_pose(index));
        assert!(
            deg < 0.05 && mm < 0.5,
            "frame {index}: {deg} deg, {mm} mm from the truth"
        );

        let with_covariance = player
            .received_with_covariance
            .iter()
            .find(|p| p.header.stamp == stamp)
            .unwrap();
        assert_eq!(with_covariance.pose.pose, pose.pose);
        for (k, value) in with_covariance.pose.covariance.iter().enumerate() {
            let expected = offline.estimate.covariance[(k / 6, k % 6)];
            assert!(
                (value - expected).abs() <= 1e-12 * expected.abs().max(1e-12),
                "covariance[{k}]"
            );
        }
        let tf = player
            .received_tf
            .iter()
            .flat_map(|m| &m.transforms)
            .find(|t| t.header.stamp == stamp)
            .unwrap();
        assert_eq!(
            (tf.header.frame_id.as_str(), tf.child_frame_id.as_str()),
            (image.header.frame_id.as_str(), "target")
        );
        assert_eq!(tf.transform.rotation, pose.pose.orientation);
    }
}
