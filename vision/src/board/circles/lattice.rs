//! The grid among the blobs: a lattice grown from a seed blob whose nearest
//! neighbours come in two opposite pairs, each step predicted from the steps already
//! taken (so perspective and lens distortion bend it gradually), then matched to the
//! target's layout under every rotation and reflection of the lattice. A reflection
//! would mean the board is seen from behind, so only the matches that keep the board's
//! handedness in the image are kept; of those (several only when the layout looks the
//! same turned round), the one whose x axis points most to the image's right.

use std::collections::{HashMap, VecDeque};

use nalgebra::{Point2, Vector2};

use super::blobs::Blob;
use crate::board::CircleLayout;

/// Neighbours considered when looking for a seed's two pairs.
const SEED_NEIGHBOURS: usize = 8;
/// A predicted position takes the nearest blob within this fraction of the step.
const CAPTURE: f64 = 0.3;
/// Neighbouring circles' areas differ by at most this factor.
const MAX_AREA_RATIO: f64 = 3.0;

/// Lattice coordinates of a blob.
type Cell = (i32, i32);

/// One grid found among the blobs: the blob of each circle id.
#[derive(Clone, Debug, PartialEq)]
pub(super) struct GridMatch {
    /// Index into the blobs of circle `id`, by id.
    pub blobs: Vec<usize>,
    /// Column and row of circle `id`, by id.
    pub cells: Vec<(usize, usize)>,
}

/// Why no single grid was found.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum LatticeMiss {
    /// No lattice of circles at all.
    NoLattice,
    /// A lattice of circles, but not the target's grid: the largest had this many.
    WrongGrid(usize),
    /// Two lattices each matching the target.
    TwoGrids,
}

/// Finds the one grid of `cols x rows` circles in `layout` among `blobs`.
pub(super) fn find_grid(
    blobs: &[Blob],
    cols: usize,
    rows: usize,
    layout: CircleLayout,
) -> Result<GridMatch, LatticeMiss> {
    let neighbours = nearest_neighbours(blobs, SEED_NEIGHBOURS);
    let mut consumed = vec![false; blobs.len()];
    let mut found: Option<GridMatch> = None;
    let mut largest = 0;
    // Seeds with the smallest steps first: blobs of the grid are closer to each other
    // than to clutter.
    let mut seeds: Vec<(usize, Vector2<f64>, Vector2<f64>)> = (0..blobs.len())
        .filter_map(|b| seed_basis(blobs, &neighbours[b], b).map(|(u, v)| (b, u, v)))
        .collect();
    seeds.sort_by(|a, b| (a.1.norm() + a.2.norm()).total_cmp(&(b.1.norm() + b.2.norm())));
    for (seed, u, v) in seeds {
        if consumed[seed] {
            continue;
        }
        let lattice = grow(blobs, seed, u, v);
        if lattice.len() < 4 {
            continue;
        }
        for &b in lattice.values() {
            consumed[b] = true;
        }
        largest = largest.max(lattice.len());
        if let Some(grid) = match_layout(blobs, &lattice, cols, rows, layout) {
            if found.is_some() {
                return Err(LatticeMiss::TwoGrids);
            }
            found = Some(grid);
        }
    }
    match found {
        Some(grid) => Ok(grid),
        None if largest == 0 => Err(LatticeMiss::NoLattice),
        None => Err(LatticeMiss::WrongGrid(largest)),
    }
}

/// The `k` nearest blobs of each blob, nearest first, among those of a similar size.
fn nearest_neighbours(blobs: &[Blob], k: usize) -> Vec<Vec<usize>> {
    blobs
        .iter()
        .enumerate()
        .map(|(a, blob)| {
            let mut near: Vec<(f64, usize)> = blobs
                .iter()
                .enumerate()
                .filter(|&(b, other)| b != a && similar(blob, other))
                .map(|(b, other)| ((other.centre - blob.centre).norm_squared(), b))
                .collect();
            near.sort_by(|x, y| x.0.total_cmp(&y.0));
            near.into_iter().take(k).map(|(_, b)| b).collect()
        })
        .collect()
}

fn similar(a: &Blob, b: &Blob) -> bool {
    let ratio = a.area as f64 / b.area as f64;
    (1.0 / MAX_AREA_RATIO..=MAX_AREA_RATIO).contains(&ratio)
}

/// Two lattice steps at `seed`: the shortest pair of opposite neighbours, and the
/// shortest other pair not along the first; `None` when the blob is not inside a
/// lattice.
fn seed_basis(blobs: &[Blob], near: &[usize], seed: usize) -> Option<(Vector2<f64>, Vector2<f64>)> {
    let here = blobs[seed].centre;
    let mut pairs: Vec<Vector2<f64>> = Vec::new();
    for (i, &a) in near.iter().enumerate() {
        let step = blobs[a].centre - here;
        let opposite = near[i + 1..].iter().any(|&b| {
            let back = blobs[b].centre - here;
            (step + back).norm() < CAPTURE * step.norm()
        });
        if opposite
            && !pairs
                .iter()
                .any(|p| (p + step).norm() < CAPTURE * step.norm())
        {
            pairs.push(step);
        }
    }
    let u = *pairs.first()?;
    let v = pairs[1..]
        .iter()
        .find(|v| (u.perp(v) / (u.norm() * v.norm())).abs() > 0.5)?;
    Some((u, *v))
}

/// The lattice reachable from `seed` with first steps `u` and `v`: each blob's cell.
fn grow(blobs: &[Blob], seed: usize, u: Vector2<f64>, v: Vector2<f64>) -> HashMap<Cell, usize> {
    let mut cells: HashMap<Cell, usize> = HashMap::from([((0, 0), seed)]);
    let mut taken = vec![false; blobs.len()];
    taken[seed] = true;
    let mut queue = VecDeque::from([(0, 0)]);
    let position =
        |cells: &HashMap<Cell, usize>, cell: Cell| cells.get(&cell).map(|&b| blobs[b].centre);
    while let Some(cell) = queue.pop_front() {
        for (du, dv) in [(1, 0), (-1, 0), (0, 1), (0, -1)] {
            let next = (cell.0 + du, cell.1 + dv);
            if cells.contains_key(&next) {
                continue;
            }
            let here = blobs[cells[&cell]].centre;
            let seed_step = u * f64::from(du) + v * f64::from(dv);
            let step = known_step(&cells, &position, cell, (du, dv)).unwrap_or(seed_step);
            let predicted = here + step;
            let radius = CAPTURE * step.norm();
            let nearest = blobs
                .iter()
                .enumerate()
                .filter(|&(b, blob)| !taken[b] && similar(blob, &blobs[cells[&cell]]))
                .map(|(b, blob)| ((blob.centre - predicted).norm(), b))
                .min_by(|a, b| a.0.total_cmp(&b.0));
            if let Some((distance, b)) = nearest
                && distance < radius
            {
                taken[b] = true;
                cells.insert(next, b);
                queue.push_back(next);
            }
        }
    }
    cells
}

/// The step from `cell` in `direction` as the lattice around it shows it: continued
/// from the step that led to `cell`, or copied from a step of a neighbouring row or
/// column.
fn known_step(
    cells: &HashMap<Cell, usize>,
    position: &impl Fn(&HashMap<Cell, usize>, Cell) -> Option<Point2<f64>>,
    cell: Cell,
    (du, dv): Cell,
) -> Option<Vector2<f64>> {
    let at = |offset: Cell| position(cells, (cell.0 + offset.0, cell.1 + offset.1));
    let (pu, pv) = (dv, du);
    let candidates = [
        ((-du, -dv), (0, 0)),
        ((pu, pv), (pu + du, pv + dv)),
        ((-pu, -pv), (-pu + du, -pv + dv)),
        ((pu - du, pv - dv), (pu, pv)),
        ((-pu - du, -pv - dv), (-pu, -pv)),
    ];
    candidates
        .iter()
        .find_map(|&(from, to)| Some(at(to)? - at(from)?))
}

/// Changes of lattice basis tried before placing a lattice: under strong perspective
/// a seed's second-shortest pair of steps may be a diagonal of the grid, which spans
/// the same lattice with sheared coordinates.
const SHEARS: [(i32, i32); 5] = [(0, 0), (1, 0), (-1, 0), (0, 1), (0, -1)];

/// The lattice as the target's grid, if it is exactly that grid.
fn match_layout(
    blobs: &[Blob],
    lattice: &HashMap<Cell, usize>,
    cols: usize,
    rows: usize,
    layout: CircleLayout,
) -> Option<GridMatch> {
    if lattice.len() != cols * rows {
        return None;
    }
    let mut best: Option<(f64, GridMatch)> = None;
    for (shear, transform) in SHEARS.iter().flat_map(|s| (0..8).map(move |t| (s, t))) {
        let sheared: HashMap<Cell, usize> = lattice
            .iter()
            .map(|(&(m, n), &b)| ((m + shear.0 * n, n + shear.1 * m), b))
            .collect();
        let Some(grid) = place(&sheared, cols, rows, layout, transform) else {
            continue;
        };
        let (x_axis, y_axis) = axes(blobs, &grid, cols);
        // Seen from the front, the board's x and y axes turn like the image's.
        if x_axis.perp(&y_axis) <= 0.0 {
            continue;
        }
        let rightwards = x_axis.x / x_axis.norm();
        if best.as_ref().is_none_or(|(r, _)| rightwards > *r) {
            best = Some((rightwards, grid));
        }
    }
    best.map(|(_, grid)| grid)
}

/// The lattice's cells mapped by one of the eight rotations and reflections, as
/// circle ids of the layout; `None` when they are not the layout's cells.
fn place(
    lattice: &HashMap<Cell, usize>,
    cols: usize,
    rows: usize,
    layout: CircleLayout,
    transform: usize,
) -> Option<GridMatch> {
    let turned = |(m, n): Cell| {
        let (a, b) = if transform & 4 == 0 { (m, n) } else { (n, m) };
        let a = if transform & 1 == 0 { a } else { -a };
        let b = if transform & 2 == 0 { b } else { -b };
        match layout {
            CircleLayout::Symmetric => (a, b),
            // The nearest neighbours of an asymmetric grid are its diagonals.
            CircleLayout::Asymmetric => (a + b, a - b),
        }
    };
    let placed: Vec<(Cell, usize)> = lattice.iter().map(|(&c, &b)| (turned(c), b)).collect();
    let min_y = placed.iter().map(|((_, y), _)| *y).min()?;
    let min_x = placed
        .iter()
        .filter(|((_, y), _)| *y == min_y)
        .map(|((x, _), _)| *x)
        .min()?;
    let mut blobs = vec![usize::MAX; cols * rows];
    let mut cells = vec![(0, 0); cols * rows];
    for ((x, y), b) in placed {
        let (x, y) = (x - min_x, y - min_y);
        let (x, y) = (usize::try_from(x).ok()?, usize::try_from(y).ok()?);
        let column = match layout {
            CircleLayout::Symmetric => x,
            CircleLayout::Asymmetric => {
                if x % 2 != y % 2 {
                    return None;
                }
                x / 2
            }
        };
        if column >= cols || y >= rows {
            return None;
        }
        let id = y * cols + column;
        if blobs[id] != usize::MAX {
            return None;
        }
        blobs[id] = b;
        cells[id] = (column, y);
    }
    blobs
        .iter()
        .all(|&b| b != usize::MAX)
        .then_some(GridMatch { blobs, cells })
}

/// Mean image directions of the board's x and y axes in a placed grid.
fn axes(blobs: &[Blob], grid: &GridMatch, cols: usize) -> (Vector2<f64>, Vector2<f64>) {
    let at = |id: usize| blobs[grid.blobs[id]].centre;
    let mut x_axis = Vector2::zeros();
    let mut y_axis = Vector2::zeros();
    for (id, &(column, _)) in grid.cells.iter().enumerate() {
        if column + 1 < cols {
            x_axis += at(id + 1) - at(id);
        }
        if id + cols < grid.blobs.len() {
            y_axis += at(id + cols) - at(id);
        }
    }
    (x_axis, y_axis)
}
