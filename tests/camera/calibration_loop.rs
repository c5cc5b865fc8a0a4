//! The calibration loop end to end over DDS: a synthetic calibration session replayed
//! into `calibrate_node`, whose `~/commit` calls `set_camera_info` of a `camera_node`
//! (on its test pattern, of the session's size) in the same namespace; the camera node
//! writes the calibration to its own camera_info_url and publishes it on `camera_info`
//! from the next frame on.

use std::process::Command;
use std::time::{Duration, Instant};

use ros2_client::Publisher;
use ros2_client::qos::Durability;
use stereocal_msgs::CameraInfoFile;
use stereocal_msgs::sensor_msgs::Image;
use stereocal_msgs::std_msgs;
use stereocal_msgs::std_srvs::srv::{TriggerRequest, TriggerResponse};
use stereocal_rosbag::{BagReader, TopicFilter};
use stereocal_runtime::qos;
use stereocal_runtime::service::{ServiceClient, call, create_client, wait_for_server};
use stereocal_runtime::testing::{DomainLease, NodeProcess};

use super::node::{CameraPeer, start_camera};
use crate::common;

const TIMEOUT: Duration = Duration::from_secs(60);

/// The left images of a 70-frame synthetic stereo calibration session (1024x768): the
/// coverage one camera alone needs.
fn session_images(dir: &std::path::Path) -> Vec<Image> {
    common::synthesize_session(&common::calibration_scene(dir, 5, 70), None);
    let reader = BagReader::open(dir.join("bag")).expect("bag");
    reader
        .messages(&TopicFilter::only(["/stereo/left/image_raw"]))
        .map(|m| m.expect("message").decode::<Image>().expect("image"))
        .collect()
}

fn start_calibrate(domain: &DomainLease, dir: &std::path::Path) -> NodeProcess {
    let mut command = Command::new(env!("CARGO_BIN_EXE_calibrate_node"));
    command
        .args([
            "--ros-args",
            "-r",
            "__ns:=/camera",
            "-r",
            "image:=session/image_raw",
            "-p",
            "size:=9x6",
            "-p",
            "square:=0.025",
            "-p",
            "camera_name:=left",
        ])
        .arg("-p")
        .arg(format!("state_dir:={}", dir.join("state").display()))
        .arg("-p")
        .arg(format!(
            "camera_info_url:=file://{}/${{NAME}}.yaml",
            dir.display()
        ))
        .env("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST");
    NodeProcess::spawn(command, domain.id()).expect("calibrate_node starts")
}

struct Calibrator {
    images: Publisher<Image>,
    status: ros2_client::Subscription<std_msgs::String>,
    calibrate: ServiceClient<TriggerRequest, TriggerResponse>,
    commit: ServiceClient<TriggerRequest, TriggerResponse>,
    last_status: serde_json::Value,
}

impl Calibrator {
    fn judged(&mut self) -> u64 {
        while let Ok(Some((message, _))) = self.status.take() {
            self.last_status = serde_json::from_str(&message.data).expect("JSON");
        }
        self.last_status["frames"]["judged"].as_u64().unwrap_or(0)
    }

    /// Publishes `image` until the node has judged it (frames are sent again while
    /// the node's reader has not matched the publisher yet).
    fn send(&mut self, image: &Image) {
        let judged = self.judged();
        let deadline = Instant::now() + TIMEOUT;
        loop {
            self.images.publish(image.clone()).expect("publish");
            let resend = Instant::now() + Duration::from_secs(1);
            while Instant::now() < resend {
                if self.judged() > judged {
                    return;
                }
                std::thread::sleep(Duration::from_millis(5));
            }
            assert!(Instant::now() < deadline, "no frame judged in {TIMEOUT:?}");
        }
    }
}

fn trigger(
    camera: &CameraPeer,
    client: &ServiceClient<TriggerRequest, TriggerResponse>,
) -> TriggerResponse {
    assert!(wait_for_server(camera.peer.node(), client, TIMEOUT));
    call(client, &TriggerRequest::default(), TIMEOUT)
        .expect("call")
        .expect("answered")
}

#[test]
fn calibrate_node_commits_into_camera_node_which_writes_and_publishes_the_calibration() {
    let session_dir = tempfile::tempdir().expect("temp dir");
    let images = session_images(session_dir.path());
    let (width, height) = (images[0].width, images[0].height);
    let domain = DomainLease::for_test().expect("a ROS domain");
    let camera_dir = tempfile::tempdir().expect("temp dir");
    let calibrate_dir = tempfile::tempdir().expect("temp dir");
    let mut camera = CameraPeer::new(&domain, "/camera");
    let camera_node = start_camera(
        &domain,
        "/camera",
        &[
            "video_device:=test_pattern".into(),
            format!("image_width:={width}"),
            format!("image_height:={height}"),
            "framerate:=5.0".into(),
            "output_encoding:=mono8".into(),
            "camera_name:=left".into(),
            format!(
                "camera_info_url:=file://{}/${{NAME}}.yaml",
                camera_dir.path().display()
            ),
        ],
    );
    let calibrate_node = start_calibrate(&domain, calibrate_dir.path());
    let node = camera.peer.node_mut();
    let calibrate = create_client(node, "/camera/calibrate_node/calibrate").expect("client");
    let commit = create_client(node, "/camera/calibrate_node/commit").expect("client");
    let mut calibrator = Calibrator {
        images: camera
            .peer
            .publisher("/camera/session/image_raw", qos::reliable(10))
            .expect("publisher"),
        status: camera
            .peer
            .subscription(
                "/camera/calibrate_node/status",
                qos::reliable(10).durability(Durability::TransientLocal),
            )
            .expect("status"),
        calibrate,
        commit,
        last_status: serde_json::Value::Null,
    };
    camera.wait_for_status("streaming", |s| s["state"]["state"] == "streaming");
    for image in &images {
        calibrator.send(image);
    }
    let calibrated = trigger(&camera, &calibrator.calibrate);
    assert!(calibrated.success, "{}", calibrated.message);

    // ~/commit calls set_camera_info once, without waiting for discovery: commit again
    // until the camera node's server has matched calibrate_node's client.
    let deadline = Instant::now() + TIMEOUT;
    let committed = loop {
        let committed = trigger(&camera, &calibrator.commit);
        assert!(committed.success, "{}", committed.message);
        if committed
            .message
            .contains("acknowledged by /camera/set_camera_info")
        {
            break committed;
        }
        assert!(
            Instant::now() < deadline,
            "camera_node never acknowledged: {}",
            committed.message
        );
        std::thread::sleep(Duration::from_millis(200));
    };
    let written = CameraInfoFile::read(camera_dir.path().join("left.yaml"))
        .expect("camera_node wrote its camera_info_url");
    let committed_file = CameraInfoFile::read(calibrate_dir.path().join("left.yaml"))
        .expect("calibrate_node's own copy");
    assert_eq!(written.camera_name, "left");
    assert_eq!(
        written.info.k, committed_file.info.k,
        "{}",
        committed.message
    );
    assert_eq!(written.info.d, committed_file.info.d);
    assert_eq!((written.info.width, written.info.height), (width, height));
    let published = camera.wait_for_camera_info(|info| info.k == written.info.k);
    assert_eq!(published.p, written.info.p);

    let calibrate_exit = calibrate_node.terminate();
    let camera_exit = camera_node.terminate();
    assert!(camera_exit.clean(), "{}", camera_exit.logs);
    assert!(calibrate_exit.clean(), "{}", calibrate_exit.logs);
}
