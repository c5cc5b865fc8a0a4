//! Monte-Carlo check of the PnP solvers: counts, over random non-degenerate problems,
//! how often each reaches what it promises. Not a timing bench: a counting program.
//!
//! ```text
//! cargo bench -p stereocal-vision --bench pnp_monte_carlo [-- --problems N] [--seed S]
//! cargo bench -p stereocal-vision --bench pnp_monte_carlo -- --problem I [--seed S]
//! ```
//!
//! Every problem is seen through a distortion-free camera of focal 800 px, its points
//! in a square window of the image from a tenth of the field of view (about 31 degrees
//! off axis) to all of it: a small window is a distant target, the hard case.
//! - **P3P** (`lambda_twist`), exact data: the true pose is among the solutions (the
//!   three points in the camera frame within 1e-6 of their distance to the camera),
//!   and every solution reprojects its own three points within 1e-6 px (focal 800).
//! - **SQPnP**, noisy problems (4 to 50 points, 0.5 px of Gaussian noise; the even
//!   ones spread in depth about as much as across, the odd ones on a plane 1 to 8 m
//!   away tilted up to 70 degrees): its best `squared_error` is at most its objective, minimized over the
//!   translation, at the rotation of every pose found by other means (the truth, EPnP
//!   and, for a plane, both IPPE poses, each refined by `refine`), plus 1e-9 relative:
//!   it reached the global minimum of its own objective.
//! - **estimate_pose**, the same problems: its RMS is at most the least RMS of
//!   `refine` started from the truth and from every solver's pose (SQPnP's minima,
//!   EPnP, IPPE's two), plus 1e-9 px. A pose refused as ambiguous counts when the best
//!   RMS it reports reaches that least RMS; any other refusal while a refined pose
//!   explains the pixels within the bound is a failure.
//!
//! Problem `i` of each part is drawn from its own generator seeded with the seed and
//! `i`, so a failure printed with its index is reproduced alone. The problems run in
//! parallel (rayon); the counts do not depend on the number of threads. Without
//! `--bench` (as `cargo test --benches` runs it) the default is 1000 problems.
//! Exits non-zero when a count shows a failure; `--problem I` then prints noisy problem
//! `I` in full: estimate_pose's result and `refine` from every start, with its
//! iterations, so a missed minimum is told from a refinement that stopped early.
// A benchmark program: a failure is printed and ends the run with a non-zero status.
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

use std::process::ExitCode;
use std::time::Instant;

use nalgebra::{
    Isometry3, Matrix3, Point2, Point3, Quaternion, Rotation3, Translation3, UnitQuaternion,
    Vector3,
};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;
use stereocal_vision::camera::{CameraModel, Distortion, Intrinsics};
use stereocal_vision::pnp::epnp::epnp;
use stereocal_vision::pnp::ippe::ippe;
use stereocal_vision::pnp::p3p::lambda_twist;
use stereocal_vision::pnp::sqpnp::sqpnp;
use stereocal_vision::pnp::{Correspondences, PnpError, PoseOptions, estimate_pose, refine};

/// Focal length of the pinhole camera the problems are seen through, pixels.
const FOCAL: f64 = 800.0;
/// Half the field of view, in normalized image units (about 31 degrees).
const HALF_FIELD: f64 = 0.6;
/// Standard deviation of the pixel noise of parts (b) and (c), pixels.
const NOISE_PX: f64 = 0.5;
/// P3P: largest distance of a solved point from the true one, relative to the true
/// point's distance to the camera, for the true pose to count as found.
const P3P_POSE_TOLERANCE: f64 = 1e-6;
/// P3P: largest reprojection error of a solution on its own points, pixels.
const P3P_REPROJECTION_TOLERANCE_PX: f64 = 1e-6;
/// SQPnP: relative margin on the objective (rounding).
const SQPNP_RELATIVE_TOLERANCE: f64 = 1e-9;
/// estimate_pose: margin on the RMS, pixels.
const RMS_TOLERANCE_PX: f64 = 1e-9;
/// Failing problems printed per part.
const SHOWN: usize = 10;

struct Args {
    problems: usize,
    seed: u64,
    /// Only this noisy problem, described in full.
    problem: Option<usize>,
}

fn parse_args() -> Args {
    let mut raw = std::env::args().skip(1);
    let mut problems = None;
    let mut seed = 1;
    let mut bench = false;
    let mut problem = None;
    while let Some(arg) = raw.next() {
        match arg.as_str() {
            // cargo bench passes --bench; cargo test --benches does not.
            "--bench" => bench = true,
            "--problems" => {
                problems = Some(raw.next().and_then(|v| v.parse().ok()).unwrap_or_else(|| {
                    panic!("--problems needs a number of problems");
                }));
            }
            "--problem" => {
                problem = Some(
                    raw.next()
                        .and_then(|v| v.parse().ok())
                        .unwrap_or_else(|| panic!("--problem needs a problem index")),
                );
            }
            "--seed" => {
                seed = raw
                    .next()
                    .and_then(|v| v.parse().ok())
                    .unwrap_or_else(|| panic!("--seed needs a number"));
            }
            other => panic!(
                "unknown argument {other}: expected --problems N and --seed S \
                 (cargo bench -p stereocal-vision --bench pnp_monte_carlo -- --problems N)"
            ),
        }
    }
    Args {
        problems: problems.unwrap_or(if bench { 100_000 } else { 1_000 }),
        seed,
        problem,
    }
}

/// The generator of problem `index` of a part.
fn rng_for(seed: u64, part: u64, index: usize) -> ChaCha8Rng {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    rng.set_stream(part << 40 | index as u64);
    rng
}

/// A rotation drawn uniformly (a uniform unit quaternion, by rejection from the ball).
fn random_rotation(rng: &mut ChaCha8Rng) -> UnitQuaternion<f64> {
    loop {
        let q: [f64; 4] = std::array::from_fn(|_| rng.random_range(-1.0..1.0));
        let norm = q.iter().map(|v| v * v).sum::<f64>().sqrt();
        if norm > 0.1 && norm <= 1.0 {
            return UnitQuaternion::from_quaternion(Quaternion::new(q[0], q[1], q[2], q[3]));
        }
    }
}

/// A standard normal sample (Box-Muller).
fn gaussian(rng: &mut ChaCha8Rng) -> f64 {
    let u: f64 = rng.random_range(f64::EPSILON..1.0);
    let v: f64 = rng.random_range(0.0..1.0);
    (-2.0 * u.ln()).sqrt() * (std::f64::consts::TAU * v).cos()
}

/// The part of the image a problem's points are seen in: a square window, a tenth of
/// the field of view to all of it, anywhere in the field. Small windows are the hard
/// cases: a distant target, weakly constraining perspective, a pronounced planar
/// ambiguity.
#[derive(Clone, Copy)]
struct Window {
    centre: (f64, f64),
    half: f64,
}

impl Window {
    fn random(rng: &mut ChaCha8Rng) -> Self {
        let half = HALF_FIELD * rng.random_range(0.1..1.0);
        let free = HALF_FIELD - half;
        let centre = if free > 0.0 {
            (rng.random_range(-free..free), rng.random_range(-free..free))
        } else {
            (0.0, 0.0)
        };
        Self { centre, half }
    }

    /// A normalized image point in the window.
    fn sample(&self, rng: &mut ChaCha8Rng) -> (f64, f64) {
        (
            self.centre.0 + rng.random_range(-self.half..self.half),
            self.centre.1 + rng.random_range(-self.half..self.half),
        )
    }
}

/// A point in the camera frame, seen in `window`, at a depth in `depth`.
fn point_in_view(
    rng: &mut ChaCha8Rng,
    window: &Window,
    depth: std::ops::Range<f64>,
) -> Point3<f64> {
    let (x, y) = window.sample(rng);
    let z = rng.random_range(depth);
    Point3::new(x * z, y * z, z)
}

/// Twice a triangle's area over its longest edge squared: 0 for collinear points,
/// about 0.87 for an equilateral triangle.
fn triangle_shape(a: &Point3<f64>, b: &Point3<f64>, c: &Point3<f64>) -> f64 {
    let longest = [
        (b - a).norm_squared(),
        (c - a).norm_squared(),
        (c - b).norm_squared(),
    ]
    .into_iter()
    .fold(0.0, f64::max);
    (b - a).cross(&(c - a)).norm() / longest
}

/// Singular values of the centred points, largest first.
fn spread(points: &[Point3<f64>]) -> [f64; 3] {
    let centroid = points.iter().map(|p| p.coords).sum::<Vector3<f64>>() / points.len() as f64;
    let scatter = points.iter().fold(Matrix3::zeros(), |acc, p| {
        let d = p.coords - centroid;
        acc + d * d.transpose()
    });
    let mut values: Vec<f64> = scatter
        .symmetric_eigenvalues()
        .iter()
        .map(|v| v.max(0.0).sqrt())
        .collect();
    values.sort_by(|a, b| b.total_cmp(a));
    [values[0], values[1], values[2]]
}

fn camera() -> CameraModel {
    CameraModel {
        width: 1600,
        height: 1200,
        intrinsics: Intrinsics {
            fx: FOCAL,
            fy: FOCAL,
            cx: 800.0,
            cy: 600.0,
        },
        distortion: Distortion::none(),
    }
}

// ---------------------------------------------------------------------------------
// (a) P3P on exact data.

/// Outcome of one P3P problem.
struct P3pOutcome {
    index: usize,
    found_truth: bool,
    solutions: usize,
    inaccurate: usize,
    worst_px: f64,
    nearest: f64,
}

/// Three points in view, not nearly collinear, at least 2 px apart in the image.
fn p3p_problem(seed: u64, index: usize) -> ([Point3<f64>; 3], [Point3<f64>; 3], Isometry3<f64>) {
    let mut rng = rng_for(seed, 1, index);
    loop {
        let window = Window::random(&mut rng);
        let in_camera: [Point3<f64>; 3] =
            std::array::from_fn(|_| point_in_view(&mut rng, &window, 0.5..10.0));
        let image: Vec<Point2<f64>> = in_camera
            .iter()
            .map(|p| Point2::new(p.x / p.z, p.y / p.z) * FOCAL)
            .collect();
        let apart = (0..3).all(|i| (image[i] - image[(i + 1) % 3]).norm() >= 2.0);
        if !apart || triangle_shape(&in_camera[0], &in_camera[1], &in_camera[2]) < 0.05 {
            continue;
        }
        let camera_from_target = Isometry3::from_parts(
            Translation3::new(
                rng.random_range(-2.0..2.0),
                rng.random_range(-2.0..2.0),
                rng.random_range(-2.0..2.0),
            ),
            random_rotation(&mut rng),
        );
        let in_target = in_camera.map(|p| camera_from_target.inverse_transform_point(&p));
        return (in_target, in_camera, camera_from_target);
    }
}

fn p3p_outcome(seed: u64, index: usize) -> P3pOutcome {
    let (in_target, in_camera, _) = p3p_problem(seed, index);
    let rays = in_camera.map(|p| Vector3::new(p.x / p.z, p.y / p.z, 1.0));
    let solutions = lambda_twist(&in_target, &rays);
    let mut outcome = P3pOutcome {
        index,
        found_truth: false,
        solutions: solutions.len(),
        inaccurate: 0,
        worst_px: 0.0,
        nearest: f64::INFINITY,
    };
    for pose in &solutions {
        let mut off_px: f64 = 0.0;
        let mut off_truth: f64 = 0.0;
        for (target, truth) in in_target.iter().zip(&in_camera) {
            let solved = pose * target;
            let projected = Point2::new(solved.x / solved.z, solved.y / solved.z);
            let observed = Point2::new(truth.x / truth.z, truth.y / truth.z);
            // NaN-propagating maxima: a non-finite solution must count as off.
            let px = (projected - observed).norm() * FOCAL;
            if px.is_nan() || px > off_px {
                off_px = px;
            }
            let relative = (solved - truth).norm() / truth.coords.norm();
            if relative.is_nan() || relative > off_truth {
                off_truth = relative;
            }
        }
        outcome.worst_px = outcome.worst_px.max(off_px);
        outcome.nearest = outcome.nearest.min(off_truth);
        if off_px.is_nan() || off_px > P3P_REPROJECTION_TOLERANCE_PX {
            outcome.inaccurate += 1;
        }
        if off_truth <= P3P_POSE_TOLERANCE {
            outcome.found_truth = true;
        }
    }
    outcome
}

// ---------------------------------------------------------------------------------
// (b) and (c): noisy problems, general and planar.

/// A noisy problem: its correspondences, its true pose, and whether it is planar.
struct Problem {
    planar: bool,
    correspondences: Correspondences,
    truth: Isometry3<f64>,
}

/// `n` points seen in a random window around a depth of 2 to 8 m, as deep as they are
/// wide give or take, spread in all three directions; and `camera_from_target`, a
/// random rotation about an origin near the points.
fn general_points(rng: &mut ChaCha8Rng, n: usize) -> (Vec<Point3<f64>>, Isometry3<f64>) {
    loop {
        let window = Window::random(rng);
        let distance = rng.random_range(2.0..8.0);
        let width = window.half * distance;
        let depth = width * rng.random_range(0.3..1.5);
        let near = (distance - depth).max(0.5);
        let points: Vec<Point3<f64>> = (0..n)
            .map(|_| point_in_view(rng, &window, near..distance + depth))
            .collect();
        let [largest, middle, smallest] = spread(&points);
        if middle >= 0.1 * largest && smallest >= 0.05 * largest {
            let centroid = points.iter().map(|p| p.coords).sum::<Vector3<f64>>() / n as f64;
            let offset = Vector3::from_fn(|_, _| rng.random_range(-1.0..1.0)) * width;
            let camera_from_target =
                Isometry3::from_parts(Translation3::from(centroid + offset), random_rotation(rng));
            return (points, camera_from_target);
        }
    }
}

/// `n` points seen in a random window, on a plane 1 to 8 m away tilted up to 70
/// degrees from facing the camera, with the plane's frame (origin off the points'
/// centroid, z its normal): the points in the camera frame and `camera_from_target`.
fn planar_points(rng: &mut ChaCha8Rng, n: usize) -> (Vec<Point3<f64>>, Isometry3<f64>) {
    loop {
        let window = Window::random(rng);
        let distance = rng.random_range(1.0..8.0);
        let centre = Vector3::new(window.centre.0, window.centre.1, 1.0) * distance;
        let tilt = rng.random_range(0.0..70f64.to_radians());
        let azimuth = rng.random_range(0.0..std::f64::consts::TAU);
        // The normal points away from the camera, as a board's z axis seen from the front.
        let toward = centre.normalize();
        let side = toward.cross(&Vector3::x()).normalize();
        let up = toward.cross(&side);
        let normal = (toward * tilt.cos()
            + (side * azimuth.cos() + up * azimuth.sin()) * tilt.sin())
        .normalize();
        let points: Vec<Point3<f64>> = (0..n)
            .filter_map(|_| {
                let (x, y) = window.sample(rng);
                let ray = Vector3::new(x, y, 1.0);
                let s = normal.dot(&centre) / normal.dot(&ray);
                (s > 0.1 && s < 3.0 * distance).then(|| Point3::from(ray * s))
            })
            .collect();
        if points.len() < n {
            continue;
        }
        // Any in-plane axis; y unless the normal is nearly along it.
        let across = if normal.y.abs() < 0.9 {
            Vector3::y()
        } else {
            Vector3::x()
        };
        let e1 = normal.cross(&across).normalize();
        let e2 = normal.cross(&e1);
        let rotation = Rotation3::from_matrix_unchecked(Matrix3::from_columns(&[e1, e2, normal]));
        let width = window.half * distance;
        let origin = centre
            + e1 * rng.random_range(-1.0..1.0) * width
            + e2 * rng.random_range(-1.0..1.0) * width;
        let camera_from_target = Isometry3::from_parts(
            Translation3::from(origin),
            UnitQuaternion::from_rotation_matrix(&rotation),
        );
        let in_target: Vec<Point3<f64>> = points
            .iter()
            .map(|p| camera_from_target.inverse_transform_point(p))
            .collect();
        let [largest, middle, _] = spread(&in_target);
        let triples_ok = n > 4
            || [(0, 1, 2), (0, 1, 3), (0, 2, 3), (1, 2, 3)]
                .iter()
                .all(|&(a, b, c)| {
                    triangle_shape(&in_target[a], &in_target[b], &in_target[c]) >= 0.05
                });
        if middle >= 0.1 * largest && triples_ok {
            return (points, camera_from_target);
        }
    }
}

/// Problem `index`: general for even indices, planar for odd ones, 4 to 50 points.
fn noisy_problem(seed: u64, index: usize, camera: &CameraModel) -> Problem {
    let mut rng = rng_for(seed, 2, index);
    let planar = index % 2 == 1;
    let n = rng.random_range(4..=50usize);
    let (in_camera, truth) = if planar {
        planar_points(&mut rng, n)
    } else {
        general_points(&mut rng, n)
    };
    let target_points: Vec<Point3<f64>> = in_camera
        .iter()
        .map(|p| truth.inverse_transform_point(p))
        .collect();
    let pixels: Vec<Point2<f64>> = in_camera
        .iter()
        .map(|p| {
            let exact = camera.project(p).expect("points in view project");
            Point2::new(
                exact.x + NOISE_PX * gaussian(&mut rng),
                exact.y + NOISE_PX * gaussian(&mut rng),
            )
        })
        .collect();
    let correspondences = Correspondences::new(camera, &target_points, &pixels)
        .expect("finite correspondences of a pinhole camera");
    Problem {
        planar,
        correspondences,
        truth,
    }
}

/// SQPnP's objective at rotation `r`, `sum_i ||B(m_i) (R M_i + t)||^2`, minimized over
/// the translation `t` (linear in `R`), or at `t_own` when that optimal translation
/// puts a point behind the camera.
fn sqpnp_objective(c: &Correspondences, pose: &Isometry3<f64>) -> f64 {
    let rotation = pose.rotation.to_rotation_matrix();
    let q_of = |m: &Point2<f64>| {
        let b = nalgebra::Matrix2x3::new(1.0, 0.0, -m.x, 0.0, 1.0, -m.y);
        b.transpose() * b
    };
    let mut sum_q = Matrix3::zeros();
    let mut sum_qrm = Vector3::zeros();
    for (point, m) in c.target_points.iter().zip(&c.normalized) {
        let q = q_of(m);
        sum_q += q;
        sum_qrm += q * (rotation * point.coords);
    }
    let error_at = |t: &Vector3<f64>| -> Option<f64> {
        let mut sum = 0.0;
        for (point, m) in c.target_points.iter().zip(&c.normalized) {
            let p = rotation * point.coords + t;
            if p.z <= 0.0 {
                return None;
            }
            sum += (p.x - m.x * p.z).powi(2) + (p.y - m.y * p.z).powi(2);
        }
        Some(sum)
    };
    let own = error_at(&pose.translation.vector).unwrap_or(f64::INFINITY);
    let best = sum_q
        .try_inverse()
        .and_then(|inverse| error_at(&(-(inverse * sum_qrm))))
        .unwrap_or(f64::INFINITY);
    own.min(best)
}

/// Outcome of SQPnP on one noisy problem.
enum SqpnpOutcome {
    /// Its best is at most every other pose's objective (plus the tolerance).
    Global,
    /// Another pose's objective is lower: SQPnP's best, the lower one, and where.
    Missed {
        found: f64,
        lower: f64,
        from: &'static str,
    },
    /// SQPnP's reported objective differs from the objective at its own pose.
    Inconsistent { reported: f64, evaluated: f64 },
    /// SQPnP returned no pose.
    Refused(PnpError),
}

/// Outcome of estimate_pose on one noisy problem.
enum EstimateOutcome {
    /// Its RMS reaches the least RMS of every refined start.
    Least,
    /// Refused as ambiguous, with its best RMS at the least.
    AmbiguousAtLeast,
    /// Refused because nothing explains the pixels within the bound (correctly).
    RefusedCorrectly,
    /// A larger RMS than a refined start's.
    Above {
        rms: f64,
        least: f64,
        from: &'static str,
    },
    /// Refused although a refined pose explains the pixels within the bound.
    Refused { error: PnpError, least: f64 },
}

struct NoisyOutcome {
    index: usize,
    planar: bool,
    points: usize,
    sqpnp: SqpnpOutcome,
    estimate: EstimateOutcome,
}

fn noisy_outcome(seed: u64, index: usize, camera: &CameraModel) -> NoisyOutcome {
    let problem = noisy_problem(seed, index, camera);
    let c = &problem.correspondences;
    let sqpnp_result = sqpnp(&c.target_points, &c.normalized);
    // Every pose found by any means, named.
    let mut starts: Vec<(&'static str, Isometry3<f64>)> = vec![("truth", problem.truth)];
    if let Ok(pose) = epnp(&c.target_points, &c.normalized) {
        starts.push(("EPnP", pose));
    }
    if problem.planar
        && let Ok(solutions) = ippe(&c.target_points, &c.normalized)
    {
        starts.push(("IPPE best", solutions.best));
        if solutions.second_rms.is_finite() {
            starts.push(("IPPE second", solutions.second));
        }
    }
    let others: Vec<(&'static str, f64, Isometry3<f64>)> = starts
        .iter()
        .filter_map(|(name, start)| {
            refine(camera, c, start)
                .ok()
                .map(|r| (*name, r.rms_px, r.camera_from_target))
        })
        .collect();
    let sqpnp_refined: Vec<(&'static str, f64, Isometry3<f64>)> = sqpnp_result
        .iter()
        .flatten()
        .filter_map(|m| {
            refine(camera, c, &m.camera_from_target)
                .ok()
                .map(|r| ("SQPnP", r.rms_px, r.camera_from_target))
        })
        .collect();

    let sqpnp = match &sqpnp_result {
        Err(e) => SqpnpOutcome::Refused(e.clone()),
        Ok(minima) => {
            let best = &minima[0];
            let evaluated = sqpnp_objective(c, &best.camera_from_target);
            let lower = others
                .iter()
                .map(|(name, _, pose)| (*name, sqpnp_objective(c, pose)))
                .min_by(|a, b| a.1.total_cmp(&b.1));
            if (evaluated - best.squared_error).abs()
                > SQPNP_RELATIVE_TOLERANCE * best.squared_error.max(evaluated) + 1e-300
            {
                SqpnpOutcome::Inconsistent {
                    reported: best.squared_error,
                    evaluated,
                }
            } else {
                match lower {
                    Some((from, lower))
                        if best.squared_error > lower * (1.0 + SQPNP_RELATIVE_TOLERANCE) =>
                    {
                        SqpnpOutcome::Missed {
                            found: best.squared_error,
                            lower,
                            from,
                        }
                    }
                    _ => SqpnpOutcome::Global,
                }
            }
        }
    };

    let (from, least) = others
        .iter()
        .chain(&sqpnp_refined)
        .map(|(name, rms, _)| (*name, *rms))
        .min_by(|a, b| a.1.total_cmp(&b.1))
        .unwrap_or(("none", f64::INFINITY));
    let options = PoseOptions::default();
    let estimate = match estimate_pose(camera, c, &options) {
        Ok(e) if e.rms_px <= least + RMS_TOLERANCE_PX => EstimateOutcome::Least,
        Ok(e) => EstimateOutcome::Above {
            rms: e.rms_px,
            least,
            from,
        },
        Err(PnpError::Ambiguous { best_rms_px, .. }) if best_rms_px <= least + RMS_TOLERANCE_PX => {
            EstimateOutcome::AmbiguousAtLeast
        }
        Err(PnpError::ReprojectionError { .. }) if least > options.max_rms_px => {
            EstimateOutcome::RefusedCorrectly
        }
        Err(error) => EstimateOutcome::Refused { error, least },
    };
    NoisyOutcome {
        index,
        planar: problem.planar,
        points: c.len(),
        sqpnp,
        estimate,
    }
}

// ---------------------------------------------------------------------------------

/// One row of the table, and the failures to show.
struct Row {
    name: String,
    problems: usize,
    successes: usize,
    failures: usize,
    note: String,
    shown: Vec<String>,
}

impl Row {
    fn new(name: &str) -> Self {
        Self {
            name: name.to_owned(),
            problems: 0,
            successes: 0,
            failures: 0,
            note: String::new(),
            shown: Vec::new(),
        }
    }

    fn count(&mut self, success: bool, describe: impl FnOnce() -> String) {
        self.problems += 1;
        if success {
            self.successes += 1;
        } else {
            self.failures += 1;
            if self.shown.len() < SHOWN {
                self.shown.push(describe());
            }
        }
    }
}

/// Every start of noisy problem `index`, refined, beside estimate_pose's result: what
/// a failure printed by the run is made of.
fn describe(seed: u64, index: usize, camera: &CameraModel) {
    let problem = noisy_problem(seed, index, camera);
    let c = &problem.correspondences;
    println!(
        "problem {index} (seed {seed}): {} points, {}",
        c.len(),
        if problem.planar { "planar" } else { "general" }
    );
    let estimate = estimate_pose(camera, c, &PoseOptions::default());
    let reference = match &estimate {
        Ok(e) => {
            println!(
                "estimate_pose: {:.12} px from {:?}, pose {:?}",
                e.rms_px, e.solver, e.camera_from_target
            );
            Some(e.camera_from_target)
        }
        Err(e) => {
            println!("estimate_pose refused: {e}");
            None
        }
    };
    let mut starts: Vec<(String, Isometry3<f64>)> = vec![("truth".into(), problem.truth)];
    if let Ok(minima) = sqpnp(&c.target_points, &c.normalized) {
        for (i, m) in minima.iter().enumerate() {
            println!("SQPnP minimum {i}: objective {:.12e}", m.squared_error);
            starts.push((format!("SQPnP {i}"), m.camera_from_target));
        }
    }
    if let Ok(pose) = epnp(&c.target_points, &c.normalized) {
        starts.push(("EPnP".into(), pose));
    }
    if let Ok(solutions) = ippe(&c.target_points, &c.normalized) {
        starts.push(("IPPE best".into(), solutions.best));
        starts.push(("IPPE second".into(), solutions.second));
    }
    if let Some(pose) = reference {
        starts.push(("estimate_pose's pose".into(), pose));
    }
    for (name, start) in &starts {
        match refine(camera, c, start) {
            Ok(r) => {
                let again = refine(camera, c, &r.camera_from_target).map(|a| a.rms_px);
                let apart = reference.map(|p| {
                    p.rotation
                        .angle_to(&r.camera_from_target.rotation)
                        .to_degrees()
                });
                println!(
                    "refine from {name:22}: {:.12} px in {:3} iterations (refined again {:.12} px), \
                     SQPnP objective {:.12e}, {:.6} deg from estimate_pose's",
                    r.rms_px,
                    r.iterations,
                    again.unwrap_or(f64::NAN),
                    sqpnp_objective(c, &r.camera_from_target),
                    apart.unwrap_or(f64::NAN)
                );
            }
            Err(e) => println!("refine from {name:22}: {e}"),
        }
    }
}

fn main() -> ExitCode {
    let args = parse_args();
    let seed = args.seed;
    let camera = camera();
    if let Some(index) = args.problem {
        describe(seed, index, &camera);
        return ExitCode::SUCCESS;
    }
    println!(
        "PnP Monte-Carlo, {} problems per part, seed {seed}, {} threads",
        args.problems,
        rayon::current_num_threads()
    );

    let started = Instant::now();
    let p3p: Vec<P3pOutcome> = (0..args.problems)
        .into_par_iter()
        .map(|i| p3p_outcome(seed, i))
        .collect();
    let p3p_seconds = started.elapsed().as_secs_f64();
    let mut truth_row = Row::new("(a) P3P: true pose among the solutions");
    let mut accuracy_row = Row::new("(a) P3P: every solution within 1e-6 px");
    let (mut solutions, mut inaccurate, mut worst_px) = (0, 0, 0.0f64);
    for o in &p3p {
        solutions += o.solutions;
        inaccurate += o.inaccurate;
        worst_px = worst_px.max(o.worst_px);
        truth_row.count(o.found_truth, || {
            format!(
                "problem {}: {} solutions, the nearest {:.3e} from the truth",
                o.index, o.solutions, o.nearest
            )
        });
        accuracy_row.count(o.inaccurate == 0, || {
            format!(
                "problem {}: {} of {} solutions off by up to {:.3e} px",
                o.index, o.inaccurate, o.solutions, o.worst_px
            )
        });
    }
    truth_row.note = format!("{p3p_seconds:.1} s");
    accuracy_row.note =
        format!("{solutions} solutions, {inaccurate} above 1e-6 px, worst {worst_px:.2e} px");

    let started = Instant::now();
    let noisy: Vec<NoisyOutcome> = (0..args.problems)
        .into_par_iter()
        .map(|i| noisy_outcome(seed, i, &camera))
        .collect();
    let noisy_seconds = started.elapsed().as_secs_f64();
    let mut rows = vec![truth_row, accuracy_row];
    for planar in [false, true] {
        let shape = if planar { "planar" } else { "general" };
        let mut sqpnp_row = Row::new(&format!("(b) SQPnP global minimum, {shape}"));
        let mut estimate_row = Row::new(&format!("(c) estimate_pose least RMS, {shape}"));
        let (mut ambiguous, mut refused_correctly) = (0, 0);
        for o in noisy.iter().filter(|o| o.planar == planar) {
            let what = format!("problem {} ({shape}, {} points)", o.index, o.points);
            sqpnp_row.count(matches!(o.sqpnp, SqpnpOutcome::Global), || match &o.sqpnp {
                SqpnpOutcome::Missed { found, lower, from } => format!(
                    "{what}: SQPnP's best {found:.6e}, {from} refined gives {lower:.6e} ({:+.2e} relative)",
                    found / lower - 1.0
                ),
                SqpnpOutcome::Inconsistent {
                    reported,
                    evaluated,
                } => format!(
                    "{what}: SQPnP reports {reported:.6e}, its pose evaluates to {evaluated:.6e}"
                ),
                SqpnpOutcome::Refused(e) => format!("{what}: SQPnP refused: {e}"),
                SqpnpOutcome::Global => String::new(),
            });
            match o.estimate {
                EstimateOutcome::AmbiguousAtLeast => ambiguous += 1,
                EstimateOutcome::RefusedCorrectly => refused_correctly += 1,
                _ => {}
            }
            estimate_row.count(
                !matches!(
                    o.estimate,
                    EstimateOutcome::Above { .. } | EstimateOutcome::Refused { .. }
                ),
                || match &o.estimate {
                    EstimateOutcome::Above { rms, least, from } => format!(
                        "{what}: estimate_pose {rms:.9} px, refine from {from} {least:.9} px"
                    ),
                    EstimateOutcome::Refused { error, least } => format!(
                        "{what}: estimate_pose refused ({error}); a refined pose has {least:.4} px"
                    ),
                    _ => String::new(),
                },
            );
        }
        sqpnp_row.note = format!("{noisy_seconds:.1} s for (b) and (c)");
        estimate_row.note = format!(
            "{ambiguous} refused as ambiguous with the least RMS, {refused_correctly} refused above the bound"
        );
        rows.push(sqpnp_row);
        rows.push(estimate_row);
    }

    println!(
        "\n{:44} {:>9} {:>10} {:>9}  notes",
        "check", "problems", "successes", "failures"
    );
    for row in &rows {
        println!(
            "{:44} {:>9} {:>10} {:>9}  {}",
            row.name, row.problems, row.successes, row.failures, row.note
        );
    }
    let mut failed = false;
    for row in &rows {
        if row.failures > 0 {
            failed = true;
            println!("\n{}: {} failures, the first:", row.name, row.failures);
            for line in &row.shown {
                println!("    {line}");
            }
        }
    }
    if failed {
        println!(
            "\nsee a noisy problem in full: cargo bench -p stereocal-vision --bench \
             pnp_monte_carlo -- --seed {seed} --problem I"
        );
        ExitCode::FAILURE
    } else {
        ExitCode::SUCCESS
    }
}
