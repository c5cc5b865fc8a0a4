//! `sensor_msgs/CameraInfo` <-> camera model, rectification and projection.

use nalgebra::{Matrix3, Matrix3x4};
use stereocal_msgs::sensor_msgs::{CameraInfo, RegionOfInterest};
use stereocal_msgs::std_msgs::Header;
use stereocal_vision::camera::{CameraModel, Distortion, DistortionModel, Intrinsics};
use thiserror::Error;

/// What a calibrated `sensor_msgs/CameraInfo` says about a camera.
#[derive(Clone, Debug, PartialEq)]
pub struct CalibratedCamera {
    /// Image size, intrinsics `K` and distortion `D` of the raw camera.
    pub model: CameraModel,
    /// `R`: rotates points from the camera frame into the rectified camera frame.
    pub rectified_from_camera: Matrix3<f64>,
    /// `P`: projects points in the rectified frame (of the left camera, for the right
    /// camera of a stereo pair) to rectified pixels.
    pub projection: Matrix3x4<f64>,
}

/// Why a `sensor_msgs/CameraInfo` does not describe a usable calibrated camera.
#[derive(Debug, Error, PartialEq)]
pub enum CameraInfoError {
    /// `K[0]` (fx) is zero: the driver publishes no calibration.
    #[error("camera_info is uncalibrated: K[0] (fx) is 0")]
    Uncalibrated,
    /// `distortion_model` names no model we know.
    #[error(
        "camera_info distortion_model {0:?} is unknown: expected plumb_bob, rational_polynomial or equidistant"
    )]
    UnknownDistortionModel(String),
    /// `D` has more coefficients than its model.
    #[error("camera_info D has {len} coefficients: {model} takes at most {max}")]
    DistortionLength {
        /// The model name.
        model: &'static str,
        /// `D.len()`.
        len: usize,
        /// Coefficients of the model.
        max: usize,
    },
    /// A number is NaN or infinite.
    #[error("camera_info {field}[{index}] is {value}: expected a finite number")]
    NonFinite {
        /// `D`, `K`, `R` or `P`.
        field: &'static str,
        /// Index in the field's row-major data.
        index: usize,
        /// The value found.
        value: f64,
    },
    /// `width` or `height` is zero.
    #[error("camera_info size {width}x{height}: width and height must be at least 1")]
    ZeroSize {
        /// `width`.
        width: u32,
        /// `height`.
        height: u32,
    },
    /// A matrix cannot be what the field means.
    #[error("camera_info {field} is degenerate: {reason}")]
    Degenerate {
        /// `K`, `R` or `P`.
        field: &'static str,
        /// What is wrong with it.
        reason: &'static str,
    },
    /// Binning other than 1 (0 means 1).
    #[error("camera_info binning {x}x{y} is not supported: expected 0 or 1")]
    Binning {
        /// `binning_x`.
        x: u32,
        /// `binning_y`.
        y: u32,
    },
    /// A region of interest other than the whole image (all zeros means the whole image).
    #[error(
        "camera_info roi at ({x},{y}) of {width}x{height} is not supported: expected all zeros or the full {full_width}x{full_height} image"
    )]
    Roi {
        /// `roi.x_offset`.
        x: u32,
        /// `roi.y_offset`.
        y: u32,
        /// `roi.width`.
        width: u32,
        /// `roi.height`.
        height: u32,
        /// camera_info `width`.
        full_width: u32,
        /// camera_info `height`.
        full_height: u32,
    },
}

/// Reads a calibrated camera from a `sensor_msgs/CameraInfo`: `K`, `D`, `R` and `P`
/// checked to be finite and meaningful, the distortion model known, binning 1 and the
/// region of interest the full image. `D` may be shorter than its model (missing
/// coefficients are zero), never longer.
pub fn calibrated_camera_from_info(info: &CameraInfo) -> Result<CalibratedCamera, CameraInfoError> {
    if info.k[0] == 0.0 {
        return Err(CameraInfoError::Uncalibrated);
    }
    let model = DistortionModel::from_ros_name(&info.distortion_model)
        .ok_or_else(|| CameraInfoError::UnknownDistortionModel(info.distortion_model.clone()))?;
    for (field, values) in [
        ("D", info.d.as_slice()),
        ("K", info.k.as_slice()),
        ("R", info.r.as_slice()),
        ("P", info.p.as_slice()),
    ] {
        if let Some((index, &value)) = values.iter().enumerate().find(|(_, v)| !v.is_finite()) {
            return Err(CameraInfoError::NonFinite {
                field,
                index,
                value,
            });
        }
    }
    let distortion =
        Distortion::from_coeffs(model, &info.d).ok_or(CameraInfoError::DistortionLength {
            model: model.ros_name(),
            len: info.d.len(),
            max: coefficient_count(model),
        })?;
    if info.width == 0 || info.height == 0 {
        return Err(CameraInfoError::ZeroSize {
            width: info.width,
            height: info.height,
        });
    }
    if info.binning_x > 1 || info.binning_y > 1 {
        return Err(CameraInfoError::Binning {
            x: info.binning_x,
            y: info.binning_y,
        });
    }
    check_roi(&info.roi, info.width, info.height)?;
    let k = Matrix3::from_row_slice(&info.k);
    if k[(1, 1)] == 0.0 {
        return Err(CameraInfoError::Degenerate {
            field: "K",
            reason: "K[4] (fy) is 0",
        });
    }
    let rectified_from_camera = Matrix3::from_row_slice(&info.r);
    if rectified_from_camera.determinant().abs() < 1e-6 {
        return Err(CameraInfoError::Degenerate {
            field: "R",
            reason: "not a rotation (determinant 0); a raw camera carries the identity",
        });
    }
    let projection = Matrix3x4::from_row_slice(&info.p);
    if projection[(0, 0)] == 0.0 || projection[(1, 1)] == 0.0 {
        return Err(CameraInfoError::Degenerate {
            field: "P",
            reason: "P[0] (fx') or P[5] (fy') is 0",
        });
    }
    Ok(CalibratedCamera {
        model: CameraModel {
            width: info.width,
            height: info.height,
            intrinsics: Intrinsics::from_matrix(&k),
            distortion,
        },
        rectified_from_camera,
        projection,
    })
}

/// Coefficients of a distortion model in camera_info `D`.
fn coefficient_count(model: DistortionModel) -> usize {
    match model {
        DistortionModel::PlumbBob => 5,
        DistortionModel::RationalPolynomial => 8,
        DistortionModel::Equidistant => 4,
    }
}

/// Accepts an unset region of interest or one covering the whole image.
fn check_roi(roi: &RegionOfInterest, width: u32, height: u32) -> Result<(), CameraInfoError> {
    let unset = roi.x_offset == 0 && roi.y_offset == 0 && roi.width == 0 && roi.height == 0;
    let full = roi.x_offset == 0 && roi.y_offset == 0 && roi.width == width && roi.height == height;
    if unset || full {
        return Ok(());
    }
    Err(CameraInfoError::Roi {
        x: roi.x_offset,
        y: roi.y_offset,
        width: roi.width,
        height: roi.height,
        full_width: width,
        full_height: height,
    })
}

/// The `sensor_msgs/CameraInfo` of a calibrated camera with its rectification and
/// projection (binning 1, no region of interest).
pub fn info_from_calibrated(camera: &CalibratedCamera, header: Header) -> CameraInfo {
    let model = &camera.model;
    let mut k = [0.0; 9];
    k.copy_from_slice(model.intrinsics.matrix().transpose().as_slice());
    let mut r = [0.0; 9];
    r.copy_from_slice(camera.rectified_from_camera.transpose().as_slice());
    let mut p = [0.0; 12];
    p.copy_from_slice(camera.projection.transpose().as_slice());
    CameraInfo {
        header,
        height: model.height,
        width: model.width,
        distortion_model: model.distortion.model().ros_name().to_owned(),
        d: model.distortion.coeffs().to_vec(),
        k,
        r,
        p,
        binning_x: 0,
        binning_y: 0,
        roi: RegionOfInterest::default(),
    }
}

/// The `sensor_msgs/CameraInfo` of a raw (unrectified, monocular) camera: `R = I`,
/// `P = [K | 0]`.
pub fn info_from_raw_camera(model: &CameraModel, header: Header) -> CameraInfo {
    let k = model.intrinsics.matrix();
    let mut projection = Matrix3x4::zeros();
    projection.fixed_view_mut::<3, 3>(0, 0).copy_from(&k);
    info_from_calibrated(
        &CalibratedCamera {
            model: model.clone(),
            rectified_from_camera: Matrix3::identity(),
            projection,
        },
        header,
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Rotation3;

    fn stereo_right() -> CalibratedCamera {
        CalibratedCamera {
            model: CameraModel {
                width: 640,
                height: 480,
                intrinsics: Intrinsics {
                    fx: 500.0,
                    fy: 502.0,
                    cx: 319.5,
                    cy: 241.0,
                },
                distortion: Distortion::RationalPolynomial {
                    coeffs: [-0.2, 0.05, 0.001, -0.002, 0.01, 0.1, 0.02, 0.003],
                },
            },
            rectified_from_camera: *Rotation3::from_euler_angles(0.01, -0.02, 0.03).matrix(),
            projection: Matrix3x4::new(
                480.0, 0.0, 310.0, -48.0, 0.0, 480.0, 240.0, 0.0, 0.0, 0.0, 1.0, 0.0,
            ),
        }
    }

    #[test]
    fn calibrated_camera_round_trips_in_row_major_order() {
        let camera = stereo_right();
        let info = info_from_calibrated(&camera, Header::default());
        assert_eq!(
            info.k,
            [500.0, 0.0, 319.5, 0.0, 502.0, 241.0, 0.0, 0.0, 1.0]
        );
        assert_eq!(info.p[3], -48.0);
        assert_eq!(info.r[1], camera.rectified_from_camera[(0, 1)]);
        assert_eq!(info.distortion_model, "rational_polynomial");
        assert_eq!(calibrated_camera_from_info(&info).unwrap(), camera);
    }

    #[test]
    fn raw_camera_has_identity_rectification_and_p_equal_to_k() {
        let model = stereo_right().model;
        let info = info_from_raw_camera(&model, Header::default());
        assert_eq!(info.r, [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0]);
        assert_eq!(
            info.p,
            [
                500.0, 0.0, 319.5, 0.0, 0.0, 502.0, 241.0, 0.0, 0.0, 0.0, 1.0, 0.0
            ]
        );
        let back = calibrated_camera_from_info(&info).unwrap();
        assert_eq!(back.model, model);
        assert_eq!(back.rectified_from_camera, Matrix3::identity());
    }

    #[test]
    fn short_d_is_padded_with_zeros() {
        let mut info = info_from_calibrated(&stereo_right(), Header::default());
        info.distortion_model = "plumb_bob".to_owned();
        info.d = vec![-0.1, 0.02, 0.0, 0.0];
        let camera = calibrated_camera_from_info(&info).unwrap();
        assert_eq!(
            camera.model.distortion,
            Distortion::PlumbBob {
                coeffs: [-0.1, 0.02, 0.0, 0.0, 0.0]
            }
        );
        info.d.clear();
        assert_eq!(
            calibrated_camera_from_info(&info).unwrap().model.distortion,
            Distortion::none()
        );
    }

    #[test]
    fn each_bad_field_has_its_own_error() {
        let good = info_from_calibrated(&stereo_right(), Header::default());
        let check = |edit: &dyn Fn(&mut CameraInfo), expected: CameraInfoError| {
            let mut info = good.clone();
            edit(&mut info);
            assert_eq!(calibrated_camera_from_info(&info).unwrap_err(), expected);
        };
        check(&|i| i.k = [0.0; 9], CameraInfoError::Uncalibrated);
        check(
            &|i| i.distortion_model = "kannala".to_owned(),
            CameraInfoError::UnknownDistortionModel("kannala".to_owned()),
        );
        check(
            &|i| {
                i.distortion_model = "equidistant".to_owned();
                i.d = vec![0.1; 5];
            },
            CameraInfoError::DistortionLength {
                model: "equidistant",
                len: 5,
                max: 4,
            },
        );
        check(
            &|i| i.p[11] = f64::INFINITY,
            CameraInfoError::NonFinite {
                field: "P",
                index: 11,
                value: f64::INFINITY,
            },
        );
        let mut nan_d = good.clone();
        nan_d.d[2] = f64::NAN;
        assert!(matches!(
            calibrated_camera_from_info(&nan_d),
            Err(CameraInfoError::NonFinite { field: "D", index: 2, value }) if value.is_nan()
        ));
        check(
            &|i| i.height = 0,
            CameraInfoError::ZeroSize {
                width: 640,
                height: 0,
            },
        );
        check(
            &|i| i.k[4] = 0.0,
            CameraInfoError::Degenerate {
                field: "K",
                reason: "K[4] (fy) is 0",
            },
        );
        check(
            &|i| i.r = [0.0; 9],
            CameraInfoError::Degenerate {
                field: "R",
                reason: "not a rotation (determinant 0); a raw camera carries the identity",
            },
        );
        check(
            &|i| i.p = [0.0; 12],
            CameraInfoError::Degenerate {
                field: "P",
                reason: "P[0] (fx') or P[5] (fy') is 0",
            },
        );
        check(
            &|i| i.binning_x = 2,
            CameraInfoError::Binning { x: 2, y: 0 },
        );
        check(
            &|i| {
                i.roi.x_offset = 10;
                i.roi.width = 100;
                i.roi.height = 100;
            },
            CameraInfoError::Roi {
                x: 10,
                y: 0,
                width: 100,
                height: 100,
                full_width: 640,
                full_height: 480,
            },
        );
    }

    #[test]
    fn full_frame_roi_is_accepted() {
        let mut info = info_from_calibrated(&stereo_right(), Header::default());
        info.roi.width = 640;
        info.roi.height = 480;
        info.binning_x = 1;
        info.binning_y = 1;
        assert!(calibrated_camera_from_info(&info).is_ok());
    }

    #[test]
    fn nan_error_message_names_field_and_index() {
        let mut info = info_from_calibrated(&stereo_right(), Header::default());
        info.k[2] = f64::NAN;
        let message = calibrated_camera_from_info(&info).unwrap_err().to_string();
        assert!(message.contains("K[2] is NaN"), "{message}");
    }
}
