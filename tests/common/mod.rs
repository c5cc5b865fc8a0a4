//! Helpers shared by the end-to-end tests: synthesizing a calibration session with
//! `stereocal synth` and checking calibrations against its ground truth.

use std::path::{Path, PathBuf};

use nalgebra::{Isometry3, Matrix3};
use stereocal::calibrate::stage::{CameraResult, StereoResult};
use stereocal::cli::calibrate::CalibrateArgs;
use stereocal::cli::synth::{SceneArg, SynthArgs, run_with_target};
use stereocal_runtime::testing::{DomainLease, PeerNode};
use stereocal_runtime::transport::TransportConfig;
use stereocal_vision::board::Target;
use stereocal_vision::camera::Intrinsics;
use stereocal_vision::synth::GroundTruth;

/// The `stereocal synth` arguments of a 1024x768 plumb-bob stereo calibration session
/// of `frames` mono8 frames from `seed`, side by side, with the default share of bad
/// frames, written into `dir`.
pub fn calibration_scene(dir: &Path, seed: u64, frames: usize) -> SynthArgs {
    SynthArgs::new(SceneArg::Calibration, dir.to_path_buf(), seed, frames)
}

/// `stereocal calibrate`'s arguments for the stereo pair of a synthesized session
/// (`/stereo/{left,right}/image_raw` in `bag`) showing the chessboard of `truth`,
/// written to `out` with the plumb-bob model.
pub fn calibrate_args(bag: PathBuf, out: PathBuf, truth: &GroundTruth) -> CalibrateArgs {
    let board = &truth.board;
    CalibrateArgs {
        left: Some("/stereo/left/image_raw".to_owned()),
        right: Some("/stereo/right/image_raw".to_owned()),
        ..CalibrateArgs::chessboard(bag, out, board.cols, board.rows, board.square_size)
    }
}

/// Runs `stereocal synth` with `args`, the scene showing `target` (`None`: the
/// default chessboard), and reads back the ground truth it wrote.
pub fn synthesize_session(args: &SynthArgs, target: Option<&Target>) -> GroundTruth {
    run_with_target(args, target).expect("synth");
    let text = std::fs::read_to_string(args.out.join("ground_truth.json")).expect("truth");
    serde_json::from_str(&text).expect("truth json")
}

/// Asserts that `got`'s fx, fy, cx and cy of camera `name` are within 0.2 px of
/// `expected`, printing each.
pub fn assert_intrinsics_near(name: &str, got: &Intrinsics, expected: &Intrinsics) {
    for (what, got, expected) in [
        ("fx", got.fx, expected.fx),
        ("fy", got.fy, expected.fy),
        ("cx", got.cx, expected.cx),
        ("cy", got.cy, expected.cy),
    ] {
        println!("{name} {what}: {got:.4} against {expected:.4}");
        assert!(
            (got - expected).abs() < 0.2,
            "{name} {what}: {got:.4} against {expected:.4}"
        );
    }
}

/// The intrinsics of a camera matrix K listed row by row, as camera_info holds it.
pub fn intrinsics_from_k(k: &[f64]) -> Intrinsics {
    Intrinsics::from_matrix(&Matrix3::from_row_slice(k))
}

/// Asserts that each calibrated camera is the ground truth's camera of the same
/// place, with intrinsics near the truth ([`assert_intrinsics_near`]).
pub fn assert_intrinsics_near_truth(cameras: &[CameraResult], truth: &GroundTruth) {
    for (camera, record) in cameras.iter().zip(&truth.cameras) {
        assert_eq!(camera.name, record.name);
        let expected = record.camera_model().expect("truth camera").intrinsics;
        assert_intrinsics_near(
            &camera.name,
            &camera.calibration.camera.intrinsics,
            &expected,
        );
    }
}

/// The ground truth's `right_from_left`.
pub fn true_right_from_left(truth: &GroundTruth) -> Isometry3<f64> {
    truth
        .extrinsics
        .right_from_left
        .as_ref()
        .expect("truth right_from_left")
        .isometry()
}

/// Asserts that the stereo calibration's `right_from_left` is within 0.05 degrees
/// and 0.3 mm of the ground truth, printing how far off it is.
pub fn assert_right_from_left_near_truth(stereo: &StereoResult, truth: &GroundTruth) {
    let expected = true_right_from_left(truth);
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

/// The test's own node `/test/<name>` on `domain`, with RustDDS's default transport.
pub fn test_node(domain: &DomainLease, name: &str) -> PeerNode {
    PeerNode::new(
        &TransportConfig::rustdds_defaults(),
        domain.id(),
        "/test",
        name,
    )
    .expect("test node")
}
