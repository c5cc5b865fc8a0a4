//! The rectify node: rectifies a camera's images like image_proc's RectifyNode. Runs as
//! the `rectify_node` executable and as `stereocal node rectify`.
//!
//! Subscribes `image` (sensor_msgs/Image) and `camera_info` (sensor_msgs/CameraInfo),
//! pairs them by stamp, and publishes `image_rect` in the input's encoding. Parameters:
//! `interpolation` (0 nearest, 1 linear, 2 cubic; may change while running) and
//! `queue_size` (frames kept on each topic and between receiving and rectifying; older
//! frames are dropped and counted when rectifying falls behind).

use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};

use crate::rectify_stage::{Rectified, Rectifier};
use crate::runtime::node::NodeBuilder;
use crate::runtime::params::ParamSpec;
use crate::runtime::qos;
use crate::runtime::queue::DropOldestQueue;
use crate::runtime::sequence_gaps::SequenceGaps;
use crate::runtime::sync::StampPairing;
use crate::runtime::throttle::Throttle;
use anyhow::Context;
use futures::{FutureExt, StreamExt};
use ros2_client::{ParameterValue, Publisher};
use stereocal_msgs::sensor_msgs::{CameraInfo, Image};
use stereocal_vision::rectify::{Interpolation, RemapOptions};

/// A frame to rectify, with the camera_info it was paired with and the interpolation
/// in force when it was received.
struct Work {
    image: Image,
    info: Arc<CameraInfo>,
    interpolation: Interpolation,
}

fn rectify_loop(
    queue: &DropOldestQueue<Work>,
    publisher: &Publisher<Image>,
    published: &AtomicU64,
) {
    let mut rectifier: Option<Rectifier> = None;
    let mut throttle = Throttle::default();
    while let Some(work) = queue.pop() {
        let rectifier = match &mut rectifier {
            Some(r) if r.options().interpolation == work.interpolation => r,
            slot => slot.insert(Rectifier::new(RemapOptions {
                interpolation: work.interpolation,
                ..RemapOptions::default()
            })),
        };
        match rectifier.rectify(&work.image, &work.info) {
            Ok(Rectified::Image(rect)) => match publisher.publish(rect) {
                Ok(()) => {
                    published.fetch_add(1, Ordering::Relaxed);
                }
                Err(e) => throttle.warn(format!("image_rect not published: {e}")),
            },
            Ok(Rectified::Uncalibrated { warning }) => {
                if let Some(warning) = warning {
                    log::warn!("{warning}");
                }
            }
            Err(e) => throttle.warn(format!(
                "frame {:?} at {}.{:09} not rectified: {e}",
                work.image.header.frame_id,
                work.image.header.stamp.sec,
                work.image.header.stamp.nanosec
            )),
        }
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
            .integer_range(0..=2),
        )
        .param(
            ParamSpec::new(
                "queue_size",
                ParameterValue::Integer(5),
                "frames kept per topic and waiting to be rectified; older ones are dropped",
            )
            .integer_range(1..=1000),
        )
        .start(args)?;
    let queue_size = usize::try_from(node.param_i64("queue_size")?).context("queue_size")?;

    let image_sub = node.subscribe::<Image>("image", qos::sensor_data(queue_size))?;
    let info_sub = node.subscribe::<CameraInfo>("camera_info", qos::sensor_data(queue_size))?;
    let publisher = node.advertise::<Image>("image_rect", qos::reliable(queue_size))?;

    let queue = Arc::new(DropOldestQueue::<Work>::new(queue_size));
    let published = Arc::new(AtomicU64::new(0));
    let worker = {
        let queue = Arc::clone(&queue);
        let published = Arc::clone(&published);
        std::thread::Builder::new()
            .name("rectify".into())
            .spawn(move || rectify_loop(&queue, &publisher, &published))
            .context("starting the rectify thread")?
    };

    let shutdown = node.shutdown();
    let mut pairing = StampPairing::new(queue_size);
    let mut gaps = SequenceGaps::default();
    let mut received = 0u64;
    let mut throttle = Throttle::default();
    futures::executor::block_on(async {
        let mut images = std::pin::pin!(image_sub.async_stream());
        let mut infos = std::pin::pin!(info_sub.async_stream());
        let mut stop = shutdown.wait().fuse();
        loop {
            let pairs = futures::select! {
                image = images.select_next_some() => match image {
                    Ok((image, message_info)) => {
                        received += 1;
                        let missed = gaps.record(message_info.publisher_gid(), message_info.sequence_number());
                        if missed > 0 {
                            throttle.warn(format!("{} image(s) lost before reception so far", gaps.missed()));
                        }
                        let stamp = (image.header.stamp.sec, image.header.stamp.nanosec);
                        pairing.push_primary(stamp, image)
                    }
                    Err(e) => {
                        throttle.warn(format!("undecodable image message: {e}"));
                        Vec::new()
                    }
                },
                info = infos.select_next_some() => match info {
                    Ok((info, _)) => {
                        let stamp = (info.header.stamp.sec, info.header.stamp.nanosec);
                        pairing.push_secondary(stamp, info)
                    }
                    Err(e) => {
                        throttle.warn(format!("undecodable camera_info message: {e}"));
                        Vec::new()
                    }
                },
                () = stop => break,
            };
            let interpolation = node
                .param_i64("interpolation")
                .ok()
                .and_then(Interpolation::from_ros_parameter)
                .unwrap_or_default();
            for (image, info) in pairs {
                if queue
                    .push(Work {
                        image,
                        info,
                        interpolation,
                    })
                    .is_some()
                {
                    throttle.warn(format!(
                        "rectifying falls behind: {} frame(s) dropped so far",
                        queue.dropped()
                    ));
                }
            }
        }
    });

    queue.close();
    if worker.join().is_err() {
        log::error!("the rectify thread panicked");
    }
    log::info!(
        "shutting down: {received} image(s) received, {} published, {} dropped while \
         waiting to be rectified, {} lost before reception, {} paired with a camera_info \
         of another stamp",
        published.load(Ordering::Relaxed),
        queue.dropped(),
        gaps.missed(),
        pairing.inexact()
    );
    // Readers go before the node and its DDS participant, which must remove them.
    drop(image_sub);
    drop(info_sub);
    drop(node);
    Ok(())
}
