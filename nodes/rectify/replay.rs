//! Replays a bag's cameras through rectify nodes running as their own processes over
//! DDS on loopback, and collects what they publish: the on-robot path, driven from a
//! recording. Each camera namespace `<ns>` gets one node that subscribes
//! `<ns>/image_raw` and `<ns>/camera_info` and publishes `<ns>/image_rect`.

use std::collections::{BTreeMap, HashMap};
use std::ffi::OsString;
use std::path::Path;
use std::process::Command;
use std::time::{Duration, Instant};

use anyhow::{Context as _, bail};
use ros2_client::{Publisher, Subscription};
use stereocal_msgs::builtin_interfaces::Time;
use stereocal_msgs::sensor_msgs::{CameraInfo, Image};
use stereocal_rosbag::{BagReader, TopicFilter};
use stereocal_runtime::qos;
use stereocal_runtime::testing::{NodeProcess, PeerNode};
use stereocal_runtime::transport::{DiscoveryRange, TransportConfig};

use crate::tools::{Percentiles, percentiles};

/// How to run the nodes and pace the replay.
#[derive(Clone, Debug)]
pub struct NodeReplay {
    /// Program and leading arguments that start one rectify node; the ROS arguments
    /// (`--ros-args -r __ns:=... `) are appended. E.g. the `rectify_node` executable, or
    /// this executable with `node rectify`.
    pub node_command: Vec<OsString>,
    /// ROS domain of the replay: the nodes and the player join it, nothing else should.
    pub domain_id: u16,
    /// Image frames (all cameras of one stamp together) published per second.
    pub rate_hz: f64,
    /// How long to wait for the nodes to come up, and for the last frames after the
    /// last one was sent.
    pub timeout: Duration,
}

/// What came back from the nodes.
#[derive(Debug, Default)]
pub struct ReplayOutcome {
    /// Per camera namespace: raw images published.
    pub sent: BTreeMap<String, usize>,
    /// Per camera namespace: rectified images received, by stamp.
    pub rectified: BTreeMap<String, BTreeMap<Time, Image>>,
    /// Time from publishing each raw image to receiving its rectified image.
    pub latencies: Vec<Duration>,
    /// What each node printed on stderr.
    pub node_logs: BTreeMap<String, String>,
}

impl ReplayOutcome {
    /// Rectified images received over all cameras.
    pub fn received(&self) -> usize {
        self.rectified.values().map(BTreeMap::len).sum()
    }

    /// Raw images sent over all cameras.
    pub fn total_sent(&self) -> usize {
        self.sent.values().sum()
    }

    /// Percentiles of the latency from publishing a raw image to receiving it
    /// rectified; `None` when nothing arrived.
    pub fn latency(&self) -> Option<Percentiles> {
        percentiles(&self.latencies)
    }
}

/// The stamp warm-up frames carry; no recorded frame uses it.
const WARM_UP_STAMP: Time = Time { sec: 0, nanosec: 1 };

/// One camera's node process and the player's endpoints for it.
struct CameraLink {
    namespace: String,
    process: NodeProcess,
    image_pub: Publisher<Image>,
    info_pub: Publisher<CameraInfo>,
    rect_sub: Subscription<Image>,
}

/// Replays `<ns>/image_raw` and `<ns>/camera_info` of every namespace in `cameras`
/// from `bag` through one rectify node per camera, and returns what they published.
/// Nodes are stopped with SIGTERM at the end, whatever happens.
pub fn replay_through_rectify_nodes(
    bag: &Path,
    cameras: &[String],
    replay: &NodeReplay,
) -> anyhow::Result<ReplayOutcome> {
    let reader = BagReader::open(bag)?;
    let transport = TransportConfig {
        range: DiscoveryRange::Localhost,
        ..TransportConfig::rustdds_defaults()
    };
    let mut player = PeerNode::new(&transport, replay.domain_id, "/stereocal", "replay")?;
    let mut links = Vec::new();
    for namespace in cameras {
        let process = start_node(namespace, replay)?;
        links.push(CameraLink {
            namespace: namespace.clone(),
            process,
            image_pub: player.publisher(&format!("{namespace}/image_raw"), qos::reliable(10))?,
            info_pub: player.publisher(&format!("{namespace}/camera_info"), qos::reliable(10))?,
            rect_sub: player
                .subscription(&format!("{namespace}/image_rect"), qos::reliable(100))?,
        });
    }
    let result = run_replay(&reader, &links, replay);
    let mut node_logs = BTreeMap::new();
    for link in links {
        let CameraLink {
            namespace,
            process,
            rect_sub,
            image_pub,
            info_pub,
        } = link;
        // Endpoints go before the node and its participant, which must remove them.
        drop((rect_sub, image_pub, info_pub));
        node_logs.insert(namespace, process.terminate().logs);
    }
    drop(player);
    let mut outcome = result?;
    outcome.node_logs = node_logs;
    Ok(outcome)
}

fn run_replay(
    reader: &BagReader,
    links: &[CameraLink],
    replay: &NodeReplay,
) -> anyhow::Result<ReplayOutcome> {
    let mut outcome = ReplayOutcome::default();
    warm_up(reader, links, replay)?;

    let topics: Vec<String> = links
        .iter()
        .flat_map(|l| {
            [
                format!("{}/image_raw", l.namespace),
                format!("{}/camera_info", l.namespace),
            ]
        })
        .collect();
    let period = Duration::from_secs_f64(1.0 / replay.rate_hz.max(0.1));
    let mut sent_at: HashMap<(usize, Time), Instant> = HashMap::new();
    let mut next_tick = Instant::now();
    let mut last_stamp = None;
    for message in reader.messages(&TopicFilter::only(&topics)) {
        let message = message?;
        let Some((index, link)) = links
            .iter()
            .enumerate()
            .find(|(_, l)| message.topic.starts_with(&format!("{}/", l.namespace)))
        else {
            continue;
        };
        if message.topic.ends_with("/camera_info") {
            let info: CameraInfo = message.decode()?;
            link.info_pub
                .publish(info)
                .map_err(|e| anyhow::anyhow!("publishing {}: {e:?}", message.topic))?;
            continue;
        }
        let image: Image = message.decode()?;
        let stamp = image.header.stamp;
        if last_stamp != Some(stamp) {
            // A new frame: keep the pace, collecting what arrives meanwhile.
            collect_until(links, next_tick, &sent_at, &mut outcome);
            next_tick = Instant::now().max(next_tick) + period;
            last_stamp = Some(stamp);
        }
        sent_at.insert((index, stamp), Instant::now());
        link.image_pub
            .publish(image)
            .map_err(|e| anyhow::anyhow!("publishing {}: {e:?}", message.topic))?;
        *outcome.sent.entry(link.namespace.clone()).or_default() += 1;
    }
    let deadline = Instant::now() + replay.timeout;
    while outcome.received() < outcome.total_sent() && Instant::now() < deadline {
        collect_until(
            links,
            Instant::now() + Duration::from_millis(20),
            &sent_at,
            &mut outcome,
        );
    }
    Ok(outcome)
}

/// Publishes the first recorded frame of every camera, stamped [`WARM_UP_STAMP`], until
/// each node has answered one: a best-effort reader drops samples of writers it has not
/// matched yet, so frames sent right after start-up could be lost.
fn warm_up(reader: &BagReader, links: &[CameraLink], replay: &NodeReplay) -> anyhow::Result<()> {
    let mut frames = Vec::new();
    for link in links {
        let first = |suffix: &str| {
            let topic = format!("{}/{suffix}", link.namespace);
            reader
                .messages(&TopicFilter::only([topic.as_str()]))
                .next()
                .with_context(|| format!("the bag has no {topic}"))
        };
        let mut image: Image = first("image_raw")??.decode()?;
        let mut info: CameraInfo = first("camera_info")??.decode()?;
        image.header.stamp = WARM_UP_STAMP;
        info.header.stamp = WARM_UP_STAMP;
        frames.push((image, info));
    }
    let deadline = Instant::now() + replay.timeout;
    let mut answered = vec![false; links.len()];
    while answered.iter().any(|a| !a) {
        if Instant::now() > deadline {
            let silent: Vec<&str> = links
                .iter()
                .zip(&answered)
                .filter(|(_, a)| !**a)
                .map(|(l, _)| l.namespace.as_str())
                .collect();
            bail!(
                "no rectify node answered within {:?} for {}",
                replay.timeout,
                silent.join(", ")
            );
        }
        for ((link, (image, info)), answered) in links.iter().zip(&frames).zip(&mut answered) {
            if *answered {
                continue;
            }
            let _ = link.info_pub.publish(info.clone());
            let _ = link.image_pub.publish(image.clone());
        }
        let until = Instant::now() + Duration::from_millis(200);
        while Instant::now() < until {
            for (link, answered) in links.iter().zip(&mut answered) {
                while let Ok(Some((image, _))) = link.rect_sub.take() {
                    *answered |= image.header.stamp == WARM_UP_STAMP;
                }
            }
            std::thread::sleep(Duration::from_millis(5));
        }
    }
    Ok(())
}

/// Takes rectified images as they arrive until `until`.
fn collect_until(
    links: &[CameraLink],
    until: Instant,
    sent_at: &HashMap<(usize, Time), Instant>,
    outcome: &mut ReplayOutcome,
) {
    loop {
        let mut got = false;
        for (index, link) in links.iter().enumerate() {
            while let Ok(Some((image, _))) = link.rect_sub.take() {
                got = true;
                let stamp = image.header.stamp;
                let Some(sent) = sent_at.get(&(index, stamp)) else {
                    continue; // a late warm-up answer
                };
                outcome.latencies.push(sent.elapsed());
                outcome
                    .rectified
                    .entry(link.namespace.clone())
                    .or_default()
                    .insert(stamp, image);
            }
        }
        let now = Instant::now();
        if now >= until {
            return;
        }
        if !got {
            std::thread::sleep(Duration::from_millis(1).min(until - now));
        }
    }
}

/// Starts the rectify node of camera namespace `namespace` as its own process.
fn start_node(namespace: &str, replay: &NodeReplay) -> anyhow::Result<NodeProcess> {
    let (program, leading) = replay
        .node_command
        .split_first()
        .context("empty node command")?;
    let mut command = Command::new(program);
    command
        .args(leading)
        .args([
            "--ros-args",
            "-r",
            &format!("__ns:={namespace}"),
            "-r",
            "image:=image_raw",
        ])
        .env("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST");
    Ok(NodeProcess::spawn(command, replay.domain_id)?)
}
