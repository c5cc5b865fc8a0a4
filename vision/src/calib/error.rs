use thiserror::Error;

/// Why a calibration could not be computed. Each message says what was wrong and what
/// to do about it.
#[derive(Clone, Debug, Error, PartialEq)]
pub enum CalibError {
    /// The image size is zero.
    #[error("image size {width}x{height} is empty: give the size of the calibrated images")]
    EmptyImage {
        /// Image width in pixels.
        width: u32,
        /// Image height in pixels.
        height: u32,
    },
    /// A view's target points and pixels differ in number.
    #[error(
        "view {view}: {points} target points but {pixels} pixels: give one pixel per target point"
    )]
    MismatchedView {
        /// Index of the view.
        view: usize,
        /// Number of target points.
        points: usize,
        /// Number of pixels.
        pixels: usize,
    },
    /// A view holds a non-finite coordinate.
    #[error("view {view}: a target point or pixel is not finite")]
    NonFinite {
        /// Index of the view.
        view: usize,
    },
    /// A view's target points are not in the target's plane `z = 0`.
    #[error(
        "view {view}: target points must lie in the plane z = 0 of the target frame (planar targets only)"
    )]
    NonPlanarTarget {
        /// Index of the view.
        view: usize,
    },
    /// Fewer usable views than the solver needs.
    #[error(
        "{usable} usable views, at least {needed} are needed ({rejected} rejected): collect more views of the target, 15 to 25 at varied positions and tilts"
    )]
    TooFewViews {
        /// Views left to calibrate with.
        usable: usize,
        /// Views the solver needs.
        needed: usize,
        /// Views rejected as unusable or not fitting.
        rejected: usize,
    },
    /// Every view is nearly fronto-parallel, so the focal length is not observable.
    #[error(
        "focal length is not observable: every view is within {max_tilt_degrees:.1} degrees of fronto-parallel; tilt the target by 20 to 45 degrees about its horizontal and vertical axes in several views"
    )]
    FrontoParallel {
        /// The largest tilt among the views, degrees.
        max_tilt_degrees: f64,
    },
    /// The initial guess does not match the requested model or image.
    #[error("the intrinsic guess is {guess}, but the calibration asks for {requested}")]
    GuessMismatch {
        /// What the guess is.
        guess: String,
        /// What the options ask for.
        requested: String,
    },
    /// A fixed distortion index is beyond the model's coefficients.
    #[error(
        "fixed distortion coefficient {index} does not exist: the {model} model has {count} coefficients"
    )]
    InvalidFixedCoefficient {
        /// The index given.
        index: usize,
        /// The model's name.
        model: &'static str,
        /// Its number of coefficients.
        count: usize,
    },
    /// The solver did not reach a finite solution.
    #[error(
        "the calibration diverged (non-finite parameters): check that the target points match the detected corners"
    )]
    Diverged,
}
