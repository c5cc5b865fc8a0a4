//! Times the pose of a target from its pixels, per call, for the side by side
//! comparison with cv2.solvePnP (`interop/bench_pnp_opencv.py`).
//!
//! ```text
//! pnp_timing PROBLEMS.json [--repeats N] [--calls N]
//! ```
//!
//! PROBLEMS.json holds one camera and the problems seen through it:
//! `{"camera": {"width", "height", "fx", "fy", "cx", "cy", "distortion_model",
//! "distortion_coefficients"}, "problems": [{"name", "target_points": [[x, y, z], ..],
//! "pixels": [[u, v], ..]}, ..]}` (metres; pixel centres at integer coordinates).
//! One call is what cv2.solvePnP does from the same input: [`Correspondences::new`]
//! (which undistorts the pixels) and [`estimate_pose`] with the default options.
//! Each problem is timed in `--repeats` batches of `--calls` calls after one untimed
//! batch, on one thread; printed as JSON: per problem the median over the batches of
//! the time per call, and the pose and its RMS error (to check both sides solved the
//! same problem).

use std::path::PathBuf;
use std::time::Instant;

use anyhow::{Context, Result, anyhow, bail};
use nalgebra::{Point2, Point3};
use serde::Deserialize;
use stereocal_vision::camera::{CameraModel, Distortion, DistortionModel, Intrinsics};
use stereocal_vision::pnp::{Correspondences, PoseEstimate, PoseOptions, estimate_pose};

#[derive(Deserialize)]
struct Camera {
    width: u32,
    height: u32,
    fx: f64,
    fy: f64,
    cx: f64,
    cy: f64,
    distortion_model: String,
    distortion_coefficients: Vec<f64>,
}

#[derive(Deserialize)]
struct Problem {
    name: String,
    target_points: Vec<[f64; 3]>,
    pixels: Vec<[f64; 2]>,
}

#[derive(Deserialize)]
struct Problems {
    camera: Camera,
    problems: Vec<Problem>,
}

struct Args {
    problems: PathBuf,
    repeats: usize,
    calls: usize,
}

fn parse_args() -> Result<Args> {
    let mut raw = std::env::args().skip(1);
    let mut problems = None;
    let mut args = Args {
        problems: PathBuf::new(),
        repeats: 7,
        calls: 200,
    };
    while let Some(arg) = raw.next() {
        let mut value = || raw.next().ok_or_else(|| anyhow!("{arg} needs a value"));
        match arg.as_str() {
            "--repeats" => args.repeats = value()?.parse().context("--repeats")?,
            "--calls" => args.calls = value()?.parse().context("--calls")?,
            _ if arg.starts_with("--") => bail!("unknown option {arg}"),
            _ => problems = Some(PathBuf::from(arg)),
        }
    }
    args.problems = problems
        .ok_or_else(|| anyhow!("usage: pnp_timing PROBLEMS.json [--repeats N] [--calls N]"))?;
    if args.repeats == 0 || args.calls == 0 {
        bail!("--repeats and --calls must be at least 1");
    }
    Ok(args)
}

fn median(mut values: Vec<f64>) -> f64 {
    values.sort_by(f64::total_cmp);
    values[values.len() / 2]
}

fn camera_model(camera: &Camera) -> Result<CameraModel> {
    let model = match camera.distortion_model.as_str() {
        "plumb_bob" => DistortionModel::PlumbBob,
        "rational_polynomial" => DistortionModel::RationalPolynomial,
        "equidistant" => DistortionModel::Equidistant,
        other => bail!("unknown distortion model {other}"),
    };
    Ok(CameraModel {
        width: camera.width,
        height: camera.height,
        intrinsics: Intrinsics {
            fx: camera.fx,
            fy: camera.fy,
            cx: camera.cx,
            cy: camera.cy,
        },
        distortion: Distortion::from_coeffs(model, &camera.distortion_coefficients)
            .ok_or_else(|| anyhow!("too many distortion coefficients for {model:?}"))?,
    })
}

/// One call, as cv2.solvePnP makes it: pixels in, pose out.
fn solve(
    camera: &CameraModel,
    points: &[Point3<f64>],
    pixels: &[Point2<f64>],
    options: &PoseOptions,
) -> Result<PoseEstimate> {
    let correspondences = Correspondences::new(camera, points, pixels)?;
    Ok(estimate_pose(camera, &correspondences, options)?)
}

fn main() -> Result<()> {
    let args = parse_args()?;
    let text = std::fs::read_to_string(&args.problems)
        .with_context(|| format!("cannot read {}", args.problems.display()))?;
    let input: Problems = serde_json::from_str(&text)
        .with_context(|| format!("{} is not a problems file", args.problems.display()))?;
    let camera = camera_model(&input.camera)?;
    let options = PoseOptions::default();
    // estimate_pose runs on the calling thread; the one-thread pool keeps it so should
    // anything inside ever reach for rayon.
    let pool = rayon::ThreadPoolBuilder::new().num_threads(1).build()?;
    let mut report = Vec::new();
    for problem in &input.problems {
        let points: Vec<Point3<f64>> = problem
            .target_points
            .iter()
            .map(|p| Point3::new(p[0], p[1], p[2]))
            .collect();
        let pixels: Vec<Point2<f64>> = problem
            .pixels
            .iter()
            .map(|p| Point2::new(p[0], p[1]))
            .collect();
        let estimate = solve(&camera, &points, &pixels, &options)
            .with_context(|| format!("problem {}", problem.name))?;
        let batches = pool.install(|| {
            (0..=args.repeats)
                .map(|_| {
                    let start = Instant::now();
                    for _ in 0..args.calls {
                        std::hint::black_box(solve(
                            &camera,
                            std::hint::black_box(&points),
                            &pixels,
                            &options,
                        )?);
                    }
                    Ok(start.elapsed().as_secs_f64() / args.calls as f64)
                })
                .collect::<Result<Vec<f64>>>()
        })?;
        // The first batch warms caches and the allocator: not counted.
        let seconds = median(batches[1..].to_vec());
        let pose = estimate.camera_from_target;
        let rotation = pose.rotation.to_rotation_matrix();
        report.push(serde_json::json!({
            "name": problem.name,
            "points": points.len(),
            "seconds": seconds,
            "rms": estimate.rms_px,
            "camera_from_target": {
                "rotation": rotation.matrix().transpose().as_slice(),
                "translation": pose.translation.vector.as_slice(),
            },
        }));
    }
    println!(
        "{}",
        serde_json::json!({"threads": 1, "calls": args.calls, "repeats": args.repeats,
                           "problems": report})
    );
    Ok(())
}
