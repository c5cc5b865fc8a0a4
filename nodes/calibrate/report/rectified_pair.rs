//! The rectified pair: one frame's raw images rectified with the calibration, side by
//! side (one above the other for a vertical rig), with epipolar lines drawn across both
//! at regular intervals, embedded as a PNG data URI. A mono camera shows its undistorted
//! image instead.

use base64::Engine;
use base64::engine::general_purpose::STANDARD;
use image::ImageEncoder;
use image::codecs::png::{CompressionType, FilterType, PngEncoder};
use nalgebra::{Matrix3, Matrix3x4};
use stereocal_vision::image::{Image, Samples};
use stereocal_vision::rectify::{RectifyMap, RemapOptions, StereoLayout, remap};

use super::ReportError;
use super::html::escape;
use super::sample::{SampleImage, SampleImages};
use super::views::stamp_text;
use crate::calibrate::stage::{CalibrationOutcome, CameraResult};
use crate::convert::Encoding;

/// Epipolar lines drawn across a rectified pair.
pub const EPIPOLAR_LINES: usize = 16;
/// Pixels on each side of an epipolar line's centre: lines are `2 * half + 1` pixels
/// wide, to stay visible when the picture is shown scaled down.
pub const EPIPOLAR_LINE_HALF_WIDTH: usize = 1;
/// The epipolar lines' colour, pure green: never a grey pixel of a mono image.
const LINE: [u8; 3] = [0, 255, 0];
/// The palette index of the lines in a picture of mono images; indices below it are
/// grey levels.
const LINE_INDEX: u8 = 255;

/// An 8-bit picture being composed: palette indices (grey levels and [`LINE_INDEX`])
/// when every image is mono, RGB otherwise.
struct Picture {
    width: usize,
    height: usize,
    /// 1 (palette indices) or 3 (RGB).
    channels: usize,
    pixels: Vec<u8>,
}

impl Picture {
    fn new(width: usize, height: usize, channels: usize) -> Self {
        Self {
            width,
            height,
            channels,
            pixels: vec![0; width * height * channels],
        }
    }

    fn line(&self) -> &'static [u8] {
        if self.channels == 1 {
            &[LINE_INDEX]
        } else {
            &LINE
        }
    }

    /// Copies `pixels` (this picture's channels, `width` wide) with its top-left at
    /// `(x, y)`.
    fn paste(&mut self, pixels: &[u8], width: usize, x: usize, y: usize) {
        let n = self.channels;
        for (r, row) in pixels.chunks_exact(width * n).enumerate() {
            let start = ((y + r) * self.width + x) * n;
            self.pixels[start..start + row.len()].copy_from_slice(row);
        }
    }

    /// Draws a horizontal line centred on row `y`.
    fn row(&mut self, y: usize) {
        let (n, line) = (self.channels, self.line());
        let rows = y.saturating_sub(EPIPOLAR_LINE_HALF_WIDTH)
            ..(y + EPIPOLAR_LINE_HALF_WIDTH + 1).min(self.height);
        let span = rows.start * self.width * n..rows.end * self.width * n;
        for pixel in self.pixels[span].chunks_exact_mut(n) {
            pixel.copy_from_slice(line);
        }
    }

    /// Draws a vertical line centred on column `x`.
    fn column(&mut self, x: usize) {
        let (n, line) = (self.channels, self.line());
        let columns = x.saturating_sub(EPIPOLAR_LINE_HALF_WIDTH)
            ..(x + EPIPOLAR_LINE_HALF_WIDTH + 1).min(self.width);
        for row in self.pixels.chunks_exact_mut(self.width * n) {
            for pixel in row[columns.start * n..columns.end * n].chunks_exact_mut(n) {
                pixel.copy_from_slice(line);
            }
        }
    }

    /// The picture as PNG: a palette image for mono sources (a third of RGB's bytes to
    /// filter and compress, which `image` does not write), RGB otherwise.
    fn png(&self) -> Result<Vec<u8>, ReportError> {
        let mut out = Vec::new();
        if self.channels == 1 {
            let mut palette: Vec<u8> = (0..LINE_INDEX).flat_map(|g| [g, g, g]).collect();
            palette.extend_from_slice(&LINE);
            let mut encoder = png::Encoder::new(&mut out, self.width as u32, self.height as u32);
            encoder.set_color(png::ColorType::Indexed);
            encoder.set_depth(png::BitDepth::Eight);
            encoder.set_palette(palette);
            encoder.set_compression(png::Compression::Fast);
            encoder.set_filter(png::Filter::Sub);
            let mut writer = encoder.write_header()?;
            writer.write_image_data(&self.pixels)?;
            writer.finish()?;
        } else {
            PngEncoder::new_with_quality(&mut out, CompressionType::Fast, FilterType::Sub)
                .write_image(
                    &self.pixels,
                    self.width as u32,
                    self.height as u32,
                    image::ExtendedColorType::Rgb8,
                )?;
        }
        Ok(out)
    }
}

/// Where the lines go along an axis of `length` pixels: [`EPIPOLAR_LINES`] evenly spaced
/// positions, half a spacing from the edges.
pub(crate) fn line_positions(length: usize) -> Vec<usize> {
    let spacing = (length / EPIPOLAR_LINES).max(1);
    (0..EPIPOLAR_LINES)
        .map(|k| spacing / 2 + k * spacing)
        .filter(|&p| p < length)
        .collect()
}

/// The rectified pair (stereo) or undistorted image (mono) of `sample`, as an HTML
/// figure of class `rectified` with the picture's size in `data-width`,
/// `data-height` and the epipolar lines' centres in `data-epipolar-rows` (horizontal
/// rig) or `data-epipolar-columns` (vertical rig), space-separated.
pub(crate) fn figure(
    outcome: &CalibrationOutcome,
    sample: &SampleImages,
) -> Result<String, ReportError> {
    if sample.images.len() != outcome.cameras.len() {
        return Err(ReportError::Sample(format!(
            "{} images for {} cameras",
            sample.images.len(),
            outcome.cameras.len()
        )));
    }
    let stamp = stamp_text(&sample.stamp);
    let channels = if sample
        .images
        .iter()
        .all(|s| matches!(s.encoding, Encoding::Mono8 | Encoding::Mono16))
    {
        1
    } else {
        3
    };
    let (picture, lines, caption) = match (
        &outcome.stereo,
        outcome.cameras.as_slice(),
        sample.images.as_slice(),
    ) {
        (Some(stereo), [left, right], [left_image, right_image]) => {
            let r = &stereo.rectification;
            let (width, height) = (r.image_size.0 as usize, r.image_size.1 as usize);
            let (left_rgb, right_rgb) = rayon::join(
                || {
                    rectified_pixels(
                        left,
                        left_image,
                        r.left_rectified_from_original.matrix(),
                        &r.left_projection,
                        (width, height),
                        channels,
                    )
                },
                || {
                    rectified_pixels(
                        right,
                        right_image,
                        r.right_rectified_from_original.matrix(),
                        &r.right_projection,
                        (width, height),
                        channels,
                    )
                },
            );
            let (left_rgb, right_rgb) = (left_rgb?, right_rgb?);
            match r.layout {
                StereoLayout::Horizontal => {
                    let mut picture = Picture::new(2 * width, height, channels);
                    picture.paste(&left_rgb, width, 0, 0);
                    picture.paste(&right_rgb, width, width, 0);
                    let rows = line_positions(height);
                    rows.iter().for_each(|&y| picture.row(y));
                    (
                        picture,
                        format!(" data-epipolar-rows=\"{}\"", join(&rows)),
                        format!(
                            "Frame {stamp}, left and right rectified with the calibration. Green: every {}th row; a corner should sit at the same height in both images.",
                            height / EPIPOLAR_LINES
                        ),
                    )
                }
                StereoLayout::Vertical => {
                    let mut picture = Picture::new(width, 2 * height, channels);
                    picture.paste(&left_rgb, width, 0, 0);
                    picture.paste(&right_rgb, width, 0, height);
                    let columns = line_positions(width);
                    columns.iter().for_each(|&x| picture.column(x));
                    (
                        picture,
                        format!(" data-epipolar-columns=\"{}\"", join(&columns)),
                        format!(
                            "Frame {stamp}, first (top) and second (bottom) camera rectified with the calibration. Green: every {}th column; a corner should sit in the same column in both images.",
                            width / EPIPOLAR_LINES
                        ),
                    )
                }
            }
        }
        (None, [camera], [image]) => {
            let model = &camera.calibration.camera;
            let (width, height) = (model.width as usize, model.height as usize);
            let projection = model.intrinsics.matrix().insert_column(3, 0.0);
            let pixels = rectified_pixels(
                camera,
                image,
                &Matrix3::identity(),
                &projection,
                (width, height),
                channels,
            )?;
            let mut picture = Picture::new(width, height, channels);
            picture.paste(&pixels, width, 0, 0);
            (
                picture,
                String::new(),
                format!(
                    "Frame {stamp} undistorted with the calibration (same camera matrix): the board's edges should be straight."
                ),
            )
        }
        _ => {
            return Err(ReportError::Sample(
                "a sample needs one image per camera of a mono or stereo calibration".to_owned(),
            ));
        }
    };
    let png = picture.png()?;
    Ok(format!(
        "<figure class=\"rectified\" data-width=\"{}\" data-height=\"{}\"{lines}><img class=\"picture\" alt=\"rectified images\" width=\"{}\" height=\"{}\" src=\"data:image/png;base64,{}\"><figcaption>{}</figcaption></figure>\n",
        picture.width,
        picture.height,
        picture.width,
        picture.height,
        STANDARD.encode(&png),
        escape(&caption)
    ))
}

fn join(values: &[usize]) -> String {
    values
        .iter()
        .map(usize::to_string)
        .collect::<Vec<_>>()
        .join(" ")
}

/// `sample` remapped through the map of `camera` with `rectified_from_original`
/// (camera_info `R`) and `projection` (`P`) at `size`, as a picture's pixels: grey
/// palette indices (`channels` 1, mono images only) or 8-bit RGB (`channels` 3).
fn rectified_pixels(
    camera: &CameraResult,
    sample: &SampleImage,
    rectified_from_original: &Matrix3<f64>,
    projection: &Matrix3x4<f64>,
    size: (usize, usize),
    channels: usize,
) -> Result<Vec<u8>, ReportError> {
    let model = &camera.calibration.camera;
    let image = &sample.image;
    if (image.width, image.height) != (model.width as usize, model.height as usize) {
        return Err(ReportError::Sample(format!(
            "the {} image is {}x{}, the calibration {}x{}",
            camera.name, image.width, image.height, model.width, model.height
        )));
    }
    let map = RectifyMap::new(model, rectified_from_original, projection, size.0, size.1).map_err(
        |source| ReportError::Map {
            camera: camera.name.clone(),
            source,
        },
    )?;
    let rectified =
        remap(image, &map, RemapOptions::default()).map_err(|source| ReportError::Remap {
            camera: camera.name.clone(),
            source,
        })?;
    Ok(if channels == 1 {
        grey_indices(&rectified)
    } else {
        rgb(&rectified, sample.encoding)
    })
}

/// A mono image as grey palette indices: 8-bit levels (16-bit samples keep their high
/// byte) below [`LINE_INDEX`], white becoming the next lighter grey.
fn grey_indices(image: &Image) -> Vec<u8> {
    let channels = image.channels.max(1);
    match &image.samples {
        Samples::U8(v) => v
            .iter()
            .step_by(channels)
            .map(|&g| g.min(LINE_INDEX - 1))
            .collect(),
        Samples::U16(v) => v
            .iter()
            .step_by(channels)
            .map(|&g| ((g >> 8) as u8).min(LINE_INDEX - 1))
            .collect(),
    }
}

/// An image of `encoding` as 8-bit RGB (16-bit samples keep their high byte, alpha is
/// dropped).
fn rgb(image: &Image, encoding: Encoding) -> Vec<u8> {
    let channels = image.channels.max(1);
    let swap = matches!(encoding, Encoding::Bgr8 | Encoding::Bgra8);
    let mut out = Vec::with_capacity(image.width * image.height * 3);
    let mut push = |pixel: &[u8]| match pixel {
        [b, g, r, ..] if swap => out.extend_from_slice(&[*r, *g, *b]),
        [r, g, b, ..] => out.extend_from_slice(&[*r, *g, *b]),
        [grey, ..] => out.extend_from_slice(&[*grey, *grey, *grey]),
        [] => {}
    };
    match &image.samples {
        Samples::U8(v) => v.chunks_exact(channels).for_each(&mut push),
        Samples::U16(v) => v.chunks_exact(channels).for_each(|pixel| {
            let mut high = [0u8; 4];
            for (h, s) in high.iter_mut().zip(pixel) {
                *h = (s >> 8) as u8;
            }
            push(&high[..pixel.len().min(4)]);
        }),
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_encoding_becomes_rgb() {
        let image = |channels, samples| Image::new(2, 1, channels, samples).unwrap();
        let mono16 = image(1, Samples::U16(vec![0x1234, 0xff00]));
        assert_eq!(
            rgb(&mono16, Encoding::Mono16),
            [0x12, 0x12, 0x12, 0xff, 0xff, 0xff]
        );
        let bgr = image(3, Samples::U8(vec![1, 2, 3, 4, 5, 6]));
        assert_eq!(rgb(&bgr, Encoding::Bgr8), [3, 2, 1, 6, 5, 4]);
        assert_eq!(rgb(&bgr, Encoding::Rgb8), [1, 2, 3, 4, 5, 6]);
        let bgra = image(4, Samples::U8(vec![1, 2, 3, 9, 4, 5, 6, 9]));
        assert_eq!(rgb(&bgra, Encoding::Bgra8), [3, 2, 1, 6, 5, 4]);
        assert_eq!(rgb(&bgra, Encoding::Rgba8), [1, 2, 3, 4, 5, 6]);
    }

    #[test]
    fn mono_images_become_grey_indices_below_the_line() {
        let mono8 = Image::new(3, 1, 1, Samples::U8(vec![0, 254, 255])).unwrap();
        assert_eq!(grey_indices(&mono8), [0, 254, 254]);
        let mono16 = Image::new(2, 1, 1, Samples::U16(vec![0x1234, 0xffff])).unwrap();
        assert_eq!(grey_indices(&mono16), [0x12, 254]);
    }

    #[test]
    fn lines_are_evenly_spaced_inside_the_image() {
        assert_eq!(
            line_positions(720),
            (0..16).map(|k| 22 + 45 * k).collect::<Vec<_>>()
        );
        assert_eq!(line_positions(8), (0..8).collect::<Vec<_>>());
    }
}
