//! `stereocal synth --scene depth | depth-walls`: rectified stereo pairs of textured
//! 3D scenes with their exact disparity, the test bed of dense stereo matching.
//!
//! Writes `<out>/bag` (`/stereo/{left,right}/image_rect` mono8 and
//! `/stereo/{left,right}/camera_info` of the rectified pair, 10 frames per second),
//! `<out>/left.yaml` and `<out>/right.yaml`, and per frame the left image's truth in
//! `<out>/truth/`: `frame_NNN_disparity.pfm` (32-bit float disparity, NaN where the
//! ray meets nothing; PFM as Middlebury's benchmark stores it) and
//! `frame_NNN_visible.png` (255 where the right camera sees the same point), listed in
//! `<out>/depth_truth.json`.

use std::path::Path;

use anyhow::{Context, bail};
use image::ImageEncoder;
use nalgebra::{Matrix3, Matrix3x4};
use serde::Serialize;
use stereocal_msgs::atomic_file;
use stereocal_msgs::builtin_interfaces::Time;
use stereocal_msgs::camera_info_file::CameraInfoFile;
use stereocal_msgs::sensor_msgs::{CameraInfo, Image as ImageMsg};
use stereocal_msgs::std_msgs::Header;
use stereocal_msgs::stereo_msgs::DisparityImage;
use stereocal_rosbag::{BagWriter, OfferedQos, WriterOptions};
use stereocal_vision::camera::{CameraModel, Distortion, Intrinsics};
use stereocal_vision::synth::depth::{DepthRig, DepthScene, DisparityTruth, PairPhotometry};

use crate::convert::{CalibratedCamera, Encoding, info_from_calibrated, msg_from_image};

/// Distances of the walls of `depth-walls`, metres.
pub const WALL_DISTANCES: [f64; 10] = [0.3, 0.4, 0.5, 0.75, 1.0, 1.25, 1.5, 2.0, 2.5, 3.0];
/// Time between frames, seconds.
const FRAME_PERIOD_S: f64 = 0.1;

/// Which depth scenes to render.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DepthScenes {
    /// `frames` rooms: boxes, a slanted board, a floor, thin poles and a weakly
    /// textured panel before a wall, each frame with its own textures.
    Rooms { frames: usize },
    /// A textured wall facing the rig at each of [`WALL_DISTANCES`].
    Walls,
}

/// Ground truth of a depth bag: the rig and where each frame's truth is.
#[derive(Debug, Serialize)]
pub struct DepthGroundTruth {
    /// Image width, pixels.
    pub width: usize,
    /// Image height, pixels.
    pub height: usize,
    /// Focal length of both rectified cameras, pixels.
    pub focal: f64,
    /// Principal point of both, pixels.
    pub cx: f64,
    /// Principal point of both, pixels.
    pub cy: f64,
    /// Baseline, metres.
    pub baseline: f64,
    /// The frames, in bag order.
    pub frames: Vec<DepthFrameRecord>,
}

/// Truth of one frame of a depth bag.
#[derive(Debug, Serialize)]
pub struct DepthFrameRecord {
    /// Index in the bag.
    pub index: usize,
    /// Stamp of both images, nanoseconds.
    pub stamp_ns: u64,
    /// Distance of the wall, metres (`depth-walls` only).
    pub distance: Option<f64>,
    /// Disparity file, relative to the output directory.
    pub disparity: String,
    /// Visibility mask, relative to the output directory.
    pub visible: String,
}

/// Renders `scenes` through `rig` into `out`, seeded by `seed`.
pub fn run(scenes: DepthScenes, rig: DepthRig, seed: u64, out: &Path) -> anyhow::Result<()> {
    if rig.width < 64 || rig.height < 48 {
        bail!(
            "a depth scene needs at least 64x48 pixels, got {}x{}",
            rig.width,
            rig.height
        );
    }
    let frames: Vec<(DepthScene, Option<f64>)> = match scenes {
        DepthScenes::Rooms { frames } => (0..frames as u64)
            .map(|i| (DepthScene::standard(rig, seed.wrapping_add(i)), None))
            .collect(),
        DepthScenes::Walls => WALL_DISTANCES
            .iter()
            .enumerate()
            .map(|(i, &d)| {
                (
                    DepthScene::wall(rig, d, seed.wrapping_add(i as u64)),
                    Some(d),
                )
            })
            .collect(),
    };
    let truth_dir = out.join("truth");
    std::fs::create_dir_all(&truth_dir)
        .with_context(|| format!("cannot create {}", truth_dir.display()))?;
    let cameras = rectified_pair(&rig);
    for (name, camera) in ["left", "right"].iter().zip(&cameras) {
        let file = CameraInfoFile {
            camera_name: (*name).to_owned(),
            info: info_from_calibrated(camera, Header::default()),
        };
        let path = out.join(format!("{name}.yaml"));
        file.write(&path)
            .with_context(|| format!("cannot write {}", path.display()))?;
    }

    let bag_path = out.join("bag");
    let options = WriterOptions {
        overwrite: true,
        ..WriterOptions::default()
    };
    let mut bag = BagWriter::create_with(&bag_path, options)
        .with_context(|| format!("cannot create the bag {}", bag_path.display()))?;
    let qos = OfferedQos::default();
    let mut topics = Vec::new();
    for name in ["left", "right"] {
        let image =
            bag.add_message_topic::<ImageMsg>(&format!("/stereo/{name}/image_rect"), &qos)?;
        let info =
            bag.add_message_topic::<CameraInfo>(&format!("/stereo/{name}/camera_info"), &qos)?;
        topics.push((image, info));
    }
    let (cx, cy) = frames
        .first()
        .map(|(scene, _)| scene.principal_point())
        .unwrap_or_default();
    let mut truth = DepthGroundTruth {
        width: rig.width,
        height: rig.height,
        focal: rig.focal,
        cx,
        cy,
        baseline: rig.baseline,
        frames: Vec::new(),
    };
    for (index, (scene, distance)) in frames.iter().enumerate() {
        let pair = scene.render(&PairPhotometry::realistic(), seed ^ (index as u64) << 32);
        let stamp_ns = ((1.0 + index as f64 * FRAME_PERIOD_S) * 1e9).round() as u64;
        let stamp = Time {
            sec: (stamp_ns / 1_000_000_000) as i32,
            nanosec: (stamp_ns % 1_000_000_000) as u32,
        };
        for ((name, image), ((image_topic, info_topic), camera)) in
            [("left", &pair.left), ("right", &pair.right)]
                .into_iter()
                .zip(topics.iter().zip(&cameras))
        {
            let header = Header {
                stamp,
                frame_id: format!("{name}_optical_frame"),
            };
            bag.write_message(
                *image_topic,
                stamp_ns,
                &msg_from_image(image, Encoding::Mono8, header.clone())?,
            )?;
            bag.write_message(*info_topic, stamp_ns, &info_from_calibrated(camera, header))?;
        }
        let disparity = format!("truth/frame_{index:03}_disparity.pfm");
        let visible = format!("truth/frame_{index:03}_visible.png");
        write_pfm(&out.join(&disparity), &pair.truth)?;
        write_visible(&out.join(&visible), &pair.truth)?;
        truth.frames.push(DepthFrameRecord {
            index,
            stamp_ns,
            distance: *distance,
            disparity,
            visible,
        });
    }
    bag.finish()
        .with_context(|| format!("cannot finish the bag {}", bag_path.display()))?;
    let mut json = serde_json::to_vec_pretty(&truth)?;
    json.push(b'\n');
    let path = out.join("depth_truth.json");
    atomic_file::write(&path, &json).with_context(|| format!("cannot write {}", path.display()))?;
    eprintln!(
        "wrote {} stereo depth frames ({}x{}, f {} px, baseline {} m) to {}",
        truth.frames.len(),
        rig.width,
        rig.height,
        rig.focal,
        rig.baseline,
        out.display()
    );
    Ok(())
}

/// The two cameras of a rectified rig: no distortion, `R = I`, the right one `baseline`
/// metres along x (`P[0][3] = -f * baseline`).
pub fn rectified_pair(rig: &DepthRig) -> [CalibratedCamera; 2] {
    let (cx, cy) = (
        (rig.width as f64 - 1.0) / 2.0,
        (rig.height as f64 - 1.0) / 2.0,
    );
    let model = CameraModel {
        width: rig.width as u32,
        height: rig.height as u32,
        intrinsics: Intrinsics {
            fx: rig.focal,
            fy: rig.focal,
            cx,
            cy,
        },
        distortion: Distortion::none(),
    };
    let projection = |tx: f64| {
        Matrix3x4::new(
            rig.focal, 0.0, cx, tx, 0.0, rig.focal, cy, 0.0, 0.0, 0.0, 1.0, 0.0,
        )
    };
    [0.0, -rig.focal * rig.baseline].map(|tx| CalibratedCamera {
        model: model.clone(),
        rectified_from_camera: Matrix3::identity(),
        projection: projection(tx),
    })
}

/// Writes the disparity of `truth` as a little-endian PFM (rows bottom to top), atomically.
fn write_pfm(path: &Path, truth: &DisparityTruth) -> anyhow::Result<()> {
    let mut bytes = format!("Pf\n{} {}\n-1.0\n", truth.width, truth.height).into_bytes();
    for row in truth.disparity.chunks(truth.width.max(1)).rev() {
        for value in row {
            bytes.extend_from_slice(&value.to_le_bytes());
        }
    }
    atomic_file::write(path, &bytes).with_context(|| format!("cannot write {}", path.display()))
}

/// Writes the visibility mask of `truth` as an 8-bit PNG (255 visible), atomically.
fn write_visible(path: &Path, truth: &DisparityTruth) -> anyhow::Result<()> {
    let mask: Vec<u8> = truth
        .visible
        .iter()
        .map(|&v| if v { 255 } else { 0 })
        .collect();
    let mut bytes = Vec::new();
    image::codecs::png::PngEncoder::new(&mut bytes)
        .write_image(
            &mask,
            truth.width as u32,
            truth.height as u32,
            image::ExtendedColorType::L8,
        )
        .with_context(|| format!("cannot encode {}", path.display()))?;
    atomic_file::write(path, &bytes).with_context(|| format!("cannot write {}", path.display()))
}

/// The truth of one frame of a depth scene, read back from the files [`run`] writes.
pub struct FrameTruth {
    /// Width, pixels.
    pub width: usize,
    /// Disparity per pixel, rows top to bottom.
    pub disparity: Vec<f32>,
    /// Whether the right camera sees each pixel's point.
    pub visible: Vec<bool>,
}

/// Errors of a disparity map against a [`FrameTruth`], over the visible pixels.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DisparityScores {
    /// Fraction off by more than 1 px, invalid pixels counted.
    pub bad1: f64,
    /// Fraction off by more than 2 px, invalid pixels counted.
    pub bad2: f64,
    /// Mean absolute error of the valid pixels, pixels.
    pub epe: f64,
    /// Fraction of visible pixels with a disparity.
    pub density: f64,
}

/// The truth of frame `index` of the depth scene in `dir`.
pub fn read_truth(dir: &Path, index: usize) -> anyhow::Result<FrameTruth> {
    let pfm = dir.join(format!("truth/frame_{index:03}_disparity.pfm"));
    let bytes = std::fs::read(&pfm).with_context(|| format!("reading {}", pfm.display()))?;
    let mut parts = bytes.splitn(4, |&b| b == b'\n');
    let (magic, size, scale, data) = (parts.next(), parts.next(), parts.next(), parts.next());
    let size = size.and_then(|s| std::str::from_utf8(s).ok()).unwrap_or("");
    let (width, height) = size
        .split_once(' ')
        .and_then(|(w, h)| Some((w.parse::<usize>().ok()?, h.parse::<usize>().ok()?)))
        .with_context(|| format!("{}: no size line", pfm.display()))?;
    let data = data.unwrap_or_default();
    if magic != Some(b"Pf".as_slice())
        || scale != Some(b"-1.0".as_slice())
        || data.len() != width * height * 4
    {
        bail!(
            "{} is not a little-endian grey PFM of {width}x{height}",
            pfm.display()
        );
    }
    let mut disparity = vec![0.0; width * height];
    for (row, chunk) in data.chunks_exact(width * 4).enumerate() {
        for (x, v) in chunk.chunks_exact(4).enumerate() {
            disparity[(height - 1 - row) * width + x] =
                f32::from_le_bytes([v[0], v[1], v[2], v[3]]);
        }
    }
    let png = dir.join(format!("truth/frame_{index:03}_visible.png"));
    let mask = image::open(&png)
        .with_context(|| format!("reading {}", png.display()))?
        .into_luma8();
    if mask.dimensions() != (width as u32, height as u32) {
        bail!("{} is not {width}x{height}", png.display());
    }
    Ok(FrameTruth {
        width,
        disparity,
        visible: mask.as_raw().iter().map(|&v| v > 0).collect(),
    })
}

impl FrameTruth {
    /// The errors of `msg` (as `disparity_node` publishes it: invalid below
    /// `min_disparity`, shifted by the principal points' offset, 0 for these rigs).
    pub fn score(&self, msg: &DisparityImage) -> DisparityScores {
        let (mut seen, mut bad1, mut bad2, mut sum, mut valid) =
            (0usize, 0usize, 0usize, 0.0, 0usize);
        let values = msg
            .image
            .data
            .chunks_exact(4)
            .map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]]));
        for ((d, &t), &visible) in values.zip(&self.disparity).zip(&self.visible) {
            if !visible || t.is_nan() {
                continue;
            }
            seen += 1;
            if d < msg.min_disparity {
                bad1 += 1;
                bad2 += 1;
                continue;
            }
            let error = f64::from((d - t).abs());
            bad1 += usize::from(error > 1.0);
            bad2 += usize::from(error > 2.0);
            sum += error;
            valid += 1;
        }
        let fraction = |n: usize| n as f64 / seen.max(1) as f64;
        DisparityScores {
            bad1: fraction(bad1),
            bad2: fraction(bad2),
            epe: sum / valid.max(1) as f64,
            density: fraction(valid),
        }
    }
}
