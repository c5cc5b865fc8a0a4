//! camera_node's capture stage driven directly with a scripted device: YUYV, MJPEG and
//! GREY frames encoded from synthetic images, with V4L2-style timestamps and sequence
//! numbers, a gap, a truncated MJPEG frame, a device that is missing, refuses the pixel
//! format, or stops; and the camera_info manager's `set_camera_info` on disk.

use std::collections::VecDeque;
use std::sync::{Arc, Mutex};
use std::time::Duration;

use image::ExtendedColorType;
use image::codecs::jpeg::JpegEncoder;
use stereocal::camera::camera_info::CameraInfoManager;
use stereocal::camera::connection::{Connection, DeviceState, Event};
use stereocal::camera::device::{CameraDevice, Control, DeviceError, Frame, Mode, PixelFormat};
use stereocal::camera::output::{FrameOutput, MjpegOutput, OutputEncoding, OutputSettings};
use stereocal::camera::stamps::ros_stamp;
use stereocal_msgs::CameraInfoFile;
use stereocal_msgs::builtin_interfaces::Time;
use stereocal_msgs::sensor_msgs::CameraInfo;
use stereocal_msgs::std_msgs::Header;

const WIDTH: u32 = 64;
const HEIGHT: u32 = 48;

fn mode(format: PixelFormat) -> Mode {
    Mode {
        format,
        width: WIDTH,
        height: HEIGHT,
        fps: 30.0,
    }
}

fn settings(encoding: OutputEncoding, mjpeg: MjpegOutput) -> OutputSettings {
    OutputSettings {
        encoding,
        mjpeg,
        frame_id: "left_optical".into(),
    }
}

/// The synthetic frame in YUV: luma, and chroma shared by each pair of pixels.
fn yuv(x: u32, y: u32, seed: u32) -> (u8, u8, u8) {
    let luma = 16 + (x * 3 + y * 5 + seed * 7) % 220;
    let u = 128 + (x / 2 * 5 + y) % 90 - 45;
    let v = 128 + (x / 2 * 3 + y * 2 + seed) % 100 - 50;
    (luma as u8, u as u8, v as u8)
}

fn yuyv_frame(seed: u32) -> Vec<u8> {
    let mut data = Vec::new();
    for y in 0..HEIGHT {
        for x in (0..WIDTH).step_by(2) {
            let (y0, u, v) = yuv(x, y, seed);
            let (y1, _, _) = yuv(x + 1, y, seed);
            data.extend([y0, u, y1, v]);
        }
    }
    data
}

/// BT.601 video range in floating point: the independent reference of the rgb8 test.
fn reference_rgb(luma: u8, u: u8, v: u8) -> [f64; 3] {
    let (c, d, e) = (
        f64::from(luma) - 16.0,
        f64::from(u) - 128.0,
        f64::from(v) - 128.0,
    );
    [
        1.164 * c + 1.596 * e,
        1.164 * c - 0.392 * d - 0.813 * e,
        1.164 * c + 2.017 * d,
    ]
    .map(|x| x.clamp(0.0, 255.0))
}

fn rgb_frame(seed: u32) -> Vec<u8> {
    (0..HEIGHT)
        .flat_map(|y| {
            (0..WIDTH).flat_map(move |x| {
                let checker = if (x / 8 + y / 8) % 2 == 0 { 60 } else { 190 };
                [checker, (x * 4 + seed) as u8, (y * 5) as u8]
            })
        })
        .collect()
}

fn jpeg(rgb: &[u8]) -> Vec<u8> {
    let mut out = Vec::new();
    JpegEncoder::new_with_quality(&mut out, 95)
        .encode(rgb, WIDTH, HEIGHT, ExtendedColorType::Rgb8)
        .expect("jpeg");
    out
}

fn frame(data: Vec<u8>, sequence: u32, timestamp_ms: u64) -> Frame {
    Frame {
        data,
        stride: 0,
        timestamp: Duration::from_millis(timestamp_ms),
        sequence,
        damaged: false,
    }
}

/// `packed`'s rows of `row_bytes` moved `stride` bytes apart, the gaps filled with
/// bytes no image has, as a driver that pads its rows delivers them.
fn padded(packed: &[u8], row_bytes: usize, stride: usize) -> Vec<u8> {
    packed
        .chunks(row_bytes)
        .flat_map(|row| {
            row.iter()
                .copied()
                .chain(std::iter::repeat_n(0xa5, stride - row_bytes))
        })
        .collect()
}

#[test]
fn rows_a_driver_pads_come_out_as_the_packed_frame_would() {
    let settings_of = |encoding| settings(encoding, MjpegOutput::Raw);
    for (format, row_bytes, packed, encodings) in [
        (
            PixelFormat::Yuyv,
            WIDTH as usize * 2,
            yuyv_frame(6),
            vec![OutputEncoding::Rgb8, OutputEncoding::Mono8],
        ),
        (
            PixelFormat::Grey,
            WIDTH as usize,
            (0..WIDTH * HEIGHT).map(|i| (i * 7 % 251) as u8).collect(),
            vec![OutputEncoding::Mono8],
        ),
    ] {
        for encoding in encodings {
            let mut output = FrameOutput::new();
            let from_packed = output
                .convert(
                    frame(packed.clone(), 0, 0),
                    &mode(format),
                    Time::default(),
                    &settings_of(encoding),
                )
                .expect("packed")
                .image
                .expect("image_raw");
            let stride = row_bytes + 24;
            let mut padded_frame = frame(padded(&packed, row_bytes, stride), 1, 0);
            padded_frame.stride = stride;
            let from_padded = output
                .convert(
                    padded_frame,
                    &mode(format),
                    Time::default(),
                    &settings_of(encoding),
                )
                .expect("padded")
                .image
                .expect("image_raw");
            assert_eq!(from_padded, from_packed, "{format} to {encoding:?}");
            // A stride shorter than a row is refused with the numbers.
            let mut short = frame(packed.clone(), 2, 0);
            short.stride = row_bytes - 2;
            let error = output
                .convert(
                    short,
                    &mode(format),
                    Time::default(),
                    &settings_of(encoding),
                )
                .expect_err("short stride");
            assert!(error.contains(&(row_bytes - 2).to_string()), "{error}");
        }
    }
}

#[test]
fn a_frame_the_device_marked_damaged_is_counted_and_not_published() {
    let mut output = FrameOutput::new();
    let mut damaged = frame(yuyv_frame(7), 0, 0);
    damaged.damaged = true;
    let error = output
        .convert(
            damaged,
            &mode(PixelFormat::Yuyv),
            Time::default(),
            &settings(OutputEncoding::Rgb8, MjpegOutput::Raw),
        )
        .expect_err("damaged");
    assert!(error.contains("V4L2_BUF_FLAG_ERROR"), "{error}");
    assert_eq!(output.counts().bad_frames, 1);
    let next = output.convert(
        frame(yuyv_frame(7), 1, 33),
        &mode(PixelFormat::Yuyv),
        Time::default(),
        &settings(OutputEncoding::Rgb8, MjpegOutput::Raw),
    );
    assert!(next.is_ok_and(|m| m.image.is_some()));
    assert_eq!(output.counts().bad_frames, 1);
}

#[test]
fn an_mjpeg_buffer_padded_with_zeros_is_passed_on_without_the_padding() {
    let mut output = FrameOutput::new();
    let whole = jpeg(&rgb_frame(8));
    // More padding than the tail searched for the end marker.
    let mut data = whole.clone();
    data.resize(whole.len() + 3 * 4096, 0);
    let messages = output
        .convert(
            frame(data, 0, 0),
            &mode(PixelFormat::Mjpeg),
            Time::default(),
            &settings(OutputEncoding::Rgb8, MjpegOutput::Both),
        )
        .expect("a whole JPEG");
    assert_eq!(messages.compressed.expect("compressed").data, whole);
    assert!(messages.image.is_some());
}

#[test]
fn yuyv_frames_become_rgb8_and_mono8_images() {
    let mut output = FrameOutput::new();
    let stamp = Time::from_nanos(1_700_000_000_000_000_000);
    let data = yuyv_frame(1);
    let rgb = output
        .convert(
            frame(data.clone(), 0, 10),
            &mode(PixelFormat::Yuyv),
            stamp,
            &settings(OutputEncoding::Rgb8, MjpegOutput::Raw),
        )
        .expect("converted");
    let image = rgb.image.expect("image_raw");
    assert!(rgb.compressed.is_none());
    assert_eq!(
        (
            image.encoding.as_str(),
            image.width,
            image.height,
            image.step
        ),
        ("rgb8", WIDTH, HEIGHT, WIDTH * 3)
    );
    assert_eq!(image.header.stamp, stamp);
    assert_eq!(image.header.frame_id, "left_optical");
    let mut worst = 0.0f64;
    for y in 0..HEIGHT {
        for x in 0..WIDTH {
            let (luma, u, v) = yuv(x, y, 1);
            let expected = reference_rgb(luma, u, v);
            let i = ((y * WIDTH + x) * 3) as usize;
            for (got, want) in image.data[i..i + 3].iter().zip(expected) {
                worst = worst.max((f64::from(*got) - want).abs());
            }
        }
    }
    assert!(worst <= 1.5, "rgb8 off BT.601 by {worst}");

    let mono = output
        .convert(
            frame(data, 1, 43),
            &mode(PixelFormat::Yuyv),
            stamp,
            &settings(OutputEncoding::Mono8, MjpegOutput::Raw),
        )
        .expect("converted")
        .image
        .expect("image_raw");
    let lumas: Vec<u8> = (0..HEIGHT)
        .flat_map(|y| (0..WIDTH).map(move |x| yuv(x, y, 1).0))
        .collect();
    assert_eq!(mono.encoding, "mono8");
    assert_eq!(mono.data, lumas, "mono8 is the luma");
    assert_eq!(output.counts().captured, 2);
    assert_eq!(output.counts().dropped, 0);
}

#[test]
fn mjpeg_pass_through_publishes_the_device_bytes_without_a_copy() {
    let mut output = FrameOutput::new();
    let data = jpeg(&rgb_frame(3));
    let expected = data.clone();
    let pointer = data.as_ptr();
    let messages = output
        .convert(
            frame(data, 7, 100),
            &mode(PixelFormat::Mjpeg),
            Time::from_nanos(5),
            &settings(OutputEncoding::Rgb8, MjpegOutput::Compressed),
        )
        .expect("converted");
    assert!(messages.image.is_none(), "nothing decoded");
    let compressed = messages.compressed.expect("image_raw/compressed");
    assert_eq!(compressed.data, expected);
    assert_eq!(
        compressed.data.as_ptr(),
        pointer,
        "the message holds the frame's own buffer"
    );
    assert_eq!(compressed.format, "rgb8; jpeg compressed bgr8");
    assert_eq!(compressed.header.stamp, Time::from_nanos(5));
}

#[test]
fn mjpeg_frames_decode_into_image_raw_within_the_jpeg_loss() {
    let mut output = FrameOutput::new();
    let rgb = rgb_frame(4);
    let messages = output
        .convert(
            frame(jpeg(&rgb), 0, 0),
            &mode(PixelFormat::Mjpeg),
            Time::from_nanos(5),
            &settings(OutputEncoding::Rgb8, MjpegOutput::Both),
        )
        .expect("converted");
    let image = messages.image.expect("decoded");
    assert!(messages.compressed.is_some());
    assert_eq!(
        (image.encoding.as_str(), image.width, image.height),
        ("rgb8", WIDTH, HEIGHT)
    );
    let mean = image
        .data
        .iter()
        .zip(&rgb)
        .map(|(a, b)| f64::from(a.abs_diff(*b)))
        .sum::<f64>()
        / rgb.len() as f64;
    assert!(mean < 3.0, "mean difference {mean}");
}

#[test]
fn a_truncated_mjpeg_frame_is_reported_and_the_next_one_goes_through() {
    let mut output = FrameOutput::new();
    let whole = jpeg(&rgb_frame(5));
    let truncated = whole[..whole.len() * 2 / 3].to_vec();
    for mjpeg in [MjpegOutput::Raw, MjpegOutput::Compressed] {
        let error = output
            .convert(
                frame(truncated.clone(), 0, 0),
                &mode(PixelFormat::Mjpeg),
                Time::default(),
                &settings(OutputEncoding::Rgb8, mjpeg),
            )
            .expect_err("truncated");
        assert!(error.contains("truncated JPEG"), "{error}");
    }
    let garbage = output
        .convert(
            frame(vec![0x12; 300], 2, 0),
            &mode(PixelFormat::Mjpeg),
            Time::default(),
            &settings(OutputEncoding::Rgb8, MjpegOutput::Raw),
        )
        .expect_err("not a JPEG");
    assert!(garbage.contains("not a JPEG"), "{garbage}");
    let next = output
        .convert(
            frame(whole, 3, 0),
            &mode(PixelFormat::Mjpeg),
            Time::default(),
            &settings(OutputEncoding::Rgb8, MjpegOutput::Raw),
        )
        .expect("the next frame converts");
    assert!(next.image.is_some());
    assert_eq!(output.counts().bad_frames, 3);
    assert_eq!(output.counts().captured, 4);
}

#[test]
fn sequence_gaps_count_as_dropped_frames_and_stamps_follow_buffer_timestamps() {
    let mut output = FrameOutput::new();
    let clock_now = Time::from_nanos(1_800_000_000_000_000_000);
    // Dequeued at monotonic 10 s, after the device stamped them: 0, 1, 2, then 5, 6.
    let dequeued = Duration::from_secs(10);
    let mut stamps = Vec::new();
    for (sequence, timestamp_ms) in [(0, 9_800), (1, 9_833), (2, 9_866), (5, 9_966), (6, 9_999)] {
        let f = frame(vec![100; (WIDTH * HEIGHT) as usize], sequence, timestamp_ms);
        let stamp = ros_stamp(f.timestamp, dequeued, clock_now);
        let image = output
            .convert(
                f,
                &mode(PixelFormat::Grey),
                stamp,
                &settings(OutputEncoding::Rgb8, MjpegOutput::Raw),
            )
            .expect("converted")
            .image
            .expect("image");
        assert_eq!(image.encoding, "mono8", "GREY is mono8");
        stamps.push(image.header.stamp);
    }
    assert_eq!(output.counts().dropped, 2, "frames 3 and 4 were lost");
    let gaps_ms: Vec<f64> = stamps
        .windows(2)
        .map(|w| w[1].seconds_since(&w[0]) * 1e3)
        .collect();
    assert_eq!(gaps_ms, [33.0, 33.0, 100.0, 33.0]);
    assert_eq!(
        clock_now.as_nanos() - stamps[0].as_nanos(),
        200_000_000,
        "the first frame was captured 200 ms before it was dequeued"
    );
    // A reopened device starts its sequence again: no drop.
    output.device_restarted();
    output
        .convert(
            frame(vec![0; (WIDTH * HEIGHT) as usize], 0, 0),
            &mode(PixelFormat::Grey),
            clock_now,
            &settings(OutputEncoding::Rgb8, MjpegOutput::Raw),
        )
        .expect("converted");
    assert_eq!(output.counts().dropped, 2);
    let short = output.convert(
        frame(vec![0; 10], 1, 0),
        &mode(PixelFormat::Grey),
        clock_now,
        &settings(OutputEncoding::Rgb8, MjpegOutput::Raw),
    );
    assert!(short.is_err_and(|e| e.contains("needs 3072 bytes, the frame has 10")));
}

/// A device that plays a script: frames, then an error (unplugged).
struct Scripted {
    frames: VecDeque<Frame>,
    offered: Vec<String>,
    starts: Arc<Mutex<u32>>,
}

impl CameraDevice for Scripted {
    fn name(&self) -> &str {
        "/dev/scripted"
    }

    fn offered_formats(&self) -> Result<Vec<String>, DeviceError> {
        Ok(self.offered.clone())
    }

    fn start(&mut self, mode: &Mode) -> Result<Mode, DeviceError> {
        let code = String::from_utf8_lossy(&mode.format.fourcc()).into_owned();
        if !self.offered.contains(&code) {
            return Err(DeviceError::FormatNotOffered {
                device: self.name().into(),
                asked: mode.format,
                offered: self.offered.clone(),
            });
        }
        *self.starts.lock().expect("lock") += 1;
        Ok(*mode)
    }

    fn controls(&self) -> Result<Vec<Control>, DeviceError> {
        Ok(Vec::new())
    }

    fn set_control(&mut self, _id: u32, _value: i64) -> Result<(), DeviceError> {
        Ok(())
    }

    fn next_frame(&mut self, _timeout: Duration) -> Result<Option<Frame>, DeviceError> {
        self.frames.pop_front().map(Some).ok_or(DeviceError::Lost {
            device: "/dev/scripted".into(),
            reason: "No such device (os error 19)".into(),
        })
    }
}

/// Polls until an event `wanted` accepts, at most 200 polls of 50 ms.
fn poll_until(connection: &mut Connection, wanted: impl Fn(&Event) -> bool) -> Event {
    for _ in 0..200 {
        let event = connection.poll(Duration::from_millis(50));
        if wanted(&event) {
            return event;
        }
    }
    panic!("no such event in 10 s");
}

#[test]
fn a_missing_or_lost_device_is_opened_again_with_back_off() {
    let opens = Arc::new(Mutex::new(0u32));
    let starts = Arc::new(Mutex::new(0u32));
    let opener = {
        let opens = Arc::clone(&opens);
        let starts = Arc::clone(&starts);
        Box::new(move || -> Result<Box<dyn CameraDevice>, DeviceError> {
            let mut n = opens.lock().expect("lock");
            *n += 1;
            if *n <= 2 {
                return Err(DeviceError::Open {
                    device: "/dev/scripted".into(),
                    reason: "No such file or directory (os error 2)".into(),
                });
            }
            Ok(Box::new(Scripted {
                frames: (0..3).map(|i| frame(vec![1; 4], i, u64::from(i))).collect(),
                offered: vec!["YUYV".into()],
                starts: Arc::clone(&starts),
            }))
        })
    };
    let mut connection = Connection::new(opener, mode(PixelFormat::Yuyv), None);
    let Event::Failed(first) = connection.poll(Duration::from_millis(10)) else {
        panic!("the first open fails");
    };
    assert!(first.to_string().contains("No such file"), "{first}");
    match connection.state() {
        DeviceState::Waiting { reason, retry_in_s } => {
            assert!(reason.contains("cannot open /dev/scripted"), "{reason}");
            assert_eq!(*retry_in_s, 0.5);
        }
        other => panic!("{other:?}"),
    }
    poll_until(&mut connection, |e| matches!(e, Event::Failed(_)));
    assert!(
        matches!(connection.state(), DeviceState::Waiting { retry_in_s, .. } if *retry_in_s == 1.0),
        "the back-off doubles: {:?}",
        connection.state()
    );
    poll_until(&mut connection, |e| matches!(e, Event::Started(_)));
    assert!(matches!(connection.state(), DeviceState::Streaming { .. }));
    let mut sequences = Vec::new();
    let lost = loop {
        match connection.poll(Duration::from_millis(50)) {
            Event::Frame(f) => sequences.push(f.sequence),
            Event::Failed(e) => break e,
            other => panic!("{other:?}"),
        }
    };
    assert_eq!(sequences, [0, 1, 2]);
    assert!(
        lost.to_string().contains("stopped delivering frames"),
        "{lost}"
    );
    assert!(
        matches!(connection.state(), DeviceState::Waiting { retry_in_s, .. } if *retry_in_s == 0.5),
        "the back-off starts again after a device that streamed: {:?}",
        connection.state()
    );
    poll_until(&mut connection, |e| matches!(e, Event::Started(_)));
    assert_eq!(*opens.lock().expect("lock"), 4);
    assert_eq!(*starts.lock().expect("lock"), 2);
}

#[test]
fn a_pixel_format_the_device_does_not_offer_says_what_it_offers() {
    let starts = Arc::new(Mutex::new(0u32));
    let device = Scripted {
        frames: VecDeque::new(),
        offered: vec!["YUYV".into(), "MJPG".into()],
        starts,
    };
    let opener = Box::new(|| -> Result<Box<dyn CameraDevice>, DeviceError> {
        Err(DeviceError::Open {
            device: "/dev/scripted".into(),
            reason: "gone".into(),
        })
    });
    let mut connection = Connection::new(opener, mode(PixelFormat::Grey), Some(Box::new(device)));
    let Event::Failed(error) = connection.poll(Duration::from_millis(10)) else {
        panic!("GREY is refused");
    };
    assert_eq!(
        error.to_string(),
        "/dev/scripted does not offer pixel format GREY; it offers YUYV, MJPG"
    );
}

fn calibration(width: u32, height: u32) -> CameraInfo {
    CameraInfo {
        width,
        height,
        distortion_model: "plumb_bob".into(),
        d: vec![-0.2, 0.05, 0.001, -0.001, 0.0],
        k: [500.0, 0.0, 319.5, 0.0, 501.0, 239.5, 0.0, 0.0, 1.0],
        r: [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0],
        p: [
            500.0, 0.0, 319.5, 0.0, 0.0, 501.0, 239.5, 0.0, 0.0, 0.0, 1.0, 0.0,
        ],
        ..CameraInfo::default()
    }
}

#[test]
fn set_camera_info_writes_the_file_atomically_and_publishes_it_next() {
    let dir = tempfile::tempdir().expect("temp dir");
    let url = format!("file://{}/cal/${{NAME}}.yaml", dir.path().display());
    let mut manager = CameraInfoManager::load("left", &url);
    assert!(
        manager
            .problem()
            .is_some_and(|p| p.contains("no calibration at")),
        "{:?}",
        manager.problem()
    );
    let header = Header {
        stamp: Time::from_nanos(42),
        frame_id: "left_optical".into(),
    };
    let (uncalibrated, warning) = manager.camera_info(640, 480, header.clone());
    assert!(warning.is_none());
    assert_eq!((uncalibrated.width, uncalibrated.height), (640, 480));
    assert_eq!(uncalibrated.k, [0.0; 9]);

    let answer = manager.set(calibration(640, 480)).expect("stored");
    let path = dir.path().join("cal/left.yaml");
    assert!(answer.contains(&path.display().to_string()), "{answer}");
    let file = CameraInfoFile::read(&path).expect("the file is on disk");
    assert_eq!(file.camera_name, "left");
    assert_eq!(file.info.k, calibration(640, 480).k);
    let leftovers: Vec<_> = std::fs::read_dir(dir.path().join("cal"))
        .expect("dir")
        .map(|e| e.expect("entry").file_name())
        .collect();
    assert_eq!(leftovers, ["left.yaml"], "no temporary file is left");
    let (published, _) = manager.camera_info(640, 480, header.clone());
    assert_eq!(published.k, calibration(640, 480).k);
    assert_eq!(published.header, header);

    // Read back by the next run; of another size, it is left out with a warning.
    let reloaded = CameraInfoManager::load("left", &url);
    assert!(reloaded.problem().is_none());
    let (other_size, warning) = reloaded.camera_info(1280, 720, header);
    assert_eq!(other_size.k, [0.0; 9]);
    assert!(warning.is_some_and(|w| w.contains("the calibration is for 640x480 images")));
}

#[test]
fn a_camera_info_url_that_cannot_be_written_answers_why() {
    let dir = tempfile::tempdir().expect("temp dir");
    // A file where the URL's directory should be.
    std::fs::write(dir.path().join("blocked"), "not a directory").expect("write");
    let url = format!("file://{}/blocked/left.yaml", dir.path().display());
    let mut manager = CameraInfoManager::load("left", &url);
    let refused = manager.set(calibration(640, 480)).expect_err("unwritable");
    assert!(refused.contains("calibration not stored"), "{refused}");
    assert!(refused.contains("blocked/left.yaml"), "{refused}");
    let (still, _) = manager.camera_info(640, 480, Header::default());
    assert_eq!(still.k, [0.0; 9], "nothing changed");

    let mut unsupported = CameraInfoManager::load("left", "http://calibrations/left.yaml");
    let refused = unsupported.set(calibration(640, 480)).expect_err("http");
    assert!(refused.contains("only file:// URLs"), "{refused}");
    let mut package = CameraInfoManager::load("left", "package://no_such_package/left.yaml");
    let refused = package.set(calibration(640, 480)).expect_err("package");
    assert!(
        refused.contains("\"no_such_package\" is not installed"),
        "{refused}"
    );
    let refused =
        CameraInfoManager::load("left", &format!("file://{}/ok.yaml", dir.path().display()))
            .set(calibration(0, 0))
            .expect_err("no size");
    assert!(refused.contains("no image size"), "{refused}");
}

/// `jpeg` without its Huffman tables (DHT segments), as many UVC cameras send MJPEG:
/// the decoder must use the standard tables of JPEG's Annex K, which the encoder used.
fn without_huffman_tables(jpeg: &[u8]) -> Vec<u8> {
    let mut out = jpeg[..2].to_vec();
    let mut at = 2;
    while at + 4 <= jpeg.len() && jpeg[at] == 0xff && jpeg[at + 1] != 0xda {
        let length = usize::from(u16::from_be_bytes([jpeg[at + 2], jpeg[at + 3]]));
        if jpeg[at + 1] != 0xc4 {
            out.extend_from_slice(&jpeg[at..at + 2 + length]);
        }
        at += 2 + length;
    }
    out.extend_from_slice(&jpeg[at..]);
    out
}

#[test]
fn mjpeg_frames_without_huffman_tables_decode_like_whole_jpegs() {
    let whole = jpeg(&rgb_frame(6));
    let bare = without_huffman_tables(&whole);
    assert!(bare.len() < whole.len(), "the tables were removed");
    assert!(!bare.windows(2).any(|w| w == [0xff, 0xc4]));
    let mut output = FrameOutput::new();
    let mut decode = |data: Vec<u8>| {
        output
            .convert(
                frame(data, 0, 0),
                &mode(PixelFormat::Mjpeg),
                Time::default(),
                &settings(OutputEncoding::Rgb8, MjpegOutput::Raw),
            )
            .expect("decoded")
            .image
            .expect("image_raw")
            .data
    };
    assert_eq!(decode(bare), decode(whole));
}
