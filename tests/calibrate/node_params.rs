//! `calibrate_node` refuses bad parameters at start-up: it exits with a failure and a
//! message that names the parameter and says what was expected.

use std::process::{Command, Stdio};

use stereocal_runtime::testing::DomainLease;

/// Runs the node with `params` (`name:=value`) and returns its exit status and the
/// last line it printed on stderr.
fn start_with(params: &[&str]) -> (bool, String) {
    let (success, stderr) = run(Command::new(env!("CARGO_BIN_EXE_calibrate_node")), params);
    (
        success,
        stderr.lines().last().unwrap_or_default().to_owned(),
    )
}

/// Runs `command` (the node) with `params` and returns its exit status and what it
/// printed on stderr.
fn run(mut command: Command, params: &[&str]) -> (bool, String) {
    let dir = tempfile::tempdir().expect("temp dir");
    let domain = DomainLease::for_test().expect("a ROS domain");
    command.args([
        "--ros-args",
        "-p",
        &format!("state_dir:={}", dir.path().display()),
    ]);
    for param in params {
        command.args(["-p", param]);
    }
    let output = command
        .env("ROS_DOMAIN_ID", domain.id().to_string())
        .env("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
        .stdin(Stdio::null())
        .output()
        .expect("run calibrate_node");
    (
        output.status.success(),
        String::from_utf8_lossy(&output.stderr).into_owned(),
    )
}

fn assert_refused(params: &[&str], expected: &[&str]) {
    let (success, message) = start_with(params);
    assert!(!success, "{params:?} was accepted");
    assert!(
        message.starts_with("calibrate_node: parameter "),
        "{params:?}: {message}"
    );
    for part in expected {
        assert!(message.contains(part), "{params:?}: {message}");
    }
}

#[test]
fn an_unknown_pattern_is_refused_naming_the_choices() {
    assert_refused(
        &["pattern:=circles", "size:=9x6", "square:=0.025"],
        &[
            "parameter pattern",
            "\"circles\"",
            "one of: chessboard, charuco",
        ],
    );
}

#[test]
fn a_bad_or_missing_size_is_refused() {
    assert_refused(
        &["size:=9by6", "square:=0.025"],
        &["parameter size", "\"9by6\"", "COLSxROWS"],
    );
    assert_refused(&["square:=0.025"], &["parameter size", "required"]);
    assert_refused(&["size:=9x6"], &["parameter square", "metres"]);
}

#[test]
fn other_bad_parameters_are_refused_by_name() {
    assert_refused(
        &["size:=9x6", "square:=0.025", "model:=fisheye"],
        &[
            "parameter model",
            "one of: plumb_bob, rational_polynomial, equidistant",
        ],
    );
    assert_refused(
        &["size:=7x5", "square:=0.04", "pattern:=charuco"],
        &["parameter marker_size"],
    );
    assert_refused(
        &[
            "size:=9x6",
            "square:=0.025",
            "camera_info_url:=http://example.invalid/camera.yaml",
        ],
        &["parameter camera_info_url", "only file://"],
    );
    assert_refused(
        &["size:=9x6", "square:=0.025", "stereo:=true", "slop:=-0.1"],
        &["parameter slop", "-0.1 is out of range 0..=10"],
    );
}

#[test]
fn stereocal_node_calibrate_runs_the_same_node() {
    let mut command = Command::new(env!("CARGO_BIN_EXE_stereocal"));
    command.args(["node", "calibrate"]);
    let (success, stderr) = run(command, &["size:=9x6", "square:=-1"]);
    assert!(!success);
    assert!(stderr.contains("Error: parameter square"), "{stderr}");
}
