//! The disparity node: a drop-in for stereo_image_proc's DisparityNode on our
//! semi-global matcher or block matcher. Runs as the `disparity_node` executable and as
//! `stereocal node disparity`.
//!
//! Subscribes `left/image_rect`, `right/image_rect` (sensor_msgs/Image, mono or 8-bit
//! colour taken as grey; `.../compressed` with `image_transport: compressed`) paired by
//! equal stamps, or within `approximate_sync_tolerance_seconds` with
//! `approximate_sync`, and `left/camera_info`, `right/camera_info`. Publishes
//! `disparity` (stereo_msgs/DisparityImage) with the left image's header, as
//! stereo_image_proc does (see [`super::stage::disparity_msg`]).
//!
//! Parameters keep stereo_image_proc's names and ranges. Where our matcher differs:
//! - `stereo_algorithm`: 1 (semi-global, the default) or 0 (block matching, with
//!   `correlation_window_size`, `prefilter_cap` and `texture_threshold` as OpenCV's
//!   StereoBM takes them);
//! - `sgbm_mode`: OpenCV's modes mapped to aggregation paths: 0 (SGBM) five, 1 (HH)
//!   eight (default), 2 (SGBM_3WAY) and 3 (HH4) four;
//! - `P1`, `P2`: penalties in census units (Hamming bits of a 9x7 census, 0 to 62 per
//!   disparity), defaults 10 and 120;
//! - `prefilter_size` is accepted so that stereo_image_proc's parameter files load: the
//!   block matcher's pre-filter is the x-Sobel one (OpenCV's default, as
//!   stereo_image_proc leaves it), which has no size; the semi-global matcher uses
//!   none of the block-matching parameters;
//! - `refine_radius` (ours): half-size of the window of the sub-pixel refinement.
//!
//! A pair that cannot be matched (sizes or encodings that differ, camera_infos of no
//! rectified horizontal pair, a disparity range wider than the image) publishes nothing;
//! the reason is logged, throttled, and the node keeps running.

use std::sync::Arc;
use std::time::Duration;

use anyhow::Context;
use ros2_client::ParameterValue;
use stereocal_msgs::sensor_msgs::{CameraInfo, Image};
use stereocal_msgs::stereo_msgs::DisparityImage;
use stereocal_runtime::node::{NodeBuilder, RosNode};
use stereocal_runtime::params::ParamSpec;
use stereocal_runtime::publisher::TopicPublisher;
use stereocal_runtime::qos;
use stereocal_runtime::skeleton::{self, FrameStats, Inputs, Worker};
use stereocal_runtime::sync::{SyncPolicy, Synced};
use stereocal_runtime::throttle::Throttle;
use stereocal_vision::stereo::{BmParams, Paths, SgmParams};

use super::stage::{DepthStage, MatcherParams, disparity_msg};
use crate::image_transport::{self, image_stream, transport};

/// Matches each synchronized pair and publishes its disparity.
struct DisparityWorker {
    stage: DepthStage,
    publisher: TopicPublisher<DisparityImage>,
    throttle: Throttle,
    published: u64,
    rejected: u64,
}

impl Worker for DisparityWorker {
    type Work = Synced<Arc<Image>, CameraInfo>;
    const NAME: &'static str = "disparity";

    fn handle(&mut self, work: Self::Work, _stats: &FrameStats) {
        let (Some(left), Some(right), Some(left_info), Some(right_info)) = (
            work.frames.first(),
            work.frames.get(1),
            work.latched.first(),
            work.latched.get(1),
        ) else {
            return;
        };
        match self.stage.disparity(left, left_info, right, right_info) {
            Ok(frame) => {
                match self
                    .publisher
                    .publish(disparity_msg(&frame, left.header.clone()))
                {
                    Ok(()) => self.published += 1,
                    Err(e) => self.throttle.warn(format!("disparity not published: {e}")),
                }
            }
            Err(reason) => {
                self.rejected += 1;
                self.throttle.warn(format!("no disparity: {reason}"));
            }
        }
    }

    fn summary(&self) -> String {
        format!(
            "{} disparity images published, {} pairs rejected",
            self.published, self.rejected
        )
    }
}

/// Declares the node's parameters. All are read once at start-up.
fn declare(builder: NodeBuilder) -> NodeBuilder {
    let integer =
        |name: &str, default: i64, range: std::ops::RangeInclusive<i64>, description: &str| {
            ParamSpec::new(name, ParameterValue::Integer(default), description).integer_range(range)
        };
    let double =
        |name: &str, default: f64, range: std::ops::RangeInclusive<f64>, description: &str| {
            ParamSpec::new(name, ParameterValue::Double(default), description).double_range(range)
        };
    let defaults = SgmParams::default();
    [
        integer(
            "stereo_algorithm",
            1,
            0..=1,
            "stereo algorithm: block matching (0) or semi-global matching (1)",
        ),
        integer(
            "prefilter_size",
            9,
            5..=255,
            "accepted for stereo_image_proc's parameter files; the x-Sobel pre-filter has no size",
        ),
        integer(
            "prefilter_cap",
            31,
            1..=63,
            "block matching: the pre-filtered derivative is clipped to this",
        ),
        integer(
            "correlation_window_size",
            15,
            5..=255,
            "block matching: side of the matching window, pixels (odd)",
        ),
        integer(
            "texture_threshold",
            10,
            0..=10000,
            "block matching: least summed derivative magnitude in the window for a match",
        ),
        integer(
            "min_disparity",
            0,
            -2048..=2048,
            "disparity to begin the search at, pixels",
        ),
        integer(
            "disparity_range",
            64,
            32..=4096,
            "number of disparities to search, pixels (a multiple of 16, below the image width)",
        ),
        integer(
            "speckle_size",
            defaults.speckle_size as i64,
            0..=1000,
            "regions of similar disparity with at most this many pixels are invalidated",
        ),
        integer(
            "speckle_range",
            4,
            0..=31,
            "largest disparity difference within one speckle region, pixels",
        ),
        integer(
            "disp12_max_diff",
            0,
            0..=128,
            "largest difference between the left-to-right and right-to-left match, pixels",
        ),
        double(
            "uniqueness_ratio",
            15.0,
            0.0..=99.0,
            "a match is kept only when every other disparity costs this many percent more",
        ),
        double(
            "P1",
            f64::from(defaults.p1),
            0.0..=4000.0,
            "penalty of a disparity change by one pixel, census units (Hamming bits)",
        ),
        double(
            "P2",
            f64::from(defaults.p2),
            0.0..=4000.0,
            "penalty of a larger disparity change, census units (at least P1)",
        ),
        integer(
            "sgbm_mode",
            1,
            0..=3,
            "OpenCV's SGBM modes as aggregation paths: 0 five, 1 eight, 2 and 3 four",
        ),
        integer(
            "refine_radius",
            defaults.refine_radius as i64,
            0..=stereocal_vision::stereo::MAX_REFINE_RADIUS as i64,
            "half-size of the window of the sub-pixel refinement on the images, pixels (0: none)",
        ),
        ParamSpec::new(
            "approximate_sync",
            ParameterValue::Boolean(false),
            "pair images whose stamps differ by up to approximate_sync_tolerance_seconds",
        ),
        double(
            "approximate_sync_tolerance_seconds",
            0.0,
            0.0..=10.0,
            "largest stamp difference of a pair with approximate_sync, seconds",
        ),
        integer(
            "queue_size",
            5,
            1..=1000,
            "frames kept per topic while waiting for pairing",
        ),
        image_transport::spec(),
    ]
    .into_iter()
    .fold(builder, NodeBuilder::param)
}

/// The matcher parameters the node's parameters ask for.
fn params_from_node(node: &RosNode) -> anyhow::Result<MatcherParams> {
    let integer = |name: &str| -> anyhow::Result<usize> {
        usize::try_from(node.param_i64(name)?).with_context(|| format!("parameter {name}"))
    };
    let min_disparity = i32::try_from(node.param_i64("min_disparity")?).context("min_disparity")?;
    let uniqueness_ratio = node.param_f64("uniqueness_ratio")?.round() as u32;
    let disp12_max_diff =
        Some(u32::try_from(node.param_i64("disp12_max_diff")?).context("disp12_max_diff")?);
    let params = if node.param_i64("stereo_algorithm")? == 0 {
        MatcherParams::Bm(BmParams {
            min_disparity,
            disparity_range: integer("disparity_range")?,
            window: integer("correlation_window_size")?,
            prefilter_cap: u8::try_from(node.param_i64("prefilter_cap")?)
                .context("prefilter_cap")?,
            texture_threshold: u32::try_from(node.param_i64("texture_threshold")?)
                .context("texture_threshold")?,
            uniqueness_ratio,
            disp12_max_diff,
            speckle_size: integer("speckle_size")?,
            speckle_range: node.param_i64("speckle_range")? as f32,
        })
    } else {
        let paths = match node.param_i64("sgbm_mode")? {
            0 => Paths::Five,
            1 => Paths::Eight,
            _ => Paths::Four,
        };
        let penalty = |name: &str| -> anyhow::Result<u16> {
            let value = node.param_f64(name)?.round();
            u16::try_from(value as i64).with_context(|| format!("parameter {name}: {value}"))
        };
        MatcherParams::Sgm(SgmParams {
            min_disparity,
            disparity_range: integer("disparity_range")?,
            paths,
            p1: penalty("P1")?,
            p2: penalty("P2")?,
            uniqueness_ratio,
            disp12_max_diff,
            speckle_size: integer("speckle_size")?,
            speckle_range: node.param_i64("speckle_range")? as f32,
            refine_radius: integer("refine_radius")?,
        })
    };
    // What does not depend on the image size is refused at start-up.
    params
        .validate(usize::MAX)
        .map_err(|e| anyhow::anyhow!("parameters: {e}"))?;
    Ok(params)
}

/// Runs the disparity node until SIGINT/SIGTERM, with `args` the command line without
/// the program name (`--ros-args` remaps, parameters, params files).
pub fn run<I, S>(args: I) -> anyhow::Result<()>
where
    I: IntoIterator<Item = S>,
    S: Into<String>,
{
    let mut node = declare(NodeBuilder::new("disparity_node")).start(args)?;
    let params = params_from_node(&node)?;
    let queue_size = usize::try_from(node.param_i64("queue_size")?).context("queue_size")?;
    let slop = if node.param_bool("approximate_sync")? {
        Duration::from_secs_f64(node.param_f64("approximate_sync_tolerance_seconds")?)
    } else {
        Duration::ZERO
    };
    let transport = transport(&node)?;
    let mut inputs = Inputs::<Arc<Image>, CameraInfo>::new(SyncPolicy {
        slop,
        depth: queue_size,
    });
    for topic in ["left/image_rect", "right/image_rect"] {
        inputs = image_stream(
            inputs,
            &mut node,
            transport,
            topic,
            qos::sensor_data(queue_size),
        )?;
    }
    for topic in ["left/camera_info", "right/camera_info"] {
        inputs = inputs.latched::<CameraInfo>(&mut node, topic, qos::sensor_data(queue_size))?;
    }
    let worker = DisparityWorker {
        stage: DepthStage::new(params),
        publisher: node.advertise("disparity", qos::reliable(queue_size))?,
        throttle: Throttle::new(node.clock()),
        published: 0,
        rejected: 0,
    };
    // The worker matches the newest pair; older ones are dropped while it is busy.
    skeleton::spin(node, inputs, 1, worker, |_, frame| frame)?;
    Ok(())
}
