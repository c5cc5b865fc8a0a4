//! `stereocal rectify`: rectifies every image topic of a bag that has a camera_info and
//! writes `<ns>/image_rect` beside copies of all input topics; with `--uncalibrated`, a
//! stereo pair without calibration ([`super::rectify_uncalibrated`]).
//!
//! The bag is streamed: a few frames per camera wait at most for their camera_info, so
//! memory stays bounded whatever the bag's size. An image is paired with the camera_info
//! of the same stamp when one arrives close by, otherwise with the nearest recent one.

use std::collections::VecDeque;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::{Duration, Instant};

use anyhow::{Context, bail};
use indicatif::{ProgressBar, ProgressStyle};
use stereocal_msgs::RosMessage;
use stereocal_msgs::camera_info_file::CameraInfoFile;
use stereocal_msgs::cdr;
use stereocal_msgs::sensor_msgs::{CameraInfo, Image as ImageMsg};
use stereocal_msgs::std_msgs::Header;
use stereocal_vision::board::PatternArgs;
use stereocal_vision::image::Image;
use stereocal_vision::rectify::RectifyMap;
use stereocal_vision::rectify::{Interpolation, RemapOptions};

use super::calibrate::CharucoArgs;
use super::image_topics::image_topics;
use super::output_bag::create_output_bag;
use super::pipeline::{self, Output};
use super::rectify_uncalibrated::{
    MatchSource, UncalibratedOptions, print_summary as print_uncalibrated_summary,
    rectify_bag_uncalibrated,
};
use crate::convert::{ImageKind, base_topic};
use crate::rectify::matches::read_points_file;
use crate::rectify::stage::{Plan, Rectifier, remap_image_msg};
use stereocal_rosbag::{BagReader, BagWriter, TopicFilter, TopicId};

/// Images per camera that may wait for a camera_info with their stamp.
const MAX_PENDING: usize = 4;
/// Recent camera_infos kept per camera for pairing by stamp.
const RECENT_INFOS: usize = 8;
/// Problems kept in a [`BagRectifyReport`]; later ones are only counted.
const MAX_PROBLEMS_KEPT: usize = 1000;

/// Arguments of `stereocal rectify`.
#[derive(clap::Args, Debug, Clone)]
pub struct RectifyArgs {
    /// Input rosbag2 bag: a directory with metadata.yaml or a .mcap file.
    #[arg(long)]
    pub bag: PathBuf,
    /// Output bag: a directory, or a file ending in .mcap. Written atomically.
    #[arg(long)]
    pub out: PathBuf,
    /// Calibration for an image topic (or its `<ns>/camera_info` topic) from a
    /// camera_calibration_parsers YAML or INI file, used instead of the bag's
    /// camera_info. Repeatable.
    #[arg(long = "camera-info", value_name = "TOPIC=FILE", value_parser = parse_camera_info_arg,
          conflicts_with = "uncalibrated")]
    pub camera_info: Vec<(String, PathBuf)>,
    /// Rectify a stereo pair without calibration (Hartley's method, as OpenCV's
    /// stereoRectifyUncalibrated): homographies from the fundamental matrix of target
    /// corners seen by both cameras (--pattern, --size, --square) or of --points.
    #[arg(long)]
    pub uncalibrated: bool,
    /// With --uncalibrated: the left camera's image topic (default: the bag's image
    /// topic with `left` in its name).
    #[arg(long, requires = "uncalibrated")]
    pub left: Option<String>,
    /// With --uncalibrated: the right camera's image topic (default: the bag's image
    /// topic with `right` in its name).
    #[arg(long, requires = "uncalibrated")]
    pub right: Option<String>,
    /// With --uncalibrated: target kind, as ROS camera_calibration: chessboard or
    /// charuco.
    #[arg(long, requires = "uncalibrated", conflicts_with = "points")]
    pub pattern: Option<String>,
    /// With --uncalibrated: inner corners of the chessboard, or squares of the ChArUco
    /// board, COLSxROWS (e.g. 9x6).
    #[arg(long, requires = "uncalibrated", conflicts_with = "points")]
    pub size: Option<String>,
    /// With --uncalibrated: side of one square, metres.
    #[arg(long, requires = "uncalibrated", conflicts_with = "points")]
    pub square: Option<String>,
    /// With --uncalibrated: the markers of a ChArUco board.
    #[command(flatten)]
    pub charuco: CharucoArgs,
    /// With --uncalibrated: matched pixels instead of a target, one correspondence a
    /// line: `left_x left_y right_x right_y` (commas or spaces; `#` starts a comment
    /// line).
    #[arg(long, requires = "uncalibrated")]
    pub points: Option<PathBuf>,
    /// With --uncalibrated: matched points farther than this from their epipolar line
    /// in either image are left out of the rectification, pixels (OpenCV's default).
    #[arg(
        long,
        default_value_t = 5.0,
        requires = "uncalibrated",
        allow_hyphen_values = true
    )]
    pub threshold: f64,
    /// Interpolation, as image_proc: 0 nearest, 1 linear, 2 cubic.
    #[arg(long, default_value_t = 1, value_parser = clap::value_parser!(i64).range(0..=2))]
    pub interpolation: i64,
    /// Replace the output bag if it exists.
    #[arg(long)]
    pub overwrite: bool,
    /// Write uncompressed chunks instead of zstd: faster, larger.
    #[arg(long)]
    pub uncompressed: bool,
}

fn parse_camera_info_arg(value: &str) -> Result<(String, PathBuf), String> {
    match value.split_once('=') {
        Some((topic, file)) if !topic.is_empty() && !file.is_empty() => {
            Ok((topic.to_owned(), PathBuf::from(file)))
        }
        _ => Err(format!("expected TOPIC=FILE.yaml, got {value:?}")),
    }
}

/// What [`rectify_bag`] should do beyond the input and output paths.
#[derive(Debug, Clone, Default)]
pub struct BagRectifyOptions {
    /// camera_info to use for an image topic (or for the image topics of a
    /// `<ns>/camera_info` topic) instead of the bag's.
    pub camera_infos: Vec<(String, CameraInfo)>,
    /// Interpolation and threading of remap.
    pub remap: RemapOptions,
    /// Replace an existing output bag.
    pub overwrite: bool,
    /// Write uncompressed chunks instead of zstd.
    pub uncompressed: bool,
}

/// One rectified camera of a [`BagRectifyReport`].
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct TopicReport {
    /// The input image topic.
    pub image_topic: String,
    /// The output topic, `<ns>/image_rect`.
    pub rect_topic: String,
    /// Where the camera_info came from: a bag topic or a file.
    pub camera_info_source: String,
    /// Images read on the input topic.
    pub frames: u64,
    /// Rectified images written.
    pub rectified: u64,
    /// Maps built (once per distinct camera_info).
    pub map_builds: u64,
}

/// A message that could not be used, and why.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Problem {
    /// The message's topic.
    pub topic: String,
    /// Its log time, nanoseconds since the Unix epoch.
    pub log_time_ns: u64,
    /// What was wrong.
    pub reason: String,
}

/// An image topic left unrectified.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct UnrectifiedTopic {
    /// The image topic.
    pub topic: String,
    /// Why it was not rectified.
    pub reason: String,
}

/// The outcome of [`rectify_bag`].
#[derive(Debug, Clone, PartialEq)]
pub struct BagRectifyReport {
    /// The bag written.
    pub output: PathBuf,
    /// Per rectified camera, in topic order.
    pub topics: Vec<TopicReport>,
    /// Image topics left unrectified.
    pub unrectified_topics: Vec<UnrectifiedTopic>,
    /// Messages copied from the input.
    pub copied: u64,
    /// Messages that could not be used (the first [`MAX_PROBLEMS_KEPT`]).
    pub problems: Vec<Problem>,
    /// Total number of problems.
    pub problem_count: u64,
    /// Damage in the input bag that ended reading early, if any: every message before it
    /// was processed and the output bag is complete for them.
    pub damage: Option<String>,
    /// Wall time of the whole run.
    pub elapsed: Duration,
}

impl BagRectifyReport {
    /// Rectified images per second over the whole run.
    pub fn frames_per_second(&self) -> f64 {
        let rectified: u64 = self.topics.iter().map(|t| t.rectified).sum();
        rectified as f64 / self.elapsed.as_secs_f64().max(1e-9)
    }
}

/// Runs `stereocal rectify`.
pub fn run(args: &RectifyArgs) -> anyhow::Result<()> {
    if args.uncalibrated {
        return run_uncalibrated(args);
    }
    let camera_infos = args
        .camera_info
        .iter()
        .map(|(topic, file)| {
            let calibration = CameraInfoFile::read(file)
                .with_context(|| format!("--camera-info {topic}={}", file.display()))?;
            Ok((topic.clone(), calibration.info))
        })
        .collect::<anyhow::Result<Vec<_>>>()?;
    let options = BagRectifyOptions {
        camera_infos,
        remap: remap_options(args)?,
        overwrite: args.overwrite,
        uncompressed: args.uncompressed,
    };
    let progress = progress_bar("frames")?;
    let report = rectify_bag(&args.bag, &args.out, &options, &progress)?;
    progress.finish_and_clear();
    print_summary(&report);
    fail_on_damage(report.damage.as_deref(), &report.output)
}

/// The remap options of `--interpolation`.
fn remap_options(args: &RectifyArgs) -> anyhow::Result<RemapOptions> {
    let interpolation = Interpolation::from_ros_parameter(args.interpolation)
        .with_context(|| format!("--interpolation {}: expected 0, 1 or 2", args.interpolation))?;
    Ok(RemapOptions {
        interpolation,
        ..RemapOptions::default()
    })
}

/// The progress bar of a run that counts `unit`.
fn progress_bar(unit: &str) -> anyhow::Result<ProgressBar> {
    let template = format!(
        "{{spinner}} [{{elapsed_precise}}] {{bar:40}} {{pos}}/{{len}} {unit} ({{per_sec}}, eta {{eta}})"
    );
    Ok(ProgressBar::new(0)
        .with_style(ProgressStyle::with_template(&template).context("progress bar template")?))
}

/// An error when the input bag's `damage` ended the run early; `output` still holds
/// everything before it.
fn fail_on_damage(damage: Option<&str>, output: &Path) -> anyhow::Result<()> {
    if let Some(damage) = damage {
        bail!(
            "the input bag is damaged ({damage}); {} holds everything before the damage",
            output.display()
        );
    }
    Ok(())
}

/// Runs `stereocal rectify --uncalibrated`.
fn run_uncalibrated(args: &RectifyArgs) -> anyhow::Result<()> {
    // Refused before the bag is searched; the vision function refuses it too.
    if args.threshold.is_nan() || args.threshold <= 0.0 {
        bail!(
            "--threshold {}: expected a distance above 0 px (matched points farther than it from their epipolar lines are left out)",
            args.threshold
        );
    }
    let source = match (&args.points, &args.pattern, &args.size, &args.square) {
        (Some(file), ..) => MatchSource::Points(read_points_file(file)?),
        (None, pattern, Some(size), Some(square)) => MatchSource::Target(
            PatternArgs {
                pattern: Some(pattern.clone().unwrap_or_else(|| "chessboard".to_owned())),
                size: Some(size.clone()),
                square: Some(square.clone()),
                marker_size: args.charuco.marker_size.clone(),
                aruco_dict: args.charuco.aruco_dict.clone(),
            }
            .target()?,
        ),
        _ => bail!(
            "--uncalibrated needs matched points: a target (--pattern P --size CxR --square S) or --points FILE"
        ),
    };
    let options = UncalibratedOptions {
        left: args.left.clone(),
        right: args.right.clone(),
        source,
        threshold: args.threshold,
        remap: remap_options(args)?,
        overwrite: args.overwrite,
        uncompressed: args.uncompressed,
    };
    let progress = progress_bar("images")?;
    let report = rectify_bag_uncalibrated(&args.bag, &args.out, &options, &progress)?;
    progress.finish_and_clear();
    print_uncalibrated_summary(&report);
    fail_on_damage(report.damage.as_deref(), &report.output)
}

fn print_summary(report: &BagRectifyReport) {
    let rectified: u64 = report.topics.iter().map(|t| t.rectified).sum();
    eprintln!(
        "rectified {rectified} frames in {:.2} s ({:.1} frames/s), copied {} messages into {}",
        report.elapsed.as_secs_f64(),
        report.frames_per_second(),
        report.copied,
        report.output.display()
    );
    for t in &report.topics {
        eprintln!(
            "  {} -> {}: {}/{} frames rectified, {} map build(s), camera_info from {}",
            t.image_topic, t.rect_topic, t.rectified, t.frames, t.map_builds, t.camera_info_source
        );
    }
    for t in &report.unrectified_topics {
        eprintln!("  {}: not rectified: {}", t.topic, t.reason);
    }
    if report.problem_count > 0 {
        eprintln!(
            "  {} message(s) skipped (reported above)",
            report.problem_count
        );
    }
}

/// Where a camera's camera_info comes from.
enum InfoSource {
    /// A topic of the bag.
    Topic(String),
    /// Given by the caller.
    Fixed(Box<CameraInfo>),
}

/// An image waiting for its camera_info: its times and stamp, still encoded.
struct PendingImage {
    log_time_ns: u64,
    publish_time_ns: u64,
    header: Header,
    data: Arc<Vec<u8>>,
}

/// One image topic being rectified, as the processing stage sees it.
struct Camera {
    image_topic: String,
    /// Raw or compressed images.
    kind: ImageKind,
    /// How much this stream is preferred among those of one camera.
    preference: (bool, bool),
    rect_topic: String,
    rect_id: TopicId,
    source: InfoSource,
    source_label: String,
    recent_infos: VecDeque<CameraInfo>,
    /// Images waiting for their camera_info.
    pending: VecDeque<PendingImage>,
    rectifier: Rectifier,
    frames: u64,
}

/// What the processing stage hands the writer for one message.
enum Outcome {
    /// What became of an image of camera `camera`.
    Frame {
        camera: usize,
        log_time_ns: u64,
        publish_time_ns: u64,
        /// The rectified image's CDR bytes, nothing for an uncalibrated camera_info
        /// (with the warning to give once), or why the image was skipped.
        result: Result<Option<Vec<u8>>, String>,
        warning: Option<String>,
    },
    /// A message that could not be used.
    Problem {
        topic: String,
        log_time_ns: u64,
        reason: String,
    },
}

/// Collects problems: printed as they happen (above the progress bar), the first ones
/// kept for the report.
pub(super) struct Problems<'a> {
    pub(super) progress: &'a ProgressBar,
    pub(super) kept: Vec<Problem>,
    pub(super) count: u64,
}

impl<'a> Problems<'a> {
    /// No problems yet; they print above `progress`.
    pub(super) fn new(progress: &'a ProgressBar) -> Self {
        Self {
            progress,
            kept: Vec::new(),
            count: 0,
        }
    }

    pub(super) fn report(&mut self, topic: &str, log_time_ns: u64, reason: String) {
        self.progress.suspend(|| {
            eprintln!("skipped {topic} message at log time {log_time_ns} ns: {reason}");
        });
        self.count += 1;
        if self.kept.len() < MAX_PROBLEMS_KEPT {
            self.kept.push(Problem {
                topic: topic.to_owned(),
                log_time_ns,
                reason,
            });
        }
    }
}

/// Rectifies every image topic of the bag at `input` that has a camera_info (the bag's
/// `<ns>/camera_info` beside `<ns>/image_raw` or `<ns>/image`, or one given in
/// `options`) into `<ns>/image_rect`, and writes it with copies of every input topic
/// to the bag at `output` (atomically: nothing appears there unless the run succeeds).
/// Bad messages are reported and skipped. `progress` counts rectified frames; pass
/// [`ProgressBar::hidden`] for none.
pub fn rectify_bag(
    input: &Path,
    output: &Path,
    options: &BagRectifyOptions,
    progress: &ProgressBar,
) -> anyhow::Result<BagRectifyReport> {
    let started = Instant::now();
    let reader = BagReader::open(input).with_context(|| format!("opening {}", input.display()))?;
    let mut writer = create_output_bag(output, options.overwrite, options.uncompressed)?;

    let copy_ids = writer.add_topics_of(reader.topics())?;
    let (mut cameras, unrectified_topics) = plan_cameras(&reader, options, &mut writer)?;
    progress
        .set_length(reader.topics_message_count(cameras.iter().map(|c| c.image_topic.as_str())));

    let outputs: Vec<(String, TopicId)> = cameras
        .iter()
        .map(|c| (c.image_topic.clone(), c.rect_id))
        .collect();
    let mut rectified = vec![0; cameras.len()];
    let mut problems = Problems::new(progress);
    let write = |outcome: Outcome, writer: &mut BagWriter| -> anyhow::Result<()> {
        match outcome {
            Outcome::Frame {
                camera,
                log_time_ns,
                publish_time_ns,
                result,
                warning,
            } => {
                let (topic, rect_id) = &outputs[camera];
                progress.inc(1);
                if let Some(warning) = warning {
                    problems.report(topic, log_time_ns, warning);
                }
                match result {
                    Ok(Some(data)) => {
                        writer.write_timed(*rect_id, log_time_ns, publish_time_ns, &data)?;
                        rectified[camera] += 1;
                    }
                    Ok(None) => {}
                    Err(reason) => problems.report(topic, log_time_ns, reason),
                }
            }
            Outcome::Problem {
                topic,
                log_time_ns,
                reason,
            } => problems.report(&topic, log_time_ns, reason),
        }
        Ok(())
    };
    let remap = options.remap;
    let ((copied, damage), writer) = pipeline::run(
        reader.messages(&TopicFilter::All),
        writer,
        write,
        |messages, out| {
            let mut copied = 0;
            let mut damage = None;
            for message in messages {
                let message = match message {
                    Ok(message) => message,
                    Err(e) => {
                        damage = Some(e.to_string());
                        break;
                    }
                };
                let data = Arc::new(message.data);
                if let Some(&id) = copy_ids.get(&*message.topic) {
                    out.copy(
                        id,
                        message.log_time_ns,
                        message.publish_time_ns,
                        data.clone(),
                    )?;
                    copied += 1;
                }
                for (index, camera) in cameras.iter_mut().enumerate() {
                    if *message.topic == camera.image_topic {
                        camera.frames += 1;
                        match cdr::prefix_from_bytes::<Header>(&data) {
                            Ok(header) => camera.pending.push_back(PendingImage {
                                log_time_ns: message.log_time_ns,
                                publish_time_ns: message.publish_time_ns,
                                header,
                                data: data.clone(),
                            }),
                            Err(e) => out.ready(Outcome::Frame {
                                camera: index,
                                log_time_ns: message.log_time_ns,
                                publish_time_ns: message.publish_time_ns,
                                result: Err(e.to_string()),
                                warning: None,
                            })?,
                        }
                    } else if matches!(&camera.source, InfoSource::Topic(t) if *t == *message.topic)
                    {
                        match cdr::from_bytes::<CameraInfo>(&data) {
                            Ok(info) => {
                                if camera.recent_infos.len() == RECENT_INFOS {
                                    camera.recent_infos.pop_front();
                                }
                                camera.recent_infos.push_back(info);
                            }
                            Err(e) => out.ready(Outcome::Problem {
                                topic: message.topic.to_string(),
                                log_time_ns: message.log_time_ns,
                                reason: e.to_string(),
                            })?,
                        }
                    } else {
                        continue;
                    }
                    camera.drain(index, false, remap, out)?;
                }
            }
            for (index, camera) in cameras.iter_mut().enumerate() {
                camera.drain(index, true, remap, out)?;
            }
            Ok((copied, damage))
        },
    )?;
    let output = writer
        .finish()
        .with_context(|| format!("finishing {}", output.display()))?;
    Ok(BagRectifyReport {
        output,
        topics: cameras
            .iter()
            .zip(rectified)
            .map(|(c, rectified)| TopicReport {
                image_topic: c.image_topic.clone(),
                rect_topic: c.rect_topic.clone(),
                camera_info_source: c.source_label.clone(),
                frames: c.frames,
                rectified,
                map_builds: c.rectifier.map_builds() as u64,
            })
            .collect(),
        unrectified_topics,
        copied,
        problems: problems.kept,
        problem_count: problems.count,
        damage,
        elapsed: started.elapsed(),
    })
}

/// Decides which image topics are rectified, from what camera_info, into which topic,
/// and adds the output topics to `writer`. Returns the cameras and the image topics
/// left out with the reason.
fn plan_cameras(
    reader: &BagReader,
    options: &BagRectifyOptions,
    writer: &mut BagWriter,
) -> anyhow::Result<(Vec<Camera>, Vec<UnrectifiedTopic>)> {
    let image_topics = image_topics(reader);
    for (topic, _) in &options.camera_infos {
        let names_image = image_topics.contains(&topic.as_str());
        let names_info = topic.ends_with("/camera_info")
            && image_topics
                .iter()
                .any(|t| namespace(base_topic(t)) == namespace(topic));
        if !names_image && !names_info {
            bail!(
                "--camera-info {topic}: the bag has no image topic {topic} nor image topics beside it (image topics: {})",
                image_topics.join(", ")
            );
        }
    }
    let mut cameras: Vec<Camera> = Vec::new();
    let mut unrectified = Vec::new();
    for &topic in &image_topics {
        let Some(kind) = reader
            .topic(topic)
            .and_then(|t| ImageKind::of_type(&t.type_name))
        else {
            continue;
        };
        let base = base_topic(topic);
        let ns = namespace(base);
        let info_topic = format!("{ns}/camera_info");
        let given = options
            .camera_infos
            .iter()
            .find(|(t, _)| t == topic || *t == info_topic);
        let leaf = &base[ns.len()..];
        let conventional = leaf == "/image_raw" || leaf == "/image";
        let (source, source_label) = match given {
            Some((t, info)) => (
                InfoSource::Fixed(Box::new(info.clone())),
                format!("--camera-info {t}"),
            ),
            None if !conventional => {
                unrectified.push(UnrectifiedTopic {
                    topic: topic.to_owned(),
                    reason: "not named <ns>/image_raw or <ns>/image; give --camera-info for it"
                        .to_owned(),
                });
                continue;
            }
            None => match reader.topic(&info_topic) {
                Some(t) if t.type_name == CameraInfo::TYPE_NAME => {
                    (InfoSource::Topic(info_topic.clone()), info_topic.clone())
                }
                _ => {
                    unrectified.push(UnrectifiedTopic {
                        topic: topic.to_owned(),
                        reason: format!("no {info_topic} in the bag and no --camera-info for it"),
                    });
                    continue;
                }
            },
        };
        let rect_topic = format!("{ns}/image_rect");
        // Of the streams of one camera, the pipeline's input is the raw one: image_raw
        // before image, uncompressed before compressed.
        let preference = (leaf == "/image_raw", kind == ImageKind::Raw);
        if let Some(other) = cameras.iter().find(|c| c.rect_topic == rect_topic) {
            if preference > other.preference {
                unrectified.push(UnrectifiedTopic {
                    topic: other.image_topic.clone(),
                    reason: format!("{topic} is rectified into {rect_topic} instead"),
                });
                cameras.retain(|c| c.rect_topic != rect_topic);
            } else {
                unrectified.push(UnrectifiedTopic {
                    topic: topic.to_owned(),
                    reason: format!(
                        "{} is rectified into {rect_topic} instead",
                        other.image_topic
                    ),
                });
                continue;
            }
        }
        if reader.topic(&rect_topic).is_some() {
            bail!(
                "the input bag already has {rect_topic}; rectifying {topic} would mix two streams on it"
            );
        }
        let rect_id =
            writer.add_topic(&rect_topic, ImageMsg::TYPE_NAME, &ImageMsg::schema_text())?;
        cameras.push(Camera {
            image_topic: topic.to_owned(),
            kind,
            preference,
            rect_topic,
            rect_id,
            source,
            source_label,
            recent_infos: VecDeque::new(),
            pending: VecDeque::new(),
            rectifier: Rectifier::new(options.remap),
            frames: 0,
        });
    }
    Ok((cameras, unrectified))
}

impl Camera {
    /// Queues the waiting images that can be paired with a camera_info now (with
    /// `finish`, all of them) to be rectified on the pool. This is camera `index`.
    fn drain(
        &mut self,
        index: usize,
        finish: bool,
        remap: RemapOptions,
        out: &Output<'_, '_, Outcome>,
    ) -> anyhow::Result<()> {
        while let Some(image) = self.pending.front() {
            let stamp = image.header.stamp;
            let info = match &self.source {
                InfoSource::Fixed(info) => Some(info.as_ref()),
                InfoSource::Topic(_) => {
                    let exact = self
                        .recent_infos
                        .iter()
                        .rev()
                        .find(|i| i.header.stamp == stamp);
                    let newer_arrived = self.recent_infos.iter().any(|i| i.header.stamp > stamp);
                    let stop_waiting = finish || self.pending.len() > MAX_PENDING || newer_arrived;
                    match exact {
                        Some(info) => Some(info),
                        None if !stop_waiting => return Ok(()),
                        None => {
                            self.recent_infos.iter().rev().min_by_key(|i| {
                                (i.header.stamp.as_nanos() - stamp.as_nanos()).abs()
                            })
                        }
                    }
                }
            };
            let Some(image) = self.pending.pop_front() else {
                break;
            };
            let (log_time_ns, publish_time_ns) = (image.log_time_ns, image.publish_time_ns);
            let frame = move |result, warning| Outcome::Frame {
                camera: index,
                log_time_ns,
                publish_time_ns,
                result,
                warning,
            };
            let Some(info) = info else {
                let reason = format!("no camera_info on {} before this image", self.source_label);
                out.ready(frame(Err(reason), None))?;
                continue;
            };
            match self.rectifier.plan(&image.header.frame_id, info) {
                Ok(Plan::Remap(map)) => {
                    let kind = self.kind;
                    out.spawn(move || {
                        frame(rectify_encoded(kind, &image.data, &map, remap), None)
                    })?;
                }
                Ok(Plan::Uncalibrated { warning }) => out.ready(frame(Ok(None), warning))?,
                Err(e) => out.ready(frame(Err(e.to_string()), None))?,
            }
        }
        Ok(())
    }
}

/// The CDR bytes of the rectified image of a CDR image message of `kind`, or why there
/// are none.
fn rectify_encoded(
    kind: ImageKind,
    data: &[u8],
    map: &RectifyMap,
    remap: RemapOptions,
) -> Result<Option<Vec<u8>>, String> {
    let image = kind.decode(data)?;
    let mut source = Image::zeros_u8(0, 0, 1);
    let mut rectified = Image::zeros_u8(0, 0, 1);
    let rect = remap_image_msg(&image, map, remap, &mut source, &mut rectified)
        .map_err(|e| e.to_string())?;
    cdr::to_bytes(&rect).map(Some).map_err(|e| e.to_string())
}

/// The namespace of a topic: everything before its last `/`.
pub(super) fn namespace(topic: &str) -> &str {
    topic.rsplit_once('/').map_or("", |(ns, _)| ns)
}
