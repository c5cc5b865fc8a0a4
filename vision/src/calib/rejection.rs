//! Robust rejection of views that do not fit the others: a per-view RMS far above the
//! median (median + MAD threshold, and a ratio to the median), or gross outliers among
//! a view's corners.

use std::fmt;

use serde::{Deserialize, Serialize};

/// When a view is judged not to fit.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct RejectionOptions {
    /// A view is rejected when its RMS is at least this many times the median RMS of
    /// the views...
    pub rms_ratio: f64,
    /// ...and exceeds the median by this many robust standard deviations of the views'
    /// RMS (1.4826 times the median absolute deviation).
    pub rms_sigmas: f64,
    /// A corner is a gross outlier when its error exceeds this many robust standard
    /// deviations of all corners' residual coordinates...
    pub corner_sigmas: f64,
    /// ...and this many pixels.
    pub min_corner_error: f64,
    /// At most this fraction of the views is rejected.
    pub max_rejected_fraction: f64,
}

impl Default for RejectionOptions {
    fn default() -> Self {
        Self {
            rms_ratio: 3.0,
            rms_sigmas: 5.0,
            corner_sigmas: 10.0,
            min_corner_error: 1.0,
            max_rejected_fraction: 0.3,
        }
    }
}

/// Why a view was left out of a calibration.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub enum RejectionReason {
    /// The view's RMS is far above the other views'.
    HighRms {
        /// The view's RMS, pixels.
        rms: f64,
        /// The median RMS of the views, pixels.
        median: f64,
    },
    /// A few of the view's corners are far from where the calibration puts them.
    OutlierCorners {
        /// Number of outlying corners.
        count: usize,
        /// Largest corner error, pixels.
        worst: f64,
        /// The error beyond which a corner is an outlier, pixels.
        threshold: f64,
    },
    /// No pose explains the view's corners (degenerate or misordered corners).
    NoPose,
}

impl fmt::Display for RejectionReason {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::HighRms { rms, median } => write!(
                f,
                "per-view RMS {rms:.2} px is {:.0}x the median ({median:.2} px): blurred or moving target",
                rms / median
            ),
            Self::OutlierCorners {
                count,
                worst,
                threshold,
            } => write!(
                f,
                "{count} corners off by more than {threshold:.1} px (worst {worst:.1} px): misdetected corners"
            ),
            Self::NoPose => write!(
                f,
                "no pose of the target explains the corners: degenerate or misordered detection"
            ),
        }
    }
}

/// A view left out of a calibration, by its index in the input.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct RejectedView {
    /// Index of the view in the input.
    pub index: usize,
    /// Why it was rejected.
    pub reason: RejectionReason,
}

/// The median of a non-empty slice (sorted copy).
pub(crate) fn median(values: &[f64]) -> f64 {
    let mut sorted = values.to_vec();
    sorted.sort_by(f64::total_cmp);
    let n = sorted.len();
    if n == 0 {
        return 0.0;
    }
    if n % 2 == 1 {
        sorted[n / 2]
    } else {
        0.5 * (sorted[n / 2 - 1] + sorted[n / 2])
    }
}

const MAD_TO_SIGMA: f64 = 1.4826;

/// The view that fits worst, if any does not fit: `errors[v]` holds view `v`'s
/// per-corner reprojection errors (pixels). Returns the position in `errors` and the
/// reason.
pub(crate) fn worst_view(
    errors: &[Vec<f64>],
    options: &RejectionOptions,
) -> Option<(usize, RejectionReason)> {
    let rms: Vec<f64> = errors
        .iter()
        .map(|e| (e.iter().map(|x| x * x).sum::<f64>() / e.len().max(1) as f64).sqrt())
        .collect();
    let median_rms = median(&rms);
    let deviations: Vec<f64> = rms.iter().map(|r| (r - median_rms).abs()).collect();
    let rms_threshold = (median_rms * options.rms_ratio)
        .max(median_rms + options.rms_sigmas * MAD_TO_SIGMA * median(&deviations));
    // A corner error is the norm of two residual coordinates; with Gaussian noise of
    // standard deviation s per coordinate its median is s * sqrt(2 ln 2).
    let all: Vec<f64> = errors.iter().flatten().copied().collect();
    let sigma = median(&all) / (2.0 * std::f64::consts::LN_2).sqrt();
    let corner_threshold = (options.corner_sigmas * sigma).max(options.min_corner_error);
    let mut worst: Option<(usize, f64, RejectionReason)> = None;
    for (v, e) in errors.iter().enumerate() {
        let outliers = e.iter().filter(|&&x| x > corner_threshold).count();
        let largest = e.iter().copied().fold(0.0, f64::max);
        // A few gross outliers are misdetections; many large errors are a blurred view.
        let candidate = if outliers > 0 && 5 * outliers <= e.len() {
            Some((
                largest / corner_threshold,
                RejectionReason::OutlierCorners {
                    count: outliers,
                    worst: largest,
                    threshold: corner_threshold,
                },
            ))
        } else if rms[v] > rms_threshold {
            Some((
                rms[v] / rms_threshold,
                RejectionReason::HighRms {
                    rms: rms[v],
                    median: median_rms,
                },
            ))
        } else {
            None
        };
        if let Some((severity, reason)) = candidate
            && worst.as_ref().is_none_or(|w| severity > w.1)
        {
            worst = Some((v, severity, reason));
        }
    }
    worst.map(|(v, _, reason)| (v, reason))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn clean(n: usize, level: f64) -> Vec<f64> {
        (0..n)
            .map(|i| level * (0.5 + (i % 5) as f64 * 0.25))
            .collect()
    }

    #[test]
    fn consistent_views_are_kept() {
        let errors: Vec<Vec<f64>> = (0..20).map(|v| clean(54, 0.1 + 0.005 * v as f64)).collect();
        assert_eq!(worst_view(&errors, &RejectionOptions::default()), None);
    }

    #[test]
    fn a_blurred_view_is_rejected_for_its_rms() {
        let mut errors: Vec<Vec<f64>> = (0..20).map(|_| clean(54, 0.1)).collect();
        errors[7] = clean(54, 0.6);
        let (view, reason) = worst_view(&errors, &RejectionOptions::default()).unwrap();
        assert_eq!(view, 7);
        assert!(
            matches!(reason, RejectionReason::HighRms { .. }),
            "{reason}"
        );
        assert!(reason.to_string().contains("blurred or moving target"));
    }

    #[test]
    fn a_misdetected_corner_is_an_outlier() {
        let mut errors: Vec<Vec<f64>> = (0..20).map(|_| clean(54, 0.1)).collect();
        errors[3][10] = 6.0;
        let (view, reason) = worst_view(&errors, &RejectionOptions::default()).unwrap();
        assert_eq!(view, 3);
        assert!(
            matches!(reason, RejectionReason::OutlierCorners { count: 1, .. }),
            "{reason}"
        );
    }
}
