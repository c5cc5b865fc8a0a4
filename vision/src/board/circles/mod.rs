//! Circle-grid detection (`circles` and `acircles`, OpenCV's symmetric and asymmetric
//! grids): dark blobs, the lattice among them matched to the target's layout, then
//! each circle's image ellipse fitted to its gradients (see [`conic`]), and the
//! ellipse's centre moved by its bias: perspective and the lens pull it away from the
//! image of the circle's centre (see [`bias`]). The blob's centroid is never taken.
//!
//! The map that gives the bias is fitted to the centres of the circle's neighbours (one
//! row and column around it: wider windows bend less with a fisheye lens and measured
//! worse), and the circles' radius is measured from their ellipses, so the printed
//! diameter need not be known. Two rounds: the corrected centres give better
//! maps.

mod bias;
mod blobs;
mod conic;
mod lattice;
mod through_lens;

use nalgebra::{Point2, Point3, Vector2};
use thiserror::Error;

use self::bias::{LocalMap, centre_bias};
use self::blobs::{Blob, dark_blobs};
use self::conic::{Ellipse, fit_ellipse, refit};
use self::lattice::{GridMatch, LatticeMiss, find_grid};
pub use self::through_lens::circle_centre_errors;
use super::detection::{Detection, TargetDetector};
use super::target::{CircleGrid, CircleLayout, Target};
use super::{BoardError, Gray};

/// Circles within this many rows and columns of a circle fit its local map.
const LOCAL_REACH: usize = 2;
/// Rounds of correcting the centres.
const BIAS_ROUNDS: usize = 2;

/// Why a circle grid was not found in an image.
#[derive(Clone, Debug, Error, PartialEq, Eq)]
pub enum CircleGridMiss {
    /// No lattice of dark circles.
    #[error("no grid of dark circles in view")]
    NoCircles,
    /// Circles in a lattice, but not the whole target.
    #[error(
        "a grid of {found} circles in view, not the {expected} of the target: keep every \
         circle in view, and check the grid's size"
    )]
    WrongGrid {
        /// Circles in the largest lattice found.
        found: usize,
        /// Circles of the target.
        expected: usize,
    },
    /// Two grids matching the target.
    #[error("two circle grids of the target's size in view: show one")]
    TwoGrids,
    /// A circle's edge could not be measured (cut by the border, or no contrast).
    #[error("circle {0} could not be located: its edge is cut or has no contrast")]
    Unlocated(usize),
}

/// Finds a circle grid ([`Target::Circles`] or [`Target::Acircles`]) in images.
#[derive(Clone, Debug)]
pub struct CircleGridDetector {
    grid: CircleGrid,
    layout: CircleLayout,
    target: Target,
    /// The circles' board positions in units of the spacing, by id.
    plane: Vec<Point2<f64>>,
}

impl CircleGridDetector {
    /// A detector of `target`; an error for a target that is not a valid circle grid.
    pub fn new(target: &Target) -> Result<Self, BoardError> {
        target.validate()?;
        let (grid, layout) = target.circle_grid().ok_or_else(|| {
            BoardError::Unsupported(format!("{} is not a circle grid", target.describe()))
        })?;
        Ok(Self {
            grid: *grid,
            layout,
            target: target.clone(),
            plane: board_plane(target, grid.spacing),
        })
    }

    /// The grid in `gray`, its circles' centres in target order; or why it was not
    /// found.
    pub fn find(&self, gray: &Gray) -> Result<Detection, CircleGridMiss> {
        let (cols, rows) = (self.grid.cols, self.grid.rows);
        let blobs = dark_blobs(gray);
        let grid = find_grid(&blobs, cols, rows, self.layout).map_err(|miss| match miss {
            LatticeMiss::NoLattice => CircleGridMiss::NoCircles,
            LatticeMiss::WrongGrid(found) => CircleGridMiss::WrongGrid {
                found,
                expected: cols * rows,
            },
            LatticeMiss::TwoGrids => CircleGridMiss::TwoGrids,
        })?;
        let ellipses = grid
            .blobs
            .iter()
            .enumerate()
            .map(|(id, &b)| locate(gray, &blobs[b]).ok_or(CircleGridMiss::Unlocated(id)))
            .collect::<Result<Vec<_>, _>>()?;
        let observed = ellipses
            .iter()
            .enumerate()
            .map(|(id, e)| e.centre().ok_or(CircleGridMiss::Unlocated(id)))
            .collect::<Result<Vec<_>, _>>()?;
        let mut centres = observed.clone();
        for _ in 0..BIAS_ROUNDS {
            centres = self.corrected(&ellipses, &observed, &centres);
        }
        Ok(Detection {
            ids: (0..centres.len()).collect(),
            square_px: median_step(&centres, &grid, cols),
            corners: centres,
        })
    }

    /// Each circle's ellipse centre (`observed`) less its bias under the map fitted
    /// to the current `centres` around it. A circle whose map cannot be fitted keeps
    /// its ellipse centre.
    fn corrected(
        &self,
        ellipses: &[Ellipse],
        observed: &[Point2<f64>],
        centres: &[Point2<f64>],
    ) -> Vec<Point2<f64>> {
        let maps = local_maps(self.grid.cols, self.grid.rows, &self.plane, centres);
        let radius = board_radius(ellipses, &maps);
        observed
            .iter()
            .zip(local_biases(&maps, radius))
            .map(|(centre, bias)| centre - bias.unwrap_or_else(Vector2::zeros))
            .collect()
    }
}

/// The map from the board to the image around each circle, fitted to the `centres`
/// of the circles within [`LOCAL_REACH`] rows and columns (`plane`: the circles'
/// board positions in units of the spacing, by id).
fn local_maps(
    cols: usize,
    rows: usize,
    plane: &[Point2<f64>],
    centres: &[Point2<f64>],
) -> Vec<Option<LocalMap>> {
    (0..plane.len())
        .map(|id| {
            let (column, row) = (id % cols, id / cols);
            let columns = column.saturating_sub(LOCAL_REACH)..=(column + LOCAL_REACH).min(cols - 1);
            let rows = row.saturating_sub(LOCAL_REACH)..=(row + LOCAL_REACH).min(rows - 1);
            let near: Vec<usize> = rows
                .flat_map(|r| columns.clone().map(move |c| r * cols + c))
                .collect();
            let board: Vec<Point2<f64>> = near
                .iter()
                .map(|&k| Point2::from(plane[k] - plane[id]))
                .collect();
            let image: Vec<Point2<f64>> = near.iter().map(|&k| centres[k]).collect();
            LocalMap::fit(&board, &image)
        })
        .collect()
}

/// The bias of each circle's ellipse centre under its map, for circles of `radius`
/// (units of the spacing); `None` where there is no map or no radius.
fn local_biases(maps: &[Option<LocalMap>], radius: Option<f64>) -> Vec<Option<Vector2<f64>>> {
    maps.iter()
        .map(|map| {
            radius
                .zip(map.as_ref())
                .and_then(|(r, map)| centre_bias(map, &Point2::origin(), r))
        })
        .collect()
}

/// The circles' radius on the board, in units of the spacing: the median over the
/// circles of the radius whose image under the local map has the ellipse's area.
fn board_radius(ellipses: &[Ellipse], maps: &[Option<LocalMap>]) -> Option<f64> {
    let mut radii: Vec<f64> = ellipses
        .iter()
        .zip(maps)
        .filter_map(|(ellipse, map)| {
            let (_, shape) = ellipse.shape()?;
            let scale = map
                .as_ref()?
                .jacobian(&Point2::origin())
                .determinant()
                .abs();
            // Area pi / sqrt(det shape) = pi r^2 |det J|.
            let r = (1.0 / (shape.determinant().sqrt() * scale)).sqrt();
            r.is_finite().then_some(r)
        })
        .collect();
    radii.sort_by(f64::total_cmp);
    radii.get(radii.len() / 2).copied()
}

/// The target's circle centres on the board, in units of the spacing, by id.
fn board_plane(target: &Target, spacing: f64) -> Vec<Point2<f64>> {
    target
        .object_points()
        .iter()
        .map(|p: &Point3<f64>| Point2::from(p.xy().coords / spacing))
        .collect()
}

/// The circle's ellipse: fitted in the blob's window, then refitted in its own.
fn locate(gray: &Gray, blob: &Blob) -> Option<Ellipse> {
    let shape = (blob.covariance * 4.0).try_inverse()?;
    let first = fit_ellipse(gray, blob.centre, &shape)?;
    refit(gray, &first)
}

/// Median distance between circles adjacent along a row or a column, pixels.
fn median_step(centres: &[Point2<f64>], grid: &GridMatch, cols: usize) -> f64 {
    let mut steps: Vec<f64> = grid
        .cells
        .iter()
        .enumerate()
        .flat_map(|(id, &(column, _))| {
            let along_row = (column + 1 < cols).then(|| (centres[id + 1] - centres[id]).norm());
            let along_column = centres
                .get(id + cols)
                .map(|below| (below - centres[id]).norm());
            along_row.into_iter().chain(along_column)
        })
        .collect();
    steps.sort_by(f64::total_cmp);
    steps.get(steps.len() / 2).copied().unwrap_or(0.0)
}

impl TargetDetector for CircleGridDetector {
    fn target(&self) -> &Target {
        &self.target
    }

    fn detect_gray(&self, gray: &Gray) -> Option<Detection> {
        self.find(gray).ok()
    }
}
