//! The raw images of one frame that the report shows rectified: read back from the bag
//! once the calibration knows which frames it used, so that calibration itself keeps
//! only corners.

use stereocal_msgs::builtin_interfaces::Time;
use stereocal_msgs::cdr;
use stereocal_msgs::sensor_msgs::{CompressedImage, Image as ImageMsg};
use stereocal_vision::image::Image;

use super::ReportError;
use crate::calibrate::stage::CalibrationOutcome;
use crate::convert::{Encoding, ImageKind, image_from_msg, image_msg_from_compressed};
use stereocal_rosbag::{BagReader, TopicFilter};

/// One camera's raw image.
#[derive(Clone, Debug, PartialEq)]
pub struct SampleImage {
    /// The message's encoding (tells RGB from BGR).
    pub encoding: Encoding,
    /// The image.
    pub image: Image,
}

/// The raw images of one frame, one per camera in the calibration's camera order.
#[derive(Clone, Debug, PartialEq)]
pub struct SampleImages {
    /// The frame's stamp.
    pub stamp: Time,
    /// One image per camera.
    pub images: Vec<SampleImage>,
}

/// The frame to show: the first pair the stereo calibration used, or the first view a
/// mono calibration used.
pub fn sample_stamp(outcome: &CalibrationOutcome) -> Option<Time> {
    match &outcome.stereo {
        Some(stereo) => stereo.used.first().copied(),
        None => outcome.cameras.first()?.used.first().copied(),
    }
}

/// Reads the images stamped `stamp` on `topics` (one per camera) from the bag, stopping
/// as soon as every camera's image is found; `None` when some camera has no decodable
/// image with that stamp.
pub fn read_sample(
    reader: &BagReader,
    topics: &[String],
    stamp: Time,
) -> Result<Option<SampleImages>, ReportError> {
    let mut images: Vec<Option<SampleImage>> = vec![None; topics.len()];
    let kinds: Vec<Option<ImageKind>> = topics
        .iter()
        .map(|t| {
            reader
                .topic(t)
                .and_then(|i| ImageKind::of_type(&i.type_name))
        })
        .collect();
    let filter = TopicFilter::only(topics.iter().map(String::as_str));
    for message in reader.messages(&filter) {
        let message = message?;
        let Some(camera) = topics.iter().position(|t| *t == *message.topic) else {
            continue;
        };
        if images[camera].is_some() {
            continue;
        }
        let Some(msg) = image_at(kinds[camera], &message.data, stamp) else {
            continue;
        };
        if let Ok((encoding, image)) = image_from_msg(&msg) {
            images[camera] = Some(SampleImage { encoding, image });
        }
        if images.iter().all(Option::is_some) {
            break;
        }
    }
    Ok(images
        .into_iter()
        .collect::<Option<Vec<_>>>()
        .map(|images| SampleImages { stamp, images }))
}

/// The image of a CDR message of `kind` when it is stamped `stamp`; a compressed image
/// is decompressed only then.
fn image_at(kind: Option<ImageKind>, data: &[u8], stamp: Time) -> Option<ImageMsg> {
    match kind? {
        ImageKind::Raw => cdr::from_bytes::<ImageMsg>(data)
            .ok()
            .filter(|msg| msg.header.stamp == stamp),
        ImageKind::Compressed => cdr::from_bytes::<CompressedImage>(data)
            .ok()
            .filter(|msg| msg.header.stamp == stamp)
            .and_then(|msg| image_msg_from_compressed(&msg).ok()),
    }
}
