//! Rendering one 1024x768 synthetic frame (realistic photometry: blur, vignetting,
//! noise), mono8 and rgb8, and a motion-blurred mono8 frame; plus building a renderer
//! (the camera's ray grid), which happens once per camera.
// A benchmark on fixed inputs: an input that fails is a bug to see at once.
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

use std::hint::black_box;
use std::sync::Arc;

use criterion::{Criterion, criterion_group, criterion_main};
use nalgebra::{Isometry3, UnitQuaternion, Vector3};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use stereocal_vision::camera::DistortionModel;
use stereocal_vision::synth::{
    Background, Chessboard, Coverage, Photometry, PixelFormat, PoseRanges, PoseSampler, Renderer,
    Shot, synthetic_camera,
};

fn bench(c: &mut Criterion) {
    let mut rng = ChaCha8Rng::seed_from_u64(1);
    let camera = synthetic_camera(DistortionModel::PlumbBob, 1024, 768, &mut rng);
    let board = Chessboard::new(9, 6, 0.04, 0.04).unwrap();
    let background = Arc::new(Background::new(1));
    let renderer = Renderer::new(
        camera.clone(),
        board,
        Arc::clone(&background),
        UnitQuaternion::identity(),
    );
    let sampler = PoseSampler::new(
        vec![(&camera, Isometry3::identity())],
        board,
        PoseRanges::default(),
    );
    let pose = sampler.sample(&mut rng, 4, Coverage::Full).unwrap();
    let shot = |format, motion_to| Shot {
        camera_from_target: pose,
        motion_to,
        photometry: Photometry::realistic(),
        supersampling: 6,
        format,
        noise_seed: 3,
    };
    let mono = shot(PixelFormat::Mono8, None);
    let rgb = shot(PixelFormat::Rgb8, None);
    let motion = shot(
        PixelFormat::Mono8,
        Some(Isometry3::new(Vector3::new(0.03, 0.01, 0.0), Vector3::zeros()) * pose),
    );
    c.bench_function("render 1024x768 mono8", |b| {
        b.iter(|| black_box(renderer.render(&mono)))
    });
    c.bench_function("render 1024x768 rgb8", |b| {
        b.iter(|| black_box(renderer.render(&rgb)))
    });
    c.bench_function("render 1024x768 mono8 motion blur", |b| {
        b.iter(|| black_box(renderer.render(&motion)))
    });
    c.bench_function("renderer for a 1024x768 camera", |b| {
        b.iter(|| {
            black_box(Renderer::new(
                camera.clone(),
                board,
                Arc::clone(&background),
                UnitQuaternion::identity(),
            ))
        })
    });
}

criterion_group! {
    name = benches;
    config = Criterion::default().sample_size(10);
    targets = bench
}
criterion_main!(benches);
