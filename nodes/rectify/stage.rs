//! The rectify pipeline stage shared by `rectify_node` and `stereocal rectify`: a raw
//! `sensor_msgs/Image` and its `sensor_msgs/CameraInfo` in, the rectified image out,
//! like image_proc's RectifyNode.

use std::sync::Arc;

use stereocal_msgs::sensor_msgs::{CameraInfo, Image as ImageMsg};
use stereocal_vision::image::{Image, Samples};
use stereocal_vision::rectify::{
    MapError, RectifyMap, RemapError, RemapOptions, remap_into, remap_u8_into,
};
use thiserror::Error;

use crate::convert::{
    CameraInfoError, Encoding, ImageMsgError, calibrated_camera_from_info, decode_image_into,
    msg_from_image,
};

/// Why a frame could not be rectified. The [`Rectifier`] stays usable: the next frame
/// is processed afresh.
#[derive(Debug, Error, PartialEq)]
pub enum RectifyError {
    /// The image message is malformed or has an unsupported encoding.
    #[error("image: {0}")]
    Image(#[from] ImageMsgError),
    /// The camera_info message does not describe a usable calibration.
    #[error(transparent)]
    CameraInfo(#[from] CameraInfoError),
    /// The image and its camera_info disagree on the size.
    #[error(
        "image is {image_width}x{image_height} but its camera_info is {info_width}x{info_height}"
    )]
    SizeMismatch {
        /// Image width.
        image_width: u32,
        /// Image height.
        image_height: u32,
        /// camera_info width.
        info_width: u32,
        /// camera_info height.
        info_height: u32,
    },
    /// No rectification map exists for this camera_info.
    #[error("rectification map: {0}")]
    Map(#[from] MapError),
    /// Remapping failed.
    #[error("remap: {0}")]
    Remap(#[from] RemapError),
}

/// What [`Rectifier::rectify`] produced for one frame.
#[derive(Debug, PartialEq)]
pub enum Rectified {
    /// The rectified image: the input's encoding and header, camera_info's size.
    Image(ImageMsg),
    /// Nothing to publish: the camera_info is uncalibrated (`K[0] == 0`). `warning` is
    /// set on the first such frame after a calibrated one (or the start), so that a
    /// node warns once, like image_proc.
    Uncalibrated {
        /// The message to log, only the first time.
        warning: Option<String>,
    },
}

/// The map of the last camera_info, kept until a camera_info that differs in a field
/// that matters arrives.
#[derive(Default)]
struct MapCache {
    /// The camera_info (header cleared) the map was built from, and the map.
    cached: Option<(CameraInfo, Arc<RectifyMap>)>,
    builds: usize,
}

impl MapCache {
    /// The map of `info`, built only when `info` differs from the cached one.
    fn get(&mut self, info: &CameraInfo) -> Result<&Arc<RectifyMap>, RectifyError> {
        let cached = match self.cached.take() {
            Some(cached) if same_calibration(&cached.0, info) => cached,
            _ => {
                let camera = calibrated_camera_from_info(info)?;
                let map = RectifyMap::new(
                    &camera.model,
                    &camera.rectified_from_camera,
                    &camera.projection,
                    info.width as usize,
                    info.height as usize,
                )?;
                self.builds += 1;
                let key = CameraInfo {
                    header: Default::default(),
                    ..info.clone()
                };
                (key, Arc::new(map))
            }
        };
        Ok(&self.cached.insert(cached).1)
    }
}

/// Rectifies images with maps built from their camera_info. Maps are built only when
/// the camera_info changes (size, distortion, `K`, `R`, `P`, binning or ROI; not the
/// header), never per frame; decode and output buffers are reused from frame to frame.
pub struct Rectifier {
    options: RemapOptions,
    maps: MapCache,
    warned_uncalibrated: bool,
    source: Image,
    rectified: Image,
}

impl Rectifier {
    /// A rectifier with the given interpolation and threading.
    pub fn new(options: RemapOptions) -> Self {
        Self {
            options,
            maps: MapCache::default(),
            warned_uncalibrated: false,
            source: Image::zeros_u8(0, 0, 1),
            rectified: Image::zeros_u8(0, 0, 1),
        }
    }

    /// The interpolation and threading in use.
    pub fn options(&self) -> RemapOptions {
        self.options
    }

    /// Gives back the data of an image this rectifier made, once nobody holds it any
    /// more, for the next frame to be remapped into without allocating.
    pub fn recycle(&mut self, image: ImageMsg) {
        self.rectified.samples = Samples::U8(image.data);
    }

    /// How many maps have been built so far.
    pub fn map_builds(&self) -> usize {
        self.maps.builds
    }

    /// Rectifies `image` with `info`, the camera_info of the same camera. The output has
    /// the input's encoding and header and camera_info's size.
    pub fn rectify(
        &mut self,
        image: &ImageMsg,
        info: &CameraInfo,
    ) -> Result<Rectified, RectifyError> {
        match self.plan(&image.header.frame_id, info)? {
            Plan::Uncalibrated { warning } => Ok(Rectified::Uncalibrated { warning }),
            Plan::Remap(map) => Ok(Rectified::Image(remap_image_msg(
                image,
                &map,
                self.options,
                &mut self.source,
                &mut self.rectified,
            )?)),
        }
    }

    /// What a frame of `frame_id` with `info` needs, for callers that remap on other
    /// threads with [`remap_image_msg`]: the map (built only when `info` changed), or
    /// nothing when `info` is uncalibrated. Frames must be planned in their order, for
    /// the warning about an uncalibrated camera_info is given once.
    pub fn plan(&mut self, frame_id: &str, info: &CameraInfo) -> Result<Plan, RectifyError> {
        if info.k[0] == 0.0 {
            let warning = (!self.warned_uncalibrated).then(|| {
                format!(
                    "camera_info of frame {frame_id:?} is uncalibrated (K[0] == 0): publishing no rectified images until a calibrated camera_info arrives"
                )
            });
            self.warned_uncalibrated = true;
            return Ok(Plan::Uncalibrated { warning });
        }
        self.warned_uncalibrated = false;
        Ok(Plan::Remap(self.maps.get(info)?.clone()))
    }
}

/// What [`Rectifier::plan`] decided for a frame.
pub enum Plan {
    /// Remap the frame with this map.
    Remap(Arc<RectifyMap>),
    /// Publish nothing: the camera_info is uncalibrated (see [`Rectified::Uncalibrated`]).
    Uncalibrated {
        /// The message to log, only the first time.
        warning: Option<String>,
    },
}

/// Rectifies `image` with `map`, decoding it into `source` and remapping into
/// `rectified` (both reshaped as needed, so that buffers can be reused from frame to
/// frame). The output has the input's encoding and header and the map's size.
///
/// An 8-bit image whose rows are packed (`step` is the row's bytes) is remapped
/// straight from the message, and into the vector of `rectified` that becomes the
/// output's data: no pixel is copied. [`Rectifier::recycle`] gives such a vector back.
pub fn remap_image_msg(
    image: &ImageMsg,
    map: &RectifyMap,
    options: RemapOptions,
    source: &mut Image,
    rectified: &mut Image,
) -> Result<ImageMsg, RectifyError> {
    if (image.width as usize, image.height as usize) != (map.width(), map.height()) {
        return Err(RectifyError::SizeMismatch {
            image_width: image.width,
            image_height: image.height,
            info_width: map.width() as u32,
            info_height: map.height() as u32,
        });
    }
    if let Some(encoding) = Encoding::from_ros_name(&image.encoding)
        && encoding.bytes_per_sample() == 1
    {
        let channels = encoding.channels();
        let row_bytes = image.width as usize * channels;
        if image.step as usize == row_bytes && image.data.len() == row_bytes * image.height as usize
        {
            let mut data = match &mut rectified.samples {
                Samples::U8(v) => std::mem::take(v),
                Samples::U16(_) => Vec::new(),
            };
            data.resize(map.width() * map.height() * channels, 0);
            remap_u8_into(
                &image.data,
                image.width as usize,
                image.height as usize,
                channels,
                map,
                &mut data,
                options,
            )?;
            return Ok(ImageMsg {
                header: image.header.clone(),
                height: image.height,
                width: image.width,
                encoding: image.encoding.clone(),
                is_bigendian: 0,
                step: image.step,
                data,
            });
        }
    }
    let encoding = decode_image_into(image, source)?;
    shape_like(rectified, source, map);
    remap_into(source, map, rectified, options)?;
    Ok(msg_from_image(rectified, encoding, image.header.clone())?)
}

/// Whether two camera_infos give the same map: every field but the header.
fn same_calibration(a: &CameraInfo, b: &CameraInfo) -> bool {
    a.width == b.width
        && a.height == b.height
        && a.distortion_model == b.distortion_model
        && a.d == b.d
        && a.k == b.k
        && a.r == b.r
        && a.p == b.p
        && a.binning_x == b.binning_x
        && a.binning_y == b.binning_y
        && a.roi == b.roi
}

/// Gives `dst` the map's size and the source's channels and sample type, keeping its
/// buffer when it already fits.
pub(crate) fn shape_like(dst: &mut Image, src: &Image, map: &RectifyMap) {
    let len = map.width() * map.height() * src.channels;
    match (&src.samples, &mut dst.samples) {
        (Samples::U8(_), Samples::U8(v)) => v.resize(len, 0),
        (Samples::U16(_), Samples::U16(v)) => v.resize(len, 0),
        (Samples::U8(_), other) => *other = Samples::U8(vec![0; len]),
        (Samples::U16(_), other) => *other = Samples::U16(vec![0; len]),
    }
    dst.width = map.width();
    dst.height = map.height();
    dst.channels = src.channels;
}
