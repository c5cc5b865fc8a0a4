//! `dds_latency`: latency and delivery of image-sized messages between two
//! processes over ros2-client/RustDDS.
//!
//! The binary publishes `sensor_msgs/msg/Image` messages of the given sizes at a
//! fixed rate and starts itself a second time as the subscriber, on the same
//! ROS domain. Each message carries its send time (wall clock, taken right
//! before `publish`) in `header.stamp`; the subscriber reports the receive time
//! of every message, and the publisher prints, per size, how many frames
//! arrived and the latency percentiles as a markdown table.

use std::{
    collections::BTreeMap,
    io::{BufRead, BufReader, Read, Write},
    process::{Command, Stdio},
    sync::{
        Arc,
        atomic::{AtomicBool, Ordering},
    },
    thread,
    time::{Duration, Instant, SystemTime, UNIX_EPOCH},
};

use anyhow::{Context as _, anyhow, bail};
use clap::Parser;
use ros2_client::{
    Context, MessageTypeName, Name, Node, NodeName, NodeOptions,
    dds::rustdds::mio1::{Events, Interest, Poll, Token},
    qos::{Durability, History, QosProfile, Reliability, WhenFull},
};
use serde::{Deserialize, Serialize};
use stereocal::tools::{ImageSize, Percentiles, Reliability as Rel, percentiles};
use stereocal_runtime::transport::{DiscoveryRange, TransportConfig};

/// Topic the measurement runs on.
const TOPIC: &str = "dds_latency_image";

/// Number of distinct pixel patterns the publisher cycles through.
const DISTINCT_FRAMES: u32 = 4;

/// Line the subscriber prints once its subscription exists.
const READY: &str = "ready";

#[derive(Parser, Clone, Debug)]
#[command(about = "Latency and delivery of image-sized DDS messages between two processes")]
struct Args {
    /// Frames published per image size.
    #[arg(long, default_value_t = 50)]
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
    /// ROS domain id (default: ROS_DOMAIN_ID, else 0).
    #[arg(long)]
    domain: Option<u16>,
    /// Publisher reliability.
    #[arg(long, value_enum, default_value_t = Rel::Reliable)]
    pub_reliability: Rel,
    /// Subscription reliability.
    #[arg(long, value_enum, default_value_t = Rel::Reliable)]
    sub_reliability: Rel,
    /// History depth (keep-last) of publisher and subscription.
    #[arg(long, default_value_t = 1)]
    depth: usize,
    /// How long a reliable publish waits for room in the send window, ms
    /// (default: one frame period).
    #[arg(long)]
    publish_wait_ms: Option<u64>,
    /// SO_RCVBUF requested, bytes (0: OS default; default: RustDDS's 8 MiB).
    #[arg(long)]
    recv_buffer: Option<usize>,
    /// SO_SNDBUF requested, bytes (0: OS default; default: RustDDS's 8 MiB).
    #[arg(long)]
    send_buffer: Option<usize>,
    /// Restrict both participants to the loopback interface.
    #[arg(long)]
    localhost_only: bool,
    /// Offered deadline of the publisher, ms. RustDDS paces NACK-driven
    /// repair at a fifth of it (1..100 ms; 10 ms without a deadline).
    #[arg(long)]
    deadline_ms: Option<u64>,
    /// Serialize the pixel array element by element instead of in bulk.
    #[arg(long)]
    elementwise: bool,
    /// Seconds to wait for late frames after the last publish.
    #[arg(long, default_value_t = 2.0)]
    drain: f64,
    /// Run as the subscriber (started by the publisher).
    #[arg(long, hide = true)]
    subscriber: bool,
}

/// builtin_interfaces/msg/Time.
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
struct Time {
    sec: i32,
    nanosec: u32,
}

impl Time {
    fn now() -> Self {
        let since = SystemTime::now()
            .duration_since(UNIX_EPOCH)
            .unwrap_or_default();
        Self {
            sec: i32::try_from(since.as_secs()).unwrap_or(i32::MAX),
            nanosec: since.subsec_nanos(),
        }
    }

    fn as_nanos(&self) -> i128 {
        i128::from(self.sec) * 1_000_000_000 + i128::from(self.nanosec)
    }
}

/// std_msgs/msg/Header.
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
struct Header {
    stamp: Time,
    frame_id: String,
}

/// sensor_msgs/msg/Image, generic over how the pixel array is serialized.
#[derive(Clone, Debug, Serialize, Deserialize)]
struct Image<D> {
    header: Header,
    height: u32,
    width: u32,
    encoding: String,
    is_bigendian: u8,
    step: u32,
    data: D,
}

/// Pixel array serialized in one bulk copy.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(transparent)]
struct BulkBytes(#[serde(with = "serde_bytes")] Vec<u8>);

/// Pixel array serialized byte by byte, as a plain `Vec<u8>` is.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(transparent)]
struct ElementBytes(Vec<u8>);

/// Access to the pixel bytes of either representation.
trait Pixels: Clone + Serialize + serde::de::DeserializeOwned + Send + 'static {
    fn from_vec(data: Vec<u8>) -> Self;
    fn bytes(&self) -> &[u8];
}

impl Pixels for BulkBytes {
    fn from_vec(data: Vec<u8>) -> Self {
        Self(data)
    }
    fn bytes(&self) -> &[u8] {
        &self.0
    }
}

impl Pixels for ElementBytes {
    fn from_vec(data: Vec<u8>) -> Self {
        Self(data)
    }
    fn bytes(&self) -> &[u8] {
        &self.0
    }
}

impl<D: Pixels> ros2_client::Message for Image<D> {}

/// Pixel value at `index` of pattern `frame` (its first byte is `frame`): the
/// subscriber checks it to catch misassembled fragments.
fn pixel(frame: u32, index: usize) -> u8 {
    (index as u32).wrapping_mul(31).wrapping_add(frame) as u8
}

/// Whether every 4099th byte (and the last) of `data` holds the pattern of a
/// pattern, for whichever pattern the first byte names.
fn pattern_intact(data: &[u8]) -> bool {
    let Some(&first) = data.first() else {
        return true;
    };
    let frame = u32::from(first);
    let last = data.len() - 1;
    (0..data.len())
        .step_by(4099)
        .chain(std::iter::once(last))
        .all(|i| data[i] == pixel(frame, i))
}

fn qos(reliability: Rel, depth: usize, wait: Duration, deadline: Option<Duration>) -> QosProfile {
    QosProfile {
        reliability: match reliability {
            Rel::Reliable => Reliability::Reliable {
                when_full: WhenFull::Wait(wait),
            },
            Rel::BestEffort => Reliability::BestEffort,
        },
        durability: Durability::Volatile,
        history: History::KeepLast {
            depth: depth.max(1),
        },
        ..QosProfile::subscription_default()
    }
    .deadline(deadline)
}

impl Args {
    fn domain_id(&self) -> u16 {
        self.domain.unwrap_or_else(|| {
            std::env::var("ROS_DOMAIN_ID")
                .ok()
                .and_then(|v| v.trim().parse().ok())
                .unwrap_or(0)
        })
    }

    fn transport(&self) -> TransportConfig {
        let defaults = TransportConfig::rustdds_defaults();
        TransportConfig {
            socket_receive_buffer: self.recv_buffer.unwrap_or(defaults.socket_receive_buffer),
            socket_send_buffer: self.send_buffer.unwrap_or(defaults.socket_send_buffer),
            range: if self.localhost_only {
                DiscoveryRange::Localhost
            } else {
                DiscoveryRange::Subnet
            },
            dds_nice: defaults.dds_nice,
        }
    }

    fn period(&self) -> Duration {
        Duration::from_secs_f64(1.0 / self.rate)
    }

    fn publisher_qos(&self) -> QosProfile {
        let wait = self
            .publish_wait_ms
            .map_or_else(|| self.period(), Duration::from_millis);
        qos(
            self.pub_reliability,
            self.depth,
            wait,
            self.deadline_ms.map(Duration::from_millis),
        )
    }

    fn subscription_qos(&self) -> QosProfile {
        qos(self.sub_reliability, self.depth, self.period(), None)
    }

    /// Arguments that start the subscriber process with the same settings.
    fn subscriber_args(&self, size: ImageSize) -> Vec<String> {
        let mut args = vec![
            "--subscriber".to_string(),
            "--domain".to_string(),
            self.domain_id().to_string(),
            "--sizes".to_string(),
            format!("{}x{}:{}", size.width, size.height, size.encoding()),
            "--sub-reliability".to_string(),
            match self.sub_reliability {
                Rel::Reliable => "reliable",
                Rel::BestEffort => "best-effort",
            }
            .to_string(),
            "--depth".to_string(),
            self.depth.to_string(),
            "--rate".to_string(),
            self.rate.to_string(),
        ];
        let transport = self.transport();
        args.extend([
            "--recv-buffer".to_string(),
            transport.socket_receive_buffer.to_string(),
            "--send-buffer".to_string(),
            transport.socket_send_buffer.to_string(),
        ]);
        if self.localhost_only {
            args.push("--localhost-only".to_string());
        }
        if self.elementwise {
            args.push("--elementwise".to_string());
        }
        args
    }
}

fn new_node(context: &Context, name: &str) -> anyhow::Result<Node> {
    let name = NodeName::new("/", name).map_err(|e| anyhow!("node name {name}: {e}"))?;
    context
        .new_node(
            name,
            NodeOptions::new()
                .enable_rosout(false)
                .start_parameter_services(false),
        )
        .map_err(|e| anyhow!("cannot create node: {e}"))
}

fn image_topic(node: &Node, qos: &QosProfile) -> anyhow::Result<ros2_client::dds::rustdds::Topic> {
    let name = Name::new("/", TOPIC).map_err(|e| anyhow!("topic name: {e}"))?;
    node.create_topic(&name, MessageTypeName::new("sensor_msgs", "Image"), qos)
        .map_err(|e| anyhow!("cannot create topic: {e}"))
}

/// One received frame: which frame, its size, and its latency.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Arrival {
    frame: u32,
    bytes: usize,
    latency_ns: i128,
    intact: bool,
}

impl Arrival {
    fn to_line(self) -> String {
        format!(
            "{} {} {} {}",
            self.frame,
            self.bytes,
            self.latency_ns,
            u8::from(self.intact)
        )
    }

    fn from_line(line: &str) -> Option<Self> {
        let mut fields = line.split_whitespace();
        let arrival = Self {
            frame: fields.next()?.parse().ok()?,
            bytes: fields.next()?.parse().ok()?,
            latency_ns: fields.next()?.parse().ok()?,
            intact: fields.next()? == "1",
        };
        fields.next().is_none().then_some(arrival)
    }
}

/// Receives images until `stop` is set, reporting each arrival to `report`.
fn receive<D: Pixels>(
    context: &Context,
    subscription_qos: QosProfile,
    stop: &AtomicBool,
    on_ready: impl FnOnce(),
    mut report: impl FnMut(Arrival),
) -> anyhow::Result<()> {
    let mut node = new_node(context, "dds_latency_sub")?;
    let topic = image_topic(&node, &subscription_qos)?;
    let mut subscription = node
        .create_subscription::<Image<D>>(&topic, Some(subscription_qos))
        .map_err(|e| anyhow!("cannot create subscription: {e}"))?;
    let mut poll = Poll::new()?;
    poll.registry()
        .register(&mut subscription, Token(0), Interest::READABLE)?;
    let mut events = Events::with_capacity(4);
    on_ready();
    while !stop.load(Ordering::Relaxed) {
        poll.poll(&mut events, Some(Duration::from_millis(50)))?;
        // Readiness is edge-triggered: take everything that has arrived.
        while let Some((image, _info)) = subscription
            .take()
            .map_err(|e| anyhow!("cannot take image: {e}"))?
        {
            let received = Time::now();
            let data = image.data.bytes();
            report(Arrival {
                frame: image.header.frame_id.parse().unwrap_or(u32::MAX),
                bytes: data.len(),
                latency_ns: received.as_nanos() - image.header.stamp.as_nanos(),
                intact: pattern_intact(data),
            });
        }
    }
    Ok(())
}

/// Subscriber process: prints `ready`, then one line per arrival, until its
/// standard input closes.
fn run_subscriber(args: &Args) -> anyhow::Result<()> {
    let context = args.transport().context(args.domain_id())?;
    let stop = Arc::new(AtomicBool::new(false));
    let stop_on_eof = Arc::clone(&stop);
    thread::spawn(move || {
        let mut sink = Vec::new();
        // Any outcome, end of input or error, means the publisher is done.
        let _ = std::io::stdin().read_to_end(&mut sink);
        stop_on_eof.store(true, Ordering::Relaxed);
    });
    let mut arrivals = Vec::new();
    let ready = || {
        println!("{READY}");
        let _ = std::io::stdout().flush();
    };
    let record = |a: Arrival| arrivals.push(a);
    if args.elementwise {
        receive::<ElementBytes>(&context, args.subscription_qos(), &stop, ready, record)?;
    } else {
        receive::<BulkBytes>(&context, args.subscription_qos(), &stop, ready, record)?;
    }
    let mut out = std::io::stdout().lock();
    for a in arrivals {
        writeln!(out, "{}", a.to_line())?;
    }
    out.flush()?;
    Ok(())
}

/// What the publisher observed for one size.
#[derive(Debug, Default)]
struct Sent {
    published: u32,
    failed: u32,
    publish_ns: Vec<u64>,
}

/// Publishes `frames` images of `size` at `rate`, once a subscriber is seen.
fn publish<D: Pixels>(
    context: &Context,
    args: &Args,
    size: ImageSize,
    subscriber_seen: impl Fn(&Node) -> bool,
) -> anyhow::Result<Sent> {
    let mut node = new_node(context, "dds_latency_pub")?;
    let qos = args.publisher_qos();
    let topic = image_topic(&node, &qos)?;
    let publisher = node
        .create_publisher::<Image<D>>(&topic, Some(qos))
        .map_err(|e| anyhow!("cannot create publisher: {e}"))?;
    let discovery_deadline = Instant::now() + Duration::from_secs(20);
    while !subscriber_seen(&node) {
        if Instant::now() > discovery_deadline {
            bail!("no subscriber discovered on /{TOPIC} within 20 s");
        }
        thread::sleep(Duration::from_millis(20));
    }
    // Discovery of the reader precedes the writer's match by a few messages.
    thread::sleep(Duration::from_millis(500));

    // Consecutive frames differ, so fragments mixed between them show up.
    let frames: Vec<Vec<u8>> = (0..DISTINCT_FRAMES)
        .map(|f| (0..size.data_len()).map(|i| pixel(f, i)).collect())
        .collect();
    let mut sent = Sent::default();
    let start = Instant::now();
    for frame in 0..args.frames {
        let due = start + args.period() * frame;
        if let Some(wait) = due.checked_duration_since(Instant::now()) {
            thread::sleep(wait);
        }
        let data = frames[(frame % DISTINCT_FRAMES) as usize].clone();
        let mut image = Image {
            header: Header {
                stamp: Time::default(),
                frame_id: frame.to_string(),
            },
            height: size.height,
            width: size.width,
            encoding: size.encoding().to_string(),
            is_bigendian: 0,
            step: size.width * size.channels,
            data: D::from_vec(data),
        };
        let before = Instant::now();
        image.header.stamp = Time::now();
        match publisher.publish(image) {
            Ok(()) => sent.published += 1,
            Err(e) => {
                eprintln!("frame {frame}: {e}");
                sent.failed += 1;
            }
        }
        sent.publish_ns
            .push(u64::try_from(before.elapsed().as_nanos()).unwrap_or(u64::MAX));
    }
    thread::sleep(Duration::from_secs_f64(args.drain.max(0.0)));
    Ok(sent)
}

/// One row of the report.
#[derive(Debug)]
struct Row {
    size: ImageSize,
    sent: Sent,
    delivered: usize,
    corrupt: usize,
    latency: Option<Percentiles>,
}

/// Frames that arrived (each counted once) and their latencies.
fn summarize(size: ImageSize, sent: Sent, arrivals: &[Arrival]) -> Row {
    let mut first: BTreeMap<u32, Arrival> = BTreeMap::new();
    for a in arrivals {
        first.entry(a.frame).or_insert(*a);
    }
    let latencies: Vec<Duration> = first
        .values()
        .map(|a| Duration::from_nanos(u64::try_from(a.latency_ns).unwrap_or(0)))
        .collect();
    let corrupt = first
        .values()
        .filter(|a| !a.intact || a.bytes != size.data_len())
        .count();
    Row {
        size,
        sent,
        delivered: first.len(),
        corrupt,
        latency: percentiles(&latencies),
    }
}

fn measure_size(args: &Args, size: ImageSize) -> anyhow::Result<Row> {
    let exe = std::env::current_exe().context("cannot locate own executable")?;
    let mut child = Command::new(exe)
        .args(args.subscriber_args(size))
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .spawn()
        .context("cannot start subscriber process")?;
    let stdout = child
        .stdout
        .take()
        .ok_or_else(|| anyhow!("subscriber has no stdout"))?;
    let mut lines = BufReader::new(stdout).lines();
    match lines.next() {
        Some(Ok(line)) if line == READY => {}
        other => {
            let _ = child.kill();
            let _ = child.wait();
            bail!("subscriber did not start: {other:?}");
        }
    }
    let context = args.transport().context(args.domain_id())?;
    let topic = format!("/{TOPIC}");
    let seen = |node: &Node| node.subscription_count(&topic) > 0;
    let sent = if args.elementwise {
        publish::<ElementBytes>(&context, args, size, seen)
    } else {
        publish::<BulkBytes>(&context, args, size, seen)
    };
    // Closing its input tells the subscriber to report and exit.
    drop(child.stdin.take());
    let arrivals: Vec<Arrival> = lines
        .map_while(Result::ok)
        .filter_map(|l| Arrival::from_line(&l))
        .collect();
    let status = child.wait()?;
    let sent = sent?;
    if !status.success() {
        bail!("subscriber exited with {status}");
    }
    Ok(summarize(size, sent, &arrivals))
}

fn print_report(args: &Args, rows: &[Row]) {
    let transport = args.transport();
    println!(
        "pub {:?}, sub {:?}, depth {}, rcvbuf {} B, sndbuf {} B, range {:?}, deadline {:?} ms, {} serialization, {} Hz, {} frames",
        args.pub_reliability,
        args.sub_reliability,
        args.depth,
        transport.socket_receive_buffer,
        transport.socket_send_buffer,
        transport.range,
        args.deadline_ms,
        if args.elementwise {
            "element-wise"
        } else {
            "bulk"
        },
        args.rate,
        args.frames,
    );
    println!(
        "| image | MB | delivered/sent | corrupt | p50 ms | p90 ms | p99 ms | max ms | publish p50 ms |"
    );
    println!("|---|---|---|---|---|---|---|---|---|");
    for row in rows {
        let publish: Vec<Duration> = row
            .sent
            .publish_ns
            .iter()
            .map(|&n| Duration::from_nanos(n))
            .collect();
        let publish_p50 = percentiles(&publish).map_or(f64::NAN, |p| p.p50);
        let l = row.latency.unwrap_or(Percentiles {
            p50: f64::NAN,
            p90: f64::NAN,
            p99: f64::NAN,
            max: f64::NAN,
        });
        println!(
            "| {} | {:.1} | {}/{} | {} | {:.1} | {:.1} | {:.1} | {:.1} | {:.1} |",
            row.size,
            row.size.data_len() as f64 / 1e6,
            row.delivered,
            row.sent.published + row.sent.failed,
            row.corrupt,
            l.p50,
            l.p90,
            l.p99,
            l.max,
            publish_p50,
        );
    }
}

fn main() -> anyhow::Result<()> {
    let args = Args::parse();
    if !(args.rate.is_finite() && args.rate > 0.0) {
        bail!("--rate must be a positive number of Hz, got {}", args.rate);
    }
    if args.subscriber {
        return run_subscriber(&args);
    }
    let mut rows = Vec::new();
    for &size in &args.sizes {
        rows.push(measure_size(&args, size).with_context(|| format!("measuring {size}"))?);
    }
    print_report(&args, &rows);
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn arrivals_round_trip_and_duplicates_count_once() {
        let a = Arrival {
            frame: 7,
            bytes: 256,
            latency_ns: 1_500_000,
            intact: true,
        };
        assert_eq!(Arrival::from_line(&a.to_line()), Some(a));
        assert_eq!(Arrival::from_line("7 12"), None);
        let size: ImageSize = "16x16:mono8".parse().unwrap();
        let broken = Arrival { frame: 8, ..a };
        let broken = Arrival {
            intact: false,
            ..broken
        };
        let row = summarize(size, Sent::default(), &[a, a, broken]);
        assert_eq!((row.delivered, row.corrupt), (2, 1));
    }

    #[test]
    fn pattern_check_catches_a_misplaced_fragment() {
        let mut data: Vec<u8> = (0..100_000).map(|i| pixel(3, i)).collect();
        assert!(pattern_intact(&data));
        // A fragment of frame 4 copied into frame 3.
        for (i, byte) in data.iter_mut().enumerate().skip(4099 * 2).take(256) {
            *byte = pixel(4, i);
        }
        assert!(!pattern_intact(&data));
    }

    /// Two participants in one process exchange 2 MB images over loopback:
    /// every frame arrives, intact, for the bulk and the element-wise paths.
    #[test]
    fn images_cross_between_two_participants() {
        for (elementwise, domain) in [(false, 181), (true, 182)] {
            let args = Args::parse_from([
                "dds_latency",
                "--frames",
                "5",
                "--rate",
                "10",
                "--sizes",
                "1280x540:rgb8",
                "--domain",
                &domain.to_string(),
                "--localhost-only",
                "--drain",
                "1.0",
            ]);
            let args = Args {
                elementwise,
                ..args
            };
            let size = args.sizes[0];
            let sub_context = args.transport().context(domain).unwrap();
            let stop = Arc::new(AtomicBool::new(false));
            let (ready_tx, ready_rx) = std::sync::mpsc::channel();
            let receiver = {
                let stop = Arc::clone(&stop);
                let qos = args.subscription_qos();
                thread::spawn(move || {
                    let mut arrivals = Vec::new();
                    let ready = move || ready_tx.send(()).unwrap();
                    let record = |a| arrivals.push(a);
                    if elementwise {
                        receive::<ElementBytes>(&sub_context, qos, &stop, ready, record)
                    } else {
                        receive::<BulkBytes>(&sub_context, qos, &stop, ready, record)
                    }
                    .unwrap();
                    arrivals
                })
            };
            ready_rx.recv().unwrap();
            let pub_context = args.transport().context(domain).unwrap();
            let topic = format!("/{TOPIC}");
            let seen = |node: &Node| node.subscription_count(&topic) > 0;
            let sent = if elementwise {
                publish::<ElementBytes>(&pub_context, &args, size, seen)
            } else {
                publish::<BulkBytes>(&pub_context, &args, size, seen)
            }
            .unwrap();
            stop.store(true, Ordering::Relaxed);
            let arrivals = receiver.join().unwrap();
            let row = summarize(size, sent, &arrivals);
            assert_eq!(row.sent.published, 5);
            assert_eq!(row.delivered, 5, "elementwise {elementwise}");
            assert_eq!(row.corrupt, 0);
            assert!(row.latency.is_some_and(|l| l.max < 1000.0));
        }
    }
}
