//! How blurred a detected chessboard or circle grid is: the 10-90 % width of its square edges, in
//! pixels, measured separately for the two families of edges so that motion blur (which
//! widens only the edges across the motion) shows apart from defocus (which widens all).
//!
//! Each edge between two adjacent inner corners separates a black and a white square.
//! Across it, from the centre line of the black square to the white square's clear
//! part (its centre line on a chessboard; short of the marker on a ChArUco board), the
//! grey profile (averaged over five lines across the middle of the edge) rises from the
//! black level to the white one; its width is the length over which it lies between
//! 10 % and 90 % of that rise. A sharp edge is one to three pixels wide (the lens and
//! the sensor's pixels); a defocused or moving board widens it to many pixels.

use crate::board::{CircleLayout, Detection, Gray};
use nalgebra::{Point2, Vector2};

/// Step between samples along a profile, pixels.
const STEP: f64 = 0.25;
/// Positions along an edge (fractions from one corner to the other) where profiles are
/// taken: the middle, away from the corners' X-junctions.
const ALONG: [f64; 5] = [0.3, 0.4, 0.5, 0.6, 0.7];
/// Edges whose two squares differ by fewer grey levels are not measured.
const MIN_CONTRAST: f64 = 16.0;
/// Edges whose squares are narrower than this (edge to square centre, pixels) are not
/// measured.
const MIN_REACH: f64 = 2.0;

/// Edge widths of a detected chessboard, pixels (medians over the edges of each family).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EdgeBlur {
    /// Width of the edges between corners adjacent along a row (the board's x): the
    /// edges that motion along the board's y widens.
    pub row_edges: f64,
    /// Width of the edges between corners adjacent along a column (the board's y): the
    /// edges that motion along the board's x widens.
    pub column_edges: f64,
}

impl EdgeBlur {
    /// The wider of the two families, pixels: the board's blur.
    pub fn width(&self) -> f64 {
        self.row_edges.max(self.column_edges)
    }

    /// Whether the blur has a direction: one family at least `ratio` times wider than
    /// the other, as motion blur makes it and defocus does not.
    pub fn is_directional(&self, ratio: f64) -> bool {
        let (low, high) = if self.row_edges < self.column_edges {
            (self.row_edges, self.column_edges)
        } else {
            (self.column_edges, self.row_edges)
        };
        high >= ratio * low
    }
}

/// The edge widths of `detection`, a board of `cols x rows` inner corners found in
/// `gray`, whose white squares are plain for a `clear` fraction of their side from each
/// edge (0.5 for a chessboard; `(square - marker) / (2 square)` for a ChArUco board).
/// `None` when no edge of one family could be measured (squares too small, edges off
/// the image, or no contrast).
pub fn edge_blur(
    gray: &Gray,
    detection: &Detection,
    cols: usize,
    rows: usize,
    clear: f64,
) -> Option<EdgeBlur> {
    let mut grid: Vec<Option<Point2<f64>>> = vec![None; cols * rows];
    for (&id, corner) in detection.ids.iter().zip(&detection.corners) {
        if let Some(slot) = grid.get_mut(id) {
            *slot = Some(*corner);
        }
    }
    let at = |i: usize, j: usize| grid[j * cols + i];
    let mut row_widths = Vec::new();
    let mut column_widths = Vec::new();
    for j in 0..rows {
        for i in 0..cols {
            let Some(here) = at(i, j) else { continue };
            // Along the row: the square centres lie a half step along the column.
            if i + 1 < cols
                && let Some(next) = at(i + 1, j)
            {
                let across = column_step(&at, i, j, rows)
                    .zip(column_step(&at, i + 1, j, rows))
                    .map(|(a, b)| (a + b) / 2.0);
                if let Some(width) = across.and_then(|v| edge_width(gray, &here, &next, &v, clear))
                {
                    row_widths.push(width);
                }
            }
            if j + 1 < rows
                && let Some(next) = at(i, j + 1)
            {
                let across = row_step(&at, i, j, cols)
                    .zip(row_step(&at, i, j + 1, cols))
                    .map(|(a, b)| (a + b) / 2.0);
                if let Some(width) = across.and_then(|v| edge_width(gray, &here, &next, &v, clear))
                {
                    column_widths.push(width);
                }
            }
        }
    }
    Some(EdgeBlur {
        row_edges: median(&mut row_widths)?,
        column_edges: median(&mut column_widths)?,
    })
}

/// The step from corner `(i, j)` to its neighbour along the column (the next row, or
/// the previous one on the last row, sign kept pointing to increasing `j`).
fn column_step(
    at: &impl Fn(usize, usize) -> Option<Point2<f64>>,
    i: usize,
    j: usize,
    rows: usize,
) -> Option<Vector2<f64>> {
    if j + 1 < rows {
        Some(at(i, j + 1)? - at(i, j)?)
    } else {
        Some(at(i, j)? - at(i, j.checked_sub(1)?)?)
    }
}

/// The step from corner `(i, j)` to its neighbour along the row, likewise.
fn row_step(
    at: &impl Fn(usize, usize) -> Option<Point2<f64>>,
    i: usize,
    j: usize,
    cols: usize,
) -> Option<Vector2<f64>> {
    if i + 1 < cols {
        Some(at(i + 1, j)? - at(i, j)?)
    } else {
        Some(at(i, j)? - at(i.checked_sub(1)?, j)?)
    }
}

/// The 10-90 % width of the edge from corner `a` to corner `b`, whose two squares
/// extend a step `across` (a neighbouring corner's offset) on either side, the white
/// one plain for a `clear` fraction of its side.
fn edge_width(
    gray: &Gray,
    a: &Point2<f64>,
    b: &Point2<f64>,
    across: &Vector2<f64>,
    clear: f64,
) -> Option<f64> {
    let along = b - a;
    let normal = Vector2::new(-along.y, along.x).try_normalize(1e-9)?;
    // Distance from the edge to the centre line of each square.
    let reach = across.dot(&normal).abs() / 2.0;
    // How far the white square is plain: to its centre line on a chessboard, to just
    // short of the marker on a ChArUco board.
    let white_reach = reach.min(0.9 * clear * 2.0 * reach);
    if white_reach < MIN_REACH {
        return None;
    }
    let level = |t: f64| -> Option<f64> {
        let mut sum = 0.0;
        for s in ALONG {
            let p = a + along * s + normal * t;
            sum += gray.sample(p.x, p.y)?;
        }
        Some(sum / ALONG.len() as f64)
    };
    // Point the normal into the white square.
    let normal_sign = if level(white_reach)? >= level(-white_reach)? {
        1.0
    } else {
        -1.0
    };
    let from_black = (reach / STEP).floor() as i64;
    let to_white = (white_reach / STEP).floor() as i64;
    let profile = (-from_black..=to_white)
        .map(|k| level(normal_sign * k as f64 * STEP))
        .collect::<Option<Vec<f64>>>()?;
    rise_width(&profile)
}

/// The 10-90 % width of the rise of `profile` (samples [`STEP`] apart, starting on the
/// dark side), pixels; `None` for a rise below [`MIN_CONTRAST`].
fn rise_width(profile: &[f64]) -> Option<f64> {
    let low = *profile.first()?;
    let high = profile.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let rise = high - low;
    if rise < MIN_CONTRAST {
        return None;
    }
    let (from, to) = (low + 0.1 * rise, low + 0.9 * rise);
    let inside = profile.iter().filter(|&&v| v > from && v < to).count();
    Some(inside as f64 * STEP)
}

/// The edge widths of `detection`, a circle grid of `cols` circles per row in `layout`
/// found in `gray` (centres in target order, every circle found): medians over the
/// circles of the profiles along the board's y (`row_edges`) and x (`column_edges`).
/// `None` when no circle's edge could be measured along one of them.
pub fn circle_blur(
    gray: &Gray,
    detection: &Detection,
    cols: usize,
    layout: CircleLayout,
) -> Option<EdgeBlur> {
    let centres = &detection.corners;
    // The circle one step along the board's y, and the nearest neighbour along a row.
    let (below, nearest) = match layout {
        CircleLayout::Symmetric => (cols, cols),
        CircleLayout::Asymmetric => (2 * cols, cols),
    };
    let mut row_widths = Vec::new();
    let mut column_widths = Vec::new();
    for (id, centre) in centres.iter().enumerate() {
        let along_x = (id % cols + 1 < cols)
            .then(|| centres.get(id + 1).map(|c| c - centre))
            .flatten();
        let along_y = centres.get(id + below).map(|c| c - centre);
        let neighbour = centres.get(id + nearest).map(|c| (c - centre).norm());
        let (Some(x), Some(y), Some(neighbour)) = (along_x, along_y, neighbour) else {
            continue;
        };
        let reach = 0.5 * neighbour.min(x.norm()).min(y.norm());
        for (direction, widths) in [(x, &mut column_widths), (y, &mut row_widths)] {
            let Some(unit) = direction.try_normalize(1e-9) else {
                continue;
            };
            for sign in [1.0, -1.0] {
                let profile = (0..=(reach / STEP).floor() as i64)
                    .map(|k| {
                        let p = centre + unit * (sign * k as f64 * STEP);
                        gray.sample(p.x, p.y)
                    })
                    .collect::<Option<Vec<f64>>>();
                if reach >= MIN_REACH
                    && let Some(width) = profile.as_deref().and_then(rise_width)
                {
                    widths.push(width);
                }
            }
        }
    }
    Some(EdgeBlur {
        row_edges: median(&mut row_widths)?,
        column_edges: median(&mut column_widths)?,
    })
}

/// The median of `values` (the mean of the middle two for an even count); `None` when
/// empty.
fn median(values: &mut [f64]) -> Option<f64> {
    if values.is_empty() {
        return None;
    }
    values.sort_by(f64::total_cmp);
    let n = values.len();
    Some(if n % 2 == 1 {
        values[n / 2]
    } else {
        (values[n / 2 - 1] + values[n / 2]) / 2.0
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A 5x4 (inner corners) axis-aligned chessboard of `square` px squares whose first
    /// corner is at `origin`, rendered with Gaussian edge profiles of standard deviation
    /// `sigma_x` across vertical edges and `sigma_y` across horizontal ones.
    fn board(square: f64, origin: f64, sigma_x: f64, sigma_y: f64) -> (Gray, Detection) {
        let (width, height) = (320, 260);
        let erf_step =
            |d: f64, sigma: f64| 0.5 * (1.0 + erf(d / (sigma * std::f64::consts::SQRT_2)));
        let mut data = Vec::with_capacity(width * height);
        for y in 0..height {
            for x in 0..width {
                let u = (x as f64 - origin) / square;
                let v = (y as f64 - origin) / square;
                // Distance to the nearest vertical / horizontal square border, signed by
                // the square parity, blended smoothly.
                let fu = u - u.round();
                let fv = v - v.round();
                let su = erf_step(
                    fu * square
                        * if (u.round() as i64) % 2 == 0 {
                            1.0
                        } else {
                            -1.0
                        },
                    sigma_x,
                );
                let sv = erf_step(
                    fv * square
                        * if (v.round() as i64) % 2 == 0 {
                            1.0
                        } else {
                            -1.0
                        },
                    sigma_y,
                );
                // XOR of the two half-planes as a product of signed levels.
                let level = 0.5 + 0.5 * (2.0 * su - 1.0) * (2.0 * sv - 1.0);
                data.push((40.0 + 180.0 * level).round() as u8);
            }
        }
        let (cols, rows) = (5, 4);
        let mut corners = Vec::new();
        for j in 0..rows {
            for i in 0..cols {
                corners.push(Point2::new(
                    origin + square * i as f64,
                    origin + square * j as f64,
                ));
            }
        }
        let detection = Detection {
            ids: (0..cols * rows).collect(),
            corners,
            square_px: square,
        };
        (
            Gray {
                width,
                height,
                data,
            },
            detection,
        )
    }

    /// Abramowitz-Stegun 7.1.26 (error below 1.5e-7).
    fn erf(x: f64) -> f64 {
        let t = 1.0 / (1.0 + 0.327_591_1 * x.abs());
        let y = 1.0
            - (((((1.061_405_429 * t - 1.453_152_027) * t) + 1.421_413_741) * t - 0.284_496_736)
                * t
                + 0.254_829_592)
                * t
                * (-x * x).exp();
        y.copysign(x)
    }

    #[test]
    fn width_is_the_ten_to_ninety_percent_rise_of_a_gaussian_edge() {
        // A Gaussian-blurred step rises from 10 % to 90 % over 2.563 sigma.
        for sigma in [1.0, 3.0, 6.0] {
            let (gray, detection) = board(40.0, 60.0, sigma, sigma);
            let blur = edge_blur(&gray, &detection, 5, 4, 0.5).unwrap();
            let expected = 2.563 * sigma;
            for width in [blur.row_edges, blur.column_edges] {
                assert!(
                    (width - expected).abs() < 0.6,
                    "sigma {sigma}: width {width} against {expected}"
                );
            }
            assert!(!blur.is_directional(1.5), "{blur:?}");
        }
    }

    #[test]
    fn blur_along_one_axis_widens_one_family_of_edges() {
        // Blur along x widens the vertical edges: those between corners adjacent along
        // a column.
        let (gray, detection) = board(40.0, 60.0, 6.0, 0.8);
        let blur = edge_blur(&gray, &detection, 5, 4, 0.5).unwrap();
        assert!(blur.column_edges > 13.0 && blur.row_edges < 3.5, "{blur:?}");
        assert!(blur.is_directional(2.0));
        assert_eq!(blur.width(), blur.column_edges);
    }

    #[test]
    fn unmeasurable_boards_give_none() {
        let (gray, detection) = board(40.0, 60.0, 1.0, 1.0);
        let flat = Gray {
            data: vec![128; gray.data.len()],
            ..gray
        };
        assert_eq!(edge_blur(&flat, &detection, 5, 4, 0.5), None);
        let (gray, mut detection) = board(40.0, 60.0, 1.0, 1.0);
        for corner in &mut detection.corners {
            corner.x += 1000.0;
        }
        assert_eq!(edge_blur(&gray, &detection, 5, 4, 0.5), None);
    }
}
