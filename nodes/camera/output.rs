//! What camera_node publishes of one captured frame: `image_raw` (rgb8 or mono8 from
//! YUYV, decoded MJPEG, GREY as mono8) and, for MJPEG, the JPEG as it came from the
//! device on `image_raw/compressed` (no decoding, no copy of its bytes), stamped with
//! the frame's capture time; and the frame counts of `~/status` (frames, drops from
//! sequence gaps, frames that could not be converted).

use serde::Serialize;
use stereocal_msgs::builtin_interfaces::Time;
use stereocal_msgs::sensor_msgs::{CompressedImage, Image};
use stereocal_msgs::std_msgs::Header;
use stereocal_runtime::sequence_gaps::SequenceGaps;

use super::device::{Frame, Mode, PixelFormat};
use super::yuyv::{yuyv_to_mono8, yuyv_to_rgb8};
use crate::convert::image_msg_from_compressed;

/// The encoding of `image_raw` from a colour format (GREY is always mono8).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum OutputEncoding {
    /// Red, green, blue.
    Rgb8,
    /// Luma only.
    Mono8,
}

impl OutputEncoding {
    /// The ROS encoding name.
    pub fn ros_name(self) -> &'static str {
        match self {
            OutputEncoding::Rgb8 => "rgb8",
            OutputEncoding::Mono8 => "mono8",
        }
    }
}

/// What an MJPEG camera publishes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MjpegOutput {
    /// Each frame decoded into `image_raw`.
    Raw,
    /// Each JPEG as it came on `image_raw/compressed`, never decoded.
    Compressed,
    /// Both.
    Both,
}

impl MjpegOutput {
    /// The `mjpeg_output` parameter's value of this choice.
    pub fn from_name(name: &str) -> Option<Self> {
        match name {
            "raw" => Some(MjpegOutput::Raw),
            "compressed" => Some(MjpegOutput::Compressed),
            "both" => Some(MjpegOutput::Both),
            _ => None,
        }
    }
}

/// How frames become messages.
#[derive(Clone, Debug, PartialEq)]
pub struct OutputSettings {
    /// `image_raw`'s encoding from YUYV and MJPEG.
    pub encoding: OutputEncoding,
    /// What MJPEG frames are published as.
    pub mjpeg: MjpegOutput,
    /// The camera's optical frame, the messages' `frame_id`.
    pub frame_id: String,
}

/// The messages of one frame.
#[derive(Debug, Default)]
pub struct Messages {
    /// `image_raw`.
    pub image: Option<Image>,
    /// `image_raw/compressed`.
    pub compressed: Option<CompressedImage>,
}

/// Frame counters of `~/status`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
pub struct FrameCounts {
    /// Frames dequeued from the device.
    pub captured: u64,
    /// Frames the device's sequence numbers say were lost before they were dequeued.
    pub dropped: u64,
    /// Frames that could not be converted (a corrupt or truncated JPEG, a short
    /// buffer): counted, reported and skipped.
    pub bad_frames: u64,
}

/// Turns frames into messages and counts them.
#[derive(Debug, Default)]
pub struct FrameOutput {
    gaps: SequenceGaps<()>,
    counts: FrameCounts,
}

impl FrameOutput {
    /// A new output, counting from zero.
    pub fn new() -> Self {
        Self::default()
    }

    /// The counts so far.
    pub fn counts(&self) -> FrameCounts {
        self.counts
    }

    /// Starts counting sequence numbers afresh, as a reopened device restarts them.
    pub fn device_restarted(&mut self) {
        self.gaps = SequenceGaps::default();
    }

    /// The messages of `frame`, captured in `mode`, stamped `stamp`; why not when the
    /// frame cannot be converted (it is counted as bad). A gap in sequence numbers
    /// before it is counted as dropped frames.
    pub fn convert(
        &mut self,
        frame: Frame,
        mode: &Mode,
        stamp: Time,
        settings: &OutputSettings,
    ) -> Result<Messages, String> {
        self.counts.captured += 1;
        self.counts.dropped += self.gaps.record((), i64::from(frame.sequence));
        let result = messages(frame, mode, stamp, settings);
        if result.is_err() {
            self.counts.bad_frames += 1;
        }
        result
    }
}

/// Bytes before the end of an MJPEG frame (after any zero padding) searched for its
/// end marker: some devices leave a few bytes after it.
const JPEG_TAIL: usize = 4096;

/// Checks, without decoding, that `data` is a whole JPEG: the start-of-image marker
/// first and an end-of-image marker near its end (a truncated frame has none), after
/// the zero bytes some devices pad their buffers with. The length of the JPEG up to
/// its end marker.
fn check_jpeg_ends(data: &[u8]) -> Result<usize, String> {
    if !data.starts_with(&[0xff, 0xd8]) {
        return Err(format!(
            "not a JPEG: {} bytes without the start-of-image marker",
            data.len()
        ));
    }
    let filled = data
        .iter()
        .rposition(|&b| b != 0)
        .map_or(0, |last| last + 1);
    let start = filled.saturating_sub(JPEG_TAIL).max(2);
    data[start..filled]
        .windows(2)
        .rposition(|w| w == [0xff, 0xd9])
        .map(|at| start + at + 2)
        .ok_or_else(|| {
            format!(
                "truncated JPEG: {} bytes without the end-of-image marker",
                data.len()
            )
        })
}

/// The `height` rows of `width_bytes` bytes of a frame whose rows start `stride`
/// bytes apart (0: packed), packed; an error when the stride is shorter than a row or
/// the frame shorter than its rows.
fn packed_rows(
    mut data: Vec<u8>,
    width_bytes: usize,
    height: usize,
    stride: usize,
) -> Result<Vec<u8>, String> {
    let stride = if stride == 0 { width_bytes } else { stride };
    if stride < width_bytes {
        return Err(format!(
            "rows {stride} bytes apart are shorter than a row of {width_bytes} bytes"
        ));
    }
    let needed = if height == 0 {
        0
    } else {
        stride * (height - 1) + width_bytes
    };
    if data.len() < needed {
        return Err(format!(
            "with rows {stride} bytes apart it needs {needed} bytes, the frame has {}",
            data.len()
        ));
    }
    if stride == width_bytes {
        data.truncate(width_bytes * height);
        return Ok(data);
    }
    Ok(data
        .chunks(stride)
        .take(height)
        .flat_map(|row| &row[..width_bytes])
        .copied()
        .collect())
}

fn messages(
    frame: Frame,
    mode: &Mode,
    stamp: Time,
    settings: &OutputSettings,
) -> Result<Messages, String> {
    let header = Header {
        stamp,
        frame_id: settings.frame_id.clone(),
    };
    let (width, height) = (mode.width as usize, mode.height as usize);
    let sequence = frame.sequence;
    if frame.damaged {
        return Err(format!(
            "frame {sequence}: the device marked it damaged (V4L2_BUF_FLAG_ERROR)"
        ));
    }
    let image = |encoding: OutputEncoding, data: Vec<u8>| Image {
        header: header.clone(),
        height: mode.height,
        width: mode.width,
        encoding: encoding.ros_name().to_owned(),
        is_bigendian: 0,
        step: mode.width
            * if encoding == OutputEncoding::Rgb8 {
                3
            } else {
                1
            },
        data,
    };
    match mode.format {
        PixelFormat::Yuyv => {
            let convert = match settings.encoding {
                OutputEncoding::Rgb8 => yuyv_to_rgb8,
                OutputEncoding::Mono8 => yuyv_to_mono8,
            };
            let stride = if frame.stride == 0 {
                width * 2
            } else {
                frame.stride
            };
            let pixels = convert(&frame.data, width, height, stride)
                .map_err(|e| format!("frame {sequence}: {e}"))?;
            Ok(Messages {
                image: Some(image(settings.encoding, pixels)),
                compressed: None,
            })
        }
        PixelFormat::Grey => {
            let data = packed_rows(frame.data, width, height, frame.stride)
                .map_err(|e| format!("frame {sequence}: a {width}x{height} GREY image: {e}"))?;
            Ok(Messages {
                image: Some(image(OutputEncoding::Mono8, data)),
                compressed: None,
            })
        }
        PixelFormat::Mjpeg => {
            let length =
                check_jpeg_ends(&frame.data).map_err(|e| format!("frame {sequence}: {e}"))?;
            let mut data = frame.data;
            // What the device padded after the end marker is not sent on.
            data.truncate(length);
            let format = match settings.encoding {
                OutputEncoding::Rgb8 => "rgb8; jpeg compressed bgr8",
                OutputEncoding::Mono8 => "mono8; jpeg compressed mono8",
            };
            let compressed = CompressedImage {
                header,
                format: format.to_owned(),
                // The device's bytes themselves: moved, not copied.
                data,
            };
            let decoded = match settings.mjpeg {
                MjpegOutput::Compressed => None,
                MjpegOutput::Raw | MjpegOutput::Both => Some(
                    image_msg_from_compressed(&compressed)
                        .map_err(|e| format!("frame {sequence}: MJPEG frame not decoded: {e}"))?,
                ),
            };
            if let Some(decoded) = &decoded
                && (decoded.width, decoded.height) != (mode.width, mode.height)
            {
                return Err(format!(
                    "frame {sequence}: the JPEG is {}x{}, the device was set to {}x{}",
                    decoded.width, decoded.height, mode.width, mode.height
                ));
            }
            Ok(Messages {
                image: decoded,
                compressed: (settings.mjpeg != MjpegOutput::Raw).then_some(compressed),
            })
        }
    }
}
