//! The rectify node: rectifies a camera's images like image_proc's RectifyNode. Runs as
//! the `rectify_node` executable and as `stereocal node rectify`.
//!
//! Subscribes `image` (sensor_msgs/Image) and `camera_info` (sensor_msgs/CameraInfo),
//! pairs them by stamp, and publishes `image_rect` in the input's encoding, and
//! `image_rect/compressed` (sensor_msgs/CompressedImage) while someone subscribes to it,
//! as image_transport's compressed publisher does. Parameters: `interpolation` (0
//! nearest, 1 linear, 2 cubic; may change while running), `queue_size` (frames kept on
//! each topic and between receiving and rectifying; older frames are dropped and counted
//! when rectifying falls behind), `image_transport` (`compressed` reads
//! `image/compressed`, see [`crate::image_transport`]) and compressed_image_transport's
//! `image_rect.compressed.format` (`jpeg` or `png`), `.jpeg_quality` and `.png_level`
//! (all three may change while running).

use std::sync::Arc;

use anyhow::Context;
use ros2_client::ParameterValue;
use stereocal_msgs::sensor_msgs::{CameraInfo, CompressedImage, Image};
use stereocal_runtime::node::NodeBuilder;
use stereocal_runtime::node::RosNode;
use stereocal_runtime::params::ParamSpec;
use stereocal_runtime::publisher::TopicPublisher;
use stereocal_runtime::qos;
use stereocal_runtime::skeleton::{self, FrameStats, Worker};
use stereocal_runtime::sync::Synced;

use crate::convert::{Compression, compressed_from_image_msg};
use crate::image_transport::{self, camera_inputs, transport};
use stereocal_runtime::throttle::Throttle;
use stereocal_vision::rectify::{Interpolation, RemapOptions};

use super::stage::{Rectified, Rectifier};

/// Parameter names of the compressed output, as compressed_image_transport names them
/// for the topic `image_rect`.
const FORMAT: &str = "image_rect.compressed.format";
const JPEG_QUALITY: &str = "image_rect.compressed.jpeg_quality";
const PNG_LEVEL: &str = "image_rect.compressed.png_level";

/// A frame to rectify, with the interpolation and compression in force when it was
/// received.
struct Work {
    frame: Synced<Arc<Image>, CameraInfo>,
    interpolation: Interpolation,
    compression: Compression,
}

/// Rectifies each frame with the [`Rectifier`] of its interpolation and publishes it,
/// compressed too while `image_rect/compressed` has subscribers.
struct RectifyWorker {
    publisher: TopicPublisher<Image>,
    compressed: TopicPublisher<CompressedImage>,
    rectifier: Option<Rectifier>,
    /// The last image published: its data is remapped into again once every
    /// subscriber has let go of it.
    last: Option<Arc<Image>>,
    published: u64,
    throttle: Throttle,
}

impl RectifyWorker {
    /// Publishes `rect` on `image_rect/compressed` if anyone subscribes.
    fn publish_compressed(&mut self, rect: &Image, compression: Compression) {
        if !self.compressed.has_readers() {
            return;
        }
        let sent = compressed_from_image_msg(rect, compression)
            .map_err(anyhow::Error::from)
            .and_then(|msg| Ok(self.compressed.publish(msg)?));
        if let Err(e) = sent {
            self.throttle
                .warn(format!("image_rect/compressed not published: {e}"));
        }
    }
}

/// The compression the parameters ask for.
fn compression(node: &RosNode) -> Compression {
    let level = |name: &str, default: u8| {
        node.param_i64(name)
            .ok()
            .and_then(|v| u8::try_from(v).ok())
            .unwrap_or(default)
    };
    match node.param_string(FORMAT).as_deref() {
        Ok("png") => Compression::Png {
            level: level(PNG_LEVEL, 3),
        },
        _ => Compression::Jpeg {
            quality: level(JPEG_QUALITY, 95),
        },
    }
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
        if let Some(last) = self.last.take().and_then(|last| Arc::try_unwrap(last).ok()) {
            rectifier.recycle(last);
        }
        match rectifier.rectify(image, info) {
            Ok(Rectified::Image(rect)) => {
                let rect = Arc::new(rect);
                match self.publisher.publish_shared(Arc::clone(&rect)) {
                    Ok(()) => self.published += 1,
                    Err(e) => self.throttle.warn(format!("image_rect not published: {e}")),
                }
                self.publish_compressed(&rect, work.compression);
                self.last = Some(rect);
            }
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
        let replaced = self.publisher.dropped_before_dds();
        format!(
            "{} published ({} over DDS{})",
            self.published,
            self.publisher.sent_over_dds(),
            if replaced > 0 {
                format!(", {replaced} replaced by newer ones before DDS sent them")
            } else {
                String::new()
            }
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
        .param(
            ParamSpec::new(
                FORMAT,
                ParameterValue::String("jpeg".into()),
                "compression of image_rect/compressed: jpeg or png",
            )
            .one_of(&["jpeg", "png"])
            .settable_while_running(),
        )
        .param(
            ParamSpec::new(
                JPEG_QUALITY,
                ParameterValue::Integer(95),
                "JPEG quality of image_rect/compressed",
            )
            .integer_range(1..=100)
            .settable_while_running(),
        )
        .param(
            ParamSpec::new(
                PNG_LEVEL,
                ParameterValue::Integer(3),
                "PNG compression level of image_rect/compressed",
            )
            .integer_range(1..=9)
            .settable_while_running(),
        )
        .start(args)?;
    let queue_size = usize::try_from(node.param_i64("queue_size")?).context("queue_size")?;
    let transport = transport(&node)?;
    let inputs = camera_inputs(&mut node, transport, queue_size)?;
    let worker = RectifyWorker {
        publisher: node.advertise::<Image>("image_rect", qos::reliable(queue_size))?,
        compressed: node
            .advertise::<CompressedImage>("image_rect/compressed", qos::reliable(queue_size))?,
        rectifier: None,
        last: None,
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
        compression: compression(node),
    })?;
    Ok(())
}
