//! Remap and map building on a 1920x1080 undistort/rectify map (plumb_bob, a small
//! rectification rotation), mono8 and rgb8, one thread and all threads of the rayon
//! pool (map building on one thread: in a rayon pool of one thread). The camera is `cases(1920, 1080)` of `interop/check_remap_opencv.py`, which
//! `interop/bench_remap_opencv.py` times against OpenCV side by side.
// A benchmark on fixed inputs: an input that fails is a bug to see at once.
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

use criterion::{Criterion, criterion_group, criterion_main};
use nalgebra::{Matrix3, Matrix3x4, Rotation3, Vector3};
use std::hint::black_box;
use stereocal_vision::camera::{CameraModel, Distortion, Intrinsics};
use stereocal_vision::image::{Image, Samples};
use stereocal_vision::rectify::{Interpolation, Parallelism, RectifyMap, RemapOptions, remap_into};

const WIDTH: usize = 1920;
const HEIGHT: usize = 1080;

fn camera(distortion: Distortion) -> CameraModel {
    CameraModel {
        width: WIDTH as u32,
        height: HEIGHT as u32,
        intrinsics: Intrinsics {
            fx: 1260.0,
            fy: 1254.0,
            cx: 967.5,
            cy: 542.925,
        },
        distortion,
    }
}

fn plumb_bob() -> CameraModel {
    camera(Distortion::PlumbBob {
        coeffs: [-0.29, 0.095, 0.0012, -0.0008, -0.014],
    })
}

fn rectification() -> (Matrix3<f64>, Matrix3x4<f64>) {
    let r = *Rotation3::new(Vector3::new(0.012, -0.021, 0.004)).matrix();
    let p = Matrix3x4::new(
        1200.0, 0.0, 954.0, -120.0, //
        0.0, 1200.0, 549.0, 0.0, //
        0.0, 0.0, 1.0, 0.0,
    );
    (r, p)
}

fn texture(channels: usize) -> Image {
    let samples = (0..WIDTH * HEIGHT * channels)
        .map(|i| {
            let (x, y, c) = ((i / channels) % WIDTH, i / channels / WIDTH, i % channels);
            ((x * 7 + y * 13 + c * 50) ^ (x * y)) as u8
        })
        .collect();
    Image::new(WIDTH, HEIGHT, channels, Samples::U8(samples)).expect("sizes agree")
}

fn bench_remap(c: &mut Criterion) {
    let (r, p) = rectification();
    let map = RectifyMap::new(&plumb_bob(), &r, &p, WIDTH, HEIGHT).expect("valid camera");
    let mut group = c.benchmark_group("remap_1920x1080");
    for (name, channels) in [("mono8", 1), ("rgb8", 3)] {
        let src = texture(channels);
        let mut dst = Image::zeros_u8(WIDTH, HEIGHT, channels);
        for (interpolation_name, interpolation) in [
            ("bilinear", Interpolation::Bilinear),
            ("nearest", Interpolation::Nearest),
        ] {
            for (threads, parallelism) in [
                ("1_thread", Parallelism::Single),
                ("all_threads", Parallelism::Rayon),
            ] {
                let options = RemapOptions {
                    interpolation,
                    parallelism,
                };
                group.bench_function(format!("{name}/{interpolation_name}/{threads}"), |b| {
                    b.iter(|| {
                        remap_into(black_box(&src), &map, &mut dst, options).expect("shapes agree")
                    })
                });
            }
        }
    }
    group.finish();
}

fn bench_map(c: &mut Criterion) {
    let (r, p) = rectification();
    let mut group = c.benchmark_group("map_1920x1080");
    let models = [
        ("plumb_bob", plumb_bob()),
        (
            "equidistant",
            camera(Distortion::Equidistant {
                coeffs: [-0.013, 0.0045, -0.0021, 0.0004],
            }),
        ),
    ];
    let one_thread = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .expect("a thread pool");
    for (name, model) in models {
        group.bench_function(format!("{name}/1_thread"), |b| {
            b.iter(|| {
                one_thread.install(|| {
                    RectifyMap::new(black_box(&model), &r, &p, WIDTH, HEIGHT).expect("valid camera")
                })
            })
        });
        group.bench_function(format!("{name}/all_threads"), |b| {
            b.iter(|| {
                RectifyMap::new(black_box(&model), &r, &p, WIDTH, HEIGHT).expect("valid camera")
            })
        });
    }
    group.finish();
}

criterion_group! {
    name = benches;
    config = Criterion::default().sample_size(30);
    targets = bench_remap, bench_map
}
criterion_main!(benches);
