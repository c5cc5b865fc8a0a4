//! The calibration session on synthesized sessions: bad frames refused for their
//! reason and good ones kept by camera_calibration's coverage rule, defocus and motion
//! blur told apart, repeated views not new, a fast-moving board refused, images of
//! another size refused, the sample store surviving a reopen (and a failed write), a
//! store of another target refused, ChArUco boards kept in part, and calibrations from
//! the kept samples (stereo and mono) against ground truth.

use crate::common;

use std::sync::{Arc, OnceLock};

use nalgebra::{Isometry3, Translation3, UnitQuaternion};

use stereocal::calibrate::session::{
    CalibrationSession, Offer, SessionConfig, SessionError, Verdict, store_path,
};
use stereocal_msgs::builtin_interfaces::Time;
use stereocal_vision::board::{ArucoDictionary, Charuco, Chessboard, Target};
use stereocal_vision::calib::quality::{SampleParams, sample_params};
use stereocal_vision::camera::DistortionModel;
use stereocal_vision::image::{Image, Samples};
use stereocal_vision::synth::{
    self, Background, CharucoMarkers, FrameKind, GroundTruth, Photometry, PixelFormat, Renderer,
    Scene, SceneKind, SceneSpec, Shot,
};

/// A rendered stereo calibration session: ground truth and each frame's images.
struct Session {
    truth: GroundTruth,
    frames: Vec<Vec<Image>>,
}

/// 1024x768 stereo calibration session of 30 frames, one in five bad (defocused,
/// motion-blurred or partly out of view), rendered once for every test.
fn session() -> &'static Session {
    static SESSION: OnceLock<Session> = OnceLock::new();
    SESSION.get_or_init(|| {
        let mut spec = SceneSpec::new(SceneKind::Calibration, 7);
        spec.frames = 30;
        spec.bad_fraction = 0.2;
        let scene = Scene::generate(&spec).expect("scene");
        let frames = (0..spec.frames)
            .map(|k| scene.render_frame(k).expect("frame"))
            .collect();
        Session {
            truth: scene.truth().clone(),
            frames,
        }
    })
}

fn target(truth: &GroundTruth) -> Target {
    Target::Chessboard(
        Chessboard::new(truth.board.cols, truth.board.rows, truth.board.square_size)
            .expect("board"),
    )
}

fn stereo_config(truth: &GroundTruth) -> SessionConfig {
    SessionConfig::new(
        target(truth),
        vec!["left".to_owned(), "right".to_owned()],
        DistortionModel::PlumbBob,
    )
}

fn stamp(truth: &GroundTruth, index: usize) -> Time {
    let stamp = truth.frames[index].stamp;
    Time {
        sec: stamp.sec,
        nanosec: stamp.nanosec,
    }
}

fn images(frame: &[Image]) -> Vec<&Image> {
    frame.iter().collect()
}

/// Offers every frame of the session in order; what the session made of each.
fn offer_all(session: &mut CalibrationSession) -> Vec<Offer> {
    let s = self::session();
    s.frames
        .iter()
        .enumerate()
        .map(|(k, frame)| {
            session
                .offer(stamp(&s.truth, k), &images(frame))
                .expect("offer")
        })
        .collect()
}

#[test]
fn bad_frames_are_refused_for_their_reason_and_good_frames_kept() {
    let s = session();
    let dir = tempfile::tempdir().unwrap();
    let mut calibration = CalibrationSession::open(stereo_config(&s.truth), dir.path()).unwrap();
    let offers = offer_all(&mut calibration);
    let verdicts: Vec<&Verdict> = offers.iter().map(|o| &o.verdict).collect();
    // Bad frames the detector still finds are refused for their blur; the others (a
    // board partly out of view, or too blurred to find) for the missing board.
    let not_found = "no whole 9x6 board found in left and right";
    let mut counts = std::collections::BTreeMap::new();
    for (frame, &verdict) in s.truth.frames.iter().zip(&verdicts) {
        let reasons: &[&str] = match frame.kind {
            FrameKind::Clean => &[],
            FrameKind::Blurred => &["out of focus", not_found],
            FrameKind::Motion => &["motion blur", not_found],
            FrameKind::Partial => &[not_found],
        };
        let reason = match verdict {
            Verdict::Added | Verdict::NotNew if reasons.is_empty() => "kept or not new",
            Verdict::Refused(got) => {
                let Some(reason) = reasons.iter().find(|r| got.contains(*r)) else {
                    panic!(
                        "frame {} ({:?}) refused as {got:?}",
                        frame.index, frame.kind
                    );
                };
                reason
            }
            _ => panic!(
                "frame {} ({:?}) judged {verdict:?}",
                frame.index, frame.kind
            ),
        };
        *counts
            .entry((format!("{:?}", frame.kind), reason))
            .or_insert(0) += 1;
    }
    eprintln!("verdicts by frame kind: {counts:?}");
    for kind in [FrameKind::Blurred, FrameKind::Motion, FrameKind::Partial] {
        let bad: usize = counts
            .iter()
            .filter(|((k, _), _)| *k == format!("{kind:?}"))
            .map(|(_, n)| n)
            .sum();
        assert!(bad >= 2, "{kind:?}: {counts:?}");
    }
    assert!(
        counts.contains_key(&("Blurred".to_owned(), "out of focus")),
        "{counts:?}"
    );
    // Good frames are kept exactly when their left view is more than 0.2 (sum of the
    // X, Y, size and skew differences) from every view kept before.
    let mut kept: Vec<SampleParams> = Vec::new();
    for offer in &offers {
        let Some(Some(left)) = offer.detections.first() else {
            continue;
        };
        let params = sample_params(left, 9, 6, 1024, 768).unwrap();
        let nearest = kept
            .iter()
            .map(|k| k.distance(&params))
            .fold(f64::INFINITY, f64::min);
        match offer.verdict {
            Verdict::Added => {
                assert!(nearest > 0.2, "added at {nearest} from a kept view");
                kept.push(params);
            }
            Verdict::NotNew => assert!(nearest <= 0.2, "not new at {nearest}"),
            Verdict::Refused(_) => {}
        }
    }
    let added = kept.len();
    let not_new = verdicts.iter().filter(|v| ***v == Verdict::NotNew).count();
    eprintln!("{added} good frames added, {not_new} not new");
    assert_eq!(calibration.sample_count(), added);
    assert_eq!(added + not_new, 24);
    let progress = calibration.progress();
    assert_eq!(progress.samples, added);
    eprintln!("{}", progress.status_line());
}

#[test]
fn defocus_and_motion_blur_of_a_found_board_are_refused_for_what_they_are() {
    let s = session();
    let frame = s
        .truth
        .frames
        .iter()
        .find(|f| f.kind == FrameKind::Clean)
        .unwrap();
    let pose = frame.views[0].camera_from_target.isometry();
    let renderer = Renderer::new(
        s.truth.cameras[0].camera_model().unwrap(),
        s.truth.board,
        Arc::new(Background::new(3)),
        UnitQuaternion::identity(),
    );
    let shot = |motion_to: Option<Isometry3<f64>>, defocus_sigma: f64| {
        renderer.render(&Shot {
            camera_from_target: pose,
            motion_to,
            photometry: Photometry {
                defocus_sigma,
                ..Photometry::realistic()
            },
            supersampling: 6,
            format: PixelFormat::Mono8,
            noise_seed: 11,
        })
    };
    let judge = |image: &Image| {
        let dir = tempfile::tempdir().unwrap();
        let mut config = stereo_config(&s.truth);
        config.cameras = vec!["left".to_owned()];
        let mut calibration = CalibrationSession::open(config, dir.path()).unwrap();
        let offer = calibration
            .offer(Time { sec: 1, nanosec: 0 }, &[image])
            .unwrap();
        assert!(offer.detections[0].is_some(), "board not found");
        offer.verdict
    };
    assert_eq!(judge(&shot(None, 0.6)), Verdict::Added);
    let Verdict::Refused(defocus) = judge(&shot(None, 3.0)) else {
        panic!("a defocused board was kept");
    };
    assert!(
        defocus.starts_with("left: board edges") && defocus.contains("out of focus"),
        "{defocus}"
    );
    // The board slides 15 mm along its x during the exposure.
    let moved = pose * Translation3::new(0.015, 0.0, 0.0);
    let Verdict::Refused(motion) = judge(&shot(Some(moved), 0.6)) else {
        panic!("a moving board was kept");
    };
    eprintln!("defocus: {defocus}\nmotion: {motion}");
    assert!(
        motion.contains("motion blur") && motion.contains("hold the board still"),
        "{motion}"
    );
}

#[test]
fn a_repeated_view_is_not_new() {
    let s = session();
    let dir = tempfile::tempdir().unwrap();
    let mut calibration = CalibrationSession::open(stereo_config(&s.truth), dir.path()).unwrap();
    let frame = images(&s.frames[0]);
    let first = calibration
        .offer(
            Time {
                sec: 100,
                nanosec: 0,
            },
            &frame,
        )
        .unwrap();
    assert_eq!(first.verdict, Verdict::Added);
    assert!(first.detections.iter().all(Option::is_some));
    let again = calibration
        .offer(
            Time {
                sec: 102,
                nanosec: 0,
            },
            &frame,
        )
        .unwrap();
    assert_eq!(again.verdict, Verdict::NotNew);
    assert_eq!(calibration.sample_count(), 1);
    assert_eq!(calibration.progress().samples, 1);
}

#[test]
fn a_board_moved_quickly_between_frames_is_refused_when_speed_is_limited() {
    let s = session();
    let clean: Vec<usize> = s
        .truth
        .frames
        .iter()
        .filter(|f| f.kind == FrameKind::Clean)
        .map(|f| f.index)
        .take(2)
        .collect();
    let (a, b) = (images(&s.frames[clean[0]]), images(&s.frames[clean[1]]));
    let t0 = Time {
        sec: 50,
        nanosec: 0,
    };
    let t1 = Time {
        sec: 50,
        nanosec: 100_000_000,
    };
    let run = |max_board_speed: f64, second: Time| {
        let dir = tempfile::tempdir().unwrap();
        let mut config = stereo_config(&s.truth);
        config.checks.max_board_speed = max_board_speed;
        let mut calibration = CalibrationSession::open(config, dir.path()).unwrap();
        assert_eq!(calibration.offer(t0, &a).unwrap().verdict, Verdict::Added);
        calibration.offer(second, &b).unwrap().verdict
    };
    let Verdict::Refused(reason) = run(200.0, t1) else {
        panic!("a board jumping between poses in 0.1 s was not refused");
    };
    assert!(
        reason.contains("moving") && reason.contains("hold the board still"),
        "{reason}"
    );
    // Unlimited, or compared with a frame more than a second older: kept.
    assert_eq!(run(0.0, t1), Verdict::Added);
    assert_eq!(
        run(
            200.0,
            Time {
                sec: 52,
                nanosec: 0
            }
        ),
        Verdict::Added
    );
}

#[test]
fn the_store_survives_a_reopen_and_belongs_to_its_target() {
    let s = session();
    let dir = tempfile::tempdir().unwrap();
    let mut calibration = CalibrationSession::open(stereo_config(&s.truth), dir.path()).unwrap();
    for k in 0..8 {
        calibration
            .offer(stamp(&s.truth, k), &images(&s.frames[k]))
            .unwrap();
    }
    assert!(calibration.sample_count() >= 3);
    let samples: Vec<_> = calibration.samples().cloned().collect();
    let progress = calibration.progress();
    drop(calibration);

    let reopened = CalibrationSession::open(stereo_config(&s.truth), dir.path()).unwrap();
    assert_eq!(reopened.samples().cloned().collect::<Vec<_>>(), samples);
    assert_eq!(reopened.progress(), progress);
    drop(reopened);

    // Another board, or other cameras, on the same store: refused, file untouched.
    let before = std::fs::read(store_path(dir.path())).unwrap();
    let mut other = stereo_config(&s.truth);
    other.target = Target::Chessboard(Chessboard::new(7, 5, 0.04).unwrap());
    let error = CalibrationSession::open(other, dir.path()).unwrap_err();
    assert!(
        matches!(error, SessionError::StoreMismatch { .. }),
        "{error:?}"
    );
    let message = error.to_string();
    assert!(
        message.contains("reset") && message.contains("state_dir"),
        "{message}"
    );
    let mut mono = stereo_config(&s.truth);
    mono.cameras = vec!["left".to_owned()];
    assert!(matches!(
        CalibrationSession::open(mono, dir.path()),
        Err(SessionError::StoreMismatch { .. })
    ));
    assert_eq!(std::fs::read(store_path(dir.path())).unwrap(), before);

    // A reset forgets the samples, in the store too.
    let mut calibration = CalibrationSession::open(stereo_config(&s.truth), dir.path()).unwrap();
    calibration.reset().unwrap();
    assert_eq!(calibration.sample_count(), 0);
    let reopened = CalibrationSession::open(stereo_config(&s.truth), dir.path()).unwrap();
    assert_eq!(reopened.sample_count(), 0);
    assert_eq!(reopened.progress().cameras[0].x, 0.0);
}

#[test]
fn a_damaged_store_is_an_error_naming_it() {
    let s = session();
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(store_path(dir.path()), b"{\"format\": \"stereocal calib").unwrap();
    let error = CalibrationSession::open(stereo_config(&s.truth), dir.path()).unwrap_err();
    assert!(
        matches!(error, SessionError::StoreDamaged { .. }),
        "{error:?}"
    );
    assert!(
        error
            .to_string()
            .contains(&store_path(dir.path()).display().to_string()),
        "{error}"
    );
}

#[test]
fn calibration_from_the_kept_samples_matches_ground_truth() {
    let s = session();
    let dir = tempfile::tempdir().unwrap();
    let mut calibration = CalibrationSession::open(stereo_config(&s.truth), dir.path()).unwrap();
    offer_all(&mut calibration);
    let outcome = calibration.calibrate().unwrap();
    assert_eq!(outcome.cameras.len(), 2);
    assert!(outcome.stereo.is_some());
    common::assert_intrinsics_near_truth(&outcome.cameras, &s.truth);
}

#[test]
fn offers_of_the_wrong_shape_are_errors_and_progress_reads() {
    let s = session();
    let dir = tempfile::tempdir().unwrap();
    let mut calibration = CalibrationSession::open(stereo_config(&s.truth), dir.path()).unwrap();
    let left = &s.frames[0][0];
    assert!(matches!(
        calibration.offer(Time::default(), &[left]),
        Err(SessionError::ImageCount { offered: 1, .. })
    ));
    let broken = Image {
        width: 10,
        ..left.clone()
    };
    assert!(matches!(
        calibration.offer(Time::default(), &[left, &broken]),
        Err(SessionError::Image { .. })
    ));
    let progress = calibration.progress();
    assert_eq!((progress.samples, progress.ready), (0, false));
    let line = progress.status_line();
    assert!(
        line.starts_with("0 samples; left: x 0%") && line.contains("right:"),
        "{line}"
    );
    let json = progress.to_json();
    assert_eq!(json["samples"], 0);
    assert_eq!(json["cameras"][1]["name"], "right");
}

#[test]
fn a_charuco_session_keeps_partly_visible_boards_and_refuses_blurred_ones() {
    let target = Charuco {
        squares_x: 7,
        squares_y: 5,
        square_size: 0.04,
        marker_size: 0.03,
        dictionary: ArucoDictionary::Dict5x5_100,
    };
    let markers = CharucoMarkers::new(target.marker_size, target.dictionary).unwrap();
    let mut spec = SceneSpec::new(SceneKind::Calibration, 5);
    spec.board = synth::Chessboard::charuco(6, 4, 0.04, 0.04, markers).unwrap();
    spec.frames = 12;
    spec.bad_fraction = 0.5;
    let scene = Scene::generate(&spec).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let config = SessionConfig::new(
        Target::Charuco(target.clone()),
        vec!["left".to_owned()],
        DistortionModel::PlumbBob,
    );
    let mut calibration = CalibrationSession::open(config.clone(), dir.path()).unwrap();
    let mut partial_kept = 0;
    for (index, frame) in scene.truth().frames.iter().enumerate() {
        let images = scene.render_frame(index).unwrap();
        let offer = calibration
            .offer(stamp(scene.truth(), index), &[&images[0]])
            .unwrap();
        // Partly visible boards are usable; blurred and moving ones are not.
        let usable = matches!(frame.kind, FrameKind::Clean | FrameKind::Partial);
        assert_eq!(
            usable,
            !matches!(offer.verdict, Verdict::Refused(_)),
            "{:?} frame {index} judged {:?}",
            frame.kind,
            offer.verdict
        );
        if let (Verdict::Added, Some(found)) = (&offer.verdict, &offer.detections[0])
            && found.ids.len() < 24
        {
            partial_kept += 1;
        }
    }
    assert!(
        calibration.sample_count() >= 4,
        "{}",
        calibration.sample_count()
    );
    assert!(partial_kept >= 1, "no partly visible board kept");
    let samples: Vec<_> = calibration.samples().cloned().collect();
    let progress = calibration.progress();
    assert!(progress.cameras[0].size > 0.0);
    drop(calibration);
    let reopened = CalibrationSession::open(config, dir.path()).unwrap();
    assert_eq!(reopened.samples().cloned().collect::<Vec<_>>(), samples);
    assert_eq!(reopened.progress(), progress);
}

#[test]
fn a_mono_session_calibrates_one_camera() {
    let s = session();
    let dir = tempfile::tempdir().unwrap();
    let mut config = stereo_config(&s.truth);
    config.cameras = vec!["left".to_owned()];
    let mut calibration = CalibrationSession::open(config, dir.path()).unwrap();
    for (k, frame) in s.frames.iter().enumerate() {
        calibration.offer(stamp(&s.truth, k), &[&frame[0]]).unwrap();
    }
    assert_eq!(calibration.progress().cameras.len(), 1);
    let outcome = calibration.calibrate().unwrap();
    assert!(outcome.stereo.is_none());
    let [camera] = outcome.cameras.as_slice() else {
        panic!("{} cameras calibrated", outcome.cameras.len());
    };
    assert_eq!(camera.name, "left");
    assert_eq!(camera.used.len(), calibration.sample_count());
    let expected = s.truth.cameras[0].camera_model().unwrap().intrinsics;
    let got = camera.calibration.camera.intrinsics;
    for (got, expected) in [
        (got.fx, expected.fx),
        (got.cx, expected.cx),
        (got.cy, expected.cy),
    ] {
        assert!(
            (got - expected).abs() < 0.2,
            "{got:.4} against {expected:.4}"
        );
    }
}

#[test]
fn images_of_another_size_than_the_kept_samples_are_refused() {
    let s = session();
    let dir = tempfile::tempdir().unwrap();
    let mut calibration = CalibrationSession::open(stereo_config(&s.truth), dir.path()).unwrap();
    let first = images(&s.frames[0]);
    assert_eq!(
        calibration
            .offer(Time { sec: 1, nanosec: 0 }, &first)
            .unwrap()
            .verdict,
        Verdict::Added
    );
    // The next view, framed in a larger image: the board is found but not kept.
    let next = s
        .truth
        .frames
        .iter()
        .position(|f| f.index > 0 && f.kind == FrameKind::Clean)
        .unwrap();
    let padded: Vec<Image> = s.frames[next]
        .iter()
        .map(|image| pad(image, 1100, 800))
        .collect();
    let offer = calibration
        .offer(Time { sec: 3, nanosec: 0 }, &images(&padded))
        .unwrap();
    assert!(offer.detections.iter().all(Option::is_some));
    let Verdict::Refused(reason) = offer.verdict else {
        panic!("images of another size kept: {:?}", offer.verdict);
    };
    assert!(
        reason.contains("1100x800") && reason.contains("1024x768") && reason.contains("reset"),
        "{reason}"
    );
    assert_eq!(calibration.sample_count(), 1);
}

/// A mono 8-bit `image` at the top left of a black `width x height` image.
fn pad(image: &Image, width: usize, height: usize) -> Image {
    let Samples::U8(data) = &image.samples else {
        panic!("not 8-bit");
    };
    assert_eq!(image.channels, 1);
    let mut out = vec![0u8; width * height];
    for (y, row) in data.chunks_exact(image.width).enumerate() {
        out[y * width..y * width + image.width].copy_from_slice(row);
    }
    Image::new(width, height, 1, Samples::U8(out)).unwrap()
}

#[test]
fn a_sample_that_cannot_be_stored_is_not_kept() {
    let s = session();
    let dir = tempfile::tempdir().unwrap();
    let store_dir = dir.path().join("state");
    let mut calibration = CalibrationSession::open(stereo_config(&s.truth), &store_dir).unwrap();
    // The store's folder cannot be made: a file has its name.
    std::fs::write(&store_dir, b"not a folder").unwrap();
    let error = calibration
        .offer(Time { sec: 1, nanosec: 0 }, &images(&s.frames[0]))
        .unwrap_err();
    assert!(
        matches!(error, SessionError::StoreWrite { .. }),
        "{error:?}"
    );
    assert!(error.to_string().contains("state"), "{error}");
    assert_eq!(calibration.sample_count(), 0);
    // Once the store can be written, the same view is new and kept.
    std::fs::remove_file(&store_dir).unwrap();
    let offer = calibration
        .offer(Time { sec: 3, nanosec: 0 }, &images(&s.frames[0]))
        .unwrap();
    assert_eq!(offer.verdict, Verdict::Added);
    assert!(store_path(&store_dir).exists());
}
