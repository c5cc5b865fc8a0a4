//! The mono reprojection problem: one camera's free intrinsics shared by all views, one
//! `camera_from_target` per view; residuals are projected minus detected pixels.

use nalgebra::{DVector, Isometry3, Vector2, Vector6};

use super::View;
use super::bundle::{BlockProblem, ViewAccumulator};
use super::invertibility::invertible_over_image;
use super::parameters::{PINHOLE_PARAMETERS, Parameterization};
use crate::camera::{CameraModel, TargetProjection, retract_pose};

/// A camera and one pose per view.
#[derive(Clone, Debug)]
pub(crate) struct MonoState {
    pub camera: CameraModel,
    pub camera_from_target: Vec<Isometry3<f64>>,
}

/// Views of a target by one camera, with the camera's free parameters.
pub(crate) struct MonoProblem<'a> {
    pub views: Vec<&'a View>,
    pub parameterization: Parameterization,
    /// Refuse steps to a lens that cannot be inverted out to the image corners.
    pub keep_invertible: bool,
}

/// The 2 x (4 + distortion) Jacobian of a projection with respect to the full
/// intrinsics, as rows.
pub(crate) fn full_intrinsic_jacobian(projection: &TargetProjection) -> [[f64; 12]; 2] {
    let p = &projection.projection;
    let mut full = [[0.0; 12]; 2];
    for (r, row) in full.iter_mut().enumerate() {
        for (c, entry) in row.iter_mut().take(PINHOLE_PARAMETERS).enumerate() {
            *entry = p.d_pixel_d_intrinsics[(r, c)];
        }
        for c in 0..p.d_pixel_d_distortion.ncols() {
            row[PINHOLE_PARAMETERS + c] = p.d_pixel_d_distortion[(r, c)];
        }
    }
    full
}

/// Squared reprojection errors of a view, one per corner; `None` for a corner behind
/// the camera.
pub(crate) fn squared_errors(
    camera: &CameraModel,
    camera_from_target: &Isometry3<f64>,
    view: &View,
) -> Vec<Option<f64>> {
    view.points_in_target
        .iter()
        .zip(&view.pixels)
        .map(|(point, pixel)| {
            camera
                .project(&(camera_from_target * point))
                .map(|projected| (projected - pixel).norm_squared())
        })
        .collect()
}

/// Sum of squared reprojection errors of a view; infinite when a corner is behind the
/// camera, so that no step is accepted into such a state.
pub(crate) fn view_sum_of_squares(
    camera: &CameraModel,
    camera_from_target: &Isometry3<f64>,
    view: &View,
) -> f64 {
    squared_errors(camera, camera_from_target, view)
        .into_iter()
        .map(|e| e.unwrap_or(f64::INFINITY))
        .sum()
}

impl BlockProblem for MonoProblem<'_> {
    type State = MonoState;

    fn shared_dim(&self) -> usize {
        self.parameterization.len()
    }

    fn view_count(&self) -> usize {
        self.views.len()
    }

    fn linearize_view(&self, state: &MonoState, view: usize, acc: &mut ViewAccumulator) {
        let pose = &state.camera_from_target[view];
        let v = self.views[view];
        let mut j_shared = vec![0.0; 2 * self.parameterization.len()];
        for (point, pixel) in v.points_in_target.iter().zip(&v.pixels) {
            let Some(projection) = state
                .camera
                .project_target_point_with_jacobians(pose, point)
            else {
                continue;
            };
            let residual: Vector2<f64> = projection.projection.pixel - pixel;
            self.parameterization
                .free_jacobian(&full_intrinsic_jacobian(&projection), &mut j_shared);
            acc.add(&residual, &j_shared, &projection.d_pixel_d_pose);
        }
    }

    fn view_cost(&self, state: &MonoState, view: usize) -> f64 {
        view_sum_of_squares(
            &state.camera,
            &state.camera_from_target[view],
            self.views[view],
        )
    }

    fn admissible(&self, state: &MonoState) -> bool {
        !self.keep_invertible || invertible_over_image(&state.camera)
    }

    fn retract(
        &self,
        state: &MonoState,
        d_shared: &DVector<f64>,
        d_views: &[Vector6<f64>],
    ) -> MonoState {
        MonoState {
            camera: self
                .parameterization
                .apply(&state.camera, d_shared.as_slice()),
            camera_from_target: state
                .camera_from_target
                .iter()
                .zip(d_views)
                .map(|(pose, d)| retract_pose(pose, d))
                .collect(),
        }
    }
}
