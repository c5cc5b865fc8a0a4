//! `stereocal calibrate --pattern charuco` on a synthetic stereo calibration session
//! of a ChArUco board with as many corners as the 9x6 chessboard
//! (`config/boards/charuco_10x7_40mm.yaml`; 1024x768, 25
//! frames, about one in ten bad, one of them partly out of view): intrinsics and
//! `right_from_left` against ground truth.

use std::path::{Path, PathBuf};

use indicatif::ProgressBar;
use stereocal::cli::calibrate::{CalibrateArgs, CharucoArgs, calibrate_bag};
use stereocal::cli::synth::{ModelArg, SceneArg, SynthArgs, run_with_target};
use stereocal_vision::board::Target;
use stereocal_vision::camera::DistortionModel;
use stereocal_vision::synth::{FrameKind, GroundTruth};

fn board_file() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("config/boards/charuco_10x7_40mm.yaml")
}

#[test]
fn charuco_stereo_session_matches_ground_truth() {
    let target = Target::from_yaml_file(&board_file()).unwrap();
    let Target::Charuco(board) = &target else {
        panic!("not a ChArUco board: {target:?}");
    };
    let dir = tempfile::tempdir().unwrap();
    run_with_target(
        &SynthArgs {
            scene: SceneArg::Calibration,
            out: dir.path().to_path_buf(),
            seed: 1,
            frames: Some(25),
            width: 1024,
            height: 768,
            model: ModelArg::PlumbBob,
            bad_frames: None,
            rgb: false,
            vertical: false,
        },
        Some(&target),
    )
    .unwrap();
    let text = std::fs::read_to_string(dir.path().join("ground_truth.json")).unwrap();
    let truth: GroundTruth = serde_json::from_str(&text).unwrap();
    assert!(
        truth.board.markers.is_some(),
        "ground truth without markers"
    );
    assert!(
        truth.frames.iter().any(|f| f.kind == FrameKind::Partial),
        "the session has no partial view"
    );

    let report = calibrate_bag(
        &CalibrateArgs {
            bag: dir.path().join("bag"),
            out: dir.path().join("calibration"),
            pattern: "charuco".to_owned(),
            size: format!("{}x{}", board.squares_x, board.squares_y),
            square: board.square_size.to_string(),
            charuco: CharucoArgs {
                marker_size: Some(board.marker_size.to_string()),
                aruco_dict: Some(board.dictionary.ros_name()),
            },
            topic: None,
            left: Some("/stereo/left/image_raw".to_owned()),
            right: Some("/stereo/right/image_raw".to_owned()),
            model: DistortionModel::PlumbBob,
            name: "camera".to_owned(),
            json: false,
        },
        &ProgressBar::hidden(),
    )
    .unwrap();
    let outcome = &report.outcome;
    assert_eq!(outcome.cameras.len(), 2);
    for (camera, record) in outcome.cameras.iter().zip(&truth.cameras) {
        assert_eq!(camera.name, record.name);
        let expected = record.camera_model().unwrap().intrinsics;
        let got = camera.calibration.camera.intrinsics;
        for (what, got, expected) in [
            ("fx", got.fx, expected.fx),
            ("fy", got.fy, expected.fy),
            ("cx", got.cx, expected.cx),
            ("cy", got.cy, expected.cy),
        ] {
            println!("{} {what}: {got:.4} against {expected:.4}", camera.name);
            assert!(
                (got - expected).abs() < 0.2,
                "{} {what}: {got:.4} against {expected:.4}",
                camera.name
            );
        }
    }

    let stereo = outcome.stereo.as_ref().unwrap();
    let expected = truth
        .extrinsics
        .right_from_left
        .as_ref()
        .unwrap()
        .isometry();
    let got = stereo.calibration.right_from_left;
    let angle = (got.rotation * expected.rotation.inverse())
        .angle()
        .to_degrees();
    let offset = (got.translation.vector - expected.translation.vector).norm();
    println!(
        "right_from_left: {angle:.4} degrees, {:.4} mm off; {} pairs used",
        offset * 1e3,
        stereo.used.len()
    );
    assert!(
        angle < 0.05,
        "right_from_left rotation off by {angle} degrees"
    );
    assert!(
        offset < 0.3e-3,
        "right_from_left translation off by {offset} m"
    );
}
