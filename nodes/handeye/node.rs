//! The hand-eye node: a headless hand-eye calibration session that never loses a
//! sample. Runs as the `handeye_node` executable and as `stereocal node handeye`.
//!
//! The target's pose comes from `image` (or `image/compressed` with `image_transport:
//! compressed`) + `camera_info` (`target_source: image`, the
//! target found as pose_node finds it, with the corners kept for the joint refinement)
//! or from `target_pose` (`target_source: pose`, geometry_msgs/PoseStamped
//! `camera_from_target`, e.g. pose_node's). The robot's pose comes from `/tf` and
//! `/tf_static` (`robot_source: tf`, `base_frame` -> `tool_frame`) or from `robot_pose`
//! (`robot_source: topic`, PoseStamped `base_from_tool`); either way it is interpolated
//! at the target's stamp between poses within `max_time_difference` of it, never the
//! latest.
//!
//! A sample is taken when the robot has stood still for `stillness_time` before the
//! image (within `stillness_tolerance` and `stillness_angle_tolerance`) and is not where
//! a kept sample was: on `~/take_sample` (std_srvs/Trigger), or by itself with
//! `auto_sample` when the robot also turned by `auto_min_rotation` from every kept
//! sample. Each sample is written atomically to `state_dir` before the service answers;
//! a restarted node has them all, and names any file it could not read.
//!
//! Services: `~/take_sample`, `~/compute` (every method, then the joint refinement on
//! the corners; the result published on `/tf_static`, reliable and transient local, as
//! `tool_frame -> camera_frame` eye-in-hand or `base_frame -> camera_frame` eye-to-hand),
//! `~/save` (the result's YAML, as `stereocal handeye` writes it, to
//! `calibration_file`, and `report.html` beside it), `~/reset` (every sample moved
//! aside), all std_srvs/Trigger, and `~/remove_sample` (stereocal_msgs/srv/RemoveSample:
//! the sample at an index moved aside; std_srvs has no service that takes an index).
//! `~/status` (see [`super::status`]) carries the samples, the newest frame's verdict,
//! the motion's spread and warnings, and the result.

use anyhow::Context;
use stereocal_msgs::geometry_msgs::PoseStamped;
use stereocal_msgs::std_msgs;
use stereocal_runtime::node::NodeBuilder;
use stereocal_runtime::qos;
use stereocal_runtime::service::TriggerServices;
use stereocal_runtime::skeleton::{self, Inputs};
use stereocal_runtime::sync::SyncPolicy;

use super::settings::{RobotSource, TargetSource, declare, settings};
use super::store::SampleStore;
use super::worker::{Endpoints, HandEyeWorker, RobotInputs, Service};
use crate::image_transport::camera_inputs;

/// Robot poses (or `/tf` messages) kept until the worker takes them: a second of a
/// 1 kHz stream while the worker finds a target.
const ROBOT_DEPTH: usize = 1000;

/// Runs the hand-eye node until SIGINT/SIGTERM, with `args` the command line without
/// the program name (`--ros-args` remaps, parameters, params files).
pub fn run<I, S>(args: I) -> anyhow::Result<()>
where
    I: IntoIterator<Item = S>,
    S: Into<String>,
{
    let mut node = declare(NodeBuilder::new("handeye_node")).start(args)?;
    let settings = settings(&node)?;
    let store = SampleStore::open(&settings.state_dir)
        .with_context(|| format!("state_dir {}", settings.state_dir.display()))?;
    let depth = settings.queue_size;
    let inputs = match &settings.target {
        TargetSource::Image(_) => camera_inputs(&mut node, settings.image_transport, depth)?,
        TargetSource::Pose => Inputs::new(SyncPolicy::exact(depth)).stream::<PoseStamped>(
            &mut node,
            "target_pose",
            qos::reliable(depth),
        )?,
    };
    let robot = match settings.robot {
        RobotSource::Topic => RobotInputs::Topic(Box::new(
            node.subscribe("robot_pose", qos::reliable(ROBOT_DEPTH))?,
        )),
        RobotSource::Tf => RobotInputs::Tf {
            tf: Box::new(node.subscribe("/tf", qos::reliable(ROBOT_DEPTH))?),
            tf_static: Box::new(node.subscribe("/tf_static", qos::tf_static())?),
        },
    };
    let endpoints = Endpoints {
        robot,
        status: node.advertise::<std_msgs::String>(
            "~/status",
            qos::reliable(1).durability(ros2_client::qos::Durability::TransientLocal),
        )?,
        tf_static: node.advertise("/tf_static", qos::tf_static())?,
        services: TriggerServices::new(&mut node, &Service::ALL)?,
        remove_sample: node.create_server("~/remove_sample")?,
    };
    let worker = HandEyeWorker::new(settings, endpoints, store, node.clock());
    skeleton::spin(node, inputs, depth, worker, |_, set| set)?;
    Ok(())
}
