//! Rotations from matrices that are only nearly rotations.

use nalgebra::{Matrix3, Matrix4x3};

/// Iteration cap of the SVD.
const SVD_MAX_ITERATIONS: usize = 1000;

/// The rotation nearest to `m` in the Frobenius norm: `U diag(1, 1, det(U V^T)) V^T`
/// from the SVD `m = U S V^T`, which also turns a matrix with `det < 0` into a proper
/// rotation. `None` for non-finite input or when the decomposition fails.
pub(crate) fn nearest_rotation(m: &Matrix3<f64>) -> Option<Matrix3<f64>> {
    if !m.iter().all(|v| v.is_finite()) {
        return None;
    }
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
