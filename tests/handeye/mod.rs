//! `stereocal handeye` on rendered sessions whose robot reports its poses with an arm's
//! noise (0.05 degree and 0.3 mm): `stereocal pose` finds the target in every image, and
//! the command pairs those poses with the bag's robot poses and recovers the true
//! hand-eye transform, eye-in-hand and eye-to-hand; from the images themselves it refines
//! on the corners to within its predicted uncertainty; bad arguments and too few samples
//! are refused with a clear message.

mod node;

use indicatif::ProgressBar;
use nalgebra::Isometry3;
use stereocal::cli::handeye::{HandEyeArgs, SetupArg, handeye_bag};
use stereocal::cli::pose::{PoseArgs, pose_bag};
use stereocal::cli::synth::{SceneArg, SynthArgs};
use stereocal::handeye::report::HandEyeReport;
use stereocal::pose::record::isometry_of;

use crate::common;
use crate::pose::pose_error;

/// A rendered session of `frames` frames run through `stereocal pose`: the directory,
/// the truth, and the pose bag.
fn posed_session(
    scene: SceneArg,
    seed: u64,
    frames: usize,
) -> (
    tempfile::TempDir,
    stereocal_vision::synth::GroundTruth,
    std::path::PathBuf,
) {
    let dir = tempfile::tempdir().expect("temp dir");
    let args = SynthArgs::new(scene, dir.path().join("synth"), seed, frames);
    let truth = common::synthesize_session(&args, None);
    let posed = dir.path().join("posed");
    let board = &truth.board;
    let pose_args = PoseArgs::chessboard(
        dir.path().join("synth/bag"),
        posed.clone(),
        board.cols,
        board.rows,
        board.square_size,
    );
    pose_bag(&pose_args, &ProgressBar::hidden()).expect("stereocal pose");
    (dir, truth, posed)
}

fn args(bag: std::path::PathBuf, setup: SetupArg, out: std::path::PathBuf) -> HandEyeArgs {
    HandEyeArgs::from_poses(bag, setup, "/camera/target_pose", "/robot/tool_pose", out)
}

/// The true `mount_from_camera` and `anchor_from_target` of a session.
fn truth_of(
    truth: &stereocal_vision::synth::GroundTruth,
    setup: SetupArg,
) -> (Isometry3<f64>, Isometry3<f64>) {
    let e = &truth.extrinsics;
    match setup {
        SetupArg::EyeInHand => (
            e.tool_from_camera.as_ref().unwrap().isometry(),
            e.base_from_target.as_ref().unwrap().isometry(),
        ),
        SetupArg::EyeToHand => (
            e.base_from_camera.as_ref().unwrap().isometry(),
            e.tool_from_target.as_ref().unwrap().isometry(),
        ),
    }
}

#[test]
fn recovers_the_true_transform_in_both_setups() {
    for (scene, setup, seed) in [
        (SceneArg::HandeyeInHand, SetupArg::EyeInHand, 81),
        (SceneArg::HandeyeToHand, SetupArg::EyeToHand, 82),
    ] {
        let (dir, truth, posed) = posed_session(scene, seed, 12);
        let out = dir.path().join("handeye");
        let report = handeye_bag(&args(posed, setup, out.clone())).unwrap();
        let (expected, expected_target) = match setup {
            SetupArg::EyeInHand => (
                truth
                    .extrinsics
                    .tool_from_camera
                    .as_ref()
                    .unwrap()
                    .isometry(),
                truth
                    .extrinsics
                    .base_from_target
                    .as_ref()
                    .unwrap()
                    .isometry(),
            ),
            SetupArg::EyeToHand => (
                truth
                    .extrinsics
                    .base_from_camera
                    .as_ref()
                    .unwrap()
                    .isometry(),
                truth
                    .extrinsics
                    .tool_from_target
                    .as_ref()
                    .unwrap()
                    .isometry(),
            ),
        };
        assert_eq!(report.results.len(), 7, "{setup:?}: {:?}", report.warnings);
        // Twelve samples with the robot's noise: every method within 0.1 degree and 2 mm.
        for (method, result) in &report.results {
            let (deg, mm) = pose_error(&isometry_of(result), &expected);
            println!("{setup:?} {method}: {deg:.4} deg, {mm:.3} mm");
            assert!(
                deg < 0.1 && mm < 2.0,
                "{setup:?} {method}: {deg} deg, {mm} mm"
            );
        }
        let (deg, mm) = pose_error(&isometry_of(&report.target), &expected_target);
        assert!(
            deg < 0.1 && mm < 2.0,
            "{setup:?} target: {deg} deg, {mm} mm"
        );
        assert_eq!(report.samples, 12);
        assert!(
            report.samples_rejected.is_empty(),
            "{:?}",
            report.samples_rejected
        );
        assert_eq!(report.frames.base, "base");
        assert_eq!(report.frames.camera, "camera_optical_frame");
        let written: HandEyeReport =
            serde_yaml::from_str(&std::fs::read_to_string(out.join("handeye.yaml")).unwrap())
                .unwrap();
        assert_eq!(written, report);
    }
}

/// From the images themselves: the target found in each, every method, and the joint
/// refinement on the corners chosen, with its uncertainty and pixel error.
#[test]
fn refines_on_the_corners_when_given_the_images() {
    let (dir, truth, _) = posed_session(SceneArg::HandeyeInHand, 84, 12);
    let board = &truth.board;
    let args = HandEyeArgs::from_images(
        dir.path().join("synth/bag"),
        SetupArg::EyeInHand,
        "/camera/image_raw",
        (board.cols, board.rows, board.square_size),
        "/robot/tool_pose",
        dir.path().join("handeye"),
    );
    let report = handeye_bag(&args).unwrap();
    assert_eq!(report.chosen, "refined");
    assert_eq!(report.results.len(), 8, "{:?}", report.warnings);
    let (expected, expected_target) = truth_of(&truth, SetupArg::EyeInHand);
    let (deg, mm) = pose_error(&isometry_of(&report.results["refined"]), &expected);
    println!(
        "refined: {deg:.4} deg, {mm:.3} mm, {:?}",
        report.uncertainty
    );
    // Within three of its own standard deviations of the truth.
    let uncertainty = report.uncertainty.as_ref().unwrap();
    assert!(
        deg < 3.0 * uncertainty.rotation_deg && mm < 3.0 * uncertainty.translation_mm,
        "refined: {deg} deg, {mm} mm against {uncertainty:?}"
    );
    let (deg, mm) = pose_error(&isometry_of(&report.target), &expected_target);
    assert!(deg < 0.1 && mm < 2.0, "target: {deg} deg, {mm} mm");
    assert!(report.rms_px.unwrap() < 0.5, "{:?}", report.rms_px);
    assert_eq!(report.frames.camera, "camera_optical_frame");
    assert_eq!(report.per_sample.len(), 12);
    assert!(
        report
            .per_sample
            .iter()
            .all(|s| s.reprojection_rms_px.is_some_and(|r| r < 0.5) && s.rejected.is_none())
    );
    assert_eq!(report.motion.motions.len(), 12 * 11 / 2);

    // The page: every method's row, a bar per sample in both residual charts, a dot per
    // motion, nothing fetched or run.
    let page = std::fs::read_to_string(dir.path().join("handeye/report.html")).unwrap();
    assert_eq!(page.matches("<tr data-method=").count(), 8);
    assert_eq!(page.matches("class=\"sample-bar used\"").count(), 2 * 12);
    assert_eq!(page.matches("class=\"motion\"").count(), 66);
    assert!(!page.contains("<script") && !page.contains("http"));
}

/// A ChArUco board, found by its markers: the refined transform within three of its
/// standard deviations of the truth, eye-to-hand.
#[test]
fn calibrates_with_a_charuco_board() {
    let board = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("config/boards/charuco_10x7_40mm.yaml");
    let target = stereocal_vision::board::Target::from_yaml_file(&board).unwrap();
    let dir = tempfile::tempdir().expect("temp dir");
    let synth = SynthArgs::new(SceneArg::HandeyeToHand, dir.path().join("synth"), 86, 12);
    let truth = common::synthesize_session(&synth, Some(&target));
    let mut args = HandEyeArgs::from_images(
        dir.path().join("synth/bag"),
        SetupArg::EyeToHand,
        "/camera/image_raw",
        (10, 7, 0.04),
        "/robot/tool_pose",
        dir.path().join("handeye"),
    );
    args.pattern = "charuco".to_owned();
    args.charuco.marker_size = Some("0.03".to_owned());
    args.charuco.aruco_dict = Some("DICT_5X5_100".to_owned());
    let report = handeye_bag(&args).unwrap();
    assert_eq!(report.chosen, "refined", "{:?}", report.warnings);
    let (expected, _) = truth_of(&truth, SetupArg::EyeToHand);
    let (deg, mm) = pose_error(&isometry_of(&report.results["refined"]), &expected);
    let uncertainty = report.uncertainty.as_ref().unwrap();
    println!("charuco refined: {deg:.4} deg, {mm:.3} mm against {uncertainty:?}");
    assert!(
        deg < 3.0 * uncertainty.rotation_deg && mm < 3.0 * uncertainty.translation_mm,
        "refined: {deg} deg, {mm} mm against {uncertainty:?}"
    );
    assert!(report.samples >= 10, "{} samples", report.samples);
}

/// The robot's poses from the bag's `/tf` instead of its pose topic: the same result;
/// frames TF does not connect are refused by name.
#[test]
fn takes_the_robot_poses_from_tf() {
    let (dir, _, posed) = posed_session(SceneArg::HandeyeInHand, 85, 8);
    let from_topic = handeye_bag(&args(
        posed.clone(),
        SetupArg::EyeInHand,
        dir.path().join("topic"),
    ))
    .unwrap();
    let tf_args = |frames: &str, out: &str| HandEyeArgs {
        robot_pose_topic: None,
        tf: Some(frames.to_owned()),
        ..args(posed.clone(), SetupArg::EyeInHand, dir.path().join(out))
    };
    let from_tf = handeye_bag(&tf_args("base:tool", "tf")).unwrap();
    assert_eq!(from_tf.results, from_topic.results);
    assert_eq!(
        (from_tf.frames.base.as_str(), from_tf.frames.tool.as_str()),
        ("base", "tool")
    );

    let error = format!(
        "{:#}",
        handeye_bag(&tf_args("base:gripper", "bad")).unwrap_err()
    );
    assert!(error.contains("unknown frame \"gripper\""), "{error}");
    // stereocal pose put camera -> target on /tf: a tree of its own.
    let error = format!(
        "{:#}",
        handeye_bag(&tf_args("base:target", "bad")).unwrap_err()
    );
    assert!(error.contains("no path from base to target"), "{error}");
    let error = format!("{:#}", handeye_bag(&tf_args("base", "bad")).unwrap_err());
    assert!(error.contains("expected BASE:TOOL"), "{error}");
}

#[test]
fn refuses_bad_arguments_and_too_few_samples() {
    let (dir, _, posed) = posed_session(SceneArg::HandeyeInHand, 83, 2);
    let out = dir.path().join("handeye");
    let error = handeye_bag(&args(posed.clone(), SetupArg::EyeInHand, out.clone())).unwrap_err();
    assert!(
        format!("{error:#}").contains("too few samples"),
        "{error:#}"
    );
    assert!(!out.join("handeye.yaml").exists());

    let mut wrong_topic = args(posed.clone(), SetupArg::EyeInHand, out.clone());
    wrong_topic.robot_pose_topic = Some("/robot/pose".to_owned());
    let error = handeye_bag(&wrong_topic).unwrap_err().to_string();
    assert!(error.contains("no topic /robot/pose"), "{error}");

    let mut wrong_type = args(posed.clone(), SetupArg::EyeInHand, out.clone());
    wrong_type.target_pose_topic = Some("/camera/camera_info".to_owned());
    let error = handeye_bag(&wrong_type).unwrap_err().to_string();
    assert!(error.contains("is a sensor_msgs/msg/CameraInfo"), "{error}");

    let mut negative = args(posed, SetupArg::EyeInHand, out);
    negative.max_time_difference = -1.0;
    let error = handeye_bag(&negative).unwrap_err().to_string();
    assert!(error.contains("--max-time-difference"), "{error}");
}
