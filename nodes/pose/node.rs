//! The pose node: the pose of a calibration target in a camera's images, like aruco_ros
//! for a whole board, with covariance and without ever publishing a pose it cannot
//! stand behind. Runs as the `pose_node` executable and as `stereocal node pose`.
//!
//! Subscribes `image` (sensor_msgs/Image; `image/compressed` with `image_transport:
//! compressed`) and `camera_info` (sensor_msgs/CameraInfo), paired by equal stamps. For each image it detects the target (`pattern`, `size`,
//! `square`, `marker_size`, `dictionary`, as calibrate_node) and publishes, stamped with
//! the image's stamp and in the camera's frame (`camera_frame`, or the image's
//! `frame_id` when empty):
//! - `target_pose` (geometry_msgs/PoseStamped): `camera_from_target`;
//! - `target_pose_with_covariance` (geometry_msgs/PoseWithCovarianceStamped);
//! - `/tf`: `camera_frame -> target_frame`, unless `publish_tf` is false;
//! - `~/annotated_image` (rgb8), only while someone subscribes: the target's axes and
//!   the reprojected corners;
//! - `~/status` (see [`super::status`]).
//!
//! A frame without a trustworthy pose publishes nothing: the reason (target not
//! visible, uncalibrated or broken camera_info, error above `max_reprojection_error`,
//! an ambiguous planar pose...) is counted in `~/status` and logged, throttled.

use std::sync::Arc;
use std::time::{Duration, Instant};

use anyhow::{Context, anyhow};
use ros2_client::ParameterValue;
use stereocal_msgs::geometry_msgs::{PoseStamped, PoseWithCovarianceStamped, TransformStamped};
use stereocal_msgs::sensor_msgs::{CameraInfo, Image};
use stereocal_msgs::std_msgs::{self, Header};
use stereocal_msgs::tf2_msgs::TFMessage;
use stereocal_runtime::node::{NodeBuilder, RosNode};
use stereocal_runtime::params::ParamSpec;
use stereocal_runtime::publisher::TopicPublisher;
use stereocal_runtime::qos;
use stereocal_runtime::skeleton::{self, FrameStats, Worker};
use stereocal_runtime::sync::Synced;
use stereocal_runtime::throttle::Throttle;
use stereocal_vision::pnp::PoseOptions;

use super::annotate::annotate;
use super::record::FrameRecord;
use super::stage::{FramePose, PoseRejection, PoseStage};
use super::status::PoseStatus;
use crate::convert::{
    Encoding, image_from_msg, msg_from_image, pose_msg, pose_with_covariance_msg, transform_msg,
};
use crate::image_transport::{self, camera_inputs, transport};
use crate::target_params::{declare_target, target_from_params};

/// How often `~/status` is published while frames arrive.
const STATUS_PERIOD: Duration = Duration::from_secs(1);
/// Messages `/tf` keeps for late readers, as tf2's broadcaster.
const TF_DEPTH: usize = 100;

/// Where the node publishes.
struct Publishers {
    pose: TopicPublisher<PoseStamped>,
    pose_with_covariance: TopicPublisher<PoseWithCovarianceStamped>,
    tf: Option<TopicPublisher<TFMessage>>,
    annotated: TopicPublisher<Image>,
    status: TopicPublisher<std_msgs::String>,
}

/// Estimates each frame's pose with the [`PoseStage`] and publishes it.
struct PoseWorker {
    stage: PoseStage,
    publishers: Publishers,
    camera_frame: String,
    target_frame: String,
    status: PoseStatus,
    status_due: Instant,
    throttle: Throttle,
}

impl PoseWorker {
    fn publish_pose(&mut self, header: &Header, pose: &FramePose) -> anyhow::Result<()> {
        let camera_from_target = &pose.estimate.camera_from_target;
        self.publishers.pose.publish(PoseStamped {
            header: header.clone(),
            pose: pose_msg(camera_from_target),
        })?;
        self.publishers
            .pose_with_covariance
            .publish(PoseWithCovarianceStamped {
                header: header.clone(),
                pose: pose_with_covariance_msg(camera_from_target, &pose.estimate.covariance),
            })?;
        if let Some(tf) = &self.publishers.tf {
            tf.publish(TFMessage {
                transforms: vec![TransformStamped {
                    header: header.clone(),
                    child_frame_id: self.target_frame.clone(),
                    transform: transform_msg(camera_from_target),
                }],
            })?;
        }
        Ok(())
    }

    fn publish_annotated(&self, image: &Image, outcome: &Result<FramePose, PoseRejection>) {
        if !self.publishers.annotated.has_readers() {
            return;
        }
        let Ok((_, pixels)) = image_from_msg(image) else {
            return;
        };
        let drawn = annotate(&pixels, self.stage.target(), outcome);
        if let Ok(msg) = msg_from_image(&drawn, Encoding::Rgb8, image.header.clone()) {
            // A lost annotated image is not worth a warning: the pose went out.
            let _ = self.publishers.annotated.publish(msg);
        }
    }

    fn publish_status(&mut self, stats: &FrameStats) {
        self.status
            .set_counts(stats.received(), stats.dropped(), stats.unpaired());
        let text = self.status.to_json_string();
        if let Err(e) = self
            .publishers
            .status
            .publish(std_msgs::String { data: text })
        {
            self.throttle.warn(format!("~/status not published: {e}"));
        }
        self.status_due = Instant::now() + STATUS_PERIOD;
    }
}

impl Worker for PoseWorker {
    type Work = Synced<Arc<Image>, CameraInfo>;
    const NAME: &'static str = "pose";

    fn start(&mut self, stats: &FrameStats) {
        self.publish_status(stats);
    }

    fn handle(&mut self, work: Self::Work, _stats: &FrameStats) {
        let (Some(image), Some(info)) = (work.frames.first(), work.latched.first()) else {
            return;
        };
        let started = Instant::now();
        let (outcome, times) = self.stage.estimate(image, info);
        let header = Header {
            stamp: image.header.stamp,
            frame_id: if self.camera_frame.is_empty() {
                image.header.frame_id.clone()
            } else {
                self.camera_frame.clone()
            },
        };
        let kind = outcome.as_ref().err().map(PoseRejection::kind);
        match &outcome {
            Ok(pose) => {
                if let Err(e) = self.publish_pose(&header, pose) {
                    self.throttle.warn(format!("pose not published: {e}"));
                }
            }
            Err(reason) => self.throttle.log_as(
                log::Level::Warn,
                reason.kind().to_owned(),
                format!("no pose: {reason}"),
            ),
        }
        self.publish_annotated(image, &outcome);
        let record = FrameRecord::new(&image.header.stamp, &outcome);
        self.status.record(record, kind, times, started.elapsed());
    }

    fn poll(&mut self, stats: &FrameStats) {
        let changed = stats.received() != self.status.frames().received
            || stats.unpaired() != self.status.frames().unpaired;
        if changed && Instant::now() >= self.status_due {
            self.publish_status(stats);
        }
    }

    fn summary(&self) -> String {
        let frames = self.status.frames();
        format!(
            "{} poses published, {} frames rejected",
            frames.poses, frames.rejected
        )
    }
}

/// Declares the node's parameters. All are read once at start-up.
fn declare(builder: NodeBuilder) -> NodeBuilder {
    let string = |name: &str, default: &str, description: &str| {
        ParamSpec::new(name, ParameterValue::String(default.into()), description)
    };
    let boolean = |name: &str, default: bool, description: &str| {
        ParamSpec::new(name, ParameterValue::Boolean(default), description)
    };
    let defaults = PoseOptions::default();
    [
        string("target_frame", "target", "TF frame of the target (child of the camera frame)"),
        string("camera_frame", "", "frame of the published poses; empty: the image's frame_id"),
        ParamSpec::new(
            "max_reprojection_error",
            ParameterValue::Double(defaults.max_rms_px),
            "poses whose RMS reprojection error is above this (pixels) are not published",
        )
        .double_range(0.0..=1000.0),
        ParamSpec::new(
            "min_ambiguity_significance",
            ParameterValue::Double(defaults.min_ambiguity_significance),
            "a planar target's pose is refused when a distinct second pose explains the corners within this many standard deviations of pixel noise as well",
        )
        .double_range(0.0..=100.0),
        ParamSpec::new(
            "pixel_noise",
            ParameterValue::Double(defaults.pixel_noise_px),
            "least standard deviation of corner noise assumed (pixels), for the covariance and the ambiguity test",
        )
        .double_range(0.0..=100.0),
        boolean("image_is_rectified", false, "images are rectified: use camera_info's P, not K and D"),
        boolean("publish_tf", true, "publish camera_frame -> target_frame on /tf"),
        ParamSpec::new(
            "queue_size",
            ParameterValue::Integer(5),
            "frames kept per topic while waiting for pairing, and waiting for the pose",
        )
        .integer_range(1..=1000),
        image_transport::spec(),
    ]
    .into_iter()
    .fold(declare_target(builder), NodeBuilder::param)
}

/// The pose options and stage the parameters ask for.
fn stage_from_params(node: &RosNode) -> anyhow::Result<PoseStage> {
    let target = target_from_params(node)?;
    let options = PoseOptions {
        max_rms_px: node.param_f64("max_reprojection_error")?,
        min_ambiguity_significance: node.param_f64("min_ambiguity_significance")?,
        pixel_noise_px: node.param_f64("pixel_noise")?,
        ..PoseOptions::default()
    };
    PoseStage::new(target, options, node.param_bool("image_is_rectified")?)
        .map_err(|e| anyhow!("parameter pattern: {e}"))
}

/// Runs the pose node until SIGINT/SIGTERM, with `args` the command line without the
/// program name (`--ros-args` remaps, parameters, params files).
pub fn run<I, S>(args: I) -> anyhow::Result<()>
where
    I: IntoIterator<Item = S>,
    S: Into<String>,
{
    let mut node = declare(NodeBuilder::new("pose_node")).start(args)?;
    let stage = stage_from_params(&node)?;
    let queue_size = usize::try_from(node.param_i64("queue_size")?).context("queue_size")?;
    let transport = transport(&node)?;
    let inputs = camera_inputs(&mut node, transport, queue_size)?;
    let publishers = Publishers {
        pose: node.advertise("target_pose", qos::reliable(queue_size))?,
        pose_with_covariance: node
            .advertise("target_pose_with_covariance", qos::reliable(queue_size))?,
        tf: if node.param_bool("publish_tf")? {
            Some(node.advertise("/tf", qos::reliable(TF_DEPTH))?)
        } else {
            None
        },
        annotated: node.advertise("~/annotated_image", qos::reliable(2))?,
        status: node.advertise(
            "~/status",
            qos::reliable(1).durability(ros2_client::qos::Durability::TransientLocal),
        )?,
    };
    let worker = PoseWorker {
        stage,
        publishers,
        camera_frame: node.param_string("camera_frame")?,
        target_frame: node.param_string("target_frame")?,
        status: PoseStatus::default(),
        status_due: Instant::now(),
        throttle: Throttle::new(node.clock()),
    };
    skeleton::spin(node, inputs, queue_size, worker, |_, frame| frame)?;
    Ok(())
}
