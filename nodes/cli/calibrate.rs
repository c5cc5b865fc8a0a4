//! `stereocal calibrate`: calibrates a camera or a stereo pair from a bag of target
//! images and writes camera_calibration_parsers YAML files (and `stereo.yaml` for a
//! pair).
//!
//! The bag is streamed: a small batch of images is held at a time, detected in parallel,
//! and only the corners are kept, so memory stays bounded whatever the bag's size.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use anyhow::{Context, bail};
use indicatif::{ProgressBar, ProgressStyle};
use rayon::prelude::*;
use serde::Serialize;
use serde_json::json;
use stereocal_msgs::RosMessage;
use stereocal_msgs::atomic_file;
use stereocal_msgs::builtin_interfaces::Time;
use stereocal_msgs::camera_info_file::CameraInfoFile;
use stereocal_msgs::cdr;
use stereocal_msgs::sensor_msgs::Image as ImageMsg;
use stereocal_vision::board::{
    MIN_CHARUCO_CORNERS, PatternArgs, Target, TargetDetector, detector_for,
};
use stereocal_vision::calib::View;
use stereocal_vision::camera::DistortionModel;

use crate::bag::{BagReader, TopicFilter};
use crate::calibration_advice;
use crate::calibration_report::{ReportInputs, read_sample, sample_stamp, write_report};
use crate::calibration_stage::{
    CalibrationOutcome, CameraFrames, CameraResult, Frame, FrameCorners, calibrate_camera,
    calibrate_pair,
};
use crate::convert::image_from_msg;

/// Arguments of `stereocal calibrate`.
#[derive(clap::Args, Debug, Clone)]
pub struct CalibrateArgs {
    /// Input rosbag2 bag: a directory with metadata.yaml or a .mcap file.
    #[arg(long)]
    pub bag: PathBuf,
    /// Output directory for the camera_info YAML files (and stereo.yaml).
    #[arg(long)]
    pub out: PathBuf,
    /// Target kind, as ROS camera_calibration: chessboard or charuco.
    #[arg(long, default_value = "chessboard")]
    pub pattern: String,
    /// Inner corners of the chessboard, or squares of the ChArUco board, COLSxROWS
    /// (e.g. 9x6).
    #[arg(long)]
    pub size: String,
    /// Side of one square, metres.
    #[arg(long)]
    pub square: String,
    /// The markers of a ChArUco board.
    #[command(flatten)]
    pub charuco: CharucoArgs,
    /// Image topic of a mono camera. Without --topic, --left and --right, a bag with
    /// one image topic is calibrated mono, one with a `left` and a `right` image topic
    /// as a stereo pair.
    #[arg(long, conflicts_with_all = ["left", "right"])]
    pub topic: Option<String>,
    /// Image topic of the left camera of a stereo pair.
    #[arg(long, requires = "right")]
    pub left: Option<String>,
    /// Image topic of the right camera of a stereo pair.
    #[arg(long, requires = "left")]
    pub right: Option<String>,
    /// Distortion model: plumb_bob, rational_polynomial or equidistant.
    #[arg(long, default_value = "plumb_bob", value_parser = parse_model)]
    pub model: DistortionModel,
    /// Name of a mono camera: its file is <out>/<name>.yaml.
    #[arg(long, default_value = "camera")]
    pub name: String,
    /// Print the results as one JSON object on stdout.
    #[arg(long)]
    pub json: bool,
}

/// The marker options of a ChArUco target, as ROS camera_calibration names them.
#[derive(clap::Args, Clone, Debug, Default)]
pub struct CharucoArgs {
    /// Side of one ChArUco marker, metres.
    #[arg(long = "charuco_marker_size")]
    pub marker_size: Option<String>,
    /// ArUco dictionary of a ChArUco board (`4x4_50`, `DICT_5X5_100`, `aruco_orig`);
    /// default `4x4_50`.
    #[arg(long = "aruco_dict")]
    pub aruco_dict: Option<String>,
}

fn parse_model(name: &str) -> Result<DistortionModel, String> {
    DistortionModel::from_ros_name(name).ok_or_else(|| {
        format!("unknown model {name:?}: expected plumb_bob, rational_polynomial or equidistant")
    })
}

/// The outcome of [`calibrate_bag`].
#[derive(Debug, Clone, PartialEq)]
pub struct CalibrateReport {
    /// The calibration.
    pub outcome: CalibrationOutcome,
    /// Image topic of each camera, in the order of `outcome.cameras`.
    pub topics: Vec<String>,
    /// Files written.
    pub written: Vec<PathBuf>,
    /// The calibration report, `<out>/report.html`.
    pub report: PathBuf,
    /// Wall time of the whole run.
    pub elapsed: Duration,
}

/// Runs `stereocal calibrate`.
pub fn run(args: &CalibrateArgs) -> anyhow::Result<()> {
    let progress = ProgressBar::new(0).with_style(
        ProgressStyle::with_template(
            "{spinner} [{elapsed_precise}] {bar:40} {pos}/{len} images ({per_sec}, eta {eta})",
        )
        .context("progress bar template")?,
    );
    let report = calibrate_bag(args, &progress)?;
    progress.finish_and_clear();
    if args.json {
        println!("{}", report_json(&report));
    } else {
        print_human(&report);
    }
    Ok(())
}

/// Calibrates the camera or stereo pair of `args.bag` and writes `<out>/<name>.yaml`
/// (mono) or `<out>/left.yaml`, `<out>/right.yaml` and `<out>/stereo.yaml` (stereo),
/// and the report `<out>/report.html` (its rectified pair is the first pair used, read
/// back from the bag), each atomically. `progress` counts images searched; pass
/// [`ProgressBar::hidden`] for none.
pub fn calibrate_bag(
    args: &CalibrateArgs,
    progress: &ProgressBar,
) -> anyhow::Result<CalibrateReport> {
    let started = Instant::now();
    let target = PatternArgs {
        pattern: Some(args.pattern.clone()),
        size: Some(args.size.clone()),
        square: Some(args.square.clone()),
        marker_size: args.charuco.marker_size.clone(),
        aruco_dict: args.charuco.aruco_dict.clone(),
    }
    .target()?;
    let detector = detector_for(&target)?;
    let reader = BagReader::open(&args.bag)
        .with_context(|| format!("opening the bag {}", args.bag.display()))?;
    let cameras = choose_cameras(&reader, args)?;
    progress.set_length(
        cameras
            .iter()
            .filter_map(|(_, topic)| reader.topic(topic))
            .map(|t| t.message_count)
            .sum(),
    );
    let frames = detect_frames(&reader, &cameras, detector.as_ref(), progress)?;
    let outcome = match frames.as_slice() {
        [mono] => CalibrationOutcome {
            cameras: vec![calibrate_camera(mono, args.model)?],
            stereo: None,
        },
        [left, right] => calibrate_pair(left, right, args.model)?,
        _ => bail!("expected one or two cameras, got {}", frames.len()),
    };
    let written = write_results(&outcome, &args.out)?;
    let topics: Vec<String> = cameras.into_iter().map(|(_, topic)| topic).collect();
    let sample = match sample_stamp(&outcome) {
        Some(stamp) => read_sample(&reader, &topics, stamp)?,
        None => None,
    };
    let report = args.out.join("report.html");
    let inputs = ReportInputs {
        outcome: &outcome,
        frames: &frames,
        sample: sample.as_ref(),
    };
    write_report(&report, &inputs).context("making the calibration report")?;
    Ok(CalibrateReport {
        outcome,
        topics,
        written,
        report,
        elapsed: started.elapsed(),
    })
}

/// The cameras to calibrate: name and image topic.
fn choose_cameras(
    reader: &BagReader,
    args: &CalibrateArgs,
) -> anyhow::Result<Vec<(String, String)>> {
    let image_topics: Vec<&str> = reader
        .topics()
        .iter()
        .filter(|t| t.type_name == ImageMsg::TYPE_NAME)
        .map(|t| t.name.as_str())
        .collect();
    let listed = if image_topics.is_empty() {
        "none".to_owned()
    } else {
        image_topics.join(", ")
    };
    let cameras = match (&args.topic, &args.left, &args.right) {
        (Some(topic), _, _) => vec![(args.name.clone(), topic.clone())],
        (None, Some(left), Some(right)) => vec![
            ("left".to_owned(), left.clone()),
            ("right".to_owned(), right.clone()),
        ],
        _ => match image_topics.as_slice() {
            [topic] => vec![(args.name.clone(), (*topic).to_owned())],
            [a, b] if a.contains("left") && b.contains("right") => vec![
                ("left".to_owned(), (*a).to_owned()),
                ("right".to_owned(), (*b).to_owned()),
            ],
            [a, b] if b.contains("left") && a.contains("right") => vec![
                ("left".to_owned(), (*b).to_owned()),
                ("right".to_owned(), (*a).to_owned()),
            ],
            _ => bail!(
                "cannot tell which image topics to calibrate (image topics in the bag: {listed}): give --topic T for a mono camera or --left T --right T for a stereo pair"
            ),
        },
    };
    for (_, topic) in &cameras {
        match reader.topic(topic) {
            Some(t) if t.type_name == ImageMsg::TYPE_NAME => {}
            Some(t) => bail!(
                "topic {topic} carries {}, not sensor_msgs/msg/Image; image topics in the bag: {listed}",
                t.type_name
            ),
            None => {
                bail!("the bag has no topic {topic}; image topics in the bag: {listed}")
            }
        }
    }
    Ok(cameras)
}

/// An image waiting for detection: camera index, and the raw message.
struct Pending {
    camera: usize,
    data: Vec<u8>,
}

/// What detection made of one message.
struct Detected {
    camera: usize,
    stamp: Time,
    size: Option<(u32, u32)>,
    corners: FrameCorners,
}

/// Streams the cameras' images and finds the target in each, a batch of images at a
/// time in parallel; returns each camera's frames in stamp order.
fn detect_frames(
    reader: &BagReader,
    cameras: &[(String, String)],
    detector: &(dyn TargetDetector + Sync),
    progress: &ProgressBar,
) -> anyhow::Result<Vec<CameraFrames>> {
    let batch_size = 2 * rayon::current_num_threads().max(1);
    let mut collector = Collector {
        cameras,
        per_camera: cameras.iter().map(|_| BTreeMap::new()).collect(),
        sizes: vec![None; cameras.len()],
    };
    let mut batch = Vec::with_capacity(batch_size);
    let filter = TopicFilter::only(cameras.iter().map(|(_, topic)| topic.as_str()));
    for message in reader.messages(&filter) {
        let message =
            message.with_context(|| format!("reading the bag {}", reader.path().display()))?;
        if let Some(camera) = cameras.iter().position(|(_, t)| **t == *message.topic) {
            batch.push(Pending {
                camera,
                data: message.data,
            });
        }
        if batch.len() == batch_size {
            collector.absorb(&mut batch, detector, progress);
        }
    }
    collector.absorb(&mut batch, detector, progress);
    let Collector {
        per_camera, sizes, ..
    } = collector;
    cameras
        .iter()
        .zip(per_camera)
        .zip(sizes)
        .map(|(((name, topic), frames), size)| {
            let Some((width, height)) = size else {
                bail!(
                    "no decodable image on {topic}: the bag has no usable images for camera {name}"
                );
            };
            Ok(CameraFrames {
                name: name.clone(),
                width,
                height,
                frames: frames
                    .into_values()
                    .map(|d| Frame {
                        stamp: d.stamp,
                        corners: d.corners,
                    })
                    .collect(),
            })
        })
        .collect()
}

/// The frames found so far, per camera.
struct Collector<'a> {
    cameras: &'a [(String, String)],
    per_camera: Vec<BTreeMap<Time, Detected>>,
    sizes: Vec<Option<(u32, u32)>>,
}

impl Collector<'_> {
    /// Detects the target in every image of `batch` in parallel, keeps what was found
    /// and empties the batch.
    fn absorb(
        &mut self,
        batch: &mut Vec<Pending>,
        detector: &(dyn TargetDetector + Sync),
        progress: &ProgressBar,
    ) {
        let target = detector.target();
        let detected: Vec<Option<Detected>> = batch
            .par_drain(..)
            .map(|pending| {
                let found = detect_one(&pending, detector, target, progress);
                progress.inc(1);
                found
            })
            .collect();
        for mut found in detected.into_iter().flatten() {
            let camera = found.camera;
            if let Some(size) = found.size {
                match self.sizes[camera] {
                    None => self.sizes[camera] = Some(size),
                    Some(first) if first != size => {
                        found.corners = FrameCorners::Unusable(format!(
                            "image is {}x{} but the camera's first image was {}x{}",
                            size.0, size.1, first.0, first.1
                        ));
                    }
                    Some(_) => {}
                }
            }
            if self.per_camera[camera].contains_key(&found.stamp) {
                progress.suspend(|| {
                    eprintln!(
                        "{}: a second image with stamp {}.{:09} s is ignored",
                        self.cameras[camera].1, found.stamp.sec, found.stamp.nanosec
                    );
                });
                continue;
            }
            self.per_camera[camera].insert(found.stamp, found);
        }
    }
}

/// Decodes one image and looks for the target; `None` when the message cannot be
/// decoded at all (no stamp to report it under), after saying so on stderr.
fn detect_one(
    pending: &Pending,
    detector: &(dyn TargetDetector + Sync),
    target: &Target,
    progress: &ProgressBar,
) -> Option<Detected> {
    let message = match cdr::from_bytes::<ImageMsg>(&pending.data) {
        Ok(message) => message,
        Err(e) => {
            progress.suspend(|| eprintln!("skipped an undecodable image message: {e}"));
            return None;
        }
    };
    let stamp = message.header.stamp;
    let unusable = |reason: String| Detected {
        camera: pending.camera,
        stamp,
        size: None,
        corners: FrameCorners::Unusable(reason),
    };
    let image = match image_from_msg(&message) {
        Ok((_, image)) => image,
        Err(e) => return Some(unusable(e.to_string())),
    };
    let detection = match detector.detect(&image) {
        Ok(detection) => detection,
        Err(e) => return Some(unusable(e.to_string())),
    };
    let corners = match detection {
        None => FrameCorners::Unusable(match target {
            Target::Chessboard(_) => "no complete board found".to_owned(),
            Target::Charuco(_) => format!(
                "no ChArUco board found (at least {MIN_CHARUCO_CORNERS} corners, not all in one line)"
            ),
        }),
        Some(detection) => match detection.object_points(target) {
            Some(points_in_target) => FrameCorners::Found(View {
                points_in_target,
                pixels: detection.corners,
            }),
            None => FrameCorners::Unusable("detected corner ids outside the board".to_owned()),
        },
    };
    Some(Detected {
        camera: pending.camera,
        stamp,
        size: Some((message.width, message.height)),
        corners,
    })
}

/// `stereo.yaml`: the pair's extrinsics and epipolar geometry.
#[derive(Serialize)]
struct StereoFile {
    right_from_left: TransformFile,
    essential_matrix: MatrixFile,
    fundamental_matrix: MatrixFile,
    rms: f64,
    epipolar_rms: f64,
}

#[derive(Serialize)]
struct TransformFile {
    rotation: MatrixFile,
    translation: Vec<f64>,
}

/// A matrix in the camera_calibration_parsers layout.
#[derive(Serialize)]
struct MatrixFile {
    rows: usize,
    cols: usize,
    data: Vec<f64>,
}

fn matrix_file(m: &nalgebra::Matrix3<f64>) -> MatrixFile {
    MatrixFile {
        rows: 3,
        cols: 3,
        data: row_major(m),
    }
}

fn row_major(m: &nalgebra::Matrix3<f64>) -> Vec<f64> {
    m.transpose().as_slice().to_vec()
}

/// Writes every result file into `out`, atomically; returns their paths.
fn write_results(outcome: &CalibrationOutcome, out: &Path) -> anyhow::Result<Vec<PathBuf>> {
    let mut written = Vec::new();
    for camera in &outcome.cameras {
        let path = out.join(format!("{}.yaml", camera.name));
        CameraInfoFile {
            camera_name: camera.name.clone(),
            info: camera.info.clone(),
        }
        .write(&path)
        .with_context(|| format!("writing {}", path.display()))?;
        written.push(path);
    }
    if let Some(stereo) = &outcome.stereo {
        let calibration = &stereo.calibration;
        let rotation = calibration
            .right_from_left
            .rotation
            .to_rotation_matrix()
            .into_inner();
        let file = StereoFile {
            right_from_left: TransformFile {
                rotation: matrix_file(&rotation),
                translation: calibration
                    .right_from_left
                    .translation
                    .vector
                    .as_slice()
                    .to_vec(),
            },
            essential_matrix: matrix_file(&calibration.essential),
            fundamental_matrix: matrix_file(&calibration.fundamental),
            rms: calibration.rms,
            epipolar_rms: calibration.epipolar_rms,
        };
        let path = out.join("stereo.yaml");
        let text = serde_yaml::to_string(&file).context("encoding stereo.yaml")?;
        atomic_file::write(&path, text.as_bytes())
            .with_context(|| format!("writing {}", path.display()))?;
        written.push(path);
    }
    Ok(written)
}

fn stamp_json(stamp: &Time) -> serde_json::Value {
    json!({"sec": stamp.sec, "nanosec": stamp.nanosec})
}

fn camera_json(camera: &CameraResult) -> serde_json::Value {
    let model = &camera.calibration.camera;
    json!({
        "rms": camera.calibration.rms,
        "k": row_major(&model.intrinsics.matrix()),
        "d": model.distortion.coeffs(),
        "distortion_model": model.distortion.model().ros_name(),
        "width": model.width,
        "height": model.height,
        "views_used": camera.used.len(),
        "views_rejected": camera
            .rejected
            .iter()
            .map(|r| json!({"stamp": stamp_json(&r.stamp), "reason": r.reason}))
            .collect::<Vec<_>>(),
    })
}

/// The JSON object `--json` prints: per camera RMS, K (row-major), D, model, size,
/// views used and rejected (stamp as `{"sec", "nanosec"}`, reason); for a pair, the
/// stereo RMS, `right_from_left` (row-major rotation, translation in metres), epipolar
/// RMS, and the pairs used and rejected; `warnings` lists what makes the result less
/// trustworthy and what to do about it.
pub fn report_json(report: &CalibrateReport) -> serde_json::Value {
    let cameras: serde_json::Map<String, serde_json::Value> = report
        .outcome
        .cameras
        .iter()
        .map(|c| (c.name.clone(), camera_json(c)))
        .collect();
    let mut object = json!({
        "cameras": cameras,
        "warnings": calibration_advice::warnings(&report.outcome),
    });
    if let Some(stereo) = &report.outcome.stereo {
        let calibration = &stereo.calibration;
        let rotation = calibration
            .right_from_left
            .rotation
            .to_rotation_matrix()
            .into_inner();
        object["stereo"] = json!({
            "rms": calibration.rms,
            "right_from_left": {
                "rotation": row_major(&rotation),
                "translation": calibration.right_from_left.translation.vector.as_slice(),
            },
            "epipolar_rms": calibration.epipolar_rms,
            "pairs_used": stereo.used.len(),
            "pairs_rejected": stereo
                .rejected
                .iter()
                .map(|r| json!({"stamp": stamp_json(&r.stamp), "reason": r.reason}))
                .collect::<Vec<_>>(),
        });
    }
    object
}

fn print_human(report: &CalibrateReport) {
    for (camera, topic) in report.outcome.cameras.iter().zip(&report.topics) {
        let model = &camera.calibration.camera;
        let i = &model.intrinsics;
        println!(
            "camera {} ({topic}, {}x{}): RMS {:.4} px, {} views used, {} rejected",
            camera.name,
            model.width,
            model.height,
            camera.calibration.rms,
            camera.used.len(),
            camera.rejected.len()
        );
        for r in &camera.rejected {
            println!(
                "  rejected {}.{:09} s: {}",
                r.stamp.sec, r.stamp.nanosec, r.reason
            );
        }
        println!(
            "  K: fx {:.3} fy {:.3} cx {:.3} cy {:.3}",
            i.fx, i.fy, i.cx, i.cy
        );
        let d: Vec<String> = model
            .distortion
            .coeffs()
            .iter()
            .map(|c| format!("{c:.6}"))
            .collect();
        println!(
            "  D ({}): [{}]",
            model.distortion.model().ros_name(),
            d.join(", ")
        );
    }
    if let Some(stereo) = &report.outcome.stereo {
        let calibration = &stereo.calibration;
        let t = calibration.right_from_left.translation.vector;
        let (roll, pitch, yaw) = calibration.right_from_left.rotation.euler_angles();
        println!(
            "stereo: RMS {:.4} px, epipolar RMS {:.4} px, {} pairs used, {} rejected",
            calibration.rms,
            calibration.epipolar_rms,
            stereo.used.len(),
            stereo.rejected.len()
        );
        for r in &stereo.rejected {
            println!(
                "  rejected pair {}.{:09} s: {}",
                r.stamp.sec, r.stamp.nanosec, r.reason
            );
        }
        println!(
            "  baseline {:.2} mm; right_from_left translation [{:.5}, {:.5}, {:.5}] m, rotation {:.4} deg (roll {:.4}, pitch {:.4}, yaw {:.4} deg)",
            t.norm() * 1e3,
            t.x,
            t.y,
            t.z,
            calibration.right_from_left.rotation.angle().to_degrees(),
            roll.to_degrees(),
            pitch.to_degrees(),
            yaw.to_degrees()
        );
    }
    for warning in calibration_advice::warnings(&report.outcome) {
        eprintln!("warning: {warning}");
    }
    for path in &report.written {
        eprintln!("wrote {}", path.display());
    }
    println!("report: {}", report.report.display());
    eprintln!("done in {:.2} s", report.elapsed.as_secs_f64());
}
