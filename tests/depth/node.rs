//! End to end over DDS on loopback: rendered rectified pairs replayed into the built
//! `disparity_node` (on this test's own ROS domain). Every pair's DisparityImage
//! arrives with the left image's header, equal to what the stage (and so `stereocal
//! depth`) computes offline; a pair whose camera_infos describe no horizontal rig
//! publishes nothing and the node goes on; it stops cleanly.

use std::process::Command;
use std::time::{Duration, Instant};

use ros2_client::{Publisher, Subscription};
use stereocal::depth::stage::{DepthStage, disparity_msg};
use stereocal_msgs::builtin_interfaces::Time;
use stereocal_msgs::sensor_msgs::{CameraInfo, Image};
use stereocal_msgs::stereo_msgs::DisparityImage;
use stereocal_runtime::qos;
use stereocal_runtime::testing::{DomainLease, NodeProcess};
use stereocal_vision::stereo::SgmParams;

use super::cli::{messages, synthesize};
use crate::common;

/// Longest wait for the node to answer one pair; pairs are sent again every second
/// meanwhile (they are best-effort to the node).
const PAIR_DEADLINE: Duration = Duration::from_secs(30);

/// One rectified pair with its camera_infos.
#[derive(Clone)]
struct Pair {
    left: Image,
    right: Image,
    left_info: CameraInfo,
    right_info: CameraInfo,
}

impl Pair {
    fn stamped(&self, stamp: Time) -> Pair {
        let mut pair = self.clone();
        pair.left.header.stamp = stamp;
        pair.right.header.stamp = stamp;
        pair.left_info.header.stamp = stamp;
        pair.right_info.header.stamp = stamp;
        pair
    }
}

/// The test's side of the node.
struct Player {
    images: [Publisher<Image>; 2],
    infos: [Publisher<CameraInfo>; 2],
    disparity: Subscription<DisparityImage>,
    received: Vec<DisparityImage>,
}

impl Player {
    fn poll(&mut self) {
        while let Ok(Some((m, _))) = self.disparity.take() {
            self.received.push(m);
        }
    }

    fn has(&self, stamp: Time) -> bool {
        self.received.iter().any(|d| d.header.stamp == stamp)
    }

    /// Sends `pair` (camera_infos first) every second until `answered` holds.
    fn send_until(&mut self, pair: &Pair, what: &str, answered: impl Fn(&Self) -> bool) {
        let deadline = Instant::now() + PAIR_DEADLINE;
        loop {
            self.infos[0].publish(pair.left_info.clone()).unwrap();
            self.infos[1].publish(pair.right_info.clone()).unwrap();
            self.images[0].publish(pair.left.clone()).unwrap();
            self.images[1].publish(pair.right.clone()).unwrap();
            let resend = Instant::now() + Duration::from_secs(1);
            while Instant::now() < resend {
                self.poll();
                if answered(self) {
                    return;
                }
                std::thread::sleep(Duration::from_millis(10));
            }
            assert!(
                Instant::now() < deadline,
                "{what}: no answer in {PAIR_DEADLINE:?}"
            );
        }
    }
}

#[test]
fn replayed_pairs_get_their_disparity_over_dds_as_the_stage_computes_it() {
    let dir = tempfile::tempdir().unwrap();
    synthesize(dir.path(), 2);
    let bag = dir.path().join("bag");
    let topic = |side: &str, name: &str| format!("/stereo/{side}/{name}");
    let lefts: Vec<Image> = messages(&bag, &topic("left", "image_rect"));
    let rights: Vec<Image> = messages(&bag, &topic("right", "image_rect"));
    let left_infos: Vec<CameraInfo> = messages(&bag, &topic("left", "camera_info"));
    let right_infos: Vec<CameraInfo> = messages(&bag, &topic("right", "camera_info"));
    let pairs: Vec<Pair> = (0..2)
        .map(|i| Pair {
            left: lefts[i].clone(),
            right: rights[i].clone(),
            left_info: left_infos[i].clone(),
            right_info: right_infos[i].clone(),
        })
        .collect();

    let domain = DomainLease::for_test().unwrap();
    let mut peer = common::test_node(&domain, "disparity_player");
    let mut player = Player {
        images: ["left", "right"].map(|side| {
            peer.publisher(&topic(side, "image_rect"), qos::reliable(10))
                .unwrap()
        }),
        infos: ["left", "right"].map(|side| {
            peer.publisher(&topic(side, "camera_info"), qos::reliable(10))
                .unwrap()
        }),
        disparity: peer
            .subscription("/stereo/disparity", qos::reliable(10))
            .unwrap(),
        received: Vec::new(),
    };
    let mut command = Command::new(env!("CARGO_BIN_EXE_disparity_node"));
    command.args([
        "--ros-args",
        "-r",
        "__ns:=/stereo",
        "-p",
        "disparity_range:=64",
    ]);
    let node = NodeProcess::spawn(command, domain.id()).expect("disparity_node starts");

    for pair in &pairs {
        let stamp = pair.left.header.stamp;
        player.send_until(pair, "a good pair", |p| p.has(stamp));
    }
    // Camera_infos of a vertical rig, sent for a few seconds: nothing for that pair,
    // and the next one still gets its disparity.
    let mut vertical = pairs[0].stamped(Time {
        sec: 50,
        nanosec: 0,
    });
    vertical.right_info.p[3] = 0.0;
    vertical.right_info.p[7] = -27.0;
    let give_up = Instant::now() + Duration::from_secs(3);
    player.send_until(&vertical, "a vertical rig", |_| Instant::now() > give_up);
    let after = pairs[1].stamped(Time {
        sec: 51,
        nanosec: 0,
    });
    player.send_until(&after, "the pair after", |p| p.has(after.left.header.stamp));
    assert!(
        !player.has(vertical.left.header.stamp),
        "a vertical rig was matched"
    );

    let exit = node.terminate();
    assert!(
        exit.clean(),
        "disparity_node did not stop cleanly:\n{}",
        exit.logs
    );
    assert!(
        exit.logs.contains("vertical"),
        "the reason is not logged:\n{}",
        exit.logs
    );

    // The node's disparities are the stage's, byte for byte, with stereo_image_proc's
    // defaults the node keeps.
    let params = SgmParams {
        disparity_range: 64,
        uniqueness_ratio: 15,
        speckle_range: 4.0,
        disp12_max_diff: Some(0),
        ..SgmParams::default()
    };
    let mut stage = DepthStage::new(params);
    for pair in &pairs {
        let frame = stage
            .disparity(&pair.left, &pair.left_info, &pair.right, &pair.right_info)
            .unwrap();
        let offline = disparity_msg(&frame, pair.left.header.clone());
        let received = player
            .received
            .iter()
            .find(|d| d.header.stamp == pair.left.header.stamp)
            .unwrap();
        assert_eq!(received, &offline);
    }
}
