//! Point undistortion: the inverse of the distortion models over the whole image, even
//! for strong distortion, and `None` exactly where no preimage exists.

use nalgebra::{Point2, Point3, Vector2};
use stereocal_vision::camera::{CameraModel, Distortion, Intrinsics};

fn camera(width: u32, height: u32, f: f64, distortion: Distortion) -> CameraModel {
    CameraModel {
        width,
        height,
        intrinsics: Intrinsics {
            fx: f,
            fy: f * 1.01,
            cx: (width as f64 - 1.0) / 2.0 + 7.3,
            cy: (height as f64 - 1.0) / 2.0 - 4.1,
        },
        distortion,
    }
}

/// A wide lens with strong barrel distortion: the image corners lie just inside the
/// fold of the radial profile, where OpenCV's default 5 fixed-point iterations are
/// still 1.8 px off.
fn strong_plumb_bob() -> CameraModel {
    camera(
        1280,
        960,
        640.0,
        Distortion::PlumbBob {
            coeffs: [-0.30, 0.10, 0.0012, -0.0008, -0.012],
        },
    )
}

/// Coefficients typical of a wide lens calibrated with rational_polynomial.
fn strong_rational() -> CameraModel {
    camera(
        1280,
        800,
        480.0,
        Distortion::RationalPolynomial {
            coeffs: [1.6, 0.35, 0.0007, -0.0004, 0.008, 2.0, 0.9, 0.06],
        },
    )
}

/// A fisheye lens whose image circle crops the sensor: the sensor corners are more
/// than 90 degrees off axis.
fn strong_fisheye() -> CameraModel {
    camera(
        1280,
        1024,
        330.0,
        Distortion::Equidistant {
            coeffs: [0.04, -0.012, 0.003, -0.0004],
        },
    )
}

/// Every pixel of a grid over the image unprojects, and the ray projects back onto the
/// pixel; returns how many pixels had no preimage.
fn round_trip_image(camera: &CameraModel, step: usize) -> usize {
    let mut missing = 0;
    for v in (0..camera.height as usize).step_by(step) {
        for u in (0..camera.width as usize).step_by(step) {
            let pixel = Point2::new(u as f64, v as f64);
            let Some(ray) = camera.unproject(&pixel) else {
                missing += 1;
                continue;
            };
            assert_eq!(ray.z, 1.0);
            let back = camera
                .project(&Point3::from(ray))
                .expect("ray in front of the camera");
            let error = (back - pixel).norm();
            assert!(
                error < 1e-9,
                "{:?}: pixel {pixel:?} reprojects {error} px away",
                camera.distortion.model()
            );
        }
    }
    missing
}

#[test]
fn plumb_bob_round_trips_over_the_whole_image() {
    assert_eq!(round_trip_image(&strong_plumb_bob(), 4), 0);
}

#[test]
fn rational_polynomial_round_trips_over_the_whole_image() {
    assert_eq!(round_trip_image(&strong_rational(), 4), 0);
}

#[test]
fn equidistant_round_trips_inside_the_hemisphere_and_rejects_beyond() {
    let camera = strong_fisheye();
    let Distortion::Equidistant { coeffs } = camera.distortion else {
        unreachable!()
    };
    let half_pi = std::f64::consts::FRAC_PI_2;
    let t2 = half_pi * half_pi;
    let theta_d_max =
        half_pi * (1.0 + t2 * (coeffs[0] + t2 * (coeffs[1] + t2 * (coeffs[2] + t2 * coeffs[3]))));
    let mut expected_missing = 0;
    for v in (0..camera.height as usize).step_by(4) {
        for u in (0..camera.width as usize).step_by(4) {
            let d = camera
                .intrinsics
                .normalized_from_pixel(&Point2::new(u as f64, v as f64));
            if d.norm() >= theta_d_max {
                expected_missing += 1;
            }
        }
    }
    assert!(expected_missing > 0, "the test lens must crop the sensor");
    assert_eq!(round_trip_image(&camera, 4), expected_missing);
}

#[test]
fn undistortion_returns_the_preimage_on_the_first_branch() {
    // f(r) = r (1 - 0.4 r^2) rises to 0.6086 at r = 0.9129 and then folds back.
    let distortion = Distortion::PlumbBob {
        coeffs: [-0.4, 0.0, 0.0, 0.0, 0.0],
    };
    let fold = (1.0f64 / 1.2).sqrt();
    let peak = fold * (1.0 - 0.4 * fold * fold);
    for &rd in &[0.1, 0.3, 0.5, 0.6, peak * (1.0 - 1e-9)] {
        let d = Vector2::new(rd * 0.6, rd * 0.8);
        let p = distortion
            .undistort(&d)
            .expect("inside the invertible range");
        assert!(p.norm() < fold, "preimage {} beyond the fold", p.norm());
        assert!((distortion.distort(&p) - d).norm() < 1e-12);
    }
    for &rd in &[peak * (1.0 + 1e-9), 0.7, 2.0] {
        assert_eq!(distortion.undistort(&Vector2::new(0.0, rd)), None);
    }
}

#[test]
fn tangential_terms_are_inverted_exactly() {
    let distortion = Distortion::PlumbBob {
        coeffs: [-0.2, 0.05, 0.02, -0.015, 0.0],
    };
    for i in 0..40 {
        let angle = i as f64 * 0.157;
        let p = Vector2::new(angle.cos(), angle.sin()) * (0.02 * i as f64);
        let d = distortion.distort(&p);
        let back = distortion.undistort(&d).expect("invertible");
        assert!((back - p).norm() < 1e-12, "{p:?} came back as {back:?}");
    }
}

#[test]
fn the_centre_and_non_finite_input() {
    for distortion in [
        strong_plumb_bob().distortion,
        strong_rational().distortion,
        strong_fisheye().distortion,
    ] {
        assert_eq!(
            distortion.undistort(&Vector2::zeros()),
            Some(Vector2::zeros())
        );
        assert_eq!(distortion.undistort(&Vector2::new(f64::NAN, 0.0)), None);
        assert_eq!(
            distortion.undistort(&Vector2::new(0.0, f64::INFINITY)),
            None
        );
    }
}

#[test]
fn undistort_pixel_is_the_distortion_free_image_of_the_same_ray() {
    let camera = strong_plumb_bob();
    let point = Point3::new(0.4, -0.3, 1.1);
    let distorted = camera.project(&point).expect("in front");
    let ideal = camera
        .undistort_pixel(&distorted)
        .expect("inside the image");
    let expected = camera
        .intrinsics
        .pixel_from_normalized(&Vector2::new(point.x / point.z, point.y / point.z));
    assert!((ideal - expected).norm() < 1e-9);
}

/// The undistorter of many points finds the preimage `undistort` finds point by point,
/// over whole images of strong lenses and beyond a folding profile's end: the same
/// points refused, and each found point the same one to rounding. Near a fold the map's
/// Jacobian is nearly singular and two exact solutions of the same equation may differ
/// by a few 1e-12 while both distort back onto the point.
#[test]
fn the_undistorter_agrees_with_undistort() {
    let folding = Distortion::PlumbBob {
        coeffs: [-0.4, 0.0, 0.0, 0.0, 0.0],
    };
    for distortion in [
        strong_plumb_bob().distortion,
        strong_rational().distortion,
        strong_fisheye().distortion,
        folding,
    ] {
        let undistorter = distortion.undistorter();
        let mut compared = 0;
        for i in -60..=60 {
            for j in -60..=60 {
                let p = Vector2::new(f64::from(i) * 0.025, f64::from(j) * 0.02);
                let one = distortion.undistort(&p);
                let many = undistorter.undistort(&p);
                match (one, many) {
                    (Some(a), Some(b)) => {
                        assert!(
                            (a - b).norm() <= 1e-10 * a.norm().max(1.0),
                            "{distortion:?} at {p}: {a} against {b}"
                        );
                        let back = distortion.distort(&b);
                        assert!(
                            (back - p).norm() <= 1e-12 * p.norm().max(1.0),
                            "{distortion:?} at {p}: {b} distorts to {back}"
                        );
                        compared += 1;
                    }
                    (None, None) => {}
                    _ => panic!("{distortion:?} at {p}: {one:?} against {many:?}"),
                }
            }
        }
        assert!(
            compared > 1000,
            "{distortion:?}: {compared} points compared"
        );
    }
}
