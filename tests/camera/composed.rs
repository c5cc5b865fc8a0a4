//! camera_node in a composition: the test pattern captured and rectified in one
//! process (`stereocal node compose`), camera_node's images reaching rectify_node by
//! reference, the rectified images outside over DDS equal to the rectify stage applied
//! to camera_node's image and calibration of the same stamp.

use std::process::Command;
use std::time::{Duration, Instant};

use stereocal::rectify::stage::{Rectified, Rectifier};
use stereocal_msgs::CameraInfoFile;
use stereocal_msgs::sensor_msgs::{CameraInfo, Image};
use stereocal_runtime::qos;
use stereocal_runtime::testing::{DomainLease, NodeProcess};
use stereocal_vision::rectify::RemapOptions;

use super::node::calibration;
use crate::common;

const TIMEOUT: Duration = Duration::from_secs(60);

#[test]
fn a_composed_camera_and_rectify_node_rectify_the_test_pattern() {
    let domain = DomainLease::for_test().expect("a ROS domain");
    let dir = tempfile::tempdir().expect("temp dir");
    let info = CameraInfo {
        d: vec![-0.25, 0.08, 0.001, -0.0005, 0.0],
        ..calibration(320, 240)
    };
    CameraInfoFile {
        camera_name: "cam".into(),
        info: info.clone(),
    }
    .write(dir.path().join("cam.yaml"))
    .expect("calibration file");
    let composition = dir.path().join("composition.yaml");
    std::fs::write(
        &composition,
        format!(
            "nodes:\n  - node: camera\n    args: [-r, __ns:=/cam, -p, video_device:=test_pattern, \
             -p, image_width:=320, -p, image_height:=240, -p, framerate:=10.0, \
             -p, camera_name:=cam, -p, \"camera_info_url:=file://{}/${{NAME}}.yaml\"]\n  \
             - node: rectify\n    args: [-r, __ns:=/cam, -r, image:=image_raw]\n",
            dir.path().display()
        ),
    )
    .expect("composition file");
    let mut command = Command::new(env!("CARGO_BIN_EXE_stereocal"));
    command.args(["node", "compose"]).arg(&composition);
    let process = NodeProcess::spawn(command, domain.id()).expect("composition starts");
    let mut peer = common::test_node(&domain, "composed_camera");
    let raw = peer
        .subscription::<Image>("/cam/image_raw", qos::reliable(30))
        .expect("image_raw");
    let rect = peer
        .subscription::<Image>("/cam/image_rect", qos::reliable(30))
        .expect("image_rect");
    let deadline = Instant::now() + TIMEOUT;
    let mut raws = Vec::new();
    let (image, rectified) = 'found: loop {
        assert!(
            Instant::now() < deadline,
            "no image_rect with its image_raw in {TIMEOUT:?}:\n{}",
            process.logs()
        );
        while let Ok(Some((image, _))) = raw.take() {
            raws.push(image);
        }
        while let Ok(Some((rectified, _))) = rect.take() {
            if let Some(image) = raws
                .iter()
                .find(|i| i.header.stamp == rectified.header.stamp)
            {
                break 'found (image.clone(), rectified);
            }
        }
        std::thread::sleep(Duration::from_millis(10));
    };
    let with_header = CameraInfo {
        header: image.header.clone(),
        ..info
    };
    let expected = match Rectifier::new(RemapOptions::default()).rectify(&image, &with_header) {
        Ok(Rectified::Image(expected)) => expected,
        other => panic!("the stage did not rectify: {other:?}"),
    };
    assert_eq!(rectified.header, image.header);
    assert_eq!(
        (
            rectified.encoding.as_str(),
            rectified.width,
            rectified.height
        ),
        ("rgb8", 320, 240)
    );
    assert!(
        rectified.data == expected.data,
        "image_rect differs from the stage's rectification of image_raw"
    );
    assert!(rectified.data != image.data, "the image was rectified");
    let exit = process.terminate();
    assert!(exit.clean(), "{}", exit.logs);
}
