//! `stereocal demo`: the main job on the bundled stereo bag. Rectifies it offline and
//! through two rectify nodes over DDS, and measures on the rectified pixels how well
//! the rows of the left and right images agree, against the scene's ground truth; then
//! calibrates a synthetic stereo session and a synthetic eye-in-hand session, matches
//! rendered stereo pairs for depth, and prints their errors against the truth.

use std::path::{Path, PathBuf};
use std::time::Duration;

use anyhow::{Context, bail};
use indicatif::{ProgressBar, ProgressStyle};

use crate::cli::calibrate::{CalibrateArgs, calibrate_bag};
use crate::cli::handeye::{HandEyeArgs, SetupArg, handeye_bag};
use crate::cli::rectify::{BagRectifyOptions, rectify_bag};
use crate::cli::synth::{SceneArg, SynthArgs};
use crate::convert::calibrated_camera_from_info;
use crate::rectify::replay::{NodeReplay, ReplayOutcome, replay_through_rectify_nodes};
use crate::rectify::row_alignment::RowAlignment;
use crate::rectify::scene::{LEFT, RIGHT, StereoScene, identical_images, read_rectified};

/// The bundled stereo scene, made by `stereocal synth` with these settings.
pub const BUNDLED_STEREO: &str = "bags/stereo";

/// Arguments of `stereocal demo`.
#[derive(clap::Args, Debug)]
pub struct DemoArgs {
    /// A scene made by `stereocal synth --scene stereo` (a folder with `bag/` and
    /// `ground_truth.json`); default: the bundled one, synthesized if missing.
    #[arg(long)]
    pub scene: Option<PathBuf>,
    /// Where to write the rectified bags and the calibration session (its camera_info
    /// files and report.html); default: a temporary folder removed at the end.
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// ROS domain of the node run (the nodes and the player join only this domain).
    #[arg(long, default_value_t = 77)]
    pub domain_id: u16,
    /// Frames per second replayed through the nodes.
    #[arg(long, default_value_t = 15.0)]
    pub rate: f64,
    /// Skip the run through the nodes over DDS.
    #[arg(long)]
    pub offline_only: bool,
}

/// Runs the demo and prints its figures.
pub fn run(args: &DemoArgs) -> anyhow::Result<()> {
    let temp = tempfile::tempdir().context("cannot create a temporary folder")?;
    let out = args.out.clone().unwrap_or_else(|| temp.path().to_owned());
    std::fs::create_dir_all(&out).with_context(|| format!("cannot create {}", out.display()))?;
    let scene = match &args.scene {
        Some(scene) => scene.clone(),
        None => bundled_or_synthesized(&out)?,
    };
    println!("stereocal demo: scene {}", scene.display());
    let scene = StereoScene::open(&scene)?;
    let camera = &scene.left.model;
    println!(
        "  {} stereo frames, {} clean; {}x{} {}",
        scene.truth.frames.len(),
        scene.clean_frames(),
        camera.width,
        camera.height,
        camera.distortion.model().ros_name()
    );

    // Offline.
    let progress = ProgressBar::new(0).with_style(
        ProgressStyle::with_template("  rectifying {bar:30} {pos}/{len} frames")
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    let rectified_bag = out.join("rectified");
    let report = rectify_bag(
        &scene.bag,
        &rectified_bag,
        &BagRectifyOptions {
            overwrite: true,
            ..BagRectifyOptions::default()
        },
        &progress,
    )?;
    progress.finish_and_clear();
    let offline = read_rectified(&rectified_bag)?;
    let (offline_alignment, offline_frames) = scene.row_alignment(&offline);
    println!(
        "\noffline: stereocal rectify -> {} ({:.1} frames/s)",
        rectified_bag.display(),
        report.frames_per_second()
    );
    print_alignment(&offline_alignment, offline_frames);

    calibration_session(&out, args.out.is_some())?;
    hand_eye_session(&out)?;
    depth_session(&out)?;

    if args.offline_only {
        return Ok(());
    }

    // On the robot's path: two rectify nodes, each its own process, over DDS.
    let exe = std::env::current_exe().context("cannot find this executable")?;
    let cameras = [LEFT.to_owned(), RIGHT.to_owned()];
    let outcome = replay_through_rectify_nodes(
        &scene.bag,
        &cameras,
        &NodeReplay {
            node_command: vec![exe.into(), "node".into(), "rectify".into()],
            domain_id: args.domain_id,
            rate_hz: args.rate,
            timeout: Duration::from_secs(30),
        },
    )?;
    let nodes = [
        outcome.rectified.get(LEFT).cloned().unwrap_or_default(),
        outcome.rectified.get(RIGHT).cloned().unwrap_or_default(),
    ];
    let (node_alignment, node_frames) = scene.row_alignment(&nodes);
    println!(
        "\nnodes: 2 x rectify_node over DDS (domain {}, {:.0} Hz)",
        args.domain_id, args.rate
    );
    println!(
        "  frames delivered                {}/{}",
        outcome.received(),
        outcome.total_sent()
    );
    print_latency(&outcome);
    println!(
        "  pixels identical to offline     {}/{} images",
        identical_images(&offline, &nodes),
        outcome.received()
    );
    print_alignment(&node_alignment, node_frames);
    if outcome.received() < outcome.total_sent() {
        bail!(
            "the nodes delivered {} of {} frames",
            outcome.received(),
            outcome.total_sent()
        );
    }
    Ok(())
}

/// A stereo calibration session with bad frames, synthesized, calibrated with
/// `stereocal calibrate`, and rectified with the result: the errors against the
/// session's ground truth. `kept`: `out` stays after the demo, so its report is worth
/// pointing to.
/// A synthetic eye-in-hand session, with the robot's noise, calibrated from its images:
/// every method's error and the joint refinement's against the truth.
fn hand_eye_session(out: &Path) -> anyhow::Result<()> {
    let dir = out.join("handeye");
    println!(
        "\nhand-eye: a synthetic eye-in-hand session (robot noise 0.05 degree, 0.3 mm), \
         calibrated from its images"
    );
    crate::cli::synth::run(&SynthArgs::new(SceneArg::HandeyeInHand, dir.clone(), 1, 15))?;
    let text = std::fs::read_to_string(dir.join("ground_truth.json"))
        .context("reading the hand-eye session's ground truth")?;
    let truth: stereocal_vision::synth::GroundTruth =
        serde_json::from_str(&text).context("decoding the hand-eye session's ground truth")?;
    let tool_from_camera = truth
        .extrinsics
        .tool_from_camera
        .context("the eye-in-hand session has no tool_from_camera")?
        .isometry();
    let board = truth.board;
    let report = handeye_bag(&HandEyeArgs::from_images(
        dir.join("bag"),
        SetupArg::EyeInHand,
        "/camera/image_raw",
        (board.cols, board.rows, board.square_size),
        "/robot/tool_pose",
        dir.join("result"),
    ))?;
    for (method, result) in &report.results {
        let found = crate::pose::record::isometry_of(result);
        let error = found.inverse() * tool_from_camera;
        println!(
            "  {method:<10} tool_from_camera error {:.4} deg, {:.3} mm{}",
            error.rotation.angle().to_degrees(),
            (found.translation.vector - tool_from_camera.translation.vector).norm() * 1e3,
            if *method == report.chosen {
                "  (chosen)"
            } else {
                ""
            }
        );
    }
    if let Some(u) = &report.uncertainty {
        println!(
            "  refined: predicted standard deviation {:.4} deg, {:.3} mm; corners {:.3} px RMS",
            u.rotation_deg,
            u.translation_mm,
            report.rms_px.unwrap_or(f64::NAN)
        );
    }
    Ok(())
}

/// Rendered rectified pairs of rooms matched with `stereocal depth`: the disparities'
/// errors against the exact truth, over the pixels both cameras see.
fn depth_session(out: &Path) -> anyhow::Result<()> {
    let dir = out.join("depth");
    println!(
        "\ndepth: rendered rectified pairs (640x480, f 600 px, 9 cm baseline) matched with \
         stereocal depth"
    );
    crate::cli::synth::run(&SynthArgs::new(SceneArg::Depth, dir.clone(), 1, 2))?;
    let matched = dir.join("disparity");
    crate::cli::depth::run(&crate::cli::depth::DepthArgs {
        bag: dir.join("bag"),
        out: matched.clone(),
        left_topic: None,
        right_topic: None,
        algorithm: crate::cli::depth::AlgorithmArg::Sgbm,
        window: stereocal_vision::stereo::BmParams::default().window,
        min_disparity: 0,
        disparity_range: 128,
        paths: crate::cli::depth::PathsArg::Eight,
        refine_radius: stereocal_vision::stereo::SgmParams::default().refine_radius,
        json: false,
        overwrite: true,
    })?;
    let reader = stereocal_rosbag::BagReader::open(&matched)?;
    let mut index = 0;
    for message in reader.messages(&stereocal_rosbag::TopicFilter::All) {
        let message = message?;
        if &*message.topic != "/stereo/disparity" {
            continue;
        }
        let msg: stereocal_msgs::stereo_msgs::DisparityImage =
            stereocal_msgs::cdr::from_bytes(&message.data)?;
        let truth = crate::cli::synth_depth::read_truth(&dir, index)?;
        let scores = truth.score(&msg);
        println!(
            "  pair {index}: bad-1.0 {:.3}, bad-2.0 {:.3}, mean error {:.3} px, {:.1} % valid \
             (OpenCV StereoSGBM on such rooms: bad-2.0 0.22, mean error 0.52 px)",
            scores.bad1,
            scores.bad2,
            scores.epe,
            100.0 * scores.density
        );
        index += 1;
    }
    Ok(())
}

fn calibration_session(out: &Path, kept: bool) -> anyhow::Result<()> {
    let dir = out.join("calibration");
    println!("\ncalibration: a synthetic stereo session, calibrated and rectified with the result");
    crate::cli::synth::run(&SynthArgs::new(SceneArg::Calibration, dir.clone(), 1, 25))?;
    let mut scene = StereoScene::open(&dir)?;
    let board = scene.truth.board;
    let bad = scene.truth.frames.len() - scene.clean_frames();
    let report = calibrate_bag(
        &CalibrateArgs {
            left: Some(format!("{LEFT}/image_raw")),
            right: Some(format!("{RIGHT}/image_raw")),
            ..CalibrateArgs::chessboard(
                scene.bag.clone(),
                dir.join("result"),
                board.cols,
                board.rows,
                board.square_size,
            )
        },
        &ProgressBar::hidden(),
    )?;
    println!(
        "  {} stereo frames ({bad} bad: blurred, moving or partly out of view), calibrated in {:.2} s",
        scene.truth.frames.len(),
        report.elapsed.as_secs_f64()
    );
    let [left, right] = report.outcome.cameras.as_slice() else {
        bail!("the calibration of a stereo session gave no pair");
    };
    for (result, truth) in [left, right].into_iter().zip(&scene.truth.cameras) {
        let camera = &result.calibration.camera.intrinsics;
        let true_camera = truth
            .camera_model()
            .context("the ground truth has an unknown camera model")?
            .intrinsics;
        println!(
            "  {:<5} rms {:.3} px, {} views used, {} left out; error fx {:+.3} fy {:+.3} cx {:+.3} cy {:+.3} px",
            result.name,
            result.calibration.rms,
            result.used.len(),
            result.rejected.len(),
            camera.fx - true_camera.fx,
            camera.fy - true_camera.fy,
            camera.cx - true_camera.cx,
            camera.cy - true_camera.cy
        );
    }
    if let (Some(stereo), Some(truth)) = (
        &report.outcome.stereo,
        scene.truth.extrinsics.right_from_left.as_ref(),
    ) {
        let error = truth.isometry().inverse() * stereo.calibration.right_from_left;
        println!(
            "  right_from_left error {:.4} deg, {:.3} mm (baseline {:.1} mm)",
            error.rotation.angle().to_degrees(),
            error.translation.vector.norm() * 1e3,
            stereo.calibration.right_from_left.translation.vector.norm() * 1e3
        );
    }

    if kept {
        println!("  report: {}", report.report.display());
    } else {
        println!("  report: report.html in a temporary folder; run with --out DIR to keep it");
    }

    // Rectify the session with the calibration and measure its rows.
    scene.left = calibrated_camera_from_info(&left.info)?;
    scene.right = calibrated_camera_from_info(&right.info)?;
    let rectified_bag = dir.join("rectified");
    rectify_bag(
        &scene.bag,
        &rectified_bag,
        &BagRectifyOptions {
            camera_infos: vec![
                (format!("{LEFT}/camera_info"), left.info.clone()),
                (format!("{RIGHT}/camera_info"), right.info.clone()),
            ],
            overwrite: true,
            ..BagRectifyOptions::default()
        },
        &ProgressBar::hidden(),
    )?;
    let (alignment, frames) = scene.row_alignment(&read_rectified(&rectified_bag)?);
    print_alignment(&alignment, frames);
    Ok(())
}

/// The bundled scene of the source tree, or one synthesized with the same settings
/// into `out` when this executable runs outside it.
fn bundled_or_synthesized(out: &Path) -> anyhow::Result<PathBuf> {
    let bundled = Path::new(env!("CARGO_MANIFEST_DIR")).join(BUNDLED_STEREO);
    if bundled.join("bag").exists() && bundled.join("ground_truth.json").exists() {
        return Ok(bundled);
    }
    let scene = out.join("stereo");
    println!(
        "the bundled scene is not here: synthesizing one into {}",
        scene.display()
    );
    crate::cli::synth::run(&bundled_stereo_args(scene.clone()))?;
    Ok(scene)
}

/// The `stereocal synth` arguments of the bundled stereo scene.
pub fn bundled_stereo_args(out: PathBuf) -> SynthArgs {
    SynthArgs {
        width: Some(640),
        height: Some(480),
        bad_frames: Some(0.0),
        ..SynthArgs::new(SceneArg::Stereo, out, 1, 8)
    }
}

fn print_alignment(alignment: &RowAlignment, frames: usize) {
    println!(
        "  row alignment (clean frames)    mean |dy| {:.4} px, max {:.4} px over {} corners in {} frames",
        alignment.mean_abs_offset(),
        alignment.max_abs_offset,
        alignment.corners,
        frames
    );
}

fn print_latency(outcome: &ReplayOutcome) {
    match outcome.latency() {
        Some(latency) => println!(
            "  latency publish -> image_rect   p50 {:.1} ms, p99 {:.1} ms",
            latency.p50, latency.p99
        ),
        None => println!("  latency publish -> image_rect   nothing arrived"),
    }
}
