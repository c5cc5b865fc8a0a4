//! Shah 2013, "Solving the robot-world/hand-eye calibration problem using the Kronecker
//! product" (`AX = ZB`): both rotations from one singular vector pair, then both
//! translations.

use nalgebra::{DMatrix, DVector, Isometry3, Matrix3, SMatrix, Vector3};

use super::{isometry, normalize_rotation};

/// `(X, Z)` with `A_i X = Z B_i` for every pair `(a[i], b[i])`.
///
/// `T = sum R_B (x) R_A` maps `vec(R_X)` to `n vec(R_Z)` (`vec` column by column), so its
/// leading right and left singular vectors are `vec(R_X)` and `vec(R_Z)` up to scale and
/// sign; each is made the nearest rotation of positive determinant. The translations
/// then solve `t_Z - R_A t_X = t_A - R_Z t_B` in the least-squares sense.
pub(super) fn solve(
    a: &[Isometry3<f64>],
    b: &[Isometry3<f64>],
) -> Result<(Isometry3<f64>, Isometry3<f64>), &'static str> {
    let mut t = SMatrix::<f64, 9, 9>::zeros();
    for (a, b) in a.iter().zip(b) {
        let ra = a.rotation.to_rotation_matrix().into_inner();
        let rb = b.rotation.to_rotation_matrix().into_inner();
        t += rb.kronecker(&ra);
    }
    let svd = t
        .try_svd(true, true, f64::EPSILON, 1000)
        .ok_or("the decomposition did not converge")?;
    let leading = svd.singular_values.imax();
    let (u, v_t) = (
        svd.u.ok_or("the decomposition did not converge")?,
        svd.v_t.ok_or("the decomposition did not converge")?,
    );
    let rx = normalize_rotation(&Matrix3::from_column_slice(
        v_t.row(leading).transpose().as_slice(),
    ))?;
    let rz = normalize_rotation(&Matrix3::from_column_slice(u.column(leading).as_slice()))?;
    let n = a.len().min(b.len());
    let mut system = DMatrix::zeros(3 * n, 6);
    let mut rhs = DVector::zeros(3 * n);
    for (k, (a, b)) in a.iter().zip(b).enumerate() {
        let ra = a.rotation.to_rotation_matrix().into_inner();
        let right = a.translation.vector - rz * b.translation.vector;
        for r in 0..3 {
            for c in 0..3 {
                system[(3 * k + r, c)] = -ra[(r, c)];
            }
            system[(3 * k + r, 3 + r)] = 1.0;
            rhs[3 * k + r] = right[r];
        }
    }
    let x = system
        .svd(true, true)
        .solve(&rhs, f64::EPSILON)
        .map_err(|_| "the least-squares solve failed")?;
    Ok((
        isometry(&rx, &Vector3::new(x[0], x[1], x[2])),
        isometry(&rz, &Vector3::new(x[3], x[4], x[5])),
    ))
}
