//! The image topics of a bag, raw (`sensor_msgs/msg/Image`) and compressed
//! (`sensor_msgs/msg/CompressedImage`, image_transport's `<base topic>/compressed`):
//! every offline command takes either wherever it takes an image topic.

use stereocal_rosbag::BagReader;

use crate::convert::ImageKind;

/// The bag's image topics of both kinds, in the bag's topic order.
pub fn image_topics(reader: &BagReader) -> Vec<&str> {
    reader
        .topics()
        .iter()
        .filter(|t| ImageKind::of_type(&t.type_name).is_some())
        .map(|t| t.name.as_str())
        .collect()
}

/// The kind of image `topic` carries; the error names what it is instead and lists the
/// bag's image topics.
pub fn image_kind(reader: &BagReader, topic: &str) -> Result<ImageKind, String> {
    let listed = || {
        let topics = image_topics(reader);
        if topics.is_empty() {
            "none".to_owned()
        } else {
            topics.join(", ")
        }
    };
    match reader.topic(topic) {
        Some(t) => ImageKind::of_type(&t.type_name).ok_or_else(|| {
            format!(
                "topic {topic} carries {}, not sensor_msgs/msg/Image or CompressedImage; image topics in the bag: {}",
                t.type_name,
                listed()
            )
        }),
        None => Err(format!(
            "the bag has no topic {topic}; image topics in the bag: {}",
            listed()
        )),
    }
}
