//! `stereocal rectify` on small bags written here: every good frame gets an image_rect
//! equal to the Rectifier's output for the camera_info of its stamp, every input message
//! is copied, bad messages are reported and skipped, and the output is atomic.

use std::collections::BTreeMap;
use std::path::Path;
use std::process::Command;

use indicatif::ProgressBar;
use nalgebra::{Matrix3x4, Rotation3};
use stereocal::cli::rectify::{BagRectifyOptions, rectify_bag};
use stereocal::convert::{CalibratedCamera, info_from_calibrated};
use stereocal::rectify::stage::{Rectified, Rectifier};
use stereocal_msgs::RosMessage;
use stereocal_msgs::builtin_interfaces::Time;
use stereocal_msgs::camera_info_file::CameraInfoFile;
use stereocal_msgs::cdr;
use stereocal_msgs::sensor_msgs::{CameraInfo, Image as ImageMsg};
use stereocal_msgs::std_msgs::Header;
use stereocal_rosbag::{BagReader, BagWriter, TopicFilter, TopicId};
use stereocal_vision::camera::{CameraModel, Distortion, Intrinsics};
use stereocal_vision::rectify::{Interpolation, RemapOptions};

const WIDTH: u32 = 80;
const HEIGHT: u32 = 60;
const FRAMES: i32 = 6;
const BASE_NS: u64 = 1_700_000_000_000_000_000;

fn stamp(frame: i32) -> Time {
    Time {
        sec: 1_700_000_000 + frame,
        nanosec: 0,
    }
}

fn log_time(frame: i32, offset_ns: u64) -> u64 {
    BASE_NS + frame as u64 * 1_000_000_000 + offset_ns
}

/// A distorted camera, stereo-rectified with a principal point that moves with
/// `variant` so that different camera_infos give different pixels.
fn info(frame_id: &str, frame: i32, variant: f64) -> CameraInfo {
    let camera = CalibratedCamera {
        model: CameraModel {
            width: WIDTH,
            height: HEIGHT,
            intrinsics: Intrinsics {
                fx: 70.0,
                fy: 70.5,
                cx: 39.5,
                cy: 29.5,
            },
            distortion: Distortion::PlumbBob {
                coeffs: [-0.3, 0.09, 0.001, 0.0005, 0.0],
            },
        },
        rectified_from_camera: *Rotation3::from_euler_angles(0.0, 0.02, -0.01).matrix(),
        projection: Matrix3x4::new(
            65.0,
            0.0,
            38.0 + variant,
            -6.5,
            0.0,
            65.0,
            30.0,
            0.0,
            0.0,
            0.0,
            1.0,
            0.0,
        ),
    };
    info_from_calibrated(
        &camera,
        Header {
            stamp: stamp(frame),
            frame_id: frame_id.to_owned(),
        },
    )
}

/// A moving checkerboard with a gradient, `channels` of 8 bits.
fn image(frame_id: &str, frame: i32, encoding: &str, channels: u32) -> ImageMsg {
    let mut data = Vec::with_capacity((WIDTH * HEIGHT * channels) as usize);
    for y in 0..HEIGHT {
        for x in 0..WIDTH {
            let check = if ((x + frame as u32) / 10 + y / 10).is_multiple_of(2) {
                210
            } else {
                25
            };
            for c in 0..channels {
                data.push(((check + x + y + 40 * c) % 256) as u8);
            }
        }
    }
    ImageMsg {
        header: Header {
            stamp: stamp(frame),
            frame_id: frame_id.to_owned(),
        },
        height: HEIGHT,
        width: WIDTH,
        encoding: encoding.to_owned(),
        is_bigendian: 0,
        step: WIDTH * channels,
        data,
    }
}

struct Topics {
    left_image: TopicId,
    left_info: TopicId,
    right_image: TopicId,
    right_info: TopicId,
}

fn add_topics(writer: &mut BagWriter) -> Topics {
    let image = |w: &mut BagWriter, name| {
        w.add_topic(name, ImageMsg::TYPE_NAME, &ImageMsg::schema_text())
            .unwrap()
    };
    let info = |w: &mut BagWriter, name| {
        w.add_topic(name, CameraInfo::TYPE_NAME, &CameraInfo::schema_text())
            .unwrap()
    };
    Topics {
        left_image: image(writer, "/left/image_raw"),
        left_info: info(writer, "/left/camera_info"),
        right_image: image(writer, "/right/image_raw"),
        right_info: info(writer, "/right/camera_info"),
    }
}

/// What the bag holds, to check the output against.
struct Sample {
    /// (image, the camera_info with its stamp) per good frame, by image topic.
    frames: BTreeMap<&'static str, Vec<(ImageMsg, CameraInfo)>>,
}

/// A stereo bag: left mono8 with camera_info logged before each image and one truncated
/// image; right rgb8 with camera_info logged after each image and changing every frame,
/// so that only pairing by stamp gives each frame its own camera_info.
fn write_stereo_bag(path: &Path) -> Sample {
    let mut writer = BagWriter::create(path).unwrap();
    let topics = add_topics(&mut writer);
    let mut frames: BTreeMap<&'static str, Vec<(ImageMsg, CameraInfo)>> = BTreeMap::new();
    for frame in 0..FRAMES {
        let left_info = info("left", frame, 0.0);
        let left = image("left", frame, "mono8", 1);
        writer
            .write(
                topics.left_info,
                log_time(frame, 0),
                &cdr::to_bytes(&left_info).unwrap(),
            )
            .unwrap();
        if frame == 2 {
            let mut bad = left.clone();
            bad.data.truncate(100);
            writer
                .write(
                    topics.left_image,
                    log_time(frame, 1_000),
                    &cdr::to_bytes(&bad).unwrap(),
                )
                .unwrap();
        } else {
            writer
                .write(
                    topics.left_image,
                    log_time(frame, 1_000),
                    &cdr::to_bytes(&left).unwrap(),
                )
                .unwrap();
            frames
                .entry("/left/image_raw")
                .or_default()
                .push((left, left_info));
        }

        let right_info = info("right", frame, frame as f64 * 0.5);
        let right = image("right", frame, "rgb8", 3);
        writer
            .write(
                topics.right_image,
                log_time(frame, 2_000),
                &cdr::to_bytes(&right).unwrap(),
            )
            .unwrap();
        writer
            .write(
                topics.right_info,
                log_time(frame, 3_000),
                &cdr::to_bytes(&right_info).unwrap(),
            )
            .unwrap();
        frames
            .entry("/right/image_raw")
            .or_default()
            .push((right, right_info));
    }
    writer.finish().unwrap();
    Sample { frames }
}

fn read_all(path: &Path) -> Vec<(String, u64, Vec<u8>)> {
    let reader = BagReader::open(path).unwrap();
    reader
        .messages(&TopicFilter::All)
        .map(|m| {
            let m = m.unwrap();
            (m.topic.to_string(), m.log_time_ns, m.data)
        })
        .collect()
}

#[test]
fn every_good_frame_is_rectified_with_the_camera_info_of_its_stamp() {
    let dir = tempfile::tempdir().unwrap();
    let input = dir.path().join("stereo");
    let output = dir.path().join("stereo_rect");
    let sample = write_stereo_bag(&input);
    let options = BagRectifyOptions {
        remap: RemapOptions {
            interpolation: Interpolation::Bicubic,
            ..RemapOptions::default()
        },
        ..BagRectifyOptions::default()
    };
    let report = rectify_bag(&input, &output, &options, &ProgressBar::hidden()).unwrap();

    assert_eq!(report.output, output);
    assert_eq!(report.damage, None);
    assert_eq!(report.problem_count, 1);
    assert_eq!(report.problems[0].topic, "/left/image_raw");
    assert_eq!(report.problems[0].log_time_ns, log_time(2, 1_000));
    assert!(
        report.problems[0].reason.contains("data"),
        "{}",
        report.problems[0].reason
    );
    let per_topic: Vec<_> = report
        .topics
        .iter()
        .map(|t| {
            (
                t.image_topic.as_str(),
                t.rect_topic.as_str(),
                t.frames,
                t.rectified,
                t.map_builds,
            )
        })
        .collect();
    assert_eq!(
        per_topic,
        [
            ("/left/image_raw", "/left/image_rect", 6, 5, 1),
            ("/right/image_raw", "/right/image_rect", 6, 6, 6),
        ]
    );

    let input_messages = read_all(&input);
    let output_messages = read_all(&output);
    // Every input message is copied unchanged.
    let copies: Vec<_> = output_messages
        .iter()
        .filter(|(topic, _, _)| !topic.ends_with("/image_rect"))
        .cloned()
        .collect();
    assert_eq!(copies, input_messages);
    assert_eq!(report.copied, input_messages.len() as u64);

    for (topic, frames) in &sample.frames {
        let rect_topic = topic.replace("image_raw", "image_rect");
        let rects: Vec<ImageMsg> = output_messages
            .iter()
            .filter(|(t, _, _)| *t == rect_topic)
            .map(|(_, _, data)| cdr::from_bytes(data).unwrap())
            .collect();
        assert_eq!(rects.len(), frames.len(), "{rect_topic}");
        for (rect, (image, info)) in rects.iter().zip(frames) {
            let mut rectifier = Rectifier::new(options.remap);
            let Ok(Rectified::Image(expected)) = rectifier.rectify(image, info) else {
                panic!("the sample frames are valid");
            };
            assert_eq!(rect, &expected, "{rect_topic} at {:?}", image.header.stamp);
        }
    }
    let reader = BagReader::open(&output).unwrap();
    assert_eq!(
        reader.topic("/right/image_rect").unwrap().type_name,
        ImageMsg::TYPE_NAME
    );
}

#[test]
fn uncalibrated_camera_info_writes_no_image_rect_and_warns_once() {
    let dir = tempfile::tempdir().unwrap();
    let input = dir.path().join("uncalibrated.mcap");
    let output = dir.path().join("out.mcap");
    let mut writer = BagWriter::create(&input).unwrap();
    let topics = add_topics(&mut writer);
    for frame in 0..4 {
        let mut uncalibrated = info("left", frame, 0.0);
        uncalibrated.k = [0.0; 9];
        writer
            .write(
                topics.left_info,
                log_time(frame, 0),
                &cdr::to_bytes(&uncalibrated).unwrap(),
            )
            .unwrap();
        let left = image("left", frame, "mono8", 1);
        writer
            .write(
                topics.left_image,
                log_time(frame, 1),
                &cdr::to_bytes(&left).unwrap(),
            )
            .unwrap();
    }
    writer.finish().unwrap();

    let report = rectify_bag(
        &input,
        &output,
        &BagRectifyOptions::default(),
        &ProgressBar::hidden(),
    )
    .unwrap();
    let left = &report.topics[0];
    assert_eq!(left.image_topic, "/left/image_raw");
    assert_eq!((left.frames, left.rectified), (4, 0));
    assert_eq!(report.problem_count, 1);
    assert!(report.problems[0].reason.contains("uncalibrated"));
    let topics: Vec<String> = read_all(&output).into_iter().map(|(t, _, _)| t).collect();
    assert_eq!(topics.len(), 8);
    assert!(!topics.iter().any(|t| t.ends_with("image_rect")));
}

#[test]
fn the_command_uses_a_camera_info_file_for_a_topic_without_camera_info() {
    let dir = tempfile::tempdir().unwrap();
    let input = dir.path().join("mono.mcap");
    let output = dir.path().join("mono_rect");
    let yaml = dir.path().join("cam.yaml");
    let calibration = info("cam", 0, 1.0);
    CameraInfoFile {
        camera_name: "cam".to_owned(),
        info: calibration.clone(),
    }
    .write(&yaml)
    .unwrap();
    let mut writer = BagWriter::create(&input).unwrap();
    let topic = writer
        .add_topic(
            "/cam/image_mono",
            ImageMsg::TYPE_NAME,
            &ImageMsg::schema_text(),
        )
        .unwrap();
    let images: Vec<_> = (0..3).map(|f| image("cam", f, "bgr8", 3)).collect();
    for (frame, msg) in images.iter().enumerate() {
        writer
            .write(
                topic,
                log_time(frame as i32, 0),
                &cdr::to_bytes(msg).unwrap(),
            )
            .unwrap();
    }
    writer.finish().unwrap();

    let run = Command::new(env!("CARGO_BIN_EXE_stereocal"))
        .arg("rectify")
        .arg("--bag")
        .arg(&input)
        .arg("--out")
        .arg(&output)
        .arg("--camera-info")
        .arg(format!("/cam/image_mono={}", yaml.display()))
        .args(["--interpolation", "0"])
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert!(run.status.success(), "{stderr}");
    assert!(stderr.contains("frames/s"), "{stderr}");
    assert!(
        stderr.contains("/cam/image_mono -> /cam/image_rect: 3/3"),
        "{stderr}"
    );

    let nearest = RemapOptions {
        interpolation: Interpolation::Nearest,
        ..RemapOptions::default()
    };
    let mut rectifier = Rectifier::new(nearest);
    let rects: Vec<ImageMsg> = read_all(&output)
        .into_iter()
        .filter(|(t, _, _)| t == "/cam/image_rect")
        .map(|(_, _, data)| cdr::from_bytes(&data).unwrap())
        .collect();
    assert_eq!(rects.len(), 3);
    for (rect, image) in rects.iter().zip(&images) {
        let Ok(Rectified::Image(expected)) = rectifier.rectify(image, &calibration) else {
            panic!("the calibration is valid");
        };
        assert_eq!(rect, &expected);
    }
}

#[test]
fn a_failed_run_leaves_no_output() {
    let dir = tempfile::tempdir().unwrap();
    let input = dir.path().join("stereo");
    let output = dir.path().join("out");
    write_stereo_bag(&input);
    let yaml = dir.path().join("cam.yaml");
    CameraInfoFile {
        camera_name: "cam".to_owned(),
        info: info("cam", 0, 0.0),
    }
    .write(&yaml)
    .unwrap();
    let run = Command::new(env!("CARGO_BIN_EXE_stereocal"))
        .arg("rectify")
        .arg("--bag")
        .arg(&input)
        .arg("--out")
        .arg(&output)
        .arg("--camera-info")
        .arg(format!("/nowhere/image_raw={}", yaml.display()))
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert!(!run.status.success());
    assert!(stderr.contains("/nowhere/image_raw"), "{stderr}");
    assert!(!output.exists());
    assert_eq!(
        std::fs::read_dir(dir.path()).unwrap().count(),
        2,
        "no staging left behind"
    );

    let bad_yaml = dir.path().join("bad.yaml");
    std::fs::write(&bad_yaml, "image_width: [").unwrap();
    let run = Command::new(env!("CARGO_BIN_EXE_stereocal"))
        .arg("rectify")
        .arg("--bag")
        .arg(&input)
        .arg("--out")
        .arg(&output)
        .arg("--camera-info")
        .arg(format!("/left/image_raw={}", bad_yaml.display()))
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert!(!run.status.success());
    assert!(stderr.contains("bad.yaml"), "{stderr}");
    assert!(!output.exists());
}
