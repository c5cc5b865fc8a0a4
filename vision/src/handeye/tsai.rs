//! Tsai and Lenz 1989, "A new technique for fully autonomous and efficient 3D robotics
//! hand/eye calibration": the rotation from the motions' modified Rodrigues vectors,
//! then the translation.

use nalgebra::{Isometry3, Matrix3, Quaternion, UnitQuaternion, Vector3};

use super::isometry;
use super::motion::{Motion, translation};

/// `|p| = 2 sin(theta / 2)` of the least rotation a motion must have to be used (about
/// 17 degrees): smaller ones carry little information. OpenCV's bound.
const MIN_INFORMATIVE: f64 = 0.3;
/// `|p|` of the largest (about 116 degrees): beyond it the equation degrades. OpenCV's
/// bound.
const MAX_INFORMATIVE: f64 = 1.7;

/// `mount_from_camera` from the motions whose robot and camera rotations are both
/// between 17 and 116 degrees. With `p = 2 sin(theta / 2) axis` of each rotation,
/// `[p_a + p_b]x p' = p_b - p_a` is solved in the least-squares sense; the rotation's
/// own vector is `p = 2 p' / sqrt(1 + |p'|^2)`, the vector part of its quaternion `p / 2`.
/// The translation comes from the same motions.
pub(super) fn solve(motions: &[Motion]) -> Result<Isometry3<f64>, &'static str> {
    let mut normal = Matrix3::zeros();
    let mut right = Vector3::zeros();
    let mut used = Vec::new();
    for motion in motions {
        let pa = modified_rodrigues(&motion.a.rotation);
        let pb = modified_rodrigues(&motion.b.rotation);
        let informative =
            |p: &Vector3<f64>| (MIN_INFORMATIVE..=MAX_INFORMATIVE).contains(&p.norm());
        if !(informative(&pa) && informative(&pb)) {
            continue;
        }
        let lhs = (pa + pb).cross_matrix();
        normal += lhs.transpose() * lhs;
        right += lhs.transpose() * (pb - pa);
        used.push(motion);
    }
    if used.len() < 2 {
        return Err("fewer than two motions turn the robot between 17 and 116 degrees");
    }
    let prime = normal
        .cholesky()
        .ok_or("the informative motions turn about one axis")?
        .solve(&right);
    let p = prime * (2.0 / (1.0 + prime.norm_squared()).sqrt());
    let v = p / 2.0;
    let w = (1.0 - v.norm_squared()).max(0.0).sqrt();
    let rotation = UnitQuaternion::from_quaternion(Quaternion::new(w, v.x, v.y, v.z))
        .to_rotation_matrix()
        .into_inner();
    let t = translation(used, &rotation)?;
    Ok(isometry(&rotation, &t))
}

/// `2 sin(theta / 2) axis`: twice the vector part of the rotation's quaternion, taken
/// with a non-negative scalar part.
fn modified_rodrigues(rotation: &UnitQuaternion<f64>) -> Vector3<f64> {
    let q = rotation.quaternion();
    let sign = if q.w < 0.0 { -1.0 } else { 1.0 };
    q.imag() * (2.0 * sign)
}
