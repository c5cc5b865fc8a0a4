//! Target pose: the pose stage on synthetic frames of every lens model against ground
//! truth and on bad input, `stereocal pose` on a bag, and `pose_node` over DDS.

mod cli;
mod node;
mod stage;

use std::path::{Path, PathBuf};

use nalgebra::Isometry3;
use stereocal::cli::synth::{ModelArg, SceneArg, SynthArgs};
use stereocal_msgs::sensor_msgs::{CameraInfo, Image};
use stereocal_rosbag::{BagReader, TopicFilter};
use stereocal_vision::board::Target;
use stereocal_vision::synth::GroundTruth;

use crate::common;

/// The image and camera_info topics of a hand-eye scene.
pub const IMAGE_TOPIC: &str = "/camera/image_raw";
/// See [`IMAGE_TOPIC`].
pub const INFO_TOPIC: &str = "/camera/camera_info";

/// A rendered eye-in-hand session: where its bag is, its truth and its frames.
pub struct Session {
    /// The directory `stereocal synth` wrote.
    pub dir: tempfile::TempDir,
    /// Ground truth.
    pub truth: GroundTruth,
    /// Image and camera_info of every frame, in stamp order.
    pub frames: Vec<(Image, CameraInfo)>,
}

impl Session {
    /// The bag.
    pub fn bag(&self) -> PathBuf {
        self.dir.path().join("bag")
    }

    /// The true `camera_from_target` of frame `index`.
    pub fn truth_pose(&self, index: usize) -> Isometry3<f64> {
        self.truth.frames[index].views[0]
            .camera_from_target
            .isometry()
    }
}

/// Renders an eye-in-hand session of `frames` frames through `model` showing `target`
/// (`None`: the 9x6 chessboard of 30 mm squares) with `bad_frames` of them blurred.
pub fn session(
    seed: u64,
    frames: usize,
    model: ModelArg,
    bad_frames: f64,
    target: Option<&Target>,
) -> Session {
    let dir = tempfile::tempdir().expect("temp dir");
    let args = SynthArgs {
        model,
        bad_frames: Some(bad_frames),
        ..SynthArgs::new(
            SceneArg::HandeyeInHand,
            dir.path().to_path_buf(),
            seed,
            frames,
        )
    };
    let truth = common::synthesize_session(&args, target);
    let frames = read_frames(&dir.path().join("bag"));
    assert_eq!(frames.len(), truth.frames.len());
    Session { dir, truth, frames }
}

/// The (image, camera_info) pairs of a hand-eye bag, in stamp order.
pub fn read_frames(bag: &Path) -> Vec<(Image, CameraInfo)> {
    let reader = BagReader::open(bag).expect("bag");
    let read = |topic: &str| -> Vec<_> {
        reader
            .messages(&TopicFilter::only([topic]))
            .map(|m| m.expect("message").data)
            .collect()
    };
    let images = read(IMAGE_TOPIC);
    let infos = read(INFO_TOPIC);
    images
        .iter()
        .zip(&infos)
        .map(|(image, info)| {
            (
                stereocal_msgs::cdr::from_bytes(image).expect("image"),
                stereocal_msgs::cdr::from_bytes(info).expect("camera_info"),
            )
        })
        .collect()
}

/// Rotation (degrees) and translation (millimetres) between two poses.
pub fn pose_error(estimate: &Isometry3<f64>, truth: &Isometry3<f64>) -> (f64, f64) {
    let delta = estimate.inverse() * truth;
    (
        delta.rotation.angle().to_degrees(),
        (estimate.translation.vector - truth.translation.vector).norm() * 1e3,
    )
}
