//! [`CameraDevice`] on a V4L2 device through the `v4l` crate: memory-mapped streaming,
//! each dequeued buffer's `bytesused` bytes copied out once with its timestamp and
//! sequence number. Kept thin: every call is one `v4l` call and the mapping of its
//! result; the tests drive camera_node through the trait, as CI has no video device.

use std::io;
use std::time::Duration;

use v4l::buffer::{Flags as BufferFlags, Type};
use v4l::capability::Flags;
use v4l::control::{self, MenuItem, Value};
use v4l::io::mmap::Stream;
use v4l::io::traits::CaptureStream;
use v4l::video::Capture;
use v4l::video::capture::Parameters;
use v4l::{Device, Format, FourCC, Fraction};

use super::device::{CameraDevice, Control, ControlKind, DeviceError, Frame, Mode, PixelFormat};

/// Buffers the driver fills while one is being handled.
const BUFFERS: u32 = 4;

/// A V4L2 capture device.
pub struct V4l2Device {
    path: String,
    device: Device,
    stream: Option<Stream<'static>>,
    /// The granted format's `bytesperline`.
    stride: usize,
}

impl V4l2Device {
    /// Opens the capture device at `path` (such as `/dev/video0`).
    pub fn open(path: &str) -> Result<Self, DeviceError> {
        let open_error = |reason: String| DeviceError::Open {
            device: path.to_owned(),
            reason,
        };
        let device = Device::with_path(path).map_err(|e| open_error(e.to_string()))?;
        let caps = device
            .query_caps()
            .map_err(|e| open_error(format!("not a V4L2 device: {e}")))?;
        if !caps.capabilities.contains(Flags::VIDEO_CAPTURE) {
            return Err(open_error(format!(
                "{} ({}) cannot capture video (single-planar)",
                caps.card, caps.driver
            )));
        }
        log::info!(
            "opened {path}: {} ({}, {})",
            caps.card,
            caps.driver,
            caps.bus
        );
        Ok(V4l2Device {
            path: path.to_owned(),
            device,
            stream: None,
            stride: 0,
        })
    }

    fn io_error(&self, what: &str) -> impl FnOnce(io::Error) -> DeviceError + '_ {
        let what = what.to_owned();
        move |e| DeviceError::Io {
            device: self.path.clone(),
            what,
            reason: e.to_string(),
        }
    }
}

/// The kind of a control camera_node exposes; `None` for buttons, strings, compound
/// and class controls.
fn control_kind(description: &control::Description) -> Option<ControlKind> {
    match description.typ {
        control::Type::Integer | control::Type::Integer64 => Some(ControlKind::Integer {
            min: description.minimum,
            max: description.maximum,
            step: i64::try_from(description.step).unwrap_or(1).max(1),
        }),
        control::Type::Boolean => Some(ControlKind::Boolean),
        control::Type::Menu | control::Type::IntegerMenu => Some(ControlKind::Menu {
            items: description
                .items
                .iter()
                .flatten()
                .map(|(index, item)| {
                    let label = match item {
                        MenuItem::Name(name) => name.clone(),
                        MenuItem::Value(value) => value.to_string(),
                    };
                    (i64::from(*index), label)
                })
                .collect(),
        }),
        _ => None,
    }
}

impl CameraDevice for V4l2Device {
    fn name(&self) -> &str {
        &self.path
    }

    fn offered_formats(&self) -> Result<Vec<String>, DeviceError> {
        let formats = self
            .device
            .enum_formats()
            .map_err(self.io_error("listing pixel formats"))?;
        Ok(formats
            .iter()
            .map(|f| String::from_utf8_lossy(&f.fourcc.repr).into_owned())
            .collect())
    }

    fn start(&mut self, mode: &Mode) -> Result<Mode, DeviceError> {
        self.stream = None;
        let offered = self.offered_formats()?;
        let code = String::from_utf8_lossy(&mode.format.fourcc()).into_owned();
        if !offered.contains(&code) {
            return Err(DeviceError::FormatNotOffered {
                device: self.path.clone(),
                asked: mode.format,
                offered,
            });
        }
        let asked = Format::new(mode.width, mode.height, FourCC::new(&mode.format.fourcc()));
        let format = self
            .device
            .set_format(&asked)
            .map_err(self.io_error("setting the format"))?;
        let format_code = PixelFormat::from_fourcc(format.fourcc.repr).ok_or_else(|| {
            DeviceError::FormatNotOffered {
                device: self.path.clone(),
                asked: mode.format,
                offered: vec![String::from_utf8_lossy(&format.fourcc.repr).into_owned()],
            }
        })?;
        // The frame interval is a fraction of a second: 1/30 for 30 fps.
        let interval = Fraction::new(1000, (mode.fps * 1000.0).round().max(1.0) as u32);
        let params = self
            .device
            .set_params(&Parameters::new(interval))
            .map_err(self.io_error("setting the frame rate"))?;
        let fps = if params.interval.numerator == 0 {
            mode.fps
        } else {
            f64::from(params.interval.denominator) / f64::from(params.interval.numerator)
        };
        let stream = Stream::with_buffers(&self.device, Type::VideoCapture, BUFFERS)
            .map_err(self.io_error("mapping capture buffers"))?;
        self.stream = Some(stream);
        self.stride = format.stride as usize;
        Ok(Mode {
            format: format_code,
            width: format.width,
            height: format.height,
            fps,
        })
    }

    fn controls(&self) -> Result<Vec<Control>, DeviceError> {
        let descriptions = self
            .device
            .query_controls()
            .map_err(self.io_error("listing controls"))?;
        let mut controls = Vec::new();
        for description in descriptions {
            let Some(kind) = control_kind(&description) else {
                continue;
            };
            let value = match self.device.control(description.id).map(|c| c.value) {
                Ok(Value::Integer(v)) => v,
                Ok(Value::Boolean(b)) => i64::from(b),
                _ => description.default,
            };
            controls.push(Control {
                id: description.id,
                name: description.name,
                kind,
                value,
            });
        }
        Ok(controls)
    }

    fn set_control(&mut self, id: u32, value: i64) -> Result<(), DeviceError> {
        let control = control::Control {
            id,
            value: Value::Integer(value),
        };
        self.device
            .set_control(control)
            .map_err(self.io_error(&format!("setting control {id:#x} to {value}")))
    }

    fn next_frame(&mut self, timeout: Duration) -> Result<Option<Frame>, DeviceError> {
        let Some(stream) = self.stream.as_mut() else {
            return Err(DeviceError::Lost {
                device: self.path.clone(),
                reason: "not streaming".into(),
            });
        };
        stream.set_timeout(timeout);
        match stream.next() {
            Ok((buffer, meta)) => {
                let used = (meta.bytesused as usize).min(buffer.len());
                let timestamp = Duration::new(
                    u64::try_from(meta.timestamp.sec).unwrap_or(0),
                    u32::try_from(meta.timestamp.usec * 1000).unwrap_or(0),
                );
                Ok(Some(Frame {
                    data: buffer[..used].to_vec(),
                    stride: self.stride,
                    timestamp,
                    sequence: meta.sequence,
                    damaged: meta.flags.contains(BufferFlags::ERROR),
                }))
            }
            Err(e) if e.kind() == io::ErrorKind::TimedOut => Ok(None),
            Err(e) => {
                self.stream = None;
                Err(DeviceError::Lost {
                    device: self.path.clone(),
                    reason: e.to_string(),
                })
            }
        }
    }
}
