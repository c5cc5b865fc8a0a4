//! Undistorts/rectifies one PNG image (mono8, mono16 or rgb8) through a camera_info's
//! K, D, R, P, for comparing stereocal's maps and remap with other implementations
//! (`interop/check_remap_opencv.py`) and for timing them (`interop/bench_remap_opencv.py`).
//!
//! ```text
//! cargo run --release -p stereocal-vision --example remap_image -- PARAMS.json INPUT.png OUTPUT.png [--map MAP.bin]
//! cargo run --release -p stereocal-vision --example remap_image -- PARAMS.json INPUT.png --bench N [--threads 1|all]
//! ```
//!
//! PARAMS.json holds the camera_info fields and the remap settings:
//! `{"width": 640, "height": 480, "distortion_model": "plumb_bob", "K": [9 values],
//! "D": [...], "R": [9 values], "P": [12 values], "interpolation": "bilinear"}`
//! (`interpolation`: `nearest`, `bilinear` or `bicubic`). `--map` also writes the map as
//! raw little-endian OpenCV `CV_16SC2` then `CV_16UC1` planes. `--bench N` builds the map
//! N times and remaps N times, on one thread (`--threads 1`: the map in a rayon pool of
//! one thread, the remap with `Parallelism::Single`) or on all of the rayon pool's
//! threads (`--threads all`, the default), and prints one JSON line with the median and
//! minimum map building and remap times in milliseconds.

use std::error::Error;
use std::time::Instant;

use nalgebra::{Matrix3, Matrix3x4};
use serde_json::Value;
use stereocal_vision::camera::{CameraModel, Distortion, DistortionModel, Intrinsics};
use stereocal_vision::image::{Image, Samples};
use stereocal_vision::rectify::{
    Interpolation, MapError, Parallelism, RectifyMap, RemapOptions, remap, remap_into,
};

type Result<T> = std::result::Result<T, Box<dyn Error>>;

fn numbers(params: &Value, key: &str, len: Option<usize>) -> Result<Vec<f64>> {
    let values = params[key]
        .as_array()
        .ok_or_else(|| format!("params: `{key}` must be an array of numbers"))?
        .iter()
        .map(|v| {
            v.as_f64()
                .ok_or_else(|| format!("params: `{key}` holds a non-number"))
        })
        .collect::<std::result::Result<Vec<f64>, String>>()?;
    match len {
        Some(n) if values.len() != n => {
            Err(format!("params: `{key}` needs {n} values, got {}", values.len()).into())
        }
        _ => Ok(values),
    }
}

fn size(params: &Value, key: &str) -> Result<usize> {
    params[key]
        .as_u64()
        .and_then(|v| usize::try_from(v).ok())
        .ok_or_else(|| format!("params: `{key}` must be a non-negative integer").into())
}

/// What the parameter file describes: a camera_info and the remap settings.
struct Params {
    camera: CameraModel,
    r: Matrix3<f64>,
    p: Matrix3x4<f64>,
    interpolation: Interpolation,
}

impl Params {
    /// The undistort/rectify map of the camera_info, at the camera's size.
    fn map(&self) -> std::result::Result<RectifyMap, MapError> {
        let (width, height) = (self.camera.width as usize, self.camera.height as usize);
        RectifyMap::new(&self.camera, &self.r, &self.p, width, height)
    }
}

/// Reads the parameter file at `path`.
fn load_params(path: &str) -> Result<Params> {
    let params: Value = serde_json::from_str(&std::fs::read_to_string(path)?)?;
    let (width, height) = (size(&params, "width")?, size(&params, "height")?);
    let model_name = params["distortion_model"]
        .as_str()
        .ok_or("params: `distortion_model` must be a string")?;
    let model = DistortionModel::from_ros_name(model_name)
        .ok_or_else(|| format!("params: unknown distortion_model `{model_name}`"))?;
    let d = numbers(&params, "D", None)?;
    let distortion = Distortion::from_coeffs(model, &d)
        .ok_or_else(|| format!("params: too many coefficients for {model_name}"))?;
    let k = Matrix3::from_row_slice(&numbers(&params, "K", Some(9))?);
    let r = Matrix3::from_row_slice(&numbers(&params, "R", Some(9))?);
    let p = Matrix3x4::from_row_slice(&numbers(&params, "P", Some(12))?);
    let interpolation = match params["interpolation"].as_str().unwrap_or("bilinear") {
        "nearest" => Interpolation::Nearest,
        "bilinear" => Interpolation::Bilinear,
        "bicubic" => Interpolation::Bicubic,
        other => return Err(format!("params: unknown interpolation `{other}`").into()),
    };
    let camera = CameraModel {
        width: u32::try_from(width)?,
        height: u32::try_from(height)?,
        intrinsics: Intrinsics::from_matrix(&k),
        distortion,
    };
    Ok(Params {
        camera,
        r,
        p,
        interpolation,
    })
}

fn read_png(path: &str) -> Result<Image> {
    let decoded = image::open(path)?;
    let (width, height) = (decoded.width() as usize, decoded.height() as usize);
    Ok(match decoded {
        image::DynamicImage::ImageLuma8(i) => {
            Image::new(width, height, 1, Samples::U8(i.into_raw()))?
        }
        image::DynamicImage::ImageRgb8(i) => {
            Image::new(width, height, 3, Samples::U8(i.into_raw()))?
        }
        image::DynamicImage::ImageLuma16(i) => {
            Image::new(width, height, 1, Samples::U16(i.into_raw()))?
        }
        other => {
            return Err(format!("{path}: unsupported PNG color type {:?}", other.color()).into());
        }
    })
}

fn write_png(path: &str, out: Image) -> Result<()> {
    let (w, h) = (u32::try_from(out.width)?, u32::try_from(out.height)?);
    let decoded = match (out.channels, out.samples) {
        (1, Samples::U8(v)) => image::GrayImage::from_raw(w, h, v).map(image::DynamicImage::from),
        (3, Samples::U8(v)) => image::RgbImage::from_raw(w, h, v).map(image::DynamicImage::from),
        (1, Samples::U16(v)) => image::ImageBuffer::<image::Luma<u16>, _>::from_raw(w, h, v)
            .map(image::DynamicImage::from),
        _ => None,
    }
    .ok_or("output image has an unsupported layout")?;
    decoded.save(path)?;
    Ok(())
}

fn write_map(path: &str, map: &RectifyMap) -> Result<()> {
    let mut bytes = Vec::with_capacity(map.xy().len() * 6);
    for [x, y] in map.xy() {
        bytes.extend_from_slice(&x.to_le_bytes());
        bytes.extend_from_slice(&y.to_le_bytes());
    }
    for f in map.fraction() {
        bytes.extend_from_slice(&f.to_le_bytes());
    }
    std::fs::write(path, bytes)?;
    Ok(())
}

/// The median and minimum of `times`, in place.
fn median_and_min(times: &mut [f64]) -> (f64, f64) {
    times.sort_by(f64::total_cmp);
    (times[times.len() / 2], times[0])
}

fn bench(
    src: &Image,
    params_path: &str,
    iterations: usize,
    parallelism: Parallelism,
) -> Result<()> {
    let threads = match parallelism {
        Parallelism::Single => 1,
        Parallelism::Rayon => rayon::current_num_threads(),
    };
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()?;
    let iterations = iterations.max(1);
    let params = load_params(params_path)?;
    let mut map = params.map()?;
    let mut map_times = Vec::with_capacity(iterations);
    for _ in 0..iterations {
        let start = Instant::now();
        // Built in the pool, so that one thread means one thread; the previous map is
        // dropped outside the timed region.
        let built = pool.install(|| params.map())?;
        map_times.push(start.elapsed().as_secs_f64() * 1e3);
        map = built;
    }
    let options = RemapOptions {
        interpolation: params.interpolation,
        parallelism,
    };
    let mut dst = remap(src, &map, options)?;
    let mut times = Vec::with_capacity(iterations);
    for _ in 0..iterations {
        let start = Instant::now();
        pool.install(|| remap_into(src, &map, &mut dst, options))?;
        times.push(start.elapsed().as_secs_f64() * 1e3);
    }
    let (map_median, map_min) = median_and_min(&mut map_times);
    let (remap_median, remap_min) = median_and_min(&mut times);
    println!(
        "{{\"map_ms_median\": {map_median:.4}, \"map_ms_min\": {map_min:.4}, \"remap_ms_median\": {remap_median:.4}, \"remap_ms_min\": {remap_min:.4}, \"iterations\": {iterations}}}"
    );
    Ok(())
}

fn main() -> Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let usage = "usage: remap_image PARAMS.json INPUT.png (OUTPUT.png [--map MAP.bin] | --bench N [--threads 1|all])";
    let [params_path, input, rest @ ..] = args.as_slice() else {
        return Err(usage.into());
    };
    let src = read_png(input)?;
    match rest {
        [flag, n, more @ ..] if flag == "--bench" => {
            let iterations: usize = n.parse().map_err(|_| usage)?;
            let parallelism = match more {
                [] => Parallelism::Rayon,
                [t, v] if t == "--threads" && v == "all" => Parallelism::Rayon,
                [t, v] if t == "--threads" && v == "1" => Parallelism::Single,
                _ => return Err(usage.into()),
            };
            bench(&src, params_path, iterations, parallelism)
        }
        [output, more @ ..] => {
            let params = load_params(params_path)?;
            let map = params.map()?;
            if let [flag, map_path] = more {
                if flag != "--map" {
                    return Err(usage.into());
                }
                write_map(map_path, &map)?;
            } else if !more.is_empty() {
                return Err(usage.into());
            }
            let out = remap(
                &src,
                &map,
                RemapOptions {
                    interpolation: params.interpolation,
                    parallelism: Parallelism::Rayon,
                },
            )?;
            write_png(output, out)
        }
        [] => Err(usage.into()),
    }
}
