//! Inverse of the lens distortion: from a distorted normalized coordinate back to the
//! undistorted one, over the whole range where the model is invertible.
//!
//! The radial part of every model is a function `f(t)` of one variable (the undistorted
//! radius `r` for the pinhole models, the ray angle `theta` for equidistant) that
//! starts at `f(0) = 0` with slope 1. The model is invertible on `[0, t_max)`, where
//! `t_max` is the first place its slope stops being positive (for rational_polynomial,
//! also where its denominator vanishes). The radial equation `f(t) = |distorted|` is
//! bracketed on that first increasing branch by a geometric scan and solved by
//! safeguarded Newton (bisection whenever a Newton step leaves the bracket), so the
//! solution is never a spurious preimage on a folded-back branch. For the pinhole
//! models the tangential terms are then added by damped Newton on the full 2D map with
//! its analytic Jacobian, starting from the radial solution.

use nalgebra::Vector2;

use super::Distortion;

/// Largest undistorted normalized radius considered for the pinhole models: a ray
/// 89.94 degrees off axis. Points further out have no useful image.
const PINHOLE_RADIUS_LIMIT: f64 = 1e3;
/// Ratio between successive radii of the bracketing scan.
const SCAN_RATIO: f64 = 1.25;
/// First radius of the bracketing scan (unless the target is smaller).
const SCAN_START: f64 = 1e-3;

impl Distortion {
    /// Inverse of [`Distortion::distort`]: the undistorted normalized coordinate whose
    /// distortion is `distorted`.
    ///
    /// Converges over the model's whole invertible range, however strong the
    /// distortion (unlike a fixed number of fixed-point iterations). Returns `None` only
    /// when `distorted` has no preimage there: beyond the radius where the model's
    /// radial profile folds back, beyond 90 degrees off axis for equidistant (no ray in
    /// front of the camera), or for non-finite input.
    pub fn undistort(&self, distorted: &Vector2<f64>) -> Option<Vector2<f64>> {
        self.undistort_on_branch(distorted, None)
    }

    /// An undistorter of many points: [`Distortion::undistort`] with the end of the
    /// model's invertible range found once, not per point.
    pub fn undistorter(&self) -> Undistorter<'_> {
        let branch_end = match self {
            Self::Equidistant { .. } => {
                branch_end(|t| self.equidistant_profile(t), std::f64::consts::FRAC_PI_2)
            }
            Self::PlumbBob { .. } | Self::RationalPolynomial { .. } => {
                branch_end(|r| self.radial_profile(r), PINHOLE_RADIUS_LIMIT)
            }
        };
        let branch_top = match self {
            Self::Equidistant { .. } => self.equidistant_profile(branch_end).0,
            Self::PlumbBob { .. } | Self::RationalPolynomial { .. } => {
                self.radial_profile(branch_end).0
            }
        };
        Undistorter {
            distortion: self,
            branch_end,
            branch_top,
        }
    }

    /// [`Distortion::undistort`], solving the radial equation below `branch_end` when
    /// it is known, else scanning for the branch from zero.
    fn undistort_on_branch(
        &self,
        distorted: &Vector2<f64>,
        branch_end: Option<f64>,
    ) -> Option<Vector2<f64>> {
        // Below a known end of the branch the profile is solved directly (inlined);
        // otherwise the branch is found first.
        fn solve(
            f: impl Fn(f64) -> (f64, f64),
            target: f64,
            limit: f64,
            branch_end: Option<f64>,
        ) -> Option<f64> {
            match branch_end {
                Some(end) => solve_below(f, target, end),
                None => solve_first_branch(&f, target, limit),
            }
        }
        if !distorted.x.is_finite() || !distorted.y.is_finite() {
            return None;
        }
        let rd = distorted.norm();
        match self {
            Self::Equidistant { .. } => {
                if rd == 0.0 {
                    return Some(*distorted);
                }
                let theta_d = |t: f64| self.equidistant_profile(t);
                let theta = solve(theta_d, rd, std::f64::consts::FRAC_PI_2, branch_end)?;
                if theta >= std::f64::consts::FRAC_PI_2 {
                    return None;
                }
                Some(distorted * (theta.tan() / rd))
            }
            Self::PlumbBob { .. } | Self::RationalPolynomial { .. } => {
                let radial = |r: f64| self.radial_profile(r);
                let (p1, p2) = self.tangential_coeffs();
                if rd == 0.0 && p1 == 0.0 && p2 == 0.0 {
                    return Some(*distorted);
                }
                let r = if rd == 0.0 {
                    0.0
                } else {
                    solve(radial, rd, PINHOLE_RADIUS_LIMIT, branch_end)?
                };
                let start = if rd == 0.0 {
                    *distorted
                } else {
                    distorted * (r / rd)
                };
                if p1 == 0.0 && p2 == 0.0 {
                    return Some(start);
                }
                self.refine_pinhole(distorted, start)
                    .or_else(|| self.refine_pinhole(distorted, *distorted))
            }
        }
    }

    /// The equidistant model's `theta_d(theta)` and its slope.
    fn equidistant_profile(&self, t: f64) -> (f64, f64) {
        let Self::Equidistant { coeffs } = self else {
            return (f64::NAN, f64::NAN);
        };
        let t2 = t * t;
        let [k1, k2, k3, k4] = *coeffs;
        let value = t * (1.0 + t2 * (k1 + t2 * (k2 + t2 * (k3 + t2 * k4))));
        let slope = 1.0 + t2 * (3.0 * k1 + t2 * (5.0 * k2 + t2 * (7.0 * k3 + t2 * 9.0 * k4)));
        (value, slope)
    }

    /// Radial profile of a pinhole model, `f(r) = r * radial(r^2)`, and its slope
    /// `f'(r)`; the slope is reported as NaN where a rational denominator is not
    /// positive (the model is not defined there).
    fn radial_profile(&self, r: f64) -> (f64, f64) {
        let s = r * r;
        match self {
            Self::PlumbBob { coeffs } => {
                let [k1, k2, _, _, k3] = *coeffs;
                let value = r * (1.0 + s * (k1 + s * (k2 + s * k3)));
                let slope = 1.0 + s * (3.0 * k1 + s * (5.0 * k2 + s * 7.0 * k3));
                (value, slope)
            }
            Self::RationalPolynomial { coeffs } => {
                let [k1, k2, _, _, k3, k4, k5, k6] = *coeffs;
                let num = 1.0 + s * (k1 + s * (k2 + s * k3));
                let den = 1.0 + s * (k4 + s * (k5 + s * k6));
                if den <= 0.0 {
                    return (f64::NAN, f64::NAN);
                }
                let dnum = k1 + s * (2.0 * k2 + s * 3.0 * k3);
                let dden = k4 + s * (2.0 * k5 + s * 3.0 * k6);
                // d/dr [r N(s)/D(s)] with ds/dr = 2r.
                let slope = ((num + 2.0 * s * dnum) * den - 2.0 * s * num * dden) / (den * den);
                (r * num / den, slope)
            }
            Self::Equidistant { .. } => (f64::NAN, f64::NAN),
        }
    }

    fn tangential_coeffs(&self) -> (f64, f64) {
        match self {
            Self::PlumbBob { coeffs } => (coeffs[2], coeffs[3]),
            Self::RationalPolynomial { coeffs } => (coeffs[2], coeffs[3]),
            Self::Equidistant { .. } => (0.0, 0.0),
        }
    }

    /// Damped Newton on `distort(p) = target` from `start`; `None` unless it converges
    /// to a point where the map is locally invertible and orientation-preserving.
    fn refine_pinhole(&self, target: &Vector2<f64>, start: Vector2<f64>) -> Option<Vector2<f64>> {
        // Squared lengths throughout: a square root would lengthen every step's chain.
        let scale_sq = target.norm_squared().max(1.0);
        let tolerance_sq = 1e-26 * scale_sq;
        let mut p = start;
        let (distorted, mut jacobian) = self.distort_with_point_jacobian(&p);
        let mut residual = distorted - target;
        let mut residual_sq = residual.norm_squared();
        for _ in 0..100 {
            if residual_sq <= tolerance_sq {
                break;
            }
            let step = jacobian.try_inverse()? * residual;
            let mut alpha = 1.0;
            let mut improved = false;
            for _ in 0..40 {
                let candidate = p - step * alpha;
                let (distorted, candidate_jacobian) = self.distort_with_point_jacobian(&candidate);
                let candidate_residual = distorted - target;
                let candidate_sq = candidate_residual.norm_squared();
                if candidate_sq < residual_sq {
                    p = candidate;
                    residual = candidate_residual;
                    residual_sq = candidate_sq;
                    jacobian = candidate_jacobian;
                    improved = true;
                    break;
                }
                alpha *= 0.5;
            }
            if !improved {
                break;
            }
        }
        let within_range = p.norm() < PINHOLE_RADIUS_LIMIT
            && self.radial_profile(p.norm()).1 > 0.0
            && jacobian.determinant() > 0.0;
        (residual_sq <= 1e-18 * scale_sq && within_range).then_some(p)
    }
}

/// [`Distortion::undistort`] for many points of one model.
pub struct Undistorter<'a> {
    distortion: &'a Distortion,
    branch_end: f64,
    /// The radial profile's value at `branch_end`: no larger distorted radius has a
    /// preimage on the branch.
    branch_top: f64,
}

impl Undistorter<'_> {
    /// The undistorted normalized coordinate whose distortion is `distorted`: the
    /// point [`Distortion::undistort`] finds, to rounding.
    ///
    /// For the pinhole models, Newton on the full 2D map starts from one fixed-point
    /// step (`distorted / radial(|distorted|^2)`) instead of the solved radial equation,
    /// which halves the cost; its result is kept only when it lies within the known end
    /// of the first branch, and the radial equation is solved otherwise.
    pub fn undistort(&self, distorted: &Vector2<f64>) -> Option<Vector2<f64>> {
        self.undistort_pinhole_directly(distorted).or_else(|| {
            self.distortion
                .undistort_on_branch(distorted, Some(self.branch_end))
        })
    }

    fn undistort_pinhole_directly(&self, distorted: &Vector2<f64>) -> Option<Vector2<f64>> {
        if matches!(self.distortion, Distortion::Equidistant { .. })
            || !distorted.iter().all(|v| v.is_finite())
        {
            return None;
        }
        let rd = distorted.norm();
        // NaN included: beyond the branch's top the radial equation has no solution,
        // and the radial path refuses the point.
        if rd.is_nan() || rd > self.branch_top || self.branch_top.is_nan() {
            return None;
        }
        let radial = if rd > 0.0 {
            self.distortion.radial_profile(rd).0 / rd
        } else {
            1.0
        };
        // NaN (a rational denominator at zero) is refused with the rest.
        if radial.is_nan() || radial <= 0.0 {
            return None;
        }
        self.distortion
            .refine_pinhole(distorted, distorted / radial)
            .filter(|p| p.norm() < self.branch_end)
    }
}

/// Where the first increasing branch of `f` (`f(0) = 0`, slope 1) ends within
/// `[0, limit]`: the last point of positive slope before the slope first stops being
/// positive, found by the same geometric scan as [`solve_first_branch`] and bisection;
/// `limit` when the slope stays positive.
fn branch_end(f: impl Fn(f64) -> (f64, f64), limit: f64) -> f64 {
    let mut lo = 0.0;
    let mut t = SCAN_START.min(limit);
    loop {
        let slope = f(t).1;
        if slope.is_nan() || slope <= 0.0 {
            break;
        }
        if t >= limit {
            return limit;
        }
        lo = t;
        t = (t * SCAN_RATIO).min(limit);
    }
    let mut hi = t;
    while hi - lo > 4.0 * f64::EPSILON * hi {
        let mid = 0.5 * (lo + hi);
        if f(mid).1 > 0.0 {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    lo
}

/// Solves `f(t) = target` (with `target > 0`) on `[0, end]`, where `f` increases from
/// `f(0) = 0`: safeguarded Newton from `t = target` (the slope at zero is 1). `None`
/// when `f(end)` falls short of `target`.
fn solve_below(f: impl Fn(f64) -> (f64, f64), target: f64, end: f64) -> Option<f64> {
    let (value_end, _) = f(end);
    // NaN included: a branch that ends short of the target has no preimage there.
    if value_end.is_nan() || value_end < target {
        return ((value_end - target).abs() <= 1e-12 * target.max(1.0)).then_some(end);
    }
    let (mut lo, mut hi) = (0.0, end);
    let mut t = target.min(end);
    for _ in 0..200 {
        let (value, slope) = f(t);
        if value == target {
            return Some(t);
        }
        if value < target {
            lo = t;
        } else {
            hi = t;
        }
        let newton = t - (value - target) / slope;
        if newton > lo && newton < hi && (newton - t).abs() <= 2.0 * f64::EPSILON * t {
            return Some(newton);
        }
        if hi - lo <= 4.0 * f64::EPSILON * hi {
            return Some(t);
        }
        t = if newton > lo && newton < hi {
            newton
        } else {
            0.5 * (lo + hi)
        };
    }
    Some(t)
}

/// Solves `f(t) = target` (with `target > 0`) on the first increasing branch of `f`,
/// `f(0) = 0`, within `[0, limit]`; `f` returns the value and the slope. `None` when the
/// branch ends (slope not positive) or the limit is reached before `target`.
fn solve_first_branch(f: &dyn Fn(f64) -> (f64, f64), target: f64, limit: f64) -> Option<f64> {
    // Bracket: `lo` is on the branch with f(lo) < target; `hi` either has
    // f(hi) >= target on the branch or lies beyond the end of the branch.
    let mut lo = 0.0;
    let mut t = SCAN_START.min(target).min(limit);
    let hi = loop {
        let (value, slope) = f(t);
        if slope.is_nan() || slope <= 0.0 || value >= target {
            break t;
        }
        if t >= limit {
            return None;
        }
        lo = t;
        t = (t * SCAN_RATIO).min(limit);
    };
    let (mut lo, mut hi) = (lo, hi);
    let mut t = 0.5 * (lo + hi);
    for _ in 0..200 {
        let (value, slope) = f(t);
        let on_branch = slope > 0.0;
        if on_branch && value == target {
            return Some(t);
        }
        if on_branch && value < target {
            lo = t;
        } else {
            hi = t;
        }
        if hi - lo <= 4.0 * f64::EPSILON * hi {
            break;
        }
        let newton = if on_branch {
            t - (value - target) / slope
        } else {
            f64::NAN
        };
        if newton > lo && newton < hi && (newton - t).abs() <= 2.0 * f64::EPSILON * t {
            return Some(newton);
        }
        t = if newton > lo && newton < hi {
            newton
        } else {
            0.5 * (lo + hi)
        };
    }
    // Converged to the end of the branch without reaching the target: no preimage.
    let (value, slope) = f(lo);
    let (value_hi, slope_hi) = f(hi);
    let hits = |v: f64, s: f64| s > 0.0 && (v - target).abs() <= 1e-12 * target.max(1.0);
    if hits(value_hi, slope_hi) {
        Some(hi)
    } else if hits(value, slope) {
        Some(lo)
    } else {
        None
    }
}
