//! `stereocal depth`: the disparity of every stereo pair of a bag, written as
//! `<ns>/disparity` (stereo_msgs/DisparityImage) and `<ns>/points2` (an organized
//! sensor_msgs/PointCloud2) beside copies of all input topics. Rectified pairs
//! (`image_rect` topics) are matched as they are; raw pairs are rectified first with
//! their camera_infos, as the rectify nodes would.
//!
//! Pairs are the left and right images of one stamp; each is matched with the
//! camera_info of its side with that stamp, or the latest one before it. The bag is
//! streamed through a [`pipeline`]: read ahead on one thread, matched on this one (the
//! matcher runs on all cores), written on another; a few images per side wait for
//! their partner, so memory stays bounded whatever the bag's size.

use std::collections::VecDeque;
use std::path::PathBuf;
use std::sync::Arc;
use std::time::Instant;

use anyhow::{Context, bail};
use indicatif::{ProgressBar, ProgressStyle};
use serde::Serialize;
use stereocal_msgs::builtin_interfaces::Time;
use stereocal_msgs::cdr;
use stereocal_msgs::sensor_msgs::{CameraInfo, Image as ImageMsg, PointCloud2};
use stereocal_msgs::stereo_msgs::DisparityImage;
use stereocal_rosbag::{BagReader, BagWriter, OfferedQos, TopicFilter};
use stereocal_vision::stereo::{BmParams, Paths, SgmParams};

use super::output_bag::create_output_bag;
use super::pipeline::{self, Output};
use crate::depth::stage::{DepthStage, MatcherParams, disparity_msg, points_msg};
use crate::rectify::stage::{Rectified, Rectifier};
use stereocal_vision::rectify::RemapOptions;

/// Images per side that may wait for their partner.
const MAX_PENDING: usize = 8;
/// Recent camera_infos kept per side.
const RECENT_INFOS: usize = 8;

/// Matching algorithm, on the command line.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum AlgorithmArg {
    /// Semi-global matching on census costs (stereo_image_proc's `stereo_algorithm: 1`).
    Sgbm,
    /// Block matching, the cheapest (`stereo_algorithm: 0`, OpenCV's StereoBM).
    Bm,
}

/// Aggregation paths, on the command line.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum PathsArg {
    /// Left, right, up and down.
    Four,
    /// One sweep: left, right and the three from above.
    Five,
    /// All eight directions.
    Eight,
}

/// Arguments of `stereocal depth`.
#[derive(clap::Args, Debug, Clone)]
pub struct DepthArgs {
    /// Input rosbag2 bag: a directory with metadata.yaml or a .mcap file.
    #[arg(long)]
    pub bag: PathBuf,
    /// Output bag: a directory, or a file ending in .mcap. Written atomically.
    #[arg(long)]
    pub out: PathBuf,
    /// Left image topic (default: the bag's only `.../left/image_rect`, else its only
    /// `.../left/image_raw`). Topics named `image_rect` or `image_rect_color` hold
    /// rectified images; any other is raw and is rectified first with its camera_info.
    #[arg(long)]
    pub left_topic: Option<String>,
    /// Right rectified image topic (default: the left one with `left` turned `right`).
    #[arg(long)]
    pub right_topic: Option<String>,
    /// Matching algorithm.
    #[arg(long, value_enum, default_value = "sgbm")]
    pub algorithm: AlgorithmArg,
    /// Block matching: side of the matching window, pixels (odd, 5 to 255).
    #[arg(long, default_value_t = BmParams::default().window)]
    pub window: usize,
    /// Smallest disparity searched, pixels.
    #[arg(long, default_value_t = 0, allow_hyphen_values = true)]
    pub min_disparity: i32,
    /// Number of disparities searched: a multiple of 16 below the image width.
    #[arg(long, default_value_t = 128)]
    pub disparity_range: usize,
    /// Semi-global matching: aggregation paths.
    #[arg(long, value_enum, default_value = "eight")]
    pub paths: PathsArg,
    /// Semi-global matching: half-size of the sub-pixel refinement's window (0: none).
    #[arg(long, default_value_t = SgmParams::default().refine_radius)]
    pub refine_radius: usize,
    /// Print one JSON object per pair (stamp, valid density, milliseconds of matching)
    /// and a summary.
    #[arg(long)]
    pub json: bool,
    /// Replace the output bag if it exists.
    #[arg(long)]
    pub overwrite: bool,
}

/// One matched pair, as `--json` prints it.
#[derive(Debug, Serialize)]
struct PairRecord {
    stamp_ns: u64,
    density: f64,
    milliseconds: f64,
}

/// What [`run`] did.
#[derive(Debug, Default, Serialize)]
struct Summary {
    pairs: u64,
    skipped: u64,
    unpaired: u64,
    frames_per_second: f64,
}

/// One side of the rig: its topics and what waits on it.
struct Side {
    image_topic: String,
    info_topic: String,
    pending: VecDeque<(u64, ImageMsg)>,
    infos: VecDeque<CameraInfo>,
    /// For raw images: what rectifies them before matching.
    rectifier: Option<Rectifier>,
}

impl Side {
    fn new(image_topic: &str) -> Self {
        Self {
            image_topic: image_topic.to_owned(),
            info_topic: format!("{}/camera_info", parent(image_topic)),
            pending: VecDeque::new(),
            infos: VecDeque::new(),
            rectifier: (!is_rectified(image_topic))
                .then(|| Rectifier::new(RemapOptions::default())),
        }
    }

    /// `image` ready to match: as it is when rectified, else rectified with `info`.
    fn rectified(
        &mut self,
        image: ImageMsg,
        info: &CameraInfo,
        side: &str,
    ) -> Result<ImageMsg, String> {
        let Some(rectifier) = &mut self.rectifier else {
            return Ok(image);
        };
        match rectifier.rectify(&image, info) {
            Ok(Rectified::Image(rect)) => Ok(rect),
            Ok(Rectified::Uncalibrated { .. }) => Err(format!(
                "the {side} camera_info is uncalibrated (K[0] == 0): its raw image cannot be rectified"
            )),
            Err(e) => Err(format!("rectifying the {side} image: {e}")),
        }
    }

    /// Whether a camera_info of `stamp` has arrived.
    fn has_info(&self, stamp: &Time) -> bool {
        let key = stamp_key(stamp);
        self.infos.iter().any(|i| stamp_key(&i.header.stamp) == key)
    }

    /// The camera_info of `stamp`, or the latest before it.
    fn info_for(&self, stamp: &Time) -> Option<&CameraInfo> {
        let key = stamp_key(stamp);
        self.infos
            .iter()
            .rev()
            .find(|i| stamp_key(&i.header.stamp) == key)
            .or_else(|| {
                self.infos
                    .iter()
                    .rev()
                    .find(|i| stamp_key(&i.header.stamp) <= key)
            })
            .or_else(|| self.infos.back())
    }
}

/// Whether a topic holds rectified images, by its name: `.../image_rect` or
/// `.../image_rect_color`.
fn is_rectified(topic: &str) -> bool {
    let leaf = topic.rsplit_once('/').map_or(topic, |(_, leaf)| leaf);
    leaf == "image_rect" || leaf == "image_rect_color"
}

fn stamp_key(stamp: &Time) -> (i32, u32) {
    (stamp.sec, stamp.nanosec)
}

/// The namespace of a topic: everything before its last `/`.
fn parent(topic: &str) -> &str {
    topic.rsplit_once('/').map_or("", |(ns, _)| ns)
}

/// Runs `stereocal depth`.
pub fn run(args: &DepthArgs) -> anyhow::Result<()> {
    let params = match args.algorithm {
        AlgorithmArg::Sgbm => MatcherParams::Sgm(SgmParams {
            min_disparity: args.min_disparity,
            disparity_range: args.disparity_range,
            paths: match args.paths {
                PathsArg::Four => Paths::Four,
                PathsArg::Five => Paths::Five,
                PathsArg::Eight => Paths::Eight,
            },
            refine_radius: args.refine_radius,
            ..SgmParams::default()
        }),
        AlgorithmArg::Bm => MatcherParams::Bm(BmParams {
            min_disparity: args.min_disparity,
            disparity_range: args.disparity_range,
            window: args.window,
            ..BmParams::default()
        }),
    };
    // Parameters that do not depend on the image are refused before reading the bag.
    params
        .validate(usize::MAX)
        .context("invalid matching parameters")?;
    let reader =
        BagReader::open(&args.bag).with_context(|| format!("opening {}", args.bag.display()))?;
    let (left_topic, right_topic) = pair_topics(&reader, args)?;
    let output_ns = parent(parent(&left_topic)).to_owned();
    let disparity_topic = format!("{output_ns}/disparity");
    let points_topic = format!("{output_ns}/points2");
    for topic in [&disparity_topic, &points_topic] {
        if reader.topic(topic).is_some() {
            bail!("the input bag already has {topic}: its messages would mix with the new ones");
        }
    }

    let mut writer = create_output_bag(&args.out, args.overwrite, false)?;
    let copy_ids = writer.add_topics_of(reader.topics())?;
    let disparity_id =
        writer.add_message_topic::<DisparityImage>(&disparity_topic, &OfferedQos::default())?;
    let points_id =
        writer.add_message_topic::<PointCloud2>(&points_topic, &OfferedQos::default())?;

    let progress = if args.json {
        ProgressBar::hidden()
    } else {
        ProgressBar::new(reader.topics_message_count([left_topic.as_str()]))
    };
    progress.set_style(
        ProgressStyle::with_template("{bar:40} {pos}/{len} pairs {per_sec} {msg}")
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    let mut sides = [Side::new(&left_topic), Side::new(&right_topic)];
    let mut stage = DepthStage::new(params);
    let mut matcher = Matcher {
        json: args.json,
        progress: &progress,
        summary: Summary::default(),
    };
    let started = Instant::now();
    let write = |pair: MatchedPair, writer: &mut BagWriter| -> anyhow::Result<()> {
        writer.write_message(disparity_id, pair.log_time_ns, &pair.disparity)?;
        writer.write_message(points_id, pair.log_time_ns, &pair.points)?;
        Ok(())
    };
    let ((), writer) = pipeline::run(
        reader.messages(&TopicFilter::All),
        writer,
        write,
        |messages, out| {
            for message in messages {
                let message = message.context("reading the bag")?;
                let data = Arc::new(message.data);
                if let Some(&id) = copy_ids.get(&*message.topic) {
                    out.copy(
                        id,
                        message.log_time_ns,
                        message.publish_time_ns,
                        data.clone(),
                    )?;
                }
                for side in sides.iter_mut() {
                    if *message.topic == side.info_topic {
                        match cdr::from_bytes::<CameraInfo>(&data) {
                            Ok(info) => {
                                if side.infos.len() == RECENT_INFOS {
                                    side.infos.pop_front();
                                }
                                side.infos.push_back(info);
                            }
                            Err(e) => {
                                progress.suspend(|| {
                                    eprintln!("skipped a camera_info on {}: {e}", message.topic)
                                });
                            }
                        }
                    } else if *message.topic == side.image_topic {
                        match cdr::from_bytes::<ImageMsg>(&data) {
                            Ok(image) => {
                                if side.pending.len() == MAX_PENDING {
                                    side.pending.pop_front();
                                    matcher.summary.unpaired += 1;
                                }
                                side.pending.push_back((message.log_time_ns, image));
                            }
                            Err(e) => {
                                matcher.summary.skipped += 1;
                                progress.suspend(|| {
                                    eprintln!("skipped an image on {}: {e}", message.topic)
                                });
                            }
                        }
                    }
                }
                // A pair waits for the camera_infos of its stamp unless its side is filling up.
                let force = sides.iter().any(|s| s.pending.len() >= MAX_PENDING / 2);
                matcher.match_pairs(&mut sides, &mut stage, out, force)?;
            }
            matcher.match_pairs(&mut sides, &mut stage, out, true)
        },
    )?;
    let mut summary = matcher.summary;
    summary.unpaired += sides.iter().map(|s| s.pending.len() as u64).sum::<u64>();
    progress.finish_and_clear();
    writer
        .finish()
        .with_context(|| format!("finishing {}", args.out.display()))?;
    summary.frames_per_second = summary.pairs as f64 / started.elapsed().as_secs_f64().max(1e-9);
    if args.json {
        println!("{}", serde_json::to_string(&summary)?);
    } else {
        eprintln!(
            "{} pairs matched ({:.1} per second) into {} in {}; {} skipped, {} images without a partner",
            summary.pairs,
            summary.frames_per_second,
            disparity_topic,
            args.out.display(),
            summary.skipped,
            summary.unpaired
        );
    }
    if summary.pairs == 0 {
        bail!("no pair of {left_topic} and {right_topic} could be matched");
    }
    Ok(())
}

/// The messages of one matched pair, for the writer.
struct MatchedPair {
    log_time_ns: u64,
    disparity: DisparityImage,
    points: PointCloud2,
}

/// Matches pairs, and counts what happened to them.
struct Matcher<'a> {
    json: bool,
    progress: &'a ProgressBar,
    summary: Summary,
}

impl Matcher<'_> {
    /// Matches the pairs both sides hold, oldest first, and queues their disparities. A
    /// pair whose stamp has no camera_info on both sides yet waits, unless `force`
    /// (then it takes the latest camera_infos).
    fn match_pairs(
        &mut self,
        sides: &mut [Side; 2],
        stage: &mut DepthStage,
        out: &Output<'_, '_, MatchedPair>,
        force: bool,
    ) -> anyhow::Result<()> {
        while let Some((left_index, right_index)) = find_pair(sides) {
            let [left, right] = sides;
            let stamp = left.pending[left_index].1.header.stamp;
            if !(force || left.has_info(&stamp) && right.has_info(&stamp)) {
                return Ok(());
            }
            let (log_time_ns, left_image) = left.pending.remove(left_index).unwrap_or_default();
            let (_, right_image) = right.pending.remove(right_index).unwrap_or_default();
            // Images older than a matched pair never find a partner.
            for side in [&mut *left, &mut *right] {
                let before = side.pending.len();
                side.pending
                    .retain(|(_, i)| stamp_key(&i.header.stamp) > stamp_key(&stamp));
                self.summary.unpaired += (before - side.pending.len()) as u64;
            }
            self.progress.inc(1);
            let (Some(left_info), Some(right_info)) =
                (left.info_for(&stamp), right.info_for(&stamp))
            else {
                self.skip(
                    &stamp,
                    "no camera_info of this stamp or before it on both sides".into(),
                );
                continue;
            };
            let (left_info, right_info) = (left_info.clone(), right_info.clone());
            let rectified = left
                .rectified(left_image, &left_info, "left")
                .and_then(|l| Ok((l, right.rectified(right_image, &right_info, "right")?)));
            let (left_image, right_image) = match rectified {
                Ok(pair) => pair,
                Err(reason) => {
                    self.skip(&stamp, reason);
                    continue;
                }
            };
            let start = Instant::now();
            match stage.disparity(&left_image, &left_info, &right_image, &right_info) {
                Ok(frame) => {
                    let milliseconds = start.elapsed().as_secs_f64() * 1e3;
                    let disparity = disparity_msg(&frame, left_image.header.clone());
                    let points = points_msg(&frame, left_image.header.clone())?;
                    out.ready(MatchedPair {
                        log_time_ns,
                        disparity,
                        points,
                    })?;
                    self.summary.pairs += 1;
                    if self.json {
                        let record = PairRecord {
                            stamp_ns: stamp.sec.max(0) as u64 * 1_000_000_000
                                + u64::from(stamp.nanosec),
                            density: frame.map.density(),
                            milliseconds,
                        };
                        println!("{}", serde_json::to_string(&record)?);
                    }
                }
                Err(e) => self.skip(&stamp, e.to_string()),
            }
        }
        Ok(())
    }

    fn skip(&mut self, stamp: &Time, reason: String) {
        self.summary.skipped += 1;
        self.progress.suspend(|| {
            eprintln!(
                "skipped the pair at {}.{:09}: {reason}",
                stamp.sec, stamp.nanosec
            );
        });
    }
}

/// Indices of a left and a right image with the same stamp, if the sides hold one.
fn find_pair(sides: &[Side; 2]) -> Option<(usize, usize)> {
    sides[0]
        .pending
        .iter()
        .enumerate()
        .find_map(|(i, (_, left))| {
            sides[1]
                .pending
                .iter()
                .position(|(_, right)| {
                    stamp_key(&right.header.stamp) == stamp_key(&left.header.stamp)
                })
                .map(|j| (i, j))
        })
}

/// The left and right image topics: as given, or the bag's only `.../left/image_rect`
/// and its `right` twin.
fn pair_topics(reader: &BagReader, args: &DepthArgs) -> anyhow::Result<(String, String)> {
    let images: Vec<&str> = reader
        .topics()
        .iter()
        .filter(|t| t.type_name == "sensor_msgs/msg/Image")
        .map(|t| t.name.as_str())
        .collect();
    let left = match &args.left_topic {
        Some(topic) => topic.clone(),
        None => {
            let rectified: Vec<&&str> = images
                .iter()
                .filter(|t| t.ends_with("left/image_rect") || t.ends_with("left/image_rect_color"))
                .collect();
            let raw: Vec<&&str> = images
                .iter()
                .filter(|t| t.ends_with("left/image_raw"))
                .collect();
            let candidates = if rectified.is_empty() { raw } else { rectified };
            match candidates.as_slice() {
                [one] => (**one).to_owned(),
                [] => bail!(
                    "the bag has no .../left/image_rect nor .../left/image_raw topic; name the pair with --left-topic and --right-topic (image topics: {})",
                    images.join(", ")
                ),
                many => bail!(
                    "the bag has several left image topics ({}); choose one with --left-topic",
                    many.iter().map(|t| **t).collect::<Vec<_>>().join(", ")
                ),
            }
        }
    };
    let right = match &args.right_topic {
        Some(topic) => topic.clone(),
        None => {
            let Some((before, after)) = left.rsplit_once("left/") else {
                bail!("cannot guess the right topic of {left}: give --right-topic");
            };
            format!("{before}right/{after}")
        }
    };
    for topic in [&left, &right] {
        if !images.contains(&topic.as_str()) {
            bail!(
                "the bag has no sensor_msgs/Image topic {topic} (image topics: {})",
                images.join(", ")
            );
        }
    }
    Ok((left, right))
}
