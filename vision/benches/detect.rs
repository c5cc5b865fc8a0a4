//! Chessboard detection (grid, ordering and sub-pixel refinement) per 1280x720
//! synthetic frame: a 9x6 board in eight poses over the image, realistic light and
//! noise on a cluttered background. `interop/bench_calibrate_opencv.py` compares
//! detection with OpenCV's findChessboardCorners + cornerSubPix on the same images.
// A benchmark on fixed inputs: an input that fails is a bug to see at once.
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

use std::hint::black_box;
use std::sync::Arc;

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use nalgebra::{Isometry3, UnitQuaternion};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use stereocal_vision::board::{self, ChessboardDetector, Gray, TargetDetector};
use stereocal_vision::camera::DistortionModel;
use stereocal_vision::image::Image;
use stereocal_vision::synth::{
    Background, Chessboard, Coverage, Photometry, PixelFormat, PoseRanges, PoseSampler, Renderer,
    Shot, synthetic_camera,
};

const WIDTH: u32 = 1280;
const HEIGHT: u32 = 720;
const VIEWS: usize = 8;

fn frames() -> Vec<Image> {
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    let camera = synthetic_camera(DistortionModel::PlumbBob, WIDTH, HEIGHT, &mut rng);
    let board = Chessboard::new(9, 6, 0.04, 0.03).expect("valid board");
    let renderer = Renderer::new(
        camera.clone(),
        board,
        Arc::new(Background::new(7)),
        UnitQuaternion::identity(),
    );
    let sampler = PoseSampler::new(
        vec![(&camera, Isometry3::identity())],
        board,
        PoseRanges::default(),
    );
    (0..VIEWS)
        .map(|index| {
            let pose = sampler
                .sample(&mut rng, index, Coverage::Full)
                .expect("a pose");
            renderer.render(&Shot {
                camera_from_target: pose,
                motion_to: None,
                photometry: Photometry::realistic(),
                supersampling: 4,
                format: PixelFormat::Mono8,
                noise_seed: index as u64,
            })
        })
        .collect()
}

fn detect(c: &mut Criterion) {
    let frames = frames();
    let grays: Vec<Gray> = frames
        .iter()
        .map(|f| Gray::from_image(f).expect("valid frame"))
        .collect();
    let detector =
        ChessboardDetector::new(board::Chessboard::new(9, 6, 0.04).expect("valid board"))
            .expect("valid detector");
    for (index, gray) in grays.iter().enumerate() {
        assert!(
            detector.detect_gray(gray).is_some(),
            "frame {index} not detected"
        );
    }
    let mut group = c.benchmark_group("detect_chessboard_1280x720");
    group.throughput(Throughput::Elements(grays.len() as u64));
    group.bench_function("frames", |b| {
        b.iter(|| {
            for gray in &grays {
                black_box(detector.detect_gray(black_box(gray)));
            }
        })
    });
    group.finish();
}

criterion_group!(benches, detect);
criterion_main!(benches);
