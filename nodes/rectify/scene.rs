//! A synthetic stereo scene on disk, as `stereocal synth --scene stereo` writes it (a
//! `bag/` whose camera_info carry the rig's calibration, and `ground_truth.json`), with
//! what the demo and the end-to-end tests measure on its rectified images.

use std::path::{Path, PathBuf};

use anyhow::Context;
use stereocal_msgs::sensor_msgs::{CameraInfo, Image};
use stereocal_vision::synth::{FrameKind, GroundTruth};

use crate::convert::{CalibratedCamera, calibrated_camera_from_info};
use crate::rectify::row_alignment::{RectifiedByStamp, RowAlignment, measure_stereo_scene};
use stereocal_rosbag::{BagReader, TopicFilter};

/// Namespace of the left camera's topics.
pub const LEFT: &str = "/stereo/left";
/// Namespace of the right camera's topics.
pub const RIGHT: &str = "/stereo/right";

/// Rectified images of the left and right cameras, by stamp.
pub type RectifiedPair = [RectifiedByStamp; 2];

/// A synthetic stereo scene: its bag, ground truth and calibrated cameras.
#[derive(Debug)]
pub struct StereoScene {
    /// The rosbag2 bag of raw images and camera_info.
    pub bag: PathBuf,
    /// The scene's ground truth.
    pub truth: GroundTruth,
    /// The left camera, from the bag's first left camera_info.
    pub left: CalibratedCamera,
    /// The right camera, from the bag's first right camera_info.
    pub right: CalibratedCamera,
}

impl StereoScene {
    /// Opens the scene written by `stereocal synth` into `dir`.
    pub fn open(dir: &Path) -> anyhow::Result<Self> {
        let bag = dir.join("bag");
        let truth_path = dir.join("ground_truth.json");
        let text = std::fs::read_to_string(&truth_path)
            .with_context(|| format!("cannot read {}", truth_path.display()))?;
        let truth: GroundTruth = serde_json::from_str(&text)
            .with_context(|| format!("{} is not a ground truth", truth_path.display()))?;
        let reader = BagReader::open(&bag)?;
        let camera = |ns: &str| -> anyhow::Result<CalibratedCamera> {
            let topic = format!("{ns}/camera_info");
            let message = reader
                .messages(&TopicFilter::only([topic.as_str()]))
                .next()
                .with_context(|| format!("{} has no {topic}", bag.display()))??;
            let info: CameraInfo = message.decode()?;
            calibrated_camera_from_info(&info).with_context(|| format!("{topic} is not usable"))
        };
        let (left, right) = (camera(LEFT)?, camera(RIGHT)?);
        Ok(Self {
            bag,
            truth,
            left,
            right,
        })
    }

    /// Frames whose images are clean (not blurred, moving or partly out of view).
    pub fn clean_frames(&self) -> usize {
        self.truth
            .frames
            .iter()
            .filter(|f| f.kind == FrameKind::Clean)
            .count()
    }

    /// Row alignment of rectified images over the clean frames, and the number of
    /// frames measured.
    pub fn row_alignment(&self, rectified: &RectifiedPair) -> (RowAlignment, usize) {
        measure_stereo_scene(
            &self.truth,
            &self.left,
            &self.right,
            &rectified[0],
            &rectified[1],
        )
    }
}

/// The `<ns>/image_rect` images of the left and right cameras in a bag written by
/// `stereocal rectify`.
pub fn read_rectified(bag: &Path) -> anyhow::Result<RectifiedPair> {
    let reader = BagReader::open(bag)?;
    let mut sides = RectifiedPair::default();
    let topics = [format!("{LEFT}/image_rect"), format!("{RIGHT}/image_rect")];
    for message in reader.messages(&TopicFilter::only(&topics)) {
        let message = message?;
        let image: Image = message.decode()?;
        let side = usize::from(*message.topic == *topics[1]);
        sides[side].insert(image.header.stamp, image);
    }
    Ok(sides)
}

/// Images of `b` that are byte for byte the image of the same camera and stamp in `a`.
pub fn identical_images(a: &RectifiedPair, b: &RectifiedPair) -> usize {
    a.iter()
        .zip(b)
        .map(|(a, b)| {
            b.iter()
                .filter(|(stamp, image)| a.get(stamp).is_some_and(|o| o.data == image.data))
                .count()
        })
        .sum()
}
