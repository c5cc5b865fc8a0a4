//! Every frame of a bag, judged for calibration as the live session judges a frame: the
//! target detected, then the same [`FrameChecks`] (sharpness in each image, board motion
//! against the camera's previous frame). Unlike the session, nothing is left out for
//! adding no coverage: the offline command sees every frame and lets the solver weigh
//! them.
//!
//! The bag is streamed: a small batch of images is held at a time, detected in parallel,
//! and only the corners are kept, so memory stays bounded whatever the bag's size.

use std::collections::BTreeMap;

use anyhow::{Context, bail};
use indicatif::ProgressBar;
use rayon::prelude::*;
use stereocal_msgs::builtin_interfaces::Time;
use stereocal_rosbag::{BagReader, TopicFilter};
use stereocal_vision::board::{Detection, Gray, MIN_CHARUCO_CORNERS, Target, TargetDetector};
use stereocal_vision::calib::quality::{EdgeLayout, FrameChecks};

use super::stage::{CameraFrames, Frame, FrameCorners};
use crate::convert::{ImageKind, image_from_msg};

/// A camera to calibrate: its name and image topic.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct CameraTopic {
    /// The camera's name (`left`, `right`, or a mono camera's name).
    pub name: String,
    /// Its image topic in the bag.
    pub topic: String,
    /// Raw or compressed images.
    pub kind: ImageKind,
}

/// An image waiting for detection: camera index, the kind of message, and its CDR bytes.
struct Pending {
    camera: usize,
    kind: ImageKind,
    data: Vec<u8>,
}

/// What detection made of one message.
struct Detected {
    camera: usize,
    stamp: Time,
    size: Option<(u32, u32)>,
    /// The board found, kept for the motion check against the next frame.
    detection: Option<Detection>,
    corners: FrameCorners,
}

/// Streams the cameras' images from `reader`, finds the target in each (a batch of
/// images at a time, in parallel) and judges it with `checks`; returns each camera's
/// frames in stamp order. `progress` counts the images searched.
pub fn judge_bag_frames(
    reader: &BagReader,
    cameras: &[CameraTopic],
    detector: &(dyn TargetDetector + Sync),
    checks: &FrameChecks,
    progress: &ProgressBar,
) -> anyhow::Result<Vec<CameraFrames>> {
    let batch_size = 2 * rayon::current_num_threads().max(1);
    let mut collector = Collector {
        cameras,
        per_camera: cameras.iter().map(|_| BTreeMap::new()).collect(),
        sizes: vec![None; cameras.len()],
    };
    let judge = Judge {
        detector,
        checks,
        layout: EdgeLayout::of(detector.target()),
    };
    let mut batch = Vec::with_capacity(batch_size);
    let filter = TopicFilter::only(cameras.iter().map(|c| c.topic.as_str()));
    for message in reader.messages(&filter) {
        let message =
            message.with_context(|| format!("reading the bag {}", reader.path().display()))?;
        if let Some(camera) = cameras.iter().position(|c| *c.topic == *message.topic) {
            batch.push(Pending {
                camera,
                kind: cameras[camera].kind,
                data: message.data,
            });
        }
        if batch.len() == batch_size {
            collector.absorb(&mut batch, &judge, progress);
        }
    }
    collector.absorb(&mut batch, &judge, progress);
    let Collector {
        per_camera, sizes, ..
    } = collector;
    cameras
        .iter()
        .zip(per_camera)
        .zip(sizes)
        .map(|((camera, frames), size)| {
            let Some((width, height)) = size else {
                bail!(
                    "no decodable image on {}: the bag has no usable images for camera {}",
                    camera.topic,
                    camera.name
                );
            };
            Ok(CameraFrames {
                name: camera.name.clone(),
                width,
                height,
                frames: judge.motion(frames.into_values()),
            })
        })
        .collect()
}

/// The detector and the checks every frame goes through.
struct Judge<'a> {
    detector: &'a (dyn TargetDetector + Sync),
    checks: &'a FrameChecks,
    layout: EdgeLayout,
}

impl Judge<'_> {
    /// Decodes one image, looks for the target and checks its sharpness; `None` when
    /// the message cannot be decoded at all (no stamp to report it under), after saying
    /// so on stderr.
    fn detect(&self, pending: &Pending, progress: &ProgressBar) -> Option<Detected> {
        let message = match pending.kind.decode(&pending.data) {
            Ok(message) => message,
            Err(e) => {
                progress.suspend(|| eprintln!("skipped an undecodable image message: {e}"));
                return None;
            }
        };
        let stamp = message.header.stamp;
        let unusable = |reason: String| Detected {
            camera: pending.camera,
            stamp,
            size: None,
            detection: None,
            corners: FrameCorners::Unusable(reason),
        };
        let gray = match image_from_msg(&message)
            .map_err(|e| e.to_string())
            .and_then(|(_, image)| Gray::from_image(&image).map_err(|e| e.to_string()))
        {
            Ok(gray) => gray,
            Err(e) => return Some(unusable(e)),
        };
        let target = self.detector.target();
        let detection = self.detector.detect_gray(&gray);
        let corners = match &detection {
            None => FrameCorners::Unusable(match target {
                Target::Chessboard(_) => "no complete board found".to_owned(),
                Target::Circles(_) | Target::Acircles(_) => format!(
                    "no complete {} found (every circle in view, one grid only)",
                    target.describe()
                ),
                Target::Charuco(_) => format!(
                    "no ChArUco board found (at least {MIN_CHARUCO_CORNERS} corners, not all in one line)"
                ),
            }),
            Some(detection) => match self.checks.check_sharpness(&gray, detection, &self.layout) {
                Err(refusal) => FrameCorners::Unusable(refusal.to_string()),
                Ok(()) => FrameCorners::from_detection(detection, target),
            },
        };
        Some(Detected {
            camera: pending.camera,
            stamp,
            size: Some((message.width, message.height)),
            detection,
            corners,
        })
    }

    /// One camera's frames in stamp order, each board's motion checked against the
    /// previous frame's.
    fn motion(&self, frames: impl Iterator<Item = Detected>) -> Vec<Frame> {
        let mut previous: Option<(Time, Option<Detection>)> = None;
        frames
            .map(|detected| {
                let mut corners = detected.corners;
                if let (FrameCorners::Found(_), Some(current), Some((before, Some(earlier)))) =
                    (&corners, &detected.detection, &previous)
                    && let Err(refusal) = self.checks.check_motion(
                        earlier,
                        current,
                        detected.stamp.seconds_since(before),
                    )
                {
                    corners = FrameCorners::Unusable(refusal.to_string());
                }
                previous = Some((detected.stamp, detected.detection));
                Frame {
                    stamp: detected.stamp,
                    corners,
                }
            })
            .collect()
    }
}

/// The frames found so far, per camera.
struct Collector<'a> {
    cameras: &'a [CameraTopic],
    per_camera: Vec<BTreeMap<Time, Detected>>,
    sizes: Vec<Option<(u32, u32)>>,
}

impl Collector<'_> {
    /// Judges every image of `batch` in parallel, keeps what was found and empties the
    /// batch.
    fn absorb(&mut self, batch: &mut Vec<Pending>, judge: &Judge, progress: &ProgressBar) {
        let detected: Vec<Option<Detected>> = batch
            .par_drain(..)
            .map(|pending| {
                let found = judge.detect(&pending, progress);
                progress.inc(1);
                found
            })
            .collect();
        for mut found in detected.into_iter().flatten() {
            let camera = found.camera;
            let (Some(size_slot), Some(frames), Some(topic)) = (
                self.sizes.get_mut(camera),
                self.per_camera.get_mut(camera),
                self.cameras.get(camera).map(|c| &c.topic),
            ) else {
                continue;
            };
            if let Some(size) = found.size {
                match *size_slot {
                    None => *size_slot = Some(size),
                    Some(first) if first != size => {
                        found.detection = None;
                        found.corners = FrameCorners::Unusable(format!(
                            "image is {}x{} but the camera's first image was {}x{}",
                            size.0, size.1, first.0, first.1
                        ));
                    }
                    Some(_) => {}
                }
            }
            if frames.contains_key(&found.stamp) {
                progress.suspend(|| {
                    eprintln!(
                        "{topic}: a second image with stamp {}.{:09} s is ignored",
                        found.stamp.sec, found.stamp.nanosec
                    );
                });
                continue;
            }
            frames.insert(found.stamp, found);
        }
    }
}
