//! Solves two-view geometry problems with `vision::geometry` and prints the results with
//! the time per call, for the side by side comparison with OpenCV's findHomography,
//! findFundamentalMat, findEssentialMat, recoverPose, triangulatePoints and
//! correctMatches (`interop/check_geometry_opencv.py`).
//!
//! ```text
//! geometry_solve PROBLEMS.json [--repeats N] [--calls N]
//! ```
//!
//! PROBLEMS.json: `{"camera": {"width", "height", "fx", "fy", "cx", "cy"}, "problems":
//! [..]}` (a distortion-free camera for both views; pixel centres at integer
//! coordinates). Each problem has a `name`, `points_a` and `points_b` (`[[u, v], ..]`)
//! and a `kind`:
//! - `"homography"`: `find_homography` with RANSAC (`ransac`: `{"threshold",
//!   "confidence", "max_iterations"}`) and with LMedS (`lmeds`: `{"confidence",
//!   "max_iterations"}`);
//! - `"scene"`: `find_fundamental` with RANSAC (`fundamental`, options as above),
//!   `find_essential` with RANSAC (`essential`) followed by `recover_pose` on its
//!   inliers (`max_distance`);
//! - `"eight_point"`: `fundamental_8point` on all points;
//! - `"triangulate"`: `triangulate_linear` with `projection_a`, `projection_b` (3x4,
//!   row-major) and `correct_matches` with `fundamental` (3x3, row-major).
//!
//! Each solver is timed in `--repeats` batches of `--calls` calls after one untimed
//! batch, on one thread; printed as JSON per problem and solver: the median time per
//! call, the matrices (row-major), inlier masks, iteration counts, poses, points.

use std::path::PathBuf;
use std::time::Instant;

use anyhow::{Context, Result, anyhow, bail};
use nalgebra::{Matrix3, Matrix3x4, Point2};
use serde::Deserialize;
use serde_json::{Value, json};
use stereocal_vision::camera::{CameraModel, Distortion, Intrinsics};
use stereocal_vision::geometry::{
    RobustOptions, correct_matches, find_essential, find_fundamental, find_homography,
    fundamental_8point, recover_pose, triangulate_linear,
};

#[derive(Deserialize)]
struct Camera {
    width: u32,
    height: u32,
    fx: f64,
    fy: f64,
    cx: f64,
    cy: f64,
}

#[derive(Deserialize)]
struct Robust {
    #[serde(default)]
    threshold: f64,
    confidence: f64,
    max_iterations: usize,
}

#[derive(Deserialize)]
struct Problem {
    name: String,
    kind: String,
    points_a: Vec<[f64; 2]>,
    points_b: Vec<[f64; 2]>,
    ransac: Option<Robust>,
    lmeds: Option<Robust>,
    fundamental: Option<Robust>,
    essential: Option<Robust>,
    max_distance: Option<f64>,
    projection_a: Option<[f64; 12]>,
    projection_b: Option<[f64; 12]>,
    fundamental_matrix: Option<[f64; 9]>,
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
        repeats: 5,
        calls: 20,
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
        .ok_or_else(|| anyhow!("usage: geometry_solve PROBLEMS.json [--repeats N] [--calls N]"))?;
    if args.repeats == 0 || args.calls == 0 {
        bail!("--repeats and --calls must be at least 1");
    }
    Ok(args)
}

/// The median over `repeats` batches of the time per call of `f`, after one untimed
/// batch, and its last result.
fn timed<T>(args: &Args, mut f: impl FnMut() -> Result<T>) -> Result<(f64, T)> {
    let mut last = f()?;
    let mut batches = Vec::with_capacity(args.repeats);
    for batch in 0..=args.repeats {
        let start = Instant::now();
        for _ in 0..args.calls {
            last = std::hint::black_box(f()?);
        }
        if batch > 0 {
            batches.push(start.elapsed().as_secs_f64() / args.calls as f64);
        }
    }
    batches.sort_by(f64::total_cmp);
    Ok((batches[batches.len() / 2], last))
}

fn robust(options: &Option<Robust>, lmeds: bool, what: &str) -> Result<RobustOptions> {
    let o = options
        .as_ref()
        .ok_or_else(|| anyhow!("the problem has no {what} options"))?;
    let base = if lmeds {
        RobustOptions::lmeds()
    } else {
        RobustOptions::ransac(o.threshold)
    };
    Ok(RobustOptions {
        confidence: o.confidence,
        max_iterations: o.max_iterations,
        ..base
    })
}

fn rows(m: &Matrix3<f64>) -> Vec<f64> {
    m.transpose().as_slice().to_vec()
}

fn mask(inliers: &[bool]) -> Vec<u8> {
    inliers.iter().map(|&i| u8::from(i)).collect()
}

fn points(p: &[[f64; 2]]) -> Vec<Point2<f64>> {
    p.iter().map(|p| Point2::new(p[0], p[1])).collect()
}

fn solve(args: &Args, camera: &CameraModel, problem: &Problem) -> Result<Value> {
    let (a, b) = (points(&problem.points_a), points(&problem.points_b));
    Ok(match problem.kind.as_str() {
        "homography" => {
            let mut out = serde_json::Map::new();
            for (key, options, lmeds) in [
                ("ransac", &problem.ransac, false),
                ("lmeds", &problem.lmeds, true),
            ] {
                let options = robust(options, lmeds, key)?;
                let (seconds, h) = timed(args, || Ok(find_homography(&a, &b, &options)?))?;
                out.insert(
                    key.into(),
                    json!({"seconds": seconds, "matrix": rows(&h.image_b_from_image_a),
                           "inliers": mask(&h.inliers), "iterations": h.iterations,
                           "rms_px": h.rms_px}),
                );
            }
            Value::Object(out)
        }
        "scene" => {
            let f_options = robust(&problem.fundamental, false, "fundamental")?;
            let (f_seconds, f) = timed(args, || Ok(find_fundamental(&a, &b, &f_options)?))?;
            let e_options = robust(&problem.essential, false, "essential")?;
            let (e_seconds, e) = timed(args, || {
                Ok(find_essential(camera, &a, camera, &b, &e_options)?)
            })?;
            let max_distance = problem.max_distance.unwrap_or(50.0);
            let (pose_seconds, pose) = timed(args, || {
                Ok(recover_pose(
                    &e.essential,
                    camera,
                    &a,
                    camera,
                    &b,
                    Some(&e.inliers),
                    max_distance,
                )?)
            })?;
            let rotation = pose.camera_b_from_camera_a.rotation.to_rotation_matrix();
            json!({
                "fundamental": {"seconds": f_seconds, "matrix": rows(&f.fundamental),
                                "inliers": mask(&f.inliers), "iterations": f.iterations,
                                "rms_px": f.rms_px},
                "essential": {"seconds": e_seconds, "matrix": rows(&e.essential),
                              "inliers": mask(&e.inliers), "iterations": e.iterations,
                              "rms_px": e.rms_px},
                "recover_pose": {"seconds": pose_seconds,
                                 "rotation": rows(rotation.matrix()),
                                 "translation": pose.camera_b_from_camera_a.translation.vector.as_slice(),
                                 "inliers": mask(&pose.inliers),
                                 "inlier_count": pose.inlier_count},
            })
        }
        "eight_point" => {
            let (seconds, f) = timed(args, || Ok(fundamental_8point(&a, &b)?))?;
            json!({"eight_point": {"seconds": seconds, "matrix": rows(&f)}})
        }
        "triangulate" => {
            let projection = |p: &Option<[f64; 12]>| -> Result<Matrix3x4<f64>> {
                Ok(Matrix3x4::from_row_slice(
                    p.as_ref()
                        .ok_or_else(|| anyhow!("a projection is missing"))?,
                ))
            };
            let (pa, pb) = (
                projection(&problem.projection_a)?,
                projection(&problem.projection_b)?,
            );
            let f = Matrix3::from_row_slice(
                problem
                    .fundamental_matrix
                    .as_ref()
                    .ok_or_else(|| anyhow!("the fundamental matrix is missing"))?,
            );
            let (t_seconds, triangulated) =
                timed(args, || Ok(triangulate_linear(&pa, &pb, &a, &b)?))?;
            let (c_seconds, corrected) = timed(args, || Ok(correct_matches(&f, &a, &b)?))?;
            let triangulated: Vec<Value> = triangulated
                .iter()
                .map(|t| match t {
                    Some(t) => json!({"point": t.point.coords.as_slice(),
                                      "error_a_px": t.error_a_px, "error_b_px": t.error_b_px}),
                    None => Value::Null,
                })
                .collect();
            let pairs =
                |p: &[Point2<f64>]| -> Vec<[f64; 2]> { p.iter().map(|p| [p.x, p.y]).collect() };
            json!({
                "triangulate": {"seconds": t_seconds, "points": triangulated},
                "correct_matches": {"seconds": c_seconds,
                                    "points_a": pairs(&corrected.points_a),
                                    "points_b": pairs(&corrected.points_b)},
            })
        }
        other => bail!("unknown problem kind {other}"),
    })
}

fn main() -> Result<()> {
    let args = parse_args()?;
    let text = std::fs::read_to_string(&args.problems)
        .with_context(|| format!("cannot read {}", args.problems.display()))?;
    let input: Problems = serde_json::from_str(&text)
        .with_context(|| format!("{} is not a problems file", args.problems.display()))?;
    let camera = CameraModel {
        width: input.camera.width,
        height: input.camera.height,
        intrinsics: Intrinsics {
            fx: input.camera.fx,
            fy: input.camera.fy,
            cx: input.camera.cx,
            cy: input.camera.cy,
        },
        distortion: Distortion::none(),
    };
    // The solvers run on the calling thread; the one-thread pool keeps them so should
    // anything inside ever reach for rayon.
    let pool = rayon::ThreadPoolBuilder::new().num_threads(1).build()?;
    let mut report = Vec::new();
    for problem in &input.problems {
        let results = pool
            .install(|| solve(&args, &camera, problem))
            .with_context(|| format!("problem {}", problem.name))?;
        report.push(json!({"name": problem.name, "results": results}));
    }
    println!(
        "{}",
        json!({"threads": 1, "calls": args.calls, "repeats": args.repeats, "problems": report})
    );
    Ok(())
}
