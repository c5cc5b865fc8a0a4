//! `sensor_msgs` messages and the `sensor_msgs/srv/SetCameraInfo` service.

use serde::{Deserialize, Serialize};

use crate::ros_message::ros_message;
use crate::std_msgs::Header;

/// Distortion model names of `sensor_msgs/distortion_models.hpp`.
pub mod distortion_models {
    /// Brown-Conrady: `d = [k1, k2, p1, p2, k3]`.
    pub const PLUMB_BOB: &str = "plumb_bob";
    /// Rational: `d = [k1, k2, p1, p2, k3, k4, k5, k6]`.
    pub const RATIONAL_POLYNOMIAL: &str = "rational_polynomial";
    /// Fisheye equidistant: `d = [k1, k2, k3, k4]`.
    pub const EQUIDISTANT: &str = "equidistant";
}

/// Image encoding names of `sensor_msgs/image_encodings.hpp` used by stereocal.
pub mod image_encodings {
    /// 8-bit greyscale.
    pub const MONO8: &str = "mono8";
    /// 16-bit greyscale.
    pub const MONO16: &str = "mono16";
    /// 8-bit red, green, blue.
    pub const RGB8: &str = "rgb8";
    /// 8-bit blue, green, red.
    pub const BGR8: &str = "bgr8";
    /// 8-bit red, green, blue, alpha.
    pub const RGBA8: &str = "rgba8";
    /// 8-bit blue, green, red, alpha.
    pub const BGRA8: &str = "bgra8";
    /// One 32-bit float channel (disparity images use it).
    pub const TYPE_32FC1: &str = "32FC1";
}

/// `sensor_msgs/msg/Image`: an uncompressed image, rows of `step` bytes.
#[derive(Debug, Clone, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct Image {
    /// Acquisition time and optical frame.
    pub header: Header,
    /// Number of rows.
    pub height: u32,
    /// Number of columns.
    pub width: u32,
    /// Pixel encoding, see [`image_encodings`].
    pub encoding: String,
    /// 1 if multi-byte channels are big-endian.
    pub is_bigendian: u8,
    /// Bytes per row, including any padding.
    pub step: u32,
    /// `step * height` bytes of pixel data.
    #[serde(with = "serde_bytes")]
    pub data: Vec<u8>,
}

ros_message!(
    Image,
    "sensor_msgs/msg/Image",
    "std_msgs/Header header\nuint32 height\nuint32 width\nstring encoding\nuint8 is_bigendian\nuint32 step\nuint8[] data\n",
    Header
);

/// `sensor_msgs/msg/CompressedImage`: an image in a compressed file format.
#[derive(Debug, Clone, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct CompressedImage {
    /// Acquisition time and optical frame.
    pub header: Header,
    /// Compression format, e.g. `jpeg` or `png`.
    pub format: String,
    /// The compressed file's bytes.
    #[serde(with = "serde_bytes")]
    pub data: Vec<u8>,
}

ros_message!(
    CompressedImage,
    "sensor_msgs/msg/CompressedImage",
    "std_msgs/Header header\nstring format\nuint8[] data\n",
    Header
);

/// `sensor_msgs/msg/RegionOfInterest`: a sub-window of an image, in pixels.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct RegionOfInterest {
    /// Leftmost column of the region.
    pub x_offset: u32,
    /// Topmost row of the region.
    pub y_offset: u32,
    /// Number of rows; 0 with `width` 0 means the full image.
    pub height: u32,
    /// Number of columns.
    pub width: u32,
    /// Whether a rectified image should be computed for this region.
    pub do_rectify: bool,
}

ros_message!(
    RegionOfInterest,
    "sensor_msgs/msg/RegionOfInterest",
    "uint32 x_offset\nuint32 y_offset\nuint32 height\nuint32 width\nbool do_rectify\n"
);

/// `sensor_msgs/msg/CameraInfo`: intrinsics, distortion, rectification and projection
/// of one camera. Matrices are row-major; pixel centres are at integer coordinates.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct CameraInfo {
    /// Time and optical frame of the image this describes.
    pub header: Header,
    /// Calibrated image height in pixels.
    pub height: u32,
    /// Calibrated image width in pixels.
    pub width: u32,
    /// Distortion model name, see [`distortion_models`].
    pub distortion_model: String,
    /// Distortion coefficients in the model's order.
    pub d: Vec<f64>,
    /// Intrinsic matrix of the raw (distorted) image, 3x3 row-major.
    pub k: [f64; 9],
    /// Rectification rotation `rectified_from_camera`, 3x3 row-major.
    pub r: [f64; 9],
    /// Projection matrix of the rectified image, 3x4 row-major.
    pub p: [f64; 12],
    /// Horizontal binning factor (0 or 1: none).
    pub binning_x: u32,
    /// Vertical binning factor (0 or 1: none).
    pub binning_y: u32,
    /// Region of interest of the published image within the calibrated one.
    pub roi: RegionOfInterest,
}

ros_message!(
    CameraInfo,
    "sensor_msgs/msg/CameraInfo",
    "std_msgs/Header header\nuint32 height\nuint32 width\nstring distortion_model\nfloat64[] d\nfloat64[9] k\nfloat64[9] r\nfloat64[12] p\nuint32 binning_x\nuint32 binning_y\nsensor_msgs/RegionOfInterest roi\n",
    Header,
    RegionOfInterest
);

/// `sensor_msgs/msg/PointField`: one field (channel) of each point in a
/// [`PointCloud2`]: where it lies in the point and what type it has.
#[derive(Debug, Clone, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct PointField {
    /// Field name, e.g. `x`, `y`, `z` or `rgb`.
    pub name: String,
    /// Byte offset of the field from the start of the point.
    pub offset: u32,
    /// Element type, one of the datatype constants ([`PointField::FLOAT32`], ...).
    pub datatype: u8,
    /// Number of elements in the field.
    pub count: u32,
}

impl PointField {
    /// `datatype` of a signed 8-bit integer.
    pub const INT8: u8 = 1;
    /// `datatype` of an unsigned 8-bit integer.
    pub const UINT8: u8 = 2;
    /// `datatype` of a signed 16-bit integer.
    pub const INT16: u8 = 3;
    /// `datatype` of an unsigned 16-bit integer.
    pub const UINT16: u8 = 4;
    /// `datatype` of a signed 32-bit integer.
    pub const INT32: u8 = 5;
    /// `datatype` of an unsigned 32-bit integer.
    pub const UINT32: u8 = 6;
    /// `datatype` of a 32-bit float.
    pub const FLOAT32: u8 = 7;
    /// `datatype` of a 64-bit float.
    pub const FLOAT64: u8 = 8;
}

ros_message!(
    PointField,
    "sensor_msgs/msg/PointField",
    "uint8 INT8=1\nuint8 UINT8=2\nuint8 INT16=3\nuint8 UINT16=4\nuint8 INT32=5\nuint8 UINT32=6\nuint8 FLOAT32=7\nuint8 FLOAT64=8\nstring name\nuint32 offset\nuint8 datatype\nuint32 count\n"
);

/// `sensor_msgs/msg/PointCloud2`: a set of points, `height` rows of `width` points,
/// each point `point_step` bytes laid out as `fields` describe. Coordinates are in
/// metres in the header's frame.
#[derive(Debug, Clone, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct PointCloud2 {
    /// Acquisition time and the frame of the points.
    pub header: Header,
    /// Number of rows; 1 for an unordered cloud.
    pub height: u32,
    /// Number of points per row (all points for an unordered cloud).
    pub width: u32,
    /// Layout of one point.
    pub fields: Vec<PointField>,
    /// Whether multi-byte fields are big-endian.
    pub is_bigendian: bool,
    /// Bytes per point.
    pub point_step: u32,
    /// Bytes per row.
    pub row_step: u32,
    /// `row_step * height` bytes of point data.
    #[serde(with = "serde_bytes")]
    pub data: Vec<u8>,
    /// True if no point is invalid (no NaN or infinite coordinates).
    pub is_dense: bool,
}

ros_message!(
    PointCloud2,
    "sensor_msgs/msg/PointCloud2",
    "std_msgs/Header header\nuint32 height\nuint32 width\nsensor_msgs/PointField[] fields\nbool is_bigendian\nuint32 point_step\nuint32 row_step\nuint8[] data\nbool is_dense\n",
    Header,
    PointField
);

/// `sensor_msgs/srv` services.
pub mod srv {
    use serde::{Deserialize, Serialize};

    use super::CameraInfo;
    use crate::ros_message::ros_message;

    /// Request of `sensor_msgs/srv/SetCameraInfo`: store this calibration.
    #[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
    pub struct SetCameraInfoRequest {
        /// The new calibration.
        pub camera_info: CameraInfo,
    }

    ros_message!(
        SetCameraInfoRequest,
        "sensor_msgs/srv/SetCameraInfo_Request",
        "sensor_msgs/CameraInfo camera_info\n",
        CameraInfo
    );

    /// Response of `sensor_msgs/srv/SetCameraInfo`.
    #[derive(Debug, Clone, PartialEq, Eq, Default, Serialize, Deserialize)]
    pub struct SetCameraInfoResponse {
        /// Whether the calibration was stored.
        pub success: bool,
        /// Why not, or a confirmation.
        pub status_message: String,
    }

    ros_message!(
        SetCameraInfoResponse,
        "sensor_msgs/srv/SetCameraInfo_Response",
        "bool success\nstring status_message\n"
    );
}
