//! `stereocal calibrate`: calibrates a camera or a stereo pair from a bag of target
//! images and writes camera_calibration_parsers YAML files (and `stereo.yaml` for a
//! pair) and `report.html`. Every frame is judged as the calibrate node judges one
//! ([`crate::calibrate::offline`]); the results print as the one
//! [`CalibrationResult`] schema, human-readable or with `--json`.

use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use anyhow::{Context, bail};
use indicatif::{ProgressBar, ProgressStyle};
use serde::Serialize;
use stereocal_msgs::atomic_file;
use stereocal_msgs::camera_info_file::CameraInfoFile;
use stereocal_rosbag::BagReader;
use stereocal_vision::board::{PatternArgs, detector_for};
use stereocal_vision::calib::quality::{DEFAULT_MAX_BLUR, FrameChecks};
use stereocal_vision::camera::DistortionModel;

use super::image_topics::{image_kind, image_topics};
use crate::calibrate::offline::{CameraTopic, judge_bag_frames};
use crate::calibrate::report::{ReportInputs, read_sample, sample_stamp, write_report};
use crate::calibrate::result::{CalibrationResult, row_major};
use crate::calibrate::stage::{
    CalibrationOutcome, RejectedFrame, calibrate_pair, calibrate_target_camera,
};

/// Arguments of `stereocal calibrate`.
#[derive(clap::Args, Debug, Clone)]
pub struct CalibrateArgs {
    /// Input rosbag2 bag: a directory with metadata.yaml or a .mcap file.
    #[arg(long)]
    pub bag: PathBuf,
    /// Output directory for the camera_info YAML files (and stereo.yaml).
    #[arg(long)]
    pub out: PathBuf,
    /// Target kind, as ROS camera_calibration: chessboard, charuco, circles or acircles.
    #[arg(long, default_value = "chessboard")]
    pub pattern: String,
    /// Inner corners of the chessboard, squares of the ChArUco board, or circles per
    /// row and rows of a circle grid, COLSxROWS (e.g. 9x6, 4x11).
    #[arg(long)]
    pub size: String,
    /// Side of one square (a circle grid's spacing), metres.
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
    /// Frames whose board edges are wider than this (10-90 % edge width, pixels) are
    /// left out as blurred; 0 disables.
    #[arg(long = "max-blur", default_value_t = DEFAULT_MAX_BLUR)]
    pub max_blur: f64,
    /// Frames whose board moves faster than this since the camera's previous frame
    /// (pixels per second) are left out; 0 disables.
    #[arg(long = "max-board-speed", default_value_t = 0.0)]
    pub max_board_speed: f64,
    /// Print the results as one JSON object on stdout.
    #[arg(long)]
    pub json: bool,
}

impl CalibrateArgs {
    /// The arguments for a `cols x rows` chessboard (inner corners) of `square` metres in
    /// `bag`, written to `out`, with every other option at its default (the image topics
    /// chosen from the bag, plumb_bob).
    pub fn chessboard(bag: PathBuf, out: PathBuf, cols: usize, rows: usize, square: f64) -> Self {
        Self {
            bag,
            out,
            pattern: "chessboard".to_owned(),
            size: format!("{cols}x{rows}"),
            square: square.to_string(),
            charuco: CharucoArgs::default(),
            topic: None,
            left: None,
            right: None,
            model: DistortionModel::PlumbBob,
            name: "camera".to_owned(),
            max_blur: DEFAULT_MAX_BLUR,
            max_board_speed: 0.0,
            json: false,
        }
    }
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
    /// Its results, as every output shows them.
    pub result: CalibrationResult,
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
        println!(
            "{}",
            serde_json::to_string(&report.result).context("encoding the results")?
        );
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
    let checks = frame_checks(args)?;
    let reader = BagReader::open(&args.bag)
        .with_context(|| format!("opening the bag {}", args.bag.display()))?;
    let cameras = choose_cameras(&reader, args)?;
    progress.set_length(reader.topics_message_count(cameras.iter().map(|c| c.topic.as_str())));
    let frames = judge_bag_frames(&reader, &cameras, detector.as_ref(), &checks, progress)?;
    let outcome = match frames.as_slice() {
        [mono] => CalibrationOutcome {
            cameras: vec![calibrate_target_camera(mono, args.model, detector.target())?.1],
            stereo: None,
        },
        [left, right] => calibrate_pair(left, right, args.model, detector.target())?,
        _ => bail!("expected one or two cameras, got {}", frames.len()),
    };
    let result = CalibrationResult::from_outcome(&outcome);
    let written = write_results(&outcome, &args.out)?;
    let topics: Vec<String> = cameras.into_iter().map(|c| c.topic).collect();
    let sample = match sample_stamp(&outcome) {
        Some(stamp) => read_sample(&reader, &topics, stamp)?,
        None => None,
    };
    let report = args.out.join("report.html");
    let inputs = ReportInputs {
        outcome: &outcome,
        result: &result,
        frames: &frames,
        sample: sample.as_ref(),
    };
    write_report(&report, &inputs).context("making the calibration report")?;
    Ok(CalibrateReport {
        outcome,
        result,
        topics,
        written,
        report,
        elapsed: started.elapsed(),
    })
}

/// The frame checks of `args`, refused when negative or not a number.
fn frame_checks(args: &CalibrateArgs) -> anyhow::Result<FrameChecks> {
    for (option, value) in [
        ("--max-blur", args.max_blur),
        ("--max-board-speed", args.max_board_speed),
    ] {
        if !(value.is_finite() && value >= 0.0) {
            bail!("{option} {value}: expected 0 (off) or a positive number");
        }
    }
    Ok(FrameChecks {
        max_board_speed: args.max_board_speed,
        max_blur: args.max_blur,
    })
}

/// The cameras to calibrate: name and image topic.
fn choose_cameras(reader: &BagReader, args: &CalibrateArgs) -> anyhow::Result<Vec<CameraTopic>> {
    let image_topics = image_topics(reader);
    let listed = if image_topics.is_empty() {
        "none".to_owned()
    } else {
        image_topics.join(", ")
    };
    let chosen: Vec<(&str, &str)> = match (&args.topic, &args.left, &args.right) {
        (Some(topic), _, _) => vec![(&args.name, topic)],
        (None, Some(left), Some(right)) => vec![("left", left), ("right", right)],
        _ => match image_topics.as_slice() {
            [topic] => vec![(&args.name, topic)],
            [a, b] if a.contains("left") && b.contains("right") => {
                vec![("left", a), ("right", b)]
            }
            [a, b] if b.contains("left") && a.contains("right") => {
                vec![("left", b), ("right", a)]
            }
            _ => bail!(
                "cannot tell which image topics to calibrate (image topics in the bag: {listed}): give --topic T for a mono camera or --left T --right T for a stereo pair"
            ),
        },
    };
    let mut cameras = Vec::with_capacity(chosen.len());
    for (name, topic) in chosen {
        cameras.push(CameraTopic {
            name: name.to_owned(),
            topic: topic.to_owned(),
            kind: image_kind(reader, topic).map_err(anyhow::Error::msg)?,
        });
    }
    Ok(cameras)
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
        data: row_major(m).to_vec(),
    }
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

/// Prints the results for a person: per camera and for the pair on stdout, warnings,
/// files written and the time taken on stderr.
fn print_human(report: &CalibrateReport) {
    let result = &report.result;
    for (camera, topic) in result.cameras.iter().zip(&report.topics) {
        println!(
            "camera {} ({topic}, {}x{}): RMS {:.4} px, {} views used, {} rejected",
            camera.name,
            camera.width,
            camera.height,
            camera.rms,
            camera.views_used,
            camera.views_rejected.len()
        );
        print_rejected("", &camera.views_rejected);
        let [fx, _, cx, _, fy, cy, ..] = camera.k;
        println!("  K: fx {fx:.3} fy {fy:.3} cx {cx:.3} cy {cy:.3}");
        let d: Vec<String> = camera.d.iter().map(|c| format!("{c:.6}")).collect();
        println!(
            "  D ({}): [{}]",
            camera.distortion_model.ros_name(),
            d.join(", ")
        );
    }
    if let Some(stereo) = &result.stereo {
        let right_from_left = stereo.right_from_left;
        let t = right_from_left.translation.vector;
        let (roll, pitch, yaw) = right_from_left.rotation.euler_angles();
        println!(
            "stereo: RMS {:.4} px, epipolar RMS {:.4} px, {} pairs used, {} rejected",
            stereo.rms,
            stereo.epipolar_rms,
            stereo.pairs_used,
            stereo.pairs_rejected.len()
        );
        print_rejected("pair ", &stereo.pairs_rejected);
        println!(
            "  baseline {:.2} mm; right_from_left translation [{:.5}, {:.5}, {:.5}] m, rotation {:.4} deg (roll {:.4}, pitch {:.4}, yaw {:.4} deg)",
            t.norm() * 1e3,
            t.x,
            t.y,
            t.z,
            right_from_left.rotation.angle().to_degrees(),
            roll.to_degrees(),
            pitch.to_degrees(),
            yaw.to_degrees()
        );
    }
    for warning in &result.warnings {
        eprintln!("warning: {warning}");
    }
    for path in &report.written {
        eprintln!("wrote {}", path.display());
    }
    println!("report: {}", report.report.display());
    eprintln!("done in {:.2} s", report.elapsed.as_secs_f64());
}

fn print_rejected(what: &str, rejected: &[RejectedFrame]) {
    for r in rejected {
        println!(
            "  rejected {what}{}.{:09} s: {}",
            r.stamp.sec, r.stamp.nanosec, r.reason
        );
    }
}
