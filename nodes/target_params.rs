//! The target parameters of every node that detects a calibration target (`pattern`,
//! `size`, `square`, `marker_size`, `dictionary`), as ROS camera_calibration names them.

use anyhow::anyhow;
use ros2_client::ParameterValue;
use stereocal_runtime::node::{NodeBuilder, RosNode};
use stereocal_runtime::params::ParamSpec;
use stereocal_vision::board::{Target, TargetPart, parse_size, target_from_parts};

/// Largest accepted target square or marker side, metres.
const MAX_SQUARE: f64 = 10.0;

/// Declares the target parameters, read-only while the node runs.
pub fn declare_target(builder: NodeBuilder) -> NodeBuilder {
    let string = |name: &str, default: &str, description: &str| {
        ParamSpec::new(name, ParameterValue::String(default.into()), description)
    };
    let double = |name: &str, default: f64, max: f64, description: &str| {
        ParamSpec::new(name, ParameterValue::Double(default), description).double_range(0.0..=max)
    };
    [
        string("pattern", "chessboard", "calibration target").one_of(&[
            "chessboard",
            "charuco",
            "circles",
            "acircles",
        ]),
        string(
            "size",
            "",
            "target size COLSxROWS: a chessboard's inner corners, a ChArUco board's squares, a \
             circle grid's circles per row and rows (required)",
        ),
        double(
            "square",
            0.0,
            MAX_SQUARE,
            "side of one square, or a circle grid's spacing, metres (required)",
        ),
        double(
            "marker_size",
            0.0,
            MAX_SQUARE,
            "ChArUco marker side, metres",
        ),
        string(
            "dictionary",
            "4x4_50",
            "ChArUco marker dictionary, e.g. 4x4_50, 5x5_100",
        ),
    ]
    .into_iter()
    .fold(builder, NodeBuilder::param)
}

fn param_error(name: &str, reason: impl std::fmt::Display) -> anyhow::Error {
    anyhow!("parameter {name}: {reason}")
}

/// Reads the target from the parameters; an error names the parameter at fault.
pub fn target_from_params(node: &RosNode) -> anyhow::Result<Target> {
    let size = node.param_string("size")?;
    if size.trim().is_empty() {
        return Err(param_error(
            "size",
            "required: the target size as COLSxROWS, e.g. 9x6",
        ));
    }
    let size = parse_size(&size).map_err(|e| param_error("size", e))?;
    target_from_parts(
        &node.param_string("pattern")?,
        size,
        node.param_f64("square")?,
        Some(node.param_f64("marker_size")?),
        Some(&node.param_string("dictionary")?),
    )
    .map_err(|(part, e)| {
        let name = match part {
            TargetPart::Pattern => "pattern",
            TargetPart::Size => "size",
            TargetPart::Square => "square",
            TargetPart::MarkerSize => "marker_size",
            TargetPart::Dictionary => "dictionary",
        };
        param_error(name, e)
    })
}
