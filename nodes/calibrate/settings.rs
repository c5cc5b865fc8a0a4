//! The calibrate node's parameters: declared with their defaults, ranges and
//! descriptions, then read and checked into [`CalibrateSettings`]; a bad value stops the
//! node at start-up with a message naming the parameter.

use std::path::PathBuf;
use std::time::Duration;

use anyhow::{Context, anyhow};
use ros2_client::ParameterValue;
use stereocal_runtime::camera_info_url::{camera_info_path, ros_home};
use stereocal_runtime::node::{NodeBuilder, RosNode};
use stereocal_runtime::params::ParamSpec;
use stereocal_vision::calib::quality::DEFAULT_MAX_BLUR;
use stereocal_vision::camera::DistortionModel;

use super::session::SessionConfig;
use crate::image_transport::{self, Transport, transport};
use crate::target_params::{declare_target, target_from_params};

/// Everything the node was configured with, checked.
#[derive(Clone, Debug, PartialEq)]
pub struct CalibrateSettings {
    /// The session's target, cameras (in image order), model and frame checks.
    pub session: SessionConfig,
    /// Whether the node subscribes a stereo pair.
    pub stereo: bool,
    /// Largest stamp difference of a stereo pair (zero: equal stamps).
    pub slop: Duration,
    /// Frames kept per topic while waiting for pairing.
    pub queue_size: usize,
    /// How images arrive.
    pub image_transport: Transport,
    /// Calibrate without being asked once coverage is ready.
    pub auto_calibrate: bool,
    /// Folder of the session's samples.
    pub state_dir: PathBuf,
    /// Where each camera's camera_info is written by `~/commit`, in camera order.
    pub camera_info_paths: Vec<PathBuf>,
}

/// Largest accepted stereo pairing slop, seconds.
const MAX_SLOP: f64 = 10.0;
/// Largest accepted board speed limit, pixels per second.
const MAX_BOARD_SPEED: f64 = 100_000.0;
/// Largest accepted blur limit, pixels.
const MAX_BLUR: f64 = 1000.0;

/// Declares the node's parameters. All are read once at start-up, so all are
/// read-only while the node runs.
pub fn declare(builder: NodeBuilder) -> NodeBuilder {
    let string = |name: &str, default: &str, description: &str| {
        ParamSpec::new(name, ParameterValue::String(default.into()), description)
    };
    let double = |name: &str, default: f64, max: f64, description: &str| {
        ParamSpec::new(name, ParameterValue::Double(default), description).double_range(0.0..=max)
    };
    let boolean = |name: &str, default: bool, description: &str| {
        ParamSpec::new(name, ParameterValue::Boolean(default), description)
    };
    [
        string("model", "plumb_bob", "distortion model").one_of(&[
            "plumb_bob",
            "rational_polynomial",
            "equidistant",
        ]),
        boolean("stereo", false, "a stereo pair on left/image and right/image, not a camera on image"),
        string("camera_name", "camera", "mono: the camera's name"),
        string("left_camera_name", "left", "stereo: the left camera's name"),
        string("right_camera_name", "right", "stereo: the right camera's name"),
        double(
            "slop",
            0.0,
            MAX_SLOP,
            "stereo: largest stamp difference of a pair, seconds; 0 pairs equal stamps only",
        ),
        double(
            "max_board_speed",
            0.0,
            MAX_BOARD_SPEED,
            "frames whose board moves faster than this (pixels per second) are refused; 0 disables",
        ),
        double(
            "max_blur",
            DEFAULT_MAX_BLUR,
            MAX_BLUR,
            "frames whose board edges are wider than this (10-90 % edge width, pixels) are refused; 0 disables",
        ),
        boolean("auto_calibrate", false, "calibrate once coverage is ready, without ~/calibrate"),
        string(
            "state_dir",
            "",
            "folder where samples persist; empty: $ROS_HOME/stereocal/<node name>",
        ),
        string("camera_info_url", "", "mono: where ~/commit writes camera_info; empty: camera_info_manager's default"),
        string("left_camera_info_url", "", "stereo: the left camera's camera_info URL"),
        string("right_camera_info_url", "", "stereo: the right camera's camera_info URL"),
        ParamSpec::new(
            "queue_size",
            ParameterValue::Integer(5),
            "frames kept per topic while waiting for pairing",
        )
        .integer_range(1..=1000),
        image_transport::spec(),
    ]
    .into_iter()
    .fold(declare_target(builder), NodeBuilder::param)
}

fn param_error(name: &str, reason: impl std::fmt::Display) -> anyhow::Error {
    anyhow!("parameter {name}: {reason}")
}

/// Reads and checks the node's parameters; an error names the parameter.
pub fn settings(node: &RosNode) -> anyhow::Result<CalibrateSettings> {
    let target = target_from_params(node)?;
    let model_name = node.param_string("model")?;
    let model = DistortionModel::from_ros_name(&model_name).ok_or_else(|| {
        param_error(
            "model",
            format!("unknown model {model_name:?}: expected plumb_bob, rational_polynomial or equidistant"),
        )
    })?;
    let stereo = node.param_bool("stereo")?;
    let (names, urls) = if stereo {
        (
            vec!["left_camera_name", "right_camera_name"],
            vec!["left_camera_info_url", "right_camera_info_url"],
        )
    } else {
        (vec!["camera_name"], vec!["camera_info_url"])
    };
    let mut cameras = Vec::new();
    for name in &names {
        let value = node.param_string(name)?;
        if value.is_empty() || value.contains(['/', '\\']) {
            return Err(param_error(name, format!("{value:?} is not a camera name")));
        }
        cameras.push(value);
    }
    if stereo && cameras[0] == cameras[1] {
        return Err(param_error(
            "right_camera_name",
            "the two cameras of a pair need different names",
        ));
    }
    let home = ros_home();
    let mut camera_info_paths = Vec::new();
    for (url_param, camera) in urls.iter().zip(&cameras) {
        let url = node.param_string(url_param)?;
        camera_info_paths
            .push(camera_info_path(&url, camera, &home).map_err(|e| param_error(url_param, e))?);
    }
    let slop = node.param_f64("slop")?;
    let state_dir = node.param_string("state_dir")?;
    let state_dir = if state_dir.is_empty() {
        home.join("stereocal").join(&node.identity().name)
    } else {
        PathBuf::from(state_dir)
    };
    let mut session = SessionConfig::new(target, cameras, model);
    session.checks.max_board_speed = node.param_f64("max_board_speed")?;
    session.checks.max_blur = node.param_f64("max_blur")?;
    Ok(CalibrateSettings {
        session,
        stereo,
        slop: Duration::try_from_secs_f64(slop).map_err(|e| param_error("slop", e))?,
        queue_size: usize::try_from(node.param_i64("queue_size")?).context("queue_size")?,
        image_transport: transport(node)?,
        auto_calibrate: node.param_bool("auto_calibrate")?,
        state_dir,
        camera_info_paths,
    })
}
