//! The point cloud node: a drop-in for stereo_image_proc's PointCloudNode. Runs as the
//! `point_cloud_node` executable and as `stereocal node point_cloud`.
//!
//! Subscribes `left/image_rect_color` (sensor_msgs/Image: mono8, mono16, rgb8, bgr8,
//! rgba8, bgra8) and `disparity` (stereo_msgs/DisparityImage, as `disparity_node`
//! publishes it), paired by equal stamps (or within
//! `approximate_sync_tolerance_seconds` with `approximate_sync`), and
//! `left/camera_info`, `right/camera_info`. Publishes `points2` (sensor_msgs/PointCloud2)
//! with the disparity's header: organized (one point per pixel), in the rectified left
//! camera frame, NaN where a pixel has no disparity, in stereo_image_proc's four layouts
//! (`use_color`, `avoid_point_cloud_padding`; see [`super::cloud`]).
//!
//! A set that cannot be used (camera_infos of no rectified horizontal pair, an image of
//! another size than the disparity, a disparity that is not `32FC1`) publishes nothing;
//! the reason is logged, throttled, and the node keeps running.

use std::sync::Arc;
use std::time::Duration;

use anyhow::Context;
use nalgebra::Matrix3x4;
use ros2_client::ParameterValue;
use stereocal_msgs::sensor_msgs::{CameraInfo, Image, PointCloud2};
use stereocal_msgs::stereo_msgs::DisparityImage;
use stereocal_runtime::node::{NodeBuilder, RosNode};
use stereocal_runtime::params::ParamSpec;
use stereocal_runtime::publisher::TopicPublisher;
use stereocal_runtime::qos;
use stereocal_runtime::skeleton::{self, FrameStats, Inputs, Worker};
use stereocal_runtime::sync::{SyncPolicy, Synced};
use stereocal_runtime::throttle::Throttle;
use stereocal_vision::stereo::Reprojection;

use super::cloud::{ChannelOrder, CloudLayout, cloud};
use crate::convert::{Encoding, image_from_msg};

/// One synchronized input of the node.
#[derive(Clone)]
pub enum CloudInput {
    /// The left rectified image, for colour.
    Image(Arc<Image>),
    /// The disparity of that image.
    Disparity(Arc<DisparityImage>),
}

impl From<Image> for CloudInput {
    fn from(image: Image) -> Self {
        Self::Image(Arc::new(image))
    }
}

impl From<Arc<Image>> for CloudInput {
    fn from(image: Arc<Image>) -> Self {
        Self::Image(image)
    }
}

impl From<DisparityImage> for CloudInput {
    fn from(disparity: DisparityImage) -> Self {
        Self::Disparity(Arc::new(disparity))
    }
}

impl From<Arc<DisparityImage>> for CloudInput {
    fn from(disparity: Arc<DisparityImage>) -> Self {
        Self::Disparity(disparity)
    }
}

/// The cloud of an image, its disparity and the pair's camera_infos.
pub fn cloud_msg(
    image: &Image,
    disparity: &DisparityImage,
    left_info: &CameraInfo,
    right_info: &CameraInfo,
    layout: CloudLayout,
) -> anyhow::Result<PointCloud2> {
    let reprojection = Reprojection::from_projections(
        &Matrix3x4::from_row_slice(&left_info.p),
        &Matrix3x4::from_row_slice(&right_info.p),
    )
    .context("camera_info")?;
    let d = &disparity.image;
    anyhow::ensure!(
        d.encoding == "32FC1"
            && d.step == d.width * 4
            && d.data.len() == (d.step * d.height) as usize,
        "disparity image is {} with step {} and {} bytes: expected 32FC1 rows of {} bytes",
        d.encoding,
        d.step,
        d.data.len(),
        d.width * 4
    );
    // The message's disparities are shifted by the principal points' offset (Z = f T / d)
    // and invalid below min_disparity; the reprojection takes them unshifted.
    let offset = (reprojection.cx_left - reprojection.cx_right) as f32;
    let values: Vec<f32> = d
        .data
        .chunks_exact(4)
        .map(|b| {
            let v = f32::from_le_bytes([b[0], b[1], b[2], b[3]]);
            let v = if d.is_bigendian != 0 {
                f32::from_bits(v.to_bits().swap_bytes())
            } else {
                v
            };
            if v < disparity.min_disparity {
                f32::NAN
            } else {
                v + offset
            }
        })
        .collect();
    let colour = if layout.color {
        let (encoding, pixels) = image_from_msg(image).context("left/image_rect_color")?;
        let order = match encoding {
            Encoding::Bgr8 | Encoding::Bgra8 => ChannelOrder::Bgr,
            _ => ChannelOrder::Rgb,
        };
        Some((pixels, order))
    } else {
        None
    };
    Ok(cloud(
        &values,
        d.width as usize,
        &reprojection,
        colour.as_ref().map(|(p, o)| (p, *o)),
        layout,
        disparity.header.clone(),
    )?)
}

/// Turns each synchronized set into a cloud and publishes it.
struct CloudWorker {
    layout: CloudLayout,
    publisher: TopicPublisher<PointCloud2>,
    throttle: Throttle,
    published: u64,
    rejected: u64,
}

impl Worker for CloudWorker {
    type Work = Synced<CloudInput, CameraInfo>;
    const NAME: &'static str = "point_cloud";

    fn handle(&mut self, work: Self::Work, _stats: &FrameStats) {
        let (
            Some(CloudInput::Image(image)),
            Some(CloudInput::Disparity(disparity)),
            Some(l),
            Some(r),
        ) = (
            work.frames.first(),
            work.frames.get(1),
            work.latched.first(),
            work.latched.get(1),
        )
        else {
            return;
        };
        let outcome = cloud_msg(image, disparity, l, r, self.layout)
            .and_then(|msg| self.publisher.publish(msg).map_err(Into::into));
        match outcome {
            Ok(()) => self.published += 1,
            Err(e) => {
                self.rejected += 1;
                self.throttle.warn(format!("no point cloud: {e:#}"));
            }
        }
    }

    fn summary(&self) -> String {
        format!(
            "{} point clouds published, {} sets rejected",
            self.published, self.rejected
        )
    }
}

/// Declares the node's parameters. All are read once at start-up.
fn declare(builder: NodeBuilder) -> NodeBuilder {
    let boolean = |name: &str, default: bool, description: &str| {
        ParamSpec::new(name, ParameterValue::Boolean(default), description)
    };
    [
        boolean("use_color", true, "add the left image's colour as a packed rgb field"),
        boolean(
            "avoid_point_cloud_padding",
            false,
            "pack points tight (12 or 16 bytes) instead of PCL's aligned 16 or 32",
        ),
        boolean(
            "approximate_sync",
            false,
            "pair the image and the disparity whose stamps differ by up to approximate_sync_tolerance_seconds",
        ),
        ParamSpec::new(
            "approximate_sync_tolerance_seconds",
            ParameterValue::Double(0.0),
            "largest stamp difference of a pair with approximate_sync, seconds",
        )
        .double_range(0.0..=10.0),
        ParamSpec::new(
            "queue_size",
            ParameterValue::Integer(5),
            "frames kept per topic while waiting for pairing",
        )
        .integer_range(1..=1000),
    ]
    .into_iter()
    .fold(builder, NodeBuilder::param)
}

fn layout(node: &RosNode) -> anyhow::Result<CloudLayout> {
    Ok(CloudLayout {
        color: node.param_bool("use_color")?,
        avoid_padding: node.param_bool("avoid_point_cloud_padding")?,
    })
}

/// Runs the point cloud node until SIGINT/SIGTERM, with `args` the command line
/// without the program name (`--ros-args` remaps, parameters, params files).
pub fn run<I, S>(args: I) -> anyhow::Result<()>
where
    I: IntoIterator<Item = S>,
    S: Into<String>,
{
    let mut node = declare(NodeBuilder::new("point_cloud_node")).start(args)?;
    let layout = layout(&node)?;
    let queue_size = usize::try_from(node.param_i64("queue_size")?).context("queue_size")?;
    let slop = if node.param_bool("approximate_sync")? {
        Duration::from_secs_f64(node.param_f64("approximate_sync_tolerance_seconds")?)
    } else {
        Duration::ZERO
    };
    let inputs = Inputs::<CloudInput, CameraInfo>::new(SyncPolicy {
        slop,
        depth: queue_size,
    })
    .stream::<Image>(
        &mut node,
        "left/image_rect_color",
        qos::sensor_data(queue_size),
    )?
    .stream::<DisparityImage>(&mut node, "disparity", qos::sensor_data(queue_size))?
    .latched::<CameraInfo>(&mut node, "left/camera_info", qos::sensor_data(queue_size))?
    .latched::<CameraInfo>(&mut node, "right/camera_info", qos::sensor_data(queue_size))?;
    let worker = CloudWorker {
        layout,
        publisher: node.advertise("points2", qos::reliable(queue_size))?,
        throttle: Throttle::new(node.clock()),
        published: 0,
        rejected: 0,
    };
    skeleton::spin(node, inputs, 1, worker, |_, frame| frame)?;
    Ok(())
}
