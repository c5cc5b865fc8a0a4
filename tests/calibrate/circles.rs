//! `stereocal calibrate --pattern acircles|circles` on synthetic stereo calibration
//! sessions of circle grids (`config/boards/acircles_4x11_20mm.yaml`,
//! `circles_9x6_40mm.yaml`; 1024x768, views tilted up to 40 degrees about each board
//! axis, about one in ten bad): intrinsics against ground truth for every lens model.

use crate::common;

use std::path::{Path, PathBuf};

use indicatif::ProgressBar;
use stereocal::cli::calibrate::{CalibrateArgs, calibrate_bag};
use stereocal::cli::synth::ModelArg;
use stereocal_vision::board::Target;
use stereocal_vision::camera::DistortionModel;

fn board_file(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("config/boards")
        .join(name)
}

/// Synthesizes a session of the board in `file` through `model` and calibrates it.
fn calibrate_circles(file: &str, pattern: &str, seed: u64, model: ModelArg) {
    let target = Target::from_yaml_file(&board_file(file)).unwrap();
    let (grid, _) = target.circle_grid().expect("a circle grid");
    let dir = tempfile::tempdir().unwrap();
    let mut scene = common::calibration_scene(dir.path(), seed, 25);
    scene.model = model;
    let truth = common::synthesize_session(&scene, Some(&target));
    assert!(
        truth.board.circles.is_some(),
        "ground truth without circles"
    );
    let report = calibrate_bag(
        &CalibrateArgs {
            pattern: pattern.to_owned(),
            size: format!("{}x{}", grid.cols, grid.rows),
            square: grid.spacing.to_string(),
            model: match model {
                ModelArg::PlumbBob => DistortionModel::PlumbBob,
                ModelArg::RationalPolynomial => DistortionModel::RationalPolynomial,
                ModelArg::Equidistant => DistortionModel::Equidistant,
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
}

#[test]
fn asymmetric_grid_sessions_match_ground_truth_for_every_lens_model() {
    for (seed, model) in [
        (71, ModelArg::PlumbBob),
        (72, ModelArg::RationalPolynomial),
        (73, ModelArg::Equidistant),
    ] {
        calibrate_circles("acircles_4x11_20mm.yaml", "acircles", seed, model);
    }
}

#[test]
fn symmetric_grid_session_matches_ground_truth() {
    calibrate_circles("circles_9x6_40mm.yaml", "circles", 74, ModelArg::PlumbBob);
}
