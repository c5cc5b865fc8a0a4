//! Why a pose could not be estimated.

use thiserror::Error;

/// Why a pose was refused. A PnP solver never returns a pose it cannot stand behind:
/// every refusal says what was wrong with the input or the result.
#[derive(Clone, Debug, Error, PartialEq)]
pub enum PnpError {
    /// Fewer correspondences than the solver needs.
    #[error("too few points: {got} given, at least {needed} needed")]
    TooFewPoints {
        /// The solver's minimum.
        needed: usize,
        /// What was given.
        got: usize,
    },
    /// The target points and the image points do not pair up.
    #[error("{target_points} target points but {image_points} image points: they must pair up")]
    MismatchedLengths {
        /// Number of target points.
        target_points: usize,
        /// Number of image points.
        image_points: usize,
    },
    /// A NaN or infinite value in the input.
    #[error("non-finite value in {0}")]
    NonFinite(&'static str),
    /// The camera model cannot be used (zero focal length, NaN...).
    #[error("unusable camera model: {0}")]
    InvalidCamera(String),
    /// A pixel has no ray through the camera model (outside the distortion model's
    /// invertible domain).
    #[error("image point {index} at ({x:.2}, {y:.2}) px has no ray through the camera model")]
    Unprojectable {
        /// Index of the point.
        index: usize,
        /// Its pixel column.
        x: f64,
        /// Its pixel row.
        y: f64,
    },
    /// The points do not determine a pose (all on a line, coincident, not planar
    /// where a planar solver was asked...).
    #[error("degenerate points: {0}")]
    Degenerate(String),
    /// The best pose puts target points behind the camera.
    #[error("{count} of {total} target points would be behind the camera")]
    BehindCamera {
        /// Points with depth <= 0.
        count: usize,
        /// All points.
        total: usize,
    },
    /// Two distinct poses explain the image almost equally well (the planar
    /// ambiguity): choosing one would be a guess.
    #[error(
        "ambiguous pose: a second pose {angle_deg:.1} deg away explains the corners almost as \
         well ({best_rms_px:.3} px against {second_rms_px:.3} px RMS, {significance:.1} \
         standard deviations of noise apart, at least {min_significance:.1} needed): tilt the \
         target or bring more of it into view"
    )]
    Ambiguous {
        /// How many standard deviations of pixel noise the second pose is worse.
        significance: f64,
        /// The least accepted significance.
        min_significance: f64,
        /// RMS reprojection error of the best pose, pixels.
        best_rms_px: f64,
        /// RMS reprojection error of the second-best pose, pixels.
        second_rms_px: f64,
        /// Rotation between the two poses, degrees.
        angle_deg: f64,
    },
    /// The best pose does not explain the image points within the bound asked for.
    #[error("reprojection error {rms_px:.3} px RMS is above the bound of {bound_px:.3} px")]
    ReprojectionError {
        /// The RMS reprojection error of the best pose, pixels.
        rms_px: f64,
        /// The bound asked for, pixels.
        bound_px: f64,
    },
    /// The solver found no pose (no real solution, or a numerical failure).
    #[error("no pose found: {0}")]
    NoSolution(String),
}
