//! How long a 1920x1080 bilinear remap takes right after the thread was idle, against
//! back to back: what a node sees at a camera's frame rate, where every frame follows
//! a pause, and what a benchmark loop sees.
//!
//! The map undistorts a plumb_bob camera (f 1400 px, k1 -0.25) into f 1300 px. For each
//! idle gap, `--samples` remaps each follow a sleep of that length and the median is
//! printed, for one thread and for the whole rayon pool, mono8 and rgb8.
//!
//! cargo run --release -p stereocal-vision --example remap_after_idle -- [--samples 30]

use std::error::Error;
use std::time::{Duration, Instant};

use nalgebra::{Matrix3, Matrix3x4};
use stereocal_vision::camera::{CameraModel, Distortion, DistortionModel, Intrinsics};
use stereocal_vision::rectify::{
    Interpolation, Parallelism, RectifyMap, RemapOptions, remap_u8_into,
};

const WIDTH: usize = 1920;
const HEIGHT: usize = 1080;
/// Idle gaps before a remap, in milliseconds (33 is a 30 Hz camera's period).
const GAPS_MS: [u64; 5] = [0, 3, 10, 20, 33];

fn undistort_map() -> Result<RectifyMap, Box<dyn Error>> {
    let camera_matrix = Matrix3::new(1400.0, 0.0, 960.0, 0.0, 1400.0, 540.0, 0.0, 0.0, 1.0);
    let distortion =
        Distortion::from_coeffs(DistortionModel::PlumbBob, &[-0.25, 0.1, 0.001, -0.001, 0.0])
            .ok_or("plumb_bob takes five coefficients")?;
    let camera = CameraModel {
        width: WIDTH as u32,
        height: HEIGHT as u32,
        intrinsics: Intrinsics::from_matrix(&camera_matrix),
        distortion,
    };
    let projection = Matrix3x4::new(
        1300.0, 0.0, 960.0, 0.0, 0.0, 1300.0, 540.0, 0.0, 0.0, 0.0, 1.0, 0.0,
    );
    Ok(RectifyMap::new(
        &camera,
        &Matrix3::identity(),
        &projection,
        WIDTH,
        HEIGHT,
    )?)
}

fn median(mut times: Vec<f64>) -> f64 {
    times.sort_by(f64::total_cmp);
    times[times.len() / 2]
}

fn main() -> Result<(), Box<dyn Error>> {
    let mut samples = 30;
    let mut args = std::env::args().skip(1);
    while let Some(arg) = args.next() {
        match (arg.as_str(), args.next()) {
            ("--samples", Some(n)) => samples = n.parse::<usize>()?.max(1),
            _ => return Err(format!("usage: remap_after_idle [--samples N], got `{arg}`").into()),
        }
    }
    let map = undistort_map()?;
    println!(
        "1920x1080 bilinear remap, median ms over {samples} remaps each after an idle gap; \
         pool of {} threads",
        rayon::current_num_threads()
    );
    print!("{:24}", "gap before each remap");
    for gap in GAPS_MS {
        print!(" {:>7}", format!("{gap} ms"));
    }
    println!();
    for channels in [1, 3] {
        let len = WIDTH * HEIGHT * channels;
        let src: Vec<u8> = (0..len).map(|i| (i * 7 % 251) as u8).collect();
        let mut dst = vec![0u8; len];
        for (label, parallelism) in [
            ("1 thread", Parallelism::Single),
            ("pool", Parallelism::Rayon),
        ] {
            let options = RemapOptions {
                interpolation: Interpolation::Bilinear,
                parallelism,
            };
            let encoding = if channels == 1 { "mono8" } else { "rgb8" };
            print!("{:24}", format!("{encoding}, {label}"));
            for gap in GAPS_MS {
                let mut times = Vec::with_capacity(samples);
                for _ in 0..samples {
                    std::thread::sleep(Duration::from_millis(gap));
                    let started = Instant::now();
                    remap_u8_into(&src, WIDTH, HEIGHT, channels, &map, &mut dst, options)?;
                    times.push(started.elapsed().as_secs_f64() * 1e3);
                }
                print!(" {:7.2}", median(times));
            }
            println!();
        }
    }
    Ok(())
}
