//! Rectifies uncalibrated stereo problems with `vision::rectify::rectify_uncalibrated`
//! and prints the homographies, for the comparison with OpenCV's
//! `stereoRectifyUncalibrated` (`interop/check_rectify_uncalibrated_opencv.py`).
//!
//! ```text
//! rectify_uncalibrated PROBLEMS.json
//! ```
//!
//! PROBLEMS.json: `{"problems": [{"name", "width", "height", "threshold",
//! "points_left": [[u, v], ..], "points_right": [[u, v], ..], "fundamental": [9,
//! row-major]}, ..]}` (pixel centres at integer coordinates). Printed as JSON, per
//! problem: `{"name", "rectified_left_from_image_left": [9, row-major],
//! "rectified_right_from_image_right": [9], "inliers": [0 or 1, ..]}`, or `{"name",
//! "error"}` with the refusal's message.

use anyhow::{Context, Result, anyhow};
use nalgebra::{Matrix3, Point2};
use serde::Deserialize;
use serde_json::{Value, json};
use stereocal_vision::rectify::rectify_uncalibrated;

#[derive(Deserialize)]
struct Problem {
    name: String,
    width: u32,
    height: u32,
    threshold: f64,
    points_left: Vec<[f64; 2]>,
    points_right: Vec<[f64; 2]>,
    fundamental: [f64; 9],
}

#[derive(Deserialize)]
struct Problems {
    problems: Vec<Problem>,
}

fn points(p: &[[f64; 2]]) -> Vec<Point2<f64>> {
    p.iter().map(|p| Point2::new(p[0], p[1])).collect()
}

fn rows(m: &Matrix3<f64>) -> Vec<f64> {
    m.transpose().as_slice().to_vec()
}

fn solve(problem: &Problem) -> Value {
    let f = Matrix3::from_row_slice(&problem.fundamental);
    match rectify_uncalibrated(
        &points(&problem.points_left),
        &points(&problem.points_right),
        &f,
        (problem.width, problem.height),
        problem.threshold,
    ) {
        Ok(r) => json!({
            "name": problem.name,
            "rectified_left_from_image_left": rows(&r.rectified_left_from_image_left),
            "rectified_right_from_image_right": rows(&r.rectified_right_from_image_right),
            "inliers": r.inliers.iter().map(|&i| u8::from(i)).collect::<Vec<_>>(),
        }),
        Err(e) => json!({"name": problem.name, "error": e.to_string()}),
    }
}

fn main() -> Result<()> {
    let path = std::env::args()
        .nth(1)
        .ok_or_else(|| anyhow!("usage: rectify_uncalibrated PROBLEMS.json"))?;
    let text = std::fs::read_to_string(&path).with_context(|| format!("reading {path}"))?;
    let problems: Problems =
        serde_json::from_str(&text).with_context(|| format!("{path} is not a problem list"))?;
    let results: Vec<Value> = problems.problems.iter().map(solve).collect();
    println!("{}", json!({ "problems": results }));
    Ok(())
}
