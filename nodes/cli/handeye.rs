//! `stereocal handeye`: hand-eye calibration of a recorded session. Target poses
//! (`camera_from_target`, geometry_msgs/PoseStamped, as `stereocal pose` or `pose_node`
//! writes them) are paired by stamp with the robot's poses (`base_from_tool`,
//! PoseStamped), interpolated at each target pose's stamp; every method of
//! `vision::handeye` solves the pairs after leaving out those that disagree, and the
//! result with the least median residual is chosen. Writes `DIR/handeye.yaml`
//! atomically; with `--json`, prints the same report on stdout.

use std::path::PathBuf;

use anyhow::{Context, bail};
use stereocal_msgs::RosMessage;
use stereocal_msgs::atomic_file;
use stereocal_msgs::cdr;
use stereocal_msgs::geometry_msgs::PoseStamped;
use stereocal_rosbag::{BagReader, TopicFilter};
use stereocal_vision::handeye::{Sample, Setup};

use crate::convert::isometry_from_pose_msg;
use crate::handeye::pairing::RobotTrack;
use crate::handeye::report::{FramesRecord, HandEyeReport, RejectedRecord, solve};
use crate::pose::record::seconds;

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
    /// Topic of the target's poses in the camera frame (geometry_msgs/PoseStamped), e.g.
    /// what `stereocal pose` adds as `<ns>/target_pose`.
    #[arg(long = "target-pose-topic")]
    pub target_pose_topic: String,
    /// Topic of the robot's tool poses in its base frame (geometry_msgs/PoseStamped).
    #[arg(long = "robot-pose-topic")]
    pub robot_pose_topic: String,
    /// The robot's tool frame, for the report (PoseStamped does not name it).
    #[arg(long = "tool-frame", default_value = "tool")]
    pub tool_frame: String,
    /// A target pose is paired only with robot poses this close on both sides of its
    /// stamp, seconds.
    #[arg(long = "max-time-difference", default_value_t = 0.02)]
    pub max_time_difference: f64,
    /// Output directory: handeye.yaml is written there.
    #[arg(long)]
    pub out: PathBuf,
    /// Print the report as one JSON object on stdout.
    #[arg(long)]
    pub json: bool,
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

/// Calibrates the session in `args.bag` and writes `args.out/handeye.yaml`.
pub fn handeye_bag(args: &HandEyeArgs) -> anyhow::Result<HandEyeReport> {
    if !(args.max_time_difference.is_finite() && args.max_time_difference >= 0.0) {
        bail!(
            "--max-time-difference {}: expected a number of seconds of at least 0",
            args.max_time_difference
        );
    }
    let reader = BagReader::open(&args.bag)
        .with_context(|| format!("opening the bag {}", args.bag.display()))?;
    for (option, topic) in [
        ("--target-pose-topic", &args.target_pose_topic),
        ("--robot-pose-topic", &args.robot_pose_topic),
    ] {
        match reader.topic(topic) {
            Some(t) if t.type_name == PoseStamped::TYPE_NAME => {}
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
    let mut robot = Vec::new();
    let mut targets = Vec::new();
    let mut unpaired = Vec::new();
    let mut frames = FramesRecord {
        base: String::new(),
        tool: args.tool_frame.clone(),
        camera: String::new(),
    };
    let filter = TopicFilter::only([
        args.target_pose_topic.as_str(),
        args.robot_pose_topic.as_str(),
    ]);
    for message in reader.messages(&filter) {
        let message = message.context("reading the bag")?;
        let is_robot = *message.topic == args.robot_pose_topic;
        let pose: PoseStamped = match cdr::from_bytes(&message.data) {
            Ok(pose) => pose,
            Err(e) => {
                eprintln!(
                    "skipped an undecodable {} message at log time {} ns: {e}",
                    message.topic, message.log_time_ns
                );
                continue;
            }
        };
        let stamp = seconds(&pose.header.stamp);
        let isometry = isometry_from_pose_msg(&pose.pose);
        if is_robot {
            match isometry {
                Ok(base_from_tool) => {
                    robot.push((stamp, base_from_tool));
                    if frames.base.is_empty() {
                        frames.base = pose.header.frame_id;
                    }
                }
                Err(e) => eprintln!("skipped the robot pose stamped {stamp:.6} s: {e}"),
            }
        } else {
            match isometry {
                Ok(camera_from_target) => {
                    targets.push((stamp, camera_from_target));
                    if frames.camera.is_empty() {
                        frames.camera = pose.header.frame_id;
                    }
                }
                Err(e) => unpaired.push(RejectedRecord {
                    stamp,
                    reason: format!("target pose: {e}"),
                }),
            }
        }
    }
    if targets.is_empty() {
        bail!("no target pose on {}", args.target_pose_topic);
    }
    if robot.is_empty() {
        bail!("no robot pose on {}", args.robot_pose_topic);
    }
    let track = RobotTrack::new(robot);
    let mut stamped = Vec::new();
    for (stamp, camera_from_target) in targets {
        match track.at(stamp, args.max_time_difference) {
            Ok(base_from_tool) => stamped.push((
                stamp,
                Sample {
                    base_from_tool,
                    camera_from_target,
                },
            )),
            Err(reason) => unpaired.push(RejectedRecord { stamp, reason }),
        }
    }
    let report = solve(args.setup.into(), frames, &stamped, unpaired)
        .with_context(|| format!("hand-eye calibration of {}", args.bag.display()))?;
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("creating {}", args.out.display()))?;
    let path = args.out.join("handeye.yaml");
    let text = serde_yaml::to_string(&report).context("encoding handeye.yaml")?;
    atomic_file::write(&path, text.as_bytes())
        .with_context(|| format!("writing {}", path.display()))?;
    Ok(report)
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
