//! End to end over DDS on loopback: rendered rectified pairs replayed into the built
//! `disparity_node` (on this test's own ROS domain). Every pair's DisparityImage
//! arrives with the left image's header, equal to what the stage (and so `stereocal
//! depth`) computes offline; a pair whose camera_infos describe no horizontal rig
//! publishes nothing and the node goes on; it stops cleanly. Through `disparity_node`
//! and `point_cloud_node` a pair becomes an organized, coloured cloud.

use std::process::Command;
use std::time::{Duration, Instant};

use ros2_client::{Publisher, Subscription};
use stereocal::depth::cloud::CloudLayout;
use stereocal::depth::point_cloud_node::cloud_msg;
use stereocal::depth::stage::{DepthStage, disparity_msg};
use stereocal_msgs::builtin_interfaces::Time;
use stereocal_msgs::sensor_msgs::{CameraInfo, Image, PointCloud2};
use stereocal_msgs::stereo_msgs::DisparityImage;
use stereocal_runtime::qos;
use stereocal_runtime::testing::{DomainLease, NodeProcess, PeerNode};
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

/// The rectified pairs of a rendered depth bag, with their camera_infos.
fn pairs_of(bag: &std::path::Path) -> Vec<Pair> {
    let topic = |side: &str, name: &str| format!("/stereo/{side}/{name}");
    let lefts: Vec<Image> = messages(bag, &topic("left", "image_rect"));
    let rights: Vec<Image> = messages(bag, &topic("right", "image_rect"));
    let left_infos: Vec<CameraInfo> = messages(bag, &topic("left", "camera_info"));
    let right_infos: Vec<CameraInfo> = messages(bag, &topic("right", "camera_info"));
    (0..lefts.len())
        .map(|i| Pair {
            left: lefts[i].clone(),
            right: rights[i].clone(),
            left_info: left_infos[i].clone(),
            right_info: right_infos[i].clone(),
        })
        .collect()
}

impl Player {
    /// Publishers of the pair's topics in /stereo and a subscriber of its disparity.
    fn new(peer: &mut PeerNode) -> Self {
        let topic = |side: &str, name: &str| format!("/stereo/{side}/{name}");
        Self {
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
        }
    }

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
    let pairs = pairs_of(&dir.path().join("bag"));

    let domain = DomainLease::for_test().unwrap();
    let mut peer = common::test_node(&domain, "disparity_player");
    let mut player = Player::new(&mut peer);
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

#[test]
fn a_replayed_pair_gets_its_point_cloud_through_both_nodes() {
    let dir = tempfile::tempdir().unwrap();
    synthesize(dir.path(), 1);
    let pair = pairs_of(&dir.path().join("bag")).remove(0);

    let domain = DomainLease::for_test().unwrap();
    let mut peer = common::test_node(&domain, "cloud_player");
    let mut player = Player::new(&mut peer);
    let clouds = peer
        .subscription::<PointCloud2>("/stereo/points2", qos::reliable(10))
        .unwrap();
    let mut disparity = Command::new(env!("CARGO_BIN_EXE_disparity_node"));
    disparity.args([
        "--ros-args",
        "-r",
        "__ns:=/stereo",
        "-p",
        "disparity_range:=64",
    ]);
    let disparity = NodeProcess::spawn(disparity, domain.id()).expect("disparity_node starts");
    // Mono images give grey points; the colour topic is the rectified mono one here.
    let mut cloud = Command::new(env!("CARGO_BIN_EXE_point_cloud_node"));
    cloud.args([
        "--ros-args",
        "-r",
        "__ns:=/stereo",
        "-r",
        "left/image_rect_color:=left/image_rect",
    ]);
    let cloud = NodeProcess::spawn(cloud, domain.id()).expect("point_cloud_node starts");

    // Send the pair (camera_infos first) every second until its cloud arrives.
    let stamp = pair.left.header.stamp;
    let deadline = Instant::now() + PAIR_DEADLINE;
    let points = 'wait: loop {
        player.infos[0].publish(pair.left_info.clone()).unwrap();
        player.infos[1].publish(pair.right_info.clone()).unwrap();
        player.images[0].publish(pair.left.clone()).unwrap();
        player.images[1].publish(pair.right.clone()).unwrap();
        let resend = Instant::now() + Duration::from_secs(1);
        while Instant::now() < resend {
            player.poll();
            while let Ok(Some((m, _))) = clouds.take() {
                if m.header.stamp == stamp {
                    break 'wait m;
                }
            }
            std::thread::sleep(Duration::from_millis(10));
        }
        assert!(Instant::now() < deadline, "no points2 in {PAIR_DEADLINE:?}");
    };
    for node in [cloud, disparity] {
        let exit = node.terminate();
        assert!(exit.clean(), "a node did not stop cleanly:\n{}", exit.logs);
    }

    // The cloud is the disparity's, through the camera_infos, in PCL's padded layout
    // with colour: x, y, z, rgb at 16, 32 bytes a point.
    player.poll();
    let disparity = player
        .received
        .iter()
        .find(|d| d.header.stamp == stamp)
        .unwrap();
    let layout = CloudLayout {
        color: true,
        avoid_padding: false,
    };
    let offline = cloud_msg(
        &pair.left,
        disparity,
        &pair.left_info,
        &pair.right_info,
        layout,
    )
    .unwrap();
    assert_eq!(points, offline);
    assert_eq!(
        (points.point_step, points.width, points.height),
        (32, 320, 240)
    );
    let values: Vec<f32> = disparity
        .image
        .data
        .chunks_exact(4)
        .map(|b| f32::from_le_bytes(b.try_into().unwrap()))
        .collect();
    let mut checked = 0;
    for (i, &d) in values.iter().enumerate() {
        let at = i * 32;
        let z = f32::from_le_bytes(points.data[at + 8..at + 12].try_into().unwrap());
        if d >= disparity.min_disparity && d > 0.0 {
            assert!(
                (z - disparity.f * disparity.t / d).abs() <= 1e-4 * z,
                "pixel {i}: z {z}"
            );
            // Grey: r = g = b = the left image's pixel.
            let rgb = u32::from_le_bytes(points.data[at + 16..at + 20].try_into().unwrap());
            let grey = u32::from(pair.left.data[i]);
            assert_eq!(rgb, (grey << 16) | (grey << 8) | grey, "pixel {i}");
            checked += 1;
        } else {
            assert!(z.is_nan(), "pixel {i}: z {z} without a disparity");
        }
    }
    assert!(checked > 320 * 240 / 2, "only {checked} points");
}
