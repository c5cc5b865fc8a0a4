//! CDR bytes of every message type against fixtures produced independently by the
//! Python `rosbags` library (`interop/check_msgs_cdr.py --write` made them from the
//! same sample values built here), plus round trips and truncated input.

use serde::Serialize;
use serde::de::DeserializeOwned;
use stereocal_msgs::builtin_interfaces::Time;
use stereocal_msgs::cdr::{self, CdrError};
use stereocal_msgs::geometry_msgs::{
    Point, Pose, PoseStamped, PoseWithCovariance, PoseWithCovarianceStamped, Quaternion, Transform,
    TransformStamped, Vector3,
};
use stereocal_msgs::rcl_interfaces::srv::{
    DescribeParametersResponse, GetParameterTypesResponse, GetParametersRequest,
    GetParametersResponse, ListParametersRequest, ListParametersResponse,
    SetParametersAtomicallyResponse, SetParametersRequest, SetParametersResponse,
};
use stereocal_msgs::rcl_interfaces::{
    FloatingPointRange, IntegerRange, ListParametersResult, Parameter, ParameterDescriptor,
    ParameterEvent, ParameterValue, SetParametersResult, parameter_type,
};
use stereocal_msgs::rosgraph_msgs::Clock;
use stereocal_msgs::sensor_msgs::srv::{SetCameraInfoRequest, SetCameraInfoResponse};
use stereocal_msgs::sensor_msgs::{
    CameraInfo, CompressedImage, Image, PointCloud2, PointField, RegionOfInterest,
};
use stereocal_msgs::std_msgs::{self, Header};
use stereocal_msgs::std_srvs::srv::{TriggerRequest, TriggerResponse};
use stereocal_msgs::stereo_msgs::DisparityImage;
use stereocal_msgs::tf2_msgs::TFMessage;

macro_rules! fixture {
    ($name:literal) => {
        include_bytes!(concat!("fixtures/", $name, ".cdr")).as_slice()
    };
}

fn time() -> Time {
    Time {
        sec: 1_700_000_000,
        nanosec: 123_456_789,
    }
}

fn header(frame_id: &str) -> Header {
    Header {
        stamp: time(),
        frame_id: frame_id.to_owned(),
    }
}

fn roi() -> RegionOfInterest {
    RegionOfInterest {
        x_offset: 1,
        y_offset: 2,
        height: 3,
        width: 4,
        do_rectify: true,
    }
}

fn image() -> Image {
    Image {
        header: header("cam"),
        height: 2,
        width: 3,
        encoding: "rgb8".to_owned(),
        is_bigendian: 0,
        step: 9,
        data: (0..18).collect(),
    }
}

fn camera_info() -> CameraInfo {
    CameraInfo {
        header: header("left"),
        height: 480,
        width: 640,
        distortion_model: "plumb_bob".to_owned(),
        d: vec![-0.1, 0.01, 0.001, -0.002, 0.0003],
        k: [500.0, 0.0, 319.5, 0.0, 501.0, 239.5, 0.0, 0.0, 1.0],
        r: [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0],
        p: [
            500.0, 0.0, 319.5, -30.0, 0.0, 501.0, 239.5, 0.0, 0.0, 0.0, 1.0, 0.0,
        ],
        binning_x: 1,
        binning_y: 2,
        roi: RegionOfInterest {
            x_offset: 10,
            y_offset: 20,
            height: 30,
            width: 40,
            do_rectify: true,
        },
    }
}

/// Two rows of two points `x, y, z: f32, intensity: u16` and two bytes of padding;
/// the last point is invalid (NaN), so the cloud is not dense.
fn point_cloud2() -> PointCloud2 {
    let points: [([f32; 3], u16); 4] = [
        ([0.5, -0.25, 1.5], 100),
        ([1.0, 0.0, 2.0], 200),
        ([-1.5, 0.75, 3.0], 300),
        ([f32::NAN; 3], 0),
    ];
    let field = |name: &str, offset, datatype| PointField {
        name: name.to_owned(),
        offset,
        datatype,
        count: 1,
    };
    PointCloud2 {
        header: header("left_optical"),
        height: 2,
        width: 2,
        fields: vec![
            field("x", 0, PointField::FLOAT32),
            field("y", 4, PointField::FLOAT32),
            field("z", 8, PointField::FLOAT32),
            field("intensity", 12, PointField::UINT16),
        ],
        is_bigendian: false,
        point_step: 16,
        row_step: 32,
        data: points
            .iter()
            .flat_map(|(xyz, intensity)| {
                xyz.iter()
                    .flat_map(|c| c.to_le_bytes())
                    .chain(intensity.to_le_bytes())
                    .chain([0, 0])
            })
            .collect(),
        is_dense: false,
    }
}

fn vector3() -> Vector3 {
    Vector3 {
        x: 1.5,
        y: -2.25,
        z: 3.0,
    }
}

fn point() -> Point {
    Point {
        x: 0.1,
        y: 0.2,
        z: 0.3,
    }
}

fn quaternion() -> Quaternion {
    Quaternion {
        x: 0.0,
        y: 0.0,
        z: 0.6,
        w: 0.8,
    }
}

fn pose() -> Pose {
    Pose {
        position: point(),
        orientation: quaternion(),
    }
}

fn transform() -> Transform {
    Transform {
        translation: vector3(),
        rotation: quaternion(),
    }
}

fn pose_with_covariance() -> PoseWithCovariance {
    PoseWithCovariance {
        pose: pose(),
        covariance: std::array::from_fn(|i| i as f64 * 0.25 - 3.0),
    }
}

fn transform_stamped(child: &str) -> TransformStamped {
    TransformStamped {
        header: header("base"),
        child_frame_id: child.to_owned(),
        transform: transform(),
    }
}

fn disparity_image() -> DisparityImage {
    let disparities = [1.0f32, 2.5, -1.0, 64.0];
    DisparityImage {
        header: header("left"),
        image: Image {
            header: header("left"),
            height: 2,
            width: 2,
            encoding: "32FC1".to_owned(),
            is_bigendian: 0,
            step: 8,
            data: disparities.iter().flat_map(|d| d.to_le_bytes()).collect(),
        },
        f: 500.0,
        t: 0.12,
        valid_window: roi(),
        min_disparity: 0.0,
        max_disparity: 64.0,
        delta_d: 0.0625,
    }
}

/// Encoding gives the fixture's bytes, decoding the fixture gives the value back,
/// and every strict prefix of the fixture is rejected with an error.
fn check<T>(value: T, fixture: &[u8])
where
    T: Serialize + DeserializeOwned + PartialEq + std::fmt::Debug,
{
    let encoded = cdr::to_bytes(&value).expect("sample encodes");
    assert_eq!(encoded, fixture, "{}", std::any::type_name::<T>());
    let decoded: T = cdr::from_bytes(fixture).expect("fixture decodes");
    assert_eq!(decoded, value);
    for len in 0..fixture.len() {
        let result = cdr::from_bytes::<T>(&fixture[..len]);
        assert!(
            result.is_err(),
            "{} decoded from {len} of {} bytes",
            std::any::type_name::<T>(),
            fixture.len()
        );
    }
}

#[test]
fn builtin_and_std_msgs_match_rosbags() {
    check(time(), fixture!("builtin_interfaces__msg__Time"));
    check(header("left_optical"), fixture!("std_msgs__msg__Header"));
}

#[test]
fn sensor_msgs_match_rosbags() {
    check(image(), fixture!("sensor_msgs__msg__Image"));
    check(
        CompressedImage {
            header: header("cam"),
            format: "png".to_owned(),
            data: vec![137, 80, 78, 71, 1, 2, 3],
        },
        fixture!("sensor_msgs__msg__CompressedImage"),
    );
    check(roi(), fixture!("sensor_msgs__msg__RegionOfInterest"));
    check(camera_info(), fixture!("sensor_msgs__msg__CameraInfo"));
    check(
        PointField {
            name: "normal".to_owned(),
            offset: 16,
            datatype: PointField::FLOAT32,
            count: 3,
        },
        fixture!("sensor_msgs__msg__PointField"),
    );
    check(point_cloud2(), fixture!("sensor_msgs__msg__PointCloud2"));
}

#[test]
fn geometry_msgs_match_rosbags() {
    check(vector3(), fixture!("geometry_msgs__msg__Vector3"));
    check(point(), fixture!("geometry_msgs__msg__Point"));
    check(quaternion(), fixture!("geometry_msgs__msg__Quaternion"));
    check(pose(), fixture!("geometry_msgs__msg__Pose"));
    check(
        PoseStamped {
            header: header("base"),
            pose: pose(),
        },
        fixture!("geometry_msgs__msg__PoseStamped"),
    );
    check(
        pose_with_covariance(),
        fixture!("geometry_msgs__msg__PoseWithCovariance"),
    );
    check(
        PoseWithCovarianceStamped {
            header: header("camera"),
            pose: pose_with_covariance(),
        },
        fixture!("geometry_msgs__msg__PoseWithCovarianceStamped"),
    );
    check(transform(), fixture!("geometry_msgs__msg__Transform"));
    check(
        transform_stamped("tool0"),
        fixture!("geometry_msgs__msg__TransformStamped"),
    );
}

#[test]
fn tf_and_stereo_msgs_match_rosbags() {
    check(
        TFMessage {
            transforms: vec![transform_stamped("tool0"), transform_stamped("camera")],
        },
        fixture!("tf2_msgs__msg__TFMessage"),
    );
    check(
        disparity_image(),
        fixture!("stereo_msgs__msg__DisparityImage"),
    );
}

#[test]
fn string_matches_rosbags() {
    check(
        std_msgs::String {
            data: r#"{"samples": 3}"#.to_owned(),
        },
        fixture!("std_msgs__msg__String"),
    );
}

#[test]
fn services_match_rosbags() {
    check(
        SetCameraInfoRequest {
            camera_info: camera_info(),
        },
        fixture!("sensor_msgs__srv__SetCameraInfo_Request"),
    );
    check(
        SetCameraInfoResponse {
            success: true,
            status_message: "stored".to_owned(),
        },
        fixture!("sensor_msgs__srv__SetCameraInfo_Response"),
    );
    check(
        TriggerRequest::default(),
        fixture!("std_srvs__srv__Trigger_Request"),
    );
    check(
        TriggerResponse {
            success: false,
            message: "no board".to_owned(),
        },
        fixture!("std_srvs__srv__Trigger_Response"),
    );
}

#[test]
fn big_image_round_trips_with_data_in_one_block() {
    let width = 1920u32;
    let height = 1080u32;
    let image = Image {
        header: header("left_optical"),
        height,
        width,
        encoding: "mono8".to_owned(),
        is_bigendian: 0,
        step: width,
        data: (0..width * height).map(|i| (i * 7 % 251) as u8).collect(),
    };
    let bytes = cdr::to_bytes(&image).expect("encodes");
    let data_offset = bytes.len() - image.data.len();
    assert_eq!(&bytes[data_offset..], image.data.as_slice());
    assert_eq!(
        &bytes[data_offset - 4..data_offset],
        (width * height).to_le_bytes().as_slice()
    );
    let decoded: Image = cdr::from_bytes(&bytes).expect("decodes");
    assert_eq!(decoded, image);
}

#[test]
fn trailing_alignment_padding_is_accepted_but_more_is_not() {
    let mut bytes = fixture!("std_msgs__msg__Header").to_vec();
    bytes.extend_from_slice(&[0, 0, 0]);
    assert_eq!(
        cdr::from_bytes::<Header>(&bytes).expect("padded"),
        header("left_optical")
    );
    bytes.push(0);
    match cdr::from_bytes::<Header>(&bytes) {
        Err(CdrError::TrailingBytes {
            offset: 29,
            trailing: 4,
            ..
        }) => {}
        other => panic!("expected trailing-bytes error, got {other:?}"),
    }
}

#[test]
fn the_header_of_a_stamped_message_decodes_alone() {
    for (bytes, frame_id) in [
        (fixture!("sensor_msgs__msg__Image"), "cam"),
        (fixture!("sensor_msgs__msg__CompressedImage"), "cam"),
        (fixture!("sensor_msgs__msg__CameraInfo"), "left"),
    ] {
        let decoded: Header = cdr::prefix_from_bytes(bytes).expect("header");
        assert_eq!(decoded, header(frame_id));
        assert!(matches!(
            cdr::from_bytes::<Header>(bytes),
            Err(CdrError::TrailingBytes { .. })
        ));
    }
    let truncated = &fixture!("sensor_msgs__msg__Image")[..12];
    assert!(matches!(
        cdr::prefix_from_bytes::<Header>(truncated),
        Err(CdrError::Malformed { .. })
    ));
}

#[test]
fn big_endian_samples_decode() {
    let time = Time {
        sec: -2,
        nanosec: 300_000_000,
    };
    let mut bytes = vec![0x00, 0x00, 0x00, 0x00];
    bytes.extend_from_slice(&(-2i32).to_be_bytes());
    bytes.extend_from_slice(&300_000_000u32.to_be_bytes());
    assert_eq!(cdr::from_bytes::<Time>(&bytes).expect("decodes"), time);
}

#[test]
fn corrupt_input_gives_errors_naming_the_offset() {
    assert!(matches!(
        cdr::from_bytes::<Time>(&[0x00, 0x01]),
        Err(CdrError::MissingHeader { len: 2 })
    ));
    assert!(matches!(
        cdr::from_bytes::<Time>(&[0x00, 0x07, 0, 0, 1, 0, 0, 0, 2, 0, 0, 0]),
        Err(CdrError::UnsupportedEncapsulation { id: [0x00, 0x07] })
    ));

    // An image whose data length prefix claims 4 GiB: rejected where the data would
    // start, without allocating it.
    let mut bytes = fixture!("sensor_msgs__msg__Image").to_vec();
    let length_at = bytes.len() - 18 - 4;
    bytes[length_at..length_at + 4].copy_from_slice(&u32::MAX.to_le_bytes());
    let error = cdr::from_bytes::<Image>(&bytes).expect_err("length past the end");
    match &error {
        CdrError::Malformed { offset, len, .. } => {
            assert_eq!(*offset, length_at + 4);
            assert_eq!(*len, bytes.len());
        }
        other => panic!("expected a malformed-input error, got {other:?}"),
    }
    assert!(
        error
            .to_string()
            .contains(&format!("offset {}", length_at + 4))
    );

    // A TF message claiming u32::MAX transforms.
    let mut bytes = fixture!("tf2_msgs__msg__TFMessage").to_vec();
    bytes[4..8].copy_from_slice(&u32::MAX.to_le_bytes());
    assert!(matches!(
        cdr::from_bytes::<TFMessage>(&bytes),
        Err(CdrError::Malformed { .. })
    ));

    // A bool that is neither 0 nor 1.
    let mut bytes = fixture!("sensor_msgs__msg__RegionOfInterest").to_vec();
    bytes[20] = 7;
    let error = cdr::from_bytes::<RegionOfInterest>(&bytes).expect_err("bad bool");
    assert!(
        matches!(error, CdrError::Malformed { offset: 20, .. }),
        "{error}"
    );

    // A frame id that is not UTF-8.
    let mut bytes = fixture!("std_msgs__msg__Header").to_vec();
    bytes[16] = 0xff;
    assert!(matches!(
        cdr::from_bytes::<Header>(&bytes),
        Err(CdrError::Malformed { .. })
    ));
}

fn parameter(name: &str, value: ParameterValue) -> Parameter {
    Parameter {
        name: name.to_owned(),
        value,
    }
}

/// One parameter of each array type and an integer, as interop/check_msgs_cdr.py
/// builds them.
fn parameters() -> Vec<Parameter> {
    vec![
        parameter(
            "interpolation",
            ParameterValue {
                type_: parameter_type::INTEGER,
                integer_value: -3,
                ..ParameterValue::default()
            },
        ),
        parameter(
            "camera.gains",
            ParameterValue {
                type_: parameter_type::DOUBLE_ARRAY,
                double_array_value: vec![0.5, -1.25],
                ..ParameterValue::default()
            },
        ),
        parameter(
            "names",
            ParameterValue {
                type_: parameter_type::STRING_ARRAY,
                string_array_value: vec!["a".into(), "bc".into()],
                ..ParameterValue::default()
            },
        ),
        parameter(
            "mask",
            ParameterValue {
                type_: parameter_type::BYTE_ARRAY,
                byte_array_value: vec![1, 255],
                ..ParameterValue::default()
            },
        ),
        parameter(
            "flags",
            ParameterValue {
                type_: parameter_type::BOOL_ARRAY,
                bool_array_value: vec![true, false],
                ..ParameterValue::default()
            },
        ),
        parameter(
            "ids",
            ParameterValue {
                type_: parameter_type::INTEGER_ARRAY,
                integer_array_value: vec![4, -5],
                ..ParameterValue::default()
            },
        ),
    ]
}

#[test]
fn clock_matches_rosbags() {
    check(
        Clock { clock: time() },
        fixture!("rosgraph_msgs__msg__Clock"),
    );
}

#[test]
fn parameter_messages_match_rosbags() {
    let all = parameters();
    check(
        ParameterEvent {
            stamp: time(),
            node: "/left/rectify_node".into(),
            new_parameters: all[..1].to_vec(),
            changed_parameters: all[1..].to_vec(),
            deleted_parameters: Vec::new(),
        },
        fixture!("rcl_interfaces__msg__ParameterEvent"),
    );
    let mut values: Vec<ParameterValue> = all.iter().map(|p| p.value.clone()).collect();
    values.push(ParameterValue::default());
    check(
        GetParametersResponse { values },
        fixture!("rcl_interfaces__srv__GetParameters_Response"),
    );
    check(
        SetParametersRequest { parameters: all },
        fixture!("rcl_interfaces__srv__SetParameters_Request"),
    );
}

#[test]
fn parameter_services_match_rosbags() {
    check(
        ListParametersRequest {
            prefixes: vec!["camera".into()],
            depth: 2,
        },
        fixture!("rcl_interfaces__srv__ListParameters_Request"),
    );
    check(
        ListParametersResponse {
            result: ListParametersResult {
                names: vec!["camera.gains".into(), "queue_size".into()],
                prefixes: vec!["camera".into()],
            },
        },
        fixture!("rcl_interfaces__srv__ListParameters_Response"),
    );
    check(
        GetParametersRequest {
            names: vec!["interpolation".into(), "nope".into()],
        },
        fixture!("rcl_interfaces__srv__GetParameters_Request"),
    );
    check(
        GetParameterTypesResponse {
            types: vec![2, 8, 0],
        },
        fixture!("rcl_interfaces__srv__GetParameterTypes_Response"),
    );
    check(
        SetParametersResponse {
            results: vec![
                SetParametersResult {
                    successful: true,
                    reason: String::new(),
                },
                SetParametersResult {
                    successful: false,
                    reason: "read-only".into(),
                },
            ],
        },
        fixture!("rcl_interfaces__srv__SetParameters_Response"),
    );
    check(
        SetParametersAtomicallyResponse {
            result: SetParametersResult {
                successful: false,
                reason: "7 is out of range".into(),
            },
        },
        fixture!("rcl_interfaces__srv__SetParametersAtomically_Response"),
    );
    check(
        DescribeParametersResponse {
            descriptors: vec![
                ParameterDescriptor {
                    name: "interpolation".into(),
                    type_: parameter_type::INTEGER,
                    description: "0 nearest, 1 linear".into(),
                    integer_range: vec![IntegerRange {
                        from_value: 0,
                        to_value: 2,
                        step: 1,
                    }],
                    ..ParameterDescriptor::default()
                },
                ParameterDescriptor {
                    name: "square".into(),
                    type_: parameter_type::DOUBLE,
                    description: "metres".into(),
                    additional_constraints: "one of: a, b".into(),
                    read_only: true,
                    floating_point_range: vec![FloatingPointRange {
                        from_value: 0.0,
                        to_value: 1.5,
                        step: 0.0,
                    }],
                    ..ParameterDescriptor::default()
                },
            ],
        },
        fixture!("rcl_interfaces__srv__DescribeParameters_Response"),
    );
}
