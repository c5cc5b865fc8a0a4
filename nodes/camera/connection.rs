//! The device's life in camera_node: opened and started in the requested mode, and when
//! it is missing, refuses the mode, fails or stops delivering, closed and opened again
//! after a back-off that doubles up to [`MAX_BACKOFF`]. The node never exits on it; the
//! state says why it is not streaming.

use std::time::{Duration, Instant};

use serde::Serialize;

use super::device::{CameraDevice, DeviceError, Frame, Mode};

/// First wait before opening a device again.
pub const MIN_BACKOFF: Duration = Duration::from_millis(500);
/// Longest wait before opening a device again.
pub const MAX_BACKOFF: Duration = Duration::from_secs(8);
/// The shortest time without a frame after which a streaming device counts as stalled
/// (at low frame rates, ten frame intervals).
const MIN_STALL: Duration = Duration::from_secs(3);

/// Opens the device: a new handle each time.
pub type Opener = Box<dyn FnMut() -> Result<Box<dyn CameraDevice>, DeviceError> + Send>;

/// Where the device is, for `~/status`.
#[derive(Clone, Debug, PartialEq, Serialize)]
#[serde(tag = "state", rename_all = "snake_case")]
pub enum DeviceState {
    /// Not opened yet.
    Opening,
    /// Capturing.
    Streaming {
        /// The mode the device granted.
        mode: String,
    },
    /// Not capturing; opened again after `retry_in_s`.
    Waiting {
        /// Why.
        reason: String,
        /// Seconds until the next attempt, from when the state was entered.
        retry_in_s: f64,
    },
}

/// What [`Connection::poll`] saw.
#[derive(Debug)]
pub enum Event {
    /// The device was opened and started in this mode (granted by the device).
    Started(Mode),
    /// A frame.
    Frame(Frame),
    /// Nothing in time.
    Idle,
    /// The device could not be opened or started, or it stopped: the error; it is
    /// opened again after the back-off.
    Failed(DeviceError),
}

/// The device, opened again whenever it fails.
pub struct Connection {
    opener: Opener,
    mode: Mode,
    device: Option<(Box<dyn CameraDevice>, Mode)>,
    state: DeviceState,
    backoff: Duration,
    retry_at: Instant,
    last_frame: Instant,
}

impl Connection {
    /// A connection that opens devices with `opener` and starts them in `mode`, first
    /// using `device` if one is already open.
    pub fn new(opener: Opener, mode: Mode, device: Option<Box<dyn CameraDevice>>) -> Self {
        let mut connection = Connection {
            opener,
            mode,
            device: None,
            state: DeviceState::Opening,
            backoff: MIN_BACKOFF,
            retry_at: Instant::now(),
            last_frame: Instant::now(),
        };
        if let Some(device) = device {
            connection.device = Some((device, mode));
        }
        connection
    }

    /// The device's state.
    pub fn state(&self) -> &DeviceState {
        &self.state
    }

    /// The open device, if streaming.
    pub fn device_mut(&mut self) -> Option<&mut Box<dyn CameraDevice>> {
        match self.state {
            DeviceState::Streaming { .. } => self.device.as_mut().map(|(device, _)| device),
            _ => None,
        }
    }

    /// The mode the device granted, if streaming.
    pub fn mode(&self) -> Option<Mode> {
        match self.state {
            DeviceState::Streaming { .. } => self.device.as_ref().map(|(_, mode)| *mode),
            _ => None,
        }
    }

    fn fail(&mut self, error: DeviceError) -> Event {
        self.device = None;
        self.retry_at = Instant::now() + self.backoff;
        self.state = DeviceState::Waiting {
            reason: error.to_string(),
            retry_in_s: self.backoff.as_secs_f64(),
        };
        self.backoff = (self.backoff * 2).min(MAX_BACKOFF);
        Event::Failed(error)
    }

    fn stall_limit(&self) -> Duration {
        self.mode()
            .map(|mode| Duration::from_secs_f64(10.0 / mode.fps.max(0.1)))
            .unwrap_or_default()
            .max(MIN_STALL)
    }

    /// Waits at most `timeout` for what comes next: opens and starts the device when
    /// it is due, else takes its next frame.
    pub fn poll(&mut self, timeout: Duration) -> Event {
        if !matches!(self.state, DeviceState::Streaming { .. }) {
            let now = Instant::now();
            if now < self.retry_at {
                std::thread::sleep((self.retry_at - now).min(timeout));
                return Event::Idle;
            }
            let mut device = match self.device.take() {
                Some((device, _)) => device,
                None => match (self.opener)() {
                    Ok(device) => device,
                    Err(e) => return self.fail(e),
                },
            };
            return match device.start(&self.mode) {
                Ok(granted) => {
                    self.device = Some((device, granted));
                    self.state = DeviceState::Streaming {
                        mode: granted.to_string(),
                    };
                    self.backoff = MIN_BACKOFF;
                    self.last_frame = Instant::now();
                    Event::Started(granted)
                }
                Err(e) => self.fail(e),
            };
        }
        let stall = self.stall_limit();
        let Some((device, _)) = self.device.as_mut() else {
            return Event::Idle;
        };
        match device.next_frame(timeout) {
            Ok(Some(frame)) => {
                self.last_frame = Instant::now();
                Event::Frame(frame)
            }
            Ok(None) if self.last_frame.elapsed() > stall => {
                let device = device.name().to_owned();
                self.fail(DeviceError::Lost {
                    device,
                    reason: format!("no frame for {:.1} s", stall.as_secs_f64()),
                })
            }
            Ok(None) => Event::Idle,
            Err(e) => self.fail(e),
        }
    }
}
