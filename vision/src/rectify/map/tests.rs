use super::*;
use crate::camera::Intrinsics;
use nalgebra::{Point3, Rotation3, Vector3};

fn camera(distortion: Distortion) -> CameraModel {
    CameraModel {
        width: 320,
        height: 240,
        intrinsics: Intrinsics {
            fx: 260.0,
            fy: 255.0,
            cx: 161.3,
            cy: 118.7,
        },
        distortion,
    }
}

fn models() -> Vec<CameraModel> {
    vec![
        camera(Distortion::PlumbBob {
            coeffs: [-0.28, 0.09, 0.001, -0.0007, -0.012],
        }),
        camera(Distortion::RationalPolynomial {
            coeffs: [0.45, -0.1, 0.0008, 0.0005, 0.02, 0.7, -0.05, 0.01],
        }),
        camera(Distortion::Equidistant {
            coeffs: [-0.012, 0.004, -0.002, 0.0004],
        }),
    ]
}

/// Every stored position is within half a fixed-point step of the camera's own
/// projection of the ray that the output pixel back-projects to.
#[test]
fn map_matches_projection_of_back_projected_rays() {
    let rectified_from_original = *Rotation3::from_euler_angles(0.02, -0.03, 0.01).matrix();
    let projection = Matrix3x4::new(
        230.0, 0.0, 150.0, -23.0, //
        0.0, 230.0, 125.0, 0.0, //
        0.0, 0.0, 1.0, 0.0,
    );
    let pixel_from_rectified = projection.fixed_view::<3, 3>(0, 0).into_owned();
    let rectified_from_pixel = pixel_from_rectified.try_inverse().unwrap();
    for model in models() {
        let map = RectifyMap::new(&model, &rectified_from_original, &projection, 300, 250).unwrap();
        let mut checked = 0;
        for y in 0..map.height() {
            for x in 0..map.width() {
                let ray_rectified = rectified_from_pixel * Vector3::new(x as f64, y as f64, 1.0);
                let ray = rectified_from_original.transpose() * ray_rectified;
                let expected = model.project(&Point3::from(ray)).unwrap();
                let (u, v) = map.source_position(x, y).unwrap();
                let tolerance = 0.5 / 32.0 + 1e-9;
                assert!(
                    (u - expected.x).abs() <= tolerance && (v - expected.y).abs() <= tolerance,
                    "{:?} at ({x}, {y}): map ({u}, {v}) vs projection {expected}",
                    model.distortion.model()
                );
                checked += 1;
            }
        }
        assert_eq!(checked, 300 * 250);
    }
}

#[test]
fn fixed_point_layout_matches_opencv() {
    let map = RectifyMap::from_fn(2, 1, |x, _| {
        if x == 0 {
            (3.5, -0.25)
        } else {
            (-1.0 / 64.0, 7.0)
        }
    })
    .unwrap();
    assert_eq!(map.xy(), &[[3, -1], [0, 7]]);
    // 3.5 -> 112 = 3*32 + 16; -0.25 -> -8 = -1*32 + 24. -1/64 rounds to even 0.
    assert_eq!(map.fraction(), &[(24 << 5) | 16, 0]);
    assert_eq!(map.source_position(0, 0), Some((3.5, -0.25)));
}

#[test]
fn fixed_point_rounds_half_to_even() {
    let half_step = 1.0 / 64.0;
    assert_eq!(fixed_point(half_step), 0);
    assert_eq!(fixed_point(3.0 * half_step), 2);
    assert_eq!(fixed_point(-half_step), 0);
    assert_eq!(fixed_point(-3.0 * half_step), -2);
    assert_eq!(fixed_point(100.3), 3210);
    assert_eq!(fixed_point(-1e300), i32::from(i16::MIN) * 32);
    assert_eq!(fixed_point(1e300), i32::from(i16::MAX) * 32 + 31);
}

#[test]
fn far_and_non_finite_positions_are_clamped() {
    let map = RectifyMap::from_fn(3, 1, |x, _| match x {
        0 => (1e9, -1e9),
        1 => (f64::NAN, f64::INFINITY),
        _ => (f64::NEG_INFINITY, 2.0),
    })
    .unwrap();
    assert_eq!(map.xy()[0], [i16::MAX, i16::MIN]);
    assert_eq!(map.xy()[1], [i16::MIN, i16::MAX]);
    assert_eq!(map.xy()[2], [i16::MIN, 2]);
}

#[test]
fn fisheye_rays_behind_the_camera_go_to_the_border() {
    let model = models().pop().unwrap();
    // A rotation of 180 degrees about y puts the whole view behind the camera.
    let behind = *Rotation3::from_euler_angles(0.0, std::f64::consts::PI, 0.0).matrix();
    let projection = model.intrinsics.matrix().insert_column(3, 0.0);
    let map = RectifyMap::new(&model, &behind, &projection, 8, 8).unwrap();
    assert!(
        map.xy()
            .iter()
            .all(|p| p[0] == i16::MAX || p[0] == i16::MIN)
    );
}

#[test]
fn bad_parameters_are_rejected() {
    let model = models().remove(0);
    let projection = model.intrinsics.matrix().insert_column(3, 0.0);
    let identity = Matrix3::identity();
    assert_eq!(
        RectifyMap::new(&model, &identity, &projection, 0, 10),
        Err(MapError::InvalidSize {
            width: 0,
            height: 10
        })
    );
    assert_eq!(
        RectifyMap::new(&model, &Matrix3::zeros(), &projection, 10, 10),
        Err(MapError::SingularProjection)
    );
    let mut nan_r = identity;
    nan_r[(1, 2)] = f64::NAN;
    assert_eq!(
        RectifyMap::new(&model, &nan_r, &projection, 10, 10),
        Err(MapError::NonFinite("rectification matrix R"))
    );
    let mut uncalibrated = model.clone();
    uncalibrated.intrinsics.fx = 0.0;
    assert!(matches!(
        RectifyMap::new(&uncalibrated, &identity, &projection, 10, 10),
        Err(MapError::InvalidFocalLength { .. })
    ));
}

#[test]
fn undistort_without_distortion_is_the_identity() {
    let model = camera(Distortion::none());
    let map = RectifyMap::undistort(&model).unwrap();
    assert_eq!((map.width(), map.height()), (320, 240));
    for (i, (xy, f)) in map.xy().iter().zip(map.fraction()).enumerate() {
        assert_eq!(*xy, [(i % 320) as i16, (i / 320) as i16]);
        assert_eq!(*f, 0);
    }
}

/// The source position of output pixel `(x, y)`, computed pixel by pixel in the most
/// direct way with OpenCV's `initUndistortRectifyMap` (pinhole) and
/// `fisheye::initUndistortRectifyMap` (equidistant) formulas: the reference the map must
/// equal bit for bit.
fn reference_position(
    distortion: &Distortion,
    k: Intrinsics,
    original_from_pixel: &Matrix3<f64>,
    x: usize,
    y: usize,
) -> (f64, f64) {
    let ir = original_from_pixel;
    let (x, y) = (x as f64, y as f64);
    let rx = ir[(0, 0)] * x + ir[(0, 1)] * y + ir[(0, 2)];
    let ry = ir[(1, 0)] * x + ir[(1, 1)] * y + ir[(1, 2)];
    let rw = ir[(2, 0)] * x + ir[(2, 1)] * y + ir[(2, 2)];
    let [k1, k2, p1, p2, k3, k4, k5, k6] = match *distortion {
        Distortion::PlumbBob {
            coeffs: [k1, k2, p1, p2, k3],
        } => [k1, k2, p1, p2, k3, 0.0, 0.0, 0.0],
        Distortion::RationalPolynomial { coeffs } => coeffs,
        Distortion::Equidistant { coeffs } => {
            if rw <= 0.0 {
                let u = if rx > 0.0 {
                    f64::NEG_INFINITY
                } else {
                    f64::INFINITY
                };
                let v = if ry > 0.0 {
                    f64::NEG_INFINITY
                } else {
                    f64::INFINITY
                };
                return (u, v);
            }
            let (x, y) = (rx / rw, ry / rw);
            let r = (x * x + y * y).sqrt();
            let theta = r.atan();
            let t2 = theta * theta;
            let t4 = t2 * t2;
            let (t6, t8) = (t4 * t2, t4 * t4);
            let theta_d =
                theta * (1.0 + coeffs[0] * t2 + coeffs[1] * t4 + coeffs[2] * t6 + coeffs[3] * t8);
            let scale = if r == 0.0 { 1.0 } else { theta_d / r };
            return (k.fx * x * scale + k.cx, k.fy * y * scale + k.cy);
        }
    };
    let w = 1.0 / rw;
    let (x, y) = (rx * w, ry * w);
    let r2 = x * x + y * y;
    let kr = (1.0 + ((k3 * r2 + k2) * r2 + k1) * r2) / (1.0 + ((k6 * r2 + k5) * r2 + k4) * r2);
    let xd = x * kr + p1 * (2.0 * x * y) + p2 * (r2 + 2.0 * x * x);
    let yd = y * kr + p1 * (r2 + 2.0 * y * y) + p2 * (2.0 * x * y);
    (k.fx * xd + k.cx, k.fy * yd + k.cy)
}

/// `v` in 1/32 pixel, rounded half to even, clamped to the `i16` range of the integer
/// part; NaN goes to the lowest value.
fn reference_fixed(v: f64) -> i32 {
    let lo = f64::from(i16::MIN) * 32.0;
    let hi = f64::from(i16::MAX) * 32.0 + 31.0;
    let steps = v * 32.0;
    if steps.is_nan() {
        lo as i32
    } else {
        steps.clamp(lo, hi).round_ties_even() as i32
    }
}

/// A camera_info of [`regression_cases`].
struct RegressionCase {
    name: String,
    model: CameraModel,
    r: Matrix3<f64>,
    p: Matrix3x4<f64>,
    /// Whether some positions must fall beyond the `i16` range.
    far: bool,
}

/// Camera_infos that exercise every path of the map: the three models, rational
/// denominators that are and are not one, distortion strong enough to throw positions
/// beyond the `i16` range, and each with R = I and P = [K | 0] (undistortion only), a
/// stereo R and P, a rotation that puts part of the view behind the camera, a
/// projection whose rays reach `w = 0` exactly on one column and one whose rays are so
/// long that `r^2` overflows.
fn regression_cases() -> Vec<RegressionCase> {
    let distortions = [
        Distortion::PlumbBob {
            coeffs: [-0.28, 0.09, 0.001, -0.0007, -0.012],
        },
        Distortion::PlumbBob {
            coeffs: [2.0, 5.0, 0.02, 0.03, 2000.0],
        },
        Distortion::RationalPolynomial {
            coeffs: [0.45, -0.1, 0.0008, 0.0005, 0.02, 0.7, -0.05, 0.01],
        },
        Distortion::RationalPolynomial {
            coeffs: [-0.31, 0.12, -0.0011, 0.0009, -0.02, 0.0, 0.0, 0.0],
        },
        Distortion::Equidistant {
            coeffs: [-0.012, 0.004, -0.002, 0.0004],
        },
    ];
    let stereo_r = *Rotation3::from_euler_angles(0.02, -0.03, 0.01).matrix();
    let stereo_p = Matrix3x4::new(
        230.0, 0.0, 150.0, -23.0, //
        0.0, 230.0, 125.0, 0.0, //
        0.0, 0.0, 1.0, 0.0,
    );
    let sideways = *Rotation3::from_euler_angles(0.3, 1.3, -0.2).matrix();
    // Rows of (P R)^-1: the third is (0.1, 0, -0.1), so w = 0 on column 1.
    let w_zero_p = Matrix3x4::new(
        1.0, 0.0, 10.0, 0.0, //
        0.0, 1.0, 0.0, 0.0, //
        1.0, 0.0, 0.0, 0.0,
    );
    let w_zero_ir = w_zero_p.fixed_view::<3, 3>(0, 0).try_inverse().unwrap();
    assert_eq!(w_zero_ir[(2, 0)] + w_zero_ir[(2, 2)], 0.0);
    // Rows of (P R)^-1: (0, 0, 1), (0, 1, 0), (1e-170, 0, 0): rays so long that r^2
    // overflows to infinity while x stays finite.
    let overflow_p = Matrix3x4::new(
        0.0, 0.0, 1e170, 0.0, //
        0.0, 1.0, 0.0, 0.0, //
        1.0, 0.0, 0.0, 0.0,
    );
    let mut cases = Vec::new();
    // A focal length so large that scaling it to 1/32 pixel overflows; the ray of pixel
    // (5, 3) is the optical axis, which it sends to the principal point (100, 50).
    let mut huge = camera(distortions[0].clone());
    huge.intrinsics = Intrinsics {
        fx: 1e307,
        fy: 1e307,
        cx: 100.0,
        cy: 50.0,
    };
    let axis_at_5_3 = Matrix3x4::new(
        1.0, 0.0, 5.0, 0.0, //
        0.0, 1.0, 3.0, 0.0, //
        0.0, 0.0, 1.0, 0.0,
    );
    cases.push(RegressionCase {
        name: "huge focal length".into(),
        model: huge,
        r: Matrix3::identity(),
        p: axis_at_5_3,
        far: true,
    });
    for (i, distortion) in distortions.into_iter().enumerate() {
        let strong = i == 1;
        let model = camera(distortion);
        let name = format!("{:?}", model.distortion);
        let undistort_p = model.intrinsics.matrix().insert_column(3, 0.0);
        for (geometry, r, p, far) in [
            ("undistort", Matrix3::identity(), undistort_p, strong),
            ("stereo", stereo_r, stereo_p, strong),
            ("sideways", sideways, stereo_p, true),
            ("w = 0", Matrix3::identity(), w_zero_p, true),
            ("r^2 overflows", Matrix3::identity(), overflow_p, true),
        ] {
            cases.push(RegressionCase {
                name: format!("{name}, {geometry}"),
                model: model.clone(),
                r,
                p,
                far,
            });
        }
    }
    cases
}

/// The map equals the per-pixel reference bit for bit, on widths that leave every
/// remainder of a vector of pixels, on one thread and on several.
#[test]
fn map_equals_the_per_pixel_reference_bit_for_bit() {
    let one_thread = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap();
    for RegressionCase {
        name,
        model,
        r,
        p,
        far: expect_far,
    } in regression_cases()
    {
        let original_from_pixel = (p.fixed_view::<3, 3>(0, 0) * r).try_inverse().unwrap();
        for (width, height) in [(333, 211), (8, 3), (1, 2), (17, 5)] {
            let map = RectifyMap::new(&model, &r, &p, width, height).unwrap();
            if name == "huge focal length" && width > 5 && height > 3 {
                assert_eq!(map.source_position(5, 3), Some((100.0, 50.0)));
            }
            let single = one_thread.install(|| RectifyMap::new(&model, &r, &p, width, height));
            assert_eq!(single.as_ref(), Ok(&map), "{name}: one thread differs");
            let mut far = 0;
            for y in 0..height {
                for x in 0..width {
                    let (u, v) = reference_position(
                        &model.distortion,
                        model.intrinsics,
                        &original_from_pixel,
                        x,
                        y,
                    );
                    let (iu, iv) = (reference_fixed(u), reference_fixed(v));
                    let i = y * width + x;
                    assert_eq!(
                        (map.xy()[i], map.fraction()[i]),
                        (
                            [(iu >> 5) as i16, (iv >> 5) as i16],
                            (((iv & 31) << 5) | (iu & 31)) as u16
                        ),
                        "{name}, {width}x{height}, pixel ({x}, {y}): source ({u}, {v})"
                    );
                    far += usize::from(!(u.abs() < 32767.0 && v.abs() < 32767.0));
                }
            }
            if (width, height) == (333, 211) {
                assert_eq!(
                    far > 0,
                    expect_far,
                    "{name}: {far} positions beyond the i16 range"
                );
            }
        }
    }
}
