//! Bags written by `BagWriter` read back by `BagReader`: topics, counts, filtering,
//! log-time order across interleaved topics and chunks, directories, bare files, split
//! bags, metadata.yaml, and atomic creation.

use std::collections::BTreeMap;
use std::path::Path;

use stereocal_rosbag::{
    BagMessage, BagReader, BagWriter, ChunkCompression, OfferedQos, TopicFilter, WriterOptions,
};

const IMAGE_SCHEMA: &str = "std_msgs/Header header\nuint32 height\nuint32 width\n";
const POSE_SCHEMA: &str = "geometry_msgs/Pose pose\n";

/// A recorded message: topic, log time, payload.
type Expected = (String, u64, Vec<u8>);

/// Writes three topics with interleaved, partly out-of-order log times (the pose topic
/// arrives up to 7 ms late), in small chunks so the bag spans many of them.
fn write_sample(path: &Path, options: WriterOptions) -> Vec<Expected> {
    let mut writer = BagWriter::create_with(path, options).expect("create");
    let left = writer
        .add_topic("/left/image_raw", "sensor_msgs/msg/Image", IMAGE_SCHEMA)
        .expect("topic");
    let right = writer
        .add_topic("/right/image_raw", "sensor_msgs/msg/Image", IMAGE_SCHEMA)
        .expect("topic");
    let pose = writer
        .add_topic_with_qos(
            "/pose",
            "geometry_msgs/msg/PoseStamped",
            POSE_SCHEMA,
            &OfferedQos::latched(),
        )
        .expect("topic");
    let base = 1_700_000_000_000_000_000u64;
    let mut expected = Vec::new();
    for i in 0..120u64 {
        let t = base + i * 10_000_000;
        for (topic, name, time, size) in [
            (left, "/left/image_raw", t, 700),
            (right, "/right/image_raw", t + 1_000, 500),
            (pose, "/pose", t - (i % 3) * 3_500_000, 40),
        ] {
            let payload: Vec<u8> = (0..size).map(|k| (k as u64 * 31 + i * 7) as u8).collect();
            let mut data = format!("{name}#{i}:").into_bytes();
            data.extend(payload);
            writer.write(topic, time, &data).expect("write");
            expected.push((name.to_owned(), time, data));
        }
    }
    writer.finish().expect("finish");
    expected.sort_by_key(|(_, t, _)| *t);
    expected
}

fn small_chunks() -> WriterOptions {
    WriterOptions {
        chunk_size: 4 * 1024,
        ..WriterOptions::default()
    }
}

fn read_all(reader: &BagReader, filter: &TopicFilter) -> Vec<BagMessage> {
    reader
        .messages(filter)
        .collect::<Result<Vec<_>, _>>()
        .expect("undamaged bag reads without error")
}

fn as_expected(messages: &[BagMessage]) -> Vec<Expected> {
    messages
        .iter()
        .map(|m| (m.topic.to_string(), m.log_time_ns, m.data.clone()))
        .collect()
}

/// Sorting by time alone leaves equal times in write order; the reader breaks ties by
/// file order, which for one topic per time is the same thing.
fn assert_same(read: &[BagMessage], expected: &[Expected]) {
    assert_eq!(read.len(), expected.len());
    assert!(
        read.windows(2)
            .all(|w| w[0].log_time_ns <= w[1].log_time_ns),
        "log-time order"
    );
    assert_eq!(as_expected(read), expected);
}

#[test]
fn directory_bag_round_trips_in_log_time_order() {
    let dir = tempfile::tempdir().expect("tempdir");
    let path = dir.path().join("session");
    let expected = write_sample(&path, small_chunks());

    let reader = BagReader::open(&path).expect("open");
    let names: Vec<&str> = reader.topics().iter().map(|t| t.name.as_str()).collect();
    assert_eq!(names, ["/left/image_raw", "/pose", "/right/image_raw"]);
    let pose = reader.topic("/pose").expect("pose topic");
    assert_eq!(pose.type_name, "geometry_msgs/msg/PoseStamped");
    assert_eq!(pose.message_count, 120);
    assert_eq!(pose.message_encoding, "cdr");
    assert_eq!(pose.schema_encoding, "ros2msg");
    assert_eq!(pose.schema_text, POSE_SCHEMA);
    assert_eq!(
        pose.offered_qos_profiles,
        OfferedQos::latched().to_rosbag2_yaml()
    );
    assert_eq!(reader.message_count(), 360);
    assert_eq!(reader.damage().count(), 0);

    let all = read_all(&reader, &TopicFilter::All);
    assert_same(&all, &expected);
    assert!(all.iter().all(|m| m.publish_time_ns == m.log_time_ns));
    let pose_sequences: Vec<u32> = all
        .iter()
        .filter(|m| &*m.topic == "/pose")
        .map(|m| m.sequence)
        .collect();
    let mut sorted = pose_sequences.clone();
    sorted.sort_unstable();
    assert_eq!(sorted, (0..120).collect::<Vec<u32>>());
}

#[test]
fn topic_filter_keeps_only_the_named_topics_in_order() {
    let dir = tempfile::tempdir().expect("tempdir");
    let path = dir.path().join("session");
    let expected = write_sample(&path, small_chunks());
    let reader = BagReader::open(&path).expect("open");

    let filter = TopicFilter::only(["/pose", "/right/image_raw"]);
    let read = read_all(&reader, &filter);
    let wanted: Vec<Expected> = expected
        .into_iter()
        .filter(|(t, _, _)| t != "/left/image_raw")
        .collect();
    assert_same(&read, &wanted);
    assert!(read.iter().all(
        |m| m.type_name.as_ref() != "sensor_msgs/msg/Image" || &*m.topic == "/right/image_raw"
    ));

    let none = read_all(&reader, &TopicFilter::only(["/not/recorded"]));
    assert!(none.is_empty());
}

#[test]
fn bare_mcap_file_round_trips_uncompressed_and_zstd() {
    for compression in [ChunkCompression::Zstd, ChunkCompression::None] {
        let dir = tempfile::tempdir().expect("tempdir");
        let path = dir.path().join("capture.mcap");
        let options = WriterOptions {
            compression,
            ..small_chunks()
        };
        let expected = write_sample(&path, options);
        assert!(path.is_file());
        assert!(!dir.path().join("metadata.yaml").exists());
        let reader = BagReader::open(&path).expect("open");
        assert_same(&read_all(&reader, &TopicFilter::All), &expected);
    }
}

#[test]
fn chunks_compressed_by_zstd_workers_read_back_and_do_not_depend_on_their_number() {
    let mut files = Vec::new();
    for threads in [1, 3] {
        let dir = tempfile::tempdir().expect("tempdir");
        let path = dir.path().join("capture.mcap");
        let options = WriterOptions {
            zstd_level: 1,
            compression_threads: threads,
            ..small_chunks()
        };
        let expected = write_sample(&path, options);
        let reader = BagReader::open(&path).expect("open");
        assert_same(&read_all(&reader, &TopicFilter::All), &expected);
        files.push(std::fs::read(&path).expect("read"));
    }
    assert!(
        files[0] == files[1],
        "one worker and three wrote different bytes"
    );
}

#[test]
fn metadata_yaml_lists_files_topics_and_counts() {
    let dir = tempfile::tempdir().expect("tempdir");
    let path = dir.path().join("session");
    let expected = write_sample(&path, small_chunks());
    let text = std::fs::read_to_string(path.join("metadata.yaml")).expect("metadata.yaml");
    let yaml: serde_yaml::Value = serde_yaml::from_str(&text).expect("valid YAML");
    let info = &yaml["rosbag2_bagfile_information"];
    assert_eq!(info["version"].as_u64(), Some(8));
    assert_eq!(info["storage_identifier"].as_str(), Some("mcap"));
    assert_eq!(info["message_count"].as_u64(), Some(360));
    let first = expected.first().expect("messages").1;
    let last = expected.last().expect("messages").1;
    assert_eq!(
        info["starting_time"]["nanoseconds_since_epoch"].as_u64(),
        Some(first)
    );
    assert_eq!(info["duration"]["nanoseconds"].as_u64(), Some(last - first));
    assert_eq!(
        info["relative_file_paths"][0].as_str(),
        Some("session_0.mcap")
    );
    assert_eq!(info["files"][0]["path"].as_str(), Some("session_0.mcap"));
    assert_eq!(info["files"][0]["message_count"].as_u64(), Some(360));
    let counts: BTreeMap<String, u64> = info["topics_with_message_count"]
        .as_sequence()
        .expect("topic list")
        .iter()
        .map(|t| {
            let meta = &t["topic_metadata"];
            assert_eq!(meta["serialization_format"].as_str(), Some("cdr"));
            assert!(
                meta["offered_qos_profiles"]
                    .as_str()
                    .is_some_and(|q| q.contains("reliability"))
            );
            assert_eq!(meta["type_description_hash"].as_str(), Some(""));
            (
                meta["name"].as_str().unwrap_or_default().to_owned(),
                t["message_count"].as_u64().unwrap_or(0),
            )
        })
        .collect();
    assert_eq!(
        counts,
        BTreeMap::from([
            ("/left/image_raw".to_owned(), 120),
            ("/pose".to_owned(), 120),
            ("/right/image_raw".to_owned(), 120),
        ])
    );
}

#[test]
fn split_bag_is_read_across_its_files() {
    let dir = tempfile::tempdir().expect("tempdir");
    let path = dir.path().join("long");
    let options = WriterOptions {
        split_size: Some(40 * 1024),
        compression: ChunkCompression::None,
        ..small_chunks()
    };
    let expected = write_sample(&path, options);
    let reader = BagReader::open(&path).expect("open");
    let files: Vec<_> = reader.files().map(Path::to_path_buf).collect();
    assert!(files.len() >= 3, "expected several files, got {files:?}");
    for (i, file) in files.iter().enumerate() {
        assert_eq!(file, &path.join(format!("long_{i}.mcap")));
    }
    assert_eq!(reader.message_count(), 360);
    assert_same(&read_all(&reader, &TopicFilter::All), &expected);

    let text = std::fs::read_to_string(path.join("metadata.yaml")).expect("metadata.yaml");
    let yaml: serde_yaml::Value = serde_yaml::from_str(&text).expect("valid YAML");
    let listed = yaml["rosbag2_bagfile_information"]["files"]
        .as_sequence()
        .expect("files");
    assert_eq!(listed.len(), files.len());
    let per_file: u64 = listed
        .iter()
        .filter_map(|f| f["message_count"].as_u64())
        .sum();
    assert_eq!(per_file, 360);
}

#[test]
fn directory_without_metadata_yaml_reads_its_mcap_files() {
    let dir = tempfile::tempdir().expect("tempdir");
    let path = dir.path().join("session");
    let expected = write_sample(&path, small_chunks());
    std::fs::remove_file(path.join("metadata.yaml")).expect("remove metadata.yaml");
    let reader = BagReader::open(&path).expect("open");
    assert_same(&read_all(&reader, &TopicFilter::All), &expected);
}

#[test]
fn nothing_appears_at_the_target_until_finish() {
    for name in ["atomic", "atomic.mcap"] {
        let dir = tempfile::tempdir().expect("tempdir");
        let path = dir.path().join(name);
        let mut writer = BagWriter::create(&path).expect("create");
        let topic = writer
            .add_topic("/a", "std_msgs/msg/String", "string data\n")
            .expect("topic");
        for i in 0..100u64 {
            writer
                .write(topic, i, &[0, 1, 0, 0, 2, 0, 0, 0, b'x', 0])
                .expect("write");
        }
        assert!(!path.exists(), "{name}: bag visible before finish");
        drop(writer);
        assert!(!path.exists(), "{name}: dropped writer left a bag");
        assert_eq!(
            std::fs::read_dir(dir.path()).expect("list").count(),
            0,
            "{name}: staging left behind"
        );

        let mut writer = BagWriter::create(&path).expect("create");
        let topic = writer
            .add_topic("/a", "std_msgs/msg/String", "string data\n")
            .expect("topic");
        writer
            .write(topic, 5, &[0, 1, 0, 0, 2, 0, 0, 0, b'x', 0])
            .expect("write");
        assert_eq!(writer.finish().expect("finish"), path);
        assert_eq!(
            std::fs::read_dir(dir.path()).expect("list").count(),
            1,
            "{name}: only the bag remains"
        );
        assert_eq!(BagReader::open(&path).expect("open").message_count(), 1);
    }
}

#[test]
fn existing_bag_is_refused_unless_overwrite() {
    let dir = tempfile::tempdir().expect("tempdir");
    let path = dir.path().join("session");
    write_sample(&path, small_chunks());
    assert!(BagWriter::create(&path).is_err());

    let options = WriterOptions {
        overwrite: true,
        ..WriterOptions::default()
    };
    let mut writer = BagWriter::create_with(&path, options).expect("create with overwrite");
    let topic = writer
        .add_topic("/only", "std_msgs/msg/String", "string data\n")
        .expect("topic");
    writer
        .write(topic, 1, b"\0\x01\0\0\x01\0\0\0\0")
        .expect("write");
    writer.finish().expect("finish");
    let reader = BagReader::open(&path).expect("open");
    assert_eq!(reader.topics().len(), 1);
    assert_eq!(reader.message_count(), 1);
    assert_eq!(std::fs::read_dir(dir.path()).expect("list").count(), 1);
}

#[test]
fn a_topic_name_keeps_one_type() {
    let dir = tempfile::tempdir().expect("tempdir");
    let mut writer = BagWriter::create(dir.path().join("b.mcap")).expect("create");
    let a = writer
        .add_topic("/t", "std_msgs/msg/String", "string data\n")
        .expect("topic");
    assert_eq!(
        writer
            .add_topic("/t", "std_msgs/msg/String", "string data\n")
            .expect("same"),
        a
    );
    let err = writer
        .add_topic("/t", "std_msgs/msg/Int32", "int32 data\n")
        .expect_err("type clash");
    assert!(err.to_string().contains("std_msgs/msg/String"), "{err}");
}
