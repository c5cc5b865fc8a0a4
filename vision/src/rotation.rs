//! Rotations from matrices that are only nearly rotations.

use nalgebra::{Matrix3, Matrix4x3, Vector3};

/// Iteration cap of the SVD.
const SVD_MAX_ITERATIONS: usize = 1000;
/// Newton steps on FOAM's characteristic polynomial before giving up (from its start
/// above the largest root it converges monotonically, in about five).
const FOAM_MAX_ITERATIONS: usize = 30;
/// FOAM's denominator, relative to the cube of the largest root, below which the
/// nearest rotation is ill-conditioned or not unique (two signed singular values
/// nearly cancel) and the SVD decides instead.
const FOAM_CONDITION: f64 = 1e-6;
/// A cross product of two rows of `a - lambda I` shorter than this, relative to
/// `|a - lambda I|^2`, leaves the eigenvector to rounding.
const EIGENVECTOR_CONDITION: f64 = 1e-8;
/// `||R^T R - I||_F^2` above which FOAM's rotation is not trusted and the SVD decides.
const FOAM_ORTHOGONALITY: f64 = 1e-24;

/// The rotation nearest to `m` in the Frobenius norm, also for a matrix with
/// `det < 0` (then `U diag(1, 1, -1) V^T` from the SVD `m = U S V^T`). `None` for
/// non-finite input or when the decomposition fails.
///
/// Markley's closed form (FOAM, "Attitude determination using vector observations: a
/// fast optimal matrix algorithm", 1993) serves well-conditioned matrices: with
/// `lambda` the largest root of `(l^2 - |m|^2)^2 - 8 l det(m) - 4 |adj(m)|^2`, which is
/// `tr(R^T m)` at the optimum,
/// `R = ((lambda^2 + |m|^2) m + 2 lambda adj(m)^T - 2 m m^T m) /
/// (lambda (lambda^2 - |m|^2) - 2 det(m))`. Its denominator is
/// `2 (d1 + d2)(d1 + d3)(d2 + d3)` for the signed singular values `d`. It nearly
/// vanishes for a matrix near a reflection (`d3 < 0` and `d2 + d3` near zero), whose
/// nearest rotation is the rotation nearest to `-m` turned half a turn about the
/// direction `m` stretches least (see [`nearest_rotation_of_reflection`]). The SVD
/// answers whatever neither form computes to rounding.
pub(crate) fn nearest_rotation(m: &Matrix3<f64>) -> Option<Matrix3<f64>> {
    if !m.iter().all(|v| v.is_finite()) {
        return None;
    }
    foam(m)
        .or_else(|| nearest_rotation_of_reflection(m))
        .or_else(|| nearest_rotation_by_svd(m))
}

/// [`nearest_rotation`] of a matrix with `det(m) < 0`. With `m = U S V^T` (`S >= 0`,
/// `det(U V^T) = -1`) the answer is `U diag(1, 1, -1) V^T`. The rotation nearest to `-m`
/// is `R = -U V^T`, well-conditioned, and `R^T (-m) = V S V^T`; so the answer is
/// `R (2 v v^T - I)` for the eigenvector `v` of the least eigenvalue of `V S V^T`.
/// `None` for `det(m) >= 0`, or when that eigenvalue is not distinct (the nearest rotation
/// is then not unique).
fn nearest_rotation_of_reflection(m: &Matrix3<f64>) -> Option<Matrix3<f64>> {
    if m.determinant() >= 0.0 {
        return None;
    }
    let negated = -m;
    let rotation = foam(&negated)?;
    let stretch = rotation.transpose() * negated;
    let v = least_eigenvector(&((stretch + stretch.transpose()) * 0.5))?;
    Some(rotation * (v * v.transpose() * 2.0 - Matrix3::identity()))
}

/// The unit eigenvector of the least eigenvalue of a symmetric 3x3 matrix, in closed
/// form (the eigenvalues by the trigonometric solution of the characteristic cubic, the
/// vector as the longest cross product of two rows of `a - lambda I`); `None` when that
/// eigenvalue is not distinct from the next to rounding.
fn least_eigenvector(a: &Matrix3<f64>) -> Option<Vector3<f64>> {
    let mean = a.trace() / 3.0;
    let centred = a - Matrix3::identity() * mean;
    let spread = (centred.norm_squared() / 6.0).sqrt();
    if spread.is_nan() || spread <= f64::EPSILON * a.norm() {
        return None;
    }
    let half_det = ((centred / spread).determinant() / 2.0).clamp(-1.0, 1.0);
    let angle = half_det.acos() / 3.0;
    let least = mean + 2.0 * spread * (angle + 2.0 * std::f64::consts::FRAC_PI_3).cos();
    let shifted = a - Matrix3::identity() * least;
    let rows = [
        shifted.row(0).transpose(),
        shifted.row(1).transpose(),
        shifted.row(2).transpose(),
    ];
    let vector = [
        rows[0].cross(&rows[1]),
        rows[0].cross(&rows[2]),
        rows[1].cross(&rows[2]),
    ]
    .into_iter()
    .max_by(|a, b| a.norm_squared().total_cmp(&b.norm_squared()))?;
    // Two equal least eigenvalues leave a - lambda I of rank one: every cross product
    // is rounding.
    let length = vector.norm();
    (length > EIGENVECTOR_CONDITION * shifted.norm_squared()).then(|| vector / length)
}

/// [`nearest_rotation`] in closed form; `None` where the SVD must decide.
fn foam(m: &Matrix3<f64>) -> Option<Matrix3<f64>> {
    let norm_sq = m.norm_squared();
    if norm_sq == 0.0 || !norm_sq.is_finite() {
        return None;
    }
    // Scaled to unit Frobenius norm: the polynomial's terms then stay near one.
    let m = m / norm_sq.sqrt();
    let det = m.determinant();
    let adj_t = Matrix3::from_columns(&[
        m.column(1).cross(&m.column(2)),
        m.column(2).cross(&m.column(0)),
        m.column(0).cross(&m.column(1)),
    ]);
    let adj_sq = adj_t.norm_squared();
    // Start above the largest root: (|m|^2 + 3) / 2 >= sum of the singular values.
    let mut lambda: f64 = 2.0;
    for _ in 0..FOAM_MAX_ITERATIONS {
        let excess = lambda * lambda - 1.0;
        let value = excess * excess - 8.0 * lambda * det - 4.0 * adj_sq;
        let slope = 4.0 * lambda * excess - 8.0 * det;
        if slope <= 0.0 {
            return None;
        }
        let next = lambda - value / slope;
        let converged = (lambda - next).abs() <= 1e-15 * lambda;
        lambda = next;
        if converged {
            break;
        }
    }
    let denominator = lambda * (lambda * lambda - 1.0) - 2.0 * det;
    if denominator.is_nan() || denominator <= FOAM_CONDITION * lambda.powi(3) {
        return None;
    }
    let rotation = (m * (lambda * lambda + 1.0) + adj_t * (2.0 * lambda)
        - m * m.transpose() * m * 2.0)
        / denominator;
    let orthogonality = (rotation.transpose() * rotation - Matrix3::identity()).norm_squared();
    (orthogonality <= FOAM_ORTHOGONALITY && rotation.determinant() > 0.0).then_some(rotation)
}

/// [`nearest_rotation`] from the SVD.
fn nearest_rotation_by_svd(m: &Matrix3<f64>) -> Option<Matrix3<f64>> {
    // The general SVD: nalgebra's special 3x3 SVD goes through m^T m and loses half
    // the digits of nearly equal singular values. A zero fourth row selects the general
    // algorithm without allocating and changes neither V nor U's first three rows.
    let mut padded = Matrix4x3::zeros();
    padded.fixed_rows_mut::<3>(0).copy_from(m);
    let svd = padded.try_svd(true, true, f64::EPSILON, SVD_MAX_ITERATIONS)?;
    let u: Matrix3<f64> = svd.u?.fixed_rows::<3>(0).into_owned();
    let v_t = svd.v_t?;
    let mut sign = Matrix3::identity();
    if (u * v_t).determinant() < 0.0 {
        sign[(2, 2)] = -1.0;
    }
    let rotation = u * sign * v_t;
    rotation.iter().all(|v| v.is_finite()).then_some(rotation)
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Rotation3;
    use rand::{RngExt, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    fn random_matrix(rng: &mut ChaCha8Rng) -> Matrix3<f64> {
        Matrix3::from_fn(|_, _| rng.random_range(-1.0..1.0))
    }

    #[test]
    fn the_closed_form_equals_the_svd_for_either_sign_of_determinant() {
        let mut rng = ChaCha8Rng::seed_from_u64(7);
        let (mut closed_form, mut negative) = (0, 0);
        for _ in 0..20_000 {
            let m = random_matrix(&mut rng) * 10f64.powf(rng.random_range(-3.0..3.0));
            let by_svd = nearest_rotation_by_svd(&m).unwrap();
            let found = nearest_rotation(&m).unwrap();
            // As near to m as the SVD's, to rounding; the rotations themselves agree as
            // far as the conditioning of the problem allows.
            let fit = |r: &Matrix3<f64>| (r.transpose() * m).trace();
            assert!(
                fit(&found) >= fit(&by_svd) - 1e-12 * m.norm(),
                "{m}: {found} against the SVD's {by_svd}"
            );
            assert!(
                (found - by_svd).norm() < 1e-9,
                "{m}: {found} against {by_svd}"
            );
            if let Some(rotation) = foam(&m) {
                closed_form += 1;
                negative += usize::from(m.determinant() < 0.0);
                assert_eq!(rotation, found);
            }
        }
        // Nearly every matrix is answered in closed form, of both signs.
        assert!(closed_form > 19_000, "{closed_form} in closed form");
        assert!(negative > 9_000, "{negative} with det < 0");
    }

    #[test]
    fn a_matrix_near_a_reflection_is_answered_in_closed_form_as_near_as_the_svd() {
        let mut rng = ChaCha8Rng::seed_from_u64(11);
        let mut closed_form = 0;
        for _ in 0..5_000 {
            let rotation = *Rotation3::from_scaled_axis(Vector3::new(
                rng.random_range(-3.0..3.0),
                rng.random_range(-3.0..3.0),
                rng.random_range(-3.0..3.0),
            ))
            .matrix();
            let noise = 10f64.powf(rng.random_range(-8.0..-1.0));
            let m = -rotation + random_matrix(&mut rng) * noise;
            let by_svd = nearest_rotation_by_svd(&m).unwrap();
            let found = nearest_rotation(&m).unwrap();
            let fit = |r: &Matrix3<f64>| (r.transpose() * m).trace();
            assert!(fit(&found) >= fit(&by_svd) - 1e-12 * m.norm(), "{m}");
            assert!((found.transpose() * found - Matrix3::identity()).norm() < 1e-12);
            assert!((found.determinant() - 1.0).abs() < 1e-12);
            closed_form += usize::from(nearest_rotation_of_reflection(&m).is_some());
        }
        assert!(closed_form > 4_900, "{closed_form} in closed form");
    }

    #[test]
    fn the_least_eigenvector_of_a_symmetric_matrix() {
        let basis = *Rotation3::from_scaled_axis(Vector3::new(0.4, -0.9, 1.3)).matrix();
        let a = basis * Matrix3::from_diagonal(&Vector3::new(5.0, 2.0, 0.5)) * basis.transpose();
        let v = least_eigenvector(&a).unwrap();
        assert!(1.0 - v.dot(&basis.column(2)).abs() < 1e-14);
        // Two equal least eigenvalues: no unique vector.
        let double =
            basis * Matrix3::from_diagonal(&Vector3::new(5.0, 0.5, 0.5)) * basis.transpose();
        assert!(least_eigenvector(&double).is_none());
    }

    #[test]
    fn a_rotation_is_its_own_nearest() {
        let rotation = *Rotation3::from_scaled_axis(Vector3::new(0.3, -1.2, 2.0)).matrix();
        let found = foam(&rotation).unwrap();
        assert!((found - rotation).norm() < 1e-14);
        let scaled = nearest_rotation(&(rotation * 1e-5)).unwrap();
        assert!((scaled - rotation).norm() < 1e-14);
    }

    #[test]
    fn a_reflection_with_no_unique_nearest_rotation_goes_to_the_svd() {
        // -R has signed singular values (1, 1, -1): R followed by half a turn about any
        // axis is equally near, and the closed form's denominator vanishes.
        let rotation = *Rotation3::from_scaled_axis(Vector3::new(0.1, 0.2, 0.3)).matrix();
        assert!(foam(&-rotation).is_none());
        assert!(nearest_rotation_of_reflection(&-rotation).is_none());
        let found = nearest_rotation(&-rotation).unwrap();
        assert!((found.transpose() * found - Matrix3::identity()).norm() < 1e-12);
        assert!((found.determinant() - 1.0).abs() < 1e-12);
    }

    #[test]
    fn non_finite_and_zero_matrices_are_refused_or_decided_by_the_svd() {
        let mut m = Matrix3::identity();
        m[(1, 2)] = f64::NAN;
        assert!(nearest_rotation(&m).is_none());
        assert!(foam(&Matrix3::zeros()).is_none());
    }
}
