//! `sensor_msgs/Image` <-> [`Image`] for the encodings remap works on.

use stereocal_msgs::sensor_msgs;
use stereocal_msgs::std_msgs::Header;
use stereocal_vision::image::{Image, Samples};
use thiserror::Error;

/// The `sensor_msgs/Image` encodings that convert to and from vision images.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Encoding {
    /// One 8-bit grey channel.
    Mono8,
    /// One 16-bit grey channel.
    Mono16,
    /// 8-bit red, green, blue.
    Rgb8,
    /// 8-bit blue, green, red.
    Bgr8,
    /// 8-bit red, green, blue, alpha.
    Rgba8,
    /// 8-bit blue, green, red, alpha.
    Bgra8,
}

impl Encoding {
    /// Every supported encoding.
    pub const ALL: [Encoding; 6] = [
        Self::Mono8,
        Self::Mono16,
        Self::Rgb8,
        Self::Bgr8,
        Self::Rgba8,
        Self::Bgra8,
    ];

    /// The name in `sensor_msgs/Image.encoding`.
    pub fn ros_name(self) -> &'static str {
        match self {
            Self::Mono8 => "mono8",
            Self::Mono16 => "mono16",
            Self::Rgb8 => "rgb8",
            Self::Bgr8 => "bgr8",
            Self::Rgba8 => "rgba8",
            Self::Bgra8 => "bgra8",
        }
    }

    /// The encoding a `sensor_msgs/Image.encoding` names, if supported.
    pub fn from_ros_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|e| e.ros_name() == name)
    }

    /// Interleaved channels per pixel.
    pub fn channels(self) -> usize {
        match self {
            Self::Mono8 | Self::Mono16 => 1,
            Self::Rgb8 | Self::Bgr8 => 3,
            Self::Rgba8 | Self::Bgra8 => 4,
        }
    }

    /// Bytes per channel sample.
    pub fn bytes_per_sample(self) -> usize {
        match self {
            Self::Mono16 => 2,
            _ => 1,
        }
    }

    /// Bytes per pixel.
    pub fn bytes_per_pixel(self) -> usize {
        self.channels() * self.bytes_per_sample()
    }
}

/// Why a `sensor_msgs/Image` and a vision [`Image`] could not be converted.
#[derive(Debug, Error, PartialEq, Eq)]
pub enum ImageMsgError {
    /// `encoding` is not one this conversion handles.
    #[error(
        "unsupported image encoding {0:?}: expected one of mono8, mono16, rgb8, bgr8, rgba8, bgra8"
    )]
    UnsupportedEncoding(String),
    /// `width` or `height` is zero.
    #[error("image size {width}x{height}: width and height must be at least 1")]
    ZeroSize {
        /// `width` of the message.
        width: u64,
        /// `height` of the message.
        height: u64,
    },
    /// `step` is shorter than a row of pixels.
    #[error("image step {step} is less than width * bytes per pixel = {min_step} ({encoding})")]
    StepTooSmall {
        /// `step` of the message.
        step: u32,
        /// `width * bytes_per_pixel`.
        min_step: u64,
        /// The encoding name.
        encoding: &'static str,
    },
    /// `data` does not hold `step * height` bytes.
    #[error("image data holds {actual} bytes, expected step * height = {expected}")]
    DataLength {
        /// `data.len()`.
        actual: usize,
        /// `step * height`.
        expected: u64,
    },
    /// The vision image's channels or sample type do not fit the requested encoding.
    #[error(
        "a {encoding} image needs {expected_channels} channel(s) of {expected_bits}-bit samples, got {channels} channel(s) of {bits}-bit samples"
    )]
    EncodingMismatch {
        /// The requested encoding name.
        encoding: &'static str,
        /// Channels the encoding has.
        expected_channels: usize,
        /// Sample bits the encoding has.
        expected_bits: usize,
        /// Channels of the image.
        channels: usize,
        /// Sample bits of the image.
        bits: usize,
    },
    /// A dimension of the vision image does not fit the message's `u32` fields.
    #[error(
        "image of {width}x{height} (row of {row_bytes} bytes) exceeds sensor_msgs/Image's u32 fields"
    )]
    TooLarge {
        /// Width in pixels.
        width: usize,
        /// Height in pixels.
        height: usize,
        /// Bytes per row.
        row_bytes: usize,
    },
}

/// Converts a `sensor_msgs/Image` to a vision image, returning its encoding beside it.
/// Honours `step` (row padding is dropped) and `is_bigendian` for 16-bit samples.
pub fn image_from_msg(msg: &sensor_msgs::Image) -> Result<(Encoding, Image), ImageMsgError> {
    let mut image = Image::zeros_u8(0, 0, 1);
    let encoding = decode_image_into(msg, &mut image)?;
    Ok((encoding, image))
}

/// Like [`image_from_msg`], but writes into `out`, reusing its sample buffer when it has
/// the right sample type; `out` is left untouched on error.
pub fn decode_image_into(
    msg: &sensor_msgs::Image,
    out: &mut Image,
) -> Result<Encoding, ImageMsgError> {
    let encoding = Encoding::from_ros_name(&msg.encoding)
        .ok_or_else(|| ImageMsgError::UnsupportedEncoding(msg.encoding.clone()))?;
    let (width, height) = (msg.width as usize, msg.height as usize);
    if width == 0 || height == 0 {
        return Err(ImageMsgError::ZeroSize {
            width: msg.width.into(),
            height: msg.height.into(),
        });
    }
    let row_bytes = width * encoding.bytes_per_pixel();
    let step = msg.step as usize;
    if step < row_bytes {
        return Err(ImageMsgError::StepTooSmall {
            step: msg.step,
            min_step: row_bytes as u64,
            encoding: encoding.ros_name(),
        });
    }
    let expected = u64::from(msg.step) * u64::from(msg.height);
    if msg.data.len() as u64 != expected {
        return Err(ImageMsgError::DataLength {
            actual: msg.data.len(),
            expected,
        });
    }
    let rows = msg.data.chunks_exact(step).map(|row| &row[..row_bytes]);
    let len = width * height * encoding.channels();
    // Take the old buffer out to reuse its allocation when the sample type matches.
    let previous = std::mem::replace(&mut out.samples, Samples::U8(Vec::new()));
    out.samples = match encoding.bytes_per_sample() {
        1 => {
            let mut samples = match previous {
                Samples::U8(v) => v,
                Samples::U16(_) => Vec::new(),
            };
            samples.clear();
            samples.reserve(len);
            rows.for_each(|row| samples.extend_from_slice(row));
            Samples::U8(samples)
        }
        _ => {
            let mut samples = match previous {
                Samples::U16(v) => v,
                Samples::U8(_) => Vec::new(),
            };
            samples.clear();
            samples.reserve(len);
            let big_endian = msg.is_bigendian != 0;
            for row in rows {
                samples.extend(row.chunks_exact(2).map(|b| {
                    let bytes = [b[0], b[1]];
                    if big_endian {
                        u16::from_be_bytes(bytes)
                    } else {
                        u16::from_le_bytes(bytes)
                    }
                }));
            }
            Samples::U16(samples)
        }
    };
    out.width = width;
    out.height = height;
    out.channels = encoding.channels();
    Ok(encoding)
}

/// Converts a vision image to a tightly packed `sensor_msgs/Image` (`step = width *
/// bytes_per_pixel`; 16-bit samples little-endian, `is_bigendian = 0`) with `header`.
pub fn msg_from_image(
    image: &Image,
    encoding: Encoding,
    header: Header,
) -> Result<sensor_msgs::Image, ImageMsgError> {
    let bits = match image.samples {
        Samples::U8(_) => 8,
        Samples::U16(_) => 16,
    };
    if image.channels != encoding.channels() || bits != 8 * encoding.bytes_per_sample() {
        return Err(ImageMsgError::EncodingMismatch {
            encoding: encoding.ros_name(),
            expected_channels: encoding.channels(),
            expected_bits: 8 * encoding.bytes_per_sample(),
            channels: image.channels,
            bits,
        });
    }
    let row_bytes = image.width * encoding.bytes_per_pixel();
    let too_large = || ImageMsgError::TooLarge {
        width: image.width,
        height: image.height,
        row_bytes,
    };
    let width = u32::try_from(image.width).map_err(|_| too_large())?;
    let height = u32::try_from(image.height).map_err(|_| too_large())?;
    let step = u32::try_from(row_bytes).map_err(|_| too_large())?;
    let data = match &image.samples {
        Samples::U8(v) => v.clone(),
        Samples::U16(v) => v.iter().flat_map(|s| s.to_le_bytes()).collect(),
    };
    Ok(sensor_msgs::Image {
        header,
        height,
        width,
        encoding: encoding.ros_name().to_owned(),
        is_bigendian: 0,
        step,
        data,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn header() -> Header {
        Header {
            frame_id: "camera_optical".to_owned(),
            ..Header::default()
        }
    }

    /// A `width`x`height` message whose every byte differs from its neighbours, with
    /// `padding` extra bytes per row.
    fn patterned_msg(
        encoding: Encoding,
        width: u32,
        height: u32,
        padding: u32,
    ) -> sensor_msgs::Image {
        let step = width * encoding.bytes_per_pixel() as u32 + padding;
        let data = (0..step * height).map(|i| (i * 7 % 251) as u8).collect();
        sensor_msgs::Image {
            header: header(),
            height,
            width,
            encoding: encoding.ros_name().to_owned(),
            is_bigendian: 0,
            step,
            data,
        }
    }

    #[test]
    fn every_encoding_round_trips_through_a_packed_message() {
        for encoding in Encoding::ALL {
            let msg = patterned_msg(encoding, 5, 3, 0);
            let (decoded, image) = image_from_msg(&msg).unwrap();
            assert_eq!(decoded, encoding);
            assert_eq!(
                (image.width, image.height, image.channels),
                (5, 3, encoding.channels())
            );
            let back = msg_from_image(&image, encoding, header()).unwrap();
            assert_eq!(back, msg, "{encoding:?}");
        }
    }

    #[test]
    fn row_padding_is_dropped_and_pixels_kept() {
        let padded = patterned_msg(Encoding::Rgb8, 4, 3, 5);
        let (_, image) = image_from_msg(&padded).unwrap();
        let Samples::U8(samples) = &image.samples else {
            panic!("rgb8 gives 8-bit samples");
        };
        for y in 0..3 {
            let row = &padded.data[y * 17..y * 17 + 12];
            assert_eq!(&samples[y * 12..(y + 1) * 12], row);
        }
        let packed = msg_from_image(&image, Encoding::Rgb8, header()).unwrap();
        assert_eq!(packed.step, 12);
        assert_eq!(packed.data.len(), 36);
    }

    #[test]
    fn sixteen_bit_samples_honour_is_bigendian() {
        let mut msg = patterned_msg(Encoding::Mono16, 2, 1, 0);
        msg.data = vec![0x12, 0x34, 0xab, 0xcd];
        msg.is_bigendian = 1;
        let (_, big) = image_from_msg(&msg).unwrap();
        assert_eq!(big.samples, Samples::U16(vec![0x1234, 0xabcd]));
        msg.is_bigendian = 0;
        let (_, little) = image_from_msg(&msg).unwrap();
        assert_eq!(little.samples, Samples::U16(vec![0x3412, 0xcdab]));
        let back = msg_from_image(&big, Encoding::Mono16, header()).unwrap();
        assert_eq!(
            (back.is_bigendian, back.data),
            (0, vec![0x34, 0x12, 0xcd, 0xab])
        );
    }

    #[test]
    fn decoding_into_reuses_and_retypes_the_buffer() {
        let mut out = Image::zeros_u8(1, 1, 1);
        decode_image_into(&patterned_msg(Encoding::Mono16, 3, 2, 0), &mut out).unwrap();
        assert!(matches!(&out.samples, Samples::U16(v) if v.len() == 6));
        let encoding =
            decode_image_into(&patterned_msg(Encoding::Bgr8, 2, 2, 1), &mut out).unwrap();
        assert_eq!(encoding, Encoding::Bgr8);
        assert!(matches!(&out.samples, Samples::U8(v) if v.len() == 12));
        assert_eq!((out.width, out.height, out.channels), (2, 2, 3));
    }

    #[test]
    fn unsupported_encoding_names_the_encoding() {
        let mut msg = patterned_msg(Encoding::Mono8, 2, 2, 0);
        msg.encoding = "bayer_rggb8".to_owned();
        let err = image_from_msg(&msg).unwrap_err();
        assert_eq!(
            err,
            ImageMsgError::UnsupportedEncoding("bayer_rggb8".to_owned())
        );
        assert!(err.to_string().contains("bayer_rggb8"));
        assert!(err.to_string().contains("mono8"));
    }

    #[test]
    fn zero_size_is_rejected() {
        let mut msg = patterned_msg(Encoding::Mono8, 2, 2, 0);
        msg.width = 0;
        msg.step = 0;
        msg.data.clear();
        assert_eq!(
            image_from_msg(&msg).unwrap_err(),
            ImageMsgError::ZeroSize {
                width: 0,
                height: 2
            }
        );
    }

    #[test]
    fn step_shorter_than_a_row_is_rejected() {
        let mut msg = patterned_msg(Encoding::Rgb8, 4, 2, 0);
        msg.step = 11;
        msg.data.truncate(22);
        let err = image_from_msg(&msg).unwrap_err();
        assert_eq!(
            err,
            ImageMsgError::StepTooSmall {
                step: 11,
                min_step: 12,
                encoding: "rgb8"
            }
        );
        assert!(err.to_string().contains("step 11"));
    }

    #[test]
    fn data_length_other_than_step_times_height_is_rejected() {
        let mut msg = patterned_msg(Encoding::Mono16, 4, 3, 2);
        msg.data.pop();
        assert_eq!(
            image_from_msg(&msg).unwrap_err(),
            ImageMsgError::DataLength {
                actual: 29,
                expected: 30
            }
        );
        msg.data.extend([0, 0]);
        assert_eq!(
            image_from_msg(&msg).unwrap_err(),
            ImageMsgError::DataLength {
                actual: 31,
                expected: 30
            }
        );
    }

    #[test]
    fn encoding_must_fit_the_image() {
        let grey = Image::zeros_u8(2, 2, 1);
        let err = msg_from_image(&grey, Encoding::Rgb8, header()).unwrap_err();
        assert_eq!(
            err,
            ImageMsgError::EncodingMismatch {
                encoding: "rgb8",
                expected_channels: 3,
                expected_bits: 8,
                channels: 1,
                bits: 8,
            }
        );
        assert!(matches!(
            msg_from_image(&grey, Encoding::Mono16, header()),
            Err(ImageMsgError::EncodingMismatch {
                expected_bits: 16,
                bits: 8,
                ..
            })
        ));
    }
}
