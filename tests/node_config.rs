//! The shipped stereo params file and the command line that
//! launch/stereo_rectify.launch.py gives each rectify_node resolve to the intended node
//! names, topics and parameters.

use std::path::Path;

use ros2_client::ParameterValue;
use stereocal_runtime::args::RosArgs;
use stereocal_runtime::names::NodeIdentity;
use stereocal_runtime::params::{ParamSpec, startup_params};

const PARAMS_FILE: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/config/stereo_rectify.yaml");

/// The arguments launch_ros passes to the node of one side.
fn launch_args(side: &str) -> Vec<String> {
    [
        "--ros-args",
        "-r",
        "__node:=rectify_node",
        "-r",
        &format!("__ns:=/{side}"),
        "--params-file",
        PARAMS_FILE,
        "-r",
        &format!("image:=/stereo/{side}/image_raw"),
        "-r",
        &format!("camera_info:=/stereo/{side}/camera_info"),
        "-r",
        &format!("image_rect:=/stereo/{side}/image_rect"),
    ]
    .iter()
    .map(|s| s.to_string())
    .collect()
}

#[test]
fn both_sides_get_their_topics_and_parameters() -> Result<(), Box<dyn std::error::Error>> {
    assert!(Path::new(PARAMS_FILE).exists());
    let specs = [
        ParamSpec::new("interpolation", ParameterValue::Integer(0), "interpolation"),
        ParamSpec::new("queue_size", ParameterValue::Integer(1), "queue size"),
    ];
    for side in ["left", "right"] {
        let (ros, node_args) = RosArgs::parse(launch_args(side))?;
        assert!(node_args.is_empty());
        let id = NodeIdentity::resolve("rectify_node", "/", &ros.remaps)?;
        assert_eq!(id.fully_qualified_name(), format!("/{side}/rectify_node"));
        for (topic, expected) in [
            ("image", "image_raw"),
            ("camera_info", "camera_info"),
            ("image_rect", "image_rect"),
        ] {
            assert_eq!(
                id.resolve_topic(topic, &ros.remaps)?,
                format!("/stereo/{side}/{expected}")
            );
        }
        let params = startup_params(&specs, &ros.params, &id)?;
        let values: Vec<&ParameterValue> = params.values.iter().map(|p| &p.value).collect();
        assert_eq!(
            values,
            vec![&ParameterValue::Integer(1), &ParameterValue::Integer(5)]
        );
        assert!(params.undeclared.is_empty(), "{:?}", params.undeclared);
    }
    Ok(())
}
