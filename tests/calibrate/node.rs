//! End to end: a synthetic stereo calibration session (1024x768, 40 frames, about one
//! in ten bad; 70 for one camera alone) replayed over DDS on loopback into a
//! `calibrate_node` process (on this test's own ROS domain); `~/calibrate` and `~/commit`
//! called through service clients, the written camera_info files checked against ground
//! truth, and a fake camera's `set_camera_info` receiving the same calibration. A second
//! test kills the node mid-session and finds the samples again after a restart (and none
//! after `~/reset`), the restarted node pairing frames whose stamps differ within its
//! `slop`; a third calibrates the left camera alone with `auto_calibrate`. With
//! `use_sim_time`, a replay at twice and at half speed, `/clock` following the frames,
//! gets the same verdict on every frame, and a `/clock` that goes back is warned about
//! while the node goes on judging.

use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex, OnceLock};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use ros2_client::{Publisher, Subscription};
use stereocal_msgs::CameraInfoFile;
use stereocal_msgs::rosgraph_msgs::Clock;
use stereocal_msgs::sensor_msgs::srv::{SetCameraInfoRequest, SetCameraInfoResponse};
use stereocal_msgs::sensor_msgs::{CameraInfo, Image};
use stereocal_msgs::std_msgs;
use stereocal_msgs::std_srvs::srv::{TriggerRequest, TriggerResponse};
use stereocal_rosbag::{BagReader, TopicFilter};
use stereocal_runtime::qos;
use stereocal_runtime::service::{
    ServiceClient, Srv, call, create_client, create_server, wait_for_server,
};
use stereocal_runtime::testing::{DomainLease, NodeProcess, PeerNode};
use stereocal_runtime::transport::{DiscoveryRange, TransportConfig};
use stereocal_vision::synth::GroundTruth;

use crate::common;

/// What the node calibrates.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Rig {
    /// The pair, in namespace `/stereo`, calibrated on `~/calibrate`.
    Stereo,
    /// The left camera alone, in namespace `/camera`, with `auto_calibrate`.
    MonoAuto,
}

impl Rig {
    fn namespace(self) -> &'static str {
        match self {
            Rig::Stereo => "/stereo",
            Rig::MonoAuto => "/camera",
        }
    }

    /// The node's fully qualified name.
    fn node(self) -> String {
        format!("{}/calibrate_node", self.namespace())
    }
}
/// How long one frame may take to be judged before it is sent again.
const FRAME_TIMEOUT: Duration = Duration::from_secs(5);

/// A rendered session: ground truth and the recorded (left, right) pairs in stamp order.
struct Session {
    truth: GroundTruth,
    pairs: Vec<(Image, Image)>,
}

/// The 40-frame stereo session, synthesized once for every test of this binary.
fn session() -> &'static Session {
    static SESSION: OnceLock<Session> = OnceLock::new();
    SESSION.get_or_init(|| synthesize(3, 40))
}

/// A longer session (70 frames) for one camera alone, whose coverage needs more views.
fn long_session() -> &'static Session {
    static SESSION: OnceLock<Session> = OnceLock::new();
    SESSION.get_or_init(|| synthesize(5, 70))
}

fn synthesize(seed: u64, frames: usize) -> Session {
    let dir = tempfile::tempdir().expect("temp dir");
    let truth =
        common::synthesize_session(&common::calibration_scene(dir.path(), seed, frames), None);
    let reader = BagReader::open(dir.path().join("bag")).expect("bag");
    let read = |topic: &str| -> Vec<Image> {
        reader
            .messages(&TopicFilter::only([topic]))
            .map(|m| m.expect("message").decode::<Image>().expect("image"))
            .collect()
    };
    let left = read("/stereo/left/image_raw");
    let right = read("/stereo/right/image_raw");
    assert_eq!(left.len(), frames);
    assert_eq!(right.len(), frames);
    Session {
        truth,
        pairs: left.into_iter().zip(right).collect(),
    }
}

/// Starts `calibrate_node` for `rig` on `domain` with its state and camera_info files
/// in `dir`, and further `-p` parameters (`name:=value`).
fn start_node(domain: &DomainLease, dir: &Path, rig: Rig, params: &[&str]) -> NodeProcess {
    let state = dir.join("state");
    let url = |name: &str| format!("file://{}", dir.join(format!("{name}.yaml")).display());
    let mut args: Vec<String> = [
        "--ros-args",
        "-r",
        &format!("__ns:={}", rig.namespace()),
        "-p",
        "size:=9x6",
        "-p",
        "square:=0.025",
        "-p",
        &format!("state_dir:={}", state.display()),
    ]
    .map(String::from)
    .to_vec();
    let rig_args = match rig {
        Rig::Stereo => vec![
            "-r".into(),
            "left/image:=left/image_raw".into(),
            "-r".into(),
            "right/image:=right/image_raw".into(),
            "-p".into(),
            "stereo:=true".into(),
            "-p".into(),
            format!("left_camera_info_url:={}", url("left")),
            "-p".into(),
            format!("right_camera_info_url:={}", url("right")),
        ],
        Rig::MonoAuto => vec![
            "-r".into(),
            "image:=image_raw".into(),
            "-p".into(),
            "camera_name:=left".into(),
            "-p".into(),
            "auto_calibrate:=true".into(),
            "-p".into(),
            format!("camera_info_url:={}", url("${NAME}")),
        ],
    };
    args.extend(rig_args);
    for param in params {
        args.extend(["-p".to_owned(), (*param).to_owned()]);
    }
    let mut command = Command::new(env!("CARGO_BIN_EXE_calibrate_node"));
    command
        .args(&args)
        .env("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST");
    NodeProcess::spawn(command, domain.id()).expect("start calibrate_node")
}

/// The test's side: a player of the pair, a reader of `~/status`, clients of the node's
/// services, and a fake left camera serving `left/set_camera_info`.
struct Player {
    clock: Publisher<Clock>,
    left: Publisher<Image>,
    right: Option<Publisher<Image>>,
    status: Subscription<std_msgs::String>,
    annotated: Subscription<Image>,
    calibrate: ServiceClient<TriggerRequest, TriggerResponse>,
    commit: ServiceClient<TriggerRequest, TriggerResponse>,
    reset: ServiceClient<TriggerRequest, TriggerResponse>,
    camera_info_received: Arc<Mutex<Vec<CameraInfo>>>,
    camera_stop: Arc<AtomicBool>,
    camera: Option<JoinHandle<()>>,
    last_status: serde_json::Value,
    peer: PeerNode,
}

impl Player {
    fn new(domain: &DomainLease, rig: Rig) -> Self {
        let transport = TransportConfig {
            range: DiscoveryRange::Localhost,
            ..TransportConfig::rustdds_defaults()
        };
        let mut peer = PeerNode::new(&transport, domain.id(), "/stereocal", "calibration_player")
            .expect("player node");
        let ns = rig.namespace();
        let (left_name, camera_service, annotated_name) = match rig {
            Rig::Stereo => (
                format!("{ns}/left/image_raw"),
                format!("{ns}/left/set_camera_info"),
                format!("{}/left/annotated_image", rig.node()),
            ),
            Rig::MonoAuto => (
                format!("{ns}/image_raw"),
                format!("{ns}/set_camera_info"),
                format!("{}/annotated_image", rig.node()),
            ),
        };
        let clock = peer
            .publisher::<Clock>("/clock", qos::reliable(1))
            .expect("clock");
        let left = peer
            .publisher::<Image>(&left_name, qos::reliable(10))
            .expect("left");
        let right = (rig == Rig::Stereo).then(|| {
            peer.publisher::<Image>(&format!("{ns}/right/image_raw"), qos::reliable(10))
                .expect("right")
        });
        let annotated = peer
            .subscription::<Image>(&annotated_name, qos::reliable(50))
            .expect("annotated");
        let status = peer
            .subscription::<std_msgs::String>(
                &format!("{}/status", rig.node()),
                qos::reliable(10).durability(ros2_client::qos::Durability::TransientLocal),
            )
            .expect("status");
        let node = peer.node_mut();
        let calibrate = create_client(node, &format!("{}/calibrate", rig.node())).expect("client");
        let commit = create_client(node, &format!("{}/commit", rig.node())).expect("client");
        let reset = create_client(node, &format!("{}/reset", rig.node())).expect("client");
        let server =
            create_server::<SetCameraInfoRequest, SetCameraInfoResponse>(node, &camera_service)
                .expect("server");
        let camera_info_received = Arc::new(Mutex::new(Vec::new()));
        let camera_stop = Arc::new(AtomicBool::new(false));
        let camera = {
            let received = Arc::clone(&camera_info_received);
            let stop = Arc::clone(&camera_stop);
            std::thread::spawn(move || {
                while !stop.load(Ordering::Relaxed) {
                    while let Ok(Some((id, Srv(request)))) = server.receive_request() {
                        received.lock().expect("lock").push(request.camera_info);
                        let _ = server.send_response(
                            id,
                            Srv(SetCameraInfoResponse {
                                success: true,
                                status_message: "stored".into(),
                            }),
                        );
                    }
                    std::thread::sleep(Duration::from_millis(5));
                }
            })
        };
        Self {
            clock,
            left,
            right,
            status,
            annotated,
            calibrate,
            commit,
            reset,
            camera_info_received,
            camera_stop,
            camera: Some(camera),
            last_status: serde_json::Value::Null,
            peer,
        }
    }

    /// Takes the status messages that arrived; whether any did.
    fn poll_status(&mut self) -> bool {
        let mut got = false;
        while let Ok(Some((message, _))) = self.status.take() {
            self.last_status = serde_json::from_str(&message.data).expect("status is JSON");
            got = true;
        }
        got
    }

    /// Annotated images received so far.
    fn annotated_images(&self) -> Vec<Image> {
        let mut images = Vec::new();
        while let Ok(Some((image, _))) = self.annotated.take() {
            images.push(image);
        }
        images
    }

    fn status_count(&self, key: &str) -> u64 {
        match key {
            "samples" => self.last_status["samples"].as_u64().unwrap_or(0),
            frames => self.last_status["frames"][frames].as_u64().unwrap_or(0),
        }
    }

    /// Waits for a started node's first status (it publishes one at start-up).
    fn wait_for_node(&mut self) {
        self.last_status = serde_json::Value::Null;
        let deadline = Instant::now() + Duration::from_secs(20);
        while !self.poll_status() {
            assert!(Instant::now() < deadline, "no status from the node in 20 s");
            std::thread::sleep(Duration::from_millis(20));
        }
    }

    /// Publishes one pair (the left image alone to a mono node) and waits until the node
    /// has judged it (sending it again
    /// while the node's readers have not matched ours yet, as frames are best-effort).
    fn send_pair(&mut self, pair: &(Image, Image)) {
        self.send_skewed_pair(pair, 0);
    }

    /// [`Player::send_pair`] with the right image stamped `skew_ns` after the left, as
    /// cameras without a shared trigger stamp their frames.
    fn send_skewed_pair(&mut self, pair: &(Image, Image), skew_ns: u32) {
        let judged = self.status_count("judged");
        let deadline = Instant::now() + Duration::from_secs(30);
        let mut right_image = pair.1.clone();
        let stamp = &mut right_image.header.stamp;
        let nanosec = u64::from(stamp.nanosec) + u64::from(skew_ns);
        stamp.sec += i32::try_from(nanosec / 1_000_000_000).expect("seconds");
        stamp.nanosec = u32::try_from(nanosec % 1_000_000_000).expect("nanoseconds");
        loop {
            self.left.publish(pair.0.clone()).expect("publish left");
            if let Some(right) = &self.right {
                right.publish(right_image.clone()).expect("publish right");
            }
            let resend = Instant::now() + FRAME_TIMEOUT.min(Duration::from_secs(1));
            while Instant::now() < resend {
                self.poll_status();
                if self.status_count("judged") > judged {
                    return;
                }
                std::thread::sleep(Duration::from_millis(5));
            }
            assert!(
                Instant::now() < deadline,
                "the node judged no frame in 30 s"
            );
        }
    }

    fn trigger(&self, which: &str) -> TriggerResponse {
        let client = match which {
            "calibrate" => &self.calibrate,
            "commit" => &self.commit,
            _ => &self.reset,
        };
        assert!(
            wait_for_server(self.peer.node(), client, Duration::from_secs(10)),
            "no ~/{which} server"
        );
        call(client, &TriggerRequest::default(), Duration::from_secs(60))
            .expect("call")
            .unwrap_or_else(|| panic!("~/{which} did not answer"))
    }
}

impl Drop for Player {
    fn drop(&mut self) {
        self.camera_stop.store(true, Ordering::Relaxed);
        if let Some(camera) = self.camera.take() {
            let _ = camera.join();
        }
    }
}

fn yaml(dir: &Path, name: &str) -> PathBuf {
    dir.join(format!("{name}.yaml"))
}

/// Checks a written camera_info file against the camera's ground truth.
fn check_camera_file(dir: &Path, truth: &GroundTruth, index: usize) -> CameraInfoFile {
    let record = &truth.cameras[index];
    let file = CameraInfoFile::read(yaml(dir, &record.name)).expect("camera_info file");
    assert_eq!(file.camera_name, record.name);
    assert_eq!((file.info.width, file.info.height), (1024, 768));
    let expected = record.camera_model().expect("model").intrinsics;
    common::assert_intrinsics_near(
        &record.name,
        &common::intrinsics_from_k(&file.info.k),
        &expected,
    );
    // R rotates into the rectified frame; P projects with the rectified focal length.
    assert_ne!(file.info.r, [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0]);
    let det = {
        let r = file.info.r;
        r[0] * (r[4] * r[8] - r[5] * r[7]) - r[1] * (r[3] * r[8] - r[5] * r[6])
            + r[2] * (r[3] * r[7] - r[4] * r[6])
    };
    assert!((det - 1.0).abs() < 1e-9, "R is a rotation: det {det}");
    assert!(file.info.p[0] > 0.0 && file.info.p[5] > 0.0 && file.info.p[10] == 1.0);
    file
}

#[test]
fn a_replayed_stereo_session_calibrates_and_commits_camera_info_near_the_truth() {
    let session = session();
    let dir = tempfile::tempdir().expect("temp dir");
    let domain = DomainLease::for_test().expect("a ROS domain");
    let mut player = Player::new(&domain, Rig::Stereo);
    let node = start_node(&domain, dir.path(), Rig::Stereo, &[]);
    player.wait_for_node();
    assert_eq!(player.status_count("samples"), 0);

    let replay = Instant::now();
    for pair in &session.pairs {
        player.send_pair(pair);
    }
    let per_pair = replay.elapsed() / 40;
    let samples = player.status_count("samples");
    assert_eq!(
        player.status_count("received"),
        40,
        "{}",
        player.last_status
    );
    assert_eq!(player.status_count("dropped"), 0, "{}", player.last_status);
    let annotated = player.annotated_images();
    assert!(!annotated.is_empty(), "no annotated image");
    for image in &annotated {
        assert_eq!(
            (image.encoding.as_str(), image.width, image.height),
            ("rgb8", 1024, 768)
        );
    }
    assert!(
        player.last_status["ready"].as_bool() == Some(true),
        "{}",
        player.last_status
    );
    assert!(samples >= 20, "{samples} samples kept of 40 frames");
    assert!(
        samples < 40,
        "the bad frames were refused: {samples} samples"
    );

    let calibrated = player.trigger("calibrate");
    assert!(calibrated.success, "{}", calibrated.message);
    println!(
        "{samples} samples of 40 pairs, {per_pair:?} per pair sent and judged; {}",
        calibrated.message
    );
    for part in ["left: RMS", "right: RMS", "epipolar RMS"] {
        assert!(calibrated.message.contains(part), "{}", calibrated.message);
    }

    let committed = player.trigger("commit");
    let node_logs = node.terminate().logs;
    assert!(committed.success, "{}\n{node_logs}", committed.message);
    assert!(
        committed
            .message
            .contains("acknowledged by /stereo/left/set_camera_info"),
        "{}",
        committed.message
    );
    assert!(
        committed
            .message
            .contains("no /stereo/right/set_camera_info server answered"),
        "{}",
        committed.message
    );
    let left = check_camera_file(dir.path(), &session.truth, 0);
    let right = check_camera_file(dir.path(), &session.truth, 1);
    // The pair shares its rectified rows: same fy and cy in both P.
    assert_eq!(left.info.p[5], right.info.p[5]);
    assert_eq!(left.info.p[6], right.info.p[6]);

    let received = player.camera_info_received.lock().expect("lock").clone();
    assert_eq!(
        received.len(),
        1,
        "the fake left camera got one camera_info"
    );
    assert_eq!(received[0].k, left.info.k);
    assert_eq!(received[0].d, left.info.d);
    assert_eq!(received[0].r, left.info.r);
    assert_eq!(received[0].p, left.info.p);
    assert_eq!(received[0].distortion_model, left.info.distortion_model);
}

#[test]
fn samples_survive_a_killed_node() {
    let session = session();
    let dir = tempfile::tempdir().expect("temp dir");
    let domain = DomainLease::for_test().expect("a ROS domain");
    let mut player = Player::new(&domain, Rig::Stereo);
    let node = start_node(&domain, dir.path(), Rig::Stereo, &[]);
    player.wait_for_node();

    let mut sent = 0;
    while player.status_count("samples") < 5 {
        player.send_pair(&session.pairs[sent]);
        sent += 1;
    }
    let kept = player.status_count("samples");
    let logs = node.kill();
    assert!(logs.contains("sample added"), "{logs}");

    // The restarted node reports the samples it found in state_dir before any frame.
    // It pairs frames within 10 ms (ApproximateTime), as the rest of the session comes
    // from cameras whose stamps differ by 4 ms.
    player.poll_status();
    let node = start_node(&domain, dir.path(), Rig::Stereo, &["slop:=0.01"]);
    player.wait_for_node();
    assert_eq!(
        player.status_count("samples"),
        kept,
        "{}",
        player.last_status
    );
    assert_eq!(player.status_count("judged"), 0);
    let early = player.trigger("calibrate");
    assert!(!early.success);
    assert!(
        early.message.contains("not enough samples to calibrate"),
        "{}",
        early.message
    );
    let early_commit = player.trigger("commit");
    assert!(!early_commit.success);
    assert!(
        early_commit.message.contains("call ~/calibrate first"),
        "{}",
        early_commit.message
    );

    for pair in &session.pairs[sent..] {
        player.send_skewed_pair(pair, 4_000_000);
    }
    assert!(player.status_count("samples") > kept);
    assert_eq!(
        player.status_count("judged") as usize,
        session.pairs.len() - sent,
        "every skewed pair paired: {}",
        player.last_status
    );
    let calibrated = player.trigger("calibrate");
    assert!(calibrated.success, "{}", calibrated.message);

    // Reset forgets the samples, here and in the store.
    let reset = player.trigger("reset");
    assert!(reset.success, "{}", reset.message);
    let deadline = Instant::now() + Duration::from_secs(5);
    while player.status_count("samples") > 0 && Instant::now() < deadline {
        player.poll_status();
        std::thread::sleep(Duration::from_millis(10));
    }
    assert_eq!(player.status_count("samples"), 0, "{}", player.last_status);
    assert!(player.last_status["calibration"].is_null());
    let logs = node.terminate().logs;
    let node = start_node(&domain, dir.path(), Rig::Stereo, &[]);
    player.wait_for_node();
    assert_eq!(
        player.status_count("samples"),
        0,
        "{}\n{logs}",
        player.last_status
    );
    drop(node);
}

#[test]
fn a_mono_node_calibrates_by_itself_once_coverage_is_ready() {
    let session = long_session();
    let dir = tempfile::tempdir().expect("temp dir");
    let domain = DomainLease::for_test().expect("a ROS domain");
    let mut player = Player::new(&domain, Rig::MonoAuto);
    let node = start_node(&domain, dir.path(), Rig::MonoAuto, &[]);
    player.wait_for_node();
    for pair in &session.pairs {
        player.send_pair(pair);
        if !player.last_status["calibration"].is_null() {
            break;
        }
    }
    let calibration = player.last_status["calibration"].clone();
    assert!(
        player.last_status["ready"].as_bool() == Some(true),
        "{}",
        player.last_status
    );
    // The calibration is keyed by camera name, as `stereocal calibrate --json` prints it.
    let camera = &calibration["cameras"]["left"];
    assert!(camera.is_object(), "{calibration}");
    assert_eq!(calibration["cameras"].as_object().map(|c| c.len()), Some(1));
    assert!(calibration.get("stereo").is_none(), "{calibration}");
    let expected = session.truth.cameras[0]
        .camera_model()
        .expect("model")
        .intrinsics;
    let k: Vec<f64> = serde_json::from_value(camera["k"].clone()).expect("k");
    common::assert_intrinsics_near("left", &common::intrinsics_from_k(&k), &expected);

    let committed = player.trigger("commit");
    let logs = node.terminate().logs;
    assert!(committed.success, "{}\n{logs}", committed.message);
    assert!(
        committed
            .message
            .contains("acknowledged by /camera/set_camera_info"),
        "{}",
        committed.message
    );
    let file = CameraInfoFile::read(yaml(dir.path(), "left")).expect("left.yaml");
    assert_eq!(file.info.k.to_vec(), k);
    // A mono camera: R = I and P = [K | 0].
    assert_eq!(file.info.r, [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0]);
    assert_eq!(
        player.camera_info_received.lock().expect("lock")[0].k,
        file.info.k
    );
    assert!(logs.contains("coverage is ready: calibrating"), "{logs}");
}

/// Frames of the sim-time replays: enough for samples to be added and refused.
const SIM_TIME_FRAMES: usize = 12;

/// The node's verdict and reason on each of the first [`SIM_TIME_FRAMES`] pairs,
/// replayed with `use_sim_time` and `/clock` at `rate` times the recorded speed (a
/// frame is not sent before the previous one was judged).
fn sim_time_verdicts(rate: f64) -> Vec<(String, String)> {
    let domain = DomainLease::for_test().expect("a ROS domain");
    let dir = tempfile::tempdir().expect("temp dir");
    let node = start_node(
        &domain,
        dir.path(),
        Rig::Stereo,
        &["use_sim_time:=true", "max_board_speed:=600"],
    );
    let mut player = Player::new(&domain, Rig::Stereo);
    player.wait_for_node();
    let pairs = &session().pairs[..SIM_TIME_FRAMES];
    let first = pairs[0].0.header.stamp;
    let start = Instant::now();
    let mut verdicts = Vec::new();
    for pair in pairs {
        let stamp = pair.0.header.stamp;
        // Pacing, not synchronization: send_pair waits for the node's verdict.
        let due = start + Duration::from_secs_f64(stamp.seconds_since(&first) / rate);
        if let Some(wait) = due.checked_duration_since(Instant::now()) {
            std::thread::sleep(wait);
        }
        player
            .clock
            .publish(Clock { clock: stamp })
            .expect("publish /clock");
        player.send_pair(pair);
        verdicts.push((
            player.last_status["verdict"].to_string(),
            player.last_status["reason"].to_string(),
        ));
    }
    let exit = node.terminate();
    assert!(
        exit.clean(),
        "calibrate_node failed on SIGTERM:\n{}",
        exit.logs
    );
    assert!(
        exit.logs.contains("clock from /clock"),
        "use_sim_time not in force:\n{}",
        exit.logs
    );
    verdicts
}

#[test]
fn with_sim_time_the_replay_speed_changes_no_verdict() {
    let fast = sim_time_verdicts(2.0);
    let slow = sim_time_verdicts(0.5);
    eprintln!("verdicts at 2x: {fast:?}");
    assert_eq!(fast, slow, "verdicts at 2x and at 0.5x differ");
    assert!(
        fast.iter().any(|(verdict, _)| verdict == "\"added\""),
        "{fast:?}"
    );
    assert!(
        fast.iter()
            .any(|(_, reason)| reason.contains("board moving")),
        "no frame was refused for motion: {fast:?}"
    );
}

#[test]
fn a_clock_going_back_is_warned_about_and_the_node_goes_on() {
    let domain = DomainLease::for_test().expect("a ROS domain");
    let dir = tempfile::tempdir().expect("temp dir");
    let node = start_node(&domain, dir.path(), Rig::Stereo, &["use_sim_time:=true"]);
    let mut player = Player::new(&domain, Rig::Stereo);
    player.wait_for_node();
    let pairs = &session().pairs;
    let late = pairs[5].0.header.stamp;
    let early = pairs[0].0.header.stamp;
    player
        .clock
        .publish(Clock { clock: late })
        .expect("publish /clock");
    player.send_pair(&pairs[5]);
    // /clock is best-effort: jump back again until the node has seen a jump.
    let deadline = Instant::now() + Duration::from_secs(30);
    while !node.logs().contains("/clock went back") {
        assert!(
            Instant::now() < deadline,
            "no warning about /clock going back:\n{}",
            node.logs()
        );
        player
            .clock
            .publish(Clock { clock: late })
            .expect("publish /clock");
        player
            .clock
            .publish(Clock { clock: early })
            .expect("publish /clock");
        std::thread::sleep(Duration::from_millis(50));
    }
    let judged = player.status_count("judged");
    player.send_pair(&pairs[1]);
    assert!(player.status_count("judged") > judged);
    let exit = node.terminate();
    assert!(
        exit.clean(),
        "calibrate_node failed on SIGTERM:\n{}",
        exit.logs
    );
    assert!(!exit.logs.contains("panicked"), "{}", exit.logs);
}
