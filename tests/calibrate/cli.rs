//! `stereocal calibrate` on a synthetic stereo calibration session (1024x768, 25 frames,
//! about one in ten bad): the intrinsics and `right_from_left` against ground truth, the
//! bad frames left out and reported, the files it writes, its `--json` output; a mono
//! camera; warnings on a calibration that should not be trusted; and clear errors for a
//! missing topic, a wrong board size and too few views.

use crate::common;

use std::path::Path;
use std::process::Command;

use indicatif::ProgressBar;
use nalgebra::{Point2, Point3};
use stereocal::calibrate::stage::{
    CalibrationStageError, CameraFrames, Frame, FrameCorners, calibrate_camera,
};
use stereocal::cli::calibrate::calibrate_bag;
use stereocal_msgs::builtin_interfaces::Time;
use stereocal_msgs::camera_info_file::CameraInfoFile;
use stereocal_vision::calib::{CalibError, View};
use stereocal_vision::camera::DistortionModel;
use stereocal_vision::synth::{FrameKind, GroundTruth};

/// Synthesizes a calibration session of `frames` frames into `dir`.
fn synthesize(dir: &Path, frames: usize) -> GroundTruth {
    common::synthesize_session(&common::calibration_scene(dir, 1, frames), None)
}

fn stamp(frame: &stereocal_vision::synth::FrameRecord) -> Time {
    Time {
        sec: frame.stamp.sec,
        nanosec: frame.stamp.nanosec,
    }
}

#[test]
fn stereo_session_matches_ground_truth_and_reports_bad_frames() {
    let dir = tempfile::tempdir().unwrap();
    let truth = synthesize(dir.path(), 25);
    let out = dir.path().join("calibration");
    let report = calibrate_bag(
        &common::calibrate_args(dir.path().join("bag"), out.clone(), &truth),
        &ProgressBar::hidden(),
    )
    .unwrap();
    let outcome = &report.outcome;
    assert_eq!(outcome.cameras.len(), 2);
    // A session covering the image with enough sharp views earns no warning.
    assert_eq!(
        stereocal::calibrate::advice::warnings(outcome),
        Vec::<String>::new()
    );

    common::assert_intrinsics_near_truth(&outcome.cameras, &truth);
    for camera in &outcome.cameras {
        // The YAML written reads back with the calibration and the rectification.
        let file = CameraInfoFile::read(out.join(format!("{}.yaml", camera.name))).unwrap();
        assert_eq!(file.camera_name, camera.name);
        assert_eq!(file.info.k, camera.info.k);
        assert_eq!(file.info.d, camera.info.d);
        assert_eq!(file.info.r, camera.info.r);
        assert_eq!(file.info.p, camera.info.p);
        assert_eq!((file.info.width, file.info.height), (1024, 768));
        assert_ne!(file.info.r, [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0]);
    }

    let stereo = outcome.stereo.as_ref().unwrap();
    common::assert_right_from_left_near_truth(stereo, &truth);
    let got = stereo.calibration.right_from_left;

    // Every bad frame is left out of the stereo solve and reported by a camera.
    let bad: Vec<_> = truth
        .frames
        .iter()
        .filter(|f| f.kind != FrameKind::Clean)
        .collect();
    assert!(!bad.is_empty());
    for frame in bad {
        let stamp = stamp(frame);
        assert!(
            !stereo.used.contains(&stamp),
            "bad frame {} used",
            frame.index
        );
        let reported = outcome
            .cameras
            .iter()
            .flat_map(|c| &c.rejected)
            .chain(&stereo.rejected)
            .any(|r| r.stamp == stamp && !r.reason.is_empty());
        assert!(
            reported,
            "bad frame {} ({:?}) not reported",
            frame.index, frame.kind
        );
    }

    let stereo_yaml: serde_yaml::Value =
        serde_yaml::from_str(&std::fs::read_to_string(out.join("stereo.yaml")).unwrap()).unwrap();
    for key in [
        "right_from_left",
        "essential_matrix",
        "fundamental_matrix",
        "rms",
        "epipolar_rms",
    ] {
        assert!(stereo_yaml.get(key).is_some(), "stereo.yaml lacks {key}");
    }
    let translation = stereo_yaml["right_from_left"]["translation"]
        .as_sequence()
        .unwrap();
    assert_eq!(translation.len(), 3);
    assert_eq!(translation[0].as_f64().unwrap(), got.translation.vector.x);

    // The binary's --json output: one object with the documented keys.
    let json_out = dir.path().join("json");
    let output = Command::new(env!("CARGO_BIN_EXE_stereocal"))
        .args(["calibrate", "--bag"])
        .arg(dir.path().join("bag"))
        .arg("--out")
        .arg(&json_out)
        .args(["--pattern", "chessboard", "--size"])
        .arg(format!("{}x{}", truth.board.cols, truth.board.rows))
        .arg("--square")
        .arg(truth.board.square_size.to_string())
        .arg("--json")
        .output()
        .unwrap();
    assert!(
        output.status.success(),
        "{}",
        String::from_utf8_lossy(&output.stderr)
    );
    let value: serde_json::Value = serde_json::from_slice(&output.stdout).unwrap();
    for name in ["left", "right"] {
        let camera = &value["cameras"][name];
        assert!(camera["rms"].as_f64().unwrap() > 0.0);
        assert_eq!(camera["k"].as_array().unwrap().len(), 9);
        assert_eq!(camera["d"].as_array().unwrap().len(), 5);
        assert_eq!(camera["distortion_model"], "plumb_bob");
        assert_eq!(camera["width"], 1024);
        assert_eq!(camera["height"], 768);
        assert!(camera["views_used"].as_u64().unwrap() >= 15);
        for rejected in camera["views_rejected"].as_array().unwrap() {
            assert!(rejected["stamp"]["sec"].is_i64());
            assert!(!rejected["reason"].as_str().unwrap().is_empty());
        }
    }
    let stereo = &value["stereo"];
    assert!(stereo["rms"].as_f64().unwrap() > 0.0);
    assert!(stereo["epipolar_rms"].as_f64().unwrap() > 0.0);
    assert_eq!(
        stereo["right_from_left"]["rotation"]
            .as_array()
            .unwrap()
            .len(),
        9
    );
    let x = stereo["right_from_left"]["translation"][0]
        .as_f64()
        .unwrap();
    let expected = common::true_right_from_left(&truth);
    assert!((x - expected.translation.vector.x).abs() < 0.3e-3);
    assert!(json_out.join("left.yaml").is_file() && json_out.join("stereo.yaml").is_file());
}

#[test]
fn missing_topic_and_wrong_board_size_give_clear_errors() {
    let dir = tempfile::tempdir().unwrap();
    let truth = synthesize(dir.path(), 3);
    let bag = dir.path().join("bag");

    let mut missing = common::calibrate_args(bag.clone(), dir.path().join("missing"), &truth);
    missing.left = Some("/stereo/lft/image_raw".to_owned());
    let error = format!(
        "{:#}",
        calibrate_bag(&missing, &ProgressBar::hidden()).unwrap_err()
    );
    assert!(error.contains("no topic /stereo/lft/image_raw"), "{error}");
    assert!(
        error.contains("/stereo/left/image_raw") && error.contains("/stereo/right/image_raw"),
        "the error lists the bag's image topics: {error}"
    );

    let mut wrong_size = common::calibrate_args(bag, dir.path().join("wrong"), &truth);
    wrong_size.size = format!("{}x{}", truth.board.cols + 1, truth.board.rows + 1);
    let error = format!(
        "{:#}",
        calibrate_bag(&wrong_size, &ProgressBar::hidden()).unwrap_err()
    );
    assert!(error.contains("no complete board found"), "{error}");
    assert!(error.contains("inner corners"), "{error}");
    assert!(
        !dir.path().join("wrong").exists(),
        "nothing written on failure"
    );
}

#[test]
fn mono_camera_is_written_under_its_name_without_rectification() {
    let dir = tempfile::tempdir().unwrap();
    let truth = synthesize(dir.path(), 3);
    let out = dir.path().join("mono");
    let mut mono = common::calibrate_args(dir.path().join("bag"), out.clone(), &truth);
    mono.left = None;
    mono.right = None;
    mono.topic = Some("/stereo/right/image_raw".to_owned());
    mono.name = "front".to_owned();
    let report = calibrate_bag(&mono, &ProgressBar::hidden()).unwrap();
    assert!(report.outcome.stereo.is_none());
    let [camera] = report.outcome.cameras.as_slice() else {
        panic!("one camera expected, got {}", report.outcome.cameras.len());
    };
    assert_eq!(camera.used.len(), 3);
    // Three views only: a sanity bound; the accuracy bar is held on the full session.
    let expected = truth.cameras[1].camera_model().unwrap().intrinsics;
    assert!((camera.calibration.camera.intrinsics.fx - expected.fx).abs() < 2.0);

    let file = CameraInfoFile::read(out.join("front.yaml")).unwrap();
    assert_eq!(file.camera_name, "front");
    assert_eq!(file.info.r, [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0]);
    let k = file.info.k;
    assert_eq!(
        file.info.p,
        [
            k[0], k[1], k[2], 0.0, k[3], k[4], k[5], 0.0, k[6], k[7], k[8], 0.0
        ]
    );
    assert!(!out.join("stereo.yaml").exists());

    let value = report.result.to_json();
    let warnings: Vec<&str> = value["warnings"]
        .as_array()
        .unwrap()
        .iter()
        .map(|w| w.as_str().unwrap())
        .collect();
    assert!(
        warnings
            .iter()
            .any(|w| w.starts_with("camera front: only 3 views used")),
        "three views are too few to trust: {warnings:?}"
    );
    assert!(value.get("stereo").is_none());
    assert_eq!(value["cameras"]["front"]["views_used"], 3);
    assert_eq!(value["cameras"].as_object().unwrap().len(), 1);
}

#[test]
fn too_few_views_says_to_collect_more() {
    let dir = tempfile::tempdir().unwrap();
    let truth = synthesize(dir.path(), 2);
    let board = &truth.board;
    let frames = truth
        .frames
        .iter()
        .map(|frame| {
            let corners = &frame.views[0].corners;
            let view = View {
                points_in_target: corners
                    .iter()
                    .map(|c| {
                        Point3::new(
                            (c.id % board.cols) as f64 * board.square_size,
                            (c.id / board.cols) as f64 * board.square_size,
                            0.0,
                        )
                    })
                    .collect(),
                pixels: corners
                    .iter()
                    .map(|c| {
                        let [x, y] = c.pixel.unwrap();
                        Point2::new(x, y)
                    })
                    .collect(),
            };
            Frame {
                stamp: stamp(frame),
                corners: FrameCorners::Found(view),
            }
        })
        .chain([Frame {
            stamp: Time {
                sec: 1_800_000_000,
                nanosec: 0,
            },
            corners: FrameCorners::Unusable("no complete board found".to_owned()),
        }])
        .collect();
    let camera = CameraFrames {
        name: "left".to_owned(),
        width: 1024,
        height: 768,
        frames,
    };
    let error = calibrate_camera(&camera, DistortionModel::PlumbBob).unwrap_err();
    assert!(
        matches!(
            error,
            CalibrationStageError::Mono {
                error: CalibError::TooFewViews { usable: 2, .. },
                ..
            }
        ),
        "{error:?}"
    );
    let message = error.to_string();
    assert!(
        message.starts_with("camera left: 2 usable views"),
        "{message}"
    );
    assert!(message.contains("collect more views"), "{message}");
    assert!(
        message.ends_with("1 of 3 frames showed no complete board (blurred, partly out of view, or another --size)"),
        "{message}"
    );
}
