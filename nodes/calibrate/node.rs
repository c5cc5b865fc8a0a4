//! The calibrate node: collects calibration samples from a live camera or stereo pair,
//! headless, like ROS camera_calibration's cameracalibrator. Runs as the
//! `calibrate_node` executable and as `stereocal node calibrate`.
//!
//! Subscribes `image` (mono) or `left/image` and `right/image` (`stereo: true`, paired
//! by exact stamp or within `slop` seconds). The [worker](super::worker) judges the
//! newest frame with a [`CalibrationSession`] (frames that arrive while it is busy are
//! dropped and counted), keeps the samples that add coverage in `state_dir` (they
//! survive a restart), and publishes [`~/status`](super::status) and
//! `~/annotated_image` (mono) or `~/left/annotated_image` and `~/right/annotated_image`
//! (stereo): each judged image as rgb8 with the detected corners, the coverage bars and
//! the verdict.
//!
//! Services (std_srvs/Trigger): `~/calibrate` calibrates from the kept samples once
//! coverage is ready (else says what is missing), `~/commit` writes each camera's
//! camera_info YAML atomically to its `file://` URL and sends it to the camera's
//! `set_camera_info` (mono) or `left/set_camera_info` and `right/set_camera_info`
//! (stereo) when a server answers within a second, `~/reset` forgets every sample.
//! With `auto_calibrate` the node calibrates by itself once coverage is ready.

use std::sync::Arc;

use anyhow::Context;
use stereocal_msgs::sensor_msgs::Image;
use stereocal_msgs::std_msgs;
use stereocal_runtime::node::NodeBuilder;
use stereocal_runtime::qos;
use stereocal_runtime::service::TriggerServices;
use stereocal_runtime::skeleton::{self, Inputs};
use stereocal_runtime::sync::SyncPolicy;

use super::session::CalibrationSession;
use super::settings::{declare, settings};
use super::worker::{CalibrateWorker, Endpoints, Service};
use crate::image_transport::image_stream;

/// Runs the calibrate node until SIGINT/SIGTERM, with `args` the command line without
/// the program name (`--ros-args` remaps, parameters, params files).
pub fn run<I, S>(args: I) -> anyhow::Result<()>
where
    I: IntoIterator<Item = S>,
    S: Into<String>,
{
    let mut node = declare(NodeBuilder::new("calibrate_node")).start(args)?;
    let settings = settings(&node)?;
    let session = CalibrationSession::open(settings.session.clone(), &settings.state_dir)
        .with_context(|| format!("state_dir {}", settings.state_dir.display()))?;
    log::info!(
        "calibrating {} with {} samples kept in {}",
        settings.session.cameras.join(" and "),
        session.sample_count(),
        settings.state_dir.display()
    );

    let (image_topics, annotated_topics, set_info_services) = if settings.stereo {
        (
            vec!["left/image", "right/image"],
            vec!["~/left/annotated_image", "~/right/annotated_image"],
            vec!["left/set_camera_info", "right/set_camera_info"],
        )
    } else {
        (
            vec!["image"],
            vec!["~/annotated_image"],
            vec!["set_camera_info"],
        )
    };
    let depth = settings.queue_size;
    let policy = SyncPolicy {
        slop: settings.slop,
        depth,
    };
    let mut inputs = Inputs::<Arc<Image>, ()>::new(policy);
    for topic in &image_topics {
        inputs = image_stream(
            inputs,
            &mut node,
            settings.image_transport,
            topic,
            qos::sensor_data(depth),
        )?;
    }
    let mut annotated = Vec::new();
    for topic in &annotated_topics {
        annotated.push(node.advertise::<Image>(topic, qos::reliable(2))?);
    }
    let mut set_camera_info = Vec::new();
    for name in &set_info_services {
        set_camera_info.push((node.resolve_topic(name)?, node.create_client(name)?));
    }
    let endpoints = Endpoints {
        status: node.advertise::<std_msgs::String>(
            "~/status",
            qos::reliable(1).durability(ros2_client::qos::Durability::TransientLocal),
        )?,
        annotated,
        services: TriggerServices::new(&mut node, &Service::ALL)?,
        set_camera_info,
    };
    // The worker judges the newest frame; older ones are dropped while it is busy.
    let worker = CalibrateWorker::new(session, settings, endpoints, node.clock());
    skeleton::spin(node, inputs, 1, worker, |_, frame| frame)?;
    Ok(())
}
