//! Reading the OpenCV reference fixture written by `interop/opencv_camera_reference.py`,
//! shared by the tests that compare against it.

use serde_json::Value;
use stereocal_vision::camera::{CameraModel, Distortion, DistortionModel, Intrinsics, Roi};

const FIXTURE: &str = include_str!("../fixtures/opencv_camera_reference.json");

/// The parsed fixture.
pub fn fixture() -> Value {
    serde_json::from_str(FIXTURE).expect("fixture is valid JSON")
}

/// All numbers of a (nested) JSON array, flattened in order.
pub fn f64s(value: &Value) -> Vec<f64> {
    value
        .as_array()
        .expect("array")
        .iter()
        .flat_map(|v| match v {
            Value::Array(_) => f64s(v),
            _ => vec![v.as_f64().expect("number")],
        })
        .collect()
}

/// The fixture's camera `name`.
pub fn camera(fixture: &Value, name: &str) -> CameraModel {
    let c = &fixture["cameras"][name];
    let model = DistortionModel::from_ros_name(c["model"].as_str().expect("model")).expect("known");
    CameraModel {
        width: c["width"].as_u64().expect("width") as u32,
        height: c["height"].as_u64().expect("height") as u32,
        intrinsics: Intrinsics {
            fx: c["fx"].as_f64().expect("fx"),
            fy: c["fy"].as_f64().expect("fy"),
            cx: c["cx"].as_f64().expect("cx"),
            cy: c["cy"].as_f64().expect("cy"),
        },
        distortion: Distortion::from_coeffs(model, &f64s(&c["coeffs"])).expect("coefficients"),
    }
}

/// A ROI written as `[x, y, width, height]`.
pub fn roi(value: &Value) -> Roi {
    let v = f64s(value);
    Roi {
        x: v[0] as u32,
        y: v[1] as u32,
        width: v[2] as u32,
        height: v[3] as u32,
    }
}
