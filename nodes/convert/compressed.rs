//! `sensor_msgs/CompressedImage` -> `sensor_msgs/Image`, as image_transport's
//! `compressed` subscriber decodes it, so that every stage takes compressed input
//! unchanged.
//!
//! The `format` field reads `"<original encoding>; <codec> compressed [<pixels>]"`
//! (`"bgr8; jpeg compressed bgr8"`, `"mono8; png compressed"`), or names the codec alone
//! (`"jpeg"`, as usb_cam writes), or is empty. The codec is read from the data's own
//! signature and must agree with the one `format` names; the image comes out in the
//! original encoding when `format` gives one this conversion handles (mono8, mono16,
//! rgb8, bgr8, rgba8, bgra8), else as image_transport gives it: mono8 or mono16 for grey,
//! bgr8 for colour, bgra8 for colour with alpha. JPEG is decoded by `zune-jpeg` (SIMD),
//! PNG by `png`.

use std::io::Cursor;

use stereocal_msgs::RosMessage;
use stereocal_msgs::cdr;
use stereocal_msgs::sensor_msgs::{CompressedImage, Image};
use stereocal_vision::channel_order::swap_red_blue;
use thiserror::Error;
use zune_jpeg::JpegDecoder;
use zune_jpeg::zune_core::colorspace::ColorSpace;
use zune_jpeg::zune_core::options::DecoderOptions;

use super::image::Encoding;
use super::jpeg_input::JpegInput;

/// Largest width or height decoded, pixels: larger is taken as damage, not an image.
const MAX_SIDE: usize = 1 << 15;
/// Largest decoded size, bytes (an 8K colour image is 100 MB): a damaged header that
/// declares more is refused before anything is allocated.
const MAX_BYTES: usize = 1 << 28;

/// A compression this conversion decodes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Codec {
    /// JPEG (JFIF).
    Jpeg,
    /// PNG.
    Png,
}

impl Codec {
    /// The name image_transport writes in `format`.
    pub fn name(self) -> &'static str {
        match self {
            Self::Jpeg => "jpeg",
            Self::Png => "png",
        }
    }

    /// The codec whose signature starts `data`.
    fn sniff(data: &[u8]) -> Option<Self> {
        if data.starts_with(&[0xFF, 0xD8, 0xFF]) {
            Some(Self::Jpeg)
        } else if data.starts_with(b"\x89PNG\r\n\x1a\n") {
            Some(Self::Png)
        } else {
            None
        }
    }
}

/// Why a CompressedImage could not be decoded.
#[derive(Debug, Error, PartialEq, Eq)]
pub enum CompressedError {
    /// `format` names a codec this conversion does not decode.
    #[error("format {format:?} names codec {codec:?}: only jpeg and png are decoded")]
    UnknownCodec {
        /// The message's format.
        format: String,
        /// The codec it names.
        codec: String,
    },
    /// The data starts with no JPEG or PNG signature.
    #[error("the data ({len} bytes, format {format:?}) is neither JPEG nor PNG")]
    NotAnImage {
        /// The message's format.
        format: String,
        /// Bytes of data.
        len: usize,
    },
    /// `format` names one codec and the data is another.
    #[error("format {format:?} says {named}, but the data is {found}")]
    CodecMismatch {
        /// The message's format.
        format: String,
        /// The codec the format names.
        named: &'static str,
        /// The codec of the data.
        found: &'static str,
    },
    /// The codec could not decode the data (corrupt or truncated).
    #[error("{codec} data could not be decoded: {reason}")]
    Corrupt {
        /// The codec.
        codec: &'static str,
        /// What the decoder said.
        reason: String,
    },
    /// The decoded pixels cannot be given in the encoding `format` asks for.
    #[error("{codec} pixels ({found}) cannot be given as {wanted}")]
    Unconvertible {
        /// The codec.
        codec: &'static str,
        /// What the data holds.
        found: String,
        /// The encoding asked for.
        wanted: &'static str,
    },
}

/// What `format` says: the original encoding when it names one this conversion gives,
/// and the codec when it names one.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Format {
    /// The encoding of the image before compression.
    pub original: Option<Encoding>,
    /// The codec named, lower case.
    pub codec: Option<String>,
}

impl Format {
    /// Reads a CompressedImage's `format`.
    pub fn parse(format: &str) -> Self {
        let format = format.trim();
        let (original, rest) = match format.split_once(';') {
            Some((original, rest)) => (Encoding::from_ros_name(original.trim()), rest),
            None => (None, format),
        };
        let codec = rest
            .split_whitespace()
            .next()
            .map(|c| match c.to_ascii_lowercase().as_str() {
                "jpg" => "jpeg".to_owned(),
                other => other.to_owned(),
            });
        Self { original, codec }
    }
}

/// The two kinds of image message: raw, and compressed (image_transport's
/// `<base topic>/compressed`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ImageKind {
    /// `sensor_msgs/msg/Image`.
    Raw,
    /// `sensor_msgs/msg/CompressedImage`.
    Compressed,
}

impl ImageKind {
    /// The kind of a topic of type `type_name`, if it carries images.
    pub fn of_type(type_name: &str) -> Option<Self> {
        if type_name == Image::TYPE_NAME {
            Some(Self::Raw)
        } else if type_name == CompressedImage::TYPE_NAME {
            Some(Self::Compressed)
        } else {
            None
        }
    }

    /// The `sensor_msgs/Image` of a CDR message of this kind, decompressed; the error
    /// says what was wrong.
    pub fn decode(self, cdr_bytes: &[u8]) -> Result<Image, String> {
        match self {
            Self::Raw => cdr::from_bytes::<Image>(cdr_bytes).map_err(|e| e.to_string()),
            Self::Compressed => {
                let msg =
                    cdr::from_bytes::<CompressedImage>(cdr_bytes).map_err(|e| e.to_string())?;
                image_msg_from_compressed(&msg).map_err(|e| e.to_string())
            }
        }
    }
}

/// The base topic of an image topic, as image_transport names them: `/cam/image_raw`
/// for `/cam/image_raw/compressed`, the topic itself otherwise.
pub fn base_topic(topic: &str) -> &str {
    topic.strip_suffix("/compressed").unwrap_or(topic)
}

/// Decodes `msg` into a `sensor_msgs/Image` with its header (see the module's
/// documentation for the encoding it comes out in).
pub fn image_msg_from_compressed(msg: &CompressedImage) -> Result<Image, CompressedError> {
    let format = Format::parse(&msg.format);
    let found = Codec::sniff(&msg.data);
    let codec = match (&format.codec, found) {
        (Some(named), _) if !matches!(named.as_str(), "jpeg" | "png") => {
            return Err(CompressedError::UnknownCodec {
                format: msg.format.clone(),
                codec: named.clone(),
            });
        }
        (_, None) => {
            return Err(CompressedError::NotAnImage {
                format: msg.format.clone(),
                len: msg.data.len(),
            });
        }
        (Some(named), Some(found)) if named != found.name() => {
            return Err(CompressedError::CodecMismatch {
                format: msg.format.clone(),
                named: if named == "png" { "png" } else { "jpeg" },
                found: found.name(),
            });
        }
        (_, Some(found)) => found,
    };
    let (encoding, width, height, data) = match codec {
        Codec::Jpeg => decode_jpeg(&msg.data, format.original)?,
        Codec::Png => decode_png(&msg.data, format.original)?,
    };
    Ok(Image {
        header: msg.header.clone(),
        height: height as u32,
        width: width as u32,
        encoding: encoding.ros_name().to_owned(),
        is_bigendian: 0,
        step: (width * encoding.bytes_per_pixel()) as u32,
        data,
    })
}

fn corrupt(codec: Codec) -> impl FnOnce(String) -> CompressedError {
    move |reason| CompressedError::Corrupt {
        codec: codec.name(),
        reason,
    }
}

/// Decoded pixels: their encoding, width, height and bytes.
type Decoded = (Encoding, usize, usize, Vec<u8>);

fn decode_jpeg(data: &[u8], original: Option<Encoding>) -> Result<Decoded, CompressedError> {
    let options = DecoderOptions::default()
        .set_max_width(MAX_SIDE)
        .set_max_height(MAX_SIDE)
        .set_strict_mode(true);
    // An MJPEG frame without Huffman tables decodes with the standard ones.
    let data = super::mjpeg::with_standard_tables_marked(data);
    let mut decoder = JpegDecoder::new_with_options(JpegInput::new(&data), options);
    decoder
        .decode_headers()
        .map_err(|e| corrupt(Codec::Jpeg)(e.to_string()))?;
    let input = decoder.input_colorspace();
    let encoding = match original {
        Some(Encoding::Mono16) => {
            return Err(CompressedError::Unconvertible {
                codec: "jpeg",
                found: "8-bit".into(),
                wanted: "mono16",
            });
        }
        Some(encoding) => encoding,
        None if input == Some(ColorSpace::Luma) => Encoding::Mono8,
        None => Encoding::Bgr8,
    };
    let (width, height) = decoder
        .dimensions()
        .ok_or_else(|| corrupt(Codec::Jpeg)("no dimensions in the header".into()))?;
    let bytes = width * height * encoding.bytes_per_pixel();
    if bytes > MAX_BYTES {
        return Err(corrupt(Codec::Jpeg)(format!(
            "the header declares {width}x{height}, {bytes} bytes decoded: more than {MAX_BYTES}"
        )));
    }
    // zune-jpeg converts YCbCr to RGB, BGR, RGBA and BGRA with SIMD; other colour spaces
    // become RGB or RGBA, and red and blue are swapped afterwards for BGR or BGRA.
    let ycbcr = input == Some(ColorSpace::YCbCr);
    let (colorspace, swap) = match encoding {
        Encoding::Mono8 | Encoding::Mono16 => (ColorSpace::Luma, false),
        Encoding::Rgb8 => (ColorSpace::RGB, false),
        Encoding::Rgba8 => (ColorSpace::RGBA, false),
        Encoding::Bgr8 if ycbcr => (ColorSpace::BGR, false),
        Encoding::Bgra8 if ycbcr => (ColorSpace::BGRA, false),
        Encoding::Bgr8 => (ColorSpace::RGB, true),
        Encoding::Bgra8 => (ColorSpace::RGBA, true),
    };
    decoder.set_options(options.jpeg_set_out_colorspace(colorspace));
    let mut pixels = decoder
        .decode()
        .map_err(|e| corrupt(Codec::Jpeg)(e.to_string()))?;
    if pixels.len() != bytes {
        return Err(corrupt(Codec::Jpeg)(format!(
            "{} bytes decoded for {width}x{height} {}",
            pixels.len(),
            encoding.ros_name()
        )));
    }
    if swap {
        swap_red_blue(&mut pixels, encoding.channels());
    }
    Ok((encoding, width, height, pixels))
}

fn decode_png(data: &[u8], original: Option<Encoding>) -> Result<Decoded, CompressedError> {
    let mut decoder =
        png::Decoder::new_with_limits(Cursor::new(data), png::Limits { bytes: MAX_BYTES });
    // Palettes and fewer than 8 bits per sample become 8-bit samples; 16 bits stay.
    decoder.set_transformations(png::Transformations::EXPAND);
    let mut reader = decoder
        .read_info()
        .map_err(|e| corrupt(Codec::Png)(e.to_string()))?;
    let size = reader
        .output_buffer_size()
        .ok_or_else(|| corrupt(Codec::Png)("an image too large to decode".into()))?;
    let mut buffer = vec![0; size];
    let info = reader
        .next_frame(&mut buffer)
        .map_err(|e| corrupt(Codec::Png)(e.to_string()))?;
    buffer.truncate(info.buffer_size());
    let (width, height) = (info.width as usize, info.height as usize);
    let sixteen = info.bit_depth == png::BitDepth::Sixteen;
    let channels = info.color_type.samples();
    let found = format!(
        "{channels} channel(s) of {} bits",
        if sixteen { 16 } else { 8 }
    );
    let unconvertible = |wanted: Encoding| CompressedError::Unconvertible {
        codec: "png",
        found: found.clone(),
        wanted: wanted.ros_name(),
    };
    if sixteen {
        // PNG samples are big-endian; ROS images here are little-endian.
        if channels != 1 || original.is_some_and(|e| e != Encoding::Mono16) {
            return Err(unconvertible(original.unwrap_or(Encoding::Mono16)));
        }
        for sample in buffer.chunks_exact_mut(2) {
            sample.swap(0, 1);
        }
        return Ok((Encoding::Mono16, width, height, buffer));
    }
    let natural = match channels {
        1 => Encoding::Mono8,
        3 => Encoding::Rgb8,
        4 => Encoding::Rgba8,
        _ => return Err(unconvertible(original.unwrap_or(Encoding::Mono8))),
    };
    let wanted = original.unwrap_or(match natural {
        Encoding::Rgb8 => Encoding::Bgr8,
        Encoding::Rgba8 => Encoding::Bgra8,
        other => other,
    });
    let pixels = match (natural, wanted) {
        (n, w) if n == w => buffer,
        (Encoding::Rgb8, Encoding::Bgr8) | (Encoding::Rgba8, Encoding::Bgra8) => {
            swap_red_blue(&mut buffer, channels);
            buffer
        }
        _ => return Err(unconvertible(wanted)),
    };
    Ok((wanted, width, height, pixels))
}

#[cfg(test)]
mod tests {
    use super::*;
    use image::codecs::jpeg::JpegEncoder;
    use image::codecs::png::PngEncoder;
    use image::{ExtendedColorType, ImageEncoder};
    use stereocal_msgs::std_msgs::Header;

    fn pattern(width: usize, height: usize, channels: usize) -> Vec<u8> {
        (0..width * height * channels)
            .map(|i| ((i * 7 + i / (width * channels) * 13) % 251) as u8)
            .collect()
    }

    fn png(pixels: &[u8], width: u32, height: u32, color: ExtendedColorType) -> Vec<u8> {
        let mut out = Vec::new();
        PngEncoder::new(&mut out)
            .write_image(pixels, width, height, color)
            .unwrap();
        out
    }

    fn message(format: &str, data: Vec<u8>) -> CompressedImage {
        CompressedImage {
            header: Header {
                frame_id: "cam".into(),
                ..Header::default()
            },
            format: format.into(),
            data,
        }
    }

    #[test]
    fn png_is_exact_in_the_encoding_the_format_names() {
        let rgb = pattern(31, 17, 3);
        let data = png(&rgb, 31, 17, ExtendedColorType::Rgb8);
        let as_rgb =
            image_msg_from_compressed(&message("rgb8; png compressed rgb8", data.clone())).unwrap();
        assert_eq!(
            (
                as_rgb.encoding.as_str(),
                as_rgb.width,
                as_rgb.height,
                as_rgb.step
            ),
            ("rgb8", 31, 17, 93)
        );
        assert_eq!(as_rgb.data, rgb);
        assert_eq!(as_rgb.header.frame_id, "cam");
        // No original encoding: bgr8, as image_transport gives colour.
        let as_bgr = image_msg_from_compressed(&message("", data)).unwrap();
        assert_eq!(as_bgr.encoding, "bgr8");
        assert_eq!(as_bgr.data[..3], [rgb[2], rgb[1], rgb[0]]);

        let grey = pattern(20, 10, 1);
        let mono = image_msg_from_compressed(&message(
            "mono8; png compressed",
            png(&grey, 20, 10, ExtendedColorType::L8),
        ))
        .unwrap();
        assert_eq!((mono.encoding.as_str(), mono.data), ("mono8", grey));

        // 16 bits (big-endian in the PNG) come out little-endian.
        let deep: Vec<u16> = (0..12u16).map(|v| v * 4099).collect();
        let native: Vec<u8> = deep.iter().flat_map(|v| v.to_ne_bytes()).collect();
        let mono16 = image_msg_from_compressed(&message(
            "16UC1; png compressed",
            png(&native, 4, 3, ExtendedColorType::L16),
        ))
        .unwrap();
        let little_endian: Vec<u8> = deep.iter().flat_map(|v| v.to_le_bytes()).collect();
        assert_eq!(
            (mono16.encoding.as_str(), mono16.step, mono16.data),
            ("mono16", 8, little_endian)
        );
    }

    #[test]
    fn jpeg_decodes_within_its_loss_in_the_encoding_asked_for() {
        let (width, height) = (64u32, 48u32);
        // Smooth content: JPEG keeps it within a few grey levels.
        let rgb: Vec<u8> = (0..height)
            .flat_map(|y| (0..width).flat_map(move |x| [(x * 3) as u8, (y * 4) as u8, 128]))
            .collect();
        let mut data = Vec::new();
        JpegEncoder::new_with_quality(&mut data, 95)
            .write_image(&rgb, width, height, ExtendedColorType::Rgb8)
            .unwrap();
        for (format, encoding) in [
            ("bgr8; jpeg compressed bgr8", "bgr8"),
            ("rgb8; jpeg compressed bgr8", "rgb8"),
            ("rgba8; jpeg compressed bgr8", "rgba8"),
            ("bgra8; jpeg compressed bgr8", "bgra8"),
            ("jpeg", "bgr8"),
            ("", "bgr8"),
        ] {
            let image = image_msg_from_compressed(&message(format, data.clone())).unwrap();
            assert_eq!(image.encoding, encoding, "{format}");
            let channels = encoding.len() - 1;
            assert_eq!(image.data.len(), rgb.len() / 3 * channels, "{format}");
            let worst = image
                .data
                .chunks_exact(channels)
                .zip(rgb.chunks_exact(3))
                .map(|(got, want)| {
                    if channels == 4 {
                        assert_eq!(got[3], 255, "{format}: alpha");
                    }
                    let got = if encoding.starts_with("bgr") {
                        [got[2], got[1], got[0]]
                    } else {
                        [got[0], got[1], got[2]]
                    };
                    (0..3).map(|c| got[c].abs_diff(want[c])).max().unwrap_or(0)
                })
                .max()
                .unwrap_or(0);
            assert!(worst <= 6, "{format}: {worst} grey levels off");
        }
        let mono =
            image_msg_from_compressed(&message("mono8; jpeg compressed mono8", data)).unwrap();
        assert_eq!((mono.encoding.as_str(), mono.step), ("mono8", 64));
    }

    #[test]
    fn bad_data_and_formats_are_named() {
        let grey = pattern(8, 8, 1);
        let png_data = png(&grey, 8, 8, ExtendedColorType::L8);
        let err = |format: &str, data: Vec<u8>| {
            image_msg_from_compressed(&message(format, data))
                .unwrap_err()
                .to_string()
        };
        let unknown = err("bgr8; tiff compressed bgr8", png_data.clone());
        assert!(unknown.contains("\"tiff\""), "{unknown}");
        let mismatch = err("mono8; jpeg compressed mono8", png_data.clone());
        assert!(
            mismatch.contains("says jpeg") && mismatch.contains("is png"),
            "{mismatch}"
        );
        let nothing = err("", vec![1, 2, 3]);
        assert!(nothing.contains("neither JPEG nor PNG"), "{nothing}");
        let truncated = err("", png_data[..png_data.len() / 2].to_vec());
        assert!(
            truncated.contains("png data could not be decoded"),
            "{truncated}"
        );
        let mut jpeg = Vec::new();
        JpegEncoder::new_with_quality(&mut jpeg, 90)
            .write_image(&grey, 8, 8, ExtendedColorType::L8)
            .unwrap();
        let cut = err("jpeg", jpeg[..20].to_vec());
        assert!(cut.contains("jpeg data could not be decoded"), "{cut}");
        // A header that declares a huge image is refused before anything is allocated.
        let mut huge = jpeg.clone();
        let sof = huge
            .windows(2)
            .position(|w| w == [0xFF, 0xC0])
            .expect("a baseline JPEG");
        huge[sof + 5..sof + 9].copy_from_slice(&[0x75, 0x30, 0x75, 0x30]);
        let declared = err("jpeg", huge);
        assert!(declared.contains("30000x30000"), "{declared}");
        let deep = err("mono16; jpeg compressed", jpeg);
        assert!(deep.contains("cannot be given as mono16"), "{deep}");
    }
}
