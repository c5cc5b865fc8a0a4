//! The one result schema of a calibration: what `stereocal calibrate --json` prints,
//! what `calibrate_node` publishes under `calibration` in `~/status`, what the
//! command's human summary, the node's `~/calibrate` answer and the report's summary
//! show. A field added here appears in all of them.
//!
//! JSON: `{"cameras": {NAME: {"rms", "k" (row-major), "d", "distortion_model",
//! "width", "height", "std_dev" ({"fx", "fy", "cx", "cy", "d"} or null when unknown),
//! "views_used", "views_rejected": [{"stamp": {"sec", "nanosec"}, "reason"}]}},
//! "stereo" (pairs only): {"rms", "right_from_left": {"rotation" (row-major),
//! "translation" (metres)}, "epipolar_rms", "pairs_used", "pairs_rejected"},
//! "warnings": [...]}`.

use nalgebra::{Isometry3, Matrix3};
use serde::ser::{SerializeMap, SerializeStruct};
use serde::{Serialize, Serializer};
use stereocal_vision::calib::IntrinsicStdDev;
use stereocal_vision::camera::DistortionModel;

use super::advice;
use super::stage::{CalibrationOutcome, CameraResult, RejectedFrame, StereoResult};

/// A calibration's results: per camera, for a pair, and the warnings about them.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct CalibrationResult {
    /// The cameras, in calibration order (left then right for a pair), keyed by name
    /// in JSON.
    #[serde(serialize_with = "cameras_by_name")]
    pub cameras: Vec<CameraSummary>,
    /// The pair, for a stereo calibration (absent from JSON otherwise).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub stereo: Option<StereoSummary>,
    /// What makes the result less trustworthy, and what to do about it.
    pub warnings: Vec<String>,
}

/// One calibrated camera.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct CameraSummary {
    /// The camera's name (its key in JSON).
    #[serde(skip)]
    pub name: String,
    /// Reprojection RMS over the views used, pixels.
    pub rms: f64,
    /// The camera matrix, row-major.
    pub k: [f64; 9],
    /// Distortion coefficients, camera_info order.
    pub d: Vec<f64>,
    /// Distortion model, as camera_info names it.
    #[serde(serialize_with = "model_name")]
    pub distortion_model: DistortionModel,
    /// Image width, pixels.
    pub width: u32,
    /// Image height, pixels.
    pub height: u32,
    /// Standard deviations of the intrinsics; `None` when the normal matrix is singular.
    #[serde(serialize_with = "std_dev")]
    pub std_dev: Option<IntrinsicStdDev>,
    /// Views the calibration used.
    pub views_used: usize,
    /// Views left out, with the reason.
    pub views_rejected: Vec<RejectedFrame>,
}

/// The calibrated stereo pair.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct StereoSummary {
    /// Reprojection RMS of the stereo solve, pixels.
    pub rms: f64,
    /// The right camera's pose in the left camera's frame.
    #[serde(serialize_with = "transform")]
    pub right_from_left: Isometry3<f64>,
    /// RMS distance of the corners from their epipolar lines, pixels.
    pub epipolar_rms: f64,
    /// Pairs the stereo solve used.
    pub pairs_used: usize,
    /// Pairs left out, with the reason.
    pub pairs_rejected: Vec<RejectedFrame>,
}

impl CalibrationResult {
    /// The results of `outcome`, with its warnings.
    pub fn from_outcome(outcome: &CalibrationOutcome) -> Self {
        Self {
            cameras: outcome
                .cameras
                .iter()
                .map(CameraSummary::from_result)
                .collect(),
            stereo: outcome.stereo.as_ref().map(StereoSummary::from_result),
            warnings: advice::warnings(outcome),
        }
    }

    /// The results as a JSON value.
    pub fn to_json(&self) -> serde_json::Value {
        serde_json::to_value(self).unwrap_or(serde_json::Value::Null)
    }

    /// The RMS figures in one line, as `~/calibrate` answers them:
    /// `left: RMS 0.0213 px over 21 views; ...; stereo: RMS ..., epipolar RMS ... over N pairs`.
    pub fn rms_line(&self) -> String {
        let mut parts: Vec<String> = self
            .cameras
            .iter()
            .map(|c| {
                format!(
                    "{}: RMS {:.4} px over {} views",
                    c.name, c.rms, c.views_used
                )
            })
            .collect();
        if let Some(stereo) = &self.stereo {
            parts.push(format!(
                "stereo: RMS {:.4} px, epipolar RMS {:.4} px over {} pairs",
                stereo.rms, stereo.epipolar_rms, stereo.pairs_used
            ));
        }
        parts.join("; ")
    }
}

impl CameraSummary {
    fn from_result(camera: &CameraResult) -> Self {
        let model = &camera.calibration.camera;
        Self {
            name: camera.name.clone(),
            rms: camera.calibration.rms,
            k: row_major(&model.intrinsics.matrix()),
            d: model.distortion.coeffs().to_vec(),
            distortion_model: model.distortion.model(),
            width: model.width,
            height: model.height,
            std_dev: camera.calibration.std_dev.clone(),
            views_used: camera.used.len(),
            views_rejected: camera.rejected.clone(),
        }
    }

    /// Names of the distortion coefficients, in the order of `d`.
    pub fn coefficient_names(&self) -> &'static [&'static str] {
        match self.distortion_model {
            DistortionModel::PlumbBob => &["k1", "k2", "p1", "p2", "k3"],
            DistortionModel::RationalPolynomial => {
                &["k1", "k2", "p1", "p2", "k3", "k4", "k5", "k6"]
            }
            DistortionModel::Equidistant => &["k1", "k2", "k3", "k4"],
        }
    }
}

impl StereoSummary {
    fn from_result(stereo: &StereoResult) -> Self {
        let calibration = &stereo.calibration;
        Self {
            rms: calibration.rms,
            right_from_left: calibration.right_from_left,
            epipolar_rms: calibration.epipolar_rms,
            pairs_used: stereo.used.len(),
            pairs_rejected: stereo.rejected.clone(),
        }
    }
}

/// A 3x3 matrix as its 9 entries, row by row.
pub fn row_major(m: &Matrix3<f64>) -> [f64; 9] {
    let mut out = [0.0; 9];
    for (k, value) in out.iter_mut().enumerate() {
        *value = m[(k / 3, k % 3)];
    }
    out
}

fn cameras_by_name<S: Serializer>(cameras: &[CameraSummary], s: S) -> Result<S::Ok, S::Error> {
    let mut map = s.serialize_map(Some(cameras.len()))?;
    for camera in cameras {
        map.serialize_entry(&camera.name, camera)?;
    }
    map.end()
}

fn model_name<S: Serializer>(model: &DistortionModel, s: S) -> Result<S::Ok, S::Error> {
    s.serialize_str(model.ros_name())
}

fn std_dev<S: Serializer>(std: &Option<IntrinsicStdDev>, s: S) -> Result<S::Ok, S::Error> {
    match std {
        None => s.serialize_none(),
        Some(std) => {
            let mut object = s.serialize_struct("IntrinsicStdDev", 5)?;
            object.serialize_field("fx", &std.fx)?;
            object.serialize_field("fy", &std.fy)?;
            object.serialize_field("cx", &std.cx)?;
            object.serialize_field("cy", &std.cy)?;
            object.serialize_field("d", &std.distortion)?;
            object.end()
        }
    }
}

fn transform<S: Serializer>(pose: &Isometry3<f64>, s: S) -> Result<S::Ok, S::Error> {
    let mut object = s.serialize_struct("Transform", 2)?;
    object.serialize_field(
        "rotation",
        &row_major(&pose.rotation.to_rotation_matrix().into_inner()),
    )?;
    object.serialize_field("translation", pose.translation.vector.as_slice())?;
    object.end()
}
