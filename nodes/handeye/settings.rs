//! The hand-eye node's parameters: declared with their defaults, ranges and
//! descriptions, then read and checked into [`HandEyeSettings`]; a bad value stops the
//! node at start-up with a message naming the parameter.

use std::path::PathBuf;

use anyhow::anyhow;
use ros2_client::ParameterValue;
use stereocal_runtime::camera_info_url::ros_home;
use stereocal_runtime::node::{NodeBuilder, RosNode};
use stereocal_runtime::params::ParamSpec;
use stereocal_vision::handeye::{RefineOptions, Setup};
use stereocal_vision::pnp::PoseOptions;

use super::robot::HISTORY_S;
use super::session::{FIRST_PIXEL_NOISE_PX, Weights};
use crate::image_transport::{self, Transport, transport};
use crate::pose::stage::PoseStage;
use crate::target_params::{declare_target, target_from_params};

/// Where the target's poses come from.
pub enum TargetSource {
    /// Found in `image` + `camera_info` by the node, with the pose stage.
    Image(PoseStage),
    /// Measured already, on `target_pose` (geometry_msgs/PoseStamped), e.g. by pose_node.
    Pose,
}

/// Where the robot's poses come from.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum RobotSource {
    /// `robot_pose` (geometry_msgs/PoseStamped, `base_from_tool`).
    Topic,
    /// `/tf` and `/tf_static`, from the base frame to the tool frame.
    Tf,
}

/// When the robot counts as still.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Stillness {
    /// How long it must have been still before the target's stamp, seconds.
    pub time_s: f64,
    /// Largest translation over that time, metres.
    pub translation_m: f64,
    /// Largest rotation over that time, radians.
    pub rotation_rad: f64,
}

/// Everything the node was configured with, checked.
pub struct HandEyeSettings {
    /// Eye-in-hand or eye-to-hand.
    pub setup: Setup,
    /// Where target poses come from.
    pub target: TargetSource,
    /// Images are rectified: seen through camera_info's `P`, not `K` and `D`.
    pub image_is_rectified: bool,
    /// How images arrive.
    pub image_transport: Transport,
    /// Where robot poses come from.
    pub robot: RobotSource,
    /// The robot's base frame; empty: the robot pose topic's frame_id.
    pub base_frame: String,
    /// The robot's tool frame.
    pub tool_frame: String,
    /// The camera's frame; empty: the target messages' frame_id.
    pub camera_frame: String,
    /// Largest gap either side of a target's stamp to the robot poses it is
    /// interpolated between, seconds.
    pub max_time_difference: f64,
    /// When the robot counts as still.
    pub stillness: Stillness,
    /// Take samples without being asked.
    pub auto_sample: bool,
    /// In automatic mode, the least rotation of the robot from every kept sample,
    /// radians.
    pub auto_min_rotation: f64,
    /// Folder of the session's samples.
    pub state_dir: PathBuf,
    /// Where `~/save` writes the result (`report.html` goes beside it).
    pub calibration_file: PathBuf,
    /// The joint refinement's weights.
    pub weights: Weights,
    /// Frames kept per topic while waiting for pairing.
    pub queue_size: usize,
}

/// Declares the node's parameters. All are read once at start-up, so all are
/// read-only while the node runs.
pub fn declare(builder: NodeBuilder) -> NodeBuilder {
    let string = |name: &str, default: &str, description: &str| {
        ParamSpec::new(name, ParameterValue::String(default.into()), description)
    };
    let double = |name: &str, default: f64, max: f64, description: &str| {
        ParamSpec::new(name, ParameterValue::Double(default), description).double_range(0.0..=max)
    };
    let pose_defaults = PoseOptions::default();
    [
        string("setup", "eye_in_hand", "eye_in_hand: the camera rides on the tool; eye_to_hand: the camera stands still and the target rides on the tool")
            .one_of(&["eye_in_hand", "eye_to_hand"]),
        string("target_source", "image", "image: find the target in image + camera_info; pose: read target_pose (PoseStamped camera_from_target, e.g. from pose_node)")
            .one_of(&["image", "pose"]),
        string("robot_source", "tf", "tf: look base_frame -> tool_frame up in /tf and /tf_static; topic: read robot_pose (PoseStamped base_from_tool)")
            .one_of(&["tf", "topic"]),
        string("base_frame", "base_link", "the robot's base frame; with robot_source topic, empty takes robot_pose's frame_id"),
        string("tool_frame", "tool0", "the robot's tool (end-effector) frame"),
        string("camera_frame", "", "the camera's frame, child of the published transform; empty: the target messages' frame_id"),
        double("max_time_difference", 0.02, 1.0, "a target pose is paired only with robot poses this close on both sides of its stamp, seconds"),
        double("stillness_time", 0.5, HISTORY_S / 2.0, "a sample is taken only when the robot has been still this long before the image, seconds"),
        double("stillness_tolerance", 0.001, 1.0, "largest robot translation that counts as still, metres"),
        double("stillness_angle_tolerance", 0.002, 1.0, "largest robot rotation that counts as still, radians"),
        ParamSpec::new("auto_sample", ParameterValue::Boolean(false), "take a sample, without ~/take_sample, whenever the robot is still, the target is seen and the pose adds rotation"),
        double("auto_min_rotation", 0.17, std::f64::consts::PI, "automatic mode: least rotation of the robot from every kept sample, radians"),
        double("max_reprojection_error", pose_defaults.max_rms_px, 1000.0, "target_source image: poses whose RMS reprojection error is above this (pixels) are not sampled"),
        ParamSpec::new("image_is_rectified", ParameterValue::Boolean(false), "target_source image: images are rectified: use camera_info's P, not K and D"),
        double("robot_rotation_noise", 0.05_f64.to_radians(), 1.0, "standard deviation of the robot's reported rotation, radians, for the joint refinement"),
        double("robot_translation_noise", 0.0003, 1.0, "standard deviation of the robot's reported position, metres, for the joint refinement"),
        string("state_dir", "", "folder where samples persist; empty: $ROS_HOME/stereocal/<node name>"),
        string("calibration_file", "", "where ~/save writes the result (report.html goes beside it); empty: <state_dir>/handeye.yaml"),
        ParamSpec::new("queue_size", ParameterValue::Integer(5), "frames kept per topic while waiting for pairing").integer_range(1..=1000),
        image_transport::spec(),
    ]
    .into_iter()
    .fold(declare_target(builder), NodeBuilder::param)
}

fn param_error(name: &str, reason: impl std::fmt::Display) -> anyhow::Error {
    anyhow!("parameter {name}: {reason}")
}

/// Reads and checks the node's parameters; an error names the parameter.
pub fn settings(node: &RosNode) -> anyhow::Result<HandEyeSettings> {
    let setup = match node.param_string("setup")?.as_str() {
        "eye_to_hand" => Setup::EyeToHand,
        _ => Setup::EyeInHand,
    };
    let target = match node.param_string("target_source")?.as_str() {
        "pose" => TargetSource::Pose,
        _ => {
            let options = PoseOptions {
                max_rms_px: node.param_f64("max_reprojection_error")?,
                ..PoseOptions::default()
            };
            TargetSource::Image(
                PoseStage::new(
                    target_from_params(node)?,
                    options,
                    node.param_bool("image_is_rectified")?,
                )
                .map_err(|e| param_error("pattern", e))?,
            )
        }
    };
    let robot = match node.param_string("robot_source")?.as_str() {
        "topic" => RobotSource::Topic,
        _ => RobotSource::Tf,
    };
    let base_frame = node.param_string("base_frame")?;
    let tool_frame = node.param_string("tool_frame")?;
    if robot == RobotSource::Tf {
        for (name, frame) in [("base_frame", &base_frame), ("tool_frame", &tool_frame)] {
            if frame.is_empty() {
                return Err(param_error(name, "required with robot_source tf"));
            }
        }
        if base_frame == tool_frame {
            return Err(param_error("tool_frame", "must differ from base_frame"));
        }
    }
    let positive = |name: &str| -> anyhow::Result<f64> {
        let value = node.param_f64(name)?;
        if value > 0.0 {
            Ok(value)
        } else {
            Err(param_error(name, format!("{value}: expected more than 0")))
        }
    };
    let state_dir = node.param_string("state_dir")?;
    let state_dir = if state_dir.is_empty() {
        ros_home().join("stereocal").join(&node.identity().name)
    } else {
        PathBuf::from(state_dir)
    };
    let calibration_file = node.param_string("calibration_file")?;
    let calibration_file = if calibration_file.is_empty() {
        state_dir.join("handeye.yaml")
    } else {
        PathBuf::from(calibration_file)
    };
    Ok(HandEyeSettings {
        setup,
        target,
        image_is_rectified: node.param_bool("image_is_rectified")?,
        image_transport: transport(node)?,
        robot,
        base_frame,
        tool_frame,
        camera_frame: node.param_string("camera_frame")?,
        max_time_difference: node.param_f64("max_time_difference")?,
        stillness: Stillness {
            time_s: node.param_f64("stillness_time")?,
            translation_m: node.param_f64("stillness_tolerance")?,
            rotation_rad: node.param_f64("stillness_angle_tolerance")?,
        },
        auto_sample: node.param_bool("auto_sample")?,
        auto_min_rotation: node.param_f64("auto_min_rotation")?,
        state_dir,
        calibration_file,
        weights: Weights {
            refine: RefineOptions {
                pixel_noise_px: FIRST_PIXEL_NOISE_PX,
                robot_rotation_noise_rad: positive("robot_rotation_noise")?,
                robot_translation_noise_m: positive("robot_translation_noise")?,
            },
            measure_pixel_noise: true,
        },
        queue_size: usize::try_from(node.param_i64("queue_size")?)
            .map_err(|e| param_error("queue_size", e))?,
    })
}
