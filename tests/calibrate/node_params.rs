//! `calibrate_node` refuses bad parameters at start-up: it exits with a failure and a
//! message that names the parameter and says what was expected. Running, it describes
//! every parameter in one `describe_parameters` response, larger than a datagram.

use std::process::{Command, Stdio};
use std::time::Duration;

use stereocal_msgs::rcl_interfaces::parameter_type;
use stereocal_msgs::rcl_interfaces::srv::{
    DescribeParametersRequest, DescribeParametersResponse, ListParametersRequest,
    ListParametersResponse,
};
use stereocal_runtime::service::{ServiceClient, call, create_client, wait_for_server};
use stereocal_runtime::testing::{DomainLease, NodeProcess};

use crate::common;

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
        &["pattern:=dots", "size:=9x6", "square:=0.025"],
        &[
            "parameter pattern",
            "\"dots\"",
            "one of: chessboard, charuco, circles, acircles",
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

#[test]
fn every_parameter_is_described_in_one_response() {
    let domain = DomainLease::for_test().expect("a ROS domain");
    let dir = tempfile::tempdir().expect("temp dir");
    let mut command = Command::new(env!("CARGO_BIN_EXE_calibrate_node"));
    command.args([
        "--ros-args",
        "-r",
        "__ns:=/cam",
        "-p",
        "size:=9x6",
        "-p",
        "square:=0.025",
        "-p",
        &format!("state_dir:={}", dir.path().display()),
    ]);
    let process = NodeProcess::spawn(command, domain.id()).expect("calibrate_node starts");
    // RustDDS's default transport advertises every interface, so the node's replies
    // to this peer are fragmented at the datagram size of the host's network interface
    // (on a host with loopback alone they would fit one 64 KiB datagram).
    let mut peer = common::test_node(&domain, "describe");
    let list: ServiceClient<ListParametersRequest, ListParametersResponse> =
        create_client(peer.node_mut(), "/cam/calibrate_node/list_parameters").expect("client");
    let describe: ServiceClient<DescribeParametersRequest, DescribeParametersResponse> =
        create_client(peer.node_mut(), "/cam/calibrate_node/describe_parameters").expect("client");
    let timeout = Duration::from_secs(30);
    assert!(
        wait_for_server(peer.node(), &list, timeout),
        "list_parameters not found"
    );
    assert!(
        wait_for_server(peer.node(), &describe, timeout),
        "describe_parameters not found"
    );
    // A reply sent before the server matched our reader is lost: ask again until one comes.
    let names = (0..10)
        .find_map(|_| {
            call(
                &list,
                &ListParametersRequest::default(),
                Duration::from_secs(3),
            )
            .expect("call")
        })
        .expect("list_parameters answered")
        .result
        .names;
    let request = DescribeParametersRequest {
        names: names.clone(),
    };
    let descriptors = (0..10)
        .find_map(|_| call(&describe, &request, Duration::from_secs(3)).expect("call"))
        .expect("describe_parameters answered")
        .descriptors;
    let size = stereocal_msgs::cdr::to_bytes(&DescribeParametersResponse {
        descriptors: descriptors.clone(),
    })
    .expect("encodes")
    .len();
    assert!(
        size > 1500,
        "the response ({size} bytes) fits in one datagram"
    );
    assert_eq!(descriptors.len(), names.len());
    for (name, descriptor) in names.iter().zip(&descriptors) {
        assert_eq!(&descriptor.name, name);
        assert!(
            !descriptor.description.is_empty(),
            "{name} has no description"
        );
        assert!(descriptor.read_only, "{name} is read once at start-up");
        match descriptor.type_ {
            parameter_type::INTEGER => assert_eq!(descriptor.integer_range.len(), 1, "{name}"),
            parameter_type::DOUBLE => {
                assert_eq!(descriptor.floating_point_range.len(), 1, "{name}")
            }
            _ => {}
        }
    }
    let pattern = descriptors
        .iter()
        .find(|d| d.name == "pattern")
        .expect("pattern");
    assert_eq!(
        pattern.additional_constraints,
        "one of: chessboard, charuco, circles, acircles"
    );
    let exit = process.terminate();
    assert!(
        exit.clean(),
        "calibrate_node failed on SIGTERM:\n{}",
        exit.logs
    );
}
