//! The one small interface between camera_node and a capture device: open it with a
//! pixel format, size and frame rate, list what it offers, read and set its controls,
//! and dequeue frames with their bytes, V4L2 timestamp and sequence number.
//!
//! [`super::v4l2`] implements it on a V4L2 device, [`super::test_pattern`] on a
//! synthetic test pattern; tests implement it with scripted frames.

use std::fmt;
use std::time::Duration;

use thiserror::Error;

/// The pixel formats camera_node captures, by their V4L2 names.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum PixelFormat {
    /// `YUYV`: 4:2:2 packed Y0 U Y1 V, two bytes a pixel.
    Yuyv,
    /// `MJPG`: one JPEG per frame.
    Mjpeg,
    /// `GREY`: 8-bit luminance.
    Grey,
}

impl PixelFormat {
    /// Every format, in the order the `pixel_format` parameter lists them.
    pub const ALL: [PixelFormat; 3] = [PixelFormat::Yuyv, PixelFormat::Mjpeg, PixelFormat::Grey];

    /// The `pixel_format` parameter's name of the format (`YUYV`, `MJPEG`, `GREY`).
    pub fn name(self) -> &'static str {
        match self {
            PixelFormat::Yuyv => "YUYV",
            PixelFormat::Mjpeg => "MJPEG",
            PixelFormat::Grey => "GREY",
        }
    }

    /// The format of a `pixel_format` parameter value.
    pub fn from_name(name: &str) -> Option<Self> {
        PixelFormat::ALL.into_iter().find(|f| f.name() == name)
    }

    /// The V4L2 four-character code (`YUYV`, `MJPG`, `GREY`).
    pub fn fourcc(self) -> [u8; 4] {
        match self {
            PixelFormat::Yuyv => *b"YUYV",
            PixelFormat::Mjpeg => *b"MJPG",
            PixelFormat::Grey => *b"GREY",
        }
    }

    /// The format of a V4L2 four-character code, if camera_node captures it.
    pub fn from_fourcc(code: [u8; 4]) -> Option<Self> {
        PixelFormat::ALL.into_iter().find(|f| f.fourcc() == code)
    }
}

impl fmt::Display for PixelFormat {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// What a device captures: pixel format, size in pixels and frames per second.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Mode {
    /// Pixel format.
    pub format: PixelFormat,
    /// Width, pixels.
    pub width: u32,
    /// Height, pixels.
    pub height: u32,
    /// Frames per second.
    pub fps: f64,
}

impl fmt::Display for Mode {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "{} {}x{} at {} fps",
            self.format, self.width, self.height, self.fps
        )
    }
}

/// One captured frame as the device delivered it.
#[derive(Clone, Debug, PartialEq)]
pub struct Frame {
    /// The bytes the device filled (`bytesused`): packed pixels, or one JPEG.
    pub data: Vec<u8>,
    /// Bytes from the start of one row of packed pixels to the next (V4L2
    /// `bytesperline`): a row's bytes, or more where the driver pads its rows; 0 for
    /// compressed frames and where the device does not say (rows are then packed).
    pub stride: usize,
    /// Whether the device marked the frame as damaged (V4L2 `V4L2_BUF_FLAG_ERROR`):
    /// its bytes may be partly wrong, and camera_node publishes nothing of it.
    pub damaged: bool,
    /// When the device captured it, on `CLOCK_MONOTONIC` (the V4L2 buffer timestamp).
    pub timestamp: Duration,
    /// The device's frame counter (the V4L2 buffer sequence number); a jump of more
    /// than one means frames were lost.
    pub sequence: u32,
}

/// The kinds of V4L2 controls camera_node exposes as parameters.
#[derive(Clone, Debug, PartialEq)]
pub enum ControlKind {
    /// An integer from `min` to `max` in steps of `step`.
    Integer {
        /// Smallest value.
        min: i64,
        /// Largest value.
        max: i64,
        /// Step between values.
        step: i64,
    },
    /// On or off.
    Boolean,
    /// One of the listed values, each with its label.
    Menu {
        /// The values and their labels.
        items: Vec<(i64, String)>,
    },
}

/// A control of a device, as it describes it.
#[derive(Clone, Debug, PartialEq)]
pub struct Control {
    /// The device's id of the control.
    pub id: u32,
    /// The device's name of it (`Brightness`, `Exposure Time, Absolute`).
    pub name: String,
    /// Its kind and values.
    pub kind: ControlKind,
    /// Its current value (a boolean as 0 or 1).
    pub value: i64,
}

/// Why a device could not do what was asked.
#[derive(Debug, Error)]
pub enum DeviceError {
    /// The device could not be opened (it does not exist, or it is not a camera).
    #[error("cannot open {device}: {reason}")]
    Open {
        /// The device path.
        device: String,
        /// What failed.
        reason: String,
    },
    /// The device does not offer the pixel format asked for.
    #[error("{device} does not offer pixel format {asked}; it offers {}", offered_list(.offered))]
    FormatNotOffered {
        /// The device path.
        device: String,
        /// The format asked for.
        asked: PixelFormat,
        /// The four-character codes it offers.
        offered: Vec<String>,
    },
    /// The device refused or failed a request.
    #[error("{device}: {what}: {reason}")]
    Io {
        /// The device path.
        device: String,
        /// What was asked.
        what: String,
        /// What it said.
        reason: String,
    },
    /// The device stopped delivering (it was unplugged, or it failed).
    #[error("{device} stopped delivering frames: {reason}")]
    Lost {
        /// The device path.
        device: String,
        /// What it said.
        reason: String,
    },
}

fn offered_list(offered: &[String]) -> String {
    if offered.is_empty() {
        "no format".to_owned()
    } else {
        offered.join(", ")
    }
}

/// A capture device.
pub trait CameraDevice: Send {
    /// The device's path or name, for messages.
    fn name(&self) -> &str;

    /// The pixel formats the device offers, as four-character codes.
    fn offered_formats(&self) -> Result<Vec<String>, DeviceError>;

    /// Sets the device to capture `mode` and starts streaming; the mode the device
    /// granted (its nearest size and rate). A format it does not offer is
    /// [`DeviceError::FormatNotOffered`].
    fn start(&mut self, mode: &Mode) -> Result<Mode, DeviceError>;

    /// The device's controls with their current values.
    fn controls(&self) -> Result<Vec<Control>, DeviceError>;

    /// Sets control `id` to `value`.
    fn set_control(&mut self, id: u32, value: i64) -> Result<(), DeviceError>;

    /// The next frame, waiting at most `timeout`; `None` when none came in time.
    fn next_frame(&mut self, timeout: Duration) -> Result<Option<Frame>, DeviceError>;
}
