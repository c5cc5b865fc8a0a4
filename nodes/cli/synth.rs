//! `stereocal synth`: renders a synthetic scene into a rosbag2 bag, with its ground
//! truth beside it (and, for stereo rigs, the true camera_info files).

use std::path::{Path, PathBuf};

use anyhow::{Context, bail};
use indicatif::{ProgressBar, ProgressStyle};
use nalgebra::Isometry3;
use stereocal_msgs::atomic_file;
use stereocal_msgs::builtin_interfaces::Time;
use stereocal_msgs::camera_info_file::CameraInfoFile;
use stereocal_msgs::geometry_msgs::{PoseStamped, TransformStamped};
use stereocal_msgs::sensor_msgs::{CameraInfo, Image as ImageMsg};
use stereocal_msgs::std_msgs::Header;
use stereocal_msgs::tf2_msgs::TFMessage;
use stereocal_vision::board::Target;
use stereocal_vision::camera::DistortionModel;
use stereocal_vision::rectify::{
    StereoRectification, StereoRectifyOptions, fisheye_stereo_rectify, stereo_rectify,
};
use stereocal_vision::synth::depth::DepthRig;
use stereocal_vision::synth::{
    Chessboard, GroundTruth, PixelFormat, RigLayout, RobotMotion, RobotNoise, Scene, SceneKind,
    SceneSpec, StampRecord,
};

use crate::cli::synth_depth::{self, DepthScenes};
use crate::convert::{
    CalibratedCamera, Encoding, info_from_calibrated, info_from_raw_camera, msg_from_image,
    pose_msg, transform_msg,
};
use stereocal_rosbag::{BagWriter, OfferedQos, TopicId, WriterOptions};

/// Largest robot stamp offset accepted, seconds.
const MAX_STAMP_OFFSET_S: f64 = 1000.0;
/// Frame of the robot's base in hand-eye bags.
const BASE_FRAME: &str = "base";
/// Frame of the robot's tool in hand-eye bags.
const TOOL_FRAME: &str = "tool";

/// Which scene to synthesize.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum SceneArg {
    /// A stereo rig looking at a chessboard in poses covering the view.
    Stereo,
    /// A stereo calibration session, about one frame in ten bad.
    Calibration,
    /// Eye-in-hand: camera on the robot's tool, board fixed.
    HandeyeInHand,
    /// Eye-to-hand: camera fixed, board on the robot's tool.
    HandeyeToHand,
    /// Rectified stereo pairs of rooms (boxes, a slanted board, a floor, thin poles, a
    /// weakly textured panel) with exact disparity truth, for dense stereo.
    Depth,
    /// Rectified stereo pairs of a textured wall from 0.3 to 3 m, with exact
    /// disparity truth.
    DepthWalls,
}

/// Lens model of the synthetic cameras.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum ModelArg {
    /// Brown-Conrady radial-tangential.
    #[value(name = "plumb_bob")]
    PlumbBob,
    /// Rational radial with tangential terms.
    #[value(name = "rational_polynomial")]
    RationalPolynomial,
    /// Fisheye equidistant.
    #[value(name = "equidistant")]
    Equidistant,
}

/// Arguments of `stereocal synth`.
#[derive(clap::Args, Debug)]
pub struct SynthArgs {
    /// Kind of scene.
    #[arg(long, value_enum)]
    pub scene: SceneArg,
    /// Output directory: receives `bag/` and `ground_truth.json` (and `left.yaml`,
    /// `right.yaml` for stereo rigs).
    #[arg(long)]
    pub out: PathBuf,
    /// Seed of every random choice: the same seed gives the same bytes.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Number of frames (default: 20 stereo, 25 calibration, 15 hand-eye, 3 depth;
    /// depth-walls has one per distance).
    #[arg(long)]
    pub frames: Option<usize>,
    /// Image width, pixels (default 1024; 640 for depth scenes, whose focal length
    /// scales with the width from 600 px at 640).
    #[arg(long)]
    pub width: Option<u32>,
    /// Image height, pixels (default 768; 480 for depth scenes).
    #[arg(long)]
    pub height: Option<u32>,
    /// Lens distortion model.
    #[arg(long, value_enum, default_value = "plumb_bob")]
    pub model: ModelArg,
    /// Fraction of bad frames (blurred, motion-blurred, partly out of view); default
    /// 0.1 for calibration, 0 otherwise.
    #[arg(long)]
    pub bad_frames: Option<f64>,
    /// Render rgb8 instead of mono8.
    #[arg(long)]
    pub rgb: bool,
    /// Stereo rigs: put the second camera below the first instead of beside it.
    #[arg(long)]
    pub vertical: bool,
    /// Hand-eye sessions: standard deviation of the robot's reported rotation about
    /// each axis, degrees (the true poses are in the ground truth).
    #[arg(long = "robot-rotation-noise", default_value_t = 0.05)]
    pub robot_rotation_noise: f64,
    /// Hand-eye sessions: standard deviation of the robot's reported position along
    /// each axis, millimetres.
    #[arg(long = "robot-translation-noise", default_value_t = 0.3)]
    pub robot_translation_noise: f64,
    /// Hand-eye sessions: the robot's stamps run this many seconds ahead of the
    /// camera's (a clock offset between the two streams; may be negative).
    #[arg(
        long = "robot-stamp-offset",
        default_value_t = 0.0,
        allow_hyphen_values = true
    )]
    pub robot_stamp_offset: f64,
}

/// Arguments of the `stereocal synth` command: the scene, and the target it shows.
#[derive(clap::Args, Debug)]
pub struct SynthCommand {
    /// The scene.
    #[command(flatten)]
    pub scene: SynthArgs,
    /// The target.
    #[command(flatten)]
    pub target: SynthTargetArgs,
}

/// The target a synthetic scene shows.
#[derive(clap::Args, Debug, Default)]
pub struct SynthTargetArgs {
    /// Target definition (`config/boards/*.yaml`: a chessboard, a ChArUco board or a
    /// circle grid), printed with a white margin of one square (one spacing); default:
    /// a 9x6 chessboard of 40 mm squares (30 mm for hand-eye).
    #[arg(long)]
    pub board: Option<PathBuf>,
}

impl SynthTargetArgs {
    /// The target read from `--board`, or `None` for the scene's default.
    pub fn target(&self) -> anyhow::Result<Option<Target>> {
        self.board
            .as_deref()
            .map(|path| {
                Target::from_yaml_file(path)
                    .with_context(|| format!("cannot use the board {}", path.display()))
            })
            .transpose()
    }
}

/// Runs `stereocal synth`: [`run`] with the target of `--board`.
pub fn run_command(command: &SynthCommand) -> anyhow::Result<()> {
    let target = command.target.target()?;
    run_with_target(&command.scene, target.as_ref())
}

impl SynthArgs {
    /// A `scene` of `frames` frames from `seed` into `out`, with every other option at
    /// its default (1024x768 mono8 plumb_bob, a horizontal rig, the scene's share of bad
    /// frames, robot noise of 0.05 degree and 0.3 mm).
    pub fn new(scene: SceneArg, out: PathBuf, seed: u64, frames: usize) -> Self {
        Self {
            scene,
            out,
            seed,
            frames: Some(frames),
            width: None,
            height: None,
            model: ModelArg::PlumbBob,
            bad_frames: None,
            rgb: false,
            vertical: false,
            robot_rotation_noise: 0.05,
            robot_translation_noise: 0.3,
            robot_stamp_offset: 0.0,
        }
    }

    /// The scene of `kind` these arguments describe.
    fn spec(&self, kind: SceneKind) -> SceneSpec {
        let defaults = SceneSpec::new(kind, self.seed);
        SceneSpec {
            frames: self.frames.unwrap_or(defaults.frames),
            width: self.width.unwrap_or(1024),
            height: self.height.unwrap_or(768),
            model: match self.model {
                ModelArg::PlumbBob => DistortionModel::PlumbBob,
                ModelArg::RationalPolynomial => DistortionModel::RationalPolynomial,
                ModelArg::Equidistant => DistortionModel::Equidistant,
            },
            bad_fraction: self.bad_frames.unwrap_or(defaults.bad_fraction),
            format: if self.rgb {
                PixelFormat::Rgb8
            } else {
                PixelFormat::Mono8
            },
            layout: if self.vertical {
                RigLayout::Vertical
            } else {
                RigLayout::Horizontal
            },
            robot_noise: RobotNoise {
                rotation_rad: self.robot_rotation_noise.to_radians(),
                translation_m: self.robot_translation_noise * 1e-3,
            },
            ..defaults
        }
    }
}

/// Renders the scene into `<out>/bag` and writes `<out>/ground_truth.json`; stereo rigs
/// also get `<out>/left.yaml` and `<out>/right.yaml` with their true rectification.
pub fn run(args: &SynthArgs) -> anyhow::Result<()> {
    run_with_target(args, None)
}

/// [`run`] with the scene showing `target` (`None`: the scene's default chessboard).
/// Ground truth lists every corner of the target; a corner is `visible` when it
/// projects into the image.
pub fn run_with_target(args: &SynthArgs, target: Option<&Target>) -> anyhow::Result<()> {
    if args.frames == Some(0) {
        bail!("--frames must be at least 1");
    }
    for (option, value) in [
        ("--robot-rotation-noise", args.robot_rotation_noise),
        ("--robot-translation-noise", args.robot_translation_noise),
    ] {
        if !(value.is_finite() && value >= 0.0) {
            bail!("{option} {value}: expected a number of at least 0");
        }
    }
    if !(args.robot_stamp_offset.is_finite() && args.robot_stamp_offset.abs() <= MAX_STAMP_OFFSET_S)
    {
        bail!(
            "--robot-stamp-offset {}: expected seconds between -{MAX_STAMP_OFFSET_S} and {MAX_STAMP_OFFSET_S}",
            args.robot_stamp_offset
        );
    }
    let kind = match args.scene {
        SceneArg::Stereo => SceneKind::Stereo,
        SceneArg::Calibration => SceneKind::Calibration,
        SceneArg::HandeyeInHand => SceneKind::HandEyeInHand,
        SceneArg::HandeyeToHand => SceneKind::HandEyeToHand,
        SceneArg::Depth | SceneArg::DepthWalls => return run_depth(args),
    };
    let mut spec = args.spec(kind);
    if let Some(target) = target {
        spec.board = Chessboard::from_target(target).context("cannot render the target")?;
    }
    let scene = Scene::generate(&spec).context("cannot make the scene")?;
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("cannot create {}", args.out.display()))?;
    write_bag(&scene, &args.out.join("bag"), args.robot_stamp_offset)?;
    write_json_atomically(&args.out.join("ground_truth.json"), scene.truth())?;
    if !spec.kind.is_hand_eye() {
        write_rectified_camera_infos(&scene, &args.out)?;
    }
    eprintln!(
        "wrote {} frames of scene {} to {}",
        scene.truth().frames.len(),
        spec.kind.name(),
        args.out.display()
    );
    Ok(())
}

/// Renders the depth scenes `args` ask for (`--scene depth` or `depth-walls`).
fn run_depth(args: &SynthArgs) -> anyhow::Result<()> {
    let scenes = if args.scene == SceneArg::DepthWalls {
        if args.frames.is_some() {
            bail!(
                "--frames does not apply to depth-walls: it has one frame per distance ({} m)",
                synth_depth::WALL_DISTANCES
                    .map(|d| d.to_string())
                    .join(", ")
            );
        }
        DepthScenes::Walls
    } else {
        DepthScenes::Rooms {
            frames: args.frames.unwrap_or(3),
        }
    };
    let rig = DepthRig::WEBCAMS;
    let rig = rig.with_size(
        args.width.map_or(rig.width, |w| w as usize),
        args.height.map_or(rig.height, |h| h as usize),
    );
    synth_depth::run(scenes, rig, args.seed, &args.out)
}

/// Image and camera_info topics of a camera in the scene.
fn camera_topics(kind: SceneKind, camera: &str) -> (String, String) {
    let ns = if kind.is_hand_eye() {
        "/camera".to_owned()
    } else {
        format!("/stereo/{camera}")
    };
    (format!("{ns}/image_raw"), format!("{ns}/camera_info"))
}

/// A message time in nanoseconds from a time in seconds.
fn nanos(seconds: f64) -> anyhow::Result<u64> {
    if seconds.is_finite() && seconds >= 0.0 {
        Ok((seconds * 1e9).round() as u64)
    } else {
        bail!("time {seconds} s before 1970")
    }
}

/// A ROS stamp from a time in seconds (at least 0).
fn stamp_of(seconds: f64) -> anyhow::Result<Time> {
    let ns = nanos(seconds)?;
    Ok(Time {
        sec: i32::try_from(ns / 1_000_000_000).context("stamp beyond 2038")?,
        nanosec: (ns % 1_000_000_000) as u32,
    })
}

/// Renders the scene's frames into a bag at `path`; a hand-eye scene's robot poses
/// follow [`RobotMotion::DEFAULT`], stamped `robot_stamp_offset` seconds ahead of the
/// camera.
fn write_bag(scene: &Scene, path: &Path, robot_stamp_offset: f64) -> anyhow::Result<()> {
    let truth = scene.truth();
    let kind = scene.spec().kind;
    let options = WriterOptions {
        overwrite: true,
        ..WriterOptions::default()
    };
    let mut bag = BagWriter::create_with(path, options)
        .with_context(|| format!("cannot create the bag {}", path.display()))?;
    let qos = OfferedQos::default();
    let mut topics = Vec::new();
    for camera in &truth.cameras {
        let (image_topic, info_topic) = camera_topics(kind, &camera.name);
        let image = bag.add_message_topic::<ImageMsg>(&image_topic, &qos)?;
        let info = bag.add_message_topic::<CameraInfo>(&info_topic, &qos)?;
        topics.push((image, info));
    }
    let robot = if kind.is_hand_eye() {
        Some((
            bag.add_message_topic::<PoseStamped>("/robot/tool_pose", &qos)?,
            bag.add_message_topic::<TFMessage>("/tf", &qos)?,
        ))
    } else {
        None
    };
    let encoding = match scene.spec().format {
        PixelFormat::Mono8 => Encoding::Mono8,
        PixelFormat::Rgb8 => Encoding::Rgb8,
    };
    // A stereo rig is recorded calibrated: its camera_info carry the rectification, as
    // a calibrated stereo camera's driver publishes them. Other scenes carry the raw
    // cameras (R = I, P = [K|0]).
    let rectified = if kind == SceneKind::Stereo {
        Some(rectified_cameras(scene)?)
    } else {
        None
    };
    let cameras: Vec<_> = scene.cameras().cloned().collect();
    let camera_info = |index: usize, header: Header| match &rectified {
        Some(rectified) => info_from_calibrated(&rectified[index], header),
        None => info_from_raw_camera(&cameras[index], header),
    };

    let progress = ProgressBar::new(truth.frames.len() as u64);
    if let Ok(style) = ProgressStyle::with_template("{bar:40} {pos}/{len} frames {elapsed}") {
        progress.set_style(style);
    }
    // The robot publishes the poses it reports, not the true ones.
    let waypoints: Vec<(f64, Isometry3<f64>)> = truth
        .frames
        .iter()
        .filter_map(|frame| {
            let reported = frame
                .reported_base_from_tool
                .as_ref()
                .or(frame.base_from_tool.as_ref())?;
            Some((stamp_seconds(&frame.stamp), reported.isometry()))
        })
        .collect();
    let mut robot_poses = RobotMotion::DEFAULT
        .stream(&waypoints)
        .into_iter()
        .peekable();
    for frame in &truth.frames {
        let stamp = ros_time(&frame.stamp);
        let seconds = stamp_seconds(&frame.stamp);
        let log_time = u64::try_from(stamp.as_nanos()).context("stamp before 1970")?;
        // The robot's poses up to the frame go first, as they were recorded.
        if let Some(topics) = robot {
            while let Some((t, base_from_tool)) = robot_poses.next_if(|(t, _)| *t < seconds) {
                write_robot_pose(&mut bag, topics, t, robot_stamp_offset, &base_from_tool)?;
            }
        }
        let images = scene
            .render_frame(frame.index)
            .context("frame index out of range")?;
        for (index, ((image, record), (image_topic, info_topic))) in
            images.iter().zip(&truth.cameras).zip(&topics).enumerate()
        {
            let header = Header {
                stamp,
                frame_id: format!("{}_optical_frame", record.name),
            };
            let message = msg_from_image(image, encoding, header.clone())?;
            bag.write_message(*image_topic, log_time, &message)?;
            bag.write_message(*info_topic, log_time, &camera_info(index, header))?;
        }
        if let Some(topics) = robot {
            while let Some((t, base_from_tool)) = robot_poses.next_if(|(t, _)| *t <= seconds) {
                write_robot_pose(&mut bag, topics, t, robot_stamp_offset, &base_from_tool)?;
            }
        }
        progress.inc(1);
    }
    if let Some(topics) = robot {
        for (t, base_from_tool) in robot_poses {
            write_robot_pose(&mut bag, topics, t, robot_stamp_offset, &base_from_tool)?;
        }
    }
    progress.finish_and_clear();
    bag.finish()
        .with_context(|| format!("cannot finish the bag {}", path.display()))?;
    Ok(())
}

/// Writes the robot's pose at time `t` (seconds) on its PoseStamped topic and `/tf`,
/// stamped `offset` seconds later.
fn write_robot_pose(
    bag: &mut BagWriter,
    (pose_topic, tf_topic): (TopicId, TopicId),
    t: f64,
    offset: f64,
    base_from_tool: &Isometry3<f64>,
) -> anyhow::Result<()> {
    let log_time = nanos(t)?;
    let header = Header {
        stamp: stamp_of(t + offset)?,
        frame_id: BASE_FRAME.to_owned(),
    };
    let pose = PoseStamped {
        header: header.clone(),
        pose: pose_msg(base_from_tool),
    };
    bag.write_message(pose_topic, log_time, &pose)?;
    let tf = TFMessage {
        transforms: vec![TransformStamped {
            header,
            child_frame_id: TOOL_FRAME.to_owned(),
            transform: transform_msg(base_from_tool),
        }],
    };
    bag.write_message(tf_topic, log_time, &tf)?;
    Ok(())
}

fn stamp_seconds(stamp: &StampRecord) -> f64 {
    f64::from(stamp.sec) + f64::from(stamp.nanosec) * 1e-9
}

fn ros_time(stamp: &StampRecord) -> Time {
    Time {
        sec: stamp.sec,
        nanosec: stamp.nanosec,
    }
}

/// Writes `value` as pretty JSON to `path`, atomically.
fn write_json_atomically(path: &Path, value: &GroundTruth) -> anyhow::Result<()> {
    let mut json = serde_json::to_vec_pretty(value)?;
    json.push(b'\n');
    atomic_file::write(path, &json).with_context(|| format!("cannot write {}", path.display()))
}

/// The cameras of a stereo scene with the R and P of the rig's stereo rectification
/// (OpenCV defaults; balance 0 for fisheye): what a calibrated rig's camera_info carry.
fn rectified_cameras(scene: &Scene) -> anyhow::Result<[CalibratedCamera; 2]> {
    let truth = scene.truth();
    let cameras: Vec<_> = scene.cameras().cloned().collect();
    let (Some(left), Some(right), Some(right_from_left)) = (
        cameras.first(),
        cameras.get(1),
        truth.extrinsics.right_from_left.as_ref(),
    ) else {
        bail!("a stereo scene needs two cameras and right_from_left");
    };
    let right_from_left = right_from_left.isometry();
    let rectification: StereoRectification =
        if left.distortion.model() == DistortionModel::Equidistant {
            fisheye_stereo_rectify(left, right, &right_from_left, true, 0.0, None, 1.0)?
        } else {
            stereo_rectify(
                left,
                right,
                &right_from_left,
                &StereoRectifyOptions::default(),
            )?
        };
    Ok([
        CalibratedCamera {
            model: left.clone(),
            rectified_from_camera: rectification.left_rectified_from_original.into_inner(),
            projection: rectification.left_projection,
        },
        CalibratedCamera {
            model: right.clone(),
            rectified_from_camera: rectification.right_rectified_from_original.into_inner(),
            projection: rectification.right_projection,
        },
    ])
}

/// `left.yaml` and `right.yaml`: the true intrinsics and distortion with the R and P of
/// the rig's stereo rectification.
fn write_rectified_camera_infos(scene: &Scene, out: &Path) -> anyhow::Result<()> {
    for (name, camera) in ["left", "right"].into_iter().zip(rectified_cameras(scene)?) {
        let file = CameraInfoFile {
            camera_name: name.to_owned(),
            info: info_from_calibrated(&camera, Header::default()),
        };
        let path = out.join(format!("{name}.yaml"));
        file.write(&path)
            .with_context(|| format!("cannot write {}", path.display()))?;
    }
    Ok(())
}
