//! A ChESS corner pass of the ChArUco detector that keeps its corner detectors, and
//! with them their image-sized buffers (the upscaled copy, the response map), from
//! one image to the next instead of allocating them for every image.

use std::fmt;
use std::sync::Mutex;

use calib_targets_chessboard::{ChessCorner, DetectorConfig, GrayImageView};
use chess_corners::{CornerDescriptor, Detector};
use nalgebra::Point2;

/// One configuration of the corner library, with detectors ready for reuse.
pub(super) struct CornerPass {
    config: DetectorConfig,
    /// Detectors not in use; a call takes one (or builds one when none is left, as
    /// happens when images are searched in parallel) and returns it afterwards.
    spare: Mutex<Vec<Detector>>,
}

impl fmt::Debug for CornerPass {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("CornerPass")
            .field("config", &self.config)
            .finish_non_exhaustive()
    }
}

impl CornerPass {
    /// A pass with the corner library's configuration `config`.
    pub(super) fn new(config: DetectorConfig) -> Self {
        Self {
            config,
            spare: Mutex::new(Vec::new()),
        }
    }

    /// The corners of `view`, as `calib_targets_chessboard::detect_corners` with
    /// this pass's configuration gives them; none when the library refuses the
    /// image or the configuration.
    pub(super) fn detect(&self, view: &GrayImageView<'_>) -> Vec<ChessCorner> {
        let (Ok(width), Ok(height)) = (u32::try_from(view.width), u32::try_from(view.height))
        else {
            return Vec::new();
        };
        let spare = self.spare.lock().ok().and_then(|mut spare| spare.pop());
        let Some(mut detector) = spare.or_else(|| Detector::new(self.config).ok()) else {
            return Vec::new();
        };
        let corners = detector
            .detect_u8(view.data, width, height)
            .unwrap_or_default()
            .iter()
            .map(chess_corner)
            .collect();
        if let Ok(mut spare) = self.spare.lock() {
            spare.push(detector);
        }
        corners
    }
}

/// The corner the chessboard and ChArUco detectors take for a corner of the corner
/// library, as `calib_targets_chessboard::detect_corners` converts it: no
/// orientation gives the no-information axes.
fn chess_corner(c: &CornerDescriptor) -> ChessCorner {
    let mut corner = ChessCorner::from_position(Point2::new(c.x, c.y));
    corner.strength = c.response;
    if let Some(axes) = c.axes {
        for (to, from) in corner.axes.iter_mut().zip(axes) {
            to.angle = from.angle;
            to.fit_std_error = from.fit_std_error;
        }
    }
    corner.position_covariance = c.position_covariance.map(Into::into);
    corner
}

#[cfg(test)]
mod tests {
    use super::*;
    use calib_targets_chessboard::{default_chess_config, detect_corners};
    use chess_corners::UpscaleConfig;

    /// A chessboard of `square`-pixel squares, shifted by `offset`, with a ramp of
    /// shading so that no two images are alike.
    fn board(width: usize, height: usize, square: usize, offset: usize) -> Vec<u8> {
        (0..width * height)
            .map(|k| {
                let (x, y) = (k % width + offset, k / width + offset);
                let dark = (x / square + y / square).is_multiple_of(2);
                let shade = (x + 2 * y) % 40;
                if dark {
                    30 + shade as u8
                } else {
                    200 + shade as u8
                }
            })
            .collect()
    }

    #[test]
    fn reused_detectors_give_the_libraries_corners() {
        let base = default_chess_config();
        for config in [base, base.with_upscale(UpscaleConfig::Fixed(2))] {
            let pass = CornerPass::new(config);
            for (width, height, square, offset) in [
                (160, 120, 20, 3),
                (97, 131, 15, 0),
                (200, 90, 23, 7),
                (160, 120, 20, 3),
            ] {
                let data = board(width, height, square, offset);
                let view = GrayImageView {
                    width,
                    height,
                    data: &data,
                };
                let expected = detect_corners(&view, &config);
                assert!(expected.len() > 10, "{width}x{height}: too few corners");
                assert_eq!(pass.detect(&view), expected, "{width}x{height}");
            }
        }
    }

    #[test]
    fn an_image_of_a_wrong_size_gives_no_corners() {
        let pass = CornerPass::new(default_chess_config());
        let data = vec![0u8; 10];
        let view = GrayImageView {
            width: 4,
            height: 4,
            data: &data,
        };
        assert!(pass.detect(&view).is_empty());
    }
}
