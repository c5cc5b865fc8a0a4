//! Organized point clouds (sensor_msgs/PointCloud2) from disparities, in the four field
//! layouts of stereo_image_proc's PointCloudNode: `x`, `y`, `z` float32, with or without
//! a packed `rgb` float32, padded to 16 or 32 bytes a point or packed tight.

use rayon::prelude::*;
use stereocal_msgs::sensor_msgs::{PointCloud2, PointField};
use stereocal_msgs::std_msgs::Header;
use stereocal_vision::image::{Image, Samples};
use stereocal_vision::stereo::Reprojection;
use thiserror::Error;

/// How the points of a cloud are laid out.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct CloudLayout {
    /// An `rgb` field (float32 holding `0x00RRGGBB`, as PCL packs it).
    pub color: bool,
    /// No padding: 12 bytes a point (16 with colour) instead of PCL's aligned 16 (32).
    pub avoid_padding: bool,
}

impl CloudLayout {
    /// Bytes a point.
    pub fn point_step(self) -> u32 {
        match (self.color, self.avoid_padding) {
            (false, true) => 12,
            (true, true) | (false, false) => 16,
            (true, false) => 32,
        }
    }

    /// The fields of a point.
    pub fn fields(self) -> Vec<PointField> {
        let field = |name: &str, offset: u32| PointField {
            name: name.to_owned(),
            offset,
            datatype: PointField::FLOAT32,
            count: 1,
        };
        let mut fields = vec![field("x", 0), field("y", 4), field("z", 8)];
        if self.color {
            fields.push(field("rgb", if self.avoid_padding { 12 } else { 16 }));
        }
        fields
    }
}

/// Why a cloud cannot be made.
#[derive(Debug, Error, PartialEq)]
pub enum CloudError {
    /// The colour image is not the disparity's size.
    #[error(
        "the colour image is {image_width}x{image_height} but the disparity is {width}x{height}"
    )]
    SizeMismatch {
        /// Image width.
        image_width: usize,
        /// Image height.
        image_height: usize,
        /// Disparity width.
        width: usize,
        /// Disparity height.
        height: usize,
    },
    /// The colour image's encoding cannot be coloured from.
    #[error("cannot colour points from a {0}-channel 16-bit image")]
    Encoding(usize),
}

/// Channel order of a colour image.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ChannelOrder {
    /// Red first (rgb8, rgba8).
    Rgb,
    /// Blue first (bgr8, bgra8).
    Bgr,
}

/// The organized cloud of `disparities` (`width` a row, raw disparities `x - x_right`,
/// NaN invalid) through `reprojection`, in the rectified left camera frame, with
/// `header`; coloured from `color` (the left image; mono is grey) when the layout has
/// colour. Points without a disparity, or at infinity, are NaN; `is_dense` is false.
pub fn cloud(
    disparities: &[f32],
    width: usize,
    reprojection: &Reprojection,
    color: Option<(&Image, ChannelOrder)>,
    layout: CloudLayout,
    header: Header,
) -> Result<PointCloud2, CloudError> {
    let height = disparities.len().checked_div(width).unwrap_or(0);
    if let Some((image, _)) = color {
        if (image.width, image.height) != (width, height) {
            return Err(CloudError::SizeMismatch {
                image_width: image.width,
                image_height: image.height,
                width,
                height,
            });
        }
        if matches!(image.samples, Samples::U16(_)) && image.channels != 1 {
            return Err(CloudError::Encoding(image.channels));
        }
    }
    let step = layout.point_step() as usize;
    let mut data = vec![0u8; step * disparities.len()];
    let rgb_offset = if layout.avoid_padding { 12 } else { 16 };
    // The reprojection in single precision, per row and per pixel: z = f B / (d - (cx_l -
    // cx_r)), x = (u - cx) z / fx, y = (v - cy) z / fy.
    let r = reprojection;
    let focal_baseline = (r.fx * r.baseline) as f32;
    let offset = (r.cx_left - r.cx_right) as f32;
    let (cx, inverse_fx) = (r.cx_left as f32, (1.0 / r.fx) as f32);
    let (cy, inverse_fy) = (r.cy as f32, (1.0 / r.fy) as f32);
    data.par_chunks_mut(step * width.max(1))
        .zip(disparities.par_chunks(width.max(1)))
        .enumerate()
        .for_each(|(v, (row, row_disparities))| {
            let ray_y = (v as f32 - cy) * inverse_fy;
            for (u, (point, &d)) in row.chunks_exact_mut(step).zip(row_disparities).enumerate() {
                let shifted = d - offset;
                let xyz = if shifted > 0.0 {
                    let z = focal_baseline / shifted;
                    [(u as f32 - cx) * inverse_fx * z, ray_y * z, z]
                } else {
                    // No disparity (NaN), or a point at or beyond infinity.
                    [f32::NAN; 3]
                };
                point[0..4].copy_from_slice(&xyz[0].to_le_bytes());
                point[4..8].copy_from_slice(&xyz[1].to_le_bytes());
                point[8..12].copy_from_slice(&xyz[2].to_le_bytes());
            }
            if let (true, Some((image, order))) = (layout.color, color) {
                let first = v * width;
                for (u, point) in row.chunks_exact_mut(step).enumerate() {
                    let rgb = packed_rgb(image, order, first + u);
                    point[rgb_offset..rgb_offset + 4].copy_from_slice(&rgb.to_le_bytes());
                }
            }
        });
    Ok(PointCloud2 {
        header,
        height: height as u32,
        width: width as u32,
        fields: layout.fields(),
        is_bigendian: false,
        point_step: step as u32,
        row_step: (step * width) as u32,
        data,
        is_dense: false,
    })
}

/// `0x00RRGGBB` of pixel `i` (16-bit grey scaled to 8 bits).
#[inline]
fn packed_rgb(image: &Image, order: ChannelOrder, i: usize) -> u32 {
    let channels = image.channels;
    let (r, g, b) = match &image.samples {
        Samples::U8(s) if channels >= 3 => {
            let p = &s[i * channels..i * channels + 3];
            match order {
                ChannelOrder::Rgb => (p[0], p[1], p[2]),
                ChannelOrder::Bgr => (p[2], p[1], p[0]),
            }
        }
        Samples::U8(s) => (s[i * channels], s[i * channels], s[i * channels]),
        Samples::U16(s) => {
            let v = (s[i] >> 8) as u8;
            (v, v, v)
        }
    };
    (u32::from(r) << 16) | (u32::from(g) << 8) | u32::from(b)
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Matrix3x4;

    fn reprojection() -> Reprojection {
        let left = Matrix3x4::new(
            100.0, 0.0, 1.5, 0.0, 0.0, 100.0, 0.5, 0.0, 0.0, 0.0, 1.0, 0.0,
        );
        let mut right = left;
        right[(0, 3)] = -100.0 * 0.1;
        Reprojection::from_projections(&left, &right).unwrap()
    }

    #[test]
    fn every_layout_has_stereo_image_procs_fields_and_steps() {
        let disparities = [5.0, f32::NAN, 10.0, 0.0, 2.5, 5.0, 5.0, 5.0];
        let colour = Image::new(4, 2, 3, Samples::U8((0..24).map(|v| v as u8).collect())).unwrap();
        for (color, avoid_padding, step, rgb_at) in [
            (false, false, 16, None),
            (true, false, 32, Some(16)),
            (false, true, 12, None),
            (true, true, 16, Some(12)),
        ] {
            let layout = CloudLayout {
                color,
                avoid_padding,
            };
            let cloud = cloud(
                &disparities,
                4,
                &reprojection(),
                Some((&colour, ChannelOrder::Bgr)),
                layout,
                Header::default(),
            )
            .unwrap();
            assert_eq!((cloud.width, cloud.height, cloud.point_step), (4, 2, step));
            assert_eq!(cloud.row_step, 4 * step);
            assert_eq!(cloud.data.len(), 8 * step as usize);
            let names: Vec<&str> = cloud.fields.iter().map(|f| f.name.as_str()).collect();
            assert_eq!(names.len(), if color { 4 } else { 3 });
            let read = |i: usize, at: usize| {
                let o = i * step as usize + at;
                f32::from_le_bytes(cloud.data[o..o + 4].try_into().unwrap())
            };
            // Pixel 0: z = f * B / d = 100 * 0.1 / 5 = 2, x = (0 - 1.5) * 2 / 100.
            assert!((read(0, 8) - 2.0).abs() < 1e-6);
            assert!((read(0, 0) + 0.03).abs() < 1e-6);
            // No disparity, and a point at infinity: NaN.
            assert!(read(1, 8).is_nan() && read(3, 0).is_nan());
            if let Some(at) = rgb_at {
                // Pixel 2 of a bgr8 image: b 6, g 7, r 8.
                let o = 2 * step as usize + at;
                let rgb = u32::from_le_bytes(cloud.data[o..o + 4].try_into().unwrap());
                assert_eq!(rgb, (8 << 16) | (7 << 8) | 6);
            }
        }
    }

    #[test]
    fn a_colour_image_of_another_size_is_refused() {
        let grey = Image::zeros_u8(3, 2, 1);
        let error = cloud(
            &[1.0; 8],
            4,
            &reprojection(),
            Some((&grey, ChannelOrder::Rgb)),
            CloudLayout {
                color: true,
                avoid_padding: false,
            },
            Header::default(),
        )
        .unwrap_err();
        assert!(error.to_string().contains("3x2"), "{error}");
    }
}
