//! Horaud and Dornaika 1995, "Hand-eye calibration": the rotation as the unit
//! quaternion that best satisfies `q_a q = q q_b`, then the translation.

use nalgebra::{Isometry3, Matrix4, Quaternion, SymmetricEigen, UnitQuaternion};

use super::isometry;
use super::motion::{Motion, translation};

/// `mount_from_camera` from the motions: `q` minimizes
/// `sum |(L(q_a) - R(q_b)) q|^2` over unit quaternions, with `L` and `R` the matrices of
/// multiplication on the left and on the right; the eigenvector of the least
/// eigenvalue. Both motions' quaternions are taken with a non-negative scalar part, so
/// that they agree in sign (a conjugation keeps the scalar part).
pub(super) fn solve(motions: &[Motion]) -> Result<Isometry3<f64>, &'static str> {
    let mut normal = Matrix4::zeros();
    for motion in motions {
        let difference =
            left(&canonical(&motion.a.rotation)) - right(&canonical(&motion.b.rotation));
        normal += difference.transpose() * difference;
    }
    let eigen = SymmetricEigen::try_new(normal, f64::EPSILON, 1000)
        .ok_or("the eigendecomposition did not converge")?;
    let least = eigen.eigenvalues.imin();
    let q = eigen.eigenvectors.column(least);
    // Rows and columns in the order (w, x, y, z).
    let rotation = UnitQuaternion::from_quaternion(Quaternion::new(q[0], q[1], q[2], q[3]))
        .to_rotation_matrix()
        .into_inner();
    let t = translation(motions, &rotation)?;
    Ok(isometry(&rotation, &t))
}

/// The quaternion of a rotation as `(w, x, y, z)` with `w >= 0`.
pub(super) fn canonical(rotation: &UnitQuaternion<f64>) -> [f64; 4] {
    let q = rotation.quaternion();
    let sign = if q.w < 0.0 { -1.0 } else { 1.0 };
    [q.w * sign, q.i * sign, q.j * sign, q.k * sign]
}

/// `L(r)` with `L(r) s = r s` (Hamilton product), on `(w, x, y, z)`.
fn left(r: &[f64; 4]) -> Matrix4<f64> {
    let [w, x, y, z] = *r;
    Matrix4::new(w, -x, -y, -z, x, w, -z, y, y, z, w, -x, z, -y, x, w)
}

/// `R(r)` with `R(r) s = s r`, on `(w, x, y, z)`.
fn right(r: &[f64; 4]) -> Matrix4<f64> {
    let [w, x, y, z] = *r;
    Matrix4::new(w, -x, -y, -z, x, w, z, -y, y, -z, w, x, z, y, -x, w)
}
