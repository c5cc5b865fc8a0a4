//! Samples that disagree with the rest, found by least median of squares and left out.

use rand::SeedableRng;
use rand::seq::index::sample as random_subset;
use rand_chacha::ChaCha8Rng;

use super::{
    Calibration, HandEye, HandEyeError, MIN_SAMPLES, Method, Sample, SampleResidual, Setup,
    calibrate,
};

/// Samples in each random subset a hypothesis is calibrated from.
const SUBSET: usize = MIN_SAMPLES + 1;
/// Random subsets tried: with a fifth of the samples bad, the chance that none of them
/// is clean is below 1e-9.
const TRIALS: usize = 100;
/// A sample is out when its residual is more than this many times the median, and
/// above 0.1 degree or 1 mm ([`SampleResidual::scaled`] above 1): below both a sample
/// agrees, however good the rest.
const MEDIAN_FACTOR: f64 = 4.0;

/// A sample left out of a calibration, and why.
#[derive(Clone, Debug, PartialEq)]
pub struct RejectedSample {
    /// Its index in the samples given.
    pub index: usize,
    /// Why it was left out.
    pub reason: String,
}

/// [`calibrate`] on the samples that agree with each other: a target pose from a
/// blurred or misdetected image, or a robot pose read at the wrong instant, is left out
/// with the reason.
///
/// Least median of squares, which needs no noise level and tolerates up to half the
/// samples bad: Park-Martin calibrates random subsets of four samples, and the
/// hypothesis whose residuals (each the larger of rotation over 0.1 degree and
/// translation over 1 mm) have the least median over all samples is kept. A sample
/// whose residual under it is more than four times that median, and above 0.1 degree or
/// 1 mm, is out. Those the hypothesis accepts are calibrated together by Park-Martin and
/// judged again by that fit, whose residuals of good samples are tighter; `method`
/// then calibrates the samples kept. With five samples or fewer
/// nothing is left out. Deterministic: the subsets are drawn from a fixed seed.
pub fn calibrate_screened(
    setup: Setup,
    samples: &[Sample],
    method: Method,
) -> Result<(Calibration, Vec<RejectedSample>), HandEyeError> {
    if samples.len() <= SUBSET + 1 {
        return Ok((calibrate(setup, samples, method)?, Vec::new()));
    }
    let mut rng = ChaCha8Rng::seed_from_u64(samples.len() as u64);
    let mut best: Option<(f64, Vec<SampleResidual>)> = None;
    for _ in 0..TRIALS {
        let subset: Vec<Sample> = random_subset(&mut rng, samples.len(), SUBSET)
            .iter()
            .map(|i| samples[i].clone())
            .collect();
        let Ok(hypothesis) = calibrate(setup, &subset, Method::Park) else {
            continue;
        };
        let residuals = residuals_of(&hypothesis.hand_eye, samples);
        let score = median(residuals.iter().map(SampleResidual::scaled).collect());
        if best.as_ref().is_none_or(|(least, _)| score < *least) {
            best = Some((score, residuals));
        }
    }
    let Some((median_score, residuals)) = best else {
        // No subset could be calibrated: the full set's own error says why.
        return Ok((calibrate(setup, samples, method)?, Vec::new()));
    };
    // The hypothesis came from four samples: refit on every sample it accepts, and judge
    // by that fit, whose residuals of good samples are tighter.
    let accepted: Vec<Sample> = samples
        .iter()
        .zip(&residuals)
        .filter(|(_, r)| r.scaled() <= (MEDIAN_FACTOR * median_score).max(1.0))
        .map(|(s, _)| s.clone())
        .collect();
    let (median_score, residuals) = match calibrate(setup, &accepted, Method::Park) {
        Ok(refit) => {
            let residuals = residuals_of(&refit.hand_eye, samples);
            (
                median(residuals.iter().map(SampleResidual::scaled).collect()),
                residuals,
            )
        }
        Err(_) => (median_score, residuals),
    };
    let bound = (MEDIAN_FACTOR * median_score).max(1.0);
    let mut kept = Vec::new();
    let mut rejected = Vec::new();
    for (index, (sample, residual)) in samples.iter().zip(&residuals).enumerate() {
        if residual.scaled() > bound {
            rejected.push(RejectedSample {
                index,
                reason: format!(
                    "disagrees with the other samples: its target pose is {:.3} degrees and \
                     {:.1} mm from where they put it, more than {MEDIAN_FACTOR} times the \
                     median",
                    residual.rotation_rad.to_degrees(),
                    residual.translation_m * 1e3
                ),
            });
        } else {
            kept.push(sample.clone());
        }
    }
    Ok((calibrate(setup, &kept, method)?, rejected))
}

fn residuals_of(hand_eye: &HandEye, samples: &[Sample]) -> Vec<SampleResidual> {
    samples.iter().map(|s| hand_eye.residual(s)).collect()
}

fn median(mut values: Vec<f64>) -> f64 {
    values.sort_by(f64::total_cmp);
    values[values.len() / 2]
}
