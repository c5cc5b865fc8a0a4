//! From a labelled grid of corners (as a grid detector returns it, with its own axes
//! and origin) to the target's corners in target order.
//!
//! Order and orientation rule. The target frame's x, y and z (into the board) form a
//! right-handed frame, so seen from the front its x axis turned a quarter clockwise
//! (image y down) is its y axis: of the eight ways to lay the board's axes on the
//! grid, those of the wrong handedness are dropped, and those whose dimensions differ
//! from the board's. Of the remaining two (four for a square board), the board's
//! colouring decides: the square diagonally outside the first corner is black (the
//! same convention as `synth::Chessboard` and OpenCV's `(cols + 1) x (rows + 1)`
//! boards with a black corner square). When the colouring cannot tell them apart
//! (`cols + rows` even), the first corner is the one nearest the image's top-left
//! (smallest `x + y`). Both rules depend on the board, not on the camera, so the two
//! images of a stereo pair get the same order.

use std::collections::HashMap;

use nalgebra::{Point2, Vector2};

use super::Gray;

/// One labelled corner of a grid.
#[derive(Clone, Copy, Debug)]
pub(crate) struct GridCorner {
    /// Grid column.
    pub u: i32,
    /// Grid row.
    pub v: i32,
    /// Image position.
    pub position: Point2<f64>,
}

/// A complete rectangular grid, `width x height` corners, row-major.
#[derive(Clone, Debug)]
struct Rect {
    width: usize,
    height: usize,
    points: Vec<Point2<f64>>,
}

impl Rect {
    fn at(&self, a: usize, b: usize) -> Point2<f64> {
        self.points[b * self.width + a]
    }

    /// Corner `(a, b)`, extrapolated linearly beyond each side.
    fn extended(&self, a: isize, b: isize) -> Point2<f64> {
        let clamp = |k: isize, n: usize| k.clamp(0, n as isize - 1) as usize;
        let (ca, cb) = (clamp(a, self.width), clamp(b, self.height));
        let mut p = self.at(ca, cb);
        let (w, h) = (self.width as isize, self.height as isize);
        if a < 0 {
            p += (self.at(ca, cb) - self.at(ca + 1, cb)) * (-a) as f64;
        } else if a >= w {
            p += (self.at(ca, cb) - self.at(ca - 1, cb)) * (a - w + 1) as f64;
        }
        if b < 0 {
            p += (self.at(ca, cb) - self.at(ca, cb + 1)) * (-b) as f64;
        } else if b >= h {
            p += (self.at(ca, cb) - self.at(ca, cb - 1)) * (b - h + 1) as f64;
        }
        p
    }

    /// Mean grey level around the centre of the square whose top-left corner is
    /// `(a, b)` (indices may reach one beyond each side); `None` off the image.
    fn square_level(&self, gray: &Gray, a: isize, b: isize) -> Option<f64> {
        let p00 = self.extended(a, b);
        let p10 = self.extended(a + 1, b);
        let p01 = self.extended(a, b + 1);
        let p11 = self.extended(a + 1, b + 1);
        let centre = Point2::from((p00.coords + p10.coords + p01.coords + p11.coords) / 4.0);
        let du: Vector2<f64> = (p10 - p00 + (p11 - p01)) / 2.0;
        let dv: Vector2<f64> = (p01 - p00 + (p11 - p10)) / 2.0;
        let mut sum = 0.0;
        for (su, sv) in [
            (0.0, 0.0),
            (-0.2, -0.2),
            (0.2, -0.2),
            (-0.2, 0.2),
            (0.2, 0.2),
        ] {
            let p = centre + du * su + dv * sv;
            sum += gray.sample(p.x, p.y)?;
        }
        Some(sum / 5.0)
    }

    /// Amplitude of the black/white alternation along a line of squares:
    /// `|sum (-1)^k level_k| / n`, or `None` off the image.
    fn alternation(
        &self,
        gray: &Gray,
        squares: impl Iterator<Item = (isize, isize)>,
    ) -> Option<f64> {
        let mut sum = 0.0;
        let mut n = 0;
        for (k, (a, b)) in squares.enumerate() {
            let level = self.square_level(gray, a, b)?;
            sum += if k % 2 == 0 { level } else { -level };
            n += 1;
        }
        (n > 0).then(|| sum.abs() / n as f64)
    }

    fn sub(&self, a0: usize, b0: usize, width: usize, height: usize) -> Rect {
        let points = (b0..b0 + height)
            .flat_map(|b| (a0..a0 + width).map(move |a| (a, b)))
            .map(|(a, b)| self.at(a, b))
            .collect();
        Rect {
            width,
            height,
            points,
        }
    }

    fn transposed(&self) -> Rect {
        let points = (0..self.width)
            .flat_map(|a| (0..self.height).map(move |b| (a, b)))
            .map(|(a, b)| self.at(a, b))
            .collect();
        Rect {
            width: self.height,
            height: self.width,
            points,
        }
    }
}

/// The rectangle of a labelled grid, with corners missing inside its bounding box
/// (at most a quarter of them) predicted from their neighbours; `None` when more are
/// missing.
fn complete_rect(corners: &[GridCorner]) -> Option<Rect> {
    let u0 = corners.iter().map(|c| c.u).min()?;
    let v0 = corners.iter().map(|c| c.v).min()?;
    let width = (corners.iter().map(|c| c.u).max()? - u0 + 1) as usize;
    let height = (corners.iter().map(|c| c.v).max()? - v0 + 1) as usize;
    if width < 2 || height < 2 || 4 * corners.len() < 3 * width * height {
        return None;
    }
    let by_label: HashMap<(i32, i32), Point2<f64>> =
        corners.iter().map(|c| ((c.u, c.v), c.position)).collect();
    let mut points: Vec<Option<Point2<f64>>> = (0..height as i32)
        .flat_map(|b| (0..width as i32).map(move |a| (a, b)))
        .map(|(a, b)| by_label.get(&(a + u0, b + v0)).copied())
        .collect();
    let (w, h) = (width as isize, height as isize);
    loop {
        let get = |points: &[Option<Point2<f64>>], a: isize, b: isize| {
            ((0..w).contains(&a) && (0..h).contains(&b))
                .then(|| points[(b * w + a) as usize])
                .flatten()
        };
        let mut filled = Vec::new();
        for b in 0..h {
            for a in 0..w {
                if get(&points, a, b).is_some() {
                    continue;
                }
                // Midpoints between neighbours, then steps continued from two
                // neighbours on one side; the mean of what is available.
                let mut sum = Vector2::zeros();
                let mut n = 0.0;
                for (da, db) in [(1, 0), (0, 1)] {
                    if let (Some(p), Some(q)) =
                        (get(&points, a - da, b - db), get(&points, a + da, b + db))
                    {
                        sum += (p.coords + q.coords) / 2.0;
                        n += 1.0;
                    }
                }
                if n == 0.0 {
                    for (da, db) in [(1, 0), (-1, 0), (0, 1), (0, -1)] {
                        if let (Some(p), Some(q)) = (
                            get(&points, a + da, b + db),
                            get(&points, a + 2 * da, b + 2 * db),
                        ) {
                            sum += p.coords * 2.0 - q.coords;
                            n += 1.0;
                        }
                    }
                }
                if n > 0.0 {
                    filled.push(((b * w + a) as usize, Point2::from(sum / n)));
                }
            }
        }
        if filled.is_empty() {
            break;
        }
        for (index, p) in filled {
            points[index] = Some(p);
        }
    }
    Some(Rect {
        width,
        height,
        points: points.into_iter().collect::<Option<Vec<_>>>()?,
    })
}

/// Adds the one line of corners a grid lacks to be `cols x rows` (the detector
/// often misses the corners of a line near the image border), extrapolated on the
/// side where the board goes on: two squares beyond the grid on that side, the
/// squares still alternate (or leave the image), while on the other side they are
/// the margin. `None` when that does not single out one side. The caller checks that
/// the added corners are real corners.
fn grow_to(rect: &Rect, gray: &Gray, cols: usize, rows: usize) -> Option<Rect> {
    let inside = rect.alternation(gray, (0..rect.width as isize - 1).map(|a| (a, 0)))?;
    let board_goes_on = |alternation: Option<f64>| alternation.is_none_or(|s| s >= 0.5 * inside);
    let (w, h) = (rect.width as isize, rect.height as isize);
    // (first new index along the grown axis, whether rows grow)
    let mut sides = Vec::new();
    if rect.width == cols && rect.height + 1 == rows {
        if board_goes_on(rect.alternation(gray, (0..w - 1).map(|a| (a, -2)))) {
            sides.push((-1, true));
        }
        if board_goes_on(rect.alternation(gray, (0..w - 1).map(|a| (a, h)))) {
            sides.push((h, true));
        }
    } else if rect.height == rows && rect.width + 1 == cols {
        if board_goes_on(rect.alternation(gray, (0..h - 1).map(|b| (-2, b)))) {
            sides.push((-1, false));
        }
        if board_goes_on(rect.alternation(gray, (0..h - 1).map(|b| (w, b)))) {
            sides.push((w, false));
        }
    }
    let [(start, rows_grow)] = sides[..] else {
        return None;
    };
    let (a_range, b_range) = if rows_grow {
        (0..w, start.min(0)..start.max(h - 1) + 1)
    } else {
        (start.min(0)..start.max(w - 1) + 1, 0..h)
    };
    let points = b_range
        .flat_map(|b| a_range.clone().map(move |a| (a, b)))
        .map(|(a, b)| rect.extended(a, b))
        .collect();
    Some(Rect {
        width: cols,
        height: rows,
        points,
    })
}

/// Removes outer lines of corners that are not inner corners of a chessboard (the
/// squares beyond them do not alternate) until the grid is `cols x rows`; `None`
/// when it cannot get there.
fn trim_to(rect: Rect, gray: &Gray, cols: usize, rows: usize) -> Option<Rect> {
    if rect.width < cols || rect.height < rows {
        return None;
    }
    if rect.width == cols && rect.height == rows {
        return Some(rect);
    }
    // Reference alternation: the first line of squares inside the grid.
    let inside = rect.alternation(gray, (0..rect.width as isize - 1).map(|a| (a, 0)))?;
    let spurious = |alternation: Option<f64>| alternation.is_none_or(|s| s < 0.5 * inside);
    let (w, h) = (rect.width as isize, rect.height as isize);
    let mut candidates: Vec<(usize, usize, usize, usize)> = Vec::new();
    if rect.width > cols {
        if spurious(rect.alternation(gray, (0..h - 1).map(|b| (-1, b)))) {
            candidates.push((1, 0, rect.width - 1, rect.height));
        }
        if spurious(rect.alternation(gray, (0..h - 1).map(|b| (w - 1, b)))) {
            candidates.push((0, 0, rect.width - 1, rect.height));
        }
    }
    if rect.height > rows {
        if spurious(rect.alternation(gray, (0..w - 1).map(|a| (a, -1)))) {
            candidates.push((0, 1, rect.width, rect.height - 1));
        }
        if spurious(rect.alternation(gray, (0..w - 1).map(|a| (a, h - 1)))) {
            candidates.push((0, 0, rect.width, rect.height - 1));
        }
    }
    let &(a0, b0, width, height) = candidates.first()?;
    trim_to(rect.sub(a0, b0, width, height), gray, cols, rows)
}

/// The board's `cols x rows` corners in target order from a labelled grid, or `None`
/// when the grid is not exactly one such board (after removing outer lines that are
/// not chessboard corners). See the module documentation for the order rule.
pub(crate) fn board_corners(
    corners: &[GridCorner],
    gray: &Gray,
    cols: usize,
    rows: usize,
) -> Option<Vec<Point2<f64>>> {
    let rect = complete_rect(corners)?;
    let mut layouts = Vec::new();
    for candidate in [rect.clone(), rect.transposed()] {
        if let Some(fitted) = trim_to(candidate.clone(), gray, cols, rows)
            .or_else(|| grow_to(&candidate, gray, cols, rows))
        {
            layouts.push(fitted);
        }
    }
    let mut orderings: Vec<Vec<Point2<f64>>> = Vec::new();
    for layout in &layouts {
        for (flip_a, flip_b) in [(false, false), (true, true), (true, false), (false, true)] {
            let ordered: Vec<Point2<f64>> = (0..rows)
                .flat_map(|j| (0..cols).map(move |i| (i, j)))
                .map(|(i, j)| {
                    let a = if flip_a { cols - 1 - i } else { i };
                    let b = if flip_b { rows - 1 - j } else { j };
                    layout.at(a, b)
                })
                .collect();
            if right_handed(&ordered, cols, rows) && !orderings.contains(&ordered) {
                orderings.push(ordered);
            }
        }
    }
    choose_ordering(orderings, gray, cols, rows)
}

/// Whether the corners, in target order, turn from x to y clockwise in the image.
fn right_handed(ordered: &[Point2<f64>], cols: usize, rows: usize) -> bool {
    let x = ordered[cols - 1] - ordered[0];
    let y = ordered[(rows - 1) * cols] - ordered[0];
    x.x * y.y - x.y * y.x > 0.0
}

/// Applies the colouring rule, then the top-left rule, to candidate orderings.
fn choose_ordering(
    orderings: Vec<Vec<Point2<f64>>>,
    gray: &Gray,
    cols: usize,
    rows: usize,
) -> Option<Vec<Point2<f64>>> {
    let scored: Vec<(f64, f64, Vec<Point2<f64>>)> = orderings
        .into_iter()
        .filter_map(|ordered| {
            let (score, magnitude) = colour_score(&ordered, gray, cols, rows)?;
            Some((score, magnitude, ordered))
        })
        .collect();
    let best = scored.iter().map(|s| s.0).fold(f64::NEG_INFINITY, f64::max);
    let magnitude = scored.iter().map(|s| s.1).fold(0.0, f64::max);
    // Orderings the colouring cannot separate score the same up to rounding.
    let tolerance = 1e-9 * magnitude.max(1.0);
    scored
        .into_iter()
        .filter(|s| s.0 >= best - tolerance)
        .map(|s| s.2)
        .min_by(|p, q| (p[0].x + p[0].y).total_cmp(&(q[0].x + q[0].y)))
}

/// How well the squares' grey levels match the colouring for corners in target
/// order: the sum of the levels of the squares that should be white minus those that
/// should be black (the square whose top-left corner is inner corner `(i, j)` is
/// black when `i + j` is even), and the sum of all levels.
fn colour_score(
    ordered: &[Point2<f64>],
    gray: &Gray,
    cols: usize,
    rows: usize,
) -> Option<(f64, f64)> {
    let rect = Rect {
        width: cols,
        height: rows,
        points: ordered.to_vec(),
    };
    let mut score = 0.0;
    let mut magnitude = 0.0;
    for j in 0..rows - 1 {
        for i in 0..cols - 1 {
            let level = rect.square_level(gray, i as isize, j as isize)?;
            score += if (i + j) % 2 == 0 { -level } else { level };
            magnitude += level;
        }
    }
    Some((score, magnitude))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A fronto-parallel board of `cols x rows` inner corners, `square` px squares,
    /// first corner at `origin`, black square outside the first corner.
    fn board_image(cols: usize, rows: usize, square: usize, origin: usize) -> Gray {
        let width = origin * 2 + cols * square;
        let height = origin * 2 + rows * square;
        let mut data = vec![255u8; width * height];
        for y in 0..height {
            for x in 0..width {
                let a =
                    (x as isize - origin as isize + square as isize).div_euclid(square as isize);
                let b =
                    (y as isize - origin as isize + square as isize).div_euclid(square as isize);
                if (0..=cols as isize).contains(&a)
                    && (0..=rows as isize).contains(&b)
                    && (a + b) % 2 == 0
                {
                    data[y * width + x] = 0;
                }
            }
        }
        Gray {
            width,
            height,
            data,
        }
    }

    fn grid(cols: usize, rows: usize, square: f64, origin: f64) -> Vec<GridCorner> {
        (0..rows)
            .flat_map(|j| (0..cols).map(move |i| (i, j)))
            .map(|(i, j)| GridCorner {
                u: i as i32,
                v: j as i32,
                position: Point2::new(
                    origin + i as f64 * square - 0.5,
                    origin + j as f64 * square - 0.5,
                ),
            })
            .collect()
    }

    #[test]
    fn colouring_fixes_the_first_corner() {
        let gray = board_image(9, 6, 20, 40);
        // The grid arrives rotated by 180 degrees: labels run from the far corner.
        let rotated: Vec<GridCorner> = grid(9, 6, 20.0, 40.0)
            .into_iter()
            .map(|c| GridCorner {
                u: 8 - c.u + 5,
                v: 5 - c.v - 2,
                ..c
            })
            .collect();
        let ordered = board_corners(&rotated, &gray, 9, 6).unwrap();
        assert_eq!(ordered[0], Point2::new(39.5, 39.5));
        assert_eq!(ordered[1], Point2::new(59.5, 39.5));
        assert_eq!(ordered[9], Point2::new(39.5, 59.5));
        // Transposed labels give the same order.
        let transposed: Vec<GridCorner> = rotated
            .iter()
            .map(|c| GridCorner {
                u: c.v,
                v: c.u,
                ..*c
            })
            .collect();
        assert_eq!(board_corners(&transposed, &gray, 9, 6).unwrap(), ordered);
    }

    #[test]
    fn wrong_sizes_and_sparse_grids_are_refused() {
        let gray = board_image(9, 6, 20, 40);
        let corners = grid(9, 6, 20.0, 40.0);
        assert!(board_corners(&corners, &gray, 8, 5).is_none());
        assert!(board_corners(&corners, &gray, 10, 6).is_none());
        // A few missing corners are predicted; a sparse grid is refused.
        let mut holed = corners.clone();
        holed.remove(20);
        let filled = board_corners(&holed, &gray, 9, 6).unwrap();
        assert!((filled[20] - Point2::new(79.5, 79.5)).norm() < 1e-9);
        let sparse: Vec<GridCorner> = corners.iter().copied().step_by(2).collect();
        assert!(board_corners(&sparse, &gray, 9, 6).is_none());
    }

    #[test]
    fn a_spurious_outer_line_is_trimmed() {
        // A column of corners found on the right edge of the board, beyond its
        // squares: the margin there does not alternate, so the line goes.
        let gray = board_image(9, 6, 20, 40);
        let with_edge = grid(10, 6, 20.0, 40.0);
        let ordered = board_corners(&with_edge, &gray, 9, 6).unwrap();
        assert_eq!(ordered.len(), 54);
        assert_eq!(ordered[8], Point2::new(199.5, 39.5));
    }

    #[test]
    fn a_missing_outer_line_is_added_on_the_board_side() {
        let gray = board_image(9, 6, 20, 40);
        // The last row of corners was not found: it is added below, not above.
        let without_last_row = grid(9, 5, 20.0, 40.0);
        let ordered = board_corners(&without_last_row, &gray, 9, 6).unwrap();
        assert_eq!(ordered, grid_positions(9, 6, 20.0, 40.0));
        // Likewise a missing first column.
        let without_first_column: Vec<GridCorner> = grid(9, 6, 20.0, 40.0)
            .into_iter()
            .filter(|c| c.u > 0)
            .collect();
        let ordered = board_corners(&without_first_column, &gray, 9, 6).unwrap();
        assert_eq!(ordered, grid_positions(9, 6, 20.0, 40.0));
        // A board two lines short is not grown.
        assert!(board_corners(&grid(9, 4, 20.0, 40.0), &gray, 9, 6).is_none());
    }

    fn grid_positions(cols: usize, rows: usize, square: f64, origin: f64) -> Vec<Point2<f64>> {
        grid(cols, rows, square, origin)
            .into_iter()
            .map(|c| c.position)
            .collect()
    }

    #[test]
    fn symmetric_colouring_falls_back_to_top_left() {
        let gray = board_image(8, 6, 20, 40);
        let ordered = board_corners(&grid(8, 6, 20.0, 40.0), &gray, 8, 6).unwrap();
        assert_eq!(ordered[0], Point2::new(39.5, 39.5));
    }
}
