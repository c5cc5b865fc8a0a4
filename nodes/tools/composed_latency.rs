//! `composed_latency`: the stereo rectify pair composed in one process, measured two
//! ways in one run.
//!
//! A camera node in the same process publishes a stereo pair (and its camera_infos) at
//! a fixed rate; two rectify nodes (`/bench/left`, `/bench/right`) rectify it; a
//! consumer node in the process takes both rectified images. The in-process path runs
//! from the camera's publish to the consumer holding the rectified pair, frames passed
//! by reference. Beside it, a subscriber in another process (this executable with
//! `--subscriber`) receives the same rectified images over DDS: the path of an outside
//! consumer, latency from the camera's stamp (its wall clock at publishing).

use std::collections::HashMap;
use std::io::{BufRead, BufReader};
use std::process::{Command, ExitCode, Stdio};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex, PoisonError};
use std::time::{Duration, Instant};

use anyhow::{Context as _, bail};
use clap::Parser;
use stereocal::tools::camera::{camera_info, image, now, pixels};
use stereocal::tools::{ImageSize, Percentiles, percentiles};
use stereocal_msgs::builtin_interfaces::Time;
use stereocal_msgs::sensor_msgs::{CameraInfo, Image};
use stereocal_runtime::node::NodeBuilder;
use stereocal_runtime::qos;
use stereocal_runtime::shutdown::Shutdown;
use stereocal_runtime::skeleton::{self, FrameStats, Inputs, Worker};
use stereocal_runtime::sync::{SyncPolicy, Synced};
use stereocal_runtime::testing::{DomainLease, PeerNode};
use stereocal_runtime::transport::{DDS_NICE_ENV, TransportConfig};

/// Queues of the nodes and subscriptions, as the rectify node's default.
const DEPTH: usize = 5;
/// How long the nodes may take to come up and the first pair to make the round trip.
const WARM_UP_TIMEOUT: Duration = Duration::from_secs(30);
/// How long the last frames may take after the last pair was published.
const DRAIN: Duration = Duration::from_secs(3);
const SIDES: [&str; 2] = ["left", "right"];

#[derive(Parser, Clone, Debug)]
#[command(
    about = "Latency of the stereo rectify pair composed in one process: in-process and over DDS"
)]
struct Args {
    /// Image size and encoding.
    #[arg(long, default_value = "1920x1080:rgb8")]
    size: ImageSize,
    /// Stereo pairs measured after warm-up.
    #[arg(long, default_value_t = 300)]
    frames: u32,
    /// Pairs per second.
    #[arg(long, default_value_t = 30.0)]
    rate: f64,
    /// ROS domain (default: the first free one from 150).
    #[arg(long)]
    domain: Option<u16>,
    /// Measure the in-process path alone, without a subscriber outside the process.
    #[arg(long)]
    in_process_only: bool,
    /// Run as the outside subscriber: print `left|right STAMP_NS RECEIVED_NS` per
    /// rectified image until stdin closes.
    #[arg(long, hide = true)]
    subscriber: bool,
}

/// The consumer: records when each rectified pair reached it.
struct Consumer {
    published: Arc<Mutex<HashMap<Time, Instant>>>,
    latencies: Arc<Mutex<Vec<Duration>>>,
}

impl Worker for Consumer {
    type Work = (Synced<Arc<Image>, ()>, Instant);
    const NAME: &'static str = "consumer";

    fn handle(&mut self, (pair, received): Self::Work, _stats: &FrameStats) {
        let published = self
            .published
            .lock()
            .unwrap_or_else(PoisonError::into_inner)
            .get(&pair.stamp)
            .copied();
        if let Some(published) = published {
            self.latencies
                .lock()
                .unwrap_or_else(PoisonError::into_inner)
                .push(received.saturating_duration_since(published));
        }
    }

    fn summary(&self) -> String {
        format!(
            "{} pairs timed",
            self.latencies
                .lock()
                .unwrap_or_else(PoisonError::into_inner)
                .len()
        )
    }
}

fn ros_args(namespace: &str, extra: &[&str]) -> Vec<String> {
    ["--ros-args", "-r", &format!("__ns:={namespace}")]
        .iter()
        .chain(extra)
        .map(|s| s.to_string())
        .collect()
}

/// The outside subscriber: prints each rectified image's stamp and arrival.
fn subscriber(domain: u16) -> anyhow::Result<()> {
    let mut peer = PeerNode::new(&TransportConfig::from_env()?, domain, "/bench", "outside")?;
    let subscriptions = SIDES
        .iter()
        .map(|side| {
            peer.subscription::<Image>(
                &format!("/bench/{side}/image_rect"),
                qos::sensor_data(DEPTH),
            )
        })
        .collect::<Result<Vec<_>, _>>()?;
    let stop = Arc::new(AtomicBool::new(false));
    let stopper = Arc::clone(&stop);
    std::thread::spawn(move || {
        // The measurer closes stdin when it is done.
        let _ = std::io::stdin().lines().count();
        stopper.store(true, Ordering::Relaxed);
    });
    println!("ready");
    while !stop.load(Ordering::Relaxed) {
        let mut idle = true;
        for (side, subscription) in SIDES.iter().zip(&subscriptions) {
            while let Ok(Some((rect, _))) = subscription.take() {
                idle = false;
                println!(
                    "{side} {} {}",
                    rect.header.stamp.as_nanos(),
                    now().as_nanos()
                );
            }
        }
        if idle {
            std::thread::sleep(Duration::from_micros(200));
        }
    }
    Ok(())
}

fn row(path: &str, delivered: usize, sent: u32, p: Option<Percentiles>) {
    match p {
        Some(p) => println!(
            "| {path} | {delivered}/{sent} | {:.1} | {:.1} | {:.1} | {:.1} |",
            p.p50, p.p90, p.p99, p.max
        ),
        None => println!("| {path} | {delivered}/{sent} | - | - | - | - |"),
    }
}

fn measure(args: &Args, domain: u16) -> anyhow::Result<()> {
    let outside_arrivals = Arc::new(Mutex::new(Vec::<(String, i64, i64)>::new()));
    let outside_ready = Arc::new(AtomicBool::new(args.in_process_only));
    let mut outside = if args.in_process_only {
        None
    } else {
        // The outside subscriber is another program: the DDS priority asked of the
        // composed process is not its.
        let mut child = Command::new(std::env::current_exe()?)
            .args(["--subscriber", "--domain", &domain.to_string()])
            .env_remove(DDS_NICE_ENV)
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .spawn()
            .context("starting the outside subscriber")?;
        let lines = BufReader::new(child.stdout.take().context("subscriber stdout")?).lines();
        let arrivals = Arc::clone(&outside_arrivals);
        let ready = Arc::clone(&outside_ready);
        let reader = std::thread::spawn(move || {
            for line in lines.map_while(Result::ok) {
                let fields: Vec<&str> = line.split(' ').collect();
                match fields.as_slice() {
                    ["ready"] => ready.store(true, Ordering::Relaxed),
                    [side, stamp, received] => {
                        if let (Ok(stamp), Ok(received)) = (stamp.parse(), received.parse()) {
                            arrivals
                                .lock()
                                .unwrap_or_else(PoisonError::into_inner)
                                .push((side.to_string(), stamp, received));
                        }
                    }
                    _ => {}
                }
            }
        });
        Some((child, reader))
    };

    let shutdown = Shutdown::install()?;
    let mut camera = NodeBuilder::new("bench_camera").start(ros_args("/bench", &[]))?;
    let mut images = Vec::new();
    let mut infos = Vec::new();
    for side in SIDES {
        images.push(camera.advertise::<Image>(&format!("{side}/image_raw"), qos::reliable(DEPTH))?);
        infos.push(
            camera.advertise::<CameraInfo>(&format!("{side}/camera_info"), qos::reliable(DEPTH))?,
        );
    }
    let mut rectify_nodes = Vec::new();
    for side in SIDES {
        let args = ros_args(&format!("/bench/{side}"), &["-r", "image:=image_raw"]);
        rectify_nodes.push(std::thread::spawn(move || {
            stereocal::rectify::node::run(args)
        }));
    }
    let published = Arc::new(Mutex::new(HashMap::new()));
    let latencies = Arc::new(Mutex::new(Vec::new()));
    let consumer = {
        let published = Arc::clone(&published);
        let latencies = Arc::clone(&latencies);
        std::thread::spawn(move || -> anyhow::Result<()> {
            let mut node = NodeBuilder::new("bench_consumer").start(ros_args("/bench", &[]))?;
            let mut inputs = Inputs::<Arc<Image>, ()>::new(SyncPolicy::exact(DEPTH));
            for side in SIDES {
                inputs = inputs.stream::<Image>(
                    &mut node,
                    &format!("{side}/image_rect"),
                    qos::sensor_data(DEPTH),
                )?;
            }
            let worker = Consumer {
                published,
                latencies,
            };
            skeleton::spin(node, inputs, DEPTH, worker, |_, pair| {
                (pair, Instant::now())
            })?;
            Ok(())
        })
    };

    let data: Vec<Vec<u8>> = (0..2).map(|p| pixels(args.size, p)).collect();
    let publish = |stamp: Time| -> anyhow::Result<()> {
        let pair: Vec<Arc<Image>> = data
            .iter()
            .map(|pixels| Arc::new(image(args.size, stamp, pixels.clone())))
            .collect();
        let info = camera_info(args.size, stamp);
        published
            .lock()
            .unwrap_or_else(PoisonError::into_inner)
            .insert(stamp, Instant::now());
        for ((image_pub, info_pub), image) in images.iter().zip(&infos).zip(pair) {
            info_pub.publish(info.clone())?;
            image_pub.publish_shared(image)?;
        }
        Ok(())
    };
    let timed = || {
        latencies
            .lock()
            .unwrap_or_else(PoisonError::into_inner)
            .len()
    };
    let deadline = Instant::now() + WARM_UP_TIMEOUT;
    let outside_heard = || {
        args.in_process_only
            || (outside_ready.load(Ordering::Relaxed)
                && !outside_arrivals
                    .lock()
                    .unwrap_or_else(PoisonError::into_inner)
                    .is_empty())
    };
    while timed() == 0 || !outside_heard() {
        if Instant::now() > deadline {
            bail!(
                "no rectified pair came back in {} s",
                WARM_UP_TIMEOUT.as_secs()
            );
        }
        publish(now())?;
        std::thread::sleep(Duration::from_millis(100));
    }
    std::thread::sleep(Duration::from_millis(500));
    latencies
        .lock()
        .unwrap_or_else(PoisonError::into_inner)
        .clear();
    outside_arrivals
        .lock()
        .unwrap_or_else(PoisonError::into_inner)
        .clear();
    let first = now();
    let period = Duration::from_secs_f64(1.0 / args.rate);
    let start = Instant::now();
    for frame in 0..args.frames {
        if let Some(wait) = (start + period * frame).checked_duration_since(Instant::now()) {
            std::thread::sleep(wait);
        }
        publish(now())?;
    }
    let drain = Instant::now() + DRAIN;
    while Instant::now() < drain && timed() < args.frames as usize {
        std::thread::sleep(Duration::from_millis(10));
    }
    std::thread::sleep(Duration::from_millis(200));
    shutdown.request();
    if let Some((mut child, reader)) = outside.take() {
        drop(child.stdin.take());
        let _ = child.wait();
        let _ = reader.join();
    }
    for node in rectify_nodes {
        if let Ok(Err(e)) = node.join() {
            bail!("a rectify node failed: {e:#}");
        }
    }
    if let Ok(Err(e)) = consumer.join() {
        bail!("the consumer failed: {e:#}");
    }
    drop(camera);

    let in_process = latencies
        .lock()
        .unwrap_or_else(PoisonError::into_inner)
        .clone();
    // The outside subscriber's pairs: both sides of a stamp of the measured run.
    let mut sides: HashMap<i64, (usize, i64)> = HashMap::new();
    for (_, stamp, received) in outside_arrivals
        .lock()
        .unwrap_or_else(PoisonError::into_inner)
        .iter()
    {
        if *stamp >= first.as_nanos() {
            let entry = sides.entry(*stamp).or_insert((0, 0));
            entry.0 += 1;
            entry.1 = entry.1.max(*received);
        }
    }
    let outside_latencies: Vec<Duration> = sides
        .iter()
        .filter(|(_, (count, _))| *count == 2)
        .map(|(stamp, (_, received))| {
            Duration::from_nanos(u64::try_from(received - stamp).unwrap_or(0))
        })
        .collect();
    println!(
        "{} stereo pairs at {} Hz through the composed rectify pair:",
        args.size, args.rate
    );
    println!();
    println!("| path | pairs delivered | p50 ms | p90 ms | p99 ms | max ms |");
    println!("|---|---|---|---|---|---|");
    row(
        "in process, by reference (camera publish to consumer)",
        in_process.len(),
        args.frames,
        percentiles(&in_process),
    );
    if args.in_process_only {
        return Ok(());
    }
    row(
        "over DDS to a subscriber in another process (camera stamp to arrival)",
        outside_latencies.len(),
        args.frames,
        percentiles(&outside_latencies),
    );
    Ok(())
}

fn main() -> ExitCode {
    let args = Args::parse();
    // The measured nodes run with the parallel pool their executables have.
    stereocal::cli::node::size_parallel_pool();
    let result = (|| -> anyhow::Result<()> {
        if args.subscriber {
            return subscriber(args.domain.unwrap_or(0));
        }
        // The nodes of this process join ROS_DOMAIN_ID: run again with it set to a
        // domain of our own.
        let wanted = args.domain;
        let env_domain: Option<u16> = std::env::var("ROS_DOMAIN_ID")
            .ok()
            .and_then(|d| d.parse().ok());
        match (wanted, env_domain) {
            (Some(domain), Some(env)) if domain == env => measure(&args, domain),
            _ => {
                let lease = match wanted {
                    Some(_) => None,
                    None => Some(DomainLease::acquire(150..=232)?),
                };
                let domain = wanted
                    .or(lease.as_ref().map(DomainLease::id))
                    .context("a domain")?;
                let status = Command::new(std::env::current_exe()?)
                    .args(std::env::args().skip(1))
                    .args(if wanted.is_some() {
                        vec![]
                    } else {
                        vec!["--domain".to_owned(), domain.to_string()]
                    })
                    .env("ROS_DOMAIN_ID", domain.to_string())
                    .status()?;
                if status.success() {
                    Ok(())
                } else {
                    bail!("measurement failed: {status}")
                }
            }
        }
    })();
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("composed_latency: {e:#}");
            ExitCode::FAILURE
        }
    }
}
