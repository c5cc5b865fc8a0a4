//! Whole scenes: seeded determinism, bad frames that really are bad, hand-eye ground
//! truth that composes, and stereo views that cover the image.

use nalgebra::Isometry3;
use stereocal_vision::image::{Image, Samples};
use stereocal_vision::synth::{
    FrameKind, GroundTruth, HandEye, PixelFormat, Scene, SceneKind, SceneSpec,
};

fn small(kind: SceneKind, seed: u64, frames: usize) -> SceneSpec {
    SceneSpec {
        frames,
        width: 480,
        height: 360,
        ..SceneSpec::new(kind, seed)
    }
}

fn bytes(image: &Image) -> &[u8] {
    match &image.samples {
        Samples::U8(v) => v,
        Samples::U16(_) => panic!("synth renders 8-bit images"),
    }
}

#[test]
fn the_same_seed_gives_the_same_bytes() {
    let spec = SceneSpec {
        format: PixelFormat::Rgb8,
        bad_fraction: 0.5,
        ..small(SceneKind::Calibration, 11, 4)
    };
    let a = Scene::generate(&spec).unwrap();
    let b = Scene::generate(&spec).unwrap();
    let json = |scene: &Scene| serde_json::to_string(scene.truth()).unwrap();
    assert_eq!(json(&a), json(&b));
    for index in 0..4 {
        let (fa, fb) = (
            a.render_frame(index).unwrap(),
            b.render_frame(index).unwrap(),
        );
        assert_eq!(fa.len(), 2);
        assert_eq!(fa[0].channels, 3);
        assert_eq!(fa, fb);
    }
    let other = Scene::generate(&small(SceneKind::Calibration, 12, 4)).unwrap();
    assert_ne!(json(&a), json(&other));
    assert!(a.render_frame(4).is_none());
}

#[test]
fn ground_truth_round_trips_through_json() {
    let scene = Scene::generate(&small(SceneKind::HandEyeToHand, 5, 3)).unwrap();
    let text = serde_json::to_string_pretty(scene.truth()).unwrap();
    let back: GroundTruth = serde_json::from_str(&text).unwrap();
    let truth = scene.truth();
    assert_eq!(back.frames.len(), truth.frames.len());
    assert_eq!(back.cameras[0].name, "camera");
    assert!(
        back.extrinsics.base_from_camera.is_some() && back.extrinsics.tool_from_camera.is_none()
    );
    for (a, b) in back.frames.iter().zip(&truth.frames) {
        assert_eq!((a.index, a.stamp, a.kind), (b.index, b.stamp, b.kind));
        for (ca, cb) in a.views[0].corners.iter().zip(&b.views[0].corners) {
            let ([xa, ya], [xb, yb]) = (ca.pixel.unwrap(), cb.pixel.unwrap());
            assert!((xa - xb).abs() < 1e-9 && (ya - yb).abs() < 1e-9);
        }
    }
    let camera = back.cameras[0].camera_model().unwrap();
    let original = scene.cameras().next().unwrap();
    assert_eq!(camera.distortion.model(), original.distortion.model());
    assert!((camera.intrinsics.fx - original.intrinsics.fx).abs() < 1e-9);
}

/// Mean squared intensity gradient in windows around the true positions of the
/// visible corners.
fn sharpness(image: &Image, corners: &[[f64; 2]]) -> f64 {
    let data = bytes(image);
    let w = image.width;
    let (mut sum, mut count) = (0.0, 0usize);
    for [x, y] in corners {
        let (cx, cy) = (x.round() as usize, y.round() as usize);
        for v in cy.saturating_sub(6).max(1)..(cy + 6).min(image.height - 1) {
            for u in cx.saturating_sub(6).max(1)..(cx + 6).min(w - 1) {
                let gx = f64::from(data[v * w + u + 1]) - f64::from(data[v * w + u - 1]);
                let gy = f64::from(data[(v + 1) * w + u]) - f64::from(data[(v - 1) * w + u]);
                sum += gx * gx + gy * gy;
                count += 1;
            }
        }
    }
    sum / count.max(1) as f64
}

#[test]
fn bad_frames_are_bad() {
    let spec = SceneSpec {
        bad_fraction: 0.3,
        ..small(SceneKind::Calibration, 3, 10)
    };
    let scene = Scene::generate(&spec).unwrap();
    let truth = scene.truth();
    let kinds: Vec<FrameKind> = truth.frames.iter().map(|f| f.kind).collect();
    for kind in [FrameKind::Blurred, FrameKind::Motion, FrameKind::Partial] {
        assert_eq!(kinds.iter().filter(|k| **k == kind).count(), 1, "{kinds:?}");
    }
    let mut clean = Vec::new();
    let mut blurred = Vec::new();
    for frame in &truth.frames {
        let left = &frame.views[0];
        let visible: Vec<[f64; 2]> = left
            .corners
            .iter()
            .filter(|c| c.visible)
            .filter_map(|c| c.pixel)
            .collect();
        let share = visible.len() as f64 / left.corners.len() as f64;
        if frame.kind == FrameKind::Partial {
            assert!(
                (0.25..=0.75).contains(&share),
                "partial frame shows {share}"
            );
            continue;
        }
        assert_eq!(share, 1.0, "frame {} of kind {:?}", frame.index, frame.kind);
        let image = &scene.render_frame(frame.index).unwrap()[0];
        let s = sharpness(image, &visible);
        match frame.kind {
            FrameKind::Clean => clean.push(s),
            _ => blurred.push((frame.kind, s)),
        }
    }
    let sharpest_bad = blurred.iter().map(|(_, s)| *s).fold(0.0, f64::max);
    let least_sharp_clean = clean.iter().cloned().fold(f64::INFINITY, f64::min);
    assert!(
        sharpest_bad < 0.3 * least_sharp_clean,
        "bad {blurred:?} vs clean {clean:?}"
    );
}

fn isometry(record: &Option<stereocal_vision::synth::TransformRecord>) -> Isometry3<f64> {
    record
        .as_ref()
        .expect("transform in the ground truth")
        .isometry()
}

#[test]
fn hand_eye_poses_compose() {
    for kind in [SceneKind::HandEyeInHand, SceneKind::HandEyeToHand] {
        let scene = Scene::generate(&small(kind, 21, 12)).unwrap();
        let truth = scene.truth();
        let e = &truth.extrinsics;
        let setup = if kind == SceneKind::HandEyeInHand {
            HandEye::InHand {
                tool_from_camera: isometry(&e.tool_from_camera),
                base_from_target: isometry(&e.base_from_target),
            }
        } else {
            HandEye::ToHand {
                base_from_camera: isometry(&e.base_from_camera),
                tool_from_target: isometry(&e.tool_from_target),
            }
        };
        let mut rotations = Vec::new();
        for frame in &truth.frames {
            let base_from_tool = isometry(&frame.base_from_tool);
            let seen = frame.views[0].camera_from_target.isometry();
            // Composed by hand, independently of HandEye's own formulas.
            let composed = if kind == SceneKind::HandEyeInHand {
                (base_from_tool * isometry(&e.tool_from_camera)).inverse()
                    * isometry(&e.base_from_target)
            } else {
                isometry(&e.base_from_camera).inverse()
                    * base_from_tool
                    * isometry(&e.tool_from_target)
            };
            let difference = composed.inverse() * seen;
            assert!(difference.translation.vector.norm() < 1e-9, "{kind:?}");
            assert!(difference.rotation.angle() < 1e-9, "{kind:?}");
            let via_setup = setup.camera_from_target(&base_from_tool).inverse() * seen;
            assert!(via_setup.translation.vector.norm() < 1e-9);
            assert!(frame.views[0].corners.iter().all(|c| c.visible));
            rotations.push(base_from_tool.rotation);
        }
        // Varied robot rotations: some pair of poses differs by more than 30 degrees.
        let widest = rotations
            .iter()
            .flat_map(|a| rotations.iter().map(move |b| a.angle_to(b)))
            .fold(0.0, f64::max);
        assert!(widest > 30f64.to_radians(), "{kind:?}: widest {widest}");
    }
}

#[test]
fn stereo_views_cover_the_image() {
    let scene = Scene::generate(&small(SceneKind::Stereo, 8, 18)).unwrap();
    let truth = scene.truth();
    let centres: Vec<(f64, f64)> = truth
        .frames
        .iter()
        .map(|frame| {
            let corners = &frame.views[0].corners;
            assert!(
                frame
                    .views
                    .iter()
                    .all(|v| v.corners.iter().all(|c| c.visible))
            );
            let n = corners.len() as f64;
            let (sx, sy) = corners
                .iter()
                .filter_map(|c| c.pixel)
                .fold((0.0, 0.0), |(a, b), [x, y]| (a + x, b + y));
            (sx / n / 480.0, sy / n / 360.0)
        })
        .collect();
    let span = |f: fn(&(f64, f64)) -> f64| {
        let values: Vec<f64> = centres.iter().map(f).collect();
        values.iter().cloned().fold(f64::MIN, f64::max)
            - values.iter().cloned().fold(f64::MAX, f64::min)
    };
    assert!(
        span(|c| c.0) > 0.4,
        "board centres span too little of the width"
    );
    assert!(
        span(|c| c.1) > 0.3,
        "board centres span too little of the height"
    );
    let baseline = truth
        .extrinsics
        .right_from_left
        .as_ref()
        .unwrap()
        .isometry();
    assert!((baseline.inverse().translation.vector.x - 0.12).abs() < 1e-12);
}
