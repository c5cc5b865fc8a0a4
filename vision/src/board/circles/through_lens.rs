//! What the detector's centres get wrong on an ideal image of a circle grid, given
//! the camera and the pose: the error a calibration takes out of the detected centres
//! once it knows them (the detector alone models the lens only to second order around
//! each circle, which a strong lens exceeds near the image border).

use nalgebra::{Isometry3, Point2, Point3, Vector2};

use super::conic::TangentFit;
use super::{board_plane, local_biases, local_maps};
use crate::board::Target;
use crate::camera::CameraModel;

/// Points on the projected edge of a circle.
const EDGE_SAMPLES: usize = 64;

/// For each circle of `target` (a circle grid) by id, where the detector would put
/// its centre in an ideal image through `camera` with the target at
/// `camera_from_target`, less the projection of the true centre; `None` for a target
/// that is not a circle grid, or a circle the camera cannot project.
pub fn circle_centre_errors(
    target: &Target,
    camera: &CameraModel,
    camera_from_target: &Isometry3<f64>,
) -> Option<Vec<Vector2<f64>>> {
    let (grid, _) = target.circle_grid()?;
    let radius = 0.5 * grid.diameter();
    let points = target.object_points();
    let truth = points
        .iter()
        .map(|p| camera.project(&(camera_from_target * p)))
        .collect::<Option<Vec<_>>>()?;
    let ellipse_centres = points
        .iter()
        .zip(&truth)
        .map(|(centre, image)| ellipse_centre(camera, camera_from_target, centre, radius, image))
        .collect::<Option<Vec<_>>>()?;
    let plane = board_plane(target, grid.spacing);
    let maps = local_maps(grid.cols, grid.rows, &plane, &truth);
    let biases = local_biases(&maps, Some(radius / grid.spacing));
    Some(
        ellipse_centres
            .iter()
            .zip(&biases)
            .zip(&truth)
            .map(|((found, bias), true_centre)| {
                found - bias.unwrap_or_else(Vector2::zeros) - true_centre
            })
            .collect(),
    )
}

/// The centre of the ellipse the detector fits to the projected edge of the circle of
/// `radius` metres around `centre` (target frame), whose centre projects to `image`.
fn ellipse_centre(
    camera: &CameraModel,
    camera_from_target: &Isometry3<f64>,
    centre: &Point3<f64>,
    radius: f64,
    image: &Point2<f64>,
) -> Option<Point2<f64>> {
    let edge = (0..EDGE_SAMPLES)
        .map(|k| {
            let angle = std::f64::consts::TAU * k as f64 / EDGE_SAMPLES as f64;
            let (sin, cos) = angle.sin_cos();
            let point = centre + nalgebra::Vector3::new(cos, sin, 0.0) * radius;
            camera.project(&(camera_from_target * point))
        })
        .collect::<Option<Vec<_>>>()?;
    let scale = (edge[0] - image).norm();
    let mut fit = TangentFit::new(*image, scale);
    for k in 0..EDGE_SAMPLES {
        let before = edge[(k + EDGE_SAMPLES - 1) % EDGE_SAMPLES];
        let after = edge[(k + 1) % EDGE_SAMPLES];
        let tangent = (after - before) / 2.0;
        // The fit on an image weighs the edge per pixel along it: by arc length here.
        if let Some(normal) = Vector2::new(tangent.y, -tangent.x).try_normalize(1e-12) {
            fit.add(edge[k], normal, tangent.norm());
        }
    }
    fit.solve()?.centre()
}
