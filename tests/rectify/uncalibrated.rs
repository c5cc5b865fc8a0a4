//! `stereocal rectify --uncalibrated` end to end. A synthetic stereo session
//! (`stereocal synth`, lenses with distortion) is turned into a distortion-free verged
//! pair by the calibrated rectify path with camera_infos whose `R` turns each camera 3
//! degrees towards the other (and rolls the right one 1.5 degrees) and whose `P` is the
//! camera's own `K`; that pair, renamed to `/cam/{left,right}/image_raw`, is what the
//! uncalibrated command rectifies. On its output the chessboard is found again in
//! every rectified pair and each corner's rows are compared.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use indicatif::ProgressBar;
use nalgebra::{Matrix3, Matrix3x4, Point2, Rotation3};
use stereocal::cli::rectify::{BagRectifyOptions, rectify_bag};
use stereocal::cli::synth::{SceneArg, SynthArgs};
use stereocal::convert::{CalibratedCamera, image_from_msg, info_from_calibrated};
use stereocal::rectify::scene::{LEFT, RIGHT, StereoScene};
use stereocal_msgs::RosMessage;
use stereocal_msgs::sensor_msgs::{CameraInfo, Image as ImageMsg};
use stereocal_rosbag::{BagReader, BagWriter, TopicFilter};
use stereocal_vision::board::{Chessboard, Target, TargetDetector, detector_for};

/// Rows of a corner in the rectified left and right images must agree to this on every
/// clean frame, pixels.
const MAX_ROW_OFFSET_PX: f64 = 0.5;
const FRAMES: usize = 6;

/// A verged, distortion-free pair in `dir/verged` (topics `/cam/{left,right}/image_raw`,
/// no camera_info), made from a synthetic stereo session; and the session's scene.
fn verged_pair(dir: &Path) -> (PathBuf, StereoScene) {
    let scene_dir = dir.join("scene");
    stereocal::cli::synth::run(&SynthArgs::new(
        SceneArg::Stereo,
        scene_dir.clone(),
        1,
        FRAMES,
    ))
    .expect("synth");
    let scene = StereoScene::open(&scene_dir).expect("scene");
    let turned = |camera: &CalibratedCamera, yaw_deg: f64, roll_deg: f64| -> CameraInfo {
        let i = &camera.model.intrinsics;
        let k = Matrix3::new(i.fx, 0.0, i.cx, 0.0, i.fy, i.cy, 0.0, 0.0, 1.0);
        let pinhole = CalibratedCamera {
            model: camera.model.clone(),
            rectified_from_camera: *Rotation3::from_euler_angles(
                0.0,
                yaw_deg.to_radians(),
                roll_deg.to_radians(),
            )
            .matrix(),
            projection: Matrix3x4::from_columns(&[
                k.column(0).into_owned(),
                k.column(1).into_owned(),
                k.column(2).into_owned(),
                nalgebra::Vector3::zeros(),
            ]),
        };
        info_from_calibrated(&pinhole, Default::default())
    };
    let through_lens = dir.join("through_lens");
    rectify_bag(
        &scene.bag,
        &through_lens,
        &BagRectifyOptions {
            camera_infos: vec![
                (format!("{LEFT}/camera_info"), turned(&scene.left, 3.0, 0.0)),
                (
                    format!("{RIGHT}/camera_info"),
                    turned(&scene.right, -3.0, 1.5),
                ),
            ],
            ..BagRectifyOptions::default()
        },
        &ProgressBar::hidden(),
    )
    .expect("the verged pair");

    let verged = dir.join("verged");
    let reader = BagReader::open(&through_lens).expect("the verged pair");
    let mut writer = BagWriter::create(&verged).expect("a bag");
    let mut topics = Vec::new();
    for (from, to) in [(LEFT, "/cam/left"), (RIGHT, "/cam/right")] {
        let id = writer
            .add_topic(
                &format!("{to}/image_raw"),
                ImageMsg::TYPE_NAME,
                &ImageMsg::schema_text(),
            )
            .expect("topic");
        topics.push((format!("{from}/image_rect"), id));
    }
    let names: Vec<&str> = topics.iter().map(|(t, _)| t.as_str()).collect();
    for message in reader.messages(&TopicFilter::only(names)) {
        let message = message.expect("message");
        let (_, id) = topics
            .iter()
            .find(|(t, _)| *t == *message.topic)
            .expect("a renamed topic");
        writer
            .write_timed(
                *id,
                message.log_time_ns,
                message.publish_time_ns,
                &message.data,
            )
            .expect("write");
    }
    writer.finish().expect("finish");
    (verged, scene)
}

fn stereocal(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_stereocal"))
        .args(args)
        .output()
        .expect("stereocal runs")
}

/// The image messages of `topic`, in bag order.
fn images(bag: &Path, topic: &str) -> Vec<ImageMsg> {
    let reader = BagReader::open(bag).expect("bag");
    reader
        .messages(&TopicFilter::only([topic]))
        .map(|m| m.expect("message").decode().expect("image"))
        .collect()
}

fn detector() -> Box<dyn TargetDetector + Send + Sync> {
    detector_for(&Target::Chessboard(Chessboard {
        cols: 9,
        rows: 6,
        square_size: 0.04,
    }))
    .expect("detector")
}

fn corners(detector: &dyn TargetDetector, image: &ImageMsg) -> Option<Vec<Point2<f64>>> {
    let (_, image) = image_from_msg(image).expect("decodable");
    detector
        .detect(&image)
        .expect("an image")
        .map(|d| d.corners)
}

/// Per pair of `left` and `right` images, the largest |row difference| of a chessboard
/// corner; `None` where the board is not found in both.
fn worst_row_offsets(left: &[ImageMsg], right: &[ImageMsg]) -> Vec<Option<f64>> {
    let detector = detector();
    left.iter()
        .zip(right)
        .map(|(l, r)| {
            assert_eq!(l.header.stamp, r.header.stamp, "pairs in stamp order");
            let (a, mut b) = (corners(&*detector, l)?, corners(&*detector, r)?);
            // A board turned half a turn may be labelled from its other end.
            if (a[0] - b[0]).norm() > (a[0] - b[b.len() - 1]).norm() {
                b.reverse();
            }
            Some(
                a.iter()
                    .zip(&b)
                    .map(|(p, q)| (p.y - q.y).abs())
                    .fold(0.0, f64::max),
            )
        })
        .collect()
}

/// `left_x left_y right_x right_y` lines of the chessboard corners in the pair's images.
fn points_file(verged: &Path) -> String {
    let detector = detector();
    let left = images(verged, "/cam/left/image_raw");
    let right = images(verged, "/cam/right/image_raw");
    let mut text = String::from("# left_x left_y right_x right_y\n");
    for (l, r) in left.iter().zip(&right) {
        if let (Some(a), Some(b)) = (corners(&*detector, l), corners(&*detector, r)) {
            for (p, q) in a.iter().zip(&b) {
                text += &format!("{}, {}, {}, {}\n", p.x, p.y, q.x, q.y);
            }
        }
    }
    text
}

/// Asserts that every frame whose verged pair shows the whole board (`seen`) shows it
/// in both rectified images of `out`, with each corner's rows within
/// [`MAX_ROW_OFFSET_PX`]; returns the largest row difference.
fn assert_rows_align(out: &Path, seen: &[bool], what: &str) -> f64 {
    let left = images(out, "/cam/left/image_rect");
    let right = images(out, "/cam/right/image_rect");
    assert_eq!(left.len(), FRAMES, "{what}: every left frame rectified");
    assert_eq!(right.len(), FRAMES, "{what}: every right frame rectified");
    let mut worst_of_all = 0.0_f64;
    for (frame, worst) in worst_row_offsets(&left, &right).into_iter().enumerate() {
        if !seen[frame] {
            continue;
        }
        let worst = worst.unwrap_or_else(|| panic!("{what}: frame {frame}: board not found"));
        assert!(
            worst <= MAX_ROW_OFFSET_PX,
            "{what}: frame {frame}: rows differ by up to {worst:.3} px"
        );
        worst_of_all = worst_of_all.max(worst);
    }
    worst_of_all
}

#[test]
fn a_verged_pair_is_rectified_from_its_target_or_from_points() {
    let dir = tempfile::tempdir().expect("temp dir");
    let (verged, scene) = verged_pair(dir.path());
    assert_eq!(
        scene.clean_frames(),
        FRAMES,
        "the session is all clean frames"
    );
    let before = worst_row_offsets(
        &images(&verged, "/cam/left/image_raw"),
        &images(&verged, "/cam/right/image_raw"),
    );
    // Turning the cameras moves the board partly out of some views.
    let seen: Vec<bool> = before.iter().map(Option::is_some).collect();
    let pairs = seen.iter().filter(|&&s| s).count();
    assert!(pairs >= 4, "the board is whole in {pairs} verged pairs");
    assert!(
        before.iter().flatten().any(|&w| w > 10.0),
        "the verged pair is far from rectified: {before:?}"
    );

    let out = dir.path().join("from_target");
    let run = stereocal(&[
        "rectify",
        "--bag",
        verged.to_str().expect("path"),
        "--out",
        out.to_str().expect("path"),
        "--uncalibrated",
        "--pattern",
        "chessboard",
        "--size",
        "9x6",
        "--square",
        "0.04",
    ]);
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert!(run.status.success(), "{stderr}");
    assert!(
        stderr.contains(&format!("in {pairs} stereo pairs")),
        "{stderr}"
    );
    let worst = assert_rows_align(&out, &seen, "from the target");
    eprintln!("from the target: rows within {worst:.3} px");

    // The bag had no camera_info: an uncalibrated one (K zero) beside each image_rect.
    let reader = BagReader::open(&out).expect("output");
    for side in ["/cam/left", "/cam/right"] {
        let infos: Vec<CameraInfo> = reader
            .messages(&TopicFilter::only([format!("{side}/camera_info").as_str()]))
            .map(|m| m.expect("message").decode().expect("camera_info"))
            .collect();
        assert_eq!(infos.len(), FRAMES, "{side}: a camera_info per image");
        assert!(infos.iter().all(|i| i.k == [0.0; 9] && i.p == [0.0; 12]));
        assert_eq!((infos[0].width, infos[0].height), (1024, 768));
    }
    assert_eq!(
        images(&out, "/cam/left/image_raw").len(),
        FRAMES,
        "input copied"
    );

    let points = dir.path().join("points.csv");
    std::fs::write(&points, points_file(&verged)).expect("points file");
    let out = dir.path().join("from_points");
    let run = stereocal(&[
        "rectify",
        "--bag",
        verged.to_str().expect("path"),
        "--out",
        out.to_str().expect("path"),
        "--uncalibrated",
        "--points",
        points.to_str().expect("path"),
        "--threshold",
        "2",
    ]);
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert!(run.status.success(), "{stderr}");
    assert!(
        stderr.contains(&format!("{} matched points", 54 * pairs)),
        "{stderr}"
    );
    let worst = assert_rows_align(&out, &seen, "from --points");
    eprintln!("from --points: rows within {worst:.3} px");
}

#[test]
fn bad_uncalibrated_input_is_refused_with_a_clear_message_and_no_output() {
    let dir = tempfile::tempdir().expect("temp dir");
    let (verged, _) = verged_pair(dir.path());
    let out = dir.path().join("out");
    let bag = verged.to_str().expect("path");
    let out_arg = out.to_str().expect("path");
    let write = |name: &str, text: &str| -> String {
        let path = dir.path().join(name);
        std::fs::write(&path, text).expect("file");
        path.to_str().expect("path").to_owned()
    };
    let bad_line = write("bad.csv", "1 2 3 4\n5 6 seven 8\n");
    let too_few = write("few.csv", "1 2 3 4\n5 6 7 8\n9 10 11 12\n");
    let on_a_line: String = (0..20)
        .map(|k| format!("{} {} {} {}\n", 10 * k, 5 * k, 10 * k + 3, 5 * k))
        .collect();
    let on_a_line = write("line.csv", &on_a_line);
    let target = [
        "--pattern",
        "chessboard",
        "--size",
        "9x6",
        "--square",
        "0.04",
    ];
    let wrong_size = [
        "--pattern",
        "chessboard",
        "--size",
        "7x5",
        "--square",
        "0.04",
    ];
    let cases: Vec<(Vec<&str>, &str)> = vec![
        (vec![], "--uncalibrated needs matched points"),
        (vec!["--points", &bad_line], "line 2"),
        (vec!["--points", &too_few], "too few correspondences"),
        (vec!["--points", &on_a_line], "lie on one line"),
        ([&target[..], &["--threshold", "0"]].concat(), "threshold 0"),
        (
            [&target[..], &["--threshold", "-2"]].concat(),
            "threshold -2",
        ),
        (wrong_size.to_vec(), "not found"),
        (
            [
                &target[..],
                &[
                    "--left",
                    "/cam/left/image_raw",
                    "--right",
                    "/cam/left/image_raw",
                ],
            ]
            .concat(),
            "both /cam/left/image_raw",
        ),
        (
            [
                &target[..],
                &["--left", "/nowhere", "--right", "/cam/right/image_raw"],
            ]
            .concat(),
            "no topic /nowhere",
        ),
    ];
    for (extra, expected) in cases {
        let mut args = vec!["rectify", "--bag", bag, "--out", out_arg, "--uncalibrated"];
        args.extend(&extra);
        let run = stereocal(&args);
        let stderr = String::from_utf8_lossy(&run.stderr);
        assert!(!run.status.success(), "{extra:?} succeeded");
        assert!(!stderr.contains("panicked"), "{extra:?}: {stderr}");
        assert!(
            stderr.contains(expected),
            "{extra:?}: expected {expected:?} in {stderr}"
        );
        assert!(!out.exists(), "{extra:?} left an output");
    }
    // The calibrated path's options do not mix with it.
    let run = stereocal(&[
        "rectify",
        "--bag",
        bag,
        "--out",
        out_arg,
        "--uncalibrated",
        "--camera-info",
        "/cam/left/image_raw=left.yaml",
    ]);
    assert!(!run.status.success());
    assert!(String::from_utf8_lossy(&run.stderr).contains("cannot be used with"));
}
