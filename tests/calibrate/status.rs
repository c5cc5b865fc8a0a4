//! One serializer for a calibration: `calibrate_node`'s `~/status` carries under
//! `calibration` exactly the object `stereocal calibrate --json` prints, for the same
//! outcome.

use std::process::Command;

use indicatif::ProgressBar;
use stereocal::calibrate::session::{Progress, Verdict};
use stereocal::calibrate::status::{FrameCounts, NodeStatus};
use stereocal::cli::calibrate::calibrate_bag;

use crate::common;

#[test]
fn the_node_status_and_the_json_output_show_one_calibration_alike() {
    let dir = tempfile::tempdir().expect("temp dir");
    let truth = common::synthesize_session(&common::calibration_scene(dir.path(), 11, 12), None);
    let bag = dir.path().join("bag");
    let args = common::calibrate_args(bag.clone(), dir.path().join("in_process"), &truth);
    let report = calibrate_bag(&args, &ProgressBar::hidden()).expect("calibrate");

    let output = Command::new(env!("CARGO_BIN_EXE_stereocal"))
        .args(["calibrate", "--bag"])
        .arg(&bag)
        .arg("--out")
        .arg(dir.path().join("cli"))
        .args(["--size", &args.size, "--square", &args.square, "--json"])
        .output()
        .expect("stereocal calibrate");
    assert!(
        output.status.success(),
        "{}",
        String::from_utf8_lossy(&output.stderr)
    );
    let printed: serde_json::Value = serde_json::from_slice(&output.stdout).expect("JSON");

    let progress = Progress {
        cameras: Vec::new(),
        samples: 12,
        ready: true,
    };
    let verdict = Verdict::Added;
    let status = NodeStatus::new(
        &progress,
        Some(&verdict),
        FrameCounts::default(),
        Some(&report.result),
    );
    let status: serde_json::Value =
        serde_json::from_str(&status.to_json_string()).expect("status JSON");
    assert_eq!(status["calibration"], printed);
    assert_eq!(status["verdict"], "added");
    assert_eq!(status["samples"], 12);
    // The object holds both cameras, keyed by name, and the pair.
    for name in ["left", "right"] {
        assert!(printed["cameras"][name]["k"].is_array(), "{printed}");
        assert!(
            printed["cameras"][name]["std_dev"]["fx"].is_f64(),
            "{printed}"
        );
    }
    assert!(printed["stereo"]["right_from_left"]["rotation"].is_array());
}
