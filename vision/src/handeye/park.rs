//! Park and Martin 1994, "Robot sensor calibration: solving AX = XB on the Euclidean
//! group": the rotation from the motions' rotation vectors (the Lie algebra), then the
//! translation.

use nalgebra::{Isometry3, Matrix3, SymmetricEigen};

use super::isometry;
use super::motion::{Motion, translation};

/// `mount_from_camera` from the motions: with `alpha` and `beta` the rotation vectors
/// of `a` and `b`, `M = sum beta alpha^T` and `R = (M^T M)^(-1/2) M^T`.
pub(super) fn solve(motions: &[Motion]) -> Result<Isometry3<f64>, &'static str> {
    let mut m = Matrix3::zeros();
    for motion in motions {
        let alpha = motion.a.rotation.scaled_axis();
        let beta = motion.b.rotation.scaled_axis();
        m += beta * alpha.transpose();
    }
    let eigen = SymmetricEigen::try_new(m.transpose() * m, f64::EPSILON, 1000)
        .ok_or("the eigendecomposition did not converge")?;
    if eigen.eigenvalues.iter().any(|&v| v.is_nan() || v <= 0.0) {
        return Err("the motions' rotation vectors do not span space");
    }
    let inverse_sqrt = eigen.eigenvectors
        * Matrix3::from_diagonal(&eigen.eigenvalues.map(|v| v.sqrt().recip()))
        * eigen.eigenvectors.transpose();
    let rotation = inverse_sqrt * m.transpose();
    let t = translation(motions, &rotation)?;
    Ok(isometry(&rotation, &t))
}
