//! Andreff, Horaud and Espiau 1999, "On-line hand-eye calibration": rotation and
//! translation together from one linear system, the rotation then made orthonormal.

use nalgebra::{DMatrix, DVector, Isometry3, Matrix3, Vector3};

use super::motion::Motion;
use super::{isometry, normalize_rotation};

/// `mount_from_camera` from the motions. With `x = [vec(R); t]` (`vec` row by row),
/// each motion gives `(I - R_a (x) R_b) vec(R) = 0` and
/// `(I (x) t_b^T) vec(R) + (I - R_a) t = t_a`; the stacked system is solved in the
/// least-squares sense and `R` replaced by the nearest rotation of its determinant's
/// sign. The translation is the system's own: its rows are what fix the scale of `R`.
pub(super) fn solve(motions: &[Motion]) -> Result<Isometry3<f64>, &'static str> {
    let mut system = DMatrix::zeros(12 * motions.len(), 12);
    let mut rhs = DVector::zeros(12 * motions.len());
    for (k, motion) in motions.iter().enumerate() {
        let ra = motion.a.rotation.to_rotation_matrix().into_inner();
        let rb = motion.b.rotation.to_rotation_matrix().into_inner();
        let (ta, tb) = (motion.a.translation.vector, motion.b.translation.vector);
        let row = 12 * k;
        let kron = ra.kronecker(&rb);
        for r in 0..9 {
            for c in 0..9 {
                let identity = if r == c { 1.0 } else { 0.0 };
                system[(row + r, c)] = identity - kron[(r, c)];
            }
        }
        for r in 0..3 {
            for c in 0..3 {
                system[(row + 9 + r, 3 * r + c)] = tb[c];
                let identity = if r == c { 1.0 } else { 0.0 };
                system[(row + 9 + r, 9 + c)] = identity - ra[(r, c)];
            }
            rhs[row + 9 + r] = ta[r];
        }
    }
    let x = system
        .svd(true, true)
        .solve(&rhs, f64::EPSILON)
        .map_err(|_| "the least-squares solve failed")?;
    let rotation = normalize_rotation(&Matrix3::from_row_slice(&x.as_slice()[0..9]))?;
    Ok(isometry(&rotation, &Vector3::new(x[9], x[10], x[11])))
}
