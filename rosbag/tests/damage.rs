//! Damaged bags: truncated files yield every complete message before the cut and then an
//! error naming the file and offset; corrupt chunks give a clear error; nothing panics.

use std::path::{Path, PathBuf};

use stereocal_rosbag::{
    BagError, BagMessage, BagReader, BagWriter, ChunkCompression, TopicFilter, WriterOptions,
};

/// Payload of message `i`: a unique marker followed by filler bytes.
fn payload(i: u32) -> Vec<u8> {
    let mut data = format!("<msg {i:05}>").into_bytes();
    data.extend((0..300u32).map(|k| (k.wrapping_mul(2_654_435_761).wrapping_add(i) >> 13) as u8));
    data
}

/// A bare .mcap file of 200 messages on two topics in 2 KiB chunks, in log-time order.
fn write_bag(dir: &Path, compression: ChunkCompression) -> PathBuf {
    let path = dir.join("source.mcap");
    let options = WriterOptions {
        compression,
        chunk_size: 2 * 1024,
        ..WriterOptions::default()
    };
    let mut writer = BagWriter::create_with(&path, options).expect("create");
    let a = writer
        .add_topic("/a", "std_msgs/msg/String", "string data\n")
        .expect("topic");
    let b = writer
        .add_topic("/b", "std_msgs/msg/String", "string data\n")
        .expect("topic");
    for i in 0..200u32 {
        let topic = if i % 3 == 0 { b } else { a };
        writer
            .write(topic, 1_000 + u64::from(i) * 10, &payload(i))
            .expect("write");
    }
    writer.finish().expect("finish")
}

/// Reads everything, splitting the messages from the errors that follow them.
fn read(path: &Path) -> (Vec<BagMessage>, Vec<BagError>) {
    let reader = BagReader::open(path).expect("a damaged bag still opens");
    let mut messages = Vec::new();
    let mut errors = Vec::new();
    for item in reader.messages(&TopicFilter::All) {
        match item {
            Ok(m) => {
                assert!(errors.is_empty(), "a message after an error");
                messages.push(m);
            }
            Err(e) => errors.push(e),
        }
    }
    (messages, errors)
}

fn index_of(message: &BagMessage) -> u32 {
    let marker = std::str::from_utf8(&message.data[5..10]).expect("marker");
    marker.parse().expect("index")
}

fn find(haystack: &[u8], needle: &[u8]) -> Option<usize> {
    haystack.windows(needle.len()).position(|w| w == needle)
}

fn cut_copy(bytes: &[u8], cut: usize, dir: &Path) -> PathBuf {
    let path = dir.join(format!("cut_{cut}.mcap"));
    std::fs::write(&path, &bytes[..cut]).expect("write cut copy");
    path
}

#[test]
fn truncated_uncompressed_bag_yields_exactly_the_complete_messages() {
    let dir = tempfile::tempdir().expect("tempdir");
    let source = write_bag(dir.path(), ChunkCompression::None);
    let bytes = std::fs::read(&source).expect("read");
    // Where each message's record ends in the file: its payload is its last bytes.
    let ends: Vec<usize> = (0..200)
        .map(|i| {
            let data = payload(i);
            find(&bytes, &data).expect("payload stored verbatim") + data.len()
        })
        .collect();
    let data_end = *ends.iter().max().expect("messages");
    let cuts = [
        20,
        bytes.len() / 10,
        bytes.len() / 3,
        ends[77],
        ends[77] + 1,
        bytes.len() / 2 + 7,
        data_end - 1,
        data_end + 5,
        bytes.len() - 1,
    ];
    for cut in cuts {
        let path = cut_copy(&bytes, cut, dir.path());
        let (messages, errors) = read(&path);
        let got: Vec<u32> = messages.iter().map(index_of).collect();
        let want: Vec<u32> = (0..200).filter(|&i| ends[i as usize] <= cut).collect();
        assert_eq!(got, want, "cut at byte {cut}");
        assert_eq!(
            errors.len(),
            1,
            "cut at byte {cut}: one error after the messages"
        );
        let error = &errors[0];
        assert!(
            matches!(error, BagError::Truncated { .. }),
            "cut at {cut}: {error}"
        );
        let offset = error.damage_offset().expect("offset");
        assert!(
            offset <= cut as u64,
            "cut at {cut}: damage reported at {offset}"
        );
        let text = error.to_string();
        assert!(text.contains(&path.display().to_string()), "{text}");
        assert!(text.contains(&format!("byte {offset}")), "{text}");
    }
}

#[test]
fn truncated_zstd_bag_yields_every_message_of_its_complete_chunks() {
    let dir = tempfile::tempdir().expect("tempdir");
    let source = write_bag(dir.path(), ChunkCompression::Zstd);
    let bytes = std::fs::read(&source).expect("read");
    let summary = mcap::Summary::read(&bytes)
        .expect("summary parses")
        .expect("summary present");
    assert!(summary.chunk_indexes.len() > 10);
    let (all, _) = read(&source);
    assert_eq!(all.len(), 200);
    for fraction in [0.15, 0.4, 0.61, 0.9] {
        let cut = (bytes.len() as f64 * fraction) as usize;
        // Messages in chunks that end before the cut must all be recovered.
        let complete: usize = summary
            .chunk_indexes
            .iter()
            .filter(|c| (c.chunk_start_offset + c.chunk_length) as usize <= cut)
            .map(|c| {
                let start = c.message_start_time;
                let end = c.message_end_time;
                all.iter()
                    .filter(|m| (start..=end).contains(&m.log_time_ns))
                    .count()
            })
            .sum();
        let path = cut_copy(&bytes, cut, dir.path());
        let (messages, errors) = read(&path);
        assert!(
            messages.len() >= complete,
            "cut {cut}: {} < {complete}",
            messages.len()
        );
        assert_eq!(
            messages,
            all[..messages.len()],
            "cut {cut}: a prefix of the bag"
        );
        assert_eq!(errors.len(), 1, "cut {cut}");
        assert!(
            matches!(errors[0], BagError::Truncated { .. }),
            "{}",
            errors[0]
        );
    }
}

#[test]
fn corrupt_chunk_is_reported_with_its_offset_after_the_messages_before_it() {
    let dir = tempfile::tempdir().expect("tempdir");
    let source = write_bag(dir.path(), ChunkCompression::Zstd);
    let mut bytes = std::fs::read(&source).expect("read");
    let summary = mcap::Summary::read(&bytes)
        .expect("summary parses")
        .expect("summary present");
    let (all, _) = read(&source);
    let chunk = &summary.chunk_indexes[4];
    let data = chunk.compressed_data_offset().expect("offset") as usize;
    for byte in &mut bytes[data + 10..data + 40] {
        *byte ^= 0x5a;
    }
    let path = dir.path().join("corrupt.mcap");
    std::fs::write(&path, &bytes).expect("write");
    let (messages, errors) = read(&path);
    let before = all
        .iter()
        .filter(|m| m.log_time_ns < chunk.message_start_time)
        .count();
    assert_eq!(messages, all[..before]);
    assert_eq!(errors.len(), 1);
    assert!(
        matches!(errors[0], BagError::Corrupt { .. }),
        "{}",
        errors[0]
    );
    assert_eq!(errors[0].damage_offset(), Some(chunk.chunk_start_offset));
}

#[test]
fn corrupt_summary_falls_back_to_scanning_the_file() {
    let dir = tempfile::tempdir().expect("tempdir");
    let source = write_bag(dir.path(), ChunkCompression::Zstd);
    let (all, _) = read(&source);
    let mut bytes = std::fs::read(&source).expect("read");
    let footer = mcap::read::footer(&bytes).expect("footer");
    // Damage the first chunk index of the summary: its CRC no longer matches.
    let at = footer.summary_start as usize + 40;
    bytes[at] ^= 0xff;
    let path = dir.path().join("bad_summary.mcap");
    std::fs::write(&path, &bytes).expect("write");
    let (messages, errors) = read(&path);
    assert_eq!(messages, all);
    assert!(errors.is_empty(), "{errors:?}");
}

#[test]
fn not_an_mcap_file_is_refused() {
    let dir = tempfile::tempdir().expect("tempdir");
    let path = dir.path().join("notes.mcap");
    std::fs::write(&path, b"these are not the bytes you are looking for").expect("write");
    let err = BagReader::open(&path).expect_err("not MCAP");
    assert!(matches!(err, BagError::NotMcap { .. }), "{err}");
    assert!(err.to_string().contains("notes.mcap"));
    let missing = BagReader::open(dir.path().join("missing")).expect_err("missing");
    assert!(matches!(missing, BagError::Io { .. }), "{missing}");
}

#[test]
fn random_byte_damage_never_panics_and_never_invents_messages() {
    let dir = tempfile::tempdir().expect("tempdir");
    let source = write_bag(dir.path(), ChunkCompression::Zstd);
    let bytes = std::fs::read(&source).expect("read");
    let payloads: Vec<Vec<u8>> = (0..200).map(payload).collect();
    let path = dir.path().join("flipped.mcap");
    let mut state = 0x9e37_79b9_7f4a_7c15u64;
    for _ in 0..150 {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        let mut damaged = bytes.clone();
        let at = (state % damaged.len() as u64) as usize;
        damaged[at] ^= 1 << (state >> 60 & 7);
        std::fs::write(&path, &damaged).expect("write");
        let Ok(reader) = BagReader::open(&path) else {
            continue;
        };
        for message in reader.messages(&TopicFilter::All).flatten() {
            // Chunk CRCs catch flipped message bytes: whatever is yielded is genuine.
            assert!(
                payloads.contains(&message.data),
                "flip at byte {at} yielded altered data"
            );
        }
    }
}
