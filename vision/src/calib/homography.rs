//! Plane-to-image homographies by the normalized direct linear transform.

use nalgebra::{Matrix3, Point2, SMatrix, SymmetricEigen};

/// The homography `H` with `image ~ H [x y 1]^T` for points of a plane, from at least
/// four correspondences, by the DLT on Hartley-normalized coordinates. `None` when the
/// points are degenerate (fewer than four, or collinear). `H` is scaled so that
/// `H[(2, 2)]` is 1 when it is not near zero.
pub(crate) fn homography(plane: &[Point2<f64>], image: &[Point2<f64>]) -> Option<Matrix3<f64>> {
    if plane.len() < 4 || plane.len() != image.len() {
        return None;
    }
    let t_plane = normalizing_transform(plane)?;
    let t_image = normalizing_transform(image)?;
    let mut ata = SMatrix::<f64, 9, 9>::zeros();
    for (p, q) in plane.iter().zip(image) {
        let p = t_plane * p.to_homogeneous();
        let q = t_image * q.to_homogeneous();
        let (x, y) = (p.x / p.z, p.y / p.z);
        let (u, v) = (q.x / q.z, q.y / q.z);
        let rows = [
            [x, y, 1.0, 0.0, 0.0, 0.0, -u * x, -u * y, -u],
            [0.0, 0.0, 0.0, x, y, 1.0, -v * x, -v * y, -v],
        ];
        for row in &rows {
            for i in 0..9 {
                for j in 0..9 {
                    ata[(i, j)] += row[i] * row[j];
                }
            }
        }
    }
    let eigen = SymmetricEigen::new(ata);
    let (smallest, _) = eigen
        .eigenvalues
        .iter()
        .enumerate()
        .min_by(|a, b| a.1.total_cmp(b.1))?;
    let mut sorted: Vec<f64> = eigen.eigenvalues.iter().copied().collect();
    sorted.sort_by(f64::total_cmp);
    // A second vanishing eigenvalue means the points do not determine the homography.
    if sorted[1] <= 1e-12 * sorted[8] {
        return None;
    }
    let h = eigen.eigenvectors.column(smallest);
    let normalized = Matrix3::new(h[0], h[1], h[2], h[3], h[4], h[5], h[6], h[7], h[8]);
    let h = t_image.try_inverse()? * normalized * t_plane;
    let scale = h[(2, 2)];
    Some(if scale.abs() > 1e-12 * h.norm() {
        h / scale
    } else {
        h / h.norm()
    })
}

/// Similarity moving the centroid to the origin and the mean distance to sqrt(2).
fn normalizing_transform(points: &[Point2<f64>]) -> Option<Matrix3<f64>> {
    let n = points.len() as f64;
    let (mx, my) = points
        .iter()
        .fold((0.0, 0.0), |(x, y), p| (x + p.x / n, y + p.y / n));
    let mean_distance = points
        .iter()
        .map(|p| ((p.x - mx).powi(2) + (p.y - my).powi(2)).sqrt())
        .sum::<f64>()
        / n;
    if mean_distance.is_nan() || mean_distance <= 0.0 || mean_distance.is_infinite() {
        return None;
    }
    let s = std::f64::consts::SQRT_2 / mean_distance;
    Some(Matrix3::new(
        s,
        0.0,
        -s * mx,
        0.0,
        s,
        -s * my,
        0.0,
        0.0,
        1.0,
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn recovers_a_known_homography() {
        let truth = Matrix3::new(520.0, 12.0, 300.0, -8.0, 505.0, 240.0, 0.05, -0.03, 1.0);
        let plane: Vec<Point2<f64>> = (0..6)
            .flat_map(|r| (0..9).map(move |c| Point2::new(c as f64 * 0.1, r as f64 * 0.1)))
            .collect();
        let image: Vec<Point2<f64>> = plane
            .iter()
            .map(|p| Point2::from_homogeneous(truth * p.to_homogeneous()).unwrap())
            .collect();
        let h = homography(&plane, &image).unwrap();
        assert!((h - truth).norm() < 1e-6 * truth.norm(), "{h} vs {truth}");
    }

    #[test]
    fn collinear_points_have_no_homography() {
        let plane: Vec<Point2<f64>> = (0..8).map(|i| Point2::new(i as f64, 0.0)).collect();
        let image: Vec<Point2<f64>> = (0..8).map(|i| Point2::new(2.0 * i as f64, 1.0)).collect();
        assert!(homography(&plane, &image).is_none());
    }
}
