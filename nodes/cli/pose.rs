//! `stereocal pose`: the target's pose in every image of a bag, judged as `pose_node`
//! judges a frame ([`crate::pose::stage`]). Writes a bag with the input's topics plus
//! `<ns>/target_pose` (geometry_msgs/PoseStamped) and the transforms
//! `camera_frame -> target_frame` on `/tf`; with `--json`, prints one
//! [`FrameRecord`] per image in stamp order.
//!
//! The bag is streamed: images wait briefly for the camera_info of their stamp, and
//! frames are solved in small batches on every core, so memory stays bounded.

use std::collections::{BTreeMap, VecDeque};
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::{Duration, Instant};

use anyhow::{Context, bail};
use indicatif::{ProgressBar, ProgressStyle};
use rayon::prelude::*;
use serde::Serialize;
use stereocal_msgs::RosMessage;
use stereocal_msgs::camera_info_file::CameraInfoFile;
use stereocal_msgs::cdr;
use stereocal_msgs::geometry_msgs::{PoseStamped, TransformStamped};
use stereocal_msgs::sensor_msgs::{CameraInfo, Image as ImageMsg};
use stereocal_msgs::std_msgs::Header;
use stereocal_msgs::tf2_msgs::TFMessage;
use stereocal_rosbag::{BagError, BagMessage, BagReader, BagWriter, OfferedQos, TopicFilter};
use stereocal_vision::board::PatternArgs;
use stereocal_vision::pnp::PoseOptions;

use super::calibrate::CharucoArgs;
use super::image_topics::{image_kind, image_topics};
use super::output_bag::create_output_bag;
use super::pipeline;
use crate::convert::{ImageKind, base_topic, pose_msg, transform_msg};
use crate::pose::record::FrameRecord;
use crate::pose::stage::{FramePose, PoseRejection, PoseStage};

/// Images that may wait for the camera_info of their stamp.
const MAX_PENDING: usize = 8;
/// Recent camera_infos kept for pairing by stamp.
const RECENT_INFOS: usize = 16;
/// Frames solved together, in parallel.
const BATCH: usize = 16;

/// Arguments of `stereocal pose`.
#[derive(clap::Args, Debug, Clone)]
pub struct PoseArgs {
    /// Input rosbag2 bag: a directory with metadata.yaml or a .mcap file.
    #[arg(long)]
    pub bag: PathBuf,
    /// Output bag: a directory, or a file ending in .mcap. Written atomically.
    #[arg(long)]
    pub out: PathBuf,
    /// Image topic; default: the bag's only image topic.
    #[arg(long)]
    pub topic: Option<String>,
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
    pub size: String,
    /// Side of one square, metres.
    #[arg(long)]
    pub square: String,
    /// The markers of a ChArUco board.
    #[command(flatten)]
    pub charuco: CharucoArgs,
    /// Poses whose RMS reprojection error is above this (pixels) are rejected.
    #[arg(long = "max-reprojection-error", default_value_t = PoseOptions::default().max_rms_px)]
    pub max_reprojection_error: f64,
    /// A planar target's pose is rejected when a distinct second pose explains the
    /// corners within this many standard deviations of pixel noise as well.
    #[arg(long = "min-ambiguity-significance", default_value_t = PoseOptions::default().min_ambiguity_significance)]
    pub min_ambiguity_significance: f64,
    /// Least standard deviation of corner noise assumed, pixels: scales the covariance
    /// and the ambiguity test.
    #[arg(long = "pixel-noise", default_value_t = PoseOptions::default().pixel_noise_px)]
    pub pixel_noise: f64,
    /// The images are rectified: see them through camera_info's P, not K and D.
    #[arg(long = "image-is-rectified")]
    pub image_is_rectified: bool,
    /// TF frame of the target.
    #[arg(long = "target-frame", default_value = "target")]
    pub target_frame: String,
    /// Replace the output bag if it exists.
    #[arg(long)]
    pub overwrite: bool,
    /// Print one JSON object, `{"frames": [...]}`, on stdout.
    #[arg(long)]
    pub json: bool,
}

impl PoseArgs {
    /// The arguments for a `cols x rows` chessboard (inner corners) of `square` metres in
    /// `bag`, written to `out`, with every other option at its default.
    pub fn chessboard(bag: PathBuf, out: PathBuf, cols: usize, rows: usize, square: f64) -> Self {
        let defaults = PoseOptions::default();
        Self {
            bag,
            out,
            topic: None,
            camera_info: None,
            pattern: "chessboard".to_owned(),
            size: format!("{cols}x{rows}"),
            square: square.to_string(),
            charuco: CharucoArgs::default(),
            max_reprojection_error: defaults.max_rms_px,
            min_ambiguity_significance: defaults.min_ambiguity_significance,
            pixel_noise: defaults.pixel_noise_px,
            image_is_rectified: false,
            target_frame: "target".to_owned(),
            overwrite: false,
            json: false,
        }
    }
}

/// The outcome of [`pose_bag`].
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PoseReport {
    /// One record per image, in stamp order.
    pub frames: Vec<FrameRecord>,
    /// The image topic.
    #[serde(skip)]
    pub topic: String,
    /// Where the camera_info came from.
    #[serde(skip)]
    pub camera_info_source: String,
    /// The bag written.
    #[serde(skip)]
    pub output: PathBuf,
    /// Damage in the input bag that ended reading early, if any.
    #[serde(skip)]
    pub damage: Option<String>,
    /// Wall time of the whole run.
    #[serde(skip)]
    pub elapsed: Duration,
}

/// Runs `stereocal pose`.
pub fn run(args: &PoseArgs) -> anyhow::Result<()> {
    let progress = ProgressBar::new(0).with_style(
        ProgressStyle::with_template(
            "{spinner} [{elapsed_precise}] {bar:40} {pos}/{len} images ({per_sec}, eta {eta})",
        )
        .context("progress bar template")?,
    );
    let report = pose_bag(args, &progress)?;
    progress.finish_and_clear();
    if args.json {
        println!(
            "{}",
            serde_json::to_string(&report).context("encoding the results")?
        );
    } else {
        print_human(&report);
    }
    Ok(())
}

fn print_human(report: &PoseReport) {
    let mut rejected: BTreeMap<&str, usize> = BTreeMap::new();
    let mut rms: Vec<f64> = Vec::new();
    for frame in &report.frames {
        match frame {
            FrameRecord::Pose { rms: r, .. } => rms.push(*r),
            FrameRecord::Rejected {
                rejected: reason, ..
            } => {
                *rejected.entry(reason.as_str()).or_default() += 1;
            }
        }
    }
    rms.sort_by(f64::total_cmp);
    eprintln!(
        "{}: {} poses in {} images (camera_info from {}), median RMS {:.3} px; wrote {} in {:.2} s",
        report.topic,
        rms.len(),
        report.frames.len(),
        report.camera_info_source,
        rms.get(rms.len() / 2).copied().unwrap_or(f64::NAN),
        report.output.display(),
        report.elapsed.as_secs_f64()
    );
    for (reason, count) in rejected {
        eprintln!("  {count} rejected: {reason}");
    }
    if let Some(damage) = &report.damage {
        eprintln!("  the input bag is damaged; reading stopped early: {damage}");
    }
}

/// The messages of one solved frame, for the writer.
struct SolvedPose {
    log_time_ns: u64,
    pose: PoseStamped,
    tf: TFMessage,
}

/// An image read from the bag, waiting for its camera_info and its pose.
struct Pending {
    log_time_ns: u64,
    image: Result<ImageMsg, String>,
}

/// A frame ready to solve: the image and the camera_info paired with it.
struct Ready {
    log_time_ns: u64,
    image: Result<ImageMsg, String>,
    info: Option<CameraInfo>,
}

/// Estimates the target's pose in every image of `args.topic` and writes the output
/// bag (atomically: nothing appears at `args.out` unless the run succeeds). `progress`
/// counts images; pass [`ProgressBar::hidden`] for none.
pub fn pose_bag(args: &PoseArgs, progress: &ProgressBar) -> anyhow::Result<PoseReport> {
    let started = Instant::now();
    let target = PatternArgs {
        pattern: Some(args.pattern.clone()),
        size: Some(args.size.clone()),
        square: Some(args.square.clone()),
        marker_size: args.charuco.marker_size.clone(),
        aruco_dict: args.charuco.aruco_dict.clone(),
    }
    .target()?;
    let options = pose_options(args)?;
    let stage = PoseStage::new(target, options, args.image_is_rectified)?;
    let reader = BagReader::open(&args.bag)
        .with_context(|| format!("opening the bag {}", args.bag.display()))?;
    let input = FrameInput::open(&reader, args.topic.as_deref(), args.camera_info.as_deref())?;
    let topic = input.topic.clone();
    let ns = base_topic(&topic)
        .rsplit_once('/')
        .map_or("", |(ns, _)| ns)
        .to_owned();
    let pose_topic_name = format!("{ns}/target_pose");
    if reader.topic(&pose_topic_name).is_some() {
        bail!("the input bag already has {pose_topic_name}");
    }
    let mut writer = create_output_bag(&args.out, args.overwrite, false)?;
    let copy_ids = writer.add_topics_of(reader.topics())?;
    let pose_topic =
        writer.add_message_topic::<PoseStamped>(&pose_topic_name, &OfferedQos::default())?;
    let tf_topic = match (copy_ids.get("/tf"), reader.topic("/tf")) {
        (Some(&id), Some(t)) if t.type_name == TFMessage::TYPE_NAME => id,
        (Some(_), Some(t)) => bail!(
            "the input bag's /tf is a {}, not a tf2_msgs/msg/TFMessage",
            t.type_name
        ),
        _ => writer.add_message_topic::<TFMessage>("/tf", &OfferedQos::default())?,
    };
    let write = |pose: SolvedPose, writer: &mut BagWriter| -> anyhow::Result<()> {
        writer.write_message(pose_topic, pose.log_time_ns, &pose.pose)?;
        writer.write_message(tf_topic, pose.log_time_ns, &pose.tf)?;
        Ok(())
    };
    let mut frames = Vec::new();
    let (damage, writer) = pipeline::run(
        reader.messages(&TopicFilter::All),
        writer,
        write,
        |messages, out| {
            input.walk(
                &reader,
                messages,
                &stage,
                progress,
                |message| {
                    if let Some(&id) = copy_ids.get(&*message.topic) {
                        let data = Arc::new(message.data);
                        out.copy(id, message.log_time_ns, message.publish_time_ns, data)?;
                    }
                    Ok(())
                },
                |frame| {
                    frames.push(FrameRecord::new(&frame.header.stamp, &frame.outcome));
                    let Ok(pose) = &frame.outcome else {
                        return Ok(());
                    };
                    let camera_from_target = &pose.estimate.camera_from_target;
                    out.ready(SolvedPose {
                        log_time_ns: frame.log_time_ns,
                        pose: PoseStamped {
                            header: frame.header.clone(),
                            pose: pose_msg(camera_from_target),
                        },
                        tf: TFMessage {
                            transforms: vec![TransformStamped {
                                header: frame.header,
                                child_frame_id: args.target_frame.clone(),
                                transform: transform_msg(camera_from_target),
                            }],
                        },
                    })
                },
            )
        },
    )?;
    let written = writer
        .finish()
        .with_context(|| format!("finishing {}", args.out.display()))?;
    frames.sort_by(|a: &FrameRecord, b| a.stamp().total_cmp(&b.stamp()));
    Ok(PoseReport {
        frames,
        topic,
        camera_info_source: input.camera_info_source,
        output: written,
        damage,
        elapsed: started.elapsed(),
    })
}

/// The pose options of `args`, refused when out of range.
fn pose_options(args: &PoseArgs) -> anyhow::Result<PoseOptions> {
    if !(args.max_reprojection_error.is_finite() && args.max_reprojection_error > 0.0) {
        bail!(
            "--max-reprojection-error {}: expected a positive number of pixels",
            args.max_reprojection_error
        );
    }
    for (option, value) in [
        (
            "--min-ambiguity-significance",
            args.min_ambiguity_significance,
        ),
        ("--pixel-noise", args.pixel_noise),
    ] {
        if !(value.is_finite() && value >= 0.0) {
            bail!("{option} {value}: expected a number of at least 0");
        }
    }
    Ok(PoseOptions {
        max_rms_px: args.max_reprojection_error,
        min_ambiguity_significance: args.min_ambiguity_significance,
        pixel_noise_px: args.pixel_noise,
        ..PoseOptions::default()
    })
}

/// One image's outcome, in bag order.
pub struct SolvedFrame {
    /// When the image was logged, nanoseconds.
    pub log_time_ns: u64,
    /// The image's header.
    pub header: Header,
    /// Its pose, or why it has none.
    pub outcome: Result<FramePose, PoseRejection>,
}

/// Where a bag's images and their camera_infos come from.
pub struct FrameInput {
    /// The image topic.
    pub topic: String,
    /// Raw or compressed images.
    kind: ImageKind,
    /// The camera_info topic beside it, `<ns>/camera_info`.
    info_topic: String,
    /// The camera_info from a file, used for every image instead of the bag's.
    fixed_info: Option<CameraInfo>,
    /// Where the camera_info comes from: the topic or the file.
    pub camera_info_source: String,
}

impl FrameInput {
    /// The image topic `asked` (default: the bag's only image topic) and its
    /// camera_info: from `camera_info_file` when given, else the bag's
    /// `<ns>/camera_info`, which must then exist.
    pub fn open(
        reader: &BagReader,
        asked: Option<&str>,
        camera_info_file: Option<&Path>,
    ) -> anyhow::Result<Self> {
        let topic = image_topic(reader, asked)?;
        let kind = image_kind(reader, &topic).map_err(anyhow::Error::msg)?;
        let ns = base_topic(&topic)
            .rsplit_once('/')
            .map_or("", |(ns, _)| ns)
            .to_owned();
        let info_topic = format!("{ns}/camera_info");
        let (fixed_info, camera_info_source) = match camera_info_file {
            Some(file) => (
                Some(
                    CameraInfoFile::read(file)
                        .with_context(|| format!("--camera-info {}", file.display()))?
                        .info,
                ),
                file.display().to_string(),
            ),
            None => match reader.topic(&info_topic) {
                Some(t) if t.type_name == CameraInfo::TYPE_NAME => (None, info_topic.clone()),
                _ => bail!("the bag has no {info_topic} beside {topic}: give --camera-info FILE"),
            },
        };
        Ok(Self {
            topic,
            kind,
            info_topic,
            fixed_info,
            camera_info_source,
        })
    }

    /// Reads `messages`, the whole of `reader`'s bag in log-time order, once: hands
    /// every message to `copy` once read (and decoded when it is an image or a
    /// camera_info), pairs each image with the camera_info of
    /// its stamp (or the file's), solves the images with `stage` in parallel batches,
    /// and hands every solved frame to `sink` in bag order. Returns the damage that
    /// ended reading early, if any. `progress` counts images.
    pub fn walk(
        &self,
        reader: &BagReader,
        messages: impl Iterator<Item = Result<BagMessage, BagError>>,
        stage: &PoseStage,
        progress: &ProgressBar,
        mut copy: impl FnMut(BagMessage) -> anyhow::Result<()>,
        mut sink: impl FnMut(SolvedFrame) -> anyhow::Result<()>,
    ) -> anyhow::Result<Option<String>> {
        progress.set_length(reader.topics_message_count([self.topic.as_str()]));
        let mut pending: VecDeque<Pending> = VecDeque::new();
        let mut infos: VecDeque<CameraInfo> = VecDeque::new();
        let mut batch: Vec<Ready> = Vec::new();
        let mut damage = None;
        let fixed_info = self.fixed_info.as_ref();
        for message in messages {
            let message = match message {
                Ok(message) => message,
                Err(e) => {
                    damage = Some(e.to_string());
                    break;
                }
            };
            let paired = if *message.topic == self.topic {
                pending.push_back(Pending {
                    log_time_ns: message.log_time_ns,
                    image: self.kind.decode(&message.data),
                });
                true
            } else if fixed_info.is_none() && *message.topic == self.info_topic {
                match cdr::from_bytes::<CameraInfo>(&message.data) {
                    Ok(info) => {
                        if infos.len() == RECENT_INFOS {
                            infos.pop_front();
                        }
                        infos.push_back(info);
                    }
                    // Its images are then rejected for want of a camera_info: say why.
                    Err(e) => progress.suspend(|| {
                        eprintln!(
                            "skipped an undecodable {} message at log time {} ns: {e}",
                            self.info_topic, message.log_time_ns
                        );
                    }),
                }
                true
            } else {
                false
            };
            copy(message)?;
            if !paired {
                continue;
            }
            pair_ready(&mut pending, &infos, fixed_info, false, &mut batch);
            if batch.len() >= BATCH {
                solve_batch(stage, &mut batch, progress, &mut sink)?;
            }
        }
        pair_ready(&mut pending, &infos, fixed_info, true, &mut batch);
        solve_batch(stage, &mut batch, progress, &mut sink)?;
        Ok(damage)
    }
}

/// The image topic: the one asked for, or the bag's only one.
fn image_topic(reader: &BagReader, asked: Option<&str>) -> anyhow::Result<String> {
    let image_topics = image_topics(reader);
    let listed = if image_topics.is_empty() {
        "none".to_owned()
    } else {
        image_topics.join(", ")
    };
    match (asked, image_topics.as_slice()) {
        (Some(topic), _) if image_topics.contains(&topic) => Ok(topic.to_owned()),
        (Some(topic), _) => bail!("the bag has no image topic {topic} (image topics: {listed})"),
        (None, [only]) => Ok((*only).to_owned()),
        (None, _) => bail!("give --topic: the bag's image topics are {listed}"),
    }
}

/// Moves the waiting images that can be paired now into `ready`: with the camera_info of
/// their stamp, or with none once it cannot come any more (a newer camera_info arrived,
/// too many images wait, or the bag ended).
fn pair_ready(
    pending: &mut VecDeque<Pending>,
    infos: &VecDeque<CameraInfo>,
    fixed: Option<&CameraInfo>,
    finish: bool,
    ready: &mut Vec<Ready>,
) {
    while let Some(front) = pending.front() {
        let stamp = front.image.as_ref().ok().map(|image| image.header.stamp);
        let info = match (fixed, stamp) {
            (_, None) => None,
            (Some(info), Some(stamp)) => {
                let mut info = info.clone();
                info.header.stamp = stamp;
                Some(info)
            }
            (None, Some(stamp)) => {
                let exact = infos.iter().rev().find(|i| i.header.stamp == stamp);
                let newer = infos.iter().any(|i| i.header.stamp > stamp);
                if exact.is_none() && !(finish || newer || pending.len() > MAX_PENDING) {
                    return;
                }
                exact.cloned()
            }
        };
        let Some(front) = pending.pop_front() else {
            return;
        };
        ready.push(Ready {
            log_time_ns: front.log_time_ns,
            image: front.image,
            info,
        });
    }
}

/// Solves the frames of `batch` in parallel and hands them to `sink` in order.
fn solve_batch(
    stage: &PoseStage,
    batch: &mut Vec<Ready>,
    progress: &ProgressBar,
    sink: &mut impl FnMut(SolvedFrame) -> anyhow::Result<()>,
) -> anyhow::Result<()> {
    let solved: Vec<Option<(Header, Result<FramePose, PoseRejection>)>> = batch
        .par_iter()
        .map(|frame| {
            let image = frame.image.as_ref().ok()?;
            let outcome = match &frame.info {
                Some(info) => stage.estimate(image, info).0,
                None => Err(PoseRejection::NoCameraInfo),
            };
            Some((image.header.clone(), outcome))
        })
        .collect();
    for (frame, solved) in batch.drain(..).zip(solved) {
        progress.inc(1);
        let (header, outcome) = match (solved, &frame.image) {
            (Some(solved), _) => solved,
            (None, Err(e)) => {
                progress.suspend(|| {
                    eprintln!(
                        "skipped an undecodable image at log time {} ns: {e}",
                        frame.log_time_ns
                    );
                });
                continue;
            }
            (None, Ok(_)) => continue,
        };
        sink(SolvedFrame {
            log_time_ns: frame.log_time_ns,
            header,
            outcome,
        })?;
    }
    Ok(())
}
