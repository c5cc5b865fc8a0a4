//! The rectify node: rectifies a camera's images like image_proc's RectifyNode. Runs as
//! the `rectify_node` executable and as `stereocal node rectify`.
//!
//! Subscribes `image` (sensor_msgs/Image) and `camera_info` (sensor_msgs/CameraInfo),
//! pairs them by stamp, and publishes `image_rect` in the input's encoding. Parameters:
//! `interpolation` (0 nearest, 1 linear, 2 cubic; may change while running),
//! `queue_size` (frames kept on each topic and between receiving and rectifying; older
//! frames are dropped and counted when rectifying falls behind) and `image_transport`
//! (`compressed` reads `image/compressed`, see [`crate::image_transport`]).

use std::sync::Arc;

use anyhow::Context;
use ros2_client::ParameterValue;
use stereocal_msgs::sensor_msgs::{CameraInfo, Image};
use stereocal_runtime::node::NodeBuilder;
use stereocal_runtime::params::ParamSpec;
use stereocal_runtime::publisher::TopicPublisher;
use stereocal_runtime::qos;
use stereocal_runtime::skeleton::{self, FrameStats, Worker};
use stereocal_runtime::sync::Synced;

use crate::image_transport::{self, camera_inputs, transport};
use stereocal_runtime::throttle::Throttle;
use stereocal_vision::rectify::{Interpolation, RemapOptions};

use super::stage::{Rectified, Rectifier};

/// A frame to rectify, with the interpolation in force when it was received.
struct Work {
    frame: Synced<Arc<Image>, CameraInfo>,
    interpolation: Interpolation,
}

/// Rectifies each frame with the [`Rectifier`] of its interpolation and publishes it.
struct RectifyWorker {
    publisher: TopicPublisher<Image>,
    rectifier: Option<Rectifier>,
    published: u64,
    throttle: Throttle,
}

impl Worker for RectifyWorker {
    type Work = Work;
    const NAME: &'static str = "rectify";

    fn handle(&mut self, work: Work, _stats: &FrameStats) {
        let (Some(image), Some(info)) = (work.frame.frames.first(), work.frame.latched.first())
        else {
            return;
        };
        let rectifier = match &mut self.rectifier {
            Some(r) if r.options().interpolation == work.interpolation => r,
            slot => slot.insert(Rectifier::new(RemapOptions {
                interpolation: work.interpolation,
                ..RemapOptions::default()
            })),
        };
        match rectifier.rectify(image, info) {
            Ok(Rectified::Image(rect)) => match self.publisher.publish(rect) {
                Ok(()) => self.published += 1,
                Err(e) => self.throttle.warn(format!("image_rect not published: {e}")),
            },
            Ok(Rectified::Uncalibrated { warning }) => {
                if let Some(warning) = warning {
                    log::warn!("{warning}");
                }
            }
            Err(e) => self.throttle.warn(format!(
                "frame {:?} at {}.{:09} not rectified: {e}",
                image.header.frame_id, image.header.stamp.sec, image.header.stamp.nanosec
            )),
        }
    }

    fn summary(&self) -> String {
        format!(
            "{} published ({} over DDS)",
            self.published,
            self.publisher.sent_over_dds()
        )
    }
}

/// Runs the rectify node until SIGINT/SIGTERM, with `args` the command line without the
/// program name (`--ros-args` remaps, parameters, params files).
pub fn run<I, S>(args: I) -> anyhow::Result<()>
where
    I: IntoIterator<Item = S>,
    S: Into<String>,
{
    let mut node = NodeBuilder::new("rectify_node")
        .param(
            ParamSpec::new(
                "interpolation",
                ParameterValue::Integer(1),
                "interpolation of rectified pixels: 0 nearest, 1 linear, 2 cubic",
            )
            .integer_range(0..=2)
            .settable_while_running(),
        )
        .param(
            ParamSpec::new(
                "queue_size",
                ParameterValue::Integer(5),
                "frames kept per topic and waiting to be rectified; older ones are dropped",
            )
            .integer_range(1..=1000),
        )
        .param(image_transport::spec())
        .start(args)?;
    let queue_size = usize::try_from(node.param_i64("queue_size")?).context("queue_size")?;
    let transport = transport(&node)?;
    let inputs = camera_inputs(&mut node, transport, queue_size)?;
    let worker = RectifyWorker {
        publisher: node.advertise::<Image>("image_rect", qos::reliable(queue_size))?,
        rectifier: None,
        published: 0,
        throttle: Throttle::new(node.clock()),
    };
    skeleton::spin(node, inputs, queue_size, worker, |node, frame| Work {
        frame,
        interpolation: node
            .param_i64("interpolation")
            .ok()
            .and_then(Interpolation::from_ros_parameter)
            .unwrap_or_default(),
    })?;
    Ok(())
}
