//! The camera node: a V4L2 camera driver with camera_info_manager's semantics. Runs as
//! the `camera_node` executable and as `stereocal node camera`.
//!
//! Captures from `video_device` (or the built-in [test pattern](super::test_pattern)
//! with `video_device: test_pattern`) in `pixel_format` (YUYV, MJPEG or GREY) at
//! `image_width` x `image_height` and `framerate`, and publishes, stamped with each
//! frame's capture time (the V4L2 buffer timestamp on the node's clock, see
//! [`super::stamps`]):
//! - `image_raw` (sensor_msgs/Image): rgb8 or mono8 (`output_encoding`) from YUYV and
//!   MJPEG, mono8 from GREY; for MJPEG with `mjpeg_output` `raw` or `both`;
//! - `image_raw/compressed` (sensor_msgs/CompressedImage): for MJPEG with
//!   `mjpeg_output` `compressed` or `both`, each JPEG as the device made it;
//! - `camera_info`: the calibration at `camera_info_url`, or an uncalibrated one of the
//!   captured size;
//! - `~/status` (see [`super::status`]).
//!
//! Serves `set_camera_info` (sensor_msgs/SetCameraInfo), which writes the calibration
//! atomically to `camera_info_url`'s file before it answers. The device's controls are
//! parameters settable while running ([`super::controls`]). A device that is missing,
//! refuses the pixel format or stops is opened again with back-off
//! ([`super::connection`]); the node keeps running and says why on `/rosout` and
//! `~/status`. With `stereo_partner` (the other camera's camera_info topic), `~/status`
//! reports how this camera's stamps differ from the partner's ([`super::stereo_sync`]).

use std::time::{Duration, Instant};

use anyhow::Context;
use ros2_client::{ParameterValue, Subscription};
use stereocal_msgs::sensor_msgs::srv::{SetCameraInfoRequest, SetCameraInfoResponse};
use stereocal_msgs::sensor_msgs::{CameraInfo, CompressedImage, Image};
use stereocal_msgs::std_msgs;
use stereocal_runtime::args::RosArgs;
use stereocal_runtime::names::NodeIdentity;
use stereocal_runtime::node::{NodeBuilder, RosNode};
use stereocal_runtime::params::{ParamSpec, startup_params};
use stereocal_runtime::publisher::TopicPublisher;
use stereocal_runtime::qos;
use stereocal_runtime::service::{ServiceServer, Srv};
use stereocal_runtime::throttle::Throttle;

use super::camera_info::CameraInfoManager;
use super::connection::{Connection, DeviceState, Event, Opener};
use super::controls::ControlParams;
use super::device::{CameraDevice, DeviceError, Mode, PixelFormat};
use super::output::{FrameOutput, MjpegOutput, OutputEncoding, OutputSettings};
use super::stamps::{monotonic_now, ros_stamp};
use super::status::{CameraInfoStatus, CameraStatus};
use super::stereo_sync::StereoSync;
use super::test_pattern::{TEST_PATTERN_DEVICE, TestPattern};

/// The node's default name.
const NODE_NAME: &str = "camera_node";
/// How long one wait for a frame lasts before services and parameters are looked at.
const POLL: Duration = Duration::from_millis(50);
/// How often `~/status` is published while nothing changes.
const STATUS_PERIOD: Duration = Duration::from_secs(1);
/// Device refusals of control parameters kept in `~/status`.
const CONTROL_ERRORS_KEPT: usize = 5;

/// The node's own parameters (the device's controls come after them).
fn base_specs() -> Vec<ParamSpec> {
    vec![
        ParamSpec::new(
            "video_device",
            ParameterValue::String("/dev/video0".into()),
            "the V4L2 capture device, or test_pattern for the built-in test pattern",
        ),
        ParamSpec::new(
            "pixel_format",
            ParameterValue::String("YUYV".into()),
            "the device's pixel format: YUYV, MJPEG or GREY",
        )
        .one_of(&["YUYV", "MJPEG", "GREY"]),
        ParamSpec::new(
            "image_width",
            ParameterValue::Integer(640),
            "image width asked of the device, pixels",
        )
        .integer_range(2..=8192),
        ParamSpec::new(
            "image_height",
            ParameterValue::Integer(480),
            "image height asked of the device, pixels",
        )
        .integer_range(1..=8192),
        ParamSpec::new(
            "framerate",
            ParameterValue::Double(30.0),
            "frames per second asked of the device",
        )
        .double_range(0.1..=240.0),
        ParamSpec::new(
            "frame_id",
            ParameterValue::String("camera".into()),
            "the camera's optical frame, frame_id of every message",
        ),
        ParamSpec::new(
            "camera_name",
            ParameterValue::String("camera".into()),
            "the camera's name: ${NAME} in camera_info_url, camera_name in its file",
        ),
        ParamSpec::new(
            "camera_info_url",
            ParameterValue::String(String::new()),
            "where the calibration is kept: file:///path.yaml or package://PACKAGE/path.yaml, \
             with ${NAME} and ${ROS_HOME}; empty: file://${ROS_HOME}/camera_info/${NAME}.yaml",
        ),
        ParamSpec::new(
            "output_encoding",
            ParameterValue::String("rgb8".into()),
            "encoding of image_raw from YUYV and MJPEG: rgb8 or mono8 (GREY is always mono8)",
        )
        .one_of(&["rgb8", "mono8"]),
        ParamSpec::new(
            "mjpeg_output",
            ParameterValue::String("raw".into()),
            "with MJPEG: raw decodes into image_raw; compressed publishes each JPEG as it \
             came on image_raw/compressed, never decoded; both does both",
        )
        .one_of(&["raw", "compressed", "both"]),
        ParamSpec::new(
            "stereo_partner",
            ParameterValue::String(String::new()),
            "the camera_info topic of the other camera of a stereo pair: ~/status reports how \
             this camera's stamps differ from its; empty: none",
        ),
    ]
}

/// Opens the device named by `video_device`.
pub fn open_device(video_device: &str) -> Result<Box<dyn CameraDevice>, DeviceError> {
    if video_device == TEST_PATTERN_DEVICE {
        return Ok(Box::new(TestPattern::new()));
    }
    open_v4l2(video_device)
}

#[cfg(feature = "v4l2")]
fn open_v4l2(path: &str) -> Result<Box<dyn CameraDevice>, DeviceError> {
    Ok(Box::new(super::v4l2::V4l2Device::open(path)?))
}

#[cfg(not(feature = "v4l2"))]
fn open_v4l2(path: &str) -> Result<Box<dyn CameraDevice>, DeviceError> {
    Err(DeviceError::Open {
        device: path.to_owned(),
        reason: "this build has no V4L2 support (built without the v4l2 feature); \
                 only video_device test_pattern works"
            .into(),
    })
}

/// The start-up value of string parameter `name` of the node the command line `args`
/// starts (params files and `-p` values applied to the default).
fn startup_string(args: &[String], name: &str) -> anyhow::Result<String> {
    let (ros_args, _) = RosArgs::parse(args.iter().cloned())?;
    let identity = NodeIdentity::resolve(NODE_NAME, "/", &ros_args.remaps)?;
    let startup = startup_params(&base_specs(), &ros_args.params, &identity)?;
    Ok(startup
        .values
        .into_iter()
        .find(|p| p.name == name)
        .and_then(|p| match p.value {
            ParameterValue::String(s) => Some(s),
            _ => None,
        })
        .unwrap_or_default())
}

/// What the node publishes on and serves.
struct Endpoints {
    image: TopicPublisher<Image>,
    compressed: TopicPublisher<CompressedImage>,
    camera_info: TopicPublisher<CameraInfo>,
    status: TopicPublisher<std_msgs::String>,
    set_camera_info: ServiceServer<SetCameraInfoRequest, SetCameraInfoResponse>,
    partner: Option<(Subscription<CameraInfo>, StereoSync)>,
}

/// The running camera.
struct Camera {
    endpoints: Endpoints,
    connection: Connection,
    output: FrameOutput,
    settings: OutputSettings,
    camera_info: CameraInfoManager,
    controls: ControlParams,
    device_name: String,
    published: u64,
    last_bad_frame: Option<String>,
    size_warning: Option<String>,
    control_errors: Vec<String>,
    status_due: Instant,
    throttle: Throttle,
}

impl Camera {
    fn status(&self) -> CameraStatus {
        let calibrated = self.size_warning.is_none() && self.camera_info.problem().is_none();
        CameraStatus {
            device: self.device_name.clone(),
            state: self.connection.state().clone(),
            frames: self.output.counts(),
            published: self.published,
            last_bad_frame: self.last_bad_frame.clone(),
            camera_info: CameraInfoStatus {
                url: self.camera_info.url().to_owned(),
                calibrated,
                problem: self
                    .size_warning
                    .clone()
                    .or_else(|| self.camera_info.problem().map(str::to_owned)),
            },
            control_errors: self.control_errors.clone(),
            stereo_sync: self
                .endpoints
                .partner
                .as_ref()
                .map(|(_, sync)| sync.report()),
        }
    }

    fn publish_status(&mut self) {
        let data = self.status().to_json_string();
        if let Err(e) = self.endpoints.status.publish(std_msgs::String { data }) {
            self.throttle.warn(format!("~/status not published: {e}"));
        }
        self.status_due = Instant::now() + STATUS_PERIOD;
    }

    fn handle_frame(&mut self, node: &RosNode, frame: super::device::Frame) {
        let stamp = ros_stamp(frame.timestamp, monotonic_now(), node.clock().now());
        let Some(mode) = self.connection.mode() else {
            return;
        };
        let messages = match self.output.convert(frame, &mode, stamp, &self.settings) {
            Ok(messages) => messages,
            Err(reason) => {
                self.throttle.warn(format!("bad frame skipped: {reason}"));
                self.last_bad_frame = Some(reason);
                return;
            }
        };
        let header = messages
            .image
            .as_ref()
            .map(|m| m.header.clone())
            .or_else(|| messages.compressed.as_ref().map(|m| m.header.clone()))
            .unwrap_or_default();
        let (info, warning) = self
            .camera_info
            .camera_info(mode.width, mode.height, header);
        if warning != self.size_warning {
            if let Some(warning) = &warning {
                log::warn!("{warning}");
            }
            self.size_warning = warning;
        }
        let mut sent = false;
        if let Some(image) = messages.image {
            match self.endpoints.image.publish(image) {
                Ok(()) => sent = true,
                Err(e) => self.throttle.warn(format!("image_raw not published: {e}")),
            }
        }
        if let Some(compressed) = messages.compressed {
            match self.endpoints.compressed.publish(compressed) {
                Ok(()) => sent = true,
                Err(e) => self
                    .throttle
                    .warn(format!("image_raw/compressed not published: {e}")),
            }
        }
        if sent {
            self.published += 1;
        }
        if let Err(e) = self.endpoints.camera_info.publish(info) {
            self.throttle
                .warn(format!("camera_info not published: {e}"));
        }
        if let Some((_, sync)) = &mut self.endpoints.partner {
            sync.own_frame(stamp);
        }
    }

    fn serve_set_camera_info(&mut self) {
        loop {
            let (id, request) = match self.endpoints.set_camera_info.receive_request() {
                Ok(Some((id, Srv(request)))) => (id, request),
                Ok(None) => return,
                Err(e) => {
                    log::warn!("set_camera_info: undecodable request: {e}");
                    return;
                }
            };
            let response = match self.camera_info.set(request.camera_info) {
                Ok(message) => {
                    log::info!("set_camera_info: {message}");
                    self.size_warning = None;
                    SetCameraInfoResponse {
                        success: true,
                        status_message: message,
                    }
                }
                Err(reason) => {
                    log::warn!("set_camera_info refused: {reason}");
                    SetCameraInfoResponse {
                        success: false,
                        status_message: reason,
                    }
                }
            };
            if let Err(e) = self
                .endpoints
                .set_camera_info
                .send_response(id, Srv(response))
            {
                log::warn!("set_camera_info: response not sent: {e:?}");
            }
            self.publish_status();
        }
    }

    fn take_partner_stamps(&mut self) {
        if let Some((subscription, sync)) = &mut self.endpoints.partner {
            while let Ok(Some((info, _))) = subscription.take() {
                sync.partner_frame(info.header.stamp);
            }
        }
    }

    fn apply_controls(&mut self, node: &RosNode) {
        let Some(device) = self.connection.device_mut() else {
            return;
        };
        for refusal in self.controls.apply(node, device.as_mut()) {
            log::warn!("control not set: {refusal}");
            if self.control_errors.len() == CONTROL_ERRORS_KEPT {
                self.control_errors.remove(0);
            }
            self.control_errors.push(refusal);
        }
    }

    /// Captures and publishes until the process is asked to stop.
    fn run(&mut self, node: &RosNode) {
        let shutdown = node.shutdown();
        self.publish_status();
        while !shutdown.requested() {
            match self.connection.poll(POLL) {
                Event::Frame(frame) => self.handle_frame(node, frame),
                Event::Started(mode) => {
                    log::info!("{}: capturing {mode}", self.device_name);
                    self.output.device_restarted();
                    if let Some(device) = self.connection.device_mut() {
                        self.controls.device_started(device.as_ref());
                    }
                    self.publish_status();
                }
                Event::Failed(e) => {
                    let retry = match self.connection.state() {
                        DeviceState::Waiting { retry_in_s, .. } => *retry_in_s,
                        _ => 0.0,
                    };
                    log::error!("{e}; trying again in {retry:.1} s");
                    self.publish_status();
                }
                Event::Idle => {}
            }
            self.serve_set_camera_info();
            self.apply_controls(node);
            self.take_partner_stamps();
            if Instant::now() >= self.status_due {
                self.publish_status();
            }
        }
        self.publish_status();
        log::info!(
            "shutting down: {} frame(s) captured, {} published, {} dropped by the device, {} bad",
            self.output.counts().captured,
            self.published,
            self.output.counts().dropped,
            self.output.counts().bad_frames
        );
    }
}

/// Runs the camera node until SIGINT/SIGTERM, with `args` the command line without the
/// program name (`--ros-args` remaps, parameters, params files).
pub fn run<I, S>(args: I) -> anyhow::Result<()>
where
    I: IntoIterator<Item = S>,
    S: Into<String>,
{
    let args: Vec<String> = args.into_iter().map(Into::into).collect();
    // The device's controls are parameters: the device is opened before the node.
    let video_device = startup_string(&args, "video_device")?;
    let opened = open_device(&video_device);
    let taken: Vec<String> = base_specs().into_iter().map(|s| s.name).collect();
    let listed = opened.as_ref().ok().map(|device| device.controls());
    let (controls, control_specs) = match &listed {
        Some(Ok(list)) => ControlParams::new(list, &taken),
        _ => ControlParams::new(&[], &taken),
    };
    let mut builder = NodeBuilder::new(NODE_NAME);
    for spec in base_specs().into_iter().chain(control_specs) {
        builder = builder.param(spec);
    }
    let mut node = builder.start(args)?;
    if let Some(Err(e)) = listed {
        log::warn!("the device's controls are not parameters of this run: {e}");
    }
    let (device, opened_now) = match opened {
        Ok(device) => (Some(device), true),
        Err(e) => {
            log::error!(
                "{e}; its controls are not parameters of this run (restart the node once the \
                 device is there to set them); opening it again with back-off"
            );
            (None, false)
        }
    };
    let format_name = node.param_string("pixel_format")?;
    let format = PixelFormat::from_name(&format_name)
        .with_context(|| format!("pixel_format {format_name:?}"))?;
    let mode = Mode {
        format,
        width: u32::try_from(node.param_i64("image_width")?).context("image_width")?,
        height: u32::try_from(node.param_i64("image_height")?).context("image_height")?,
        fps: node.param_f64("framerate")?,
    };
    let settings = OutputSettings {
        encoding: match node.param_string("output_encoding")?.as_str() {
            "mono8" => OutputEncoding::Mono8,
            _ => OutputEncoding::Rgb8,
        },
        mjpeg: MjpegOutput::from_name(&node.param_string("mjpeg_output")?)
            .unwrap_or(MjpegOutput::Raw),
        frame_id: node.param_string("frame_id")?,
    };
    let camera_info = CameraInfoManager::load(
        &node.param_string("camera_name")?,
        &node.param_string("camera_info_url")?,
    );
    if let Some(problem) = camera_info.problem() {
        log::warn!("{problem}");
    }
    let partner_topic = node.param_string("stereo_partner")?;
    let partner = if partner_topic.is_empty() {
        None
    } else {
        let subscription = node.subscribe::<CameraInfo>(&partner_topic, qos::sensor_data(10))?;
        Some((
            subscription,
            StereoSync::new(&node.resolve_topic(&partner_topic)?),
        ))
    };
    let endpoints = Endpoints {
        image: node.advertise("image_raw", qos::reliable(5))?,
        compressed: node.advertise("image_raw/compressed", qos::reliable(5))?,
        camera_info: node.advertise("camera_info", qos::reliable(5))?,
        status: node.advertise(
            "~/status",
            qos::reliable(1).durability(ros2_client::qos::Durability::TransientLocal),
        )?,
        set_camera_info: node.create_server("set_camera_info")?,
        partner,
    };
    let opener: Opener = {
        let path = video_device.clone();
        Box::new(move || open_device(&path))
    };
    if opened_now {
        log::info!("{video_device}: starting {mode}");
    }
    let mut camera = Camera {
        endpoints,
        connection: Connection::new(opener, mode, device),
        output: FrameOutput::new(),
        settings,
        camera_info,
        controls,
        device_name: video_device,
        published: 0,
        last_bad_frame: None,
        size_warning: None,
        control_errors: Vec::new(),
        status_due: Instant::now(),
        throttle: Throttle::new(node.clock()),
    };
    camera.run(&node);
    drop(camera);
    drop(node);
    Ok(())
}
