//! `stereocal rectify --uncalibrated`: rectifies a stereo pair of a bag without a
//! calibration. The fundamental matrix comes from matched points (target corners found
//! in left and right images of the same stamp, or a `--points` file), the two
//! homographies from it as OpenCV's `stereoRectifyUncalibrated` computes them
//! ([`rectify_uncalibrated`]), and every image of each camera is warped by its
//! homography into `<ns>/image_rect`, beside copies of all input topics.
//!
//! The rectified images have no calibration: where the bag has no `<ns>/camera_info`
//! for a camera, one is written beside each rectified image with its size and `K`,
//! `R`, `P` zero (ROS's uncalibrated camera); a camera_info the bag has is copied as
//! every input topic is, and describes the raw images only.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use anyhow::{Context, bail};
use indicatif::ProgressBar;
use nalgebra::{Matrix3, Point2};
use stereocal_msgs::RosMessage;
use stereocal_msgs::cdr;
use stereocal_msgs::sensor_msgs::{CameraInfo, Image as ImageMsg};
use stereocal_rosbag::{BagReader, BagWriter, TopicFilter, TopicId};
use stereocal_vision::board::{Target, detector_for};
use stereocal_vision::calib::quality::FrameChecks;
use stereocal_vision::geometry::{RobustOptions, find_fundamental};
use stereocal_vision::rectify::{RemapOptions, UncalibratedRectification, rectify_uncalibrated};

use super::image_topics::{image_kind, image_topics};
use super::output_bag::create_output_bag;
use super::rectify::{Problem, Problems, namespace};
use crate::calibrate::offline::{CameraTopic, judge_bag_frames};
use crate::convert::{ImageKind, base_topic};
use crate::rectify::homography::{HomographyWarper, uncalibrated_info};
use crate::rectify::matches::{Match, frames_with_target, match_target_corners};

/// Sampson distance, pixels, below which a correspondence supports a fundamental
/// matrix in the RANSAC search: detected target corners are good to a fraction of a
/// pixel.
pub const FUNDAMENTAL_THRESHOLD_PX: f64 = 1.0;

/// Where the matched points come from.
#[derive(Debug, Clone)]
pub enum MatchSource {
    /// Corners of this target found in left and right images of the same stamp.
    Target(Target),
    /// Matched pixels given by the caller: `(left, right)`.
    Points(Vec<Match>),
}

/// What [`rectify_bag_uncalibrated`] should do.
#[derive(Debug, Clone)]
pub struct UncalibratedOptions {
    /// Image topic of the left camera; `None` picks the bag's image topic with `left`
    /// in its name.
    pub left: Option<String>,
    /// Image topic of the right camera; `None` as `left`.
    pub right: Option<String>,
    /// The matched points.
    pub source: MatchSource,
    /// Correspondences farther than this from their epipolar line in either image are
    /// left out of the rectification, pixels.
    pub threshold: f64,
    /// Interpolation and threading of the warp.
    pub remap: RemapOptions,
    /// Replace an existing output bag.
    pub overwrite: bool,
    /// Write uncompressed chunks instead of zstd.
    pub uncompressed: bool,
}

/// One camera of an [`UncalibratedReport`].
#[derive(Debug, Clone, PartialEq)]
pub struct SideReport {
    /// The input image topic.
    pub image_topic: String,
    /// The output topic, `<ns>/image_rect`.
    pub rect_topic: String,
    /// The `<ns>/camera_info` written beside it, when the bag had none.
    pub info_topic: Option<String>,
    /// Images read.
    pub frames: u64,
    /// Rectified images written.
    pub rectified: u64,
}

/// The outcome of [`rectify_bag_uncalibrated`].
#[derive(Debug, Clone)]
pub struct UncalibratedReport {
    /// The bag written.
    pub output: PathBuf,
    /// Left and right cameras.
    pub sides: [SideReport; 2],
    /// Size of the images, `(width, height)`.
    pub image_size: (u32, u32),
    /// Matched points found or given.
    pub correspondences: usize,
    /// Stereo pairs whose target corners were matched (0 with `--points`).
    pub pairs_matched: usize,
    /// `F` of the matches, `[r.x r.y 1] F [l.x l.y 1]^T = 0`.
    pub fundamental: Matrix3<f64>,
    /// Matches the RANSAC search for `F` kept.
    pub fundamental_inliers: usize,
    /// The homographies, and the matches used for them.
    pub rectification: UncalibratedRectification,
    /// Mean and largest |row difference| of the matches used, after rectification,
    /// pixels.
    pub row_offset_px: (f64, f64),
    /// Messages copied from the input.
    pub copied: u64,
    /// Messages that could not be used (the first ones).
    pub problems: Vec<Problem>,
    /// Total number of problems.
    pub problem_count: u64,
    /// Damage in the input bag that ended the warping pass early, if any.
    pub damage: Option<String>,
    /// Wall time of the whole run.
    pub elapsed: Duration,
}

/// Rectifies the stereo pair of the bag at `input` without calibration and writes
/// `<ns>/image_rect` for both cameras beside copies of every input topic to `output`
/// (atomically). `progress` counts images searched for the target, then images warped;
/// pass [`ProgressBar::hidden`] for none.
pub fn rectify_bag_uncalibrated(
    input: &Path,
    output: &Path,
    options: &UncalibratedOptions,
    progress: &ProgressBar,
) -> anyhow::Result<UncalibratedReport> {
    let started = Instant::now();
    let reader = BagReader::open(input).with_context(|| format!("opening {}", input.display()))?;
    let cameras = choose_pair(&reader, options)?;
    let matches = match &options.source {
        MatchSource::Target(target) => target_matches(&reader, &cameras, target, progress)?,
        MatchSource::Points(points) => Matches {
            points: points.clone(),
            pairs: 0,
            image_size: pair_size(
                first_image_size(&reader, &cameras[0])?,
                first_image_size(&reader, &cameras[1])?,
            )?,
        },
    };
    let (image_size, pairs_matched) = (matches.image_size, matches.pairs);
    let (left, right): (Vec<_>, Vec<_>) = matches.points.iter().copied().unzip();
    let estimate = find_fundamental(
        &left,
        &right,
        &RobustOptions::ransac(FUNDAMENTAL_THRESHOLD_PX),
    )
    .with_context(|| {
        format!(
            "estimating the fundamental matrix from {} matched points",
            left.len()
        )
    })?;
    let rectification = rectify_uncalibrated(
        &left,
        &right,
        &estimate.fundamental,
        image_size,
        options.threshold,
    )
    .with_context(|| {
        format!(
            "rectifying from {} matched points (the fundamental matrix explains {} of them)",
            left.len(),
            estimate.inlier_count
        )
    })?;
    let row_offset_px = row_offsets(&rectification, &left, &right);

    progress.set_position(0);
    progress.set_length(reader.topics_message_count(cameras.iter().map(|c| c.topic.as_str())));
    let mut pass = WarpPass::new(&reader, output, options, &cameras, &rectification, progress)?;
    let damage = pass.run(&reader, image_size)?;
    let WarpPass {
        writer,
        sides,
        problems,
        copied,
        ..
    } = pass;
    let output = writer
        .finish()
        .with_context(|| format!("finishing {}", output.display()))?;
    Ok(UncalibratedReport {
        output,
        sides: sides.map(|s| s.report),
        image_size,
        correspondences: left.len(),
        pairs_matched,
        fundamental: estimate.fundamental,
        fundamental_inliers: estimate.inlier_count,
        rectification,
        row_offset_px,
        copied,
        problems: problems.kept,
        problem_count: problems.count,
        damage,
        elapsed: started.elapsed(),
    })
}

/// Prints what [`rectify_bag_uncalibrated`] did, on stderr.
pub fn print_summary(report: &UncalibratedReport) {
    let rectified: u64 = report.sides.iter().map(|s| s.rectified).sum();
    let source = if report.pairs_matched > 0 {
        format!(
            "{} target corners matched in {} stereo pairs",
            report.correspondences, report.pairs_matched
        )
    } else {
        format!("{} matched points", report.correspondences)
    };
    let (mean, max) = report.row_offset_px;
    eprintln!(
        "uncalibrated rectification from {source}: F explains {} of them; the {} within the threshold of their epipolar lines give the homographies, and their rows after rectification differ by mean {mean:.3} px, max {max:.3} px",
        report.fundamental_inliers, report.rectification.inlier_count
    );
    for (name, h) in [
        (
            "rectified_left_from_image_left",
            &report.rectification.rectified_left_from_image_left,
        ),
        (
            "rectified_right_from_image_right",
            &report.rectification.rectified_right_from_image_right,
        ),
    ] {
        let rows: Vec<String> = h
            .row_iter()
            .map(|r| format!("[{:.6e}, {:.6e}, {:.6e}]", r[0], r[1], r[2]))
            .collect();
        eprintln!("  {name} = [{}]", rows.join(", "));
    }
    eprintln!(
        "rectified {rectified} frames in {:.2} s, copied {} messages into {}",
        report.elapsed.as_secs_f64(),
        report.copied,
        report.output.display()
    );
    for s in &report.sides {
        let info = match &s.info_topic {
            Some(topic) => format!(", uncalibrated camera_info on {topic}"),
            None => format!(
                ", the bag's {}/camera_info copied (it describes the raw images, not these)",
                namespace(&s.rect_topic)
            ),
        };
        eprintln!(
            "  {} -> {}: {}/{} frames rectified{info}",
            s.image_topic, s.rect_topic, s.rectified, s.frames
        );
    }
    if report.problem_count > 0 {
        eprintln!(
            "  {} message(s) skipped (reported above)",
            report.problem_count
        );
    }
}

/// The left and right image topics: the options', or the bag's image topics with
/// `left` and `right` in their names.
fn choose_pair(
    reader: &BagReader,
    options: &UncalibratedOptions,
) -> anyhow::Result<[CameraTopic; 2]> {
    let topics = image_topics(reader);
    let listed = if topics.is_empty() {
        "none".to_owned()
    } else {
        topics.join(", ")
    };
    let pick = |given: &Option<String>, side: &str| -> anyhow::Result<String> {
        if let Some(topic) = given {
            return Ok(topic.clone());
        }
        let candidates: Vec<&&str> = topics.iter().filter(|t| t.contains(side)).collect();
        match candidates.as_slice() {
            [topic] => Ok((**topic).to_owned()),
            _ => bail!(
                "cannot tell which image topic is the {side} camera (image topics in the bag: {listed}): give --left T --right T"
            ),
        }
    };
    let (left, right) = (pick(&options.left, "left")?, pick(&options.right, "right")?);
    if left == right {
        bail!("--left and --right are both {left}: a stereo pair needs two image topics");
    }
    let camera = |name: &str, topic: String| -> anyhow::Result<CameraTopic> {
        Ok(CameraTopic {
            name: name.to_owned(),
            kind: image_kind(reader, &topic).map_err(anyhow::Error::msg)?,
            topic,
        })
    };
    Ok([camera("left", left)?, camera("right", right)?])
}

/// Matched points of a bag, and the size of its images.
struct Matches {
    points: Vec<Match>,
    /// Stereo pairs they come from (0 for points given).
    pairs: usize,
    image_size: (u32, u32),
}

/// The target's corners matched between left and right images of the same stamp (by
/// their point on the target), the number of pairs they come from, and the image size.
fn target_matches(
    reader: &BagReader,
    cameras: &[CameraTopic; 2],
    target: &Target,
    progress: &ProgressBar,
) -> anyhow::Result<Matches> {
    let detector = detector_for(target)?;
    progress.set_length(reader.topics_message_count(cameras.iter().map(|c| c.topic.as_str())));
    let frames = judge_bag_frames(
        reader,
        cameras,
        detector.as_ref(),
        &FrameChecks::default(),
        progress,
    )?;
    let [left, right] = frames.as_slice() else {
        bail!("expected frames of two cameras, got {}", frames.len());
    };
    let size = pair_size((left.width, left.height), (right.width, right.height))?;
    let matched = match_target_corners(left, right);
    if matched.pairs == 0 {
        bail!(
            "the target was not found in a left and a right image of the same stamp ({} on {}, {} on {}): record both cameras with synchronized stamps and the whole target in view",
            frames_with_target(left),
            cameras[0].topic,
            frames_with_target(right),
            cameras[1].topic
        );
    }
    Ok(Matches {
        points: matched.points,
        pairs: matched.pairs,
        image_size: size,
    })
}

/// The one size of both cameras' images.
fn pair_size(left: (u32, u32), right: (u32, u32)) -> anyhow::Result<(u32, u32)> {
    if left != right {
        bail!(
            "the left images are {}x{} but the right ones {}x{}: uncalibrated rectification needs both cameras at one size",
            left.0,
            left.1,
            right.0,
            right.1
        );
    }
    Ok(left)
}

/// The size of the first decodable image of `camera`.
fn first_image_size(reader: &BagReader, camera: &CameraTopic) -> anyhow::Result<(u32, u32)> {
    let mut last_error = None;
    for message in reader.messages(&TopicFilter::only([camera.topic.as_str()])) {
        let message =
            message.with_context(|| format!("reading the bag {}", reader.path().display()))?;
        match camera.kind.decode(&message.data) {
            Ok(image) => return Ok((image.width, image.height)),
            Err(e) => last_error = Some(e),
        }
    }
    match last_error {
        Some(e) => bail!("no decodable image on {}: {e}", camera.topic),
        None => bail!("no image on {}", camera.topic),
    }
}

/// Mean and largest |row difference| of the matches used, after rectification.
fn row_offsets(
    rectification: &UncalibratedRectification,
    left: &[Point2<f64>],
    right: &[Point2<f64>],
) -> (f64, f64) {
    let row = |h: &Matrix3<f64>, p: &Point2<f64>| {
        let q = h * p.to_homogeneous();
        q.y / q.z
    };
    let offsets: Vec<f64> = left
        .iter()
        .zip(right)
        .zip(&rectification.inliers)
        .filter(|(_, used)| **used)
        .map(|((l, r), _)| {
            (row(&rectification.rectified_left_from_image_left, l)
                - row(&rectification.rectified_right_from_image_right, r))
            .abs()
        })
        .collect();
    let mean = offsets.iter().sum::<f64>() / offsets.len().max(1) as f64;
    (mean, offsets.iter().copied().fold(0.0, f64::max))
}

/// One camera being warped.
struct Side {
    image_topic: String,
    kind: ImageKind,
    warper: HomographyWarper,
    rect_id: TopicId,
    /// Where the uncalibrated camera_info goes, when the bag has none for the camera.
    info_id: Option<TopicId>,
    report: SideReport,
}

/// The second pass: every message copied, every image of the pair warped.
struct WarpPass<'a> {
    writer: BagWriter,
    copy_ids: BTreeMap<String, TopicId>,
    sides: [Side; 2],
    problems: Problems<'a>,
    copied: u64,
}

impl<'a> WarpPass<'a> {
    fn new(
        reader: &BagReader,
        output: &Path,
        options: &UncalibratedOptions,
        cameras: &[CameraTopic; 2],
        rectification: &UncalibratedRectification,
        progress: &'a ProgressBar,
    ) -> anyhow::Result<Self> {
        let mut writer = create_output_bag(output, options.overwrite, options.uncompressed)?;
        let copy_ids = writer.add_topics_of(reader.topics())?;
        let homographies = [
            &rectification.rectified_left_from_image_left,
            &rectification.rectified_right_from_image_right,
        ];
        let mut sides = Vec::with_capacity(2);
        for (camera, h) in cameras.iter().zip(homographies) {
            let ns = namespace(base_topic(&camera.topic));
            let rect_topic = format!("{ns}/image_rect");
            if reader.topic(&rect_topic).is_some() {
                bail!(
                    "the input bag already has {rect_topic}; rectifying {} would mix two streams on it",
                    camera.topic
                );
            }
            let info_topic = format!("{ns}/camera_info");
            let info_id = if reader.topic(&info_topic).is_none() {
                Some(writer.add_topic(
                    &info_topic,
                    CameraInfo::TYPE_NAME,
                    &CameraInfo::schema_text(),
                )?)
            } else {
                None
            };
            let warper = HomographyWarper::new(h, options.remap)
                .with_context(|| format!("the homography of {} is singular", camera.topic))?;
            sides.push(Side {
                image_topic: camera.topic.clone(),
                kind: camera.kind,
                warper,
                rect_id: writer.add_topic(
                    &rect_topic,
                    ImageMsg::TYPE_NAME,
                    &ImageMsg::schema_text(),
                )?,
                info_id,
                report: SideReport {
                    image_topic: camera.topic.clone(),
                    rect_topic,
                    info_topic: info_id.map(|_| info_topic),
                    frames: 0,
                    rectified: 0,
                },
            });
        }
        let sides: [Side; 2] = sides
            .try_into()
            .map_err(|_| anyhow::anyhow!("a stereo pair has two cameras"))?;
        Ok(Self {
            writer,
            copy_ids,
            sides,
            problems: Problems::new(progress),
            copied: 0,
        })
    }

    /// Streams the bag; returns the damage that ended reading early, if any.
    fn run(&mut self, reader: &BagReader, size: (u32, u32)) -> anyhow::Result<Option<String>> {
        for message in reader.messages(&TopicFilter::All) {
            let message = match message {
                Ok(message) => message,
                Err(e) => return Ok(Some(e.to_string())),
            };
            if let Some(&id) = self.copy_ids.get(&*message.topic) {
                self.writer.write_timed(
                    id,
                    message.log_time_ns,
                    message.publish_time_ns,
                    &message.data,
                )?;
                self.copied += 1;
            }
            let Some(side) = self
                .sides
                .iter_mut()
                .find(|s| *s.image_topic == *message.topic)
            else {
                continue;
            };
            side.report.frames += 1;
            self.problems.progress.inc(1);
            let warped = side.kind.decode(&message.data).and_then(|image| {
                if (image.width, image.height) != size {
                    return Err(format!(
                        "image is {}x{} but the rectification is for {}x{}",
                        image.width, image.height, size.0, size.1
                    ));
                }
                side.warper.warp(&image).map_err(|e| e.to_string())
            });
            let rect = match warped {
                Ok(rect) => rect,
                Err(reason) => {
                    self.problems
                        .report(&message.topic, message.log_time_ns, reason);
                    continue;
                }
            };
            let (log, publish) = (message.log_time_ns, message.publish_time_ns);
            let data = cdr::to_bytes(&rect)
                .with_context(|| format!("encoding {}", side.report.rect_topic))?;
            self.writer.write_timed(side.rect_id, log, publish, &data)?;
            if let Some(info_id) = side.info_id {
                let info = cdr::to_bytes(&uncalibrated_info(&rect))
                    .context("encoding an uncalibrated camera_info")?;
                self.writer.write_timed(info_id, log, publish, &info)?;
            }
            side.report.rectified += 1;
        }
        Ok(None)
    }
}
