//! `stereocal handeye`: hand-eye calibration of a recorded session. The target's poses
//! come from the images (found as `stereocal pose` finds them) or from a topic of poses
//! already measured (`camera_from_target`, geometry_msgs/PoseStamped); each is paired by
//! stamp with the robot's pose (`base_from_tool`, PoseStamped), interpolated at that
//! stamp. Every method of `vision::handeye` solves the pairs after leaving out those
//! that disagree; the result with the least median residual is chosen, and with images
//! it starts the joint refinement on the target's pixels, which is then chosen. Writes
//! `DIR/handeye.yaml` and `DIR/report.html` atomically; with `--json`, prints the same
//! report on stdout.

use std::path::PathBuf;

use anyhow::{Context, bail};
use indicatif::ProgressBar;
use nalgebra::Isometry3;
use stereocal_msgs::RosMessage;
use stereocal_msgs::atomic_file;
use stereocal_msgs::cdr;
use stereocal_msgs::geometry_msgs::PoseStamped;
use stereocal_msgs::tf2_msgs::TFMessage;
use stereocal_rosbag::{BagMessage, BagReader, TopicFilter};
use stereocal_vision::board::PatternArgs;
use stereocal_vision::camera::CameraModel;
use stereocal_vision::handeye::{RefineOptions, Sample, Setup, TargetObservation};
use stereocal_vision::pnp::PoseOptions;

use super::calibrate::CharucoArgs;
use super::pose::FrameInput;
use crate::convert::isometry_from_pose_msg;
use crate::handeye::page::html;
use crate::handeye::report::{FramesRecord, HandEyeReport, RejectedRecord};
use crate::handeye::session::{FIRST_PIXEL_NOISE_PX, SessionSample, Weights, calibrate_session};
use crate::pose::record::seconds;
use crate::pose::stage::PoseStage;
use crate::tf_buffer::{PoseTrack, TfBuffer};

/// Where the camera is.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum SetupArg {
    /// The camera rides on the robot's tool; the target stands still.
    EyeInHand,
    /// The camera stands still; the target rides on the robot's tool.
    EyeToHand,
}

impl From<SetupArg> for Setup {
    fn from(setup: SetupArg) -> Self {
        match setup {
            SetupArg::EyeInHand => Setup::EyeInHand,
            SetupArg::EyeToHand => Setup::EyeToHand,
        }
    }
}

/// Arguments of `stereocal handeye`.
#[derive(clap::Args, Debug, Clone)]
pub struct HandEyeArgs {
    /// Input rosbag2 bag: a directory with metadata.yaml or a .mcap file.
    #[arg(long)]
    pub bag: PathBuf,
    /// Where the camera is.
    #[arg(long, value_enum)]
    pub setup: SetupArg,
    /// Topic of the target's poses already measured in the camera frame
    /// (geometry_msgs/PoseStamped), e.g. what `stereocal pose` adds as
    /// `<ns>/target_pose`. Instead of the images.
    #[arg(long = "target-pose-topic", conflicts_with = "image_topic")]
    pub target_pose_topic: Option<String>,
    /// Image topic to find the target in; its camera_info is `<ns>/camera_info` or
    /// `--camera-info`. The target's pixels then also drive the joint refinement.
    #[arg(long = "image-topic")]
    pub image_topic: Option<String>,
    /// Calibration from a camera_calibration_parsers YAML or INI file, used instead of
    /// the bag's `<ns>/camera_info`.
    #[arg(long = "camera-info")]
    pub camera_info: Option<PathBuf>,
    /// Target kind, as ROS camera_calibration: chessboard, charuco, circles or acircles.
    #[arg(long, default_value = "chessboard")]
    pub pattern: String,
    /// Inner corners of the chessboard, squares of the ChArUco board, or circles per row
    /// and rows of a circle grid, COLSxROWS.
    #[arg(long)]
    pub size: Option<String>,
    /// Side of one square, metres.
    #[arg(long)]
    pub square: Option<String>,
    /// The markers of a ChArUco board.
    #[command(flatten)]
    pub charuco: CharucoArgs,
    /// Topic of the robot's tool poses in its base frame (geometry_msgs/PoseStamped).
    #[arg(
        long = "robot-pose-topic",
        conflicts_with = "tf",
        required_unless_present = "tf"
    )]
    pub robot_pose_topic: Option<String>,
    /// The robot's poses from the bag's `/tf` and `/tf_static` instead: `BASE:TOOL`,
    /// the frames whose transform `base_from_tool` is looked up at each stamp.
    #[arg(long)]
    pub tf: Option<String>,
    /// The robot's tool frame, for the report when the poses come from a topic
    /// (PoseStamped does not name it).
    #[arg(long = "tool-frame", default_value = "tool")]
    pub tool_frame: String,
    /// A target pose is paired only with robot poses this close on both sides of its
    /// stamp, seconds.
    #[arg(long = "max-time-difference", default_value_t = 0.02)]
    pub max_time_difference: f64,
    /// Standard deviation of a detected corner coordinate, pixels (the joint
    /// refinement's weight of the corners against the robot). Default: measured, the
    /// refinement run once with 0.2 px and again with the noise its residuals show (at
    /// least 0.01 px).
    #[arg(long = "pixel-noise")]
    pub pixel_noise: Option<f64>,
    /// Standard deviation of the robot's reported rotation, degrees.
    #[arg(long = "robot-rotation-noise", default_value_t = 0.05)]
    pub robot_rotation_noise: f64,
    /// Standard deviation of the robot's reported position, millimetres.
    #[arg(long = "robot-translation-noise", default_value_t = 0.3)]
    pub robot_translation_noise: f64,
    /// Output directory: handeye.yaml is written there.
    #[arg(long)]
    pub out: PathBuf,
    /// Print the report as one JSON object on stdout.
    #[arg(long)]
    pub json: bool,
}

impl HandEyeArgs {
    /// The arguments for a session of `setup` in `bag` whose target poses are on
    /// `target_pose_topic` and robot poses on `robot_pose_topic`, written to `out`, with
    /// every other option at its default.
    pub fn from_poses(
        bag: PathBuf,
        setup: SetupArg,
        target_pose_topic: &str,
        robot_pose_topic: &str,
        out: PathBuf,
    ) -> Self {
        Self {
            target_pose_topic: Some(target_pose_topic.to_owned()),
            ..Self::defaults(bag, setup, robot_pose_topic, out)
        }
    }

    /// The arguments for a session of `setup` in `bag` whose images on `image_topic`
    /// show a `cols x rows` chessboard (inner corners) of `square` metres, and whose
    /// robot poses are on `robot_pose_topic`, written to `out`, with every other option
    /// at its default.
    pub fn from_images(
        bag: PathBuf,
        setup: SetupArg,
        image_topic: &str,
        (cols, rows, square): (usize, usize, f64),
        robot_pose_topic: &str,
        out: PathBuf,
    ) -> Self {
        Self {
            image_topic: Some(image_topic.to_owned()),
            size: Some(format!("{cols}x{rows}")),
            square: Some(square.to_string()),
            ..Self::defaults(bag, setup, robot_pose_topic, out)
        }
    }

    fn defaults(bag: PathBuf, setup: SetupArg, robot_pose_topic: &str, out: PathBuf) -> Self {
        Self {
            bag,
            setup,
            target_pose_topic: None,
            image_topic: None,
            camera_info: None,
            pattern: "chessboard".to_owned(),
            size: None,
            square: None,
            charuco: CharucoArgs::default(),
            robot_pose_topic: Some(robot_pose_topic.to_owned()),
            tf: None,
            tool_frame: "tool".to_owned(),
            max_time_difference: 0.02,
            pixel_noise: None,
            robot_rotation_noise: 0.05,
            robot_translation_noise: 0.3,
            out,
            json: false,
        }
    }

    fn weights(&self) -> anyhow::Result<Weights> {
        for (option, value) in [
            (
                "--pixel-noise",
                self.pixel_noise.unwrap_or(FIRST_PIXEL_NOISE_PX),
            ),
            ("--robot-rotation-noise", self.robot_rotation_noise),
            ("--robot-translation-noise", self.robot_translation_noise),
        ] {
            if !(value.is_finite() && value > 0.0) {
                bail!("{option} {value}: expected a positive number");
            }
        }
        Ok(Weights {
            refine: RefineOptions {
                pixel_noise_px: self.pixel_noise.unwrap_or(FIRST_PIXEL_NOISE_PX),
                robot_rotation_noise_rad: self.robot_rotation_noise.to_radians(),
                robot_translation_noise_m: self.robot_translation_noise * 1e-3,
            },
            measure_pixel_noise: self.pixel_noise.is_none(),
        })
    }
}

/// Runs `stereocal handeye`.
pub fn run(args: &HandEyeArgs) -> anyhow::Result<()> {
    let report = handeye_bag(args)?;
    if args.json {
        println!(
            "{}",
            serde_json::to_string(&report).context("encoding the report")?
        );
    } else {
        print_human(&report);
    }
    Ok(())
}

/// A target pose read or found, with the pixels it came from when found in an image.
struct TargetPose {
    stamp: f64,
    camera_from_target: Isometry3<f64>,
    observation: Option<(TargetObservation, CameraModel)>,
}

/// `base_from_tool` at a stamp (seconds), or why there is none.
type RobotLookup = Box<dyn Fn(f64) -> Result<Isometry3<f64>, String>>;

/// Where the robot's poses come from, and what has been read of them.
enum Robot {
    /// A PoseStamped topic.
    Topic {
        topic: String,
        poses: Vec<(f64, Isometry3<f64>)>,
    },
    /// `/tf` and `/tf_static`, looked up from `base` to `tool`.
    Tf {
        buffer: TfBuffer,
        base: String,
        tool: String,
    },
}

impl Robot {
    fn new(args: &HandEyeArgs) -> anyhow::Result<Self> {
        match (&args.robot_pose_topic, &args.tf) {
            (Some(topic), None) => Ok(Self::Topic {
                topic: topic.clone(),
                poses: Vec::new(),
            }),
            (None, Some(frames)) => match frames.split_once(':') {
                Some((base, tool)) if !base.is_empty() && !tool.is_empty() => Ok(Self::Tf {
                    buffer: TfBuffer::default(),
                    base: base.to_owned(),
                    tool: tool.to_owned(),
                }),
                _ => bail!("--tf {frames}: expected BASE:TOOL, two frame names"),
            },
            _ => bail!("give --robot-pose-topic or --tf, one of them"),
        }
    }

    /// The topics to read.
    fn topics(&self) -> Vec<&str> {
        match self {
            Self::Topic { topic, .. } => vec![topic.as_str()],
            Self::Tf { .. } => vec!["/tf", "/tf_static"],
        }
    }

    /// Keeps what a message of the robot's topics says; returns the frame of a pose
    /// read from a topic (the base frame).
    fn read(&mut self, message: &BagMessage) -> Option<String> {
        match self {
            Self::Topic { topic, poses } if *message.topic == *topic => {
                let (stamp, base_from_tool, frame) = pose_of(message)?;
                poses.push((stamp, base_from_tool));
                Some(frame)
            }
            Self::Tf { buffer, .. } if matches!(&*message.topic, "/tf" | "/tf_static") => {
                let is_static = &*message.topic == "/tf_static";
                match cdr::from_bytes::<TFMessage>(&message.data) {
                    Ok(tf) => {
                        for t in &tf.transforms {
                            if let Err(e) = buffer.insert(t, is_static) {
                                eprintln!("skipped a transform on {}: {e}", message.topic);
                            }
                        }
                    }
                    Err(e) => eprintln!(
                        "skipped an undecodable {} message at log time {} ns: {e}",
                        message.topic, message.log_time_ns
                    ),
                }
                None
            }
            _ => None,
        }
    }

    /// `base_from_tool` at each stamp: interpolated from the topic's poses or looked up
    /// in TF, within `max_gap` seconds on both sides.
    fn into_lookup(self, max_gap: f64) -> anyhow::Result<RobotLookup> {
        Ok(match self {
            Self::Topic { topic, poses } => {
                if poses.is_empty() {
                    bail!("no robot pose on {topic}");
                }
                let track = PoseTrack::new(poses);
                Box::new(move |stamp| track.at(stamp, max_gap))
            }
            Self::Tf { buffer, base, tool } => {
                buffer
                    .connects(&base, &tool)
                    .with_context(|| format!("--tf {base}:{tool}"))?;
                Box::new(move |stamp| {
                    buffer
                        .lookup(&base, &tool, stamp, max_gap)
                        .map_err(|e| e.to_string())
                })
            }
        })
    }
}

/// What the bag holds for the calibration.
struct Gathered {
    targets: Vec<TargetPose>,
    robot: Robot,
    unpaired: Vec<RejectedRecord>,
    frames: FramesRecord,
}

/// Calibrates the session in `args.bag` and writes `args.out/handeye.yaml` and
/// `args.out/report.html`. The refinement sees every sample through the camera of the
/// first one's camera_info.
pub fn handeye_bag(args: &HandEyeArgs) -> anyhow::Result<HandEyeReport> {
    if !(args.max_time_difference.is_finite() && args.max_time_difference >= 0.0) {
        bail!(
            "--max-time-difference {}: expected a number of seconds of at least 0",
            args.max_time_difference
        );
    }
    let weights = args.weights()?;
    let reader = BagReader::open(&args.bag)
        .with_context(|| format!("opening the bag {}", args.bag.display()))?;
    if let Some(topic) = &args.robot_pose_topic {
        check_pose_topic(&reader, "--robot-pose-topic", topic)?;
    }
    let mut gathered = match (&args.target_pose_topic, &args.image_topic) {
        (Some(topic), None) => {
            check_pose_topic(&reader, "--target-pose-topic", topic)?;
            read_poses(&reader, args, topic)?
        }
        (None, image_topic) => find_poses(&reader, args, image_topic.as_deref())?,
        (Some(_), Some(_)) => bail!("give --target-pose-topic or --image-topic, not both"),
    };
    if gathered.targets.is_empty() {
        let first = gathered.unpaired.first().map_or(String::new(), |r| {
            format!("; the first at {:.6} s: {}", r.stamp, r.reason)
        });
        bail!(
            "no target pose in {} ({} frames rejected{first})",
            args.bag.display(),
            gathered.unpaired.len()
        );
    }
    let robot_at = gathered.robot.into_lookup(args.max_time_difference)?;
    let mut samples = Vec::new();
    for target in gathered.targets {
        match robot_at(target.stamp) {
            Ok(base_from_tool) => samples.push(SessionSample {
                stamp: target.stamp,
                sample: Sample {
                    base_from_tool,
                    camera_from_target: target.camera_from_target,
                },
                observation: target.observation,
            }),
            Err(reason) => gathered.unpaired.push(RejectedRecord {
                stamp: target.stamp,
                reason,
            }),
        }
    }
    let report = calibrate_session(
        args.setup.into(),
        gathered.frames,
        &samples,
        gathered.unpaired,
        &weights,
    )
    .with_context(|| format!("hand-eye calibration of {}", args.bag.display()))?
    .report;
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("creating {}", args.out.display()))?;
    let path = args.out.join("handeye.yaml");
    let text = serde_yaml::to_string(&report).context("encoding handeye.yaml")?;
    atomic_file::write(&path, text.as_bytes())
        .with_context(|| format!("writing {}", path.display()))?;
    let path = args.out.join("report.html");
    let page = html(&report).context("making report.html")?;
    atomic_file::write(&path, page.as_bytes())
        .with_context(|| format!("writing {}", path.display()))?;
    Ok(report)
}

/// Refuses a topic the bag lacks or that is not of PoseStamped.
fn check_pose_topic(reader: &BagReader, option: &str, topic: &str) -> anyhow::Result<()> {
    match reader.topic(topic) {
        Some(t) if t.type_name == PoseStamped::TYPE_NAME => Ok(()),
        Some(t) => bail!(
            "{option} {topic} is a {}, not a {}",
            t.type_name,
            PoseStamped::TYPE_NAME
        ),
        None => bail!(
            "{option}: the bag has no topic {topic} (PoseStamped topics: {})",
            reader.topics_of_type(PoseStamped::TYPE_NAME).join(", ")
        ),
    }
}

/// A PoseStamped message's stamp (seconds), pose and frame; `None`, said on stderr,
/// when it cannot be decoded or is not a pose.
fn pose_of(message: &BagMessage) -> Option<(f64, Isometry3<f64>, String)> {
    let pose: PoseStamped = match cdr::from_bytes(&message.data) {
        Ok(pose) => pose,
        Err(e) => {
            eprintln!(
                "skipped an undecodable {} message at log time {} ns: {e}",
                message.topic, message.log_time_ns
            );
            return None;
        }
    };
    let stamp = seconds(&pose.header.stamp);
    match isometry_from_pose_msg(&pose.pose) {
        Ok(isometry) => Some((stamp, isometry, pose.header.frame_id)),
        Err(e) => {
            eprintln!(
                "skipped the {} message stamped {stamp:.6} s: {e}",
                message.topic
            );
            None
        }
    }
}

fn empty_gathered(args: &HandEyeArgs) -> anyhow::Result<Gathered> {
    let robot = Robot::new(args)?;
    let (base, tool) = match &robot {
        Robot::Tf { base, tool, .. } => (base.clone(), tool.clone()),
        Robot::Topic { .. } => (String::new(), args.tool_frame.clone()),
    };
    Ok(Gathered {
        targets: Vec::new(),
        robot,
        unpaired: Vec::new(),
        frames: FramesRecord {
            base,
            tool,
            camera: String::new(),
        },
    })
}

/// Keeps what a message of the robot's topics says.
fn gather_robot(gathered: &mut Gathered, message: &BagMessage) {
    if let Some(frame) = gathered.robot.read(message)
        && gathered.frames.base.is_empty()
    {
        gathered.frames.base = frame;
    }
}

/// The target poses of a topic of poses already measured, and the robot poses.
fn read_poses(reader: &BagReader, args: &HandEyeArgs, topic: &str) -> anyhow::Result<Gathered> {
    let mut gathered = empty_gathered(args)?;
    let mut topics = gathered.robot.topics();
    topics.push(topic);
    let filter = TopicFilter::only(topics.into_iter().map(str::to_owned).collect::<Vec<_>>());
    for message in reader.messages(&filter) {
        let message = message.context("reading the bag")?;
        if *message.topic == *topic {
            if let Some((stamp, camera_from_target, frame)) = pose_of(&message) {
                targets_push(&mut gathered, stamp, camera_from_target, None, frame);
            }
        } else {
            gather_robot(&mut gathered, &message);
        }
    }
    Ok(gathered)
}

fn targets_push(
    gathered: &mut Gathered,
    stamp: f64,
    camera_from_target: Isometry3<f64>,
    observation: Option<(TargetObservation, CameraModel)>,
    frame: String,
) {
    gathered.targets.push(TargetPose {
        stamp,
        camera_from_target,
        observation,
    });
    if gathered.frames.camera.is_empty() {
        gathered.frames.camera = frame;
    }
}

/// The target poses found in the images of `image_topic` (default: the bag's only one)
/// with their pixels, and the robot poses, in one pass over the bag.
fn find_poses(
    reader: &BagReader,
    args: &HandEyeArgs,
    image_topic: Option<&str>,
) -> anyhow::Result<Gathered> {
    let (Some(size), Some(square)) = (&args.size, &args.square) else {
        bail!("give --size and --square of the target (or --target-pose-topic)");
    };
    let target = PatternArgs {
        pattern: Some(args.pattern.clone()),
        size: Some(size.clone()),
        square: Some(square.clone()),
        marker_size: args.charuco.marker_size.clone(),
        aruco_dict: args.charuco.aruco_dict.clone(),
    }
    .target()?;
    let stage = PoseStage::new(target, PoseOptions::default(), false)?;
    let input = FrameInput::open(reader, image_topic, args.camera_info.as_deref())?;
    let gathered = std::cell::RefCell::new(empty_gathered(args)?);
    let damage = input.walk(
        reader,
        reader.messages(&TopicFilter::All),
        &stage,
        &ProgressBar::hidden(),
        |message| {
            gather_robot(&mut gathered.borrow_mut(), &message);
            Ok(())
        },
        |frame| {
            let stamp = seconds(&frame.header.stamp);
            let mut gathered = gathered.borrow_mut();
            match frame.outcome {
                Ok(pose) => {
                    let observation = Some((
                        TargetObservation {
                            target_points: pose.target_points,
                            pixels: pose.detection.corners,
                        },
                        pose.camera,
                    ));
                    targets_push(
                        &mut gathered,
                        stamp,
                        pose.estimate.camera_from_target,
                        observation,
                        frame.header.frame_id,
                    );
                }
                Err(rejection) => gathered.unpaired.push(RejectedRecord {
                    stamp,
                    reason: rejection.to_string(),
                }),
            }
            Ok(())
        },
    )?;
    if let Some(damage) = damage {
        eprintln!("the bag is damaged; reading stopped early: {damage}");
    }
    Ok(gathered.into_inner())
}

fn print_human(report: &HandEyeReport) {
    let transform = &report.results[&report.chosen];
    let name = match report.setup.as_str() {
        "eye-in-hand" => "tool_from_camera",
        _ => "base_from_camera",
    };
    println!(
        "{} ({}): {name} translation {:?} m, rotation (row-major) {:?}",
        report.setup, report.chosen, transform.translation, transform.rotation
    );
    println!(
        "{} samples; residuals median {:.3} deg, {:.2} mm (largest {:.3} deg, {:.2} mm)",
        report.samples,
        report.residuals.rotation_deg_median,
        report.residuals.translation_mm_median,
        report.residuals.rotation_deg_max,
        report.residuals.translation_mm_max
    );
    for r in &report.samples_rejected {
        eprintln!("  left out the sample at {:.6} s: {}", r.stamp, r.reason);
    }
    for w in &report.warnings {
        eprintln!("  warning: {w}");
    }
}
