//! CDR encode/decode of full-HD images: `sensor_msgs::Image` (data through
//! `serde_bytes`, one block copy) next to the same layout with a plain `Vec<u8>`
//! (serde's element-by-element sequence), which is what bulk byte arrays avoid.
// A benchmark on fixed inputs: an input that fails is a bug to see at once.
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

use std::hint::black_box;

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use serde::{Deserialize, Serialize};
use stereocal_msgs::cdr;
use stereocal_msgs::sensor_msgs::Image;
use stereocal_msgs::std_msgs::Header;

/// `sensor_msgs/msg/Image` with its data as a serde sequence of `u8`.
#[derive(Serialize, Deserialize)]
struct ElementwiseImage {
    header: Header,
    height: u32,
    width: u32,
    encoding: String,
    is_bigendian: u8,
    step: u32,
    data: Vec<u8>,
}

fn image(encoding: &str, channels: u32) -> Image {
    let (width, height) = (1920u32, 1080u32);
    let step = width * channels;
    Image {
        header: Header::default(),
        height,
        width,
        encoding: encoding.to_owned(),
        is_bigendian: 0,
        step,
        data: (0..step * height).map(|i| (i % 251) as u8).collect(),
    }
}

fn bench_images(c: &mut Criterion) {
    for (encoding, channels) in [("mono8", 1), ("rgb8", 3)] {
        let image = image(encoding, channels);
        let bytes = cdr::to_bytes(&image).expect("encodes");
        let mut group = c.benchmark_group(format!("cdr_image_1920x1080_{encoding}"));
        group.throughput(Throughput::Bytes(bytes.len() as u64));
        group.bench_function("encode", |b| {
            b.iter(|| cdr::to_bytes(black_box(&image)).expect("encodes"))
        });
        group.bench_function("decode", |b| {
            b.iter(|| cdr::from_bytes::<Image>(black_box(&bytes)).expect("decodes"))
        });
        let elementwise = ElementwiseImage {
            header: image.header.clone(),
            height: image.height,
            width: image.width,
            encoding: image.encoding.clone(),
            is_bigendian: 0,
            step: image.step,
            data: image.data.clone(),
        };
        assert_eq!(cdr::to_bytes(&elementwise).expect("encodes"), bytes);
        group.bench_function("encode_elementwise", |b| {
            b.iter(|| cdr::to_bytes(black_box(&elementwise)).expect("encodes"))
        });
        group.bench_function("decode_elementwise", |b| {
            b.iter(|| cdr::from_bytes::<ElementwiseImage>(black_box(&bytes)).expect("decodes"))
        });
        group.finish();
    }
}

criterion_group!(benches, bench_images);
criterion_main!(benches);
