//! `stereocal play`: publishes a bag's messages over ROS 2 at their recorded pace (or
//! `--rate` times it), like `ros2 bag play`, as the node `stereocal_player`. With
//! `--clock` every message is preceded by `/clock` (rosgraph_msgs/Clock) at its
//! recorded time, so nodes with `use_sim_time` follow the recording's time whatever the
//! rate; `--loop` starts again at the end (time then goes back, which such nodes
//! notice). Messages of any type are published as recorded, byte for byte, with the
//! reliability and durability they were recorded with.

use std::collections::BTreeMap;
use std::path::PathBuf;
use std::time::{Duration, Instant};

use anyhow::{Context, bail};
use clap::Args;
use ros2_client::Publisher;
use ros2_client::qos::{History, QosProfile};
use stereocal_msgs::builtin_interfaces::Time;
use stereocal_msgs::rosgraph_msgs::Clock;
use stereocal_rosbag::{BagReader, Durability, OfferedQos, Reliability, TopicFilter};
use stereocal_runtime::node::{NodeBuilder, RosNode};
use stereocal_runtime::publisher::TopicPublisher;
use stereocal_runtime::qos;
use stereocal_runtime::raw::RawCdr;
use stereocal_runtime::shutdown::Shutdown;

/// Messages a publisher keeps for late or slow reliable readers, unless the recording
/// offered more.
const PUBLISH_DEPTH: usize = 10;

/// Longest sleep between two looks at the stop request while waiting for a message's
/// time.
const STOP_CHECK: Duration = Duration::from_millis(50);

/// Longest playback span and subscriber wait accepted: a century.
const MAX_SECONDS: f64 = 3.2e9;

/// Arguments of `stereocal play`.
#[derive(Args, Debug)]
pub struct PlayArgs {
    /// The bag: a rosbag2 directory (metadata.yaml + .mcap) or a .mcap file.
    #[arg(long)]
    pub bag: PathBuf,
    /// Playback speed relative to the recording (2: twice as fast).
    #[arg(long, default_value_t = 1.0)]
    pub rate: f64,
    /// Publish /clock (rosgraph_msgs/Clock) at each message's recorded time.
    #[arg(long)]
    pub clock: bool,
    /// Play again from the start at the end, until interrupted.
    #[arg(long = "loop")]
    pub repeat: bool,
    /// Play only these topics (default: every topic).
    #[arg(long, num_args = 1..)]
    pub topics: Vec<String>,
    /// Before playing, wait up to this many seconds until every played topic has a
    /// subscriber (a reliable subscriber then misses nothing).
    #[arg(long, value_name = "SECONDS")]
    pub wait_for_subscribers: Option<f64>,
    /// ROS arguments (`--ros-args -r /cam/image_raw:=/left/image_raw ...`).
    #[arg(trailing_var_arg = true, allow_hyphen_values = true)]
    pub ros_args: Vec<String>,
}

/// One played topic.
struct Played {
    publisher: Publisher<RawCdr>,
    sent: u64,
}

/// Plays the bag of `args` until it ends (or, with `--loop`, until SIGINT/SIGTERM).
pub fn run(args: &PlayArgs) -> anyhow::Result<()> {
    if !(args.rate.is_finite() && args.rate >= 1e-6) {
        bail!("--rate {} must be a number of at least 1e-6", args.rate);
    }
    let subscriber_wait = args
        .wait_for_subscribers
        .map(|seconds| {
            if (0.0..=MAX_SECONDS).contains(&seconds) {
                Ok(Duration::from_secs_f64(seconds))
            } else {
                Err(anyhow::anyhow!(
                    "--wait-for-subscribers {seconds} must be from 0 to {MAX_SECONDS} seconds"
                ))
            }
        })
        .transpose()?;
    let bag = BagReader::open(&args.bag).with_context(|| format!("bag {}", args.bag.display()))?;
    for topic in &args.topics {
        if bag.topic(topic).is_none() {
            bail!("topic {topic} is not in {}", args.bag.display());
        }
    }
    let filter = if args.topics.is_empty() {
        TopicFilter::All
    } else {
        TopicFilter::only(args.topics.iter().cloned())
    };
    let mut node = NodeBuilder::new("stereocal_player").start(args.ros_args.clone())?;
    let mut played = BTreeMap::new();
    for topic in bag.topics().iter().filter(|t| filter.accepts(&t.name)) {
        let offered = OfferedQos::from_rosbag2_yaml(&topic.offered_qos_profiles);
        let publisher = node.advertise_raw(&topic.name, &topic.type_name, replay_qos(&offered))?;
        played.insert(topic.name.clone(), Played { publisher, sent: 0 });
    }
    if bag.topics_message_count(played.keys().map(String::as_str)) == 0 {
        bail!("{} has no message to play", args.bag.display());
    }
    let clock = if args.clock {
        Some(node.advertise::<Clock>("/clock", qos::reliable(PUBLISH_DEPTH))?)
    } else {
        None
    };
    let shutdown = node.shutdown();
    if let Some(limit) = subscriber_wait {
        wait_for_subscribers(&node, &played, clock.as_ref(), limit);
    }
    let started = Instant::now();
    let mut passes = 0u64;
    loop {
        passes += 1;
        play_once(&bag, &filter, args, &mut played, clock.as_ref(), &shutdown)?;
        if !args.repeat || shutdown.requested() {
            break;
        }
    }
    let total: u64 = played.values().map(|p| p.sent).sum();
    eprintln!(
        "played {total} message(s) of {} topic(s) in {:.1} s ({passes} pass(es) at rate {})",
        played.len(),
        started.elapsed().as_secs_f64(),
        args.rate
    );
    for (topic, p) in &played {
        eprintln!("  {topic}: {}", p.sent);
    }
    Ok(())
}

/// The QoS a topic is published with: the recorded publishers' reliability and
/// durability when they all agree (transient local keeps latched topics such as
/// `/tf_static` reaching late subscribers), else reliable and volatile, keeping at
/// least [`PUBLISH_DEPTH`] messages.
fn replay_qos(offered: &[OfferedQos]) -> QosProfile {
    let all = |wanted: fn(&OfferedQos) -> bool| !offered.is_empty() && offered.iter().all(wanted);
    let depth = offered
        .iter()
        .map(|q| q.depth as usize)
        .max()
        .unwrap_or(0)
        .max(PUBLISH_DEPTH);
    let profile = if all(|q| q.reliability == Reliability::BestEffort) {
        QosProfile::publisher_default()
            .reliability_best_effort()
            .history(History::KeepLast { depth })
    } else {
        qos::reliable(depth)
    };
    if all(|q| q.durability == Durability::TransientLocal) {
        profile.durability(ros2_client::qos::Durability::TransientLocal)
    } else {
        profile
    }
}

/// Waits until every played topic (and `/clock`, when published) has a subscriber, at
/// most `limit`.
fn wait_for_subscribers(
    node: &RosNode,
    played: &BTreeMap<String, Played>,
    clock: Option<&TopicPublisher<Clock>>,
    limit: Duration,
) {
    let deadline = Instant::now() + limit;
    let mut unheard: Vec<&str> = played
        .iter()
        .filter(|(_, p)| !node.wait_for_subscription(&p.publisher, deadline))
        .map(|(topic, _)| topic.as_str())
        .collect();
    if clock.is_some_and(|clock| !clock.wait_for_outside_reader(deadline)) {
        unheard.push("/clock");
    }
    if !unheard.is_empty() {
        log::warn!("playing with no subscriber on {}", unheard.join(", "));
    }
}

/// Plays the bag from its start, pacing messages by their log times.
fn play_once(
    bag: &BagReader,
    filter: &TopicFilter,
    args: &PlayArgs,
    played: &mut BTreeMap<String, Played>,
    clock: Option<&TopicPublisher<Clock>>,
    shutdown: &Shutdown,
) -> anyhow::Result<()> {
    let started = Instant::now();
    let mut first_log_time = None;
    for message in bag.messages(filter) {
        if shutdown.requested() {
            break;
        }
        let message = message.with_context(|| format!("bag {}", args.bag.display()))?;
        let first = *first_log_time.get_or_insert(message.log_time_ns);
        let offset = message.log_time_ns.saturating_sub(first) as f64 * 1e-9 / args.rate;
        let Some(due) = Duration::try_from_secs_f64(offset.min(MAX_SECONDS))
            .ok()
            .and_then(|offset| started.checked_add(offset))
        else {
            bail!(
                "{}: message at {} ns is too far from the first",
                message.topic,
                message.log_time_ns
            );
        };
        while let Some(wait) = due.checked_duration_since(Instant::now()) {
            if shutdown.requested() {
                return Ok(());
            }
            std::thread::sleep(wait.min(STOP_CHECK));
        }
        let Some(topic) = played.get_mut(&*message.topic) else {
            continue;
        };
        let sample = match RawCdr::from_sample(&message.data) {
            Ok(sample) => sample,
            Err(reason) => {
                log::warn!(
                    "{}: message at {} ns not played: {reason}",
                    message.topic,
                    message.log_time_ns
                );
                continue;
            }
        };
        if let Some(clock) = clock {
            let now = Time::from_nanos(i64::try_from(message.log_time_ns).unwrap_or(i64::MAX));
            if let Err(e) = clock.publish(Clock { clock: now }) {
                log::warn!("/clock not published: {e:?}");
            }
        }
        match topic.publisher.publish(sample) {
            Ok(()) => topic.sent += 1,
            Err(e) => log::warn!("{}: message not published: {e:?}", message.topic),
        }
    }
    Ok(())
}
