//! `sensor_msgs/Image` -> `sensor_msgs/CompressedImage`, as image_transport's
//! `compressed` publisher (compressed_image_transport) encodes it: JPEG or PNG, the
//! `format` field `"<encoding>; <codec> compressed <pixels>"` (`"rgb8; jpeg compressed
//! bgr8"`, `"mono8; png compressed mono8"`), which [`super::image_msg_from_compressed`]
//! and image_transport's subscribers decode back to the original encoding.
//!
//! JPEG holds 8-bit grey or colour: mono16 is refused, alpha is dropped. PNG holds every
//! encoding this crate converts, exactly. JPEG through `image`'s encoder, PNG through
//! `png` (the DEFLATE level is compressed_image_transport's `png_level`).

use image::ExtendedColorType;
use image::codecs::jpeg::JpegEncoder;
use stereocal_msgs::sensor_msgs::{CompressedImage, Image};
use thiserror::Error;

use super::image::Encoding;

/// How `image_rect/compressed` (or any compressed topic) is encoded.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Compression {
    /// JPEG of this quality, 1 to 100.
    Jpeg {
        /// compressed_image_transport's `jpeg_quality`.
        quality: u8,
    },
    /// PNG at this DEFLATE level, 1 to 9.
    Png {
        /// compressed_image_transport's `png_level`.
        level: u8,
    },
}

/// Why an image could not be compressed.
#[derive(Debug, Error, PartialEq)]
pub enum CompressError {
    /// The encoding is not one this conversion handles, or the codec cannot hold it.
    #[error("cannot compress {encoding:?} images as {codec}: {reason}")]
    Unsupported {
        /// The image's encoding.
        encoding: String,
        /// The codec asked for.
        codec: &'static str,
        /// What the codec holds.
        reason: &'static str,
    },
    /// The message's size fields disagree with its data.
    #[error("image of {width}x{height} {encoding} with step {step} has {bytes} bytes of data")]
    BadSize {
        /// Width.
        width: u32,
        /// Height.
        height: u32,
        /// Encoding.
        encoding: String,
        /// Row stride.
        step: u32,
        /// Bytes present.
        bytes: usize,
    },
    /// The encoder failed.
    #[error("{codec} encoder: {message}")]
    Encoder {
        /// The codec.
        codec: &'static str,
        /// What it said.
        message: String,
    },
}

/// `msg` compressed as `compression` asks, with its header.
pub fn compressed_from_image_msg(
    msg: &Image,
    compression: Compression,
) -> Result<CompressedImage, CompressError> {
    let codec = match compression {
        Compression::Jpeg { .. } => "jpeg",
        Compression::Png { .. } => "png",
    };
    let encoding = Encoding::from_ros_name(&msg.encoding).ok_or(CompressError::Unsupported {
        encoding: msg.encoding.clone(),
        codec,
        reason: "expected mono8, mono16, rgb8, bgr8, rgba8 or bgra8",
    })?;
    let pixels = packed_samples(msg, encoding)?;
    let (width, height) = (msg.width, msg.height);
    let (data, stored) = match compression {
        Compression::Jpeg { quality } => {
            let (rgb, colour, stored) = match encoding {
                Encoding::Mono16 => {
                    return Err(CompressError::Unsupported {
                        encoding: msg.encoding.clone(),
                        codec,
                        reason: "JPEG holds 8-bit samples: use png for mono16",
                    });
                }
                Encoding::Mono8 => (pixels, ExtendedColorType::L8, "mono8"),
                other => (
                    to_rgb(&pixels, other, false),
                    ExtendedColorType::Rgb8,
                    "bgr8",
                ),
            };
            let mut out = Vec::new();
            JpegEncoder::new_with_quality(&mut out, quality.clamp(1, 100))
                .encode(&rgb, width, height, colour)
                .map_err(|e| encoder_error(codec, e))?;
            (out, stored)
        }
        Compression::Png { level } => {
            let (samples, colour, depth, stored) = match encoding {
                Encoding::Mono8 => (
                    pixels,
                    png::ColorType::Grayscale,
                    png::BitDepth::Eight,
                    "mono8",
                ),
                Encoding::Mono16 => (
                    big_endian_16(&pixels, msg.is_bigendian != 0),
                    png::ColorType::Grayscale,
                    png::BitDepth::Sixteen,
                    "mono16",
                ),
                Encoding::Rgb8 | Encoding::Bgr8 => (
                    to_rgb(&pixels, encoding, false),
                    png::ColorType::Rgb,
                    png::BitDepth::Eight,
                    "bgr8",
                ),
                Encoding::Rgba8 | Encoding::Bgra8 => (
                    to_rgb(&pixels, encoding, true),
                    png::ColorType::Rgba,
                    png::BitDepth::Eight,
                    "bgra8",
                ),
            };
            let mut out = Vec::new();
            let mut encoder = png::Encoder::new(&mut out, width, height);
            encoder.set_color(colour);
            encoder.set_depth(depth);
            encoder.set_deflate_compression(png::DeflateCompression::Level(level.clamp(1, 9)));
            let mut writer = encoder
                .write_header()
                .map_err(|e| encoder_error(codec, e))?;
            writer
                .write_image_data(&samples)
                .map_err(|e| encoder_error(codec, e))?;
            writer.finish().map_err(|e| encoder_error(codec, e))?;
            (out, stored)
        }
    };
    Ok(CompressedImage {
        header: msg.header.clone(),
        format: format!("{}; {codec} compressed {stored}", msg.encoding),
        data,
    })
}

fn encoder_error(codec: &'static str, error: impl std::fmt::Display) -> CompressError {
    CompressError::Encoder {
        codec,
        message: error.to_string(),
    }
}

/// The image's rows without their padding.
fn packed_samples(msg: &Image, encoding: Encoding) -> Result<Vec<u8>, CompressError> {
    let row = msg.width as usize * encoding.bytes_per_pixel();
    let step = msg.step as usize;
    let height = msg.height as usize;
    let needed = step
        .checked_mul(height.saturating_sub(1))
        .and_then(|n| n.checked_add(row));
    let fits =
        msg.width > 0 && height > 0 && step >= row && needed.is_some_and(|n| n <= msg.data.len());
    if !fits {
        return Err(CompressError::BadSize {
            width: msg.width,
            height: msg.height,
            encoding: msg.encoding.clone(),
            step: msg.step,
            bytes: msg.data.len(),
        });
    }
    Ok((0..height)
        .flat_map(|y| &msg.data[y * step..y * step + row])
        .copied()
        .collect())
}

/// Colour pixels in red-green-blue order, with alpha when `alpha` (and the input has it).
fn to_rgb(pixels: &[u8], encoding: Encoding, alpha: bool) -> Vec<u8> {
    let channels = encoding.channels();
    let blue_first = matches!(encoding, Encoding::Bgr8 | Encoding::Bgra8);
    let out_channels = if alpha { 4 } else { 3 };
    let mut out = Vec::with_capacity(pixels.len() / channels * out_channels);
    for pixel in pixels.chunks_exact(channels) {
        let (r, b) = if blue_first {
            (pixel[2], pixel[0])
        } else {
            (pixel[0], pixel[2])
        };
        out.extend_from_slice(&[r, pixel[1], b]);
        if alpha {
            out.push(pixel[3]);
        }
    }
    out
}

/// 16-bit samples in PNG's big-endian order.
fn big_endian_16(pixels: &[u8], big_endian: bool) -> Vec<u8> {
    if big_endian {
        return pixels.to_vec();
    }
    pixels
        .chunks_exact(2)
        .flat_map(|sample| [sample[1], sample[0]])
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::convert::image_msg_from_compressed;
    use stereocal_msgs::std_msgs::Header;

    fn image(encoding: &str, width: u32, height: u32, padding: u32) -> Image {
        let bytes = Encoding::from_ros_name(encoding).unwrap().bytes_per_pixel() as u32;
        let step = width * bytes + padding;
        Image {
            header: Header {
                frame_id: "cam".into(),
                ..Header::default()
            },
            height,
            width,
            encoding: encoding.into(),
            is_bigendian: 0,
            step,
            data: (0..step * height)
                .map(|i| {
                    let (x, y) = (i % step, i / step);
                    // Smooth, so that JPEG's loss stays small.
                    ((x / 3 + 2 * y) % 256) as u8
                })
                .collect(),
        }
    }

    fn packed(msg: &Image) -> Vec<u8> {
        packed_samples(msg, Encoding::from_ros_name(&msg.encoding).unwrap()).unwrap()
    }

    #[test]
    fn png_comes_back_exactly_in_every_encoding() {
        for encoding in ["mono8", "mono16", "rgb8", "bgr8", "rgba8", "bgra8"] {
            let msg = image(encoding, 37, 11, 5);
            let compressed =
                compressed_from_image_msg(&msg, Compression::Png { level: 3 }).unwrap();
            assert!(
                compressed
                    .format
                    .starts_with(&format!("{encoding}; png compressed ")),
                "{}",
                compressed.format
            );
            let back = image_msg_from_compressed(&compressed).unwrap();
            assert_eq!(back.encoding, encoding);
            assert_eq!((back.width, back.height), (37, 11));
            assert_eq!(packed(&back), packed(&msg), "{encoding}");
            assert_eq!(back.header, msg.header);
        }
    }

    #[test]
    fn jpeg_comes_back_within_its_loss() {
        for encoding in ["mono8", "rgb8", "bgr8"] {
            let msg = image(encoding, 64, 48, 0);
            let compressed =
                compressed_from_image_msg(&msg, Compression::Jpeg { quality: 95 }).unwrap();
            assert!(compressed.data.starts_with(&[0xFF, 0xD8, 0xFF]));
            let back = image_msg_from_compressed(&compressed).unwrap();
            assert_eq!(back.encoding, encoding);
            let (a, b) = (packed(&back), packed(&msg));
            let mean = a
                .iter()
                .zip(&b)
                .map(|(x, y)| f64::from(x.abs_diff(*y)))
                .sum::<f64>()
                / a.len() as f64;
            assert!(mean < 2.0, "{encoding}: mean difference {mean}");
        }
    }

    #[test]
    fn what_cannot_be_compressed_is_named() {
        let mono16 = image("mono16", 8, 8, 0);
        let error = compressed_from_image_msg(&mono16, Compression::Jpeg { quality: 90 })
            .unwrap_err()
            .to_string();
        assert!(error.contains("mono16") && error.contains("png"), "{error}");
        let mut yuv = image("mono8", 8, 8, 0);
        yuv.encoding = "yuv422".into();
        assert!(compressed_from_image_msg(&yuv, Compression::Png { level: 3 }).is_err());
        let mut short = image("rgb8", 8, 8, 0);
        short.data.truncate(10);
        assert!(matches!(
            compressed_from_image_msg(&short, Compression::Png { level: 3 }),
            Err(CompressError::BadSize { .. })
        ));
    }
}
