//! `stereocal node compose`: the stereo rectify pair of
//! config/stereo_rectify_composition.yaml runs in one process, each node under its own
//! name and namespace and the parameters of the params file given on the command line,
//! rectifying its side of the bundled stereo bag exactly as the rectify stage does,
//! logging under its own logger name, and both stop on one SIGTERM. In a composition
//! where calibrate_node takes rectify_node's output, the frames reach it by reference
//! and never go over DDS while nothing outside subscribes them; once a reader outside
//! subscribes, DDS sends them to that reader only, not to calibrate_node as well. A
//! composition naming an unknown node is refused at start-up.

use std::path::Path;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use stereocal::cli::demo::BUNDLED_STEREO;
use stereocal::rectify::stage::{Rectified, Rectifier};
use stereocal_msgs::sensor_msgs::{CameraInfo, Image};
use stereocal_rosbag::{BagReader, TopicFilter};
use stereocal_runtime::qos;
use stereocal_runtime::testing::{DomainLease, NodeProcess};
use stereocal_vision::rectify::{Interpolation, RemapOptions};

use crate::common;

const SIDES: [&str; 2] = ["left", "right"];

fn root() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

/// The first image and camera_info of `side` in the bundled stereo bag.
fn first_frame(side: &str) -> (Image, CameraInfo) {
    let bag = BagReader::open(root().join(BUNDLED_STEREO).join("bag")).expect("bundled bag");
    let topics = [
        format!("/stereo/{side}/image_raw"),
        format!("/stereo/{side}/camera_info"),
    ];
    let (mut image, mut info) = (None, None);
    for message in bag.messages(&TopicFilter::only(topics.clone())) {
        let message = message.expect("bag message");
        if *message.topic == topics[0] {
            image.get_or_insert_with(|| message.decode::<Image>().expect("image"));
        } else {
            info.get_or_insert_with(|| message.decode::<CameraInfo>().expect("camera_info"));
        }
    }
    (image.expect("an image"), info.expect("a camera_info"))
}

#[test]
fn the_composed_stereo_pair_rectifies_both_sides_in_one_process() {
    let domain = DomainLease::for_test().expect("a ROS domain");
    // Nearest, not the default bilinear: the pixels show the params file reached both.
    let params = tempfile::NamedTempFile::new().expect("temp file");
    std::fs::write(
        params.path(),
        "/**/rectify_node:\n  ros__parameters:\n    interpolation: 0\n",
    )
    .expect("write params file");
    let mut command = Command::new(env!("CARGO_BIN_EXE_stereocal"));
    command
        .args(["node", "compose"])
        .arg(root().join("config/stereo_rectify_composition.yaml"))
        .args(["--ros-args", "--params-file"])
        .arg(params.path());
    let process = NodeProcess::spawn(command, domain.id()).expect("composition starts");
    let mut peer = common::test_node(&domain, "composition");
    let mut sides = Vec::new();
    for side in SIDES {
        let (image, info) = first_frame(side);
        let nearest = RemapOptions {
            interpolation: Interpolation::Nearest,
            ..RemapOptions::default()
        };
        let expected = match Rectifier::new(nearest).rectify(&image, &info) {
            Ok(Rectified::Image(rect)) => rect,
            other => panic!("the stage did not rectify {side}: {other:?}"),
        };
        let images = peer
            .publisher::<Image>(&format!("/stereo/{side}/image_raw"), qos::reliable(5))
            .expect("image publisher");
        let infos = peer
            .publisher::<CameraInfo>(&format!("/stereo/{side}/camera_info"), qos::reliable(5))
            .expect("camera_info publisher");
        let rectified = peer
            .subscription::<Image>(&format!("/stereo/{side}/image_rect"), qos::reliable(5))
            .expect("image_rect subscription");
        sides.push((image, info, expected, images, infos, rectified));
    }

    // The node's image subscription is best-effort: send again until each side's frame
    // has made the round trip.
    let deadline = Instant::now() + Duration::from_secs(60);
    for (side, (image, info, expected, images, infos, rectified)) in SIDES.iter().zip(&sides) {
        let got = loop {
            assert!(
                Instant::now() < deadline,
                "no {side} image_rect in 60 s:\n{}",
                process.logs()
            );
            infos.publish(info.clone()).expect("publish camera_info");
            images.publish(image.clone()).expect("publish image");
            let resend = Instant::now() + Duration::from_millis(500);
            let mut got = None;
            while got.is_none() && Instant::now() < resend {
                match rectified.take() {
                    Ok(Some((rect, _))) => got = Some(rect),
                    _ => std::thread::sleep(Duration::from_millis(10)),
                }
            }
            if let Some(rect) = got {
                break rect;
            }
        };
        assert_eq!(got.header, expected.header, "{side}");
        assert!(
            got.data == expected.data,
            "{side} pixels differ from the stage's"
        );
    }

    let exit = process.terminate();
    assert!(
        exit.clean(),
        "the composition failed on SIGTERM:\n{}",
        exit.logs
    );
    for side in SIDES {
        let logger = format!("[stereo.{side}.rectify_node]: ");
        assert!(
            exit.logs
                .lines()
                .any(|l| l.contains(&logger) && l.contains("shutting down: ")),
            "{side} node's shutdown not logged under its own name:\n{}",
            exit.logs
        );
    }
}

#[test]
fn a_composition_naming_an_unknown_node_is_refused_at_start_up() {
    let dir = tempfile::tempdir().expect("temp dir");
    let file = dir.path().join("composition.yaml");
    std::fs::write(&file, "nodes:\n  - node: rectify\n  - node: rektify\n").expect("write");
    let output = Command::new(env!("CARGO_BIN_EXE_stereocal"))
        .args(["node", "compose"])
        .arg(&file)
        .stdin(Stdio::null())
        .output()
        .expect("run stereocal node compose");
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(!output.status.success());
    assert!(
        stderr.contains("node 2 is \"rektify\": expected one of rectify, calibrate"),
        "{stderr}"
    );
    assert!(
        !stderr.contains("started"),
        "a node was started before the composition was checked:\n{stderr}"
    );
}

/// What the composition's nodes logged about their messages: rectify_node's shutdown
/// summary and calibrate_node's.
struct Summaries {
    rectify: String,
    calibrate: String,
}

/// Runs rectify_node and calibrate_node in one process, calibrate_node judging what
/// rectify_node publishes, until calibrate_node has judged three frames; with
/// `outside_reader`, a subscriber of this test's process also reads `image_rect` until
/// it has received one over DDS.
fn rectify_into_calibrate(outside_reader: bool) -> Summaries {
    let domain = DomainLease::for_test().expect("a ROS domain");
    let dir = tempfile::tempdir().expect("temp dir");
    let composition = dir.path().join("composition.yaml");
    std::fs::write(
        &composition,
        format!(
            "nodes:\n  - node: rectify\n    args: [-r, __ns:=/stereo/left, -r, image:=image_raw]\n  \
             - node: calibrate\n    args: [-r, __ns:=/inspect, -r, image:=/stereo/left/image_rect, \
             -p, size:=9x6, -p, square:=0.025, -p, 'state_dir:={}']\n",
            dir.path().join("state").display()
        ),
    )
    .expect("write composition");
    let mut command = Command::new(env!("CARGO_BIN_EXE_stereocal"));
    command.args(["node", "compose"]).arg(&composition);
    let process = NodeProcess::spawn(command, domain.id()).expect("composition starts");
    let mut peer = common::test_node(&domain, "in_process");
    let (image, info) = first_frame("left");
    let images = peer
        .publisher::<Image>("/stereo/left/image_raw", qos::reliable(5))
        .expect("image publisher");
    let infos = peer
        .publisher::<CameraInfo>("/stereo/left/camera_info", qos::reliable(5))
        .expect("camera_info publisher");
    let status = peer
        .subscription::<stereocal_msgs::std_msgs::String>(
            "/inspect/calibrate_node/status",
            qos::reliable(10).durability(ros2_client::qos::Durability::TransientLocal),
        )
        .expect("status subscription");
    let rectified = outside_reader.then(|| {
        peer.subscription::<Image>("/stereo/left/image_rect", qos::reliable(5))
            .expect("image_rect subscription")
    });

    const JUDGED: u64 = 3;
    let deadline = Instant::now() + Duration::from_secs(60);
    let mut judged = 0;
    let mut outside = 0;
    let mut sent = 0u32;
    while judged < JUDGED || (outside_reader && outside == 0) {
        assert!(
            Instant::now() < deadline,
            "in 60 s calibrate_node received {judged} rectified frames, the outside \
             subscriber {outside}:\n{}",
            process.logs()
        );
        let mut frame = image.clone();
        let mut frame_info = info.clone();
        sent += 1;
        frame.header.stamp.nanosec = sent;
        frame_info.header.stamp.nanosec = sent;
        infos.publish(frame_info).expect("publish camera_info");
        images.publish(frame).expect("publish image");
        let until = Instant::now() + Duration::from_millis(300);
        while Instant::now() < until {
            while let Ok(Some((message, _))) = status.take() {
                let value: serde_json::Value =
                    serde_json::from_str(&message.data).expect("status JSON");
                judged = value["frames"]["received"].as_u64().unwrap_or(0);
            }
            while let Some(Ok(Some(_))) = rectified.as_ref().map(|r| r.take()) {
                outside += 1;
            }
            std::thread::sleep(Duration::from_millis(10));
        }
    }
    let exit = process.terminate();
    assert!(
        exit.clean(),
        "the composition failed on SIGTERM:\n{}",
        exit.logs
    );
    let summary = |node: &str| {
        exit.logs
            .lines()
            .find(|l| l.contains(&format!("[{node}]: shutting down: ")))
            .unwrap_or_else(|| panic!("no {node} summary:\n{}", exit.logs))
            .to_owned()
    };
    let summaries = Summaries {
        rectify: summary("stereo.left.rectify_node"),
        calibrate: summary("inspect.calibrate_node"),
    };
    let published: u64 = summaries
        .rectify
        .split(" frame(s) received, ")
        .nth(1)
        .and_then(|rest| rest.split(' ').next())
        .and_then(|n| n.parse().ok())
        .unwrap_or_else(|| panic!("no published count in {}", summaries.rectify));
    assert!(published >= JUDGED, "{}", summaries.rectify);
    summaries
}

#[test]
fn a_rectified_frame_reaches_a_node_of_the_same_process_without_dds() {
    let summaries = rectify_into_calibrate(false);
    assert!(
        summaries.rectify.contains("published (0 over DDS)"),
        "image_rect went over DDS with no reader outside the process: {}",
        summaries.rectify
    );
}

#[test]
fn with_a_reader_outside_dds_sends_only_to_it() {
    let summaries = rectify_into_calibrate(true);
    assert!(
        !summaries.rectify.contains("published (0 over DDS)"),
        "image_rect never went over DDS to the outside reader: {}",
        summaries.rectify
    );
    assert!(
        summaries
            .calibrate
            .contains(", 0 of this process's own over DDS ignored"),
        "calibrate_node received rectify_node's frames over DDS as well: {}",
        summaries.calibrate
    );
}
