//! Compressed images (sensor_msgs/CompressedImage on image_transport's
//! `<topic>/compressed`) wherever raw ones go: a rendered session's images recompressed
//! as PNG calibrate exactly as the raw bag does and rectify into the same bytes; as
//! JPEG (quality 95) they calibrate within the JPEG loss of the raw result and of the
//! truth.

use std::path::Path;

use image::codecs::jpeg::JpegEncoder;
use image::codecs::png::PngEncoder;
use image::{ExtendedColorType, ImageEncoder};
use indicatif::ProgressBar;
use stereocal::cli::calibrate::{CalibrateArgs, calibrate_bag};
use stereocal::cli::rectify::{BagRectifyOptions, rectify_bag};
use stereocal::cli::synth::{SceneArg, SynthArgs};
use stereocal::convert::Codec;
use stereocal_msgs::RosMessage;
use stereocal_msgs::cdr;
use stereocal_msgs::sensor_msgs::{CompressedImage, Image};
use stereocal_rosbag::{BagReader, BagWriter, OfferedQos, TopicFilter, WriterOptions};

use crate::common;

/// Writes `input` to `output` with every image topic replaced by `<topic>/compressed`
/// in `codec` (JPEG at quality 95), every other topic copied.
fn compress_bag(input: &Path, output: &Path, codec: Codec) {
    let reader = BagReader::open(input).unwrap();
    let mut writer = BagWriter::create_with(
        output,
        WriterOptions {
            overwrite: true,
            ..WriterOptions::default()
        },
    )
    .unwrap();
    let mut ids = std::collections::BTreeMap::new();
    for topic in reader.topics() {
        let qos = OfferedQos::from_rosbag2_yaml(&topic.offered_qos_profiles)
            .into_iter()
            .next()
            .unwrap_or_default();
        let id = if topic.type_name == Image::TYPE_NAME {
            writer
                .add_topic_with_qos(
                    &format!("{}/compressed", topic.name),
                    CompressedImage::TYPE_NAME,
                    &CompressedImage::schema_text(),
                    &qos,
                )
                .unwrap()
        } else {
            writer
                .add_topic_with_qos(&topic.name, &topic.type_name, &topic.schema_text, &qos)
                .unwrap()
        };
        ids.insert(topic.name.clone(), id);
    }
    for message in reader.messages(&TopicFilter::All) {
        let message = message.unwrap();
        let id = ids[&*message.topic];
        if &*message.type_name != Image::TYPE_NAME {
            writer
                .write_timed(
                    id,
                    message.log_time_ns,
                    message.publish_time_ns,
                    &message.data,
                )
                .unwrap();
            continue;
        }
        let image: Image = cdr::from_bytes(&message.data).unwrap();
        let (color, channels) = match image.encoding.as_str() {
            "mono8" => (ExtendedColorType::L8, 1),
            "rgb8" => (ExtendedColorType::Rgb8, 3),
            other => panic!("no test encoding for {other}"),
        };
        let pixels: Vec<u8> = image
            .data
            .chunks(image.step as usize)
            .flat_map(|row| &row[..image.width as usize * channels])
            .copied()
            .collect();
        let mut data = Vec::new();
        let format = match codec {
            Codec::Jpeg => {
                JpegEncoder::new_with_quality(&mut data, 95)
                    .write_image(&pixels, image.width, image.height, color)
                    .unwrap();
                format!("{0}; jpeg compressed {0}", image.encoding)
            }
            Codec::Png => {
                PngEncoder::new(&mut data)
                    .write_image(&pixels, image.width, image.height, color)
                    .unwrap();
                format!("{}; png compressed", image.encoding)
            }
        };
        let compressed = CompressedImage {
            header: image.header,
            format,
            data,
        };
        writer
            .write_message(id, message.log_time_ns, &compressed)
            .unwrap();
    }
    writer.finish().unwrap();
}

fn calibrate(
    bag: &Path,
    out: &Path,
    truth: &stereocal_vision::synth::GroundTruth,
    suffix: &str,
) -> stereocal::cli::calibrate::CalibrateReport {
    let board = &truth.board;
    let args = CalibrateArgs {
        left: Some(format!("/stereo/left/image_raw{suffix}")),
        right: Some(format!("/stereo/right/image_raw{suffix}")),
        ..CalibrateArgs::chessboard(
            bag.to_path_buf(),
            out.to_path_buf(),
            board.cols,
            board.rows,
            board.square_size,
        )
    };
    calibrate_bag(&args, &ProgressBar::hidden()).unwrap()
}

#[test]
fn calibrate_reads_png_exactly_and_jpeg_within_its_loss() {
    let dir = tempfile::tempdir().unwrap();
    let truth = common::synthesize_session(&common::calibration_scene(dir.path(), 5, 20), None);
    let raw = calibrate(&dir.path().join("bag"), &dir.path().join("raw"), &truth, "");

    let png = dir.path().join("png");
    compress_bag(&dir.path().join("bag"), &png, Codec::Png);
    let from_png = calibrate(&png, &dir.path().join("from_png"), &truth, "/compressed");
    for (a, b) in raw.outcome.cameras.iter().zip(&from_png.outcome.cameras) {
        assert_eq!(a.info.k, b.info.k, "{}", a.name);
        assert_eq!(a.info.d, b.info.d, "{}", a.name);
    }

    let jpeg = dir.path().join("jpeg");
    compress_bag(&dir.path().join("bag"), &jpeg, Codec::Jpeg);
    let from_jpeg = calibrate(&jpeg, &dir.path().join("from_jpeg"), &truth, "/compressed");
    common::assert_intrinsics_near_truth(&from_jpeg.outcome.cameras, &truth);
    for (a, b) in raw.outcome.cameras.iter().zip(&from_jpeg.outcome.cameras) {
        let largest = a
            .info
            .k
            .iter()
            .zip(&b.info.k)
            .map(|(x, y)| (x - y).abs())
            .fold(0.0, f64::max);
        println!("{}: JPEG 95 moves K by at most {largest:.4} px", a.name);
        assert!(largest < 0.1, "{}: K moved by {largest} px", a.name);
    }
}

/// The `image_rect` messages of a rectified bag, in order.
fn rectified(bag: &Path, topic: &str) -> Vec<Image> {
    let reader = BagReader::open(bag).unwrap();
    reader
        .messages(&TopicFilter::only([topic]))
        .map(|m| cdr::from_bytes(&m.unwrap().data).unwrap())
        .collect()
}

#[test]
fn rectify_turns_compressed_topics_into_the_same_raw_image_rect() {
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("scene");
    common::synthesize_session(&SynthArgs::new(SceneArg::Stereo, scene.clone(), 3, 3), None);
    let png = dir.path().join("png");
    compress_bag(&scene.join("bag"), &png, Codec::Png);
    let options = BagRectifyOptions::default();
    rectify_bag(
        &scene.join("bag"),
        &dir.path().join("raw_rect"),
        &options,
        &ProgressBar::hidden(),
    )
    .unwrap();
    let report = rectify_bag(
        &png,
        &dir.path().join("png_rect"),
        &options,
        &ProgressBar::hidden(),
    )
    .unwrap();
    let topics: Vec<&str> = report
        .topics
        .iter()
        .map(|t| t.image_topic.as_str())
        .collect();
    assert_eq!(
        topics,
        [
            "/stereo/left/image_raw/compressed",
            "/stereo/right/image_raw/compressed"
        ]
    );
    for side in ["left", "right"] {
        let topic = format!("/stereo/{side}/image_rect");
        let from_raw = rectified(&dir.path().join("raw_rect"), &topic);
        let from_png = rectified(&dir.path().join("png_rect"), &topic);
        assert_eq!(from_raw.len(), 3);
        assert_eq!(from_raw, from_png, "{topic}");
    }
}
