//! The `image_transport` parameter of every node that takes images, as
//! stereo_image_proc has it: `raw` subscribes `sensor_msgs/Image` on the image topic,
//! `compressed` subscribes `sensor_msgs/CompressedImage` on `<image topic>/compressed`
//! (the image topic resolved with its remaps first, as image_transport does) and
//! decompresses each message before the node sees it.

use std::sync::Arc;

use ros2_client::{ParameterValue, QosProfile};
use stereocal_msgs::sensor_msgs::{CameraInfo, CompressedImage, Image};
use stereocal_runtime::node::RosNode;
use stereocal_runtime::params::ParamSpec;
use stereocal_runtime::qos;
use stereocal_runtime::skeleton::Inputs;
use stereocal_runtime::sync::SyncPolicy;

use crate::convert::image_msg_from_compressed;

/// The parameter's name.
const NAME: &str = "image_transport";

/// How images arrive.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Transport {
    /// `sensor_msgs/Image` on the image topic.
    Raw,
    /// `sensor_msgs/CompressedImage` (JPEG or PNG) on `<image topic>/compressed`.
    Compressed,
}

/// The parameter, read-only while the node runs.
pub fn spec() -> ParamSpec {
    ParamSpec::new(
        NAME,
        ParameterValue::String("raw".into()),
        "raw: sensor_msgs/Image on the image topic; compressed: sensor_msgs/CompressedImage (JPEG, PNG) on <image topic>/compressed",
    )
    .one_of(&["raw", "compressed"])
}

/// The transport the node was started with.
pub fn transport(node: &RosNode) -> anyhow::Result<Transport> {
    Ok(match node.param_string(NAME)?.as_str() {
        "compressed" => Transport::Compressed,
        _ => Transport::Raw,
    })
}

/// `inputs` with the image stream `topic` added in `transport`: a compressed image is
/// decompressed into the `sensor_msgs/Image` it was made from before synchronization;
/// one that cannot be is logged with its reason and left out.
pub fn image_stream<F, C>(
    inputs: Inputs<F, C>,
    node: &mut RosNode,
    transport: Transport,
    topic: &str,
    qos: QosProfile,
) -> anyhow::Result<Inputs<F, C>>
where
    F: From<Arc<Image>> + 'static,
    C: 'static,
    Image: Into<F>,
{
    Ok(match transport {
        Transport::Raw => inputs.stream::<Image>(node, topic, qos)?,
        Transport::Compressed => {
            let compressed = format!("{}/compressed", node.resolve_topic(topic)?);
            inputs.stream_decoded::<CompressedImage>(node, &compressed, qos, |message| {
                image_msg_from_compressed(message)
                    .map(|image| F::from(Arc::new(image)))
                    .map_err(|e| e.to_string())
            })?
        }
    })
}

/// The inputs of a node that sees one camera: `image` in `transport` paired by equal
/// stamps with `camera_info`, both best-effort, `depth` frames kept per topic.
pub fn camera_inputs<F>(
    node: &mut RosNode,
    transport: Transport,
    depth: usize,
) -> anyhow::Result<Inputs<F, CameraInfo>>
where
    F: From<Arc<Image>> + 'static,
    Image: Into<F>,
{
    Ok(image_stream(
        Inputs::new(SyncPolicy::exact(depth)),
        node,
        transport,
        "image",
        qos::sensor_data(depth),
    )?
    .latched::<CameraInfo>(node, "camera_info", qos::sensor_data(depth))?)
}
