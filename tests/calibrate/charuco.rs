//! `stereocal calibrate --pattern charuco` on a synthetic stereo calibration session
//! of a ChArUco board with as many corners as the 9x6 chessboard
//! (`config/boards/charuco_10x7_40mm.yaml`; 1024x768, 25
//! frames, about one in ten bad, one of them partly out of view): intrinsics and
//! `right_from_left` against ground truth.

use crate::common;

use std::path::{Path, PathBuf};

use indicatif::ProgressBar;
use stereocal::cli::calibrate::{CalibrateArgs, CharucoArgs, calibrate_bag};
use stereocal_vision::board::Target;
use stereocal_vision::synth::FrameKind;

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
    let truth =
        common::synthesize_session(&common::calibration_scene(dir.path(), 1, 25), Some(&target));
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
            pattern: "charuco".to_owned(),
            size: format!("{}x{}", board.squares_x, board.squares_y),
            square: board.square_size.to_string(),
            charuco: CharucoArgs {
                marker_size: Some(board.marker_size.to_string()),
                aruco_dict: Some(board.dictionary.ros_name()),
            },
            ..common::calibrate_args(
                dir.path().join("bag"),
                dir.path().join("calibration"),
                &truth,
            )
        },
        &ProgressBar::hidden(),
    )
    .unwrap();
    let outcome = &report.outcome;
    assert_eq!(outcome.cameras.len(), 2);
    common::assert_intrinsics_near_truth(&outcome.cameras, &truth);
    common::assert_right_from_left_near_truth(outcome.stereo.as_ref().unwrap(), &truth);
}
