//! `stereocal play` publishes a bag over DDS as recorded: every message of the played
//! topics arrives with the recorded content and in order, and `/clock` carries each
//! message's recorded time.
//!
//! The player loops, and the test waits until one whole pass has arrived: a reader of
//! another RustDDS participant may only match the player's writers seconds after the
//! player matched it (on the next participant announcement), and what was sent before
//! is not repaired for it.

use std::path::Path;
use std::process::Command;
use std::time::{Duration, Instant};

use stereocal::cli::demo::BUNDLED_STEREO;
use stereocal_msgs::builtin_interfaces::Time;
use stereocal_msgs::rosgraph_msgs::Clock;
use stereocal_msgs::sensor_msgs::{CameraInfo, Image};
use stereocal_rosbag::{BagReader, TopicFilter};
use stereocal_runtime::qos;
use stereocal_runtime::testing::{DomainLease, NodeProcess};

use crate::common;

/// Whether `received` holds `pass` as a contiguous run.
fn holds_pass<T: PartialEq>(received: &[T], pass: &[T]) -> bool {
    received.windows(pass.len()).any(|run| run == pass)
}

#[test]
fn a_bag_is_played_as_recorded_with_its_clock() {
    let bag_path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join(BUNDLED_STEREO)
        .join("bag");
    let bag = BagReader::open(&bag_path).expect("bundled bag");
    let topics = ["/stereo/left/image_raw", "/stereo/left/camera_info"];
    let (mut images, mut infos, mut log_times) = (Vec::new(), Vec::new(), Vec::new());
    for message in bag.messages(&TopicFilter::only(topics)) {
        let message = message.expect("bag message");
        log_times.push(Time::from_nanos(
            i64::try_from(message.log_time_ns).expect("time"),
        ));
        match &*message.topic {
            "/stereo/left/image_raw" => images.push(message.decode::<Image>().expect("image")),
            _ => infos.push(message.decode::<CameraInfo>().expect("camera_info")),
        }
    }

    let domain = DomainLease::for_test().expect("a ROS domain");
    let mut peer = common::test_node(&domain, "listener");
    let image_sub = peer
        .subscription::<Image>(topics[0], qos::reliable(50))
        .expect("image subscription");
    let info_sub = peer
        .subscription::<CameraInfo>(topics[1], qos::reliable(50))
        .expect("camera_info subscription");
    let clock_sub = peer
        .subscription::<Clock>("/clock", qos::reliable(50))
        .expect("clock subscription");
    let mut command = Command::new(env!("CARGO_BIN_EXE_stereocal"));
    command
        .args(["play", "--loop", "--rate", "4", "--clock", "--bag"])
        .arg(&bag_path)
        .arg("--topics")
        .args(topics);
    let player = NodeProcess::spawn(command, domain.id()).expect("stereocal play starts");

    let deadline = Instant::now() + Duration::from_secs(60);
    let (mut got_images, mut got_infos, mut clock) = (Vec::new(), Vec::new(), Vec::new());
    while !(holds_pass(&got_images, &images)
        && holds_pass(&got_infos, &infos)
        && holds_pass(&clock, &log_times))
    {
        assert!(
            Instant::now() < deadline,
            "no whole pass in 60 s: {} images, {} camera_infos, {} clock ticks\n{}",
            got_images.len(),
            got_infos.len(),
            clock.len(),
            player.logs()
        );
        while let Ok(Some((image, _))) = image_sub.take() {
            got_images.push(image);
        }
        while let Ok(Some((info, _))) = info_sub.take() {
            got_infos.push(info);
        }
        while let Ok(Some((tick, _))) = clock_sub.take() {
            clock.push(tick.clock);
        }
        std::thread::sleep(Duration::from_millis(10));
    }
    let exit = player.terminate();
    assert!(
        exit.clean(),
        "stereocal play failed on SIGTERM:\n{}",
        exit.logs
    );
    assert!(exit.logs.contains("pass(es) at rate 4"), "{}", exit.logs);
}
