//! A bag of many chunks is read holding at most two chunks at a time.

use stereocal_rosbag::{BagReader, BagWriter, TopicFilter, WriterOptions};

const CHUNK_SIZE: u64 = 256 * 1024;
const MESSAGE_BYTES: usize = 60 * 1024;

/// Deterministic, poorly compressible bytes.
fn noise(seed: u64, len: usize) -> Vec<u8> {
    let mut state = seed.wrapping_mul(0x9e37_79b9_7f4a_7c15) | 1;
    (0..len)
        .map(|_| {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 24) as u8
        })
        .collect()
}

#[test]
fn reading_holds_at_most_two_chunks() {
    let dir = tempfile::tempdir().expect("tempdir");
    let path = dir.path().join("big");
    let options = WriterOptions {
        chunk_size: CHUNK_SIZE,
        ..WriterOptions::default()
    };
    let mut writer = BagWriter::create_with(&path, options).expect("create");
    let image = writer
        .add_topic("/cam/image_raw", "sensor_msgs/msg/Image", "uint8[] data\n")
        .expect("topic");
    let info = writer
        .add_topic(
            "/cam/camera_info",
            "sensor_msgs/msg/CameraInfo",
            "uint32 height\n",
        )
        .expect("topic");
    let count = 400u64;
    for i in 0..count {
        let t = 5_000_000_000 + i * 33_333_333;
        writer
            .write(image, t, &noise(i, MESSAGE_BYTES))
            .expect("write");
        writer
            .write(info, t + 10, &noise(i + 10_000, 64))
            .expect("write");
    }
    writer.finish().expect("finish");

    let file = path.join("big_0.mcap");
    let file_bytes = std::fs::metadata(&file).expect("bag file").len();
    let bytes = std::fs::read(&file).expect("read");
    let summary = mcap::Summary::read(&bytes)
        .expect("summary")
        .expect("present");
    let chunks = summary.chunk_indexes.len();
    assert!(chunks >= 60, "{chunks} chunks");
    drop(bytes);

    let reader = BagReader::open(&path).expect("open");
    let mut messages = reader.messages(&TopicFilter::All);
    let mut read = 0u64;
    let mut last = 0u64;
    for message in messages.by_ref() {
        let message = message.expect("message");
        assert!(message.log_time_ns >= last);
        last = message.log_time_ns;
        read += 1;
    }
    assert_eq!(read, 2 * count);
    let held = messages.peak_segments_held();
    let peak = messages.peak_buffered_bytes();
    assert!(held <= 2, "held {held} chunks at once");
    let one_chunk = CHUNK_SIZE as usize + MESSAGE_BYTES + 1024;
    assert!(peak <= 2 * one_chunk, "peak {peak} bytes buffered");
    assert!(
        (peak as u64) * 20 < file_bytes,
        "peak {peak} bytes for a {file_bytes}-byte bag"
    );
}
