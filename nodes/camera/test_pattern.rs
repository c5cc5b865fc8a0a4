//! camera_node's test pattern, as many camera drivers have one: `video_device:
//! test_pattern` captures synthetic frames instead of a device's, so the node, its
//! topics, services and parameters can be tried without a camera. Moving colour bars
//! above a grey ramp, encoded as the device would deliver them (YUYV, MJPEG or GREY) at
//! the requested size and rate, stamped on `CLOCK_MONOTONIC` with consecutive sequence
//! numbers. Two controls act on it: `Brightness` (added to every channel) and
//! `Horizontal Flip`.

use std::time::Duration;

use image::ExtendedColorType;
use image::codecs::jpeg::JpegEncoder;

use super::device::{CameraDevice, Control, ControlKind, DeviceError, Frame, Mode, PixelFormat};
use super::stamps::monotonic_now;

/// The `video_device` value that selects the test pattern.
pub const TEST_PATTERN_DEVICE: &str = "test_pattern";

/// Distinct frames of the pattern's motion, rendered once per mode and control change.
const CYCLE: usize = 30;

/// The largest size the pattern grants, as a device grants the nearest size it has:
/// the frames of a cycle are kept, so this bounds their memory (124 MB in YUYV).
const MAX_SIZE: (u32, u32) = (1920, 1080);

/// JPEG quality of the MJPEG frames.
const JPEG_QUALITY: u8 = 90;

/// Control ids, as V4L2 numbers `V4L2_CID_BRIGHTNESS` and `V4L2_CID_HFLIP`.
const BRIGHTNESS: u32 = 0x0098_0900;
const HFLIP: u32 = 0x0098_0914;

/// The eight colour bars (white, yellow, cyan, green, magenta, red, blue, black).
const BARS: [[u8; 3]; 8] = [
    [235, 235, 235],
    [235, 235, 16],
    [16, 235, 235],
    [16, 235, 16],
    [235, 16, 235],
    [235, 16, 16],
    [16, 16, 235],
    [16, 16, 16],
];

/// The test-pattern device.
#[derive(Debug)]
pub struct TestPattern {
    mode: Option<Mode>,
    brightness: i64,
    flip: bool,
    frames: Vec<Vec<u8>>,
    started: Duration,
    sequence: u32,
}

impl Default for TestPattern {
    fn default() -> Self {
        Self::new()
    }
}

impl TestPattern {
    /// A test pattern not yet started.
    pub fn new() -> Self {
        TestPattern {
            mode: None,
            brightness: 0,
            flip: false,
            frames: Vec::new(),
            started: Duration::ZERO,
            sequence: 0,
        }
    }

    /// The rgb8 pixels of frame `index` of the cycle.
    fn render(&self, mode: &Mode, index: usize) -> Vec<u8> {
        let (w, h) = (mode.width as usize, mode.height as usize);
        let shift = index * w / CYCLE;
        let bars_end = h * 2 / 3;
        let mut rgb = Vec::with_capacity(w * h * 3);
        for y in 0..h {
            for x in 0..w {
                let sx = if self.flip { w - 1 - x } else { x };
                let colour = if y < bars_end {
                    BARS[((sx + shift) % w.max(1)) * BARS.len() / w.max(1)]
                } else {
                    let level = (16 + sx * 219 / w.max(1)) as u8;
                    [level; 3]
                };
                rgb.extend(colour.map(|c| (i64::from(c) + self.brightness).clamp(0, 255) as u8));
            }
        }
        rgb
    }

    /// Frame `index` encoded in `mode`'s pixel format.
    fn encode(&self, mode: &Mode, index: usize) -> Result<Vec<u8>, DeviceError> {
        let rgb = self.render(mode, index);
        Ok(match mode.format {
            PixelFormat::Yuyv => rgb_to_yuyv(&rgb),
            PixelFormat::Grey => rgb.chunks_exact(3).map(|p| luma(p).0).collect(),
            PixelFormat::Mjpeg => {
                let mut jpeg = Vec::new();
                JpegEncoder::new_with_quality(&mut jpeg, JPEG_QUALITY)
                    .encode(&rgb, mode.width, mode.height, ExtendedColorType::Rgb8)
                    .map_err(|e| DeviceError::Io {
                        device: TEST_PATTERN_DEVICE.into(),
                        what: "encoding an MJPEG frame".into(),
                        reason: e.to_string(),
                    })?;
                jpeg
            }
        })
    }

    fn render_cycle(&mut self) -> Result<(), DeviceError> {
        if let Some(mode) = self.mode {
            self.frames = (0..CYCLE)
                .map(|i| self.encode(&mode, i))
                .collect::<Result<_, _>>()?;
        }
        Ok(())
    }
}

/// BT.601 video-range luma and the pixel's (B - Y, R - Y) chroma terms.
fn luma(p: &[u8]) -> (u8, f64, f64) {
    let (r, g, b) = (f64::from(p[0]), f64::from(p[1]), f64::from(p[2]));
    let y = 16.0 + (65.481 * r + 128.553 * g + 24.966 * b) / 255.0;
    let u = (-37.797 * r - 74.203 * g + 112.0 * b) / 255.0;
    let v = (112.0 * r - 93.786 * g - 18.214 * b) / 255.0;
    (y.round().clamp(0.0, 255.0) as u8, u, v)
}

/// YUYV of rgb8 pixels (an even number per row), chroma averaged over each pair.
fn rgb_to_yuyv(rgb: &[u8]) -> Vec<u8> {
    let chroma = |c: f64| (128.0 + c).round().clamp(0.0, 255.0) as u8;
    rgb.chunks_exact(6)
        .flat_map(|pair| {
            let (y0, u0, v0) = luma(&pair[..3]);
            let (y1, u1, v1) = luma(&pair[3..]);
            [y0, chroma((u0 + u1) / 2.0), y1, chroma((v0 + v1) / 2.0)]
        })
        .collect()
}

impl CameraDevice for TestPattern {
    fn name(&self) -> &str {
        TEST_PATTERN_DEVICE
    }

    fn offered_formats(&self) -> Result<Vec<String>, DeviceError> {
        Ok(PixelFormat::ALL
            .iter()
            .map(|f| String::from_utf8_lossy(&f.fourcc()).into_owned())
            .collect())
    }

    fn start(&mut self, mode: &Mode) -> Result<Mode, DeviceError> {
        let granted = Mode {
            // YUYV pairs pixels, as a device would round the width.
            width: (mode.width.min(MAX_SIZE.0) & !1).max(2),
            height: mode.height.clamp(1, MAX_SIZE.1),
            fps: mode.fps.clamp(1.0, 120.0),
            format: mode.format,
        };
        self.mode = Some(granted);
        self.render_cycle()?;
        self.started = monotonic_now();
        self.sequence = 0;
        Ok(granted)
    }

    fn controls(&self) -> Result<Vec<Control>, DeviceError> {
        Ok(vec![
            Control {
                id: BRIGHTNESS,
                name: "Brightness".into(),
                kind: ControlKind::Integer {
                    min: -64,
                    max: 64,
                    step: 1,
                },
                value: self.brightness,
            },
            Control {
                id: HFLIP,
                name: "Horizontal Flip".into(),
                kind: ControlKind::Boolean,
                value: i64::from(self.flip),
            },
        ])
    }

    fn set_control(&mut self, id: u32, value: i64) -> Result<(), DeviceError> {
        let refused = |reason: String| DeviceError::Io {
            device: TEST_PATTERN_DEVICE.into(),
            what: format!("setting control {id:#x} to {value}"),
            reason,
        };
        match id {
            BRIGHTNESS if (-64..=64).contains(&value) => self.brightness = value,
            BRIGHTNESS => return Err(refused("out of range -64..=64".into())),
            HFLIP => self.flip = value != 0,
            _ => return Err(refused("no such control".into())),
        }
        self.render_cycle()
    }

    fn next_frame(&mut self, timeout: Duration) -> Result<Option<Frame>, DeviceError> {
        let Some(mode) = self.mode else {
            return Err(DeviceError::Lost {
                device: TEST_PATTERN_DEVICE.into(),
                reason: "not started".into(),
            });
        };
        let due = self.started + Duration::from_secs_f64(f64::from(self.sequence) / mode.fps);
        let now = monotonic_now();
        if due > now {
            let wait = due - now;
            std::thread::sleep(wait.min(timeout));
            if wait > timeout {
                return Ok(None);
            }
        }
        let data = self
            .frames
            .get(self.sequence as usize % CYCLE)
            .cloned()
            .unwrap_or_default();
        let frame = Frame {
            data,
            stride: 0,
            timestamp: monotonic_now(),
            sequence: self.sequence,
            damaged: false,
        };
        self.sequence = self.sequence.wrapping_add(1);
        Ok(Some(frame))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::camera::yuyv::yuyv_to_rgb8;

    fn mode(format: PixelFormat) -> Mode {
        Mode {
            format,
            width: 64,
            height: 48,
            fps: 200.0,
        }
    }

    #[test]
    fn frames_come_in_sequence_in_the_asked_format() -> Result<(), DeviceError> {
        let mut pattern = TestPattern::new();
        let granted = pattern.start(&mode(PixelFormat::Yuyv))?;
        assert_eq!(granted.fps, 120.0, "the rate is clamped");
        let mut last = None;
        for expected in 0..3 {
            let frame =
                pattern
                    .next_frame(Duration::from_secs(1))?
                    .ok_or_else(|| DeviceError::Lost {
                        device: "test".into(),
                        reason: "no frame".into(),
                    })?;
            assert_eq!(frame.sequence, expected);
            assert_eq!(frame.data.len(), 64 * 48 * 2);
            assert!(last.is_none_or(|t| frame.timestamp > t));
            last = Some(frame.timestamp);
        }
        pattern.start(&mode(PixelFormat::Mjpeg))?;
        let jpeg = pattern.next_frame(Duration::from_secs(1))?;
        assert!(jpeg.is_some_and(|f| f.data.starts_with(&[0xff, 0xd8])));
        Ok(())
    }

    #[test]
    fn yuyv_frames_decode_to_the_rendered_bars() -> Result<(), DeviceError> {
        let mut pattern = TestPattern::new();
        let mode = mode(PixelFormat::Yuyv);
        pattern.start(&mode)?;
        let rgb = pattern.render(&mode, 0);
        let decoded =
            yuyv_to_rgb8(&pattern.frames[0], 64, 48, 128).map_err(|e| DeviceError::Lost {
                device: "test".into(),
                reason: e.to_string(),
            })?;
        // Chroma is shared by a pair of pixels: compare away from the bar edges.
        let worst = rgb
            .iter()
            .zip(&decoded)
            .map(|(a, b)| a.abs_diff(*b))
            .max()
            .unwrap_or(0);
        assert!(worst <= 130, "edges only: {worst}");
        let (a, b) = (&rgb[3 * 4..3 * 5], &decoded[3 * 4..3 * 5]);
        assert!(
            a.iter().zip(b).all(|(x, y)| x.abs_diff(*y) <= 2),
            "{a:?} {b:?}"
        );
        Ok(())
    }

    #[test]
    fn brightness_is_a_control_with_a_range() -> Result<(), DeviceError> {
        let mut pattern = TestPattern::new();
        pattern.start(&mode(PixelFormat::Grey))?;
        let before = pattern.frames[0][0];
        pattern.set_control(BRIGHTNESS, 10)?;
        // 10 more in every channel is 219/255 of it in video-range luma.
        let after = pattern.frames[0][0];
        assert!((8..=9).contains(&(after - before)), "{before} -> {after}");
        assert!(pattern.set_control(BRIGHTNESS, 65).is_err());
        assert_eq!(pattern.controls()?[0].value, 10);
        Ok(())
    }
}
