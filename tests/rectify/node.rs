//! End to end over DDS on loopback: the built `rectify_node` binary, on its own ROS
//! domain, rectifies what this test publishes exactly as the rectify stage does, serves
//! and describes its parameters through the ROS 2 parameter services (refusing
//! out-of-range and read-only sets, publishing `/parameter_events` and unmoved by
//! events of others), and stops cleanly on SIGTERM.

use std::process::Command;
use std::time::{Duration, Instant};

use ros2_client::{Log, Node};
use serde::Serialize;
use serde::de::DeserializeOwned;
use stereocal::rectify::stage::{Rectified, Rectifier};
use stereocal_msgs::RosMessage;
use stereocal_msgs::builtin_interfaces::Time;
use stereocal_msgs::rcl_interfaces::srv::{
    DescribeParametersRequest, DescribeParametersResponse, GetParametersRequest,
    GetParametersResponse, ListParametersRequest, ListParametersResponse,
    SetParametersAtomicallyRequest, SetParametersAtomicallyResponse, SetParametersRequest,
    SetParametersResponse,
};
use stereocal_msgs::rcl_interfaces::{self as wire, ParameterEvent, parameter_type};
use stereocal_msgs::rosgraph_msgs::Clock;
use stereocal_msgs::sensor_msgs::{CameraInfo, Image};
use stereocal_msgs::std_msgs::Header;
use stereocal_runtime::qos;
use stereocal_runtime::service::{self, ServiceClient};
use stereocal_runtime::testing::{DomainLease, NodeProcess, block_on_timeout};
use stereocal_runtime::transport::DDS_NICE_ENV;
use stereocal_vision::rectify::RemapOptions;

use crate::common;

const WIDTH: u32 = 320;
const HEIGHT: u32 = 240;
/// Longest wait for discovery, a frame or a reply: a deadline, not a pause, long enough
/// for a node started on a machine busy with other builds and tests.
const TIMEOUT: Duration = Duration::from_secs(60);

/// Starts `rectify_node` in namespace `/cam` on `domain`, with `extra` ROS arguments.
fn start_node(domain: &DomainLease, extra: &[&str]) -> NodeProcess {
    start_node_with_env(domain, extra, &[])
}

/// [`start_node`] with environment variables `env` set.
fn start_node_with_env(domain: &DomainLease, extra: &[&str], env: &[(&str, &str)]) -> NodeProcess {
    let mut command = Command::new(env!("CARGO_BIN_EXE_rectify_node"));
    command
        .args(["--ros-args", "-r", "__ns:=/cam", "-r", "image:=image_raw"])
        .args(extra)
        .envs(env.iter().copied());
    NodeProcess::spawn(command, domain.id()).expect("rectify_node starts")
}

fn camera_info(stamp: Time) -> CameraInfo {
    let angle: f64 = 0.03;
    let (s, c) = angle.sin_cos();
    CameraInfo {
        header: Header {
            stamp,
            frame_id: "cam_optical".into(),
        },
        width: WIDTH,
        height: HEIGHT,
        distortion_model: "plumb_bob".into(),
        d: vec![-0.25, 0.08, 0.001, -0.0005, 0.0],
        k: [260.0, 0.0, 161.5, 0.0, 262.0, 118.5, 0.0, 0.0, 1.0],
        r: [c, 0.0, s, 0.0, 1.0, 0.0, -s, 0.0, c],
        p: [
            240.0, 0.0, 158.0, 0.0, 0.0, 240.0, 121.0, 0.0, 0.0, 0.0, 1.0, 0.0,
        ],
        ..CameraInfo::default()
    }
}

fn image(stamp: Time, rgb: bool, seed: u32) -> Image {
    let channels = if rgb { 3 } else { 1 };
    let step = WIDTH * channels;
    let data = (0..HEIGHT)
        .flat_map(|y| {
            (0..step).map(move |i| {
                let x = i / channels;
                let checker = ((x / 20 + y / 20) % 2) * 160;
                (checker + (x * 3 + y * 5 + i % channels * 40 + seed * 11) % 90) as u8
            })
        })
        .collect();
    Image {
        header: Header {
            stamp,
            frame_id: "cam_optical".into(),
        },
        height: HEIGHT,
        width: WIDTH,
        encoding: if rgb { "rgb8" } else { "mono8" }.into(),
        is_bigendian: 0,
        step,
        data,
    }
}

#[test]
fn rectifies_every_frame_like_the_stage_and_stops_on_sigterm() {
    rectifies_every_frame_like_the_stage(&[]);
}

#[test]
fn with_its_dds_threads_at_a_lower_priority_every_frame_still_goes_over_dds_in_order() {
    // image_rect is then serialized and sent from a thread of lower priority.
    rectifies_every_frame_like_the_stage(&[(DDS_NICE_ENV, "10")]);
}

/// Frames published to a rectify_node started with `env` come back on `image_rect`
/// over DDS, every one equal to the rectify stage's and in order; a bad frame is
/// reported and skipped; SIGTERM stops the node cleanly.
fn rectifies_every_frame_like_the_stage(env: &[(&str, &str)]) {
    let domain = DomainLease::for_test().expect("a ROS domain");
    let process = start_node_with_env(&domain, &["-p", "interpolation:=1"], env);
    let mut peer = common::test_node(&domain, "frames");
    let rosout_topic = peer.context().get_rosout_topic();
    let rosout = peer
        .node_mut()
        .create_subscription::<Log>(&rosout_topic, None)
        .expect("rosout subscription");
    let image_pub = peer
        .publisher::<Image>("/cam/image_raw", qos::reliable(10))
        .expect("image publisher");
    let info_pub = peer
        .publisher::<CameraInfo>("/cam/camera_info", qos::reliable(10))
        .expect("camera_info publisher");
    let rect_sub = peer
        .subscription::<Image>("/cam/image_rect", qos::reliable(50))
        .expect("image_rect subscription");

    let matched = block_on_timeout(
        async {
            image_pub.wait_for_subscription(peer.node()).await;
            info_pub.wait_for_subscription(peer.node()).await;
            rect_sub.wait_for_publisher(peer.node()).await;
        },
        TIMEOUT,
    );
    assert!(matched.is_some(), "rectify_node was not discovered");

    // Our writers may know the node's readers before those know our writers, and a
    // best-effort reader ignores samples of writers it has not matched yet: warm up
    // until a frame makes the whole round trip.
    let warm_up = Instant::now() + TIMEOUT;
    let mut round_trip = false;
    for k in 0u32.. {
        if round_trip || Instant::now() > warm_up {
            break;
        }
        let stamp = Time { sec: 1, nanosec: k };
        info_pub
            .publish(camera_info(stamp))
            .expect("publish camera_info");
        image_pub
            .publish(image(stamp, false, 0))
            .expect("publish image");
        std::thread::sleep(Duration::from_millis(200));
        while let Ok(Some(_)) = rect_sub.take() {
            round_trip = true;
        }
    }
    assert!(
        round_trip,
        "no frame made the round trip through rectify_node"
    );

    // Mono and colour frames, and one whose step disagrees with its width: the node
    // must log it and keep going.
    let mut expected = Vec::new();
    let mut rectifier = Rectifier::new(RemapOptions::default());
    for i in 1..=12u32 {
        let stamp = Time {
            sec: 100,
            nanosec: i * 1_000_000,
        };
        let mut frame = image(stamp, i % 4 == 0, i);
        let info = camera_info(stamp);
        if i == 6 {
            frame.step += 1;
        } else {
            match rectifier.rectify(&frame, &info) {
                Ok(Rectified::Image(rect)) => expected.push(rect),
                other => panic!("the stage did not rectify frame {i}: {other:?}"),
            }
        }
        info_pub.publish(info).expect("publish camera_info");
        image_pub.publish(frame).expect("publish image");
        std::thread::sleep(Duration::from_millis(80));
    }

    let mut received: Vec<Image> = Vec::new();
    let deadline = Instant::now() + TIMEOUT;
    while received.len() < expected.len() && Instant::now() < deadline {
        match rect_sub.take() {
            Ok(Some((image, _))) if image.header.stamp.sec == 1 => {}
            Ok(Some((image, _))) => received.push(image),
            Ok(None) => std::thread::sleep(Duration::from_millis(10)),
            Err(e) => panic!("image_rect did not decode: {e:?}"),
        }
    }
    let mut logged = Vec::new();
    while let Ok(Some((log, _))) = rosout.take() {
        logged.push(log);
    }
    let exit = process.terminate();
    let stderr = exit.logs.as_str();
    assert!(exit.clean(), "rectify_node failed on SIGTERM:\n{stderr}");
    let stamps: Vec<u32> = received
        .iter()
        .map(|i| i.header.stamp.nanosec / 1_000_000)
        .collect();
    assert_eq!(
        received.len(),
        expected.len(),
        "frames missing from image_rect, got {stamps:?}:\n{stderr}"
    );
    for (got, want) in received.iter().zip(&expected) {
        assert_eq!(got.header, want.header);
        assert_eq!(got.encoding, want.encoding);
        assert_eq!(
            (got.width, got.height, got.step),
            (want.width, want.height, want.step)
        );
        assert!(
            got.data == want.data,
            "pixels of frame {:?} differ",
            got.header.stamp
        );
    }
    assert!(
        logged.iter().any(|log| log.name == "cam.rectify_node"
            && log.level == Log::WARN
            && log.msg.contains("not rectified")),
        "bad frame not reported on /rosout: {logged:?}"
    );
    assert!(
        stderr.contains("not rectified"),
        "bad frame not reported:\n{stderr}"
    );
    // Every frame that reached the node was published, except the bad one.
    let summary = stderr
        .split("shutting down: ")
        .nth(1)
        .unwrap_or_else(|| panic!("no summary:\n{stderr}"));
    let numbers: Vec<u64> = summary
        .split(' ')
        .filter_map(|word| word.trim_end_matches(',').parse().ok())
        .collect();
    let (received_by_node, published, dropped) = (numbers[0], numbers[1], numbers[2]);
    assert_eq!(published + 1, received_by_node, "{summary}");
    assert_eq!(dropped, 0, "{summary}");
}

fn client<Req, Resp>(node: &mut Node, service: &str) -> ServiceClient<Req, Resp>
where
    Req: RosMessage + Serialize + DeserializeOwned + Clone + 'static,
    Resp: RosMessage + Serialize + DeserializeOwned + 'static,
{
    service::create_client(node, &format!("/cam/rectify_node/{service}")).expect("client")
}

fn call<Req, Resp>(node: &Node, client: &ServiceClient<Req, Resp>, request: Req) -> Resp
where
    Req: Serialize + DeserializeOwned + Clone + 'static,
    Resp: Serialize + DeserializeOwned + 'static,
{
    assert!(
        service::wait_for_server(node, client, TIMEOUT),
        "parameter service not discovered"
    );
    // A reply sent before the server has matched our response reader is lost (the
    // service topics are volatile), so a call that goes unanswered is repeated until
    // the deadline.
    let deadline = Instant::now() + TIMEOUT;
    while Instant::now() < deadline {
        if let Some(response) =
            service::call(client, &request, Duration::from_secs(2)).expect("service call")
        {
            return response;
        }
    }
    panic!("parameter service never answered in {TIMEOUT:?}")
}

fn integer(name: &str, value: i64) -> wire::Parameter {
    wire::Parameter {
        name: name.into(),
        value: wire::ParameterValue {
            type_: parameter_type::INTEGER,
            integer_value: value,
            ..wire::ParameterValue::default()
        },
    }
}

#[test]
fn parameters_are_served_described_and_checked() {
    let domain = DomainLease::for_test().expect("a ROS domain");
    let params_file = tempfile::NamedTempFile::new().expect("temp file");
    std::fs::write(
        params_file.path(),
        "/**:\n  ros__parameters:\n    queue_size: 7\n/cam/rectify_node:\n  ros__parameters:\n    interpolation: 2\n",
    )
    .expect("write params file");
    let path = params_file.path().to_string_lossy().into_owned();
    let process = start_node(&domain, &["--params-file", &path]);
    let mut peer = common::test_node(&domain, "params");
    let events = peer
        .subscription::<ParameterEvent>("/parameter_events", qos::reliable(100))
        .expect("parameter events subscription");

    let list =
        client::<ListParametersRequest, ListParametersResponse>(peer.node_mut(), "list_parameters");
    let names = call(peer.node(), &list, ListParametersRequest::default())
        .result
        .names;
    assert_eq!(
        names,
        [
            "use_sim_time",
            "interpolation",
            "queue_size",
            "image_transport",
            "image_rect.compressed.format",
            "image_rect.compressed.jpeg_quality",
            "image_rect.compressed.png_level"
        ]
    );

    let get =
        client::<GetParametersRequest, GetParametersResponse>(peer.node_mut(), "get_parameters");
    let get_values = |node: &Node| -> Vec<i64> {
        let request = GetParametersRequest {
            names: vec!["interpolation".into(), "queue_size".into()],
        };
        call(node, &get, request)
            .values
            .iter()
            .map(|v| v.integer_value)
            .collect()
    };
    assert_eq!(get_values(peer.node()), [2, 7]);

    let describe = client::<DescribeParametersRequest, DescribeParametersResponse>(
        peer.node_mut(),
        "describe_parameters",
    );
    let request = DescribeParametersRequest {
        names: vec!["interpolation".into(), "queue_size".into(), "nope".into()],
    };
    let descriptors = call(peer.node(), &describe, request).descriptors;
    assert_eq!(descriptors.len(), 3);
    let interpolation = &descriptors[0];
    assert_eq!(interpolation.name, "interpolation");
    assert_eq!(interpolation.type_, parameter_type::INTEGER);
    assert!(
        interpolation.description.contains("cubic"),
        "{interpolation:?}"
    );
    assert!(!interpolation.read_only);
    assert_eq!(
        (
            interpolation.integer_range[0].from_value,
            interpolation.integer_range[0].to_value
        ),
        (0, 2)
    );
    assert!(descriptors[1].read_only, "queue_size is read at start-up");
    assert_eq!(descriptors[2].type_, parameter_type::NOT_SET);

    let setter =
        client::<SetParametersRequest, SetParametersResponse>(peer.node_mut(), "set_parameters");
    let request = SetParametersRequest {
        parameters: vec![
            integer("interpolation", 3),
            integer("queue_size", 2),
            integer("interpolation", 0),
        ],
    };
    let results = call(peer.node(), &setter, request).results;
    assert!(
        !results[0].successful && results[0].reason.contains("out of range 0..=2"),
        "{results:?}"
    );
    assert!(
        !results[1].successful && results[1].reason.contains("read-only"),
        "{results:?}"
    );
    assert!(results[2].successful, "{results:?}");
    assert_eq!(get_values(peer.node()), [0, 7]);

    let atomic = client::<SetParametersAtomicallyRequest, SetParametersAtomicallyResponse>(
        peer.node_mut(),
        "set_parameters_atomically",
    );
    let request = SetParametersAtomicallyRequest {
        parameters: vec![integer("interpolation", 1), integer("interpolation", 9)],
    };
    let result = call(peer.node(), &atomic, request).result;
    assert!(
        !result.successful && result.reason.contains("9 is out of range"),
        "{result:?}"
    );
    assert_eq!(
        get_values(peer.node()),
        [0, 7],
        "a refused atomic set changes nothing"
    );

    // The declaration event may precede our subscription, and on a loaded machine so
    // may the accepted set's: events published before the subscription matched are
    // not delivered (the topic is volatile). Until the deadline, the set is repeated
    // whenever no event follows it.
    let deadline = Instant::now() + TIMEOUT;
    let changed = loop {
        let event = block_on_timeout(
            async {
                loop {
                    match events.async_take().await {
                        Ok((event, _)) if !event.changed_parameters.is_empty() => break event,
                        _ => continue,
                    }
                }
            },
            Duration::from_secs(2),
        );
        if let Some(event) = event {
            break event;
        }
        assert!(
            Instant::now() < deadline,
            "no parameter event after the set in {TIMEOUT:?}"
        );
        let again = SetParametersRequest {
            parameters: vec![integer("interpolation", 0)],
        };
        assert!(call(peer.node(), &setter, again).results[0].successful);
    };
    assert_eq!(changed.node, "/cam/rectify_node");
    assert_eq!(changed.changed_parameters, [integer("interpolation", 0)]);

    // A parameter event reports another node's change; one naming this node and a
    // parameter it does not have, or another value for one it has, changes nothing.
    let foreign = ParameterEvent {
        node: "/cam/rectify_node".into(),
        new_parameters: vec![integer("no_such_parameter", 5)],
        changed_parameters: vec![integer("no_such_parameter", 6), integer("interpolation", 2)],
        deleted_parameters: vec![integer("queue_size", 7)],
        ..ParameterEvent::default()
    };
    let publisher = peer
        .publisher::<ParameterEvent>("/parameter_events", qos::reliable(100))
        .expect("parameter events publisher");
    let deadline = Instant::now() + TIMEOUT;
    loop {
        publisher.publish(foreign.clone()).expect("publish event");
        let seen = block_on_timeout(
            async {
                loop {
                    if let Ok((event, _)) = events.async_take().await
                        && event == foreign
                    {
                        break;
                    }
                }
            },
            Duration::from_secs(2),
        );
        if seen.is_some() {
            break;
        }
        assert!(
            Instant::now() < deadline,
            "our parameter event was not on the domain in {TIMEOUT:?}"
        );
    }
    assert_eq!(get_values(peer.node()), [0, 7]);
    let names = call(peer.node(), &list, ListParametersRequest::default())
        .result
        .names;
    assert!(
        !names.iter().any(|name| name == "no_such_parameter"),
        "{names:?}"
    );
    assert!(names.iter().any(|name| name == "queue_size"), "{names:?}");

    let exit = process.terminate();
    assert!(
        exit.clean(),
        "rectify_node failed on SIGTERM:\n{}",
        exit.logs
    );
}

#[test]
fn with_sim_time_parameter_events_carry_clock_time() {
    let domain = DomainLease::for_test().expect("a ROS domain");
    let process = start_node(&domain, &["-p", "use_sim_time:=true"]);
    let mut peer = common::test_node(&domain, "sim_time");
    let clock = peer
        .publisher::<Clock>("/clock", qos::reliable(1))
        .expect("clock publisher");
    let events = peer
        .subscription::<ParameterEvent>("/parameter_events", qos::reliable(100))
        .expect("parameter events subscription");
    let setter =
        client::<SetParametersRequest, SetParametersResponse>(peer.node_mut(), "set_parameters");
    let sim_now = Time {
        sec: 42,
        nanosec: 5,
    };
    // /clock is received best-effort: set again until an event carries the clock's time.
    let deadline = Instant::now() + TIMEOUT;
    let mut stamps = Vec::new();
    for value in (0..=2).cycle() {
        assert!(
            Instant::now() < deadline,
            "no event stamped {sim_now:?}: {stamps:?}"
        );
        clock
            .publish(Clock { clock: sim_now })
            .expect("publish /clock");
        let request = SetParametersRequest {
            parameters: vec![integer("interpolation", value)],
        };
        assert!(call(peer.node(), &setter, request).results[0].successful);
        while let Ok(Some((event, _))) = events.take() {
            stamps.push(event.stamp);
        }
        if stamps.contains(&sim_now) {
            break;
        }
    }
    let exit = process.terminate();
    assert!(
        exit.clean(),
        "rectify_node failed on SIGTERM:\n{}",
        exit.logs
    );
}
