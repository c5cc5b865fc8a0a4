//! `rectify_latency`: `rectify_node` measured end to end over DDS.
//!
//! For every transport configuration and image size asked for, this binary starts the
//! real `rectify_node` process on a ROS domain of its own, with the configuration's
//! environment, and joins that domain with the same transport settings. It publishes
//! `image_raw` and a plumb_bob `camera_info` with the same stamp, like a camera driver,
//! and subscribes to `image_rect`. Warm-up frames go out until one comes back
//! rectified (a best-effort reader drops samples of writers it has not matched yet);
//! then `--frames` frames are published at `--rate`. Each frame's stamp is its send
//! time (wall clock), so the latency of a rectified frame is its receive time minus its
//! stamp. Every received frame is compared with what the rectify stage computes from
//! the same image and camera_info. The report is a markdown table per run, and the
//! ratios of each configuration against the first.

use std::{
    collections::HashMap,
    net::SocketAddr,
    path::PathBuf,
    process::Command,
    sync::{
        Arc, Mutex,
        atomic::{AtomicBool, AtomicUsize, Ordering},
    },
    thread,
    time::{Duration, Instant},
};

use anyhow::{Context as _, anyhow, bail};
use clap::{Parser, ValueEnum};
use ros2_client::{
    Publisher, Subscription,
    dds::rustdds::mio1::{Events, Interest, Poll, Token},
};
use stereocal::rectify::stage::{Rectified, Rectifier};
use stereocal::tools::camera::{camera_info, image, now, pixels};
use stereocal::tools::{ImageSize, Percentiles, Reliability as Rel, percentiles};
use stereocal_msgs::builtin_interfaces::Time;
use stereocal_msgs::sensor_msgs::{CameraInfo, Image};
use stereocal_runtime::qos;
use stereocal_runtime::testing::{NodeProcess, PeerNode, block_on_timeout};
use stereocal_runtime::transport::{RECEIVE_BUFFER_ENV, SEND_BUFFER_ENV, TransportConfig};
use stereocal_vision::rectify::RemapOptions;

/// Distinct images the camera cycles through.
const PATTERNS: usize = 2;

/// Frames kept by the publishers' and the `image_rect` reader's histories.
const DEPTH: usize = 5;

/// How long discovery may take.
const DISCOVERY_TIMEOUT: Duration = Duration::from_secs(20);

/// How long warm-up frames are sent while none comes back rectified.
const WARM_UP_TIMEOUT: Duration = Duration::from_secs(10);

/// Time the writers get after the first round trip before measuring, so late matches
/// and warm-up frames still in flight settle.
const SETTLE: Duration = Duration::from_millis(500);

#[derive(Parser, Clone, Debug)]
#[command(about = "Latency and delivery of rectify_node end to end over DDS")]
struct Args {
    /// Frames measured per image size and configuration (after the warm-up).
    #[arg(long, default_value_t = 300)]
    frames: u32,
    /// Publication rate, Hz.
    #[arg(long, default_value_t = 30.0)]
    rate: f64,
    /// Image sizes, WIDTHxHEIGHT:ENCODING with ENCODING mono8 or rgb8.
    #[arg(
        long,
        value_delimiter = ',',
        default_value = "640x480:mono8,1280x720:mono8,1920x1080:mono8,640x480:rgb8,1280x720:rgb8,1920x1080:rgb8"
    )]
    sizes: Vec<ImageSize>,
    /// Transport configurations, run back to back in this order for each size.
    #[arg(
        long,
        value_enum,
        value_delimiter = ',',
        default_value = "default,tuned"
    )]
    configs: Vec<Config>,
    /// ROS domain id of the first run; each run uses the next one.
    #[arg(long, default_value_t = 150)]
    domain: u16,
    /// The rectify_node executable (default: the one next to this binary).
    #[arg(long)]
    node: Option<PathBuf>,
    /// Reliability of the `image_rect` subscription.
    #[arg(long, value_enum, default_value_t = Rel::Reliable)]
    rect_reliability: Rel,
    /// Seconds to wait for late frames after the last publish.
    #[arg(long, default_value_t = 2.0)]
    drain: f64,
}

/// A DDS transport configuration, given to the node and to this process alike.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
enum Config {
    /// What RustDDS does unasked: every interface, 8 MiB socket buffer requests.
    Default,
    /// The recommended settings on one host: `ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST`.
    Tuned,
    /// Every interface and no socket buffer requests (the OS defaults).
    OsBuffers,
}

impl Config {
    /// The environment variables this configuration sets; the others it clears.
    fn env(self) -> Vec<(&'static str, &'static str)> {
        match self {
            Config::Default => Vec::new(),
            Config::Tuned => vec![("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")],
            Config::OsBuffers => vec![(RECEIVE_BUFFER_ENV, "0"), (SEND_BUFFER_ENV, "0")],
        }
    }

    /// The transport a node started with [`Self::env`] uses.
    fn transport(self) -> anyhow::Result<TransportConfig> {
        let env = self.env();
        Ok(TransportConfig::from_lookup(|name| {
            env.iter()
                .find(|(n, _)| *n == name)
                .map(|(_, v)| v.to_string())
        })?)
    }

    fn name(self) -> &'static str {
        match self {
            Config::Default => "default",
            Config::Tuned => "tuned",
            Config::OsBuffers => "os-buffers",
        }
    }
}

/// Variables that select a node's transport, cleared before a configuration's own.
const TRANSPORT_VARIABLES: [&str; 4] = [
    "ROS_AUTOMATIC_DISCOVERY_RANGE",
    "ROS_LOCALHOST_ONLY",
    RECEIVE_BUFFER_ENV,
    SEND_BUFFER_ENV,
];

/// What was published with a given stamp.
#[derive(Clone, Copy, Debug)]
struct SentFrame {
    /// Index among the measured frames; `None` for warm-up frames.
    frame: Option<u32>,
    /// Which camera image it was.
    pattern: usize,
}

/// One rectified frame received.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Arrival {
    frame: u32,
    latency_ns: i64,
    /// Whether its pixels are what the rectify stage gives.
    intact: bool,
}

/// What rectify_node reports about itself when it stops.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct NodeCounts {
    received: u64,
    published: u64,
    queue_dropped: u64,
    lost_before_reception: u64,
}

impl NodeCounts {
    /// Reads the node's shutdown summary ("shutting down: R frame(s) received, P
    /// published (O over DDS), D dropped while the rectify thread was busy, L lost
    /// before reception").
    fn from_log(log: &str) -> Option<Self> {
        let summary = log.rsplit("shutting down: ").next()?;
        let count = |label: &str| -> Option<u64> {
            let before = &summary[..summary.find(label)?];
            before
                .rsplit([' ', ','])
                .find(|w| !w.is_empty())?
                .parse()
                .ok()
        };
        Some(Self {
            received: count(" frame(s) received")?,
            published: count(" published")?,
            queue_dropped: count(" dropped while")?,
            lost_before_reception: count(" lost before reception")?,
        })
    }
}

/// The outcome of one configuration and size.
#[derive(Debug)]
struct Row {
    config: Config,
    size: ImageSize,
    sent: u32,
    publish_failed: u32,
    warm_up: u32,
    /// Whether a warm-up frame came back before the measured ones were sent.
    round_trip: bool,
    delivered: usize,
    mismatched: usize,
    latency: Option<Percentiles>,
    publish_p50_ms: Option<f64>,
    node: Option<NodeCounts>,
    reader_locators: Vec<SocketAddr>,
}

/// A measured span in nanoseconds as a duration (a negative one, from clock steps, as 0).
fn nanos(ns: i64) -> Duration {
    Duration::from_nanos(u64::try_from(ns).unwrap_or(0))
}

/// Frames that arrived (each counted once) and their latencies.
fn summarize_arrivals(arrivals: &[Arrival]) -> (usize, usize, Option<Percentiles>) {
    let mut first: HashMap<u32, Arrival> = HashMap::new();
    for a in arrivals {
        first.entry(a.frame).or_insert(*a);
    }
    let latencies: Vec<Duration> = first.values().map(|a| nanos(a.latency_ns)).collect();
    let mismatched = first.values().filter(|a| !a.intact).count();
    (first.len(), mismatched, percentiles(&latencies))
}

/// Starts the rectify_node process of one run, on `domain` with the environment of
/// `config` (the transport variables of the measuring environment removed first).
fn start_node(executable: &PathBuf, domain: u16, config: Config) -> anyhow::Result<NodeProcess> {
    let mut command = Command::new(executable);
    command.args(["--ros-args", "-r", "image:=image_raw"]);
    for variable in TRANSPORT_VARIABLES {
        command.env_remove(variable);
    }
    command.envs(config.env());
    Ok(NodeProcess::spawn(command, domain)?)
}

/// The unicast locators the readers of `topic` that `measurer` discovered advertise.
fn reader_locators(measurer: &PeerNode, topic: &str) -> Vec<SocketAddr> {
    let dds_topic = format!("rt{topic}");
    measurer
        .context()
        .domain_participant()
        .discovered_readers()
        .iter()
        .filter(|r| r.subscription_topic_data.topic_name() == &dds_topic)
        .flat_map(|r| r.reader_proxy.unicast_locator_list.iter())
        .map(|l| SocketAddr::from(*l))
        .collect()
}

/// State shared between the publishing and the receiving threads.
#[derive(Default)]
struct Shared {
    sent: Mutex<HashMap<Time, SentFrame>>,
    arrivals: Mutex<Vec<Arrival>>,
    /// Rectified frames received, warm-up included.
    received: AtomicUsize,
    stop: AtomicBool,
}

/// Takes rectified frames until told to stop, timing and checking each.
fn receive(
    mut subscription: Subscription<Image>,
    shared: &Shared,
    expected: &[Vec<u8>],
) -> anyhow::Result<()> {
    let mut poll = Poll::new()?;
    poll.registry()
        .register(&mut subscription, Token(0), Interest::READABLE)?;
    let mut events = Events::with_capacity(4);
    while !shared.stop.load(Ordering::Relaxed) {
        poll.poll(&mut events, Some(Duration::from_millis(50)))?;
        // Readiness is edge-triggered: take everything that has arrived.
        while let Some((rect, _)) = subscription
            .take()
            .map_err(|e| anyhow!("cannot take image_rect: {e}"))?
        {
            let received = now();
            shared.received.fetch_add(1, Ordering::Relaxed);
            let sent = shared
                .sent
                .lock()
                .map_err(|_| anyhow!("sent-frame table poisoned"))?
                .get(&rect.header.stamp)
                .copied();
            if let Some(SentFrame {
                frame: Some(frame),
                pattern,
            }) = sent
            {
                let arrival = Arrival {
                    frame,
                    latency_ns: received.as_nanos() - rect.header.stamp.as_nanos(),
                    intact: expected.get(pattern).is_some_and(|e| *e == rect.data),
                };
                shared
                    .arrivals
                    .lock()
                    .map_err(|_| anyhow!("arrival list poisoned"))?
                    .push(arrival);
            }
        }
    }
    Ok(())
}

/// Publishes frame after frame with fresh stamps, remembering each.
struct Camera {
    size: ImageSize,
    images: Vec<Vec<u8>>,
    image_pub: Publisher<Image>,
    info_pub: Publisher<CameraInfo>,
    published: u32,
    failed: u32,
    publish_ns: Vec<i64>,
}

impl Camera {
    fn publish(&mut self, shared: &Shared, frame: Option<u32>) -> anyhow::Result<()> {
        let pattern = self.published.wrapping_add(self.failed) as usize % PATTERNS;
        let data = self.images[pattern].clone();
        let started = Instant::now();
        let stamp = now();
        shared
            .sent
            .lock()
            .map_err(|_| anyhow!("sent-frame table poisoned"))?
            .insert(stamp, SentFrame { frame, pattern });
        let info = camera_info(self.size, stamp);
        let result = match self.info_pub.publish(info) {
            Ok(()) => self
                .image_pub
                .publish(image(self.size, stamp, data))
                .map_err(|e| format!("image_raw not published: {e}")),
            Err(e) => Err(format!("camera_info not published: {e}")),
        };
        match result {
            Ok(()) => self.published += 1,
            Err(e) => {
                eprintln!("frame {frame:?}: {e}");
                self.failed += 1;
            }
        }
        if frame.is_some() {
            self.publish_ns
                .push(i64::try_from(started.elapsed().as_nanos()).unwrap_or(i64::MAX));
        }
        Ok(())
    }
}

/// The rectified images of the camera's patterns, as the rectify stage makes them.
fn expected_rectified(size: ImageSize) -> anyhow::Result<Vec<Vec<u8>>> {
    let mut rectifier = Rectifier::new(RemapOptions::default());
    let stamp = Time { sec: 0, nanosec: 0 };
    let info = camera_info(size, stamp);
    (0..PATTERNS)
        .map(
            |p| match rectifier.rectify(&image(size, stamp, pixels(size, p)), &info)? {
                Rectified::Image(rect) => Ok(rect.data),
                Rectified::Uncalibrated { .. } => bail!("camera_info of {size} is uncalibrated"),
            },
        )
        .collect()
}

fn measure(
    args: &Args,
    node_exe: &PathBuf,
    config: Config,
    size: ImageSize,
    domain: u16,
) -> anyhow::Result<Row> {
    let expected = expected_rectified(size)?;
    let transport = config.transport()?;
    let process = start_node(node_exe, domain, config)?;
    let mut measurer = PeerNode::new(&transport, domain, "/", "rectify_latency")?;
    let publisher_qos = qos::reliable(DEPTH);
    let rect_qos = match args.rect_reliability {
        Rel::Reliable => qos::reliable(DEPTH),
        Rel::BestEffort => qos::sensor_data(DEPTH),
    };
    let image_pub = measurer.publisher::<Image>("/image_raw", publisher_qos.clone())?;
    let info_pub = measurer.publisher::<CameraInfo>("/camera_info", publisher_qos)?;
    let rect_sub = measurer.subscription::<Image>("/image_rect", rect_qos)?;
    let matched = block_on_timeout(
        async {
            image_pub.wait_for_subscription(measurer.node()).await;
            info_pub.wait_for_subscription(measurer.node()).await;
            rect_sub.wait_for_publisher(measurer.node()).await;
        },
        DISCOVERY_TIMEOUT,
    );
    if matched.is_none() {
        bail!("rectify_node not discovered within {DISCOVERY_TIMEOUT:?}");
    }
    let reader_locators = reader_locators(&measurer, "/image_raw");

    let shared = Arc::new(Shared::default());
    let receiver = {
        let shared = Arc::clone(&shared);
        thread::spawn(move || receive(rect_sub, &shared, &expected))
    };
    let mut camera = Camera {
        size,
        images: (0..PATTERNS).map(|p| pixels(size, p)).collect(),
        image_pub,
        info_pub,
        published: 0,
        failed: 0,
        publish_ns: Vec::new(),
    };
    let period = Duration::from_secs_f64(1.0 / args.rate);

    // Without a round trip within the limit the frames are measured all the same:
    // that configuration loses frames of this size, and the table shows how many.
    let warm_up_deadline = Instant::now() + WARM_UP_TIMEOUT;
    while shared.received.load(Ordering::Relaxed) == 0 && Instant::now() < warm_up_deadline {
        if receiver.is_finished() {
            break;
        }
        camera.publish(&shared, None)?;
        thread::sleep(period);
    }
    let round_trip = shared.received.load(Ordering::Relaxed) > 0;
    thread::sleep(SETTLE);

    let (published_in_warm_up, failed_in_warm_up) = (camera.published, camera.failed);
    let start = Instant::now();
    for frame in 0..args.frames {
        if let Some(wait) = (start + period * frame).checked_duration_since(Instant::now()) {
            thread::sleep(wait);
        }
        camera.publish(&shared, Some(frame))?;
    }
    let drain_deadline = Instant::now() + Duration::from_secs_f64(args.drain.max(0.0));
    let arrived = || shared.arrivals.lock().map_or(0, |a| a.len());
    while Instant::now() < drain_deadline && arrived() < args.frames as usize {
        thread::sleep(Duration::from_millis(20));
    }
    shared.stop.store(true, Ordering::Relaxed);
    receiver
        .join()
        .map_err(|_| anyhow!("receiver thread panicked"))??;
    let exit = process.terminate();
    if !exit.clean() {
        bail!(
            "rectify_node did not stop cleanly on SIGTERM ({:?}):\n{}",
            exit.status,
            exit.logs
        );
    }
    let log = exit.logs;
    drop(measurer);

    let arrivals = shared
        .arrivals
        .lock()
        .map_err(|_| anyhow!("arrival list poisoned"))?
        .clone();
    let (delivered, mismatched, latency) = summarize_arrivals(&arrivals);
    Ok(Row {
        config,
        size,
        sent: args.frames,
        publish_failed: camera.failed - failed_in_warm_up,
        warm_up: published_in_warm_up + failed_in_warm_up,
        round_trip,
        delivered,
        mismatched,
        latency,
        publish_p50_ms: percentiles(
            &camera
                .publish_ns
                .iter()
                .map(|&n| nanos(n))
                .collect::<Vec<_>>(),
        )
        .map(|p| p.p50),
        node: NodeCounts::from_log(&log),
        reader_locators,
    })
}

fn print_row(row: &Row) {
    let ms = |v: Option<f64>| v.map_or("-".to_string(), |v| format!("{v:.1}"));
    let l = row.latency;
    let node = row.node.map_or("-".to_string(), |n| {
        format!(
            "{}/{}/{}/{}",
            n.received, n.published, n.queue_dropped, n.lost_before_reception
        )
    });
    println!(
        "| {} | {:.2} | {} | {}/{} | {} | {} | {} | {} | {} | {} | {} | {} | {} |",
        row.size,
        row.size.data_len() as f64 / 1e6,
        row.config.name(),
        row.delivered,
        row.sent,
        row.mismatched,
        row.publish_failed,
        ms(l.map(|l| l.p50)),
        ms(l.map(|l| l.p90)),
        ms(l.map(|l| l.p99)),
        ms(l.map(|l| l.max)),
        ms(row.publish_p50_ms),
        if row.round_trip {
            row.warm_up.to_string()
        } else {
            format!("{} (none back)", row.warm_up)
        },
        node,
    );
}

/// Ratios of each configuration against the first one run for the same size.
fn print_ratios(rows: &[Row]) {
    let Some(baseline) = rows.first().map(|r| r.config) else {
        return;
    };
    println!();
    println!("| image | config | p50 ratio | p99 ratio | delivered ratio |");
    println!("|---|---|---|---|---|");
    for row in rows.iter().filter(|r| r.config != baseline) {
        let Some(base) = rows
            .iter()
            .find(|b| b.config == baseline && b.size == row.size)
        else {
            continue;
        };
        let ratio = |a: Option<f64>, b: Option<f64>| match (a, b) {
            (Some(a), Some(b)) if b > 0.0 => format!("{:.2}x", a / b),
            _ => "-".to_string(),
        };
        println!(
            "| {} | {} vs {} | {} | {} | {} |",
            row.size,
            baseline.name(),
            row.config.name(),
            ratio(base.latency.map(|l| l.p50), row.latency.map(|l| l.p50)),
            ratio(base.latency.map(|l| l.p99), row.latency.map(|l| l.p99)),
            ratio(Some(row.delivered as f64), Some(base.delivered as f64)),
        );
    }
}

fn main() -> anyhow::Result<()> {
    let args = Args::parse();
    if !(args.rate.is_finite() && args.rate > 0.0) {
        bail!("--rate must be a positive number of Hz, got {}", args.rate);
    }
    let node_exe = match &args.node {
        Some(path) => path.clone(),
        None => std::env::current_exe()
            .context("cannot locate own executable")?
            .with_file_name("rectify_node"),
    };
    let runs = args.sizes.len() * args.configs.len();
    if usize::from(args.domain) + runs > 233 {
        bail!(
            "--domain {}: {runs} runs need domain ids up to 232",
            args.domain
        );
    }
    println!(
        "rectify_node {}, {} frames at {} Hz per run, image_rect reader {:?}",
        node_exe.display(),
        args.frames,
        args.rate,
        args.rect_reliability
    );
    for config in &args.configs {
        println!("- {}: {}", config.name(), config.transport()?);
    }
    println!();
    println!(
        "| image | MB | config | delivered/sent | mismatched | publish failed | p50 ms | p90 ms | p99 ms | max ms | publish p50 ms | warm-up frames | node rx/tx/queue-dropped/lost |"
    );
    println!("|---|---|---|---|---|---|---|---|---|---|---|---|---|");
    let mut rows = Vec::new();
    let mut domain = args.domain;
    for &size in &args.sizes {
        for &config in &args.configs {
            let row = measure(&args, &node_exe, config, size, domain).with_context(|| {
                format!("measuring {size} with the {} transport", config.name())
            })?;
            print_row(&row);
            if row.reader_locators.is_empty() {
                eprintln!(
                    "{size} {}: rectify_node's image reader advertised no unicast locator",
                    config.name()
                );
            } else {
                eprintln!(
                    "{size} {}: rectify_node's image reader at {:?}",
                    config.name(),
                    row.reader_locators
                );
            }
            rows.push(row);
            domain += 1;
        }
    }
    print_ratios(&rows);
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn configurations_give_the_transport_the_node_will_use() {
        use stereocal_runtime::transport::DiscoveryRange;
        assert_eq!(
            Config::Default.transport().unwrap(),
            TransportConfig::rustdds_defaults()
        );
        assert_eq!(
            Config::Tuned.transport().unwrap().range,
            DiscoveryRange::Localhost
        );
        let os = Config::OsBuffers.transport().unwrap();
        assert_eq!((os.socket_receive_buffer, os.socket_send_buffer), (0, 0));
        assert_eq!(os.range, DiscoveryRange::Subnet);
    }

    #[test]
    fn camera_is_calibrated_and_rectifies_both_patterns() {
        let size: ImageSize = "64x48:rgb8".parse().unwrap();
        let expected = expected_rectified(size).unwrap();
        assert_eq!(expected.len(), PATTERNS);
        assert!(expected.iter().all(|e| e.len() == size.data_len()));
        assert_ne!(expected[0], expected[1]);
        assert_eq!(camera_info(size, Time { sec: 0, nanosec: 0 }).d.len(), 5);
    }

    #[test]
    fn node_summary_is_read_from_its_log() {
        let log = "[INFO] started\n[INFO] [cam.rectify_node]: shutting down: 330 frame(s) \
                   received, 328 published (328 over DDS), 2 dropped while the rectify thread \
                   was busy, 4 \
                   lost before reception, 0 without a partner, 0 with a camera_info of \
                   another stamp\n";
        assert_eq!(
            NodeCounts::from_log(log),
            Some(NodeCounts {
                received: 330,
                published: 328,
                queue_dropped: 2,
                lost_before_reception: 4,
            })
        );
        assert_eq!(NodeCounts::from_log("killed"), None);
    }

    #[test]
    fn each_frame_counts_once_with_nearest_rank_percentiles() {
        let arrivals: Vec<Arrival> = (1..=100)
            .map(|ms| Arrival {
                frame: ms,
                latency_ns: i64::from(ms) * 1_000_000,
                intact: ms != 7,
            })
            .collect();
        let mut with_duplicate = arrivals.clone();
        with_duplicate.push(arrivals[3]);
        let (delivered, mismatched, latency) = summarize_arrivals(&with_duplicate);
        assert_eq!((delivered, mismatched), (100, 1));
        let p = latency.unwrap();
        assert_eq!((p.p50, p.p90, p.p99, p.max), (50.0, 90.0, 99.0, 100.0));
        assert_eq!(summarize_arrivals(&[]).2, None);
    }
}
