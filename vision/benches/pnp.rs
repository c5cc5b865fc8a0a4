//! Per-call time of the PnP solvers on a 9x6 board (54 points) seen through a plumb-bob
//! camera with 0.2 px of noise, and on 54 points spread in space.
//! `interop/bench_pnp_opencv.py` times [`estimate_pose`] against cv2.solvePnP (SQPNP
//! and ITERATIVE) side by side on the same problems.
// A benchmark on fixed inputs: an input that fails is a bug to see at once.
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

use std::hint::black_box;

use criterion::{Criterion, criterion_group, criterion_main};
use nalgebra::{Isometry3, Point2, Point3, Translation3, UnitQuaternion, Vector2, Vector3};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use stereocal_vision::camera::CameraModel;
use stereocal_vision::pnp::epnp::epnp;
use stereocal_vision::pnp::ippe::ippe;
use stereocal_vision::pnp::p3p::lambda_twist;
use stereocal_vision::pnp::sqpnp::sqpnp;
use stereocal_vision::pnp::{Correspondences, PoseOptions, estimate_pose, refine};
use stereocal_vision::synth::corner_session_camera;

fn problem(planar: bool) -> (CameraModel, Correspondences) {
    let camera = corner_session_camera();
    let mut rng = ChaCha8Rng::seed_from_u64(54);
    let points: Vec<Point3<f64>> = (0..6)
        .flat_map(|r| (0..9).map(move |c| (r, c)))
        .map(|(r, c)| {
            let z = if planar {
                0.0
            } else {
                rng.random_range(-0.05..0.05)
            };
            Point3::new(c as f64 * 0.03, r as f64 * 0.03, z)
        })
        .collect();
    let truth = Isometry3::from_parts(
        Translation3::new(-0.12, -0.07, 0.6),
        UnitQuaternion::from_scaled_axis(Vector3::new(0.3, -0.4, 0.1)),
    );
    let pixels: Vec<Point2<f64>> = points
        .iter()
        .map(|p| {
            camera.project(&(truth * p)).unwrap()
                + Vector2::new(rng.random_range(-0.35..0.35), rng.random_range(-0.35..0.35))
        })
        .collect();
    let c = Correspondences::new(&camera, &points, &pixels).unwrap();
    (camera, c)
}

fn pnp(c: &mut Criterion) {
    for planar in [true, false] {
        let (camera, corr) = problem(planar);
        let shape = if planar { "board" } else { "spatial" };
        let options = PoseOptions::default();
        c.bench_function(&format!("estimate_pose/{shape}_54"), |b| {
            b.iter(|| estimate_pose(&camera, black_box(&corr), &options).unwrap())
        });
        c.bench_function(&format!("sqpnp/{shape}_54"), |b| {
            b.iter(|| sqpnp(black_box(&corr.target_points), &corr.normalized).unwrap())
        });
        c.bench_function(&format!("epnp/{shape}_54"), |b| {
            b.iter(|| epnp(black_box(&corr.target_points), &corr.normalized).unwrap())
        });
        let start = estimate_pose(&camera, &corr, &options)
            .unwrap()
            .camera_from_target;
        c.bench_function(&format!("refine/{shape}_54"), |b| {
            b.iter(|| refine(&camera, black_box(&corr), &start).unwrap())
        });
        if planar {
            c.bench_function("ippe/board_54", |b| {
                b.iter(|| ippe(black_box(&corr.target_points), &corr.normalized).unwrap())
            });
        }
    }
    let (_, corr) = problem(false);
    let points = [
        corr.target_points[0],
        corr.target_points[20],
        corr.target_points[40],
    ];
    let rays = [0, 20, 40].map(|i| Vector3::new(corr.normalized[i].x, corr.normalized[i].y, 1.0));
    c.bench_function("lambda_twist", |b| {
        b.iter(|| lambda_twist(black_box(&points), &rays))
    });
}

criterion_group!(benches, pnp);
criterion_main!(benches);
