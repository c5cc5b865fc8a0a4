//! Robust estimation around a minimal solver: RANSAC (the most inliers within a
//! threshold) and LMedS (the least median of squared errors), both seeded.

use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::GeometryError;

/// The seed of [`RobustOptions::ransac`] and [`RobustOptions::lmeds`].
const DEFAULT_SEED: u64 = 0x5eed_9e0e;
/// Draws of a sample the solver refuses (collinear points...) before giving up.
const MAX_SAMPLE_ATTEMPTS: usize = 1000;
/// The outlier ratio LMedS plans its number of samples for (OpenCV's).
const LMEDS_OUTLIER_RATIO: f64 = 0.45;
/// The least LMedS inlier threshold, in pixels (OpenCV's floor).
const LMEDS_MIN_SIGMA_PX: f64 = 1e-3;

/// How a robust estimator tells inliers from outliers.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RobustMethod {
    /// RANSAC: the model with the most correspondences within
    /// [`RobustOptions::threshold_px`] wins (ties go to the least summed squared error).
    Ransac,
    /// Least median of squares: the model with the least median squared error wins; its
    /// inliers are those within 2.5 robust standard deviations, estimated from that
    /// median. Needs no threshold, but fails when half the correspondences or more are
    /// outliers.
    LMedS,
}

/// How [`find_homography`](super::find_homography),
/// [`find_fundamental`](super::find_fundamental) and
/// [`find_essential`](super::find_essential) search, with OpenCV's meaning of each field.
#[derive(Clone, Debug, PartialEq)]
pub struct RobustOptions {
    /// RANSAC or LMedS.
    pub method: RobustMethod,
    /// RANSAC only: the largest error of an inlier, in pixels (what the error is says
    /// each estimator: transfer distance, Sampson distance).
    pub threshold_px: f64,
    /// Wanted probability, in (0, 1), of having drawn at least one all-inlier sample:
    /// RANSAC stops once the best inlier ratio so far makes more samples unnecessary,
    /// LMedS draws the samples that 45 % outliers would need.
    pub confidence: f64,
    /// Most samples drawn, whatever the confidence.
    pub max_iterations: usize,
    /// Seed of the sampling: the same input, options and seed give the same result.
    pub seed: u64,
}

impl RobustOptions {
    /// RANSAC with the given inlier threshold in pixels, confidence 0.999, at most 2000
    /// samples, a fixed seed.
    pub fn ransac(threshold_px: f64) -> Self {
        Self {
            method: RobustMethod::Ransac,
            threshold_px,
            confidence: 0.999,
            max_iterations: 2000,
            seed: DEFAULT_SEED,
        }
    }

    /// LMedS with confidence 0.999, at most 2000 samples, a fixed seed.
    pub fn lmeds() -> Self {
        Self {
            method: RobustMethod::LMedS,
            threshold_px: 0.0,
            ..Self::ransac(0.0)
        }
    }

    fn check(&self) -> Result<(), GeometryError> {
        if self.method == RobustMethod::Ransac
            && !(self.threshold_px > 0.0 && self.threshold_px.is_finite())
        {
            return Err(GeometryError::InvalidOption(format!(
                "threshold_px must be positive and finite, got {}",
                self.threshold_px
            )));
        }
        if !(self.confidence > 0.0 && self.confidence < 1.0) {
            return Err(GeometryError::InvalidOption(format!(
                "confidence must be in (0, 1), got {}",
                self.confidence
            )));
        }
        if self.max_iterations == 0 {
            return Err(GeometryError::InvalidOption(
                "max_iterations must be at least 1".into(),
            ));
        }
        Ok(())
    }
}

/// A model family with a minimal solver and a per-correspondence error.
pub(crate) trait Estimator {
    /// One hypothesis.
    type Model;
    /// Correspondences in a minimal sample.
    const SAMPLE_SIZE: usize;

    /// Number of correspondences.
    fn len(&self) -> usize;

    /// Whether a sample can give a meaningful model (not collinear...).
    fn is_valid_sample(&self, _sample: &[usize]) -> bool {
        true
    }

    /// Every model consistent with the sample, pushed onto `models`.
    fn fit_sample(&self, sample: &[usize], models: &mut Vec<Self::Model>);

    /// The squared error of correspondence `index` under `model`, in the units the
    /// threshold is given in.
    fn squared_error(&self, model: &Self::Model, index: usize) -> f64;
}

/// The winning hypothesis of a robust search.
pub(crate) struct Consensus<M> {
    /// The best model.
    pub model: M,
    /// Samples drawn.
    pub iterations: usize,
    /// The squared error below which a correspondence is an inlier: the RANSAC
    /// threshold, or LMedS's from its median.
    pub squared_threshold: f64,
}

/// Rounds of refitting a consensus model on its inliers.
const REFIT_ROUNDS: usize = 3;

/// A consensus model refined on its inliers: `refit` fits a model to the inliers of
/// a mask (`None` when it cannot), and the refit is kept while the inlier set grows
/// (never when it would shrink), for at most [`REFIT_ROUNDS`]. Returns the model, its
/// inlier mask and count, and the RMS error of its inliers (square root of the mean
/// squared error, in the estimator's units).
pub(crate) fn refit_on_inliers<E: Estimator>(
    estimator: &E,
    consensus: &Consensus<E::Model>,
    mut refit: impl FnMut(&E::Model, &[bool]) -> Option<E::Model>,
) -> (E::Model, Vec<bool>, usize, f64)
where
    E::Model: Clone,
{
    let threshold = consensus.squared_threshold;
    let (mut mask, mut count) = inliers(estimator, &consensus.model, threshold);
    let mut model = consensus.model.clone();
    for _ in 0..REFIT_ROUNDS {
        let Some(refitted) = refit(&model, &mask) else {
            break;
        };
        let (new_mask, new_count) = inliers(estimator, &refitted, threshold);
        if new_count < count {
            break;
        }
        let grew = new_count > count;
        (model, mask, count) = (refitted, new_mask, new_count);
        if !grew {
            break;
        }
    }
    let squared_sum: f64 = (0..estimator.len())
        .filter(|&i| mask[i])
        .map(|i| estimator.squared_error(&model, i))
        .sum();
    let rms = (squared_sum / count.max(1) as f64).sqrt();
    (model, mask, count, rms)
}

/// Which correspondences `model` explains within `squared_threshold`, and how many.
pub(crate) fn inliers<E: Estimator>(
    estimator: &E,
    model: &E::Model,
    squared_threshold: f64,
) -> (Vec<bool>, usize) {
    let mask: Vec<bool> = (0..estimator.len())
        .map(|i| estimator.squared_error(model, i) <= squared_threshold)
        .collect();
    let count = mask.iter().filter(|&&inlier| inlier).count();
    (mask, count)
}

/// Runs RANSAC or LMedS as `options` says. `pixel_scale` is the size of one pixel in the
/// units of [`Estimator::squared_error`] (1 for errors in pixels, 1/f for normalized
/// image coordinates). Fails with [`GeometryError::NoConsensus`] when no model explains
/// at least a minimal sample's worth of correspondences.
pub(crate) fn search<E: Estimator>(
    estimator: &E,
    options: &RobustOptions,
    pixel_scale: f64,
) -> Result<Consensus<E::Model>, GeometryError> {
    options.check()?;
    let total = estimator.len();
    if total < E::SAMPLE_SIZE {
        return Err(GeometryError::TooFewPoints {
            needed: E::SAMPLE_SIZE,
            got: total,
        });
    }
    let mut sampler = Sampler {
        rng: ChaCha8Rng::seed_from_u64(options.seed),
        pool: (0..total).collect(),
    };
    let found = match options.method {
        RobustMethod::Ransac => {
            let threshold = options.threshold_px * pixel_scale;
            ransac(estimator, options, &mut sampler, threshold * threshold)
        }
        RobustMethod::LMedS => lmeds(estimator, options, &mut sampler, pixel_scale),
    };
    let no_consensus = |best| GeometryError::NoConsensus {
        best,
        needed: E::SAMPLE_SIZE,
        total,
    };
    let consensus = found.ok_or_else(|| no_consensus(0))?;
    let (_, count) = inliers(estimator, &consensus.model, consensus.squared_threshold);
    if count < E::SAMPLE_SIZE {
        return Err(no_consensus(count));
    }
    Ok(consensus)
}

/// Samples needed to draw one all-inlier sample with probability `confidence` at an
/// inlier ratio of `inliers / total` (OpenCV's `RANSACUpdateNumIters`), at most `cap`.
pub(crate) fn samples_needed(
    confidence: f64,
    inliers: usize,
    total: usize,
    sample_size: usize,
    cap: usize,
) -> usize {
    let all_inliers = (inliers as f64 / total as f64).powi(sample_size as i32);
    // ln_1p keeps precision when an all-inlier sample is rare.
    let denominator = (-all_inliers).ln_1p();
    let numerator = (1.0 - confidence).max(f64::MIN_POSITIVE).ln();
    if denominator.is_nan() || denominator >= 0.0 || -numerator >= cap as f64 * -denominator {
        return cap;
    }
    ((numerator / denominator).round() as usize).min(cap)
}

struct Sampler {
    rng: ChaCha8Rng,
    pool: Vec<usize>,
}

impl Sampler {
    /// A random sample of distinct indices the estimator accepts, or `None` after
    /// [`MAX_SAMPLE_ATTEMPTS`] refused draws.
    fn draw<E: Estimator>(&mut self, estimator: &E) -> Option<Vec<usize>> {
        for _ in 0..MAX_SAMPLE_ATTEMPTS {
            // A partial Fisher-Yates shuffle: the first SAMPLE_SIZE entries are the sample.
            for i in 0..E::SAMPLE_SIZE {
                let j = self.rng.random_range(i..self.pool.len());
                self.pool.swap(i, j);
            }
            let sample = &self.pool[..E::SAMPLE_SIZE];
            if estimator.is_valid_sample(sample) {
                return Some(sample.to_vec());
            }
        }
        None
    }
}

fn ransac<E: Estimator>(
    estimator: &E,
    options: &RobustOptions,
    sampler: &mut Sampler,
    squared_threshold: f64,
) -> Option<Consensus<E::Model>> {
    let total = estimator.len();
    let mut budget = options.max_iterations;
    let mut iterations = 0;
    let mut best: Option<(E::Model, usize, f64)> = None;
    let mut models = Vec::new();
    while iterations < budget {
        let Some(sample) = sampler.draw(estimator) else {
            break;
        };
        iterations += 1;
        estimator.fit_sample(&sample, &mut models);
        for model in models.drain(..) {
            let (best_count, best_sum) = best
                .as_ref()
                .map_or((E::SAMPLE_SIZE.saturating_sub(1), f64::INFINITY), |b| {
                    (b.1, b.2)
                });
            let mut count = 0;
            let mut sum = 0.0;
            let mut hopeless = false;
            for i in 0..total {
                let error = estimator.squared_error(&model, i);
                if error <= squared_threshold {
                    count += 1;
                    sum += error;
                }
                // Stop scoring once this model cannot reach the best count.
                if count + (total - i - 1) < best_count {
                    hopeless = true;
                    break;
                }
            }
            if hopeless {
                continue;
            }
            if count > best_count || (count == best_count && sum < best_sum) {
                budget = samples_needed(
                    options.confidence,
                    count,
                    total,
                    E::SAMPLE_SIZE,
                    options.max_iterations,
                );
                best = Some((model, count, sum));
            }
        }
    }
    best.map(|(model, _, _)| Consensus {
        model,
        iterations,
        squared_threshold,
    })
}

fn lmeds<E: Estimator>(
    estimator: &E,
    options: &RobustOptions,
    sampler: &mut Sampler,
    pixel_scale: f64,
) -> Option<Consensus<E::Model>> {
    let total = estimator.len();
    let good = ((1.0 - LMEDS_OUTLIER_RATIO) * total as f64).ceil() as usize;
    let planned = samples_needed(
        options.confidence,
        good,
        total,
        E::SAMPLE_SIZE,
        options.max_iterations,
    )
    .max(1);
    let mut iterations = 0;
    let mut best: Option<(E::Model, f64)> = None;
    let mut models = Vec::new();
    let mut errors = vec![0.0; total];
    while iterations < planned {
        let Some(sample) = sampler.draw(estimator) else {
            break;
        };
        iterations += 1;
        estimator.fit_sample(&sample, &mut models);
        for model in models.drain(..) {
            for (i, error) in errors.iter_mut().enumerate() {
                *error = estimator.squared_error(&model, i);
            }
            let (_, median, _) = errors.select_nth_unstable_by(total / 2, f64::total_cmp);
            let median = *median;
            if median.is_finite() && best.as_ref().is_none_or(|b| median < b.1) {
                best = Some((model, median));
            }
        }
    }
    let (model, median) = best?;
    // The robust standard deviation of the errors, with the small-sample correction of
    // Rousseeuw and Leroy (OpenCV's).
    let spare = total.saturating_sub(E::SAMPLE_SIZE).max(1) as f64;
    let sigma =
        (2.5 * 1.4826 * (1.0 + 5.0 / spare) * median.sqrt()).max(LMEDS_MIN_SIGMA_PX * pixel_scale);
    Some(Consensus {
        model,
        iterations,
        squared_threshold: sigma * sigma,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn samples_needed_follows_the_inlier_ratio() {
        // 50 % inliers, 4-point samples, 0.99: log(0.01) / log(1 - 1/16) = 71.4.
        assert_eq!(samples_needed(0.99, 50, 100, 4, 2000), 71);
        assert_eq!(samples_needed(0.99, 100, 100, 4, 2000), 0);
        assert_eq!(samples_needed(0.99, 0, 100, 4, 2000), 2000);
        assert_eq!(samples_needed(0.999999, 5, 100, 7, 2000), 2000);
    }
}
