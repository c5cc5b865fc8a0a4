//! RANSAC around a minimal pose solver, for correspondences with outliers.
//!
//! Random minimal samples give candidate poses; each is scored by the pixel
//! reprojection error of every correspondence through the full camera model, the
//! number of samples adapts to the best inlier ratio so far, and the winner is refined
//! by Levenberg-Marquardt ([`super::refine()`]) on its inliers. Sampling is seeded:
//! the same input and options give the same result.

use nalgebra::{Isometry3, Point2, Point3, Vector3};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::p3p::lambda_twist;
use super::{Correspondences, PnpError, refine};
use crate::camera::CameraModel;

/// The seed of [`RansacOptions::default`].
const DEFAULT_SEED: u64 = 0x5eed_5eed;

/// A minimal pose solver: candidate poses from exactly `sample_size()`
/// correspondences.
pub trait MinimalSolver: Sync {
    /// The number of correspondences one call to [`MinimalSolver::solve`] takes.
    fn sample_size(&self) -> usize;

    /// Every pose `camera_from_target` consistent with the sample: `target_points` in
    /// the target frame (metres) and their undistorted normalized image points
    /// `(X/Z, Y/Z)`, both of length [`MinimalSolver::sample_size`]. Empty for a
    /// degenerate sample.
    fn solve(
        &self,
        target_points: &[Point3<f64>],
        normalized: &[Point2<f64>],
    ) -> Vec<Isometry3<f64>>;
}

/// Lambda Twist P3P ([`lambda_twist`]) as a minimal solver (3 points).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct P3p;

impl MinimalSolver for P3p {
    fn sample_size(&self) -> usize {
        3
    }

    /// Up to four poses, each putting the three points in front of the camera; none
    /// unless exactly three correspondences are given.
    fn solve(
        &self,
        target_points: &[Point3<f64>],
        normalized: &[Point2<f64>],
    ) -> Vec<Isometry3<f64>> {
        let (Ok(points), Ok(normalized)) = (
            <&[Point3<f64>; 3]>::try_from(target_points),
            <&[Point2<f64>; 3]>::try_from(normalized),
        ) else {
            return Vec::new();
        };
        lambda_twist(points, &normalized.map(|p| Vector3::new(p.x, p.y, 1.0)))
    }
}

/// How [`ransac`] searches.
#[derive(Clone, Debug, PartialEq)]
pub struct RansacOptions {
    /// Largest pixel reprojection error of an inlier, in pixels of the (distorted)
    /// image.
    pub threshold_px: f64,
    /// Wanted probability, in (0, 1), of having drawn at least one all-inlier sample
    /// before stopping: sets the number of samples from the best inlier ratio found.
    pub confidence: f64,
    /// Most samples drawn, whatever the confidence.
    pub max_iterations: usize,
    /// Seed of the sampling: the same seed gives the same result.
    pub seed: u64,
}

impl Default for RansacOptions {
    /// 2 px, 0.999 confidence, at most 1000 samples, a fixed seed.
    fn default() -> Self {
        Self {
            threshold_px: 2.0,
            confidence: 0.999,
            max_iterations: 1000,
            seed: DEFAULT_SEED,
        }
    }
}

/// The pose [`ransac`] found and the correspondences it explains.
#[derive(Clone, Debug, PartialEq)]
pub struct RansacPose {
    /// The refined pose, mapping target points to the camera frame.
    pub camera_from_target: Isometry3<f64>,
    /// Indices, ascending, of the correspondences this pose reprojects within the
    /// threshold.
    pub inliers: Vec<usize>,
    /// Samples drawn (degenerate ones included).
    pub iterations: usize,
}

/// Estimates `camera_from_target` from correspondences of which some may be gross
/// outliers: the best hypothesis of `solver` on random minimal samples, scored by
/// the number of correspondences that `camera` reprojects within
/// `options.threshold_px` (ties broken by their summed squared error; a point behind
/// the camera is an outlier), refined on its inliers, re-scored, and refined once more
/// if its inlier set grew. The returned inliers are those of the returned pose.
///
/// A pose is accepted only with more inliers than its sample and than chance explains:
/// with `p` the fraction of the image within the threshold of a pixel, a wrong pose
/// must be unlikely (probability below `1 - confidence` over all poses scored) to
/// collect as many of the other points, were the outliers uniform over the image. With
/// a few dozen points and a 2 px threshold this asks for one or two points beyond the
/// sample; it keeps a pose that agrees with a handful of random pixels from being
/// called a solution. A camera model without an image size skips this test.
///
/// Errors: [`PnpError::TooFewPoints`] with fewer than `sample_size() + 1`
/// correspondences; [`PnpError::NoSolution`] when no pose explains enough of them, or
/// for an invalid option (naming it); [`PnpError::MismatchedLengths`] for inconsistent
/// correspondences; a refinement error as [`refine()`] reports it.
pub fn ransac(
    camera: &CameraModel,
    correspondences: &Correspondences,
    solver: &dyn MinimalSolver,
    options: &RansacOptions,
) -> Result<RansacPose, PnpError> {
    check_options(options)?;
    check_lengths(correspondences)?;
    let sample_size = solver.sample_size();
    let needed = sample_size.saturating_add(1);
    if correspondences.len() < needed {
        return Err(PnpError::TooFewPoints {
            needed,
            got: correspondences.len(),
        });
    }
    let scorer = Scorer {
        camera,
        correspondences,
        squared_threshold: options.threshold_px * options.threshold_px,
    };
    let search = search(&scorer, solver, options);
    let needed_inliers =
        credible_inliers(camera, correspondences.len(), sample_size, &search, options);
    let not_enough = |inliers: usize| {
        PnpError::NoSolution(format!(
            "no pose reprojects enough of the {} points within {} px to tell it from \
             chance: best {inliers}, at least {needed_inliers} needed",
            correspondences.len(),
            options.threshold_px
        ))
    };
    let best = match search.best {
        Some(best) if best.score.inliers.len() >= needed_inliers => best,
        best => return Err(not_enough(best.map_or(0, |b| b.score.inliers.len()))),
    };
    let polished = polish(&scorer, best)?;
    if polished.score.inliers.len() < needed_inliers {
        return Err(not_enough(polished.score.inliers.len()));
    }
    Ok(RansacPose {
        camera_from_target: polished.pose,
        inliers: polished.score.inliers,
        iterations: search.iterations,
    })
}

/// Refuses options the search cannot run with, naming the option.
fn check_options(options: &RansacOptions) -> Result<(), PnpError> {
    let invalid = |what: String| {
        Err(PnpError::NoSolution(format!(
            "invalid RANSAC option: {what}"
        )))
    };
    if !(options.threshold_px > 0.0 && options.threshold_px.is_finite()) {
        return invalid(format!(
            "threshold_px must be positive and finite, got {}",
            options.threshold_px
        ));
    }
    if !(options.confidence > 0.0 && options.confidence < 1.0) {
        return invalid(format!(
            "confidence must be strictly between 0 and 1, got {}",
            options.confidence
        ));
    }
    if options.max_iterations == 0 {
        return invalid("max_iterations must be at least 1".into());
    }
    Ok(())
}

/// Refuses correspondences whose public fields were filled with different lengths.
fn check_lengths(correspondences: &Correspondences) -> Result<(), PnpError> {
    let points = correspondences.target_points.len();
    for image_points in [
        correspondences.pixels.len(),
        correspondences.normalized.len(),
    ] {
        if image_points != points {
            return Err(PnpError::MismatchedLengths {
                target_points: points,
                image_points,
            });
        }
    }
    Ok(())
}

/// Which correspondences a pose explains, and how well.
#[derive(Clone, Debug)]
struct Score {
    /// Ascending indices of the inliers.
    inliers: Vec<usize>,
    /// Sum of the inliers' squared pixel errors.
    squared_error: f64,
}

impl Score {
    /// More inliers, or as many with a smaller error.
    fn beats(&self, other: &Score) -> bool {
        self.inliers.len() > other.inliers.len()
            || (self.inliers.len() == other.inliers.len()
                && self.squared_error < other.squared_error)
    }
}

/// A pose with its score.
struct Hypothesis {
    pose: Isometry3<f64>,
    score: Score,
}

/// Scores poses on all correspondences through the camera model.
struct Scorer<'a> {
    camera: &'a CameraModel,
    correspondences: &'a Correspondences,
    squared_threshold: f64,
}

impl Scorer<'_> {
    fn score(&self, pose: &Isometry3<f64>) -> Score {
        let mut score = Score {
            inliers: Vec::new(),
            squared_error: 0.0,
        };
        let pairs = self
            .correspondences
            .target_points
            .iter()
            .zip(&self.correspondences.pixels);
        for (index, (point, pixel)) in pairs.enumerate() {
            let Some(projected) = self.camera.project(&(pose * point)) else {
                continue;
            };
            let squared = (projected - pixel).norm_squared();
            if squared <= self.squared_threshold {
                score.inliers.push(index);
                score.squared_error += squared;
            }
        }
        score
    }

    /// The correspondences at `indices`, as their own set.
    fn subset(&self, indices: &[usize]) -> Correspondences {
        let c = self.correspondences;
        Correspondences {
            target_points: indices
                .iter()
                .filter_map(|&i| c.target_points.get(i).copied())
                .collect(),
            pixels: indices
                .iter()
                .filter_map(|&i| c.pixels.get(i).copied())
                .collect(),
            normalized: indices
                .iter()
                .filter_map(|&i| c.normalized.get(i).copied())
                .collect(),
        }
    }
}

/// The outcome of the sampling.
struct Search {
    /// The best hypothesis, if any sample gave one.
    best: Option<Hypothesis>,
    /// Samples drawn.
    iterations: usize,
    /// Poses scored.
    hypotheses: usize,
}

/// Draws minimal samples until the best hypothesis makes more samples unnecessary at
/// the asked confidence, or the budget is spent.
fn search(scorer: &Scorer, solver: &dyn MinimalSolver, options: &RansacOptions) -> Search {
    let correspondences = scorer.correspondences;
    let total = correspondences.len();
    let sample_size = solver.sample_size();
    let mut rng = ChaCha8Rng::seed_from_u64(options.seed);
    let mut pool: Vec<usize> = (0..total).collect();
    let mut best: Option<Hypothesis> = None;
    let mut budget = options.max_iterations as f64;
    let mut iterations = 0;
    let mut hypotheses = 0;
    while (iterations as f64) < budget {
        iterations += 1;
        let sample = draw_sample(&mut rng, &mut pool, sample_size);
        let sample_points: Vec<Point3<f64>> = sample
            .iter()
            .filter_map(|&i| correspondences.target_points.get(i).copied())
            .collect();
        let sample_normalized: Vec<Point2<f64>> = sample
            .iter()
            .filter_map(|&i| correspondences.normalized.get(i).copied())
            .collect();
        for pose in solver.solve(&sample_points, &sample_normalized) {
            if !is_finite(&pose) {
                continue;
            }
            hypotheses += 1;
            let score = scorer.score(&pose);
            if best.as_ref().is_none_or(|b| score.beats(&b.score)) {
                budget = samples_needed(score.inliers.len(), total, sample_size, options)
                    .min(options.max_iterations as f64);
                best = Some(Hypothesis { pose, score });
            }
        }
    }
    Search {
        best,
        iterations,
        hypotheses,
    }
}

/// `size` distinct indices drawn uniformly: a partial Fisher-Yates shuffle of `pool`
/// (a permutation of all indices), whose first `size` entries are the sample.
fn draw_sample<'a>(rng: &mut ChaCha8Rng, pool: &'a mut [usize], size: usize) -> &'a [usize] {
    let size = size.min(pool.len());
    for i in 0..size {
        let j = rng.random_range(i..pool.len());
        pool.swap(i, j);
    }
    pool.get(..size).unwrap_or_default()
}

/// Samples needed to draw at least one all-inlier sample with probability
/// `confidence`, at the inlier ratio `inliers / total`.
fn samples_needed(
    inliers: usize,
    total: usize,
    sample_size: usize,
    options: &RansacOptions,
) -> f64 {
    let all_inliers = (inliers as f64 / total as f64).powf(sample_size as f64);
    if all_inliers >= 1.0 {
        return 0.0;
    }
    // ln_1p keeps precision when an all-inlier sample is rare.
    ((1.0 - options.confidence).ln() / (-all_inliers).ln_1p()).ceil()
}

/// The fewest inliers a pose needs to be told apart from chance: more than the sample
/// (which any pose from it explains), and more than a wrong pose collects by chance
/// from the other points. A gross outlier, taken as uniform over the image, lands
/// within the threshold of where a wrong pose projects its point with probability
/// `p = pi threshold^2 / image area`; the count must be one that `Binomial(total -
/// sample_size, p)` reaches with probability at most `(1 - confidence)` over the
/// number of poses scored. Without an image size only the sample bound applies.
fn credible_inliers(
    camera: &CameraModel,
    total: usize,
    sample_size: usize,
    search: &Search,
    options: &RansacOptions,
) -> usize {
    let area = f64::from(camera.width) * f64::from(camera.height);
    let chance = std::f64::consts::PI * options.threshold_px * options.threshold_px / area;
    let others = total.saturating_sub(sample_size);
    let allowed = (1.0 - options.confidence) / search.hypotheses.max(1) as f64;
    let extra = if area > 0.0 {
        fewest_unlikely(others, chance, allowed)
    } else {
        1
    };
    sample_size.saturating_add(extra)
}

/// The smallest `k >= 1` with `P(Binomial(n, p) >= k) <= allowed`; `n + 1` when even
/// `n` is too likely.
fn fewest_unlikely(n: usize, p: f64, allowed: f64) -> usize {
    if p >= 1.0 {
        return n.saturating_add(1);
    }
    // Log-probabilities, since (1 - p)^n underflows for large n.
    let log_odds = p.ln() - (-p).ln_1p();
    let mut log_pmf = Vec::with_capacity(n.saturating_add(1));
    let mut current = n as f64 * (-p).ln_1p();
    log_pmf.push(current);
    for i in 0..n {
        current += ((n - i) as f64).ln() - ((i + 1) as f64).ln() + log_odds;
        log_pmf.push(current);
    }
    // The tail grows as k falls: walk down from k = n while it stays small enough.
    let mut fewest = n.saturating_add(1);
    let mut tail = 0.0;
    for (k, log_p) in log_pmf.iter().enumerate().skip(1).rev() {
        tail += log_p.exp();
        if tail > allowed {
            break;
        }
        fewest = k;
    }
    fewest
}

/// Refines a hypothesis on its inliers, re-scores it, and refines once more on the new
/// inliers if there are more of them.
fn polish(scorer: &Scorer, hypothesis: Hypothesis) -> Result<Hypothesis, PnpError> {
    let refine_on = |inliers: &[usize], pose: &Isometry3<f64>| {
        refine(scorer.camera, &scorer.subset(inliers), pose).map(|r| r.camera_from_target)
    };
    let pose = refine_on(&hypothesis.score.inliers, &hypothesis.pose)?;
    let score = scorer.score(&pose);
    if score.inliers.len() <= hypothesis.score.inliers.len() {
        return Ok(Hypothesis { pose, score });
    }
    let pose = refine_on(&score.inliers, &pose)?;
    Ok(Hypothesis {
        score: scorer.score(&pose),
        pose,
    })
}

fn is_finite(pose: &Isometry3<f64>) -> bool {
    pose.translation.vector.iter().all(|v| v.is_finite())
        && pose.rotation.coords.iter().all(|v| v.is_finite())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::pnp::test_camera as camera;
    use nalgebra::{Translation3, UnitQuaternion, Vector2};

    fn truth() -> Isometry3<f64> {
        Isometry3::from_parts(
            Translation3::new(-0.1, -0.05, 0.6),
            UnitQuaternion::from_scaled_axis(Vector3::new(0.3, -0.4, 0.1)),
        )
    }

    /// A 9 x 6 board of 3 cm squares; `relief` metres of random depth off its plane.
    fn board(rng: &mut ChaCha8Rng, relief: f64) -> Vec<Point3<f64>> {
        (0..6)
            .flat_map(|r| (0..9).map(move |c| (r, c)))
            .map(|(r, c)| {
                let z = if relief > 0.0 {
                    rng.random_range(-relief..relief)
                } else {
                    0.0
                };
                Point3::new(c as f64 * 0.03, r as f64 * 0.03, z)
            })
            .collect()
    }

    /// A random pixel in the image at least 20 px from `pixel`.
    fn far_pixel(rng: &mut ChaCha8Rng, camera: &CameraModel, pixel: &Point2<f64>) -> Point2<f64> {
        loop {
            let candidate = Point2::new(
                rng.random_range(0.0..camera.width as f64),
                rng.random_range(0.0..camera.height as f64),
            );
            if (candidate - pixel).norm() > 20.0 {
                return candidate;
            }
        }
    }

    /// The board seen at the true pose with `outliers` of its pixels moved far away and
    /// the others perturbed by up to `noise_px`; returns the true inliers too.
    fn problem(
        seed: u64,
        relief: f64,
        outliers: usize,
        noise_px: f64,
    ) -> (Correspondences, Vec<usize>) {
        let camera = camera();
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let points = board(&mut rng, relief);
        let mut pixels: Vec<_> = points
            .iter()
            .map(|p| camera.project(&(truth() * p)).unwrap())
            .collect();
        let mut order: Vec<usize> = (0..points.len()).collect();
        draw_sample(&mut rng, &mut order, outliers);
        let (bad, good) = order.split_at(outliers);
        for &i in bad {
            pixels[i] = far_pixel(&mut rng, &camera, &pixels[i]);
        }
        if noise_px > 0.0 {
            for &i in good {
                pixels[i] += Vector2::new(
                    rng.random_range(-noise_px..noise_px),
                    rng.random_range(-noise_px..noise_px),
                );
            }
        }
        let mut inliers = good.to_vec();
        inliers.sort_unstable();
        (
            Correspondences::new(&camera, &points, &pixels).unwrap(),
            inliers,
        )
    }

    fn pose_error(pose: &Isometry3<f64>) -> (f64, f64) {
        let error = pose.inverse() * truth();
        (
            error.rotation.angle().to_degrees(),
            error.translation.vector.norm(),
        )
    }

    #[test]
    fn recovers_the_pose_and_exact_inliers_among_gross_outliers() {
        for (seed, relief) in [(1, 0.0), (2, 0.0), (3, 0.05), (4, 0.05)] {
            // 16 of 54 points, 30 %, are gross outliers.
            let (c, true_inliers) = problem(seed, relief, 16, 0.0);
            let result = ransac(&camera(), &c, &P3p, &RansacOptions::default()).unwrap();
            let (degrees, metres) = pose_error(&result.camera_from_target);
            assert!(
                degrees < 1e-8,
                "seed {seed}: rotation error {degrees:e} deg"
            );
            assert!(metres < 1e-9, "seed {seed}: translation error {metres:e} m");
            assert_eq!(result.inliers, true_inliers, "seed {seed}");
            // About 17 samples suffice at 70 % inliers and 0.999 confidence.
            assert!(result.iterations < 100, "{} samples", result.iterations);
        }
    }

    #[test]
    fn noisy_inliers_give_the_least_squares_pose() {
        for (seed, relief) in [(5, 0.0), (6, 0.05)] {
            let (c, true_inliers) = problem(seed, relief, 16, 0.5);
            let result = ransac(&camera(), &c, &P3p, &RansacOptions::default()).unwrap();
            assert_eq!(result.inliers, true_inliers, "seed {seed}");
            // The noise limits the pose, not the search: it is the least-squares pose
            // on the true inliers.
            let scorer = Scorer {
                camera: &camera(),
                correspondences: &c,
                squared_threshold: 4.0,
            };
            let optimum = refine(&camera(), &scorer.subset(&true_inliers), &truth())
                .unwrap()
                .camera_from_target;
            let difference = result.camera_from_target.inverse() * optimum;
            assert!(difference.rotation.angle() < 1e-7, "seed {seed}");
            assert!(difference.translation.vector.norm() < 1e-7, "seed {seed}");
            let (degrees, metres) = pose_error(&result.camera_from_target);
            assert!(degrees < 0.3, "seed {seed}: rotation error {degrees} deg");
            assert!(metres < 2e-3, "seed {seed}: translation error {metres} m");
        }
    }

    #[test]
    fn same_seed_same_result() {
        let (c, _) = problem(7, 0.05, 16, 0.5);
        let options = RansacOptions {
            seed: 12345,
            ..RansacOptions::default()
        };
        let first = ransac(&camera(), &c, &P3p, &options).unwrap();
        let second = ransac(&camera(), &c, &P3p, &options).unwrap();
        assert_eq!(first, second);
    }

    #[test]
    fn without_outliers_one_sample_is_enough() {
        let (c, true_inliers) = problem(8, 0.0, 0, 0.0);
        let result = ransac(&camera(), &c, &P3p, &RansacOptions::default()).unwrap();
        assert_eq!(result.iterations, 1);
        assert_eq!(result.inliers, true_inliers);
    }

    #[test]
    fn refuses_all_outliers() {
        // With 54 random pixels, some of the ~2000 poses scored per run pick up a fourth
        // point within 2 px by chance: the chance bound must still refuse every run.
        for seed in 0..40 {
            let (c, true_inliers) = problem(seed, 0.05 * (seed % 2) as f64, 54, 0.0);
            assert!(true_inliers.is_empty());
            let options = RansacOptions {
                seed,
                ..RansacOptions::default()
            };
            assert!(
                matches!(
                    ransac(&camera(), &c, &P3p, &options),
                    Err(PnpError::NoSolution(_))
                ),
                "seed {seed}"
            );
        }
    }

    #[test]
    fn half_outliers_are_handled() {
        let (c, true_inliers) = problem(13, 0.05, 27, 0.0);
        let result = ransac(&camera(), &c, &P3p, &RansacOptions::default()).unwrap();
        assert_eq!(result.inliers, true_inliers);
        let (degrees, metres) = pose_error(&result.camera_from_target);
        assert!(
            degrees < 1e-8 && metres < 1e-9,
            "{degrees:e} deg, {metres:e} m"
        );
    }

    #[test]
    fn chance_bound_follows_the_binomial_tail() {
        // 51 other points, a 2 px disc in a 1024 x 768 image: one chance inlier has
        // probability 8e-4 per pose, two 3.4e-7.
        let p = std::f64::consts::PI * 4.0 / (1024.0 * 768.0);
        assert_eq!(fewest_unlikely(51, p, 1e-3 / 2000.0), 2);
        assert_eq!(fewest_unlikely(51, p, 1e-3), 1);
        assert_eq!(fewest_unlikely(51, p, 1e-12), 4);
        assert_eq!(fewest_unlikely(51, 1.0, 1e-3), 52);
        assert_eq!(fewest_unlikely(0, p, 1e-3), 1);
        // Large n: (1 - p)^n underflows without logarithms.
        assert_eq!(fewest_unlikely(1_000_000, 0.5, 1e-3), 501_546);
    }

    #[test]
    fn refuses_too_few_points() {
        let (mut c, _) = problem(10, 0.0, 0, 0.0);
        c.target_points.truncate(3);
        c.pixels.truncate(3);
        c.normalized.truncate(3);
        assert_eq!(
            ransac(&camera(), &c, &P3p, &RansacOptions::default()),
            Err(PnpError::TooFewPoints { needed: 4, got: 3 })
        );
    }

    #[test]
    fn refuses_inconsistent_correspondences() {
        let (mut c, _) = problem(10, 0.0, 0, 0.0);
        c.normalized.pop();
        assert_eq!(
            ransac(&camera(), &c, &P3p, &RansacOptions::default()),
            Err(PnpError::MismatchedLengths {
                target_points: 54,
                image_points: 53
            })
        );
    }

    #[test]
    fn refuses_invalid_options_naming_them() {
        let (c, _) = problem(11, 0.0, 0, 0.0);
        let base = RansacOptions::default();
        let cases = [
            (
                RansacOptions {
                    threshold_px: 0.0,
                    ..base.clone()
                },
                "threshold_px",
            ),
            (
                RansacOptions {
                    threshold_px: f64::NAN,
                    ..base.clone()
                },
                "threshold_px",
            ),
            (
                RansacOptions {
                    confidence: 1.0,
                    ..base.clone()
                },
                "confidence",
            ),
            (
                RansacOptions {
                    confidence: 0.0,
                    ..base.clone()
                },
                "confidence",
            ),
            (
                RansacOptions {
                    max_iterations: 0,
                    ..base.clone()
                },
                "max_iterations",
            ),
        ];
        for (options, name) in cases {
            match ransac(&camera(), &c, &P3p, &options) {
                Err(PnpError::NoSolution(message)) => {
                    assert!(message.contains(name), "{message}")
                }
                other => panic!("{name}: {other:?}"),
            }
        }
    }

    /// A solver that finds nothing, as for degenerate samples.
    struct Nothing;

    impl MinimalSolver for Nothing {
        fn sample_size(&self) -> usize {
            3
        }
        fn solve(&self, _: &[Point3<f64>], _: &[Point2<f64>]) -> Vec<Isometry3<f64>> {
            Vec::new()
        }
    }

    #[test]
    fn degenerate_samples_are_skipped_within_the_budget() {
        let (c, _) = problem(12, 0.0, 0, 0.0);
        assert!(matches!(
            ransac(&camera(), &c, &Nothing, &RansacOptions::default()),
            Err(PnpError::NoSolution(_))
        ));
    }

    #[test]
    fn p3p_solver_needs_exactly_three_points() {
        let points = [Point3::new(0.0, 0.0, 0.0); 4];
        let normalized = [Point2::new(0.0, 0.0); 4];
        assert!(P3p.solve(&points, &normalized).is_empty());
        assert!(P3p.solve(&points[..3], &normalized[..2]).is_empty());
    }
}
