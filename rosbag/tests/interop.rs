//! Typed messages through bags, and the Rust half of the rosbags interop check.
//!
//! `interop/check_bag_interop.py` runs the two ignored tests: one writes the sample bag
//! into `$STEREOCAL_BAG_INTEROP_OUT` for the Python `rosbags` and `mcap` libraries to
//! check, the other reads the bag `rosbags` wrote at `$STEREOCAL_BAG_INTEROP_IN` and
//! checks it holds the same sample. Both sides build the sample from the same formulas.

use std::path::Path;

use stereocal_msgs::RosMessage;
use stereocal_msgs::builtin_interfaces::Time;
use stereocal_msgs::geometry_msgs::{Point, Pose, PoseStamped, Quaternion};
use stereocal_msgs::sensor_msgs::Image;
use stereocal_msgs::std_msgs::Header;
use stereocal_rosbag::{BagReader, BagWriter, OfferedQos, TopicFilter};

const IMAGE_TOPIC: &str = "/left/image_raw";
const POSE_TOPIC: &str = "/target_pose";
const FRAMES: u32 = 5;

fn stamp(i: u32) -> Time {
    Time {
        sec: 100 + i as i32,
        nanosec: 1000 * i,
    }
}

fn log_time(i: u32) -> u64 {
    u64::from(100 + i) * 1_000_000_000 + u64::from(1000 * i)
}

fn image(i: u32) -> Image {
    Image {
        header: Header {
            stamp: stamp(i),
            frame_id: "left_camera_optical".into(),
        },
        height: 3,
        width: 4,
        encoding: "mono8".into(),
        is_bigendian: 0,
        step: 4,
        data: (0..12).map(|k| (i * 16 + k) as u8).collect(),
    }
}

fn pose(i: u32) -> PoseStamped {
    PoseStamped {
        header: Header {
            stamp: stamp(i),
            frame_id: "base".into(),
        },
        pose: Pose {
            position: Point {
                x: f64::from(i),
                y: 2.0 * f64::from(i),
                z: -0.5,
            },
            orientation: Quaternion {
                x: 0.0,
                y: 0.0,
                z: 0.0,
                w: 1.0,
            },
        },
    }
}

fn write_sample(path: &Path) {
    let mut writer = BagWriter::create(path).expect("create");
    let images = writer
        .add_message_topic::<Image>(IMAGE_TOPIC, &OfferedQos::default())
        .expect("topic");
    let poses = writer
        .add_message_topic::<PoseStamped>(POSE_TOPIC, &OfferedQos::latched())
        .expect("topic");
    for i in 0..FRAMES {
        writer
            .write_message(images, log_time(i), &image(i))
            .expect("write");
        writer
            .write_message(poses, log_time(i) + 500, &pose(i))
            .expect("write");
    }
    writer.finish().expect("finish");
}

fn check_sample(path: &Path) {
    let reader = BagReader::open(path).expect("open");
    let topics: Vec<(&str, &str, u64)> = reader
        .topics()
        .iter()
        .map(|t| (t.name.as_str(), t.type_name.as_str(), t.message_count))
        .collect();
    assert_eq!(
        topics,
        [
            (IMAGE_TOPIC, Image::TYPE_NAME, u64::from(FRAMES)),
            (POSE_TOPIC, PoseStamped::TYPE_NAME, u64::from(FRAMES)),
        ]
    );
    let messages: Vec<_> = reader
        .messages(&TopicFilter::All)
        .collect::<Result<_, _>>()
        .expect("read");
    assert_eq!(messages.len(), 2 * FRAMES as usize);
    for (i, pair) in (0..FRAMES).zip(messages.chunks(2)) {
        assert_eq!(pair[0].log_time_ns, log_time(i));
        assert_eq!(pair[0].decode::<Image>().expect("image"), image(i));
        assert_eq!(pair[1].log_time_ns, log_time(i) + 500);
        assert_eq!(pair[1].decode::<PoseStamped>().expect("pose"), pose(i));
        assert!(pair[1].decode::<Image>().is_err(), "type is checked");
    }
}

#[test]
fn typed_messages_round_trip() {
    let dir = tempfile::tempdir().expect("tempdir");
    let path = dir.path().join("typed");
    write_sample(&path);
    check_sample(&path);
    let reader = BagReader::open(&path).expect("open");
    let image_topic = reader.topic(IMAGE_TOPIC).expect("topic");
    assert_eq!(image_topic.schema_text, Image::schema_text());
}

#[test]
#[ignore = "run by interop/check_bag_interop.py"]
fn write_bag_for_rosbags() {
    let Some(out) = std::env::var_os("STEREOCAL_BAG_INTEROP_OUT") else {
        eprintln!("skipped: STEREOCAL_BAG_INTEROP_OUT names no bag to write");
        return;
    };
    write_sample(Path::new(&out));
}

#[test]
#[ignore = "run by interop/check_bag_interop.py"]
fn read_bag_written_by_rosbags() {
    let Some(bag) = std::env::var_os("STEREOCAL_BAG_INTEROP_IN") else {
        eprintln!("skipped: STEREOCAL_BAG_INTEROP_IN names no bag to read");
        return;
    };
    check_sample(Path::new(&bag));
}
