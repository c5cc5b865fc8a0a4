//! Levenberg-Marquardt for problems with a few shared parameters and one 6-DoF pose per
//! view, solved through the Schur complement on the pose blocks: every residual depends
//! on the shared parameters and on one view's pose, so the normal matrix is an arrow
//! (a small shared block, a 6x6 block per view and their couplings) and one iteration
//! costs time linear in the number of views.

use nalgebra::{DMatrix, DVector, Matrix6, Matrix6xX, Vector2, Vector6};

/// A least-squares problem with the block structure described in the module
/// documentation. `State` holds the shared parameters and the per-view poses.
pub(crate) trait BlockProblem {
    /// Shared parameters and per-view poses.
    type State: Clone;

    /// Number of free shared parameters.
    fn shared_dim(&self) -> usize;

    /// Number of views (pose blocks).
    fn view_count(&self) -> usize;

    /// Adds every residual of `view` at `state`, with its Jacobians, to `acc`.
    fn linearize_view(&self, state: &Self::State, view: usize, acc: &mut ViewAccumulator);

    /// Sum of squared residuals of `view` at `state`.
    fn view_cost(&self, state: &Self::State, view: usize) -> f64;

    /// Whether `state` is one the solution may take: when the initial state is, no step
    /// leaves the admissible states.
    fn admissible(&self, state: &Self::State) -> bool;

    /// The state moved by `d_shared` (free shared parameters) and one pose update per
    /// view.
    fn retract(
        &self,
        state: &Self::State,
        d_shared: &DVector<f64>,
        d_views: &[Vector6<f64>],
    ) -> Self::State;
}

/// The normal-equation blocks of one view: `U` (shared x shared), `W` (shared x pose),
/// `V` (pose x pose) and the gradients `J^T r`.
pub(crate) struct ViewAccumulator {
    u: DMatrix<f64>,
    w: Matrix6xX<f64>,
    v: Matrix6<f64>,
    g_shared: DVector<f64>,
    g_pose: Vector6<f64>,
    cost: f64,
}

impl ViewAccumulator {
    fn new(shared_dim: usize) -> Self {
        Self {
            u: DMatrix::zeros(shared_dim, shared_dim),
            w: Matrix6xX::zeros(shared_dim),
            v: Matrix6::zeros(),
            g_shared: DVector::zeros(shared_dim),
            g_pose: Vector6::zeros(),
            cost: 0.0,
        }
    }

    fn clear(&mut self) {
        self.u.fill(0.0);
        self.w.fill(0.0);
        self.v.fill(0.0);
        self.g_shared.fill(0.0);
        self.g_pose.fill(0.0);
        self.cost = 0.0;
    }

    /// Adds a 2-vector residual with its Jacobians: `j_shared` is 2 x shared_dim,
    /// stored row-major (`[row 0..., row 1...]`), `j_pose` is 2 x 6.
    pub(crate) fn add(
        &mut self,
        residual: &Vector2<f64>,
        j_shared: &[f64],
        j_pose: &nalgebra::Matrix2x6<f64>,
    ) {
        let n = self.g_shared.len();
        debug_assert_eq!(j_shared.len(), 2 * n);
        self.cost += residual.norm_squared();
        self.v += j_pose.transpose() * j_pose;
        self.g_pose += j_pose.transpose() * residual;
        for row in 0..2 {
            let js = &j_shared[row * n..(row + 1) * n];
            let jp = j_pose.row(row);
            let r = residual[row];
            for a in 0..n {
                let ja = js[a];
                if ja == 0.0 {
                    continue;
                }
                self.g_shared[a] += ja * r;
                for (b, jb) in js.iter().enumerate().skip(a) {
                    self.u[(a, b)] += ja * jb;
                }
                for k in 0..6 {
                    self.w[(k, a)] += jp[k] * ja;
                }
            }
        }
    }
}

/// Stopping rules of [`solve`].
#[derive(Clone, Copy, Debug)]
pub(crate) struct Termination {
    /// Maximum number of linearizations.
    pub max_iterations: usize,
    /// Stop when an accepted step reduces the cost by less than this fraction.
    pub relative_cost_tolerance: f64,
}

impl Default for Termination {
    fn default() -> Self {
        Self {
            max_iterations: 100,
            relative_cost_tolerance: 1e-14,
        }
    }
}

/// What [`solve`] found.
pub(crate) struct Solution<S> {
    /// The state at the minimum.
    pub state: S,
    /// Sum of squared residuals per view at `state`.
    pub view_costs: Vec<f64>,
    /// Inverse of the Schur complement of the undamped normal matrix at `state`: the
    /// shared block of `(J^T J)^-1` (multiply by the residual variance for the
    /// covariance). `None` when the shared parameters are not observable.
    pub shared_inverse: Option<DMatrix<f64>>,
}

struct Linearization {
    views: Vec<ViewAccumulator>,
    u: DMatrix<f64>,
    g_shared: DVector<f64>,
    cost: f64,
}

fn linearize<P: BlockProblem>(problem: &P, state: &P::State, lin: &mut Linearization) {
    lin.u.fill(0.0);
    lin.g_shared.fill(0.0);
    lin.cost = 0.0;
    for (view, acc) in lin.views.iter_mut().enumerate() {
        acc.clear();
        problem.linearize_view(state, view, acc);
        lin.u += &acc.u;
        lin.g_shared += &acc.g_shared;
        lin.cost += acc.cost;
    }
    // Only the upper triangle was accumulated.
    lin.u.fill_lower_triangle_with_upper_triangle();
}

/// Solves the damped normal equations `(J^T J + lambda diag(J^T J)) d = -J^T r` by the
/// Schur complement; returns the shared step, the pose steps and the reduction of the
/// sum of squares that the linear model predicts (`lambda d^T D d - d^T J^T r`), or
/// `None` when the damped system is not positive definite.
fn damped_step(lin: &Linearization, lambda: f64) -> Option<(DVector<f64>, Vec<Vector6<f64>>, f64)> {
    let n = lin.u.nrows();
    let mut s = lin.u.clone();
    for i in 0..n {
        s[(i, i)] += lambda * lin.u[(i, i)].max(1e-12);
    }
    let mut rhs = -&lin.g_shared;
    let mut v_inverses = Vec::with_capacity(lin.views.len());
    for acc in &lin.views {
        let mut v = acc.v;
        for i in 0..6 {
            v[(i, i)] += lambda * acc.v[(i, i)].max(1e-12);
        }
        let v_inv = v.cholesky()?.inverse();
        if n > 0 {
            let w_t_vinv = acc.w.transpose() * v_inv;
            s -= &w_t_vinv * &acc.w;
            rhs += &w_t_vinv * acc.g_pose;
        }
        v_inverses.push(v_inv);
    }
    let d_shared = if n > 0 {
        solve_scaled(&s, &rhs)?
    } else {
        DVector::zeros(0)
    };
    let mut predicted = 0.0;
    for i in 0..n {
        let d = d_shared[i];
        predicted += d * (lambda * lin.u[(i, i)].max(1e-12) * d - lin.g_shared[i]);
    }
    let d_views: Vec<Vector6<f64>> = lin
        .views
        .iter()
        .zip(&v_inverses)
        .map(|(acc, v_inv)| {
            let d = v_inv * (-acc.g_pose - &acc.w * &d_shared);
            for i in 0..6 {
                predicted += d[i] * (lambda * acc.v[(i, i)].max(1e-12) * d[i] - acc.g_pose[i]);
            }
            d
        })
        .collect();
    Some((d_shared, d_views, predicted))
}

/// Solves `s x = rhs` for a symmetric positive definite `s`, with Jacobi scaling so that
/// parameters of very different magnitudes (focal lengths, high-order coefficients)
/// do not spoil the factorization.
fn solve_scaled(s: &DMatrix<f64>, rhs: &DVector<f64>) -> Option<DVector<f64>> {
    let scale = scaling(s)?;
    let scaled = DMatrix::from_fn(s.nrows(), s.ncols(), |i, j| s[(i, j)] * scale[i] * scale[j]);
    let y = scaled.cholesky()?.solve(&rhs.component_mul(&scale));
    Some(y.component_mul(&scale))
}

fn scaling(s: &DMatrix<f64>) -> Option<DVector<f64>> {
    let diag = s.diagonal();
    if diag
        .iter()
        .any(|&d| d.is_nan() || d <= 0.0 || d.is_infinite())
    {
        return None;
    }
    Some(diag.map(|d| 1.0 / d.sqrt()))
}

/// Inverse of the undamped Schur complement (the shared block of `(J^T J)^-1`), by
/// eigendecomposition as OpenCV does (`DECOMP_EIG`), so that a nearly redundant model
/// (rational_polynomial's numerator and denominator) still gets its large
/// uncertainties; `None` when the complement is singular.
fn shared_inverse(lin: &Linearization) -> Option<DMatrix<f64>> {
    let n = lin.u.nrows();
    let mut s = lin.u.clone();
    for acc in &lin.views {
        let v_inv = acc.v.cholesky()?.inverse();
        s -= acc.w.transpose() * v_inv * &acc.w;
    }
    let scale = scaling(&s)?;
    let scaled = DMatrix::from_fn(n, n, |i, j| s[(i, j)] * scale[i] * scale[j]);
    let eigen = scaled.symmetric_eigen();
    let largest = eigen.eigenvalues.max();
    // Below this the matrix is singular to working precision.
    let floor = largest * f64::EPSILON;
    if largest.is_nan() || eigen.eigenvalues.iter().any(|&l| l.is_nan() || l <= floor) {
        return None;
    }
    let inverse_values = eigen.eigenvalues.map(|l| 1.0 / l);
    let inv = &eigen.eigenvectors
        * DMatrix::from_diagonal(&inverse_values)
        * eigen.eigenvectors.transpose();
    Some(DMatrix::from_fn(n, n, |i, j| {
        inv[(i, j)] * scale[i] * scale[j]
    }))
}

/// Minimizes the problem's sum of squared residuals from `initial` by
/// Levenberg-Marquardt with Marquardt's diagonal scaling and Nielsen's damping update;
/// from an admissible `initial`, a step into an inadmissible state is refused as one
/// that does not reduce the cost.
pub(crate) fn solve<P: BlockProblem>(
    problem: &P,
    initial: P::State,
    termination: Termination,
) -> Solution<P::State> {
    let n = problem.shared_dim();
    let mut lin = Linearization {
        views: (0..problem.view_count())
            .map(|_| ViewAccumulator::new(n))
            .collect(),
        u: DMatrix::zeros(n, n),
        g_shared: DVector::zeros(n),
        cost: 0.0,
    };
    let constrained = problem.admissible(&initial);
    let mut state = initial;
    let mut lambda = 1e-3;
    let mut nu = 2.0;
    linearize(problem, &state, &mut lin);
    'outer: for _ in 0..termination.max_iterations {
        loop {
            let Some((d_shared, d_views, predicted)) = damped_step(&lin, lambda) else {
                lambda *= nu;
                nu *= 2.0;
                if lambda > 1e20 {
                    break 'outer;
                }
                continue;
            };
            let candidate = problem.retract(&state, &d_shared, &d_views);
            let cost: f64 = if constrained && !problem.admissible(&candidate) {
                f64::INFINITY
            } else {
                (0..problem.view_count())
                    .map(|v| problem.view_cost(&candidate, v))
                    .sum()
            };
            let reduction = lin.cost - cost;
            if cost.is_finite() && reduction > 0.0 {
                let rho = if predicted > 0.0 {
                    reduction / predicted
                } else {
                    1.0
                };
                lambda *= (1.0 - (2.0 * rho - 1.0).powi(3)).max(1.0 / 3.0);
                nu = 2.0;
                let previous = lin.cost;
                state = candidate;
                linearize(problem, &state, &mut lin);
                if reduction <= termination.relative_cost_tolerance * previous {
                    break 'outer;
                }
                break;
            }
            lambda *= nu;
            nu *= 2.0;
            if lambda > 1e20 {
                break 'outer;
            }
        }
    }
    let view_costs = lin.views.iter().map(|acc| acc.cost).collect();
    Solution {
        shared_inverse: if n > 0 { shared_inverse(&lin) } else { None },
        state,
        view_costs,
    }
}
