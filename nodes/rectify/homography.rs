//! Images warped by a homography: the image side of uncalibrated rectification
//! (`stereocal rectify --uncalibrated`), where each camera's rectified image is its raw
//! image seen through `rectified_from_image`, with no lens model.

use nalgebra::Matrix3;
use stereocal_msgs::sensor_msgs::{CameraInfo, Image as ImageMsg};
use stereocal_vision::image::Image;
use stereocal_vision::rectify::{RectifyMap, RemapOptions, remap_into};

use super::stage::{RectifyError, shape_like};
use crate::convert::{decode_image_into, msg_from_image};

/// Warps images by one homography. The map is built once per image size and reused, as
/// are the decode and output buffers.
pub struct HomographyWarper {
    /// Maps rectified pixels back to raw ones: the inverse of `rectified_from_image`.
    image_from_rectified: Matrix3<f64>,
    options: RemapOptions,
    map: Option<RectifyMap>,
    source: Image,
    warped: Image,
}

impl HomographyWarper {
    /// A warper by `rectified_from_image` (pixel centres at integer coordinates), with
    /// the given interpolation and threading; `None` when the homography is singular.
    pub fn new(rectified_from_image: &Matrix3<f64>, options: RemapOptions) -> Option<Self> {
        let image_from_rectified = rectified_from_image.try_inverse()?;
        Some(Self {
            image_from_rectified,
            options,
            map: None,
            source: Image::zeros_u8(0, 0, 1),
            warped: Image::zeros_u8(0, 0, 1),
        })
    }

    /// The rectified image of `image`: its size, encoding and header; pixels whose
    /// source lies outside the image are black.
    pub fn warp(&mut self, image: &ImageMsg) -> Result<ImageMsg, RectifyError> {
        let (width, height) = (image.width as usize, image.height as usize);
        let map = match self.map.take() {
            Some(map) if (map.width(), map.height()) == (width, height) => map,
            _ => {
                let h = self.image_from_rectified;
                RectifyMap::from_fn(width, height, move |x, y| {
                    let p = h * nalgebra::Vector3::new(x as f64, y as f64, 1.0);
                    (p.x / p.z, p.y / p.z)
                })?
            }
        };
        let map = self.map.insert(map);
        let encoding = decode_image_into(image, &mut self.source)?;
        shape_like(&mut self.warped, &self.source, map);
        remap_into(&self.source, map, &mut self.warped, self.options)?;
        Ok(msg_from_image(
            &self.warped,
            encoding,
            image.header.clone(),
        )?)
    }
}

/// The camera_info of an image rectified without calibration: its header and size, `K`,
/// `R` and `P` all zero and no distortion model, which ROS reads as an uncalibrated
/// camera (`K[0] == 0`), so that nothing takes metric meaning from it.
pub fn uncalibrated_info(image: &ImageMsg) -> CameraInfo {
    CameraInfo {
        header: image.header.clone(),
        height: image.height,
        width: image.width,
        distortion_model: String::new(),
        d: Vec::new(),
        k: [0.0; 9],
        r: [0.0; 9],
        p: [0.0; 12],
        binning_x: 0,
        binning_y: 0,
        roi: Default::default(),
    }
}
