//! Whether a calibrated pinhole lens can still be inverted over its whole image.
//!
//! Within the views' corners a lens model is pinned by the data; beyond them a model
//! with many coefficients (rational_polynomial's numerator and denominator can grow
//! together) can fold back on itself while fitting the corners just as well, and a
//! lens that folds inside the image cannot be undistorted or rectified to its border.
//! The rational_polynomial solvers therefore refuse steps into such lenses, as a
//! constraint.

use nalgebra::{Point2, Vector2};

use crate::camera::{CameraModel, DistortionModel};

/// How far beyond each image corner's ray, as a factor on its undistorted radius, the
/// lens must still be monotonic: a lens that folds or has a pole just past the corner
/// maps the border pixels through its steepest part.
const MARGIN: f64 = 1.25;
/// Samples of the radial profile between the optical axis and the margin.
const SAMPLES: usize = 128;

/// Whether every pixel of the image has a ray and the lens stays monotonic a margin
/// beyond: each image corner's distortion can be inverted, and along the corner's
/// direction the distorted radius grows strictly from the optical axis out to
/// [`MARGIN`] times the corner's undistorted radius (no fold, no pole of
/// rational_polynomial's denominator). Equidistant lenses are not held to it: a
/// fisheye's image corners may lie outside its image circle.
pub(crate) fn invertible_over_image(camera: &CameraModel) -> bool {
    if camera.distortion.model() == DistortionModel::Equidistant {
        return true;
    }
    // The outer edges of the border pixels (pixel centres at integer coordinates).
    let right = f64::from(camera.width) - 0.5;
    let bottom = f64::from(camera.height) - 0.5;
    [(-0.5, -0.5), (right, -0.5), (-0.5, bottom), (right, bottom)]
        .iter()
        .all(|&(x, y)| {
            camera
                .unproject(&Point2::new(x, y))
                .is_some_and(|ray| monotonic_to(camera, &(ray.xy() * MARGIN)))
        })
}

/// Whether the distorted point's extent along `end`'s direction grows strictly from
/// the optical axis to the undistorted normalized point `end`.
fn monotonic_to(camera: &CameraModel, end: &Vector2<f64>) -> bool {
    let direction = end.normalize();
    let mut previous = 0.0;
    (1..=SAMPLES).all(|i| {
        let point = end * (i as f64 / SAMPLES as f64);
        let extent = camera.distortion.distort(&point).dot(&direction);
        let growing = extent.is_finite() && extent > previous;
        previous = extent;
        growing
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::camera::{Distortion, Intrinsics};

    fn camera(distortion: Distortion) -> CameraModel {
        CameraModel {
            width: 1024,
            height: 768,
            intrinsics: Intrinsics {
                fx: 827.4,
                fy: 827.7,
                cx: 500.0,
                cy: 376.9,
            },
            distortion,
        }
    }

    #[test]
    fn a_lens_that_folds_inside_the_image_is_not_invertible() {
        // A rational fit of a plumb_bob lens (k1 = -0.19) that matches it over the
        // views' corners but whose profile peaks before the image corners.
        let folded = camera(Distortion::RationalPolynomial {
            coeffs: [
                -1.543, -0.146, -0.0007, 0.00076, -0.159, -1.350, -0.468, -0.165,
            ],
        });
        assert!(!invertible_over_image(&folded));
        let truth = camera(Distortion::PlumbBob {
            coeffs: [-0.1934, 0.0623, -0.0007, 0.00075, -0.0059],
        });
        assert!(invertible_over_image(&truth));
        assert!(invertible_over_image(&camera(Distortion::none())));
    }

    #[test]
    fn a_pole_just_beyond_the_image_corner_is_refused() {
        // Numerator and denominator nearly share a root (s = 0.52 and 0.5, r = 0.707):
        // the profile rises monotonically to the pole, so every border pixel inverts,
        // onto the pole's steep flank (the upper-left corner's ray at r = 0.65).
        let pole = camera(Distortion::RationalPolynomial {
            coeffs: [-1.0 / 0.52, 0.0, 0.0, 0.0, 0.0, -2.0, 0.0, 0.0],
        });
        assert!(pole.unproject(&Point2::new(-0.5, -0.5)).is_some());
        assert!(!invertible_over_image(&pole));
    }

    #[test]
    fn the_synthetic_lenses_are_invertible() {
        // The rational lens of the ground-truth tests, and a barrel lens of plumb_bob's shape.
        for coeffs in [
            [0.6, -0.1, 0.0007, 0.0004, 0.01, 0.9, 0.05, 0.005],
            [-0.25, 0.05, 0.001, 0.0008, 0.0, 0.0, 0.0, 0.0],
        ] {
            let lens = camera(Distortion::RationalPolynomial { coeffs });
            assert!(invertible_over_image(&lens), "{coeffs:?}");
        }
    }
}
