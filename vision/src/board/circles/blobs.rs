//! Dark blobs that may be circles of a grid: pixels darker than their surroundings
//! (below [`DARK_FRACTION`] of the local mean, so uneven light and any exposure
//! work alike), joined into 8-connected components, kept when their second moments
//! describe a filled ellipse.

use nalgebra::{Matrix2, Point2};

use crate::board::Gray;

/// A pixel is dark when below this fraction of the mean grey level around it.
const DARK_FRACTION: u64 = 4;
/// Denominator of [`DARK_FRACTION`]: dark below 4 / 5 of the local mean.
const DARK_DENOMINATOR: u64 = 5;
/// The local mean is taken over a square window of this fraction of the shorter image
/// side (twice the half-width), at least [`MIN_WINDOW_HALF`] pixels from its centre to
/// each side: wide enough to hold a circle and the light around it.
const WINDOW_FRACTION: usize = 6;
/// Smallest half-width of the mean's window, pixels.
const MIN_WINDOW_HALF: usize = 16;
/// Blobs of fewer pixels are too small to locate to a fraction of a pixel.
pub(super) const MIN_AREA: usize = 16;
/// Blobs larger than this fraction of the image are not circles of a grid.
const MAX_AREA_FRACTION: usize = 16;
/// Smallest ratio of the minor to the major axis: a circle seen at 78 degrees.
const MIN_AXIS_RATIO: f64 = 0.2;
/// A filled ellipse covers exactly the area its second moments give; the blob's area
/// may differ from it by this fraction (pixelation, noise at the edge).
const MAX_FILL_ERROR: f64 = 0.15;

/// A dark blob that looks like a filled ellipse.
#[derive(Clone, Debug, PartialEq)]
pub(super) struct Blob {
    /// Centroid, pixels (pixel centres at integer coordinates).
    pub centre: Point2<f64>,
    /// Covariance of the blob's pixel positions, pixels²: an ellipse of semi-axes `a`,
    /// `b` has eigenvalues `a² / 4` and `b² / 4`.
    pub covariance: Matrix2<f64>,
    /// Pixels.
    pub area: usize,
}

/// Running sums of one component.
#[derive(Clone, Copy, Default)]
struct Moments {
    count: u64,
    x: f64,
    y: f64,
    xx: f64,
    yy: f64,
    xy: f64,
    touches_border: bool,
}

impl Moments {
    fn add(&mut self, x: usize, y: usize, width: usize, height: usize) {
        let (fx, fy) = (x as f64, y as f64);
        self.count += 1;
        self.x += fx;
        self.y += fy;
        self.xx += fx * fx;
        self.yy += fy * fy;
        self.xy += fx * fy;
        if x == 0 || y == 0 || x + 1 == width || y + 1 == height {
            self.touches_border = true;
        }
    }

    /// The blob, when the component is a filled ellipse of a usable size.
    fn blob(&self, max_area: usize) -> Option<Blob> {
        let area = usize::try_from(self.count).ok()?;
        if self.touches_border || !(MIN_AREA..=max_area).contains(&area) {
            return None;
        }
        let n = self.count as f64;
        let (mx, my) = (self.x / n, self.y / n);
        let covariance = Matrix2::new(
            self.xx / n - mx * mx,
            self.xy / n - mx * my,
            self.xy / n - mx * my,
            self.yy / n - my * my,
        );
        let eigen = covariance.symmetric_eigen();
        let (low, high) = (eigen.eigenvalues.min(), eigen.eigenvalues.max());
        if low.is_nan() || low <= 0.0 || (low / high).sqrt() < MIN_AXIS_RATIO {
            return None;
        }
        // A filled ellipse of semi-axes a, b: area pi a b, eigenvalues a^2/4, b^2/4;
        // a pixelated one also has the 1/12 px^2 of each pixel's own spread.
        let ellipse_area =
            4.0 * std::f64::consts::PI * ((low + 1.0 / 12.0) * (high + 1.0 / 12.0)).sqrt();
        if ((n - ellipse_area) / ellipse_area).abs() > MAX_FILL_ERROR {
            return None;
        }
        Some(Blob {
            centre: Point2::new(mx, my),
            covariance,
            area,
        })
    }
}

/// The dark blobs of `gray` that look like filled ellipses, not touching the border.
pub(super) fn dark_blobs(gray: &Gray) -> Vec<Blob> {
    let (width, height) = (gray.width, gray.height);
    if width < 3 || height < 3 {
        return Vec::new();
    }
    let dark = dark_mask(gray);
    let max_area = width * height / MAX_AREA_FRACTION;
    let mut seen = vec![false; width * height];
    let mut stack = Vec::new();
    let mut blobs = Vec::new();
    for start in 0..width * height {
        if !dark[start] || seen[start] {
            continue;
        }
        let mut moments = Moments::default();
        seen[start] = true;
        stack.push(start);
        while let Some(k) = stack.pop() {
            let (x, y) = (k % width, k / width);
            moments.add(x, y, width, height);
            for ny in y.saturating_sub(1)..=(y + 1).min(height - 1) {
                for nx in x.saturating_sub(1)..=(x + 1).min(width - 1) {
                    let n = ny * width + nx;
                    if dark[n] && !seen[n] {
                        seen[n] = true;
                        stack.push(n);
                    }
                }
            }
        }
        blobs.extend(moments.blob(max_area));
    }
    blobs
}

/// Whether each pixel is darker than [`DARK_FRACTION`] of the mean of the window around
/// it (the window clipped to the image), from an integral image.
fn dark_mask(gray: &Gray) -> Vec<bool> {
    let (width, height) = (gray.width, gray.height);
    let stride = width + 1;
    let mut integral = vec![0u64; stride * (height + 1)];
    for y in 0..height {
        let mut row_sum = 0u64;
        for x in 0..width {
            row_sum += u64::from(gray.data[y * width + x]);
            integral[(y + 1) * stride + x + 1] = integral[y * stride + x + 1] + row_sum;
        }
    }
    let half = (width.min(height) / WINDOW_FRACTION / 2).max(MIN_WINDOW_HALF);
    let mut dark = vec![false; width * height];
    for y in 0..height {
        let (top, bottom) = (y.saturating_sub(half), (y + half + 1).min(height));
        for x in 0..width {
            let (left, right) = (x.saturating_sub(half), (x + half + 1).min(width));
            let sum = integral[bottom * stride + right] + integral[top * stride + left]
                - integral[top * stride + right]
                - integral[bottom * stride + left];
            let count = ((bottom - top) * (right - left)) as u64;
            let value = u64::from(gray.data[y * width + x]);
            dark[y * width + x] = value * count * DARK_DENOMINATOR < sum * DARK_FRACTION;
        }
    }
    dark
}

#[cfg(test)]
mod tests {
    use super::*;

    fn disc_image(width: usize, height: usize, discs: &[(f64, f64, f64)]) -> Gray {
        let mut data = vec![200u8; width * height];
        for y in 0..height {
            for x in 0..width {
                for &(cx, cy, r) in discs {
                    if (x as f64 - cx).powi(2) + (y as f64 - cy).powi(2) <= r * r {
                        data[y * width + x] = 20;
                    }
                }
            }
        }
        Gray {
            width,
            height,
            data,
        }
    }

    #[test]
    fn discs_are_found_and_squares_lines_and_border_blobs_are_not() {
        let mut gray = disc_image(
            200,
            120,
            &[(40.0, 40.0, 8.0), (100.0, 60.0, 12.0), (0.0, 60.0, 9.0)],
        );
        // A long bar and a tiny speck.
        for x in 130..190 {
            for y in 20..24 {
                gray.data[y * 200 + x] = 10;
            }
        }
        gray.data[100 * 200 + 150] = 0;
        let blobs = dark_blobs(&gray);
        assert_eq!(blobs.len(), 2, "{blobs:?}");
        assert!((blobs[0].centre - Point2::new(40.0, 40.0)).norm() < 1e-9);
        assert!((blobs[1].centre - Point2::new(100.0, 60.0)).norm() < 1e-9);
        let area = std::f64::consts::PI * 12.0 * 12.0;
        assert!((blobs[1].area as f64 - area).abs() < 0.03 * area);
    }
}
