//! Where a camera's corners fell in its image: counts in a 3x3 grid of regions, so that
//! a calibration can say which parts of the image the board never reached (its
//! distortion there is extrapolated).

use nalgebra::Point2;

/// The image is split into this many columns and rows of regions; every region should
/// hold some corners, or the distortion there is extrapolated.
const REGIONS: usize = 3;

/// Where the used corners of one camera fell: corner counts in a 3x3 grid of image
/// regions, row-major from the top-left.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct RegionCoverage {
    /// Corner count per region, `counts[row][col]`.
    pub counts: [[usize; REGIONS]; REGIONS],
}

impl RegionCoverage {
    /// Counts `pixels` (pixel centres at integer coordinates) into the regions of a
    /// `width x height` image; pixels outside the image are not counted.
    pub fn from_pixels<'a>(
        pixels: impl IntoIterator<Item = &'a Point2<f64>>,
        width: u32,
        height: u32,
    ) -> Self {
        let mut coverage = Self::default();
        let (w, h) = (f64::from(width), f64::from(height));
        for p in pixels {
            let (x, y) = (p.x + 0.5, p.y + 0.5);
            if !(0.0..w).contains(&x) || !(0.0..h).contains(&y) {
                continue;
            }
            let col = ((x / w * REGIONS as f64) as usize).min(REGIONS - 1);
            let row = ((y / h * REGIONS as f64) as usize).min(REGIONS - 1);
            coverage.counts[row][col] += 1;
        }
        coverage
    }

    /// Names of the regions no corner fell in (`top-left`, `centre`, ...).
    pub fn empty_regions(&self) -> Vec<&'static str> {
        const NAMES: [[&str; REGIONS]; REGIONS] = [
            ["top-left", "top", "top-right"],
            ["left", "centre", "right"],
            ["bottom-left", "bottom", "bottom-right"],
        ];
        let mut empty = Vec::new();
        for (row, names) in NAMES.iter().enumerate() {
            for (col, name) in names.iter().enumerate() {
                if self.counts[row][col] == 0 {
                    empty.push(*name);
                }
            }
        }
        empty
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn regions_count_pixels_and_name_the_empty_ones() {
        let pixels = [
            Point2::new(0.0, 0.0),
            Point2::new(639.0, 479.0),
            Point2::new(320.0, 240.0),
            Point2::new(-1.0, 10.0),
        ];
        let coverage = RegionCoverage::from_pixels(&pixels, 640, 480);
        assert_eq!(coverage.counts, [[1, 0, 0], [0, 1, 0], [0, 0, 1]]);
        assert_eq!(
            coverage.empty_regions(),
            ["top", "top-right", "left", "right", "bottom-left", "bottom"]
        );
    }
}
