//! The calibrate node: collects calibration samples from a live camera or stereo pair,
//! headless, like ROS camera_calibration's cameracalibrator. Runs as the
//! `calibrate_node` executable and as `stereocal node calibrate`.
//!
//! Subscribes `image` (mono) or `left/image` and `right/image` (`stereo: true`, paired
//! by exact stamp or within `slop` seconds). A worker thread judges the newest frame
//! with a [`CalibrationSession`] (frames that arrive while it is busy are dropped and
//! counted), keeps the samples that add coverage in `state_dir` (they survive a
//! restart), and publishes:
//! - `~/status` (std_msgs/String, reliable, transient local): the progress as JSON,
//!   `{"samples", "ready", "cameras": [{"name", "x", "y", "size", "skew"}], "verdict",
//!   "reason", "frames": {"received", "judged", "dropped", "unpaired"}, "calibration"}`
//!   (`calibration` is null until calibrated, then `{"cameras": [{"name", "rms",
//!   "views_used", "k", "d"}], "stereo": {"rms", "epipolar_rms", "pairs_used"}}`) after
//!   every judged frame, at start-up and after every service call;
//! - `~/annotated_image` (mono) or `~/left/annotated_image` and
//!   `~/right/annotated_image` (stereo): each judged image as rgb8 with the detected
//!   corners, the coverage bars and the verdict.
//!
//! Services (std_srvs/Trigger): `~/calibrate` calibrates from the kept samples once
//! coverage is ready (else says what is missing), `~/commit` writes each camera's
//! camera_info YAML atomically to its `file://` URL and sends it to the camera's
//! `set_camera_info` (mono) or `left/set_camera_info` and `right/set_camera_info`
//! (stereo) when a server answers within a second, `~/reset` forgets every sample.
//! With `auto_calibrate` the node calibrates by itself once coverage is ready.

use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Duration;

use anyhow::{Context, anyhow};
use futures::{FutureExt, StreamExt};
use ros2_client::{ParameterValue, Publisher};
use stereocal_msgs::CameraInfoFile;
use stereocal_msgs::builtin_interfaces::Time;
use stereocal_msgs::sensor_msgs::Image;
use stereocal_msgs::sensor_msgs::srv::{SetCameraInfoRequest, SetCameraInfoResponse};
use stereocal_msgs::std_msgs;
use stereocal_msgs::std_srvs::srv::{TriggerRequest, TriggerResponse};
use stereocal_vision::board::{Target, TargetPart, parse_size, target_from_parts};
use stereocal_vision::camera::DistortionModel;

use crate::calibration_session::{
    CalibrationSession, DEFAULT_MAX_BLUR, ENOUGH_SAMPLES, Progress, SessionConfig, Verdict,
    annotate,
};
use crate::calibration_stage::CalibrationOutcome;
use crate::convert::{Encoding, image_from_msg, msg_from_image};
use crate::runtime::node::{NodeBuilder, RosNode};
use crate::runtime::params::ParamSpec;
use crate::runtime::qos;
use crate::runtime::queue::DropOldestQueue;
use crate::runtime::service::{self, ServiceClient, ServiceServer, Srv};
use crate::runtime::shutdown::Shutdown;
use crate::runtime::sync::FramePairing;
use crate::runtime::throttle::Throttle;

/// How long the worker waits for a frame before it looks at the services again.
const SERVICE_POLL: Duration = Duration::from_millis(20);

/// How long `~/commit` waits for a camera's `set_camera_info` to answer.
const SET_CAMERA_INFO_TIMEOUT: Duration = Duration::from_secs(1);

/// camera_info_manager's default URL: `${ROS_HOME}` and `${NAME}` are substituted.
pub const DEFAULT_CAMERA_INFO_URL: &str = "file://${ROS_HOME}/camera_info/${NAME}.yaml";

/// Everything the node was configured with, checked.
#[derive(Clone, Debug, PartialEq)]
pub struct CalibrateSettings {
    /// The session's target, cameras (in image order), model and frame checks.
    pub session: SessionConfig,
    /// Whether the node subscribes a stereo pair.
    pub stereo: bool,
    /// Largest stamp difference of a stereo pair, nanoseconds (0: equal stamps).
    pub slop_ns: i64,
    /// Frames kept per topic while waiting for pairing.
    pub queue_size: usize,
    /// Calibrate without being asked once coverage is ready.
    pub auto_calibrate: bool,
    /// Folder of the session's samples.
    pub state_dir: PathBuf,
    /// Where each camera's camera_info is written by `~/commit`, in camera order.
    pub camera_info_paths: Vec<PathBuf>,
}

/// The directory ROS keeps its files in: `$ROS_HOME`, else `~/.ros`.
pub fn ros_home() -> PathBuf {
    match std::env::var_os("ROS_HOME") {
        Some(home) if !home.is_empty() => PathBuf::from(home),
        _ => std::env::var_os("HOME")
            .map(PathBuf::from)
            .unwrap_or_default()
            .join(".ros"),
    }
}

/// The file a camera_info URL names, as camera_info_manager resolves it: `${NAME}` is
/// the camera's name and `${ROS_HOME}` is `ros_home`; only `file://` URLs with an
/// absolute path are supported.
pub fn camera_info_path(url: &str, camera_name: &str, ros_home: &Path) -> Result<PathBuf, String> {
    let resolved = url
        .replace("${NAME}", camera_name)
        .replace("${ROS_HOME}", &ros_home.to_string_lossy());
    let Some(path) = resolved.strip_prefix("file://") else {
        return Err(format!(
            "{url:?} is not supported: only file:// URLs (file:///absolute/path.yaml) can be written"
        ));
    };
    if !path.starts_with('/') {
        return Err(format!(
            "{url:?} has no absolute path: write file:///absolute/path.yaml"
        ));
    }
    Ok(PathBuf::from(path))
}

fn declare(builder: NodeBuilder) -> NodeBuilder {
    let string = |name: &str, default: &str, description: &str| {
        ParamSpec::new(name, ParameterValue::String(default.into()), description)
    };
    let double = |name: &str, default: f64, description: &str| {
        ParamSpec::new(name, ParameterValue::Double(default), description)
    };
    let boolean = |name: &str, default: bool, description: &str| {
        ParamSpec::new(name, ParameterValue::Boolean(default), description)
    };
    [
        string("pattern", "chessboard", "calibration target: chessboard or charuco"),
        string(
            "size",
            "",
            "target size COLSxROWS: a chessboard's inner corners, a ChArUco board's squares (required)",
        ),
        double("square", 0.0, "side of one square, metres (required)"),
        double("marker_size", 0.0, "ChArUco marker side, metres"),
        string("dictionary", "4x4_50", "ChArUco marker dictionary, e.g. 4x4_50, 5x5_100"),
        string(
            "model",
            "plumb_bob",
            "distortion model: plumb_bob, rational_polynomial or equidistant",
        ),
        boolean("stereo", false, "a stereo pair on left/image and right/image, not a camera on image"),
        string("camera_name", "camera", "mono: the camera's name"),
        string("left_camera_name", "left", "stereo: the left camera's name"),
        string("right_camera_name", "right", "stereo: the right camera's name"),
        double(
            "slop",
            0.0,
            "stereo: largest stamp difference of a pair, seconds; 0 pairs equal stamps only",
        ),
        double(
            "max_board_speed",
            0.0,
            "frames whose board moves faster than this (pixels per second) are refused; 0 disables",
        ),
        double(
            "max_blur",
            DEFAULT_MAX_BLUR,
            "frames whose board edges are wider than this (10-90 % edge width, pixels) are refused; 0 disables",
        ),
        boolean("auto_calibrate", false, "calibrate once coverage is ready, without ~/calibrate"),
        string(
            "state_dir",
            "",
            "folder where samples persist; empty: $ROS_HOME/stereocal/<node name>",
        ),
        string("camera_info_url", "", "mono: where ~/commit writes camera_info; empty: camera_info_manager's default"),
        string("left_camera_info_url", "", "stereo: the left camera's camera_info URL"),
        string("right_camera_info_url", "", "stereo: the right camera's camera_info URL"),
        ParamSpec::new(
            "queue_size",
            ParameterValue::Integer(5),
            "frames kept per topic while waiting for pairing",
        )
        .integer_range(1..=1000),
    ]
    .into_iter()
    .fold(builder, NodeBuilder::param)
}

fn param_error(name: &str, reason: impl std::fmt::Display) -> anyhow::Error {
    anyhow!("parameter {name}: {reason}")
}

fn target_from_params(node: &RosNode) -> anyhow::Result<Target> {
    let size = node.param_string("size")?;
    if size.trim().is_empty() {
        return Err(param_error(
            "size",
            "required: the target size as COLSxROWS, e.g. 9x6",
        ));
    }
    let size = parse_size(&size).map_err(|e| param_error("size", e))?;
    target_from_parts(
        &node.param_string("pattern")?,
        size,
        node.param_f64("square")?,
        Some(node.param_f64("marker_size")?),
        Some(&node.param_string("dictionary")?),
    )
    .map_err(|(part, e)| {
        let name = match part {
            TargetPart::Pattern => "pattern",
            TargetPart::Size => "size",
            TargetPart::Square => "square",
            TargetPart::MarkerSize => "marker_size",
            TargetPart::Dictionary => "dictionary",
        };
        param_error(name, e)
    })
}

fn non_negative(node: &RosNode, name: &str) -> anyhow::Result<f64> {
    let value = node.param_f64(name)?;
    if value.is_finite() && value >= 0.0 {
        Ok(value)
    } else {
        Err(param_error(name, format!("{value} must be 0 or more")))
    }
}

/// Reads and checks the node's parameters; an error names the parameter.
fn settings(node: &RosNode) -> anyhow::Result<CalibrateSettings> {
    let target = target_from_params(node)?;
    let model_name = node.param_string("model")?;
    let model = DistortionModel::from_ros_name(&model_name).ok_or_else(|| {
        param_error(
            "model",
            format!("unknown model {model_name:?}: expected plumb_bob, rational_polynomial or equidistant"),
        )
    })?;
    let stereo = node.param_bool("stereo")?;
    let (names, urls) = if stereo {
        (
            vec!["left_camera_name", "right_camera_name"],
            vec!["left_camera_info_url", "right_camera_info_url"],
        )
    } else {
        (vec!["camera_name"], vec!["camera_info_url"])
    };
    let mut cameras = Vec::new();
    for name in &names {
        let value = node.param_string(name)?;
        if value.is_empty() || value.contains(['/', '\\']) {
            return Err(param_error(name, format!("{value:?} is not a camera name")));
        }
        cameras.push(value);
    }
    if stereo && cameras[0] == cameras[1] {
        return Err(param_error(
            "right_camera_name",
            "the two cameras of a pair need different names",
        ));
    }
    let home = ros_home();
    let mut camera_info_paths = Vec::new();
    for (url_param, camera) in urls.iter().zip(&cameras) {
        let url = node.param_string(url_param)?;
        let url = if url.is_empty() {
            DEFAULT_CAMERA_INFO_URL.to_owned()
        } else {
            url
        };
        camera_info_paths
            .push(camera_info_path(&url, camera, &home).map_err(|e| param_error(url_param, e))?);
    }
    let slop = non_negative(node, "slop")?;
    let state_dir = node.param_string("state_dir")?;
    let state_dir = if state_dir.is_empty() {
        home.join("stereocal").join(&node.identity().name)
    } else {
        PathBuf::from(state_dir)
    };
    let mut session = SessionConfig::new(target, cameras, model);
    session.max_board_speed = non_negative(node, "max_board_speed")?;
    session.max_blur = non_negative(node, "max_blur")?;
    Ok(CalibrateSettings {
        session,
        stereo,
        slop_ns: (slop * 1e9).round() as i64,
        queue_size: usize::try_from(node.param_i64("queue_size")?).context("queue_size")?,
        auto_calibrate: node.param_bool("auto_calibrate")?,
        state_dir,
        camera_info_paths,
    })
}

/// A synchronized frame: one image per camera, in camera order.
struct Work {
    stamp: Time,
    images: Vec<Image>,
}

/// Frame counters shared by the receiving and the judging threads.
#[derive(Default)]
struct Counters {
    received: AtomicU64,
    judged: AtomicU64,
    unpaired: AtomicU64,
}

type Trigger = ServiceServer<TriggerRequest, TriggerResponse>;

/// The node's services.
#[derive(Clone, Copy)]
enum Service {
    Calibrate,
    Commit,
    Reset,
}

impl Service {
    fn name(self) -> &'static str {
        match self {
            Service::Calibrate => "~/calibrate",
            Service::Commit => "~/commit",
            Service::Reset => "~/reset",
        }
    }
}
type SetCameraInfoClient = ServiceClient<SetCameraInfoRequest, SetCameraInfoResponse>;

/// The worker's side of the node: the session and everything it answers with.
struct Worker {
    session: CalibrationSession,
    settings: CalibrateSettings,
    status: Publisher<std_msgs::String>,
    annotated: Vec<Publisher<Image>>,
    calibrate: Trigger,
    commit: Trigger,
    reset: Trigger,
    set_camera_info: Vec<(String, SetCameraInfoClient)>,
    outcome: Option<CalibrationOutcome>,
    last_verdict: Option<Verdict>,
    counters: Arc<Counters>,
    queue: Arc<DropOldestQueue<Work>>,
    stop: Shutdown,
    frame_log: Throttle,
    warn_log: Throttle,
}

fn stamp_ns(stamp: &Time) -> i64 {
    i64::from(stamp.sec) * 1_000_000_000 + i64::from(stamp.nanosec)
}

/// RMS figures of a calibration, as the `~/calibrate` answer says them.
pub fn outcome_summary(outcome: &CalibrationOutcome) -> String {
    let mut parts: Vec<String> = outcome
        .cameras
        .iter()
        .map(|c| {
            format!(
                "{}: RMS {:.4} px over {} views",
                c.name,
                c.calibration.rms,
                c.used.len()
            )
        })
        .collect();
    if let Some(stereo) = &outcome.stereo {
        parts.push(format!(
            "stereo: RMS {:.4} px, epipolar RMS {:.4} px over {} pairs",
            stereo.calibration.rms,
            stereo.calibration.epipolar_rms,
            stereo.used.len()
        ));
    }
    parts.join("; ")
}

fn outcome_json(outcome: &CalibrationOutcome) -> serde_json::Value {
    serde_json::json!({
        "cameras": outcome.cameras.iter().map(|c| serde_json::json!({
            "name": c.name,
            "rms": c.calibration.rms,
            "views_used": c.used.len(),
            "k": c.info.k,
            "d": c.info.d,
        })).collect::<Vec<_>>(),
        "stereo": outcome.stereo.as_ref().map(|s| serde_json::json!({
            "rms": s.calibration.rms,
            "epipolar_rms": s.calibration.epipolar_rms,
            "pairs_used": s.used.len(),
        })),
    })
}

/// What `~/calibrate` answers when coverage is not ready: what is still missing.
pub fn not_ready_message(progress: &Progress) -> String {
    let mut missing = Vec::new();
    for camera in &progress.cameras {
        let bars: Vec<String> = [
            ("x", camera.x),
            ("y", camera.y),
            ("size", camera.size),
            ("skew", camera.skew),
        ]
        .iter()
        .filter(|(_, v)| *v < 1.0)
        .map(|(bar, v)| format!("{bar} {:.0}%", v * 100.0))
        .collect();
        if !bars.is_empty() {
            missing.push(format!("{}: {}", camera.name, bars.join(", ")));
        }
    }
    format!(
        "not enough samples to calibrate: {} kept; calibration needs every coverage bar full \
         or {ENOUGH_SAMPLES} samples (missing {}): move the board across the whole image, \
         nearer and farther, and tilted",
        progress.samples,
        missing.join("; ")
    )
}

impl Worker {
    fn run(mut self) {
        self.publish_status();
        loop {
            match self.queue.pop_timeout(SERVICE_POLL) {
                Some(work) => self.judge(work),
                None if self.stop.requested() => break,
                None => {}
            }
            self.serve();
        }
    }

    fn judge(&mut self, work: Work) {
        let mut images = Vec::with_capacity(work.images.len());
        for (msg, camera) in work.images.iter().zip(&self.settings.session.cameras) {
            match image_from_msg(msg) {
                Ok((_, image)) => images.push(image),
                Err(e) => {
                    self.warn_log.log(
                        log::Level::Warn,
                        format!("camera {camera}: unusable image: {e}"),
                    );
                    return;
                }
            }
        }
        let refs: Vec<_> = images.iter().collect();
        let offer = match self.session.offer(work.stamp, &refs) {
            Ok(offer) => offer,
            Err(e) => {
                self.warn_log
                    .log(log::Level::Warn, format!("frame not judged: {e}"));
                return;
            }
        };
        self.counters.judged.fetch_add(1, Ordering::Relaxed);
        let progress = self.session.progress();
        match &offer.verdict {
            Verdict::Added => log::info!(
                "sample added at {}.{:09}: {}",
                work.stamp.sec,
                work.stamp.nanosec,
                progress.status_line()
            ),
            Verdict::NotNew => self.frame_log.log(
                log::Level::Debug,
                "frame not new: too close to a kept sample".to_owned(),
            ),
            Verdict::Refused(reason) => self
                .frame_log
                .log(log::Level::Info, format!("frame refused: {reason}")),
        }
        for (k, (image, publisher)) in images.iter().zip(&self.annotated).enumerate() {
            let detection = offer.detections.get(k).and_then(Option::as_ref);
            let annotated = annotate(image, detection, &progress, &offer.verdict);
            let header = work.images[k].header.clone();
            match msg_from_image(&annotated, Encoding::Rgb8, header) {
                Ok(msg) => {
                    if let Err(e) = publisher.publish(msg) {
                        self.warn_log.log(
                            log::Level::Warn,
                            format!("annotated image not published: {e}"),
                        );
                    }
                }
                Err(e) => self
                    .warn_log
                    .log(log::Level::Warn, format!("annotated image not made: {e}")),
            }
        }
        let added = offer.verdict == Verdict::Added;
        self.last_verdict = Some(offer.verdict);
        if added && progress.ready && self.settings.auto_calibrate && self.outcome.is_none() {
            log::info!("coverage is ready: calibrating");
            let answer = self.run_calibration();
            log::log!(
                if answer.success {
                    log::Level::Info
                } else {
                    log::Level::Warn
                },
                "{}",
                answer.message
            );
        }
        self.publish_status();
    }

    fn publish_status(&mut self) {
        let mut status = self.session.progress().to_json();
        let (verdict, reason) = match &self.last_verdict {
            None => (serde_json::Value::Null, serde_json::Value::Null),
            Some(Verdict::Added) => ("added".into(), serde_json::Value::Null),
            Some(Verdict::NotNew) => ("not_new".into(), serde_json::Value::Null),
            Some(Verdict::Refused(reason)) => ("refused".into(), reason.clone().into()),
        };
        if let Some(object) = status.as_object_mut() {
            object.insert("verdict".into(), verdict);
            object.insert("reason".into(), reason);
            object.insert(
                "frames".into(),
                serde_json::json!({
                    "received": self.counters.received.load(Ordering::Relaxed),
                    "judged": self.counters.judged.load(Ordering::Relaxed),
                    "dropped": self.queue.dropped(),
                    "unpaired": self.counters.unpaired.load(Ordering::Relaxed),
                }),
            );
            object.insert(
                "calibration".into(),
                self.outcome
                    .as_ref()
                    .map_or(serde_json::Value::Null, outcome_json),
            );
        }
        if let Err(e) = self.status.publish(std_msgs::String {
            data: status.to_string(),
        }) {
            self.warn_log
                .log(log::Level::Warn, format!("status not published: {e}"));
        }
    }

    fn server(&self, service: Service) -> &Trigger {
        match service {
            Service::Calibrate => &self.calibrate,
            Service::Commit => &self.commit,
            Service::Reset => &self.reset,
        }
    }

    /// Answers the service requests that have arrived.
    fn serve(&mut self) {
        let mut answered = false;
        for service in [Service::Calibrate, Service::Commit, Service::Reset] {
            loop {
                let id = match self.server(service).receive_request() {
                    Ok(Some((id, _))) => id,
                    Ok(None) => break,
                    Err(e) => {
                        self.warn_log.log(
                            log::Level::Warn,
                            format!("{}: undecodable request: {e}", service.name()),
                        );
                        break;
                    }
                };
                let response = match service {
                    Service::Calibrate => self.run_calibration(),
                    Service::Commit => self.run_commit(),
                    Service::Reset => self.run_reset(),
                };
                let level = if response.success {
                    log::Level::Info
                } else {
                    log::Level::Warn
                };
                log::log!(level, "{}: {}", service.name(), response.message);
                if let Err(e) = self.server(service).send_response(id, Srv(response)) {
                    log::warn!("{}: response not sent: {e:?}", service.name());
                }
                answered = true;
            }
        }
        if answered {
            self.publish_status();
        }
    }

    fn run_calibration(&mut self) -> TriggerResponse {
        let progress = self.session.progress();
        if !progress.ready {
            return TriggerResponse {
                success: false,
                message: not_ready_message(&progress),
            };
        }
        match self.session.calibrate() {
            Ok(outcome) => {
                let message = format!(
                    "calibrated from {} samples: {}",
                    progress.samples,
                    outcome_summary(&outcome)
                );
                self.outcome = Some(outcome);
                TriggerResponse {
                    success: true,
                    message,
                }
            }
            Err(e) => TriggerResponse {
                success: false,
                message: format!("calibration failed: {e}"),
            },
        }
    }

    fn run_commit(&mut self) -> TriggerResponse {
        let Some(outcome) = &self.outcome else {
            return TriggerResponse {
                success: false,
                message: "nothing to commit: no calibration yet; call ~/calibrate first".into(),
            };
        };
        let mut reports = Vec::new();
        let mut success = true;
        for ((camera, path), (client_name, client)) in outcome
            .cameras
            .iter()
            .zip(&self.settings.camera_info_paths)
            .zip(&self.set_camera_info)
        {
            let file = CameraInfoFile {
                camera_name: camera.name.clone(),
                info: camera.info.clone(),
            };
            if let Err(e) = file.write(path) {
                success = false;
                reports.push(format!("{}: not written: {e}", camera.name));
                continue;
            }
            let request = SetCameraInfoRequest {
                camera_info: camera.info.clone(),
            };
            let ack = match service::call(client, &request, SET_CAMERA_INFO_TIMEOUT) {
                Ok(Some(response)) if response.success => {
                    format!("acknowledged by {client_name}")
                }
                Ok(Some(response)) => {
                    format!("{client_name} refused it: {}", response.status_message)
                }
                Ok(None) => format!("no {client_name} server answered"),
                Err(e) => format!("{client_name} not called: {e}"),
            };
            reports.push(format!(
                "{} written to {} ({ack})",
                camera.name,
                path.display()
            ));
        }
        TriggerResponse {
            success,
            message: reports.join("; "),
        }
    }

    fn run_reset(&mut self) -> TriggerResponse {
        self.outcome = None;
        self.last_verdict = None;
        match self.session.reset() {
            Ok(()) => TriggerResponse {
                success: true,
                message: "every sample forgotten".into(),
            },
            Err(e) => TriggerResponse {
                success: false,
                message: format!("reset failed: {e}"),
            },
        }
    }
}

/// Runs the calibrate node until SIGINT/SIGTERM, with `args` the command line without
/// the program name (`--ros-args` remaps, parameters, params files).
pub fn run<I, S>(args: I) -> anyhow::Result<()>
where
    I: IntoIterator<Item = S>,
    S: Into<String>,
{
    let mut node = declare(NodeBuilder::new("calibrate_node")).start(args)?;
    let settings = settings(&node)?;
    let session = CalibrationSession::open(settings.session.clone(), &settings.state_dir)
        .with_context(|| format!("state_dir {}", settings.state_dir.display()))?;
    log::info!(
        "calibrating {} with {} samples kept in {}",
        settings.session.cameras.join(" and "),
        session.sample_count(),
        settings.state_dir.display()
    );

    let depth = settings.queue_size;
    let (image_topics, annotated_topics, set_info_services) = if settings.stereo {
        (
            vec!["left/image", "right/image"],
            vec!["~/left/annotated_image", "~/right/annotated_image"],
            vec!["left/set_camera_info", "right/set_camera_info"],
        )
    } else {
        (
            vec!["image"],
            vec!["~/annotated_image"],
            vec!["set_camera_info"],
        )
    };
    let mut subscriptions = Vec::new();
    for topic in &image_topics {
        subscriptions.push(node.subscribe::<Image>(topic, qos::sensor_data(depth))?);
    }
    let mut annotated = Vec::new();
    for topic in &annotated_topics {
        annotated.push(node.advertise::<Image>(topic, qos::reliable(2))?);
    }
    let status = node.advertise::<std_msgs::String>(
        "~/status",
        qos::reliable(1).durability(ros2_client::qos::Durability::TransientLocal),
    )?;
    let calibrate = node.create_server("~/calibrate")?;
    let commit = node.create_server("~/commit")?;
    let reset = node.create_server("~/reset")?;
    let mut set_camera_info = Vec::new();
    for name in &set_info_services {
        set_camera_info.push((node.resolve_topic(name)?, node.create_client(name)?));
    }

    // The worker judges the newest frame; older ones are dropped while it is busy.
    let queue = Arc::new(DropOldestQueue::<Work>::new(1));
    let counters = Arc::new(Counters::default());
    let worker = Worker {
        session,
        settings: settings.clone(),
        status,
        annotated,
        calibrate,
        commit,
        reset,
        set_camera_info,
        outcome: None,
        last_verdict: None,
        counters: Arc::clone(&counters),
        queue: Arc::clone(&queue),
        stop: node.shutdown(),
        frame_log: Throttle::default(),
        warn_log: Throttle::default(),
    };
    let worker = std::thread::Builder::new()
        .name("calibrate".into())
        .spawn(move || worker.run())
        .context("starting the calibration thread")?;

    let shutdown = node.shutdown();
    let mut pairing = FramePairing::<Image, Image>::new(settings.slop_ns, depth);
    let mut throttle = Throttle::default();
    let push = |images: Vec<Image>| {
        let stamp = images[0].header.stamp;
        counters.received.fetch_add(1, Ordering::Relaxed);
        queue.push(Work { stamp, images });
    };
    futures::executor::block_on(async {
        let mut stop = shutdown.wait().fuse();
        let mut streams: Vec<_> = subscriptions
            .iter()
            .map(|s| Box::pin(s.async_stream()))
            .collect();
        loop {
            let (index, message) = match streams.as_mut_slice() {
                [mono] => futures::select! {
                    m = mono.select_next_some() => (0, m),
                    () = stop => break,
                },
                [left, right] => futures::select! {
                    m = left.select_next_some() => (0, m),
                    m = right.select_next_some() => (1, m),
                    () = stop => break,
                },
                _ => break,
            };
            let image = match message {
                Ok((image, _)) => image,
                Err(e) => {
                    throttle.log(log::Level::Warn, format!("undecodable image message: {e}"));
                    continue;
                }
            };
            if !settings.stereo {
                push(vec![image]);
                continue;
            }
            let stamp = stamp_ns(&image.header.stamp);
            let pairs = if index == 0 {
                pairing.push_left(stamp, image)
            } else {
                pairing.push_right(stamp, image)
            };
            counters
                .unpaired
                .store(pairing.unpaired(), Ordering::Relaxed);
            for (left, right) in pairs {
                push(vec![left, right]);
            }
        }
    });

    shutdown.request();
    queue.close();
    if worker.join().is_err() {
        log::error!("the calibration thread panicked");
    }
    log::info!(
        "shutting down: {} frame(s) received, {} judged, {} dropped while judging, {} \
         without a partner",
        counters.received.load(Ordering::Relaxed),
        counters.judged.load(Ordering::Relaxed),
        queue.dropped(),
        counters.unpaired.load(Ordering::Relaxed)
    );
    // Readers go before the node and its DDS participant, which must remove them.
    drop(subscriptions);
    drop(node);
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::calibration_session::CameraCoverage;

    #[test]
    fn camera_info_urls_resolve_like_camera_info_manager() {
        let home = Path::new("/home/robot/.ros");
        assert_eq!(
            camera_info_path(DEFAULT_CAMERA_INFO_URL, "left", home),
            Ok(PathBuf::from("/home/robot/.ros/camera_info/left.yaml"))
        );
        assert_eq!(
            camera_info_path("file:///tmp/cal/${NAME}.yaml", "right", home),
            Ok(PathBuf::from("/tmp/cal/right.yaml"))
        );
        let http = camera_info_path("http://host/left.yaml", "left", home).unwrap_err();
        assert!(http.contains("only file://"), "{http}");
        let relative = camera_info_path("file://cal/left.yaml", "left", home).unwrap_err();
        assert!(relative.contains("absolute"), "{relative}");
    }

    #[test]
    fn not_ready_says_which_bars_are_missing() {
        let progress = Progress {
            cameras: vec![CameraCoverage {
                name: "left".into(),
                x: 1.0,
                y: 0.5,
                size: 1.0,
                skew: 0.25,
            }],
            samples: 7,
            ready: false,
        };
        let message = not_ready_message(&progress);
        assert!(message.contains("7 kept"), "{message}");
        assert!(message.contains("left: y 50%, skew 25%"), "{message}");
        assert!(!message.contains("x 100%"), "{message}");
    }
}
