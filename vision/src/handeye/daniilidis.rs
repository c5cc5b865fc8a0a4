//! Daniilidis 1999, "Hand-eye calibration using dual quaternions": rotation and
//! translation together from the null space of one linear system.

use nalgebra::{DMatrix, Isometry3, Quaternion, SVector, UnitQuaternion, Vector3};

use super::horaud::canonical;
use super::isometry;
use super::motion::Motion;

/// `mount_from_camera` from the motions.
///
/// Each motion's dual quaternion `(q, q')` with `q' = (0, t) q / 2` gives six equations
/// in the unknown `(q, q')`: with `a`, `b` the vector parts of `q_a`, `q_b` and `a'`,
/// `b'` those of `q'_a`, `q'_b`, the rows `[a - b, [a + b]x, 0, 0]` and
/// `[a' - b', [a' + b']x, a - b, [a + b]x]`. The solution is the combination of the two
/// right singular vectors of least singular value that is a unit dual quaternion
/// (`|q| = 1`, `q . q' = 0`).
pub(super) fn solve(motions: &[Motion]) -> Result<Isometry3<f64>, &'static str> {
    let mut system = DMatrix::zeros(6 * motions.len(), 8);
    for (k, motion) in motions.iter().enumerate() {
        let (qa, da) = dual_quaternion(motion.a);
        let (qb, db) = dual_quaternion(motion.b);
        let (a, b) = (qa.imag(), qb.imag());
        let (a_dual, b_dual) = (da.imag(), db.imag());
        let row = 6 * k;
        put(&mut system, row, 0, &(a - b), &(a + b));
        put(
            &mut system,
            row + 3,
            0,
            &(a_dual - b_dual),
            &(a_dual + b_dual),
        );
        put(&mut system, row + 3, 4, &(a - b), &(a + b));
    }
    let svd = system.svd(false, true);
    let v_t = svd.v_t.ok_or("the decomposition did not converge")?;
    let mut order: Vec<usize> = (0..svd.singular_values.len()).collect();
    order.sort_by(|&i, &j| svd.singular_values[i].total_cmp(&svd.singular_values[j]));
    let vector =
        |i: usize| -> SVector<f64, 8> { v_t.row(i).transpose().fixed_rows::<8>(0).into_owned() };
    // The two of least singular value, the second-least first (OpenCV's v7 then v8).
    let (first, second) = (vector(order[1]), vector(order[0]));
    let part = |v: &SVector<f64, 8>, at: usize| v.fixed_rows::<4>(at).into_owned();
    let (u1, v1, u2, v2) = (
        part(&first, 0),
        part(&first, 4),
        part(&second, 0),
        part(&second, 4),
    );
    let a = u1.dot(&v1);
    let b = u1.dot(&v2) + u2.dot(&v1);
    let c = u2.dot(&v2);
    let roots = if a.abs() > f64::EPSILON * (b.abs() + c.abs()) {
        let discriminant = (b * b - 4.0 * a * c).max(0.0).sqrt();
        [
            (-b + discriminant) / (2.0 * a),
            (-b - discriminant) / (2.0 * a),
        ]
    } else {
        [-c / b, -c / b]
    };
    let value = |s: f64| s * s * u1.dot(&u1) + 2.0 * s * u1.dot(&u2) + u2.dot(&u2);
    let s = if value(roots[0]) >= value(roots[1]) {
        roots[0]
    } else {
        roots[1]
    };
    let lambda2 = value(s).sqrt().recip();
    let lambda1 = s * lambda2;
    let solution = first * lambda1 + second * lambda2;
    let q = Quaternion::new(solution[0], solution[1], solution[2], solution[3]);
    let q_dual = Quaternion::new(solution[4], solution[5], solution[6], solution[7]);
    let translation: Vector3<f64> = (q_dual * q.conjugate()).imag() * 2.0;
    let rotation = UnitQuaternion::from_quaternion(q)
        .to_rotation_matrix()
        .into_inner();
    let result = isometry(&rotation, &translation);
    if result.translation.vector.iter().all(|v| v.is_finite()) {
        Ok(result)
    } else {
        Err("no unit dual quaternion in the null space")
    }
}

/// The dual quaternion `(q, q')` of a pose, `q` with a non-negative scalar part and
/// `q' = (0, t) q / 2`.
fn dual_quaternion(pose: Isometry3<f64>) -> (Quaternion<f64>, Quaternion<f64>) {
    let [w, x, y, z] = canonical(&pose.rotation);
    let q = Quaternion::new(w, x, y, z);
    let t = pose.translation.vector;
    let dual = Quaternion::new(0.0, t.x, t.y, t.z) * q * 0.5;
    (q, dual)
}

/// Writes `[difference, [sum]x]` into three rows of `system` from `(row, column)`.
fn put(
    system: &mut DMatrix<f64>,
    row: usize,
    column: usize,
    difference: &Vector3<f64>,
    sum: &Vector3<f64>,
) {
    let skew = sum.cross_matrix();
    for r in 0..3 {
        system[(row + r, column)] = difference[r];
        for c in 0..3 {
            system[(row + r, column + 1 + c)] = skew[(r, c)];
        }
    }
}
