//! Where in the image a partly found ChArUco board lies: the homography from the
//! board's grid to the image, fitted to the corners found, bounds the whole board.

use nalgebra::{Matrix3, Point2, Vector3};

use crate::geometry::homography_dlt;

/// The fitted homography must place every corner found within this share of the
/// square next to it; a wider miss (a mislabelled corner, a fit to a handful of
/// corners bent by the lens) leaves the board's extent unknown.
const FIT_TOLERANCE: f64 = 0.1;

/// Squares the region holds past the board's edge on every side, room for the
/// extrapolation's error.
const MARGIN_SQUARES: f64 = 1.0;

/// Pixels the region holds past the squares, for the corner detector's support.
const MARGIN_PX: f64 = 8.0;

/// A rectangle of an image, `[x0, x1) x [y0, y1)` in whole pixels.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) struct Region {
    /// First column.
    pub x0: usize,
    /// First row.
    pub y0: usize,
    /// Column past the last.
    pub x1: usize,
    /// Row past the last.
    pub y1: usize,
}

impl Region {
    /// The region's pixels of an image `width` pixels wide, row after row; `None`
    /// when the image is too small for the region.
    pub(super) fn crop(&self, data: &[u8], width: usize) -> Option<Vec<u8>> {
        let mut out = Vec::with_capacity((self.x1 - self.x0) * (self.y1 - self.y0));
        for y in self.y0..self.y1 {
            out.extend_from_slice(data.get(y * width + self.x0..y * width + self.x1)?);
        }
        Some(out)
    }
}

/// The region of a `width x height` image that holds the whole `cols x rows` grid of
/// which `corners` (ids below `cols * rows`, each once) were found, with its outer
/// squares and margins; `None` when the corners do not fix it (fewer than four, a
/// degenerate or poor homography, a part of the board behind the camera) or the region
/// is the whole image.
pub(super) fn board_region(
    corners: &[(usize, Point2<f64>)],
    cols: usize,
    rows: usize,
    width: usize,
    height: usize,
) -> Option<Region> {
    let grid = |id: usize| Point2::new((id % cols) as f64, (id / cols) as f64);
    let grid_points: Vec<Point2<f64>> = corners.iter().map(|&(id, _)| grid(id)).collect();
    let image_points: Vec<Point2<f64>> = corners.iter().map(|&(_, p)| p).collect();
    let image_from_grid = homography_dlt(&grid_points, &image_points).ok()?;
    // The corners found fix which side of the board's horizon is in front.
    let side = (image_from_grid * grid_points.first()?.to_homogeneous())
        .z
        .signum();
    let board = Projection {
        image_from_grid: side * image_from_grid,
    };
    let fits = grid_points.iter().zip(&image_points).all(|(g, p)| {
        matches!((board.project(g), board.local_square(g)),
            (Some(q), Some(square)) if (q - p).norm() <= FIT_TOLERANCE * square)
    });
    if !fits {
        return None;
    }
    // The board's edge runs one square outside its inner corners.
    let low = -1.0 - MARGIN_SQUARES;
    let (right, bottom) = (
        (cols as f64) + MARGIN_SQUARES,
        (rows as f64) + MARGIN_SQUARES,
    );
    let outline = [(low, low), (right, low), (right, bottom), (low, bottom)]
        .map(|(x, y)| board.project(&Point2::new(x, y)));
    let (mut x0, mut y0, mut x1, mut y1) = (f64::INFINITY, f64::INFINITY, f64::MIN, f64::MIN);
    for q in outline {
        let q = q?;
        (x0, y0, x1, y1) = (x0.min(q.x), y0.min(q.y), x1.max(q.x), y1.max(q.y));
    }
    let clamp = |v: f64, size: usize| v.clamp(0.0, size as f64) as usize;
    let region = Region {
        x0: clamp((x0 - MARGIN_PX).floor(), width),
        y0: clamp((y0 - MARGIN_PX).floor(), height),
        x1: clamp((x1 + MARGIN_PX).ceil() + 1.0, width),
        y1: clamp((y1 + MARGIN_PX).ceil() + 1.0, height),
    };
    let whole = region.x0 == 0 && region.y0 == 0 && region.x1 == width && region.y1 == height;
    (region.x1 > region.x0 && region.y1 > region.y0 && !whole).then_some(region)
}

/// A homography from the board's grid to the image, scaled so that the grid points in
/// front of the camera have a positive third coordinate.
struct Projection {
    image_from_grid: Matrix3<f64>,
}

impl Projection {
    /// The image of the grid point `p`, when it lies in front of the camera.
    fn project(&self, p: &Point2<f64>) -> Option<Point2<f64>> {
        let v: Vector3<f64> = self.image_from_grid * p.to_homogeneous();
        let q = Point2::new(v.x / v.z, v.y / v.z);
        (v.z > 0.0 && q.x.is_finite() && q.y.is_finite()).then_some(q)
    }

    /// The shorter side, in pixels, of the image of the grid square at `p`.
    fn local_square(&self, p: &Point2<f64>) -> Option<f64> {
        let q = self.project(p)?;
        let along = self.project(&Point2::new(p.x + 1.0, p.y))?;
        let across = self.project(&Point2::new(p.x, p.y + 1.0))?;
        Some((along - q).norm().min((across - q).norm()))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The corners of a 9x6 grid seen under a homography: squares of about 30 pixels
    /// with some perspective, the grid's origin at (300, 200).
    fn seen(ids: impl Iterator<Item = usize>) -> Vec<(usize, Point2<f64>)> {
        let h = Matrix3::new(30.0, 4.0, 300.0, -3.0, 28.0, 200.0, 0.002, -0.001, 1.0);
        ids.map(|id| {
            let g = Point2::new((id % 9) as f64, (id / 9) as f64);
            let v = h * g.to_homogeneous();
            (id, Point2::new(v.x / v.z, v.y / v.z))
        })
        .collect()
    }

    #[test]
    fn the_region_holds_the_whole_board_from_a_part_of_it() {
        let all = seen(0..54);
        let part = seen((0..54).filter(|id| id % 9 < 4 && id / 9 < 3));
        let region = board_region(&part, 9, 6, 1024, 768).expect("a region");
        for (_, p) in &all {
            assert!(p.x >= region.x0 as f64 + 30.0 && p.x < region.x1 as f64 - 30.0);
            assert!(p.y >= region.y0 as f64 + 30.0 && p.y < region.y1 as f64 - 30.0);
        }
        assert!(region.x1 - region.x0 < 600 && region.y1 - region.y0 < 400);
        let data = vec![7u8; 1024 * 768];
        let crop = region.crop(&data, 1024).expect("inside the image");
        assert_eq!(
            crop.len(),
            (region.x1 - region.x0) * (region.y1 - region.y0)
        );
    }

    #[test]
    fn no_region_without_a_trustworthy_fit() {
        // Three corners, then four on one line: no homography.
        assert_eq!(board_region(&seen(0..3), 9, 6, 1024, 768), None);
        assert_eq!(board_region(&seen(0..4), 9, 6, 1024, 768), None);
        // A mislabelled corner: the fit misses it by a square.
        let mut wrong = seen(0..27);
        wrong[13].1 = wrong[14].1;
        assert_eq!(board_region(&wrong, 9, 6, 1024, 768), None);
    }
}
