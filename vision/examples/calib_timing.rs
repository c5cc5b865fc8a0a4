//! Times chessboard detection and the mono solve on given images, for the side by
//! side comparison with OpenCV (`interop/bench_calibrate_opencv.py`).
//!
//! ```text
//! calib_timing detect --size 9x6 [--repeats N] [--threads N] [--corners out.json] image.png...
//! calib_timing mono --corners corners.json [--repeats N] [--threads N]
//! calib_timing stereo --corners corners.json [--repeats N] [--threads N]
//! ```
//!
//! `detect` decodes every image first (decoding is not timed), then detects the board
//! in each: with `--threads 1` one image after the other on one thread, otherwise the
//! images spread over a pool of that many threads (0: one per core). It prints JSON:
//! the median over the repeats of the mean time per image, with one thread also each
//! image's median time, and which images had the board.
//! `--corners` writes the corners found (pixel centres at integer coordinates) with
//! the board's points (in squares), the input of `mono` and `stereo`. Images are named
//! `<camera>_<frame>`. `mono` times `calibrate_mono` (plumb_bob, every view kept, as
//! cv2.calibrateCamera) on each camera's views of such a file; `stereo` times
//! `calibrate_stereo` with those intrinsics held (as cv2.stereoCalibrate with
//! CALIB_FIX_INTRINSIC, every pair kept) on the frames found by `left` and `right`.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{Context, Result, anyhow, bail};
use nalgebra::{Point2, Point3};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use stereocal_vision::board::{self, ChessboardDetector, Gray, TargetDetector};
use stereocal_vision::calib::{
    MonoOptions, StereoOptions, StereoView, View, calibrate_mono, calibrate_stereo,
};
use stereocal_vision::camera::DistortionModel;

/// Corners of a set of images, keyed by image file stem; `None` where the board was
/// not found.
#[derive(Serialize, Deserialize)]
struct Corners {
    image_size: [u32; 2],
    object_points: Vec<[f64; 3]>,
    images: BTreeMap<String, Option<Vec<[f64; 2]>>>,
}

struct Args {
    command: String,
    size: Option<String>,
    repeats: usize,
    threads: usize,
    corners: Option<PathBuf>,
    images: Vec<PathBuf>,
}

fn parse_args() -> Result<Args> {
    let mut raw = std::env::args().skip(1);
    let command = raw
        .next()
        .ok_or_else(|| anyhow!("expected a command: detect, mono or stereo"))?;
    let mut args = Args {
        command,
        size: None,
        repeats: 5,
        threads: 1,
        corners: None,
        images: Vec::new(),
    };
    while let Some(arg) = raw.next() {
        let mut value = || raw.next().ok_or_else(|| anyhow!("{arg} needs a value"));
        match arg.as_str() {
            "--size" => args.size = Some(value()?),
            "--repeats" => args.repeats = value()?.parse().context("--repeats")?,
            "--threads" => args.threads = value()?.parse().context("--threads")?,
            "--corners" => args.corners = Some(PathBuf::from(value()?)),
            _ if arg.starts_with("--") => bail!("unknown option {arg}"),
            _ => args.images.push(PathBuf::from(arg)),
        }
    }
    if args.repeats == 0 {
        bail!("--repeats must be at least 1");
    }
    Ok(args)
}

fn median(mut values: Vec<f64>) -> f64 {
    values.sort_by(f64::total_cmp);
    values[values.len() / 2]
}

fn load_gray(path: &Path) -> Result<Gray> {
    let decoded = image::open(path)
        .with_context(|| format!("cannot read {}", path.display()))?
        .into_luma8();
    Ok(Gray {
        width: decoded.width() as usize,
        height: decoded.height() as usize,
        data: decoded.into_raw(),
    })
}

fn detect(args: &Args, pool: &rayon::ThreadPool) -> Result<()> {
    let size = args
        .size
        .as_deref()
        .ok_or_else(|| anyhow!("--size COLSxROWS is required"))?;
    let (cols, rows) = board::parse_size(size)?;
    let chessboard = board::Chessboard::new(cols, rows, 1.0)?;
    let detector = ChessboardDetector::new(chessboard)?;
    if args.images.is_empty() {
        bail!("no images given");
    }
    let grays = args
        .images
        .iter()
        .map(|p| load_gray(p))
        .collect::<Result<Vec<_>>>()?;
    // A first pass untimed, as the repeats find the allocator and caches warm.
    pool.install(|| grays.iter().for_each(|g| drop(detector.detect_gray(g))));
    // One thread: each image timed on its own. More: the batch, spread over the pool.
    let mut found = Vec::new();
    let mut per_image = Vec::new();
    let mut each: Vec<Vec<f64>> = vec![Vec::new(); grays.len()];
    for _ in 0..args.repeats {
        let start = Instant::now();
        found = if args.threads == 1 {
            pool.install(|| {
                grays
                    .iter()
                    .zip(&mut each)
                    .map(|(gray, times)| {
                        let start = Instant::now();
                        let detection = detector.detect_gray(gray);
                        times.push(start.elapsed().as_secs_f64());
                        detection
                    })
                    .collect()
            })
        } else {
            pool.install(|| grays.par_iter().map(|g| detector.detect_gray(g)).collect())
        };
        per_image.push(start.elapsed().as_secs_f64() / grays.len() as f64);
    }
    if let Some(path) = &args.corners {
        let images = args
            .images
            .iter()
            .zip(&found)
            .map(|(path, detection)| {
                let name = path
                    .file_stem()
                    .map(|s| s.to_string_lossy().into_owned())
                    .unwrap_or_default();
                let corners = detection
                    .as_ref()
                    .map(|d| d.corners.iter().map(|p| [p.x, p.y]).collect());
                (name, corners)
            })
            .collect();
        let corners = Corners {
            image_size: [grays[0].width as u32, grays[0].height as u32],
            object_points: detector
                .target()
                .object_points()
                .iter()
                .map(|p| [p.x, p.y, p.z])
                .collect(),
            images,
        };
        std::fs::write(path, serde_json::to_string(&corners)?)
            .with_context(|| format!("cannot write {}", path.display()))?;
    }
    let detected: Vec<bool> = found.iter().map(Option::is_some).collect();
    println!(
        "{}",
        serde_json::json!({
            "images": grays.len(),
            "threads": pool.current_num_threads(),
            "seconds_per_image": median(per_image),
            "seconds_each": each.into_iter().filter(|t| !t.is_empty()).map(median).collect::<Vec<_>>(),
            "detected": detected,
        })
    );
    Ok(())
}

/// The corners file of `--corners`, and its board's points.
fn read_corners(args: &Args) -> Result<(Corners, Vec<Point3<f64>>)> {
    let path = args
        .corners
        .as_ref()
        .ok_or_else(|| anyhow!("--corners FILE is required"))?;
    let text =
        std::fs::read_to_string(path).with_context(|| format!("cannot read {}", path.display()))?;
    let corners: Corners = serde_json::from_str(&text)?;
    let points = corners
        .object_points
        .iter()
        .map(|p| Point3::new(p[0], p[1], p[2]))
        .collect();
    Ok((corners, points))
}

/// Each camera's found views by frame: image `left_003` is frame `003` of `left`.
fn views_by_camera(
    corners: &Corners,
    points: &[Point3<f64>],
) -> BTreeMap<String, BTreeMap<String, View>> {
    let mut cameras: BTreeMap<String, BTreeMap<String, View>> = BTreeMap::new();
    for (name, found) in &corners.images {
        let Some(found) = found else { continue };
        let (camera, frame) = name.rsplit_once('_').unwrap_or((name.as_str(), ""));
        cameras.entry(camera.to_owned()).or_default().insert(
            frame.to_owned(),
            View {
                points_in_target: points.to_vec(),
                pixels: found.iter().map(|p| Point2::new(p[0], p[1])).collect(),
            },
        );
    }
    cameras
}

/// OpenCV's calibrateCamera defaults: plumb_bob, every view kept.
fn mono_options() -> MonoOptions {
    MonoOptions {
        rejection: None,
        ..MonoOptions::new(DistortionModel::PlumbBob)
    }
}

/// Median seconds of `repeats` runs of `solve`, and the RMS of the last.
fn time_solve<F>(pool: &rayon::ThreadPool, repeats: usize, solve: F) -> Result<(f64, f64)>
where
    F: Fn() -> Result<f64> + Sync,
{
    let mut seconds = Vec::new();
    let mut rms = 0.0;
    for _ in 0..repeats {
        let start = Instant::now();
        rms = pool.install(&solve)?;
        seconds.push(start.elapsed().as_secs_f64());
    }
    Ok((median(seconds), rms))
}

fn mono(args: &Args, pool: &rayon::ThreadPool) -> Result<()> {
    let (corners, points) = read_corners(args)?;
    let [width, height] = corners.image_size;
    let options = mono_options();
    let mut report = serde_json::Map::new();
    for (camera, views) in views_by_camera(&corners, &points) {
        let views: Vec<View> = views.into_values().collect();
        let (seconds, rms) = time_solve(pool, args.repeats, || {
            Ok(calibrate_mono(&views, width, height, &options)?.rms)
        })?;
        report.insert(
            camera,
            serde_json::json!({"views": views.len(), "seconds": seconds, "rms": rms}),
        );
    }
    println!("{}", serde_json::Value::Object(report));
    Ok(())
}

fn stereo(args: &Args, pool: &rayon::ThreadPool) -> Result<()> {
    let (corners, points) = read_corners(args)?;
    let [width, height] = corners.image_size;
    let cameras = views_by_camera(&corners, &points);
    let (Some(left), Some(right)) = (cameras.get("left"), cameras.get("right")) else {
        bail!("the corners file has no left_* and right_* images");
    };
    let options = mono_options();
    let intrinsics = |views: &BTreeMap<String, View>| {
        let views: Vec<View> = views.values().cloned().collect();
        calibrate_mono(&views, width, height, &options).map(|c| c.camera)
    };
    let (left_camera, right_camera) = (intrinsics(left)?, intrinsics(right)?);
    let pairs: Vec<StereoView> = left
        .iter()
        .filter_map(|(frame, l)| {
            right.get(frame).map(|r| StereoView {
                points_in_target: points.clone(),
                left: l.pixels.clone(),
                right: r.pixels.clone(),
            })
        })
        .collect();
    let fixed = StereoOptions {
        rejection: None,
        ..StereoOptions::default()
    };
    let (seconds, rms) = time_solve(pool, args.repeats, || {
        Ok(calibrate_stereo(&left_camera, &right_camera, &pairs, &fixed)?.rms)
    })?;
    println!(
        "{}",
        serde_json::json!({"pairs": pairs.len(), "seconds": seconds, "rms": rms})
    );
    Ok(())
}

fn main() -> Result<()> {
    let args = parse_args()?;
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(args.threads)
        .build()?;
    match args.command.as_str() {
        "detect" => detect(&args, &pool),
        "mono" => mono(&args, &pool),
        "stereo" => stereo(&args, &pool),
        other => bail!("unknown command {other}: expected detect, mono or stereo"),
    }
}
