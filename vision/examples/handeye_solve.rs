//! Solves hand-eye problems with every method of `vision::handeye` and prints the
//! results, for comparing them with OpenCV's `calibrateHandEye` and
//! `calibrateRobotWorldHandEye` on the same samples (`interop/check_handeye_opencv.py`).
//!
//! ```text
//! handeye_solve PROBLEMS.json
//! ```
//!
//! PROBLEMS.json: `{"setup": "eye-in-hand" | "eye-to-hand", "problems": [{"samples":
//! [{"base_from_tool": T, "camera_from_target": T}, ..]}, ..]}` with each T
//! `{"rotation": [9, row-major], "translation": [3]}` (metres). Printed: one JSON object,
//! `{"problems": [{"<method>": {"mount_from_camera": T, "anchor_from_target": T} |
//! {"error": "<reason>"}, ..}, ..]}`: the camera in the frame it is fixed to (the tool
//! for eye-in-hand, the base for eye-to-hand) and the target in the other.

use std::error::Error;

use nalgebra::{Isometry3, Matrix3, Rotation3, Translation3, UnitQuaternion, Vector3};
use serde::Deserialize;
use serde_json::{Map, Value, json};
use stereocal_vision::handeye::{Method, Sample, Setup, calibrate};

type Result<T> = std::result::Result<T, Box<dyn Error>>;

#[derive(Deserialize)]
struct Transform {
    rotation: [f64; 9],
    translation: [f64; 3],
}

#[derive(Deserialize)]
struct JsonSample {
    base_from_tool: Transform,
    camera_from_target: Transform,
}

#[derive(Deserialize)]
struct Problem {
    samples: Vec<JsonSample>,
}

#[derive(Deserialize)]
struct Problems {
    setup: String,
    problems: Vec<Problem>,
}

fn isometry(t: &Transform) -> Isometry3<f64> {
    let rotation = Rotation3::from_matrix(&Matrix3::from_row_slice(&t.rotation));
    Isometry3::from_parts(
        Translation3::from(Vector3::from(t.translation)),
        UnitQuaternion::from_rotation_matrix(&rotation),
    )
}

fn transform(pose: &Isometry3<f64>) -> Value {
    let rotation = pose.rotation.to_rotation_matrix();
    json!({
        "rotation": rotation.matrix().transpose().as_slice(),
        "translation": pose.translation.vector.as_slice(),
    })
}

fn main() -> Result<()> {
    let path = std::env::args()
        .nth(1)
        .ok_or("usage: handeye_solve PROBLEMS.json")?;
    let text = std::fs::read_to_string(&path).map_err(|e| format!("cannot read {path}: {e}"))?;
    let input: Problems =
        serde_json::from_str(&text).map_err(|e| format!("{path} is not a problems file: {e}"))?;
    let setup = match input.setup.as_str() {
        "eye-in-hand" => Setup::EyeInHand,
        "eye-to-hand" => Setup::EyeToHand,
        other => return Err(format!("unknown setup {other:?}").into()),
    };
    let mut out = Vec::new();
    for problem in &input.problems {
        let samples: Vec<Sample> = problem
            .samples
            .iter()
            .map(|s| Sample {
                base_from_tool: isometry(&s.base_from_tool),
                camera_from_target: isometry(&s.camera_from_target),
            })
            .collect();
        let mut results = Map::new();
        for method in Method::ALL {
            let result = match calibrate(setup, &samples, method) {
                Ok(c) => json!({
                    "mount_from_camera": transform(c.hand_eye.mount_from_camera()),
                    "anchor_from_target": transform(c.hand_eye.anchor_from_target()),
                }),
                Err(e) => json!({"error": e.to_string()}),
            };
            results.insert(method.name().into(), result);
        }
        out.push(Value::Object(results));
    }
    println!("{}", json!({ "problems": out }));
    Ok(())
}
