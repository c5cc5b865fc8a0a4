//! Over DDS on loopback: the built `camera_node` on its test pattern (CI has no video
//! device) publishes stamped `image_raw` and `camera_info`, stores a calibration sent
//! to `set_camera_info` on disk before it answers and publishes it from then on; with a
//! device that does not exist it keeps running, says why on `~/status`, and refuses a
//! calibration it cannot write, with the reason.

use std::path::Path;
use std::process::Command;
use std::time::{Duration, Instant};

use ros2_client::Subscription;
use ros2_client::qos::Durability;
use stereocal_msgs::CameraInfoFile;
use stereocal_msgs::sensor_msgs::srv::{SetCameraInfoRequest, SetCameraInfoResponse};
use stereocal_msgs::sensor_msgs::{CameraInfo, Image};
use stereocal_msgs::std_msgs;
use stereocal_runtime::qos;
use stereocal_runtime::service::{ServiceClient, call, create_client, wait_for_server};
use stereocal_runtime::testing::{DomainLease, NodeProcess, PeerNode};

use crate::common;

/// Longest wait for discovery, a frame or a reply: a deadline on progress, long enough
/// for a node started on a machine busy with other builds and tests.
const TIMEOUT: Duration = Duration::from_secs(60);

/// Starts `camera_node` in namespace `/cam` on `domain` with `-p` parameters.
pub fn start_camera(domain: &DomainLease, namespace: &str, params: &[String]) -> NodeProcess {
    let mut command = Command::new(env!("CARGO_BIN_EXE_camera_node"));
    command
        .args(["--ros-args", "-r", &format!("__ns:={namespace}")])
        .env("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST");
    for param in params {
        command.args(["-p", param]);
    }
    NodeProcess::spawn(command, domain.id()).expect("camera_node starts")
}

/// The calibration a calibrator would send for a `width` x `height` camera.
pub fn calibration(width: u32, height: u32) -> CameraInfo {
    let (w, h) = (f64::from(width), f64::from(height));
    CameraInfo {
        width,
        height,
        distortion_model: "plumb_bob".into(),
        d: vec![-0.21, 0.07, 0.0012, -0.0008, 0.0],
        k: [
            0.8 * w,
            0.0,
            w / 2.0 - 0.5,
            0.0,
            0.8 * w,
            h / 2.0 - 0.5,
            0.0,
            0.0,
            1.0,
        ],
        r: [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0],
        p: [
            0.8 * w,
            0.0,
            w / 2.0 - 0.5,
            0.0,
            0.0,
            0.8 * w,
            h / 2.0 - 0.5,
            0.0,
            0.0,
            0.0,
            1.0,
            0.0,
        ],
        ..CameraInfo::default()
    }
}

/// The test's side of a camera node in `namespace`.
pub struct CameraPeer {
    pub images: Subscription<Image>,
    pub infos: Subscription<CameraInfo>,
    pub status: Subscription<std_msgs::String>,
    pub set_camera_info: ServiceClient<SetCameraInfoRequest, SetCameraInfoResponse>,
    pub last_status: serde_json::Value,
    pub peer: PeerNode,
}

impl CameraPeer {
    pub fn new(domain: &DomainLease, namespace: &str) -> Self {
        let mut peer = common::test_node(domain, "camera_peer");
        let images = peer
            .subscription::<Image>(&format!("{namespace}/image_raw"), qos::reliable(20))
            .expect("image_raw");
        let infos = peer
            .subscription::<CameraInfo>(&format!("{namespace}/camera_info"), qos::reliable(20))
            .expect("camera_info");
        let status = peer
            .subscription::<std_msgs::String>(
                &format!("{namespace}/camera_node/status"),
                qos::reliable(10).durability(Durability::TransientLocal),
            )
            .expect("status");
        let set_camera_info =
            create_client(peer.node_mut(), &format!("{namespace}/set_camera_info"))
                .expect("client");
        CameraPeer {
            images,
            infos,
            status,
            set_camera_info,
            last_status: serde_json::Value::Null,
            peer,
        }
    }

    /// Waits until the status satisfies `done`, at most [`TIMEOUT`].
    pub fn wait_for_status(&mut self, what: &str, done: impl Fn(&serde_json::Value) -> bool) {
        let deadline = Instant::now() + TIMEOUT;
        loop {
            while let Ok(Some((message, _))) = self.status.take() {
                self.last_status = serde_json::from_str(&message.data).expect("status is JSON");
            }
            if done(&self.last_status) {
                return;
            }
            assert!(
                Instant::now() < deadline,
                "{what}: not in {TIMEOUT:?}; last status {}",
                self.last_status
            );
            std::thread::sleep(Duration::from_millis(20));
        }
    }

    /// Sends `info` to `set_camera_info` and returns the answer.
    pub fn set_camera_info(&self, info: CameraInfo) -> SetCameraInfoResponse {
        assert!(
            wait_for_server(self.peer.node(), &self.set_camera_info, TIMEOUT),
            "no set_camera_info server"
        );
        call(
            &self.set_camera_info,
            &SetCameraInfoRequest { camera_info: info },
            TIMEOUT,
        )
        .expect("call")
        .expect("set_camera_info answered")
    }

    /// Waits for a camera_info that `wanted` accepts.
    pub fn wait_for_camera_info(&self, wanted: impl Fn(&CameraInfo) -> bool) -> CameraInfo {
        let deadline = Instant::now() + TIMEOUT;
        loop {
            while let Ok(Some((info, _))) = self.infos.take() {
                if wanted(&info) {
                    return info;
                }
            }
            assert!(
                Instant::now() < deadline,
                "no such camera_info in {TIMEOUT:?}"
            );
            std::thread::sleep(Duration::from_millis(10));
        }
    }
}

fn url(dir: &Path, file: &str) -> String {
    format!("file://{}/{file}", dir.display())
}

#[test]
fn the_test_pattern_publishes_stamped_frames_and_set_camera_info_stores_a_calibration() {
    let domain = DomainLease::for_test().expect("a ROS domain");
    let dir = tempfile::tempdir().expect("temp dir");
    let mut camera = CameraPeer::new(&domain, "/cam");
    let process = start_camera(
        &domain,
        "/cam",
        &[
            "video_device:=test_pattern".into(),
            "image_width:=320".into(),
            "image_height:=240".into(),
            "framerate:=15.0".into(),
            "frame_id:=left_optical".into(),
            "camera_name:=left".into(),
            format!("camera_info_url:={}", url(dir.path(), "cal/${NAME}.yaml")),
        ],
    );
    camera.wait_for_status("streaming", |s| s["state"]["state"] == "streaming");

    let deadline = Instant::now() + TIMEOUT;
    let mut images = Vec::new();
    while images.len() < 5 {
        assert!(
            Instant::now() < deadline,
            "{} images in {TIMEOUT:?}",
            images.len()
        );
        while let Ok(Some((image, _))) = camera.images.take() {
            images.push(image);
        }
        std::thread::sleep(Duration::from_millis(10));
    }
    let wall = stereocal_runtime::clock::NodeClock::System.now();
    for image in &images {
        assert_eq!(
            (
                image.encoding.as_str(),
                image.width,
                image.height,
                image.step
            ),
            ("rgb8", 320, 240, 960)
        );
        assert_eq!(image.header.frame_id, "left_optical");
        let age = wall.seconds_since(&image.header.stamp);
        assert!(
            (0.0..TIMEOUT.as_secs_f64()).contains(&age),
            "stamp {age} s old"
        );
    }
    assert!(
        images
            .windows(2)
            .all(|w| w[1].header.stamp > w[0].header.stamp),
        "stamps increase"
    );
    let last_stamp = images.last().map(|i| i.header.stamp).expect("an image");
    let uncalibrated = camera.wait_for_camera_info(|info| info.header.stamp == last_stamp);
    assert_eq!((uncalibrated.width, uncalibrated.height), (320, 240));
    assert_eq!(uncalibrated.k, [0.0; 9], "no calibration yet");
    assert_eq!(camera.last_status["camera_info"]["calibrated"], false);

    let answer = camera.set_camera_info(calibration(320, 240));
    assert!(answer.success, "{}", answer.status_message);
    let path = dir.path().join("cal/left.yaml");
    assert!(
        answer.status_message.contains(&path.display().to_string()),
        "{}",
        answer.status_message
    );
    // The file is on disk when the answer comes.
    let file = CameraInfoFile::read(&path).expect("written before the answer");
    assert_eq!(file.camera_name, "left");
    assert_eq!(file.info.k, calibration(320, 240).k);
    let calibrated = camera.wait_for_camera_info(|info| info.k == calibration(320, 240).k);
    assert_eq!(calibrated.d, calibration(320, 240).d);
    assert_eq!(calibrated.header.frame_id, "left_optical");
    camera.wait_for_status("calibrated", |s| s["camera_info"]["calibrated"] == true);
    // At least the five images received above.
    assert!(camera.last_status["frames"]["captured"].as_u64() >= Some(5));
    assert_eq!(camera.last_status["frames"]["bad_frames"], 0);

    let exit = process.terminate();
    assert!(
        exit.clean(),
        "camera_node failed on SIGTERM:\n{}",
        exit.logs
    );
    assert!(
        exit.logs
            .contains("set_camera_info: calibration written to"),
        "{}",
        exit.logs
    );
}

#[test]
fn a_missing_device_keeps_the_node_running_and_an_unwritable_url_is_refused() {
    let domain = DomainLease::for_test().expect("a ROS domain");
    let dir = tempfile::tempdir().expect("temp dir");
    std::fs::write(dir.path().join("blocked"), "a file, not a directory").expect("write");
    let mut camera = CameraPeer::new(&domain, "/cam");
    let process = start_camera(
        &domain,
        "/cam",
        &[
            "video_device:=/dev/stereocal-no-such-camera".into(),
            format!(
                "camera_info_url:={}",
                url(dir.path(), "blocked/${NAME}.yaml")
            ),
        ],
    );
    // Two attempts at least: the back-off doubled, and the node is still there.
    camera.wait_for_status("waiting after a second attempt", |s| {
        s["state"]["state"] == "waiting" && s["state"]["retry_in_s"].as_f64() >= Some(1.0)
    });
    let reason = camera.last_status["state"]["reason"].to_string();
    assert!(
        reason.contains("cannot open /dev/stereocal-no-such-camera: No such file or directory"),
        "{reason}"
    );
    let refused = camera.set_camera_info(calibration(640, 480));
    assert!(!refused.success);
    assert!(
        refused.status_message.contains("calibration not stored")
            && refused.status_message.contains("blocked/camera.yaml"),
        "{}",
        refused.status_message
    );
    let exit = process.terminate();
    assert!(
        exit.clean(),
        "camera_node failed on SIGTERM:\n{}",
        exit.logs
    );
    assert!(exit.logs.contains("trying again in"), "{}", exit.logs);
    assert!(!exit.logs.contains("panicked"), "{}", exit.logs);
}

#[test]
fn a_stereo_pair_reports_the_stamp_differences_of_its_cameras() {
    let domain = DomainLease::for_test().expect("a ROS domain");
    let dir = tempfile::tempdir().expect("temp dir");
    let mut right = CameraPeer::new(&domain, "/stereo/right");
    let camera = |side: &str, partner: &str| {
        let mut params = vec![
            "video_device:=test_pattern".to_owned(),
            "image_width:=160".into(),
            "image_height:=120".into(),
            "framerate:=20.0".into(),
            format!("camera_name:={side}"),
            format!("camera_info_url:={}", url(dir.path(), "${NAME}.yaml")),
        ];
        if !partner.is_empty() {
            params.push(format!("stereo_partner:={partner}"));
        }
        start_camera(&domain, &format!("/stereo/{side}"), &params)
    };
    let left_node = camera("left", "");
    let right_node = camera("right", "/stereo/left/camera_info");
    right.wait_for_status("20 pairs matched", |s| {
        s["stereo_sync"]["pairs"].as_u64() >= Some(20)
    });
    let sync = &right.last_status["stereo_sync"];
    println!("stereo_sync: {sync}");
    assert_eq!(sync["partner"], "/stereo/left/camera_info");
    // Two free-running cameras at 20 fps: the nearest left frame of each right frame is
    // at most half a frame interval (25 ms) away, give or take scheduling: the median
    // holds to that, a frame captured late on a loaded machine may lie further.
    let median = sync["median_abs_ms"].as_f64().expect("a median");
    let max = sync["max_abs_ms"].as_f64().expect("a maximum");
    assert!(median <= 25.0 + 5.0, "median |difference| {median} ms");
    assert!(max >= median && max < 100.0, "max |difference| {max} ms");
    assert!(
        sync["last_ms"]
            .as_f64()
            .is_some_and(|last| last.abs() <= max)
    );
    for node in [right_node, left_node] {
        let exit = node.terminate();
        assert!(exit.clean(), "{}", exit.logs);
    }
}

#[test]
fn with_sim_time_frames_are_stamped_on_the_clock_topic() {
    use stereocal_msgs::builtin_interfaces::Time;
    use stereocal_msgs::rosgraph_msgs::Clock;

    let domain = DomainLease::for_test().expect("a ROS domain");
    let dir = tempfile::tempdir().expect("temp dir");
    let mut camera = CameraPeer::new(&domain, "/cam");
    let clock = camera
        .peer
        .publisher::<Clock>("/clock", qos::reliable(1))
        .expect("clock publisher");
    let process = start_camera(
        &domain,
        "/cam",
        &[
            "video_device:=test_pattern".into(),
            "image_width:=160".into(),
            "image_height:=120".into(),
            "use_sim_time:=true".into(),
            format!("camera_info_url:={}", url(dir.path(), "${NAME}.yaml")),
        ],
    );
    camera.wait_for_status("streaming", |s| s["state"]["state"] == "streaming");
    let sim = Time::from_nanos(1_000_000_000_000);
    // /clock is best-effort on the node's side: published until frames carry it.
    let deadline = Instant::now() + TIMEOUT;
    let stamped = loop {
        clock.publish(Clock { clock: sim }).expect("publish /clock");
        let mut found = None;
        while let Ok(Some((image, _))) = camera.images.take() {
            if image.header.stamp.sec >= 999 {
                found = Some(image.header.stamp);
            }
        }
        if let Some(stamp) = found {
            break stamp;
        }
        assert!(Instant::now() < deadline, "no frame on simulated time");
        std::thread::sleep(Duration::from_millis(20));
    };
    // The simulated clock stands at 1000 s: a frame is stamped with it less its age.
    let age = sim.seconds_since(&stamped);
    assert!(
        (0.0..1.0).contains(&age),
        "stamp {stamped:?}, {age} s before /clock"
    );
    let exit = process.terminate();
    assert!(exit.clean(), "{}", exit.logs);
    assert!(exit.logs.contains("clock from /clock"), "{}", exit.logs);
}
