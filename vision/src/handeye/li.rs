//! Li, Wang and Wu 2010, "Simultaneous robot-world and hand-eye calibration using
//! dual-quaternions and Kronecker product" (`AX = ZB`): both rotations and both
//! translations from one linear system.

use nalgebra::{DMatrix, DVector, Isometry3, Matrix3, Vector3};

use super::{isometry, normalize_rotation};

/// `(X, Z)` with `A_i X = Z B_i` for every pair `(a[i], b[i])`.
///
/// With `x = [vec(R_X); vec(R_Z); t_X; t_Z]` (`vec` row by row), each pair gives
/// `(R_A (x) I) vec(R_X) - (I (x) R_B^T) vec(R_Z) = 0` and
/// `(I (x) t_B^T) vec(R_Z) - R_A t_X + t_Z = t_A`; the stacked system is solved in the
/// least-squares sense and each rotation replaced by the nearest rotation of its
/// determinant's sign.
pub(super) fn solve(
    a: &[Isometry3<f64>],
    b: &[Isometry3<f64>],
) -> Result<(Isometry3<f64>, Isometry3<f64>), &'static str> {
    let n = a.len().min(b.len());
    let mut system = DMatrix::zeros(12 * n, 24);
    let mut rhs = DVector::zeros(12 * n);
    for (k, (a, b)) in a.iter().zip(b).enumerate() {
        let ra = a.rotation.to_rotation_matrix().into_inner();
        let rb = b.rotation.to_rotation_matrix().into_inner();
        let (ta, tb) = (a.translation.vector, b.translation.vector);
        let row = 12 * k;
        let left = ra.kronecker(&Matrix3::identity());
        let right = Matrix3::identity().kronecker(&rb.transpose());
        for r in 0..9 {
            for c in 0..9 {
                system[(row + r, c)] = left[(r, c)];
                system[(row + r, 9 + c)] = -right[(r, c)];
            }
        }
        for r in 0..3 {
            for c in 0..3 {
                system[(row + 9 + r, 9 + 3 * r + c)] = tb[c];
                system[(row + 9 + r, 18 + c)] = -ra[(r, c)];
            }
            system[(row + 9 + r, 21 + r)] = 1.0;
            rhs[row + 9 + r] = ta[r];
        }
    }
    let x = system
        .svd(true, true)
        .solve(&rhs, f64::EPSILON)
        .map_err(|_| "the least-squares solve failed")?;
    let rx = normalize_rotation(&Matrix3::from_row_slice(&x.as_slice()[0..9]))?;
    let rz = normalize_rotation(&Matrix3::from_row_slice(&x.as_slice()[9..18]))?;
    Ok((
        isometry(&rx, &Vector3::new(x[18], x[19], x[20])),
        isometry(&rz, &Vector3::new(x[21], x[22], x[23])),
    ))
}
