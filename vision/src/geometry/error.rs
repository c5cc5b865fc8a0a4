//! Why a two-view geometry could not be estimated.

use thiserror::Error;

/// Why a homography, fundamental or essential matrix, relative pose or triangulation
/// was refused. Every refusal names what was wrong with the input or the result; no
/// estimator returns a matrix or point that is not finite.
#[derive(Clone, Debug, Error, PartialEq)]
pub enum GeometryError {
    /// Fewer correspondences than the estimator needs.
    #[error("too few correspondences: {got} given, at least {needed} needed")]
    TooFewPoints {
        /// The estimator's minimum.
        needed: usize,
        /// What was given.
        got: usize,
    },
    /// The two point lists do not pair up.
    #[error("{a} points in the first image but {b} in the second: they must pair up")]
    MismatchedLengths {
        /// Number of points in the first image.
        a: usize,
        /// Number of points in the second image.
        b: usize,
    },
    /// A NaN or infinite value in the input.
    #[error("non-finite value in {0}")]
    NonFinite(&'static str),
    /// An option out of its range (naming it and the range).
    #[error("invalid option: {0}")]
    InvalidOption(String),
    /// A pixel has no ray through its camera model (outside the distortion model's
    /// invertible domain).
    #[error(
        "point {index} of the {image} image at ({x:.2}, {y:.2}) px has no ray through the camera model"
    )]
    Unprojectable {
        /// Which image: "first" or "second".
        image: &'static str,
        /// Index of the point.
        index: usize,
        /// Its pixel column.
        x: f64,
        /// Its pixel row.
        y: f64,
    },
    /// The points do not determine the model (coincident, collinear, all on one plane
    /// where a general scene is needed...).
    #[error("degenerate configuration: {0}")]
    Degenerate(String),
    /// No model explains enough correspondences.
    #[error(
        "no consensus: the best model explains {best} of {total} correspondences, at least \
         {needed} needed"
    )]
    NoConsensus {
        /// Inliers of the best model found (0 when no sample gave a model).
        best: usize,
        /// The fewest inliers accepted.
        needed: usize,
        /// All correspondences.
        total: usize,
    },
    /// A numerical failure: the result would not be finite, or a decomposition failed.
    #[error("no solution: {0}")]
    NoSolution(String),
}
