//! `ros2msg` schema texts against the complete message definitions that the Python
//! `rosbags` library generates (fixtures written by `interop/check_msgs_schemas.py`).

use stereocal_msgs::RosMessage;
use stereocal_msgs::builtin_interfaces::Time;
use stereocal_msgs::geometry_msgs::{
    Point, Pose, PoseStamped, PoseWithCovariance, PoseWithCovarianceStamped, Quaternion, Transform,
    TransformStamped, Vector3,
};
use stereocal_msgs::rcl_interfaces::{
    ListParametersResult, Parameter, ParameterDescriptor, ParameterEvent, ParameterValue,
    SetParametersResult,
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

macro_rules! check_schema {
    ($ty:ty, $fixture:literal) => {
        assert_eq!(
            <$ty>::schema_text(),
            include_str!(concat!("fixtures/", $fixture, ".ros2msg")),
            "{}",
            <$ty>::TYPE_NAME
        );
        assert_eq!(<$ty>::TYPE_NAME, $fixture.replace("__", "/"));
    };
}

#[test]
fn message_schemas_match_rosbags() {
    check_schema!(Time, "builtin_interfaces__msg__Time");
    check_schema!(Header, "std_msgs__msg__Header");
    check_schema!(std_msgs::String, "std_msgs__msg__String");
    check_schema!(Image, "sensor_msgs__msg__Image");
    check_schema!(CompressedImage, "sensor_msgs__msg__CompressedImage");
    check_schema!(RegionOfInterest, "sensor_msgs__msg__RegionOfInterest");
    check_schema!(CameraInfo, "sensor_msgs__msg__CameraInfo");
    check_schema!(PointField, "sensor_msgs__msg__PointField");
    check_schema!(PointCloud2, "sensor_msgs__msg__PointCloud2");
    check_schema!(Vector3, "geometry_msgs__msg__Vector3");
    check_schema!(Point, "geometry_msgs__msg__Point");
    check_schema!(Quaternion, "geometry_msgs__msg__Quaternion");
    check_schema!(Pose, "geometry_msgs__msg__Pose");
    check_schema!(PoseStamped, "geometry_msgs__msg__PoseStamped");
    check_schema!(PoseWithCovariance, "geometry_msgs__msg__PoseWithCovariance");
    check_schema!(
        PoseWithCovarianceStamped,
        "geometry_msgs__msg__PoseWithCovarianceStamped"
    );
    check_schema!(Transform, "geometry_msgs__msg__Transform");
    check_schema!(TransformStamped, "geometry_msgs__msg__TransformStamped");
    check_schema!(TFMessage, "tf2_msgs__msg__TFMessage");
    check_schema!(DisparityImage, "stereo_msgs__msg__DisparityImage");
    check_schema!(Clock, "rosgraph_msgs__msg__Clock");
    check_schema!(ParameterValue, "rcl_interfaces__msg__ParameterValue");
    check_schema!(Parameter, "rcl_interfaces__msg__Parameter");
    check_schema!(
        ParameterDescriptor,
        "rcl_interfaces__msg__ParameterDescriptor"
    );
    check_schema!(
        SetParametersResult,
        "rcl_interfaces__msg__SetParametersResult"
    );
    check_schema!(
        ListParametersResult,
        "rcl_interfaces__msg__ListParametersResult"
    );
    check_schema!(ParameterEvent, "rcl_interfaces__msg__ParameterEvent");
}

#[test]
fn service_schemas_list_their_fields_and_dependencies() {
    assert_eq!(
        SetCameraInfoRequest::TYPE_NAME,
        "sensor_msgs/srv/SetCameraInfo_Request"
    );
    assert_eq!(
        SetCameraInfoRequest::schema_text(),
        format!(
            "sensor_msgs/CameraInfo camera_info\n{}\nMSG: sensor_msgs/CameraInfo\n{}",
            "=".repeat(80),
            CameraInfo::schema_text()
        )
    );
    assert_eq!(
        SetCameraInfoResponse::schema_text(),
        "bool success\nstring status_message\n"
    );
    assert_eq!(TriggerRequest::TYPE_NAME, "std_srvs/srv/Trigger_Request");
    assert_eq!(TriggerRequest::schema_text(), "");
    assert_eq!(
        TriggerResponse::schema_text(),
        "bool success\nstring message\n"
    );
}
