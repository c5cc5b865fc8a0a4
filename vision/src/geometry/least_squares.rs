//! Levenberg-Marquardt for the small refinements of this module (a homography on its
//! transfer error, an essential matrix on its Sampson error), on a state that may live
//! on a manifold: steps are taken in a local parametrization and retracted.

use nalgebra::{SMatrix, SVector};

/// Relative decrease of the cost below which the refinement has converged.
const CONVERGED: f64 = 1e-12;
/// Damping beyond which no step lowers the cost: the refinement stops.
const MAX_DAMPING: f64 = 1e12;

/// A nonlinear least-squares problem with `P` local degrees of freedom.
pub(crate) trait LeastSquares<const P: usize> {
    /// A point of the search space.
    type State: Clone;

    /// The cost (sum of squared residuals), `J^T J` and `J^T r` at `state`, `J` the
    /// Jacobian of the residuals with respect to the local step; `None` when the cost
    /// is not finite.
    fn linearize(&self, state: &Self::State) -> Option<(f64, SMatrix<f64, P, P>, SVector<f64, P>)>;

    /// The state reached by a local step from `state`.
    fn retract(&self, state: &Self::State, step: &SVector<f64, P>) -> Self::State;
}

/// Minimizes the problem's cost from `start` by at most `max_iterations` accepted or
/// refused steps; returns the best state found (`start` when no step lowers the cost).
pub(crate) fn levenberg_marquardt<const P: usize, L: LeastSquares<P>>(
    problem: &L,
    start: L::State,
    max_iterations: usize,
) -> L::State {
    let Some((mut cost, mut jtj, mut jtr)) = problem.linearize(&start) else {
        return start;
    };
    let mut state = start;
    let mut damping = 1e-3;
    for _ in 0..max_iterations {
        let mut damped = jtj;
        for i in 0..P {
            // Marquardt's scaling: parameters of very different magnitudes damp alike.
            damped[(i, i)] += damping * jtj[(i, i)].max(1e-12);
        }
        let Some(step) = damped.cholesky().map(|c| -c.solve(&jtr)) else {
            damping *= 10.0;
            if damping > MAX_DAMPING {
                break;
            }
            continue;
        };
        let candidate = problem.retract(&state, &step);
        match problem.linearize(&candidate) {
            Some((new_cost, new_jtj, new_jtr)) if new_cost < cost => {
                let decrease = cost - new_cost;
                state = candidate;
                (cost, jtj, jtr) = (new_cost, new_jtj, new_jtr);
                damping = (damping * 0.1).max(1e-12);
                if decrease <= CONVERGED * cost {
                    break;
                }
            }
            _ => {
                damping *= 10.0;
                if damping > MAX_DAMPING {
                    break;
                }
            }
        }
    }
    state
}
