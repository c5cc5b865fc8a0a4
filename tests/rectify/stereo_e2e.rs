//! End to end: a synthetic stereo bag replayed through two `rectify_node` processes over
//! DDS on loopback (on this test's own ROS domain), against `stereocal rectify` on the
//! same bag and against the scene's ground truth.

use std::time::Duration;

use indicatif::ProgressBar;
use stereocal::cli::demo::bundled_stereo_args;
use stereocal::cli::rectify::{BagRectifyOptions, rectify_bag};
use stereocal::rectify::replay::{NodeReplay, replay_through_rectify_nodes};
use stereocal::rectify::scene::{LEFT, RIGHT, StereoScene, identical_images, read_rectified};
use stereocal_runtime::testing::DomainLease;

/// Rows of a corner in the rectified left and right images must agree to this, on
/// average over the clean frames (pixels).
const MAX_MEAN_ROW_OFFSET: f64 = 0.05;

#[test]
fn nodes_over_dds_rectify_every_frame_like_the_offline_command_with_aligned_rows() {
    let dir = tempfile::tempdir().expect("temp dir");
    let scene_dir = dir.path().join("scene");
    stereocal::cli::synth::run(&bundled_stereo_args(scene_dir.clone())).expect("synth");
    let scene = StereoScene::open(&scene_dir).expect("scene");

    let offline_bag = dir.path().join("rectified");
    rectify_bag(
        &scene.bag,
        &offline_bag,
        &BagRectifyOptions::default(),
        &ProgressBar::hidden(),
    )
    .expect("offline rectify");
    let offline = read_rectified(&offline_bag).expect("rectified bag");

    let domain = DomainLease::for_test().expect("a ROS domain");
    let outcome = replay_through_rectify_nodes(
        &scene.bag,
        &[LEFT.to_owned(), RIGHT.to_owned()],
        &NodeReplay {
            node_command: vec![env!("CARGO_BIN_EXE_rectify_node").into()],
            domain_id: domain.id(),
            rate_hz: 15.0,
            timeout: Duration::from_secs(30),
        },
    )
    .expect("replay through the nodes");
    let nodes = [
        outcome.rectified.get(LEFT).cloned().unwrap_or_default(),
        outcome.rectified.get(RIGHT).cloned().unwrap_or_default(),
    ];

    let frames = scene.truth.frames.len();
    assert_eq!(outcome.total_sent(), 2 * frames, "every raw image was sent");
    assert_eq!(
        outcome.received(),
        2 * frames,
        "every frame arrived rectified; node logs: {:#?}",
        outcome.node_logs
    );
    assert_eq!(offline[0].len() + offline[1].len(), 2 * frames);
    assert_eq!(
        identical_images(&offline, &nodes),
        2 * frames,
        "the nodes give the offline command's pixels"
    );

    for (what, rectified) in [("offline", &offline), ("nodes", &nodes)] {
        let (alignment, measured) = scene.row_alignment(rectified);
        assert_eq!(
            measured,
            scene.clean_frames(),
            "{what}: every clean frame measured"
        );
        assert!(
            alignment.corners >= 20 * measured,
            "{what}: {} corners measured in {measured} frames",
            alignment.corners
        );
        assert_eq!(alignment.missed, 0, "{what}: every corner located");
        assert!(
            alignment.mean_abs_offset() <= MAX_MEAN_ROW_OFFSET,
            "{what}: mean |dy| {:.4} px over {} corners (max {:.4})",
            alignment.mean_abs_offset(),
            alignment.corners,
            alignment.max_abs_offset
        );
    }
}

#[test]
fn raw_camera_info_leaves_rows_unaligned() {
    // The measurement can fail: without the rig's rectification (camera_info of a raw
    // camera, R = I and P = [K|0]) the same corners are rows apart.
    let dir = tempfile::tempdir().expect("temp dir");
    let scene_dir = dir.path().join("scene");
    stereocal::cli::synth::run(&bundled_stereo_args(scene_dir.clone())).expect("synth");
    let scene = StereoScene::open(&scene_dir).expect("scene");
    let raw = |camera: &stereocal::convert::CalibratedCamera| {
        stereocal::convert::info_from_raw_camera(&camera.model, Default::default())
    };
    let out = dir.path().join("undistorted");
    rectify_bag(
        &scene.bag,
        &out,
        &BagRectifyOptions {
            camera_infos: vec![
                (format!("{LEFT}/camera_info"), raw(&scene.left)),
                (format!("{RIGHT}/camera_info"), raw(&scene.right)),
            ],
            ..BagRectifyOptions::default()
        },
        &ProgressBar::hidden(),
    )
    .expect("undistort");
    let undistorted = read_rectified(&out).expect("bag");
    let raw_scene = StereoScene {
        left: stereocal::convert::calibrated_camera_from_info(&raw(&scene.left)).expect("left"),
        right: stereocal::convert::calibrated_camera_from_info(&raw(&scene.right)).expect("right"),
        ..scene
    };
    let (alignment, _) = raw_scene.row_alignment(&undistorted);
    assert!(alignment.corners > 0);
    assert!(
        alignment.mean_abs_offset() > 1.0,
        "mean |dy| {:.3} px",
        alignment.mean_abs_offset()
    );
}
