//! ros2-client publishes and subscribes through RustDDS's CDR adapters, not through
//! [`stereocal_msgs::cdr`]. These tests run our message types through those adapters
//! and check that they give the same ROS 2 bytes (the `rosbags` fixtures) and decode
//! them back, byte arrays included.

use rustdds::RepresentationIdentifier;
use rustdds::no_key::{DeserializerAdapter, SerializerAdapter};
use rustdds::{CDRDeserializerAdapter, CDRSerializerAdapter};
use serde::Serialize;
use serde::de::DeserializeOwned;
use stereocal_msgs::cdr;
use stereocal_msgs::sensor_msgs::{CameraInfo, CompressedImage, Image, PointCloud2};
use stereocal_msgs::stereo_msgs::DisparityImage;
use stereocal_msgs::tf2_msgs::TFMessage;

/// RustDDS's publisher encoding of `fixture`'s message equals the fixture: same
/// representation identifier (CDR_LE) and same body; its subscriber decodes the body
/// to the same value we decode.
fn check<T>(fixture: &[u8])
where
    T: Serialize + DeserializeOwned + PartialEq + std::fmt::Debug,
{
    let value: T = cdr::from_bytes(fixture).expect("fixture decodes");
    let name = std::any::type_name::<T>();
    assert_eq!(
        <CDRSerializerAdapter<T> as SerializerAdapter<T>>::output_encoding(),
        RepresentationIdentifier::CDR_LE
    );
    assert_eq!(fixture[..4], cdr::CDR_LE_HEADER);
    let body = <CDRSerializerAdapter<T> as SerializerAdapter<T>>::to_bytes(&value)
        .expect("RustDDS encodes");
    assert_eq!(&body[..], &fixture[4..], "{name}");
    let decoded = <CDRDeserializerAdapter<T> as DeserializerAdapter<T>>::from_bytes(
        &fixture[4..],
        RepresentationIdentifier::CDR_LE,
    )
    .expect("RustDDS decodes");
    assert_eq!(decoded, value, "{name}");
}

#[test]
fn rustdds_adapters_give_the_ros_bytes() {
    check::<Image>(include_bytes!("fixtures/sensor_msgs__msg__Image.cdr"));
    check::<CompressedImage>(include_bytes!(
        "fixtures/sensor_msgs__msg__CompressedImage.cdr"
    ));
    check::<CameraInfo>(include_bytes!("fixtures/sensor_msgs__msg__CameraInfo.cdr"));
    check::<PointCloud2>(include_bytes!("fixtures/sensor_msgs__msg__PointCloud2.cdr"));
    check::<TFMessage>(include_bytes!("fixtures/tf2_msgs__msg__TFMessage.cdr"));
    check::<DisparityImage>(include_bytes!(
        "fixtures/stereo_msgs__msg__DisparityImage.cdr"
    ));
}
