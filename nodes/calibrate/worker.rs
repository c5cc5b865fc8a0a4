//! The calibrate node's worker: offers each synchronized frame to the
//! [`CalibrationSession`], publishes the annotated images and `~/status`, and answers
//! `~/calibrate`, `~/commit` and `~/reset` between frames.

use std::sync::Arc;
use std::time::Duration;

use stereocal_msgs::CameraInfoFile;
use stereocal_msgs::sensor_msgs::Image;
use stereocal_msgs::sensor_msgs::srv::{SetCameraInfoRequest, SetCameraInfoResponse};
use stereocal_msgs::std_msgs;
use stereocal_msgs::std_srvs::srv::TriggerResponse;
use stereocal_runtime::clock::NodeClock;
use stereocal_runtime::publisher::TopicPublisher;
use stereocal_runtime::service::{self, ServiceClient, TriggerServices};
use stereocal_runtime::skeleton::{FrameStats, Worker};
use stereocal_runtime::sync::Synced;
use stereocal_runtime::throttle::Throttle;
use stereocal_vision::calib::quality::ENOUGH_SAMPLES;
use stereocal_vision::image::Image as VisionImage;

use super::result::CalibrationResult;
use super::session::{CalibrationSession, Offer, Progress, Verdict, annotate};
use super::settings::CalibrateSettings;
use super::stage::CalibrationOutcome;
use super::status::{FrameCounts, NodeStatus};
use crate::convert::{Encoding, image_from_msg, msg_from_image};

/// How long `~/commit` waits for a camera's `set_camera_info` to answer.
const SET_CAMERA_INFO_TIMEOUT: Duration = Duration::from_secs(1);

/// The node's services.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Service {
    /// `~/calibrate`: calibrate from the kept samples.
    Calibrate,
    /// `~/commit`: write and send the calibration.
    Commit,
    /// `~/reset`: forget every sample.
    Reset,
}

impl Service {
    /// Every service with its name.
    pub const ALL: [(Service, &'static str); 3] = [
        (Service::Calibrate, "~/calibrate"),
        (Service::Commit, "~/commit"),
        (Service::Reset, "~/reset"),
    ];
}

/// A camera's `set_camera_info` client, with the service's resolved name.
pub type SetCameraInfo = (
    String,
    ServiceClient<SetCameraInfoRequest, SetCameraInfoResponse>,
);

/// What the worker publishes on, serves and calls.
pub struct Endpoints {
    /// `~/status`.
    pub status: TopicPublisher<std_msgs::String>,
    /// `~/annotated_image`, or `~/left/annotated_image` and `~/right/annotated_image`.
    pub annotated: Vec<TopicPublisher<Image>>,
    /// `~/calibrate`, `~/commit`, `~/reset`.
    pub services: TriggerServices<Service>,
    /// Each camera's `set_camera_info`, in camera order.
    pub set_camera_info: Vec<SetCameraInfo>,
}

/// A calibration and its results.
struct Calibrated {
    outcome: CalibrationOutcome,
    result: CalibrationResult,
}

/// The calibrate node's worker.
pub struct CalibrateWorker {
    session: CalibrationSession,
    settings: CalibrateSettings,
    endpoints: Endpoints,
    calibrated: Option<Calibrated>,
    last_verdict: Option<Verdict>,
    judged: u64,
    frame_log: Throttle,
    warn_log: Throttle,
}

impl CalibrateWorker {
    /// A worker judging frames with `session`, throttling repeated logs on `clock`.
    pub fn new(
        session: CalibrationSession,
        settings: CalibrateSettings,
        endpoints: Endpoints,
        clock: NodeClock,
    ) -> Self {
        Self {
            session,
            settings,
            endpoints,
            calibrated: None,
            last_verdict: None,
            judged: 0,
            frame_log: Throttle::new(clock.clone()),
            warn_log: Throttle::new(clock),
        }
    }

    fn publish_status(&mut self, progress: &Progress, stats: &FrameStats) {
        let frames = FrameCounts {
            received: stats.received(),
            judged: self.judged,
            dropped: stats.dropped(),
            unpaired: stats.unpaired(),
        };
        let status = NodeStatus::new(
            progress,
            self.last_verdict.as_ref(),
            frames,
            self.calibrated.as_ref().map(|c| &c.result),
        );
        if let Err(e) = self.endpoints.status.publish(std_msgs::String {
            data: status.to_json_string(),
        }) {
            self.warn_log.warn(format!("status not published: {e}"));
        }
    }

    /// Publishes each camera's image of `frame` annotated with its detection, the
    /// coverage bars and the verdict.
    fn publish_annotated(
        &mut self,
        frame: &Synced<Arc<Image>, ()>,
        images: &[VisionImage],
        offer: &Offer,
        progress: &Progress,
    ) {
        for (k, (image, publisher)) in images.iter().zip(&self.endpoints.annotated).enumerate() {
            let detection = offer.detections.get(k).and_then(Option::as_ref);
            let annotated = annotate(image, detection, progress, &offer.verdict);
            let Some(header) = frame.frames.get(k).map(|m| m.header.clone()) else {
                continue;
            };
            match msg_from_image(&annotated, Encoding::Rgb8, header) {
                Ok(msg) => {
                    if let Err(e) = publisher.publish(msg) {
                        self.warn_log
                            .warn(format!("annotated image not published: {e}"));
                    }
                }
                Err(e) => self.warn_log.warn(format!("annotated image not made: {e}")),
            }
        }
    }

    fn calibrate(&mut self) -> TriggerResponse {
        let progress = self.session.progress();
        if !progress.ready {
            return TriggerResponse {
                success: false,
                message: not_ready_message(&progress),
            };
        }
        match self.session.calibrate() {
            Ok(outcome) => {
                let result = CalibrationResult::from_outcome(&outcome);
                let message = format!(
                    "calibrated from {} samples: {}",
                    progress.samples,
                    result.rms_line()
                );
                self.calibrated = Some(Calibrated { outcome, result });
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

    fn commit(&self) -> TriggerResponse {
        let Some(calibrated) = &self.calibrated else {
            return TriggerResponse {
                success: false,
                message: "nothing to commit: no calibration yet; call ~/calibrate first".into(),
            };
        };
        let mut reports = Vec::new();
        let mut success = true;
        for ((camera, path), (client_name, client)) in calibrated
            .outcome
            .cameras
            .iter()
            .zip(&self.settings.camera_info_paths)
            .zip(&self.endpoints.set_camera_info)
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

    fn reset(&mut self) -> TriggerResponse {
        self.calibrated = None;
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

impl Worker for CalibrateWorker {
    type Work = Synced<Arc<Image>, ()>;
    const NAME: &'static str = "calibrate";
    // Services are answered between frames: often enough that a call feels immediate.
    const POLL: Duration = Duration::from_millis(20);

    fn start(&mut self, stats: &FrameStats) {
        self.publish_status(&self.session.progress(), stats);
    }

    fn handle(&mut self, frame: Self::Work, stats: &FrameStats) {
        let mut images = Vec::with_capacity(frame.frames.len());
        for (msg, camera) in frame.frames.iter().zip(&self.settings.session.cameras) {
            match image_from_msg(msg) {
                Ok((_, image)) => images.push(image),
                Err(e) => {
                    self.warn_log
                        .warn(format!("camera {camera}: unusable image: {e}"));
                    return;
                }
            }
        }
        let refs: Vec<_> = images.iter().collect();
        let offer = match self.session.offer(frame.stamp, &refs) {
            Ok(offer) => offer,
            Err(e) => {
                self.warn_log.warn(format!("frame not judged: {e}"));
                return;
            }
        };
        self.judged += 1;
        let progress = self.session.progress();
        match &offer.verdict {
            Verdict::Added => log::info!(
                "sample added at {}.{:09}: {}",
                frame.stamp.sec,
                frame.stamp.nanosec,
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
        self.publish_annotated(&frame, &images, &offer, &progress);
        let added = offer.verdict == Verdict::Added;
        self.last_verdict = Some(offer.verdict);
        if added && progress.ready && self.settings.auto_calibrate && self.calibrated.is_none() {
            log::info!("coverage is ready: calibrating");
            let answer = self.calibrate();
            let level = if answer.success {
                log::Level::Info
            } else {
                log::Level::Warn
            };
            log::log!(level, "{}", answer.message);
        }
        self.publish_status(&progress, stats);
    }

    fn poll(&mut self, stats: &FrameStats) {
        let calls = self.endpoints.services.receive();
        let answered = !calls.is_empty();
        for call in calls {
            let response = match call.service {
                Service::Calibrate => self.calibrate(),
                Service::Commit => self.commit(),
                Service::Reset => self.reset(),
            };
            self.endpoints.services.respond(call, response);
        }
        if answered {
            self.publish_status(&self.session.progress(), stats);
        }
    }

    fn summary(&self) -> String {
        format!("{} judged", self.judged)
    }
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::calibrate::session::CameraCoverage;

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
