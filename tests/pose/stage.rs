//! The pose stage on rendered eye-in-hand frames: poses against ground truth for every
//! lens model, an asymmetric circle grid, ChArUco partial views, rectified input through P,
//! and every kind of bad input answered with its reason.

use stereocal::cli::synth::ModelArg;
use stereocal::pose::stage::{PoseRejection, PoseStage};
use stereocal::rectify::stage::{Rectified, Rectifier};
use stereocal_vision::board::{Chessboard, Target};
use stereocal_vision::pnp::{PnpError, PoseOptions};
use stereocal_vision::rectify::RemapOptions;

use super::{Session, pose_error, session};

fn chessboard_stage(
    truth_board: &stereocal_vision::synth::Chessboard,
    rectified: bool,
) -> PoseStage {
    let target = Target::Chessboard(
        Chessboard::new(truth_board.cols, truth_board.rows, truth_board.square_size).unwrap(),
    );
    PoseStage::new(target, PoseOptions::default(), rectified).unwrap()
}

/// Every frame's pose, checked against the truth: within `max_deg` and `max_mm`, and
/// within five standard deviations of the pose's own covariance (blurred frames have a
/// larger error and say so in their covariance).
fn assert_poses_near_truth(
    session: &Session,
    stage: &PoseStage,
    max_deg: f64,
    max_mm: f64,
) -> usize {
    let mut found = 0;
    for (index, (image, info)) in session.frames.iter().enumerate() {
        let (outcome, _) = stage.estimate(image, info);
        let Ok(pose) = outcome else {
            continue;
        };
        found += 1;
        let truth = session.truth_pose(index);
        let (deg, mm) = pose_error(&pose.estimate.camera_from_target, &truth);
        let covariance = &pose.estimate.covariance;
        let sigma_mm = covariance.fixed_view::<3, 3>(0, 0).trace().sqrt() * 1e3;
        let sigma_deg = covariance
            .fixed_view::<3, 3>(3, 3)
            .trace()
            .sqrt()
            .to_degrees();
        println!(
            "frame {index}: {deg:.4} deg ({sigma_deg:.4}), {mm:.3} mm ({sigma_mm:.3}), rms {:.3} px",
            pose.estimate.rms_px
        );
        assert!(
            deg < max_deg && mm < max_mm,
            "frame {index}: {deg} deg, {mm} mm"
        );
        assert!(
            deg < 5.0 * sigma_deg && mm < 5.0 * sigma_mm,
            "frame {index}: covariance too small"
        );
    }
    found
}

#[test]
fn chessboard_poses_match_truth_for_every_lens_model() {
    for (seed, model) in [
        (11, ModelArg::PlumbBob),
        (12, ModelArg::RationalPolynomial),
        (13, ModelArg::Equidistant),
    ] {
        let session = session(seed, 6, model, 0.0, None);
        let stage = chessboard_stage(&session.truth.board, false);
        let found = assert_poses_near_truth(&session, &stage, 0.05, 0.5);
        assert_eq!(
            found,
            session.frames.len(),
            "{model:?}: a frame without a pose"
        );
    }
}

#[test]
fn circle_grid_poses_match_truth() {
    let file = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("config/boards/acircles_4x11_20mm.yaml");
    let target = Target::from_yaml_file(&file).unwrap();
    let session = session(14, 6, ModelArg::PlumbBob, 0.0, Some(&target));
    let stage = PoseStage::new(target, PoseOptions::default(), false).unwrap();
    let found = assert_poses_near_truth(&session, &stage, 0.05, 0.5);
    assert_eq!(found, session.frames.len(), "a frame without a pose");
}

#[test]
fn blurred_frames_get_a_pose_or_a_reason() {
    let session = session(21, 10, ModelArg::PlumbBob, 0.5, None);
    let stage = chessboard_stage(&session.truth.board, false);
    let found = assert_poses_near_truth(&session, &stage, 0.5, 3.0);
    assert!(found >= 5, "{found} poses in 10 frames");
}

#[test]
fn rectified_images_are_seen_through_p() {
    let session = session(31, 3, ModelArg::PlumbBob, 0.0, None);
    let stage = chessboard_stage(&session.truth.board, true);
    let mut rectifier = Rectifier::new(RemapOptions::default());
    for (index, (image, info)) in session.frames.iter().enumerate() {
        let Ok(Rectified::Image(rect)) = rectifier.rectify(image, info) else {
            panic!("frame {index} not rectified");
        };
        // The raw camera_info has R = I and P = [K | 0]: the rectified camera is the raw
        // camera without its distortion, in the same frame.
        let pose = stage.estimate(&rect, info).0.unwrap();
        let (deg, mm) = pose_error(
            &pose.estimate.camera_from_target,
            &session.truth_pose(index),
        );
        assert!(deg < 0.05 && mm < 0.5, "frame {index}: {deg} deg, {mm} mm");
        // The same rectified image through K and D is wrong, and says so.
        let raw_stage = chessboard_stage(&session.truth.board, false);
        if let Ok(wrong) = raw_stage.estimate(&rect, info).0 {
            assert!(wrong.estimate.rms_px > pose.estimate.rms_px);
        }
    }
}

#[test]
fn bad_input_is_answered_with_its_reason() {
    let session = session(41, 1, ModelArg::PlumbBob, 0.0, None);
    let stage = chessboard_stage(&session.truth.board, false);
    let (image, info) = &session.frames[0];
    let reject = |image: &stereocal_msgs::sensor_msgs::Image,
                  info: &stereocal_msgs::sensor_msgs::CameraInfo| {
        stage.estimate(image, info).0.unwrap_err()
    };

    let mut uncalibrated = info.clone();
    uncalibrated.k[0] = 0.0;
    let e = reject(image, &uncalibrated);
    assert_eq!(e.kind(), "camera_info");
    assert!(e.to_string().contains("uncalibrated"), "{e}");

    let mut nan = info.clone();
    nan.d[1] = f64::NAN;
    let e = reject(image, &nan);
    assert!(e.to_string().contains("D[1] is NaN"), "{e}");

    let mut blank = image.clone();
    blank.data.iter_mut().for_each(|v| *v = 128);
    let e = reject(&blank, info);
    assert!(matches!(e, PoseRejection::NotVisible(_)), "{e}");

    let mut later = info.clone();
    later.header.stamp.nanosec += 1;
    let e = reject(image, &later);
    assert_eq!(e.kind(), "unpaired_camera_info");
    assert!(
        e.to_string()
            .contains("no camera_info with the image's stamp"),
        "{e}"
    );

    let mut small = info.clone();
    small.width /= 2;
    assert!(matches!(
        reject(image, &small),
        PoseRejection::SizeMismatch { .. }
    ));

    let mut truncated = image.clone();
    truncated.data.truncate(100);
    assert_eq!(reject(&truncated, info).kind(), "image");

    // A reprojection bound no pose can meet.
    let strict = PoseStage::new(
        stage.target().clone(),
        PoseOptions {
            max_rms_px: 1e-6,
            ..PoseOptions::default()
        },
        false,
    )
    .unwrap();
    let e = strict.estimate(image, info).0.unwrap_err();
    assert!(
        matches!(e, PoseRejection::Pose(PnpError::ReprojectionError { .. })),
        "{e}"
    );
}

fn charuco_target() -> Target {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("config/boards/charuco_10x7_40mm.yaml");
    Target::from_yaml_file(&path).unwrap()
}

#[test]
fn charuco_poses_match_truth_including_partial_views() {
    let target = charuco_target();
    let session = session(51, 12, ModelArg::PlumbBob, 0.4, Some(&target));
    let stage = PoseStage::new(target, PoseOptions::default(), false).unwrap();
    let partial = session
        .truth
        .frames
        .iter()
        .enumerate()
        .filter(|(_, f)| f.kind == stereocal_vision::synth::FrameKind::Partial)
        .map(|(i, _)| i)
        .collect::<Vec<_>>();
    assert!(!partial.is_empty(), "no partial view in the session");
    let found = assert_poses_near_truth(&session, &stage, 0.5, 3.0);
    assert!(found >= 6, "{found} poses in 12 frames");
    let partial_found = partial
        .iter()
        .filter(|&&i| {
            stage
                .estimate(&session.frames[i].0, &session.frames[i].1)
                .0
                .is_ok()
        })
        .count();
    assert!(partial_found > 0, "no pose from a partial view");
}

#[test]
fn a_charuco_view_with_too_few_corners_is_refused() {
    let target = charuco_target();
    let session = session(52, 1, ModelArg::PlumbBob, 0.0, Some(&target));
    let stage = PoseStage::new(target, PoseOptions::default(), false).unwrap();
    let (image, info) = &session.frames[0];
    assert!(stage.estimate(image, info).0.is_ok());
    // Keep only a patch around four corners of the board, the rest white paper.
    let corners = &session.truth.frames[0].views[0].corners;
    let cols = session.truth.board.cols;
    let patch: Vec<[f64; 2]> = [cols + 1, cols + 2, 2 * cols + 1, 2 * cols + 2]
        .iter()
        .map(|&id| corners[id].pixel.unwrap())
        .collect();
    let (x0, x1) = (
        patch.iter().map(|p| p[0]).fold(f64::MAX, f64::min),
        patch.iter().map(|p| p[0]).fold(f64::MIN, f64::max),
    );
    let (y0, y1) = (
        patch.iter().map(|p| p[1]).fold(f64::MAX, f64::min),
        patch.iter().map(|p| p[1]).fold(f64::MIN, f64::max),
    );
    let margin = 0.6 * (x1 - x0);
    let mut masked = image.clone();
    let width = image.width as usize;
    for (i, v) in masked.data.iter_mut().enumerate() {
        let (x, y) = ((i % width) as f64, (i / width) as f64);
        if x < x0 - margin || x > x1 + margin || y < y0 - margin || y > y1 + margin {
            *v = 230;
        }
    }
    let e = stage.estimate(&masked, info).0.unwrap_err();
    assert!(matches!(e, PoseRejection::NotVisible(_)), "{e}");
    assert!(e.to_string().contains("at least 6 corners"), "{e}");
}
