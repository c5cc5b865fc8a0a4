//! Real roots of univariate polynomials, for the minimal solvers (the 7-point cubic, the
//! 5-point tenth-degree polynomial) and the optimal triangulation's sixth-degree one.

use nalgebra::{DMatrix, linalg::Schur};

/// Largest imaginary part, relative to the root's magnitude (at least 1), of an
/// eigenvalue of the companion matrix still taken as a real root: a double root splits
/// into a complex pair by about the square root of rounding.
const MAX_RELATIVE_IMAGINARY: f64 = 1e-6;
/// Newton steps polishing each root on the polynomial itself.
const POLISH_STEPS: usize = 3;

/// The value of the polynomial `sum coefficients[i] x^i` at `x` (Horner).
pub(crate) fn evaluate(coefficients: &[f64], x: f64) -> f64 {
    coefficients.iter().rev().fold(0.0, |sum, &c| sum * x + c)
}

/// The real roots of `sum coefficients[i] x^i`, lowest degree first in `coefficients`,
/// ascending, from the eigenvalues of the companion matrix, each polished by Newton
/// steps. Leading coefficients that vanish next to the others are dropped (the degree
/// falls); an identically zero polynomial has no roots reported.
pub(crate) fn real_roots(coefficients: &[f64]) -> Vec<f64> {
    let scale = coefficients.iter().fold(0.0_f64, |m, c| m.max(c.abs()));
    if !(scale > 0.0 && scale.is_finite()) {
        return Vec::new();
    }
    let Some(top) = coefficients.iter().rposition(|c| c.abs() > 1e-14 * scale) else {
        return Vec::new();
    };
    let mut roots = match top {
        0 => Vec::new(),
        1 => vec![-coefficients[0] / coefficients[1]],
        _ => companion_roots(&coefficients[..=top]),
    };
    let derivative: Vec<f64> = coefficients[..=top]
        .iter()
        .enumerate()
        .skip(1)
        .map(|(i, &c)| i as f64 * c)
        .collect();
    for root in &mut roots {
        for _ in 0..POLISH_STEPS {
            let slope = evaluate(&derivative, *root);
            let step = evaluate(&coefficients[..=top], *root) / slope;
            if !step.is_finite() {
                break;
            }
            *root -= step;
        }
    }
    roots.retain(|r| r.is_finite());
    roots.sort_by(f64::total_cmp);
    roots
}

/// Real eigenvalues of the companion matrix of a polynomial of degree at least 2 whose
/// leading coefficient does not vanish.
fn companion_roots(coefficients: &[f64]) -> Vec<f64> {
    let degree = coefficients.len() - 1;
    let leading = coefficients[degree];
    let mut companion = DMatrix::<f64>::zeros(degree, degree);
    for i in 0..degree {
        companion[(0, i)] = -coefficients[degree - 1 - i] / leading;
        if i + 1 < degree {
            companion[(i + 1, i)] = 1.0;
        }
    }
    let Some(schur) = Schur::try_new(companion, f64::EPSILON, 1000) else {
        return Vec::new();
    };
    schur
        .complex_eigenvalues()
        .iter()
        .filter(|z| z.im.abs() <= MAX_RELATIVE_IMAGINARY * z.re.abs().max(1.0))
        .map(|z| z.re)
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn finds_the_real_roots_of_a_product() {
        // (x - 1)(x + 2)(x - 0.5)(x^2 + 1) = x^5 + 0.5x^4 - 1.5x^3 + 1.5x^2 - 2.5x + 1
        let roots = real_roots(&[1.0, -2.5, 1.5, -1.5, 0.5, 1.0]);
        assert_eq!(roots.len(), 3, "{roots:?}");
        for (r, t) in roots.iter().zip([-2.0, 0.5, 1.0]) {
            assert!((r - t).abs() < 1e-12, "{roots:?}");
        }
    }

    #[test]
    fn a_vanishing_leading_coefficient_lowers_the_degree() {
        let roots = real_roots(&[-6.0, 1.0, 1.0, 0.0]);
        assert_eq!(roots.len(), 2);
        assert!((roots[0] + 3.0).abs() < 1e-12 && (roots[1] - 2.0).abs() < 1e-12);
        assert!(real_roots(&[0.0, 0.0]).is_empty());
    }
}
