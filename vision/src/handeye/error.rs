//! Why a hand-eye calibration could not be computed.

use thiserror::Error;

/// Why no hand-eye transform was returned. A degenerate set of samples is an error,
/// never a number.
#[derive(Clone, Debug, Error, PartialEq)]
pub enum HandEyeError {
    /// Fewer samples than any method needs.
    #[error("too few samples: {got} given, at least {needed} needed")]
    TooFewSamples {
        /// The least number of samples.
        needed: usize,
        /// What was given.
        got: usize,
    },
    /// A sample with a NaN or infinite value.
    #[error("sample {index}: non-finite value in its {what}")]
    NonFinite {
        /// Index of the sample.
        index: usize,
        /// Which pose.
        what: &'static str,
    },
    /// The motions between the samples do not determine the transform; the message
    /// says what is missing and which poses to add.
    #[error("degenerate motion: {0}")]
    Degenerate(String),
    /// The method's numerics failed (a decomposition did not converge).
    #[error("{method} failed: {reason}")]
    NoSolution {
        /// The method's name.
        method: &'static str,
        /// What failed.
        reason: String,
    },
}
