//! The hand-eye node's worker: turns each target frame into a target pose, pairs it with
//! the robot's pose at its stamp, judges whether a sample could be taken from it (robot
//! still, pose new), takes samples when asked or, in automatic mode, by itself, and
//! answers `~/take_sample`, `~/remove_sample`, `~/compute`, `~/save` and `~/reset`
//! between frames. A sample is on disk before the service that took it answers.

use std::collections::VecDeque;
use std::path::Path;
use std::sync::Arc;
use std::time::{Duration, Instant};

use nalgebra::Isometry3;
use ros2_client::Subscription;
use stereocal_msgs::atomic_file;
use stereocal_msgs::geometry_msgs::{PoseStamped, TransformStamped};
use stereocal_msgs::sensor_msgs::{CameraInfo, Image};
use stereocal_msgs::std_msgs::{self, Header};
use stereocal_msgs::std_srvs::srv::TriggerResponse;
use stereocal_msgs::stereocal_msgs::srv::{RemoveSampleRequest, RemoveSampleResponse};
use stereocal_msgs::tf2_msgs::TFMessage;
use stereocal_runtime::clock::NodeClock;
use stereocal_runtime::publisher::TopicPublisher;
use stereocal_runtime::service::{ServiceServer, Srv, TriggerServices};
use stereocal_runtime::skeleton::{FrameStats, Worker};
use stereocal_runtime::sync::Synced;
use stereocal_runtime::throttle::Throttle;
use stereocal_vision::handeye::{Sample, Setup, TargetObservation, motion_spread};

use super::page::html;
use super::report::FramesRecord;
use super::robot::{Motion, RobotPoses};
use super::session::{Calibrated, SessionSample, calibrate_session};
use super::settings::{HandEyeSettings, TargetSource};
use super::status::{
    DamagedEntry, FrameCounts, HandEyeStatus, LatestEntry, MotionEntry, MovedEntry, ResultEntry,
    SampleEntry,
};
use super::store::{DamagedSample, SampleStore, StoredCorners, StoredSample};
use crate::convert::{isometry_from_pose_msg, transform_msg};
use crate::pose::record::{TransformRecord, isometry_of, seconds};
use crate::pose::stage::camera_model_of;

/// How often `~/status` is published while frames arrive.
const STATUS_PERIOD: Duration = Duration::from_secs(1);
/// How long a target pose waits for the robot poses around its stamp, wall time.
const PAIRING_WAIT: Duration = Duration::from_secs(2);
/// Target poses kept waiting for robot poses; the oldest goes unpaired beyond this.
const MAX_PENDING: usize = 100;
/// The newest paired frame is too old to sample after this long without another (a
/// camera that stopped): the operator's pose is no longer the one it shows.
const MAX_CANDIDATE_AGE: Duration = Duration::from_secs(10);

/// A frame of the target as the skeleton delivers it: an image (with the camera_info
/// of its stamp beside it in the set), or a pose already measured.
pub enum TargetMessage {
    /// An image.
    Image(Arc<Image>),
    /// `camera_from_target`, measured already.
    Pose(Arc<PoseStamped>),
}

impl From<Arc<Image>> for TargetMessage {
    fn from(image: Arc<Image>) -> Self {
        Self::Image(image)
    }
}

impl From<Image> for TargetMessage {
    fn from(image: Image) -> Self {
        Self::Image(Arc::new(image))
    }
}

impl From<Arc<PoseStamped>> for TargetMessage {
    fn from(pose: Arc<PoseStamped>) -> Self {
        Self::Pose(pose)
    }
}

impl From<PoseStamped> for TargetMessage {
    fn from(pose: PoseStamped) -> Self {
        Self::Pose(Arc::new(pose))
    }
}

/// The node's Trigger services.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Service {
    /// `~/take_sample`: take a sample from the newest frame.
    TakeSample,
    /// `~/compute`: calibrate from the samples and publish the result on `/tf_static`.
    Compute,
    /// `~/save`: write the last result to `calibration_file`.
    Save,
    /// `~/reset`: forget every sample.
    Reset,
}

impl Service {
    /// Every Trigger service with its name.
    pub const ALL: [(Service, &'static str); 4] = [
        (Service::TakeSample, "~/take_sample"),
        (Service::Compute, "~/compute"),
        (Service::Save, "~/save"),
        (Service::Reset, "~/reset"),
    ];
}

/// The subscriptions the robot's poses arrive on.
pub enum RobotInputs {
    /// `robot_pose`.
    Topic(Box<Subscription<PoseStamped>>),
    /// `/tf` and `/tf_static`.
    Tf {
        /// `/tf`.
        tf: Box<Subscription<TFMessage>>,
        /// `/tf_static`.
        tf_static: Box<Subscription<TFMessage>>,
    },
}

/// What the worker reads, publishes on and serves.
pub struct Endpoints {
    /// The robot's poses.
    pub robot: RobotInputs,
    /// `~/status`.
    pub status: TopicPublisher<std_msgs::String>,
    /// `/tf_static`, where the result goes.
    pub tf_static: TopicPublisher<TFMessage>,
    /// `~/take_sample`, `~/compute`, `~/save`, `~/reset`.
    pub services: TriggerServices<Service>,
    /// `~/remove_sample`.
    pub remove_sample: ServiceServer<RemoveSampleRequest, RemoveSampleResponse>,
}

/// A target pose waiting for the robot's poses around its stamp.
#[derive(Clone, Debug)]
struct Observation {
    stamp: f64,
    camera_from_target: Isometry3<f64>,
    corners: Option<StoredCorners>,
    received: Instant,
}

/// A target pose paired with the robot's.
#[derive(Clone, Debug)]
struct Candidate {
    observation: Observation,
    base_from_tool: Isometry3<f64>,
    /// How far the robot moved before the stamp, or why that is unknown.
    moved: Result<Motion, String>,
    /// When it was paired.
    paired: Instant,
}

/// The newest frame's outcome.
#[derive(Clone, Debug)]
enum Latest {
    /// No target pose in it.
    NoTarget { stamp: f64, reason: String },
    /// No robot pose at its stamp.
    NoRobot { stamp: f64, reason: String },
    /// Paired.
    Paired(Box<Candidate>),
}

/// The hand-eye node's worker.
pub struct HandEyeWorker {
    settings: HandEyeSettings,
    endpoints: Endpoints,
    robot: RobotPoses,
    store: SampleStore,
    damaged: Vec<DamagedSample>,
    pending: VecDeque<Observation>,
    latest: Option<Latest>,
    calibrated: Option<Calibrated>,
    saved: Option<String>,
    camera_frame: String,
    counts: FrameCounts,
    status_due: Instant,
    clock: NodeClock,
    throttle: Throttle,
}

impl HandEyeWorker {
    /// A worker with the samples of `store` (and the `damaged` files it could not
    /// read), configured by `settings`.
    pub fn new(
        settings: HandEyeSettings,
        endpoints: Endpoints,
        (store, damaged): (SampleStore, Vec<DamagedSample>),
        clock: NodeClock,
    ) -> Self {
        let robot = match &endpoints.robot {
            RobotInputs::Topic(_) => RobotPoses::topic(),
            RobotInputs::Tf { .. } => RobotPoses::tf(&settings.base_frame, &settings.tool_frame),
        };
        Self {
            camera_frame: settings.camera_frame.clone(),
            settings,
            endpoints,
            robot,
            store,
            damaged,
            pending: VecDeque::new(),
            latest: None,
            calibrated: None,
            saved: None,
            counts: FrameCounts::default(),
            status_due: Instant::now(),
            throttle: Throttle::new(clock.clone()),
            clock,
        }
    }

    /// Keeps every robot pose that has arrived.
    fn receive_robot(&mut self) {
        let mut problems = Vec::new();
        match &self.endpoints.robot {
            RobotInputs::Topic(subscription) => loop {
                match subscription.take() {
                    Ok(Some((message, _))) => {
                        if let Err(e) = self.robot.insert_pose(&message) {
                            problems.push(format!("robot_pose: a pose skipped: {e}"));
                        }
                    }
                    Ok(None) => break,
                    Err(e) => {
                        problems.push(format!("robot_pose: undecodable message: {e}"));
                        break;
                    }
                }
            },
            RobotInputs::Tf { tf, tf_static } => {
                for (subscription, is_static, topic) in
                    [(tf_static, true, "/tf_static"), (tf, false, "/tf")]
                {
                    loop {
                        match subscription.take() {
                            Ok(Some((message, _))) => problems.extend(
                                self.robot
                                    .insert_tf(&message, is_static)
                                    .into_iter()
                                    .map(|e| format!("{topic}: a transform skipped: {e}")),
                            ),
                            Ok(None) => break,
                            Err(e) => {
                                problems.push(format!("{topic}: undecodable message: {e}"));
                                break;
                            }
                        }
                    }
                }
            }
        }
        for problem in problems {
            self.throttle.warn(problem);
        }
    }

    /// The target pose of a frame, or why there is none.
    fn observe(
        &mut self,
        set: &Synced<TargetMessage, CameraInfo>,
    ) -> Result<Option<Observation>, (f64, String)> {
        let Some(frame) = set.frames.first() else {
            return Ok(None);
        };
        match frame {
            TargetMessage::Image(image) => {
                let stamp = seconds(&image.header.stamp);
                let Some(info) = set.latched.first() else {
                    return Err((stamp, "no camera_info".into()));
                };
                self.learn_camera_frame(&image.header);
                let TargetSource::Image(stage) = &self.settings.target else {
                    return Err((stamp, "images arrive, but target_source is pose".into()));
                };
                let pose = stage
                    .estimate(image, info)
                    .0
                    .map_err(|r| (stamp, r.to_string()))?;
                Ok(Some(Observation {
                    stamp,
                    camera_from_target: pose.estimate.camera_from_target,
                    corners: Some(StoredCorners {
                        target_points: pose.target_points.iter().map(|p| [p.x, p.y, p.z]).collect(),
                        pixels: pose.detection.corners.iter().map(|p| [p.x, p.y]).collect(),
                        camera_info: CameraInfo::clone(info),
                    }),
                    received: Instant::now(),
                }))
            }
            TargetMessage::Pose(message) => {
                let stamp = seconds(&message.header.stamp);
                self.learn_camera_frame(&message.header);
                let camera_from_target = isometry_from_pose_msg(&message.pose)
                    .map_err(|e| (stamp, format!("target_pose: {e}")))?;
                Ok(Some(Observation {
                    stamp,
                    camera_from_target,
                    corners: None,
                    received: Instant::now(),
                }))
            }
        }
    }

    fn learn_camera_frame(&mut self, header: &Header) {
        if self.camera_frame.is_empty() && !header.frame_id.is_empty() {
            self.camera_frame = header.frame_id.clone();
        }
    }

    /// Pairs the waiting target poses whose robot poses have arrived, in stamp order;
    /// those that can no longer be paired go unpaired.
    fn pair_pending(&mut self) {
        let max_gap = self.settings.max_time_difference;
        while let Some(observation) = self.pending.front() {
            let stamp = observation.stamp;
            match self.robot.base_from_tool(stamp, max_gap) {
                Ok(base_from_tool) => {
                    let Some(observation) = self.pending.pop_front() else {
                        break;
                    };
                    let moved =
                        self.robot
                            .motion_before(stamp, self.settings.stillness.time_s, max_gap);
                    self.latest = Some(Latest::Paired(Box::new(Candidate {
                        observation,
                        base_from_tool,
                        moved,
                        paired: Instant::now(),
                    })));
                    if self.settings.auto_sample {
                        self.sample_automatically();
                    }
                }
                Err(reason) => {
                    let passed = self.robot.newest().is_some_and(|newest| {
                        newest > stamp + max_gap + PAIRING_WAIT.as_secs_f64()
                    });
                    if !passed && observation.received.elapsed() < PAIRING_WAIT {
                        break;
                    }
                    self.pending.pop_front();
                    self.unpaired(stamp, reason);
                }
            }
        }
    }

    fn unpaired(&mut self, stamp: f64, reason: String) {
        self.counts.no_robot_pose += 1;
        let reason = match self.robot.newest() {
            Some(_) => reason,
            None => match &self.endpoints.robot {
                RobotInputs::Topic(_) => "no robot pose has arrived on robot_pose".to_owned(),
                RobotInputs::Tf { .. } => "no transform has arrived on /tf".to_owned(),
            },
        };
        self.throttle.log_as(
            log::Level::Warn,
            "no robot pose".to_owned(),
            format!("no robot pose at the target's stamp {stamp:.6} s: {reason}"),
        );
        self.latest = Some(Latest::NoRobot { stamp, reason });
    }

    /// Why no sample can be taken from `candidate` now, if not.
    fn refusal(&self, candidate: &Candidate) -> Option<String> {
        let still = &self.settings.stillness;
        if candidate.paired.elapsed() > MAX_CANDIDATE_AGE {
            return Some(format!(
                "no target frame paired with a robot pose in the last {} s",
                MAX_CANDIDATE_AGE.as_secs()
            ));
        }
        match &candidate.moved {
            Err(e) => {
                return Some(format!(
                    "whether the robot stood still for {} s before the image is unknown: {e}",
                    still.time_s
                ));
            }
            Ok(moved)
                if moved.translation_m > still.translation_m
                    || moved.rotation_rad > still.rotation_rad =>
            {
                return Some(format!(
                    "the robot moved {:.2} mm and {:.3} degrees in the {} s before the image: \
                     wait until it stands still",
                    moved.translation_m * 1e3,
                    moved.rotation_rad.to_degrees(),
                    still.time_s
                ));
            }
            Ok(_) => {}
        }
        self.store
            .samples()
            .enumerate()
            .find_map(|(index, sample)| {
                let apart =
                    isometry_of(&sample.base_from_tool).inverse() * candidate.base_from_tool;
                (apart.translation.vector.norm() <= still.translation_m
                    && apart.rotation.angle() <= still.rotation_rad)
                    .then(|| {
                        format!(
                            "the robot stands where sample {index} was taken: move it to a new pose"
                        )
                    })
            })
    }

    /// Takes a sample from the newest frame when it can: its file is written before
    /// this returns.
    fn take_sample(&mut self) -> TriggerResponse {
        let refused = |message: String| TriggerResponse {
            success: false,
            message,
        };
        let candidate = match &self.latest {
            None => return refused("no target frame yet: is the camera publishing?".into()),
            Some(Latest::NoTarget { stamp, reason }) => {
                return refused(format!(
                    "no target pose in the newest frame ({stamp:.6} s): {reason}"
                ));
            }
            Some(Latest::NoRobot { stamp, reason }) => {
                return refused(format!(
                    "no robot pose at the newest frame's stamp ({stamp:.6} s): {reason}"
                ));
            }
            Some(Latest::Paired(candidate)) => (**candidate).clone(),
        };
        if let Some(reason) = self.refusal(&candidate) {
            return refused(reason);
        }
        let stamp = candidate.observation.stamp;
        let sample = StoredSample {
            stamp,
            base_from_tool: TransformRecord::new(&candidate.base_from_tool),
            camera_from_target: TransformRecord::new(&candidate.observation.camera_from_target),
            corners: candidate.observation.corners,
        };
        match self.store.take(sample) {
            Ok(index) => TriggerResponse {
                success: true,
                message: format!(
                    "sample {index} taken at {stamp:.6} s; {} kept in {}",
                    self.store.len(),
                    self.settings.state_dir.display()
                ),
            },
            Err(e) => refused(format!("sample not taken: {e}")),
        }
    }

    /// In automatic mode: takes the newest frame as a sample when it can and its robot
    /// pose turns by at least `auto_min_rotation` from every kept sample's.
    fn sample_automatically(&mut self) {
        let Some(Latest::Paired(candidate)) = &self.latest else {
            return;
        };
        if self.refusal(candidate).is_some() {
            return;
        }
        let turns_enough = self.store.samples().all(|sample| {
            let apart = isometry_of(&sample.base_from_tool).inverse() * candidate.base_from_tool;
            apart.rotation.angle() >= self.settings.auto_min_rotation
        });
        if !turns_enough {
            return;
        }
        let answer = self.take_sample();
        let level = if answer.success {
            log::Level::Info
        } else {
            log::Level::Warn
        };
        log::log!(level, "automatic sample: {}", answer.message);
        self.publish_status(None);
    }

    /// The kept samples as the calibration takes them.
    fn session_samples(&self) -> Vec<SessionSample> {
        let rectified = self.settings.image_is_rectified;
        self.store
            .samples()
            .map(|stored| SessionSample {
                stamp: stored.stamp,
                sample: Sample {
                    base_from_tool: isometry_of(&stored.base_from_tool),
                    camera_from_target: isometry_of(&stored.camera_from_target),
                },
                observation: stored.corners.as_ref().and_then(|corners| {
                    let camera = camera_model_of(&corners.camera_info, rectified).ok()?;
                    Some((
                        TargetObservation {
                            target_points: corners
                                .target_points
                                .iter()
                                .map(|p| (*p).into())
                                .collect(),
                            pixels: corners.pixels.iter().map(|p| (*p).into()).collect(),
                        },
                        camera,
                    ))
                }),
            })
            .collect()
    }

    fn frames(&self) -> FramesRecord {
        let base = if self.settings.base_frame.is_empty() {
            self.robot.base_frame().unwrap_or_default().to_owned()
        } else {
            self.settings.base_frame.clone()
        };
        FramesRecord {
            base,
            tool: self.settings.tool_frame.clone(),
            camera: self.camera_frame.clone(),
        }
    }

    /// Calibrates from the kept samples and publishes the result on `/tf_static`.
    fn compute(&mut self) -> TriggerResponse {
        let frames = self.frames();
        let calibrated = match calibrate_session(
            self.settings.setup,
            frames.clone(),
            &self.session_samples(),
            Vec::new(),
            &self.settings.weights,
        ) {
            Ok(calibrated) => calibrated,
            Err(e) => {
                return TriggerResponse {
                    success: false,
                    message: format!("calibration from {} samples failed: {e}", self.store.len()),
                };
            }
        };
        let report = &calibrated.report;
        let mount = match self.settings.setup {
            Setup::EyeInHand => &frames.tool,
            Setup::EyeToHand => &frames.base,
        };
        let camera = if frames.camera.is_empty() {
            "camera"
        } else {
            &frames.camera
        };
        let mut message = format!(
            "calibrated from {} samples with {}: residual medians {:.3} deg, {:.2} mm",
            report.samples,
            report.chosen,
            report.residuals.rotation_deg_median,
            report.residuals.translation_mm_median,
        );
        if let Some(u) = &report.uncertainty {
            message.push_str(&format!(
                "; predicted standard deviations {:.3} deg, {:.2} mm",
                u.rotation_deg, u.translation_mm
            ));
        }
        let transform = TransformStamped {
            header: Header {
                stamp: self.clock.now(),
                frame_id: mount.clone(),
            },
            child_frame_id: camera.to_owned(),
            transform: transform_msg(calibrated.hand_eye.mount_from_camera()),
        };
        match self.endpoints.tf_static.publish(TFMessage {
            transforms: vec![transform],
        }) {
            Ok(()) => message.push_str(&format!("; {mount} -> {camera} published on /tf_static")),
            Err(e) => message.push_str(&format!("; not published on /tf_static: {e}")),
        }
        for warning in &report.warnings {
            message.push_str(&format!("; warning: {warning}"));
        }
        self.calibrated = Some(calibrated);
        TriggerResponse {
            success: true,
            message,
        }
    }

    /// Writes the last result to `calibration_file`, and `report.html` beside it.
    fn save(&mut self) -> TriggerResponse {
        let Some(calibrated) = &self.calibrated else {
            return TriggerResponse {
                success: false,
                message: "nothing to save: no calibration yet; call ~/compute first".into(),
            };
        };
        match write_result(&self.settings.calibration_file, calibrated) {
            Ok(html_path) => {
                let path = self.settings.calibration_file.display().to_string();
                self.saved = Some(path.clone());
                TriggerResponse {
                    success: true,
                    message: format!("saved {path} and {}", html_path.display()),
                }
            }
            Err(message) => TriggerResponse {
                success: false,
                message,
            },
        }
    }

    fn reset(&mut self) -> TriggerResponse {
        match self.store.reset() {
            Ok(count) => {
                self.calibrated = None;
                TriggerResponse {
                    success: true,
                    message: format!(
                        "{count} samples forgotten (their files moved aside in {})",
                        self.settings.state_dir.display()
                    ),
                }
            }
            Err(e) => TriggerResponse {
                success: false,
                message: format!("reset failed: {e}"),
            },
        }
    }

    fn remove_sample(&mut self, request: RemoveSampleRequest) -> RemoveSampleResponse {
        let index = request.index as usize;
        let (success, message) = match self.store.remove(index) {
            Ok(sample) => (
                true,
                format!(
                    "sample {index} (taken at {:.6} s) removed; its file moved to removed/ in {}",
                    sample.stamp,
                    self.settings.state_dir.display()
                ),
            ),
            Err(e) => (false, format!("nothing removed: {e}")),
        };
        RemoveSampleResponse {
            success,
            message,
            samples: u32::try_from(self.store.len()).unwrap_or(u32::MAX),
        }
    }

    /// Answers the service calls that have arrived; whether there were any.
    fn answer_services(&mut self) -> bool {
        let calls = self.endpoints.services.receive();
        let mut answered = !calls.is_empty();
        for call in calls {
            let response = match call.service {
                Service::TakeSample => self.take_sample(),
                Service::Compute => self.compute(),
                Service::Save => self.save(),
                Service::Reset => self.reset(),
            };
            self.endpoints.services.respond(call, response);
        }
        loop {
            match self.endpoints.remove_sample.receive_request() {
                Ok(Some((id, Srv(request)))) => {
                    answered = true;
                    let response = self.remove_sample(request);
                    let level = if response.success {
                        log::Level::Info
                    } else {
                        log::Level::Warn
                    };
                    log::log!(level, "~/remove_sample: {}", response.message);
                    if let Err(e) = self
                        .endpoints
                        .remove_sample
                        .send_response(id, Srv(response))
                    {
                        log::warn!("~/remove_sample: response not sent: {e:?}");
                    }
                }
                Ok(None) => break,
                Err(e) => {
                    log::warn!("~/remove_sample: undecodable request: {e}");
                    break;
                }
            }
        }
        answered
    }

    fn status(&self) -> HandEyeStatus {
        let samples: Vec<Sample> = self
            .store
            .samples()
            .map(|s| Sample {
                base_from_tool: isometry_of(&s.base_from_tool),
                camera_from_target: isometry_of(&s.camera_from_target),
            })
            .collect();
        let (motion, warnings) = if samples.len() >= 2 {
            let spread = motion_spread(self.settings.setup, &samples);
            let mut warnings = spread.warnings(self.settings.setup);
            if let Err(e) = spread.check() {
                warnings.insert(0, e.to_string());
            }
            (
                Some(MotionEntry {
                    largest_rotation_deg: spread.largest_rotation_rad.to_degrees(),
                    axis_spread_deg: spread.axis_spread_rad.to_degrees(),
                }),
                warnings,
            )
        } else {
            (None, Vec::new())
        };
        let latest = self.latest.as_ref().map(|latest| match latest {
            Latest::NoTarget { stamp, reason } | Latest::NoRobot { stamp, reason } => LatestEntry {
                stamp: *stamp,
                ready: false,
                reason: Some(reason.clone()),
                moved: None,
            },
            Latest::Paired(candidate) => {
                let reason = self.refusal(candidate);
                LatestEntry {
                    stamp: candidate.observation.stamp,
                    ready: reason.is_none(),
                    reason,
                    moved: candidate.moved.as_ref().ok().map(|m| MovedEntry {
                        rotation_deg: m.rotation_rad.to_degrees(),
                        translation_mm: m.translation_m * 1e3,
                    }),
                }
            }
        });
        HandEyeStatus {
            setup: self.settings.setup.name(),
            samples: self
                .store
                .samples()
                .enumerate()
                .map(|(index, s)| SampleEntry {
                    index,
                    stamp: s.stamp,
                    corners: s.corners.as_ref().map(|c| c.pixels.len()),
                })
                .collect(),
            damaged: self
                .damaged
                .iter()
                .map(|d| DamagedEntry {
                    path: d.path.display().to_string(),
                    reason: d.reason.clone(),
                })
                .collect(),
            latest,
            motion,
            warnings,
            result: self.calibrated.as_ref().map(ResultEntry::new),
            saved: self.saved.clone(),
            frames: self.counts,
        }
    }

    fn publish_status(&mut self, stats: Option<&FrameStats>) {
        if let Some(stats) = stats {
            self.counts.received = stats.received();
            self.counts.dropped = stats.dropped();
            self.counts.unpaired = stats.unpaired();
        }
        let text = self.status().to_json_string();
        if let Err(e) = self
            .endpoints
            .status
            .publish(std_msgs::String { data: text })
        {
            self.throttle.warn(format!("~/status not published: {e}"));
        }
        self.status_due = Instant::now() + STATUS_PERIOD;
    }
}

/// Writes `calibrated`'s report to `path` and its page to `report.html` beside it,
/// each atomically; returns the page's path, or what went wrong.
fn write_result(path: &Path, calibrated: &Calibrated) -> Result<std::path::PathBuf, String> {
    let dir = path
        .parent()
        .filter(|d| !d.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    std::fs::create_dir_all(dir).map_err(|e| format!("creating {}: {e}", dir.display()))?;
    let text = serde_yaml::to_string(&calibrated.report)
        .map_err(|e| format!("encoding the result: {e}"))?;
    atomic_file::write(path, text.as_bytes())
        .map_err(|e| format!("writing {}: {e}", path.display()))?;
    let page_path = dir.join("report.html");
    let page = html(&calibrated.report).map_err(|e| format!("making report.html: {e}"))?;
    atomic_file::write(&page_path, page.as_bytes())
        .map_err(|e| format!("writing {}: {e}", page_path.display()))?;
    Ok(page_path)
}

impl Worker for HandEyeWorker {
    type Work = Synced<TargetMessage, CameraInfo>;
    const NAME: &'static str = "handeye";
    // Services and robot poses are taken between frames: often enough that a call feels
    // immediate and a target pose is paired as soon as its robot poses arrive.
    const POLL: Duration = Duration::from_millis(20);

    fn start(&mut self, stats: &FrameStats) {
        for damaged in &self.damaged {
            log::warn!(
                "sample file {} left in place, not read: {}",
                damaged.path.display(),
                damaged.reason
            );
        }
        log::info!(
            "{} samples kept in {}",
            self.store.len(),
            self.settings.state_dir.display()
        );
        self.publish_status(Some(stats));
    }

    fn handle(&mut self, set: Self::Work, stats: &FrameStats) {
        self.receive_robot();
        match self.observe(&set) {
            Ok(None) => {}
            // A frame delivered again (same stamp) while its first copy waits adds
            // nothing.
            Ok(Some(observation)) if self.pending.iter().any(|o| o.stamp == observation.stamp) => {}
            Ok(Some(observation)) => {
                self.pending.push_back(observation);
                if self.pending.len() > MAX_PENDING
                    && let Some(oldest) = self.pending.pop_front()
                {
                    self.unpaired(oldest.stamp, "robot poses fell behind the images".into());
                }
            }
            Err((stamp, reason)) => {
                self.counts.no_target += 1;
                self.throttle.log_as(
                    log::Level::Info,
                    "no target".to_owned(),
                    format!("no target pose at {stamp:.6} s: {reason}"),
                );
                self.latest = Some(Latest::NoTarget { stamp, reason });
            }
        }
        self.pair_pending();
        if Instant::now() >= self.status_due {
            self.publish_status(Some(stats));
        }
    }

    fn poll(&mut self, stats: &FrameStats) {
        self.receive_robot();
        self.pair_pending();
        if self.answer_services() {
            self.publish_status(Some(stats));
        }
        let changed = stats.received() != self.counts.received;
        if changed && Instant::now() >= self.status_due {
            self.publish_status(Some(stats));
        }
    }

    fn summary(&self) -> String {
        format!("{} samples kept", self.store.len())
    }
}
