//! What a detector finds, and the trait every detector implements.

use nalgebra::{Point2, Point3};

use super::target::Target;
use super::{BoardError, Gray};
use crate::image::Image;

/// A target found in an image.
#[derive(Clone, Debug, PartialEq)]
pub struct Detection {
    /// Image positions of the corners found, pixel centres at integer coordinates,
    /// in target order (ascending ids).
    pub corners: Vec<Point2<f64>>,
    /// Target corner id of each entry of `corners`: its index in
    /// [`Target::object_points`].
    pub ids: Vec<usize>,
    /// Median side of a square in the image, pixels.
    pub square_px: f64,
}

impl Detection {
    /// The target-frame points of the detected corners, matching `corners` entry for
    /// entry; `None` when an id is not a corner of `target`.
    pub fn object_points(&self, target: &Target) -> Option<Vec<Point3<f64>>> {
        let all = target.object_points();
        self.ids.iter().map(|&id| all.get(id).copied()).collect()
    }
}

/// A detector of one calibration target.
pub trait TargetDetector {
    /// The target it looks for.
    fn target(&self) -> &Target;

    /// Looks for the target in a grey image. A chessboard is found only in full
    /// (every inner corner), else `None`. A ChArUco board may be partly visible: the
    /// detection holds the corners found (`ids` a subset of the target's), and `None`
    /// when fewer than [`MIN_CHARUCO_CORNERS`](super::MIN_CHARUCO_CORNERS) are found
    /// or all lie on one line of the board.
    fn detect_gray(&self, gray: &Gray) -> Option<Detection>;

    /// Looks for the target in any image (mono or colour, 8 or 16 bits); an error
    /// only when the image itself is malformed.
    fn detect(&self, image: &Image) -> Result<Option<Detection>, BoardError> {
        Ok(self.detect_gray(&Gray::from_image(image)?))
    }
}
