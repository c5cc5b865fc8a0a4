//! Running nodes as processes of their own and talking to them, for tests and measuring
//! tools (the `testing` feature): [`NodeProcess`] starts a node executable on a ROS
//! domain and collects what it logs, [`PeerNode`] is the caller's own ROS node with its
//! spinner, [`DomainLease`] hands out ROS domains no other leaseholder on the machine
//! uses at the same time, and [`block_on_timeout`] waits for discovery without hanging.
//!
//! Waits here are deadlines on progress, never fixed sleeps: a loaded machine makes a
//! node slower to start or to stop, not a test wrong.

use std::fs::File;
use std::future::Future;
use std::io::Read;
use std::ops::RangeInclusive;
use std::path::PathBuf;
use std::process::{Child, Command, ExitStatus, Stdio};
use std::sync::{Arc, Mutex, PoisonError};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use futures::FutureExt;
use ros2_client::{Context, Node, NodeName, NodeOptions, Publisher, QosProfile, Subscription};
use serde::Serialize;
use serde::de::DeserializeOwned;
use stereocal_msgs::RosMessage;

use crate::error::{Result, RuntimeError};
use crate::node::create_topic;
use crate::transport::TransportConfig;

/// How long a node may take to stop after SIGTERM before it is killed.
pub const TERMINATE_TIMEOUT: Duration = Duration::from_secs(10);

fn failure(what: &str, e: impl std::fmt::Display) -> RuntimeError {
    RuntimeError::Middleware(format!("{what}: {e}"))
}

/// A node running as its own process, its stderr collected while it runs. Dropping it
/// kills the process.
pub struct NodeProcess {
    child: Child,
    name: String,
    stderr: Arc<Mutex<Vec<u8>>>,
    reader: Option<JoinHandle<()>>,
}

/// How a [`NodeProcess`] ended.
#[derive(Debug)]
pub struct NodeExit {
    /// Its exit status; `None` when it ignored SIGTERM and had to be killed.
    pub status: Option<ExitStatus>,
    /// Everything it wrote to stderr.
    pub logs: String,
}

impl NodeExit {
    /// Whether the node stopped by itself with exit status 0.
    pub fn clean(&self) -> bool {
        self.status.is_some_and(|s| s.success())
    }
}

impl NodeProcess {
    /// Starts `command` (the node executable with its arguments and environment) on ROS
    /// domain `domain`, with stdin and stdout closed and stderr collected.
    pub fn spawn(mut command: Command, domain: u16) -> Result<Self> {
        let name = command.get_program().to_string_lossy().into_owned();
        let mut child = command
            .env("ROS_DOMAIN_ID", domain.to_string())
            .stdin(Stdio::null())
            .stdout(Stdio::null())
            .stderr(Stdio::piped())
            .spawn()
            .map_err(|e| failure(&format!("starting {name}"), e))?;
        let stderr = Arc::new(Mutex::new(Vec::new()));
        let reader = child.stderr.take().map(|mut pipe| {
            let sink = Arc::clone(&stderr);
            std::thread::spawn(move || {
                let mut chunk = [0u8; 4096];
                while let Ok(n) = pipe.read(&mut chunk) {
                    let Some(read) = chunk.get(..n).filter(|read| !read.is_empty()) else {
                        break;
                    };
                    // Bytes, not text: a character may be split between two reads.
                    sink.lock()
                        .unwrap_or_else(PoisonError::into_inner)
                        .extend_from_slice(read);
                }
            })
        });
        Ok(Self {
            child,
            name,
            stderr,
            reader,
        })
    }

    /// What the node has written to stderr so far.
    pub fn logs(&self) -> String {
        String::from_utf8_lossy(&self.stderr.lock().unwrap_or_else(PoisonError::into_inner))
            .into_owned()
    }

    /// Asks the node to stop with SIGTERM and waits up to [`TERMINATE_TIMEOUT`] for it;
    /// a node still running then is killed.
    pub fn terminate(mut self) -> NodeExit {
        let signalled = Command::new("kill")
            .args(["-TERM", &self.child.id().to_string()])
            .status()
            .is_ok_and(|s| s.success());
        let deadline = Instant::now() + TERMINATE_TIMEOUT;
        let mut status = None;
        while signalled && Instant::now() < deadline {
            match self.child.try_wait() {
                Ok(Some(exit)) => {
                    status = Some(exit);
                    break;
                }
                Ok(None) => std::thread::sleep(Duration::from_millis(20)),
                Err(_) => break,
            }
        }
        if status.is_none() {
            log::warn!("{} did not stop on SIGTERM: killed", self.name);
        }
        NodeExit {
            status,
            logs: self.finish(),
        }
    }

    /// Kills the node with SIGKILL, leaving it no chance to save anything on the way
    /// out; returns what it logged.
    pub fn kill(mut self) -> String {
        self.finish()
    }

    /// Kills the process if it still runs, reaps it and returns its whole stderr.
    fn finish(&mut self) -> String {
        let _ = self.child.kill();
        let _ = self.child.wait();
        if let Some(reader) = self.reader.take() {
            let _ = reader.join();
        }
        self.logs()
    }
}

impl Drop for NodeProcess {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// The caller's own ROS node on a domain, with its spinner running (discovery, and the
/// replies of services it calls). Endpoints made from it must be dropped before it.
pub struct PeerNode {
    node: Node,
    context: Context,
    spinner: Option<JoinHandle<()>>,
}

impl PeerNode {
    /// Joins `domain` with `transport` as node `namespace/name` (without `/rosout`).
    pub fn new(
        transport: &TransportConfig,
        domain: u16,
        namespace: &str,
        name: &str,
    ) -> Result<Self> {
        let context = transport
            .context(domain)
            .map_err(|e| failure("DDS participant", e))?;
        let node_name =
            NodeName::new(namespace, name).map_err(|e| failure("node name", format!("{e:?}")))?;
        let mut node = context
            .new_node(node_name, NodeOptions::new().enable_rosout(false))
            .map_err(|e| failure("node", format!("{e:?}")))?;
        let spinner = node.spinner().map_err(|e| failure("node spinner", e))?;
        let spinner = std::thread::Builder::new()
            .name("peer-spinner".into())
            .spawn(move || {
                let _ = futures::executor::block_on(spinner.spin());
            })
            .map_err(|e| failure("spinner thread", e))?;
        Ok(Self {
            node,
            context,
            spinner: Some(spinner),
        })
    }

    /// The node.
    pub fn node(&self) -> &Node {
        &self.node
    }

    /// The node, to create endpoints with.
    pub fn node_mut(&mut self) -> &mut Node {
        &mut self.node
    }

    /// The DDS context (its participant).
    pub fn context(&self) -> &Context {
        &self.context
    }

    /// A publisher on the absolute topic `name`.
    pub fn publisher<M>(&mut self, name: &str, qos: QosProfile) -> Result<Publisher<M>>
    where
        M: RosMessage + Serialize,
    {
        let topic = create_topic::<M>(&mut self.node, name, &qos)?;
        self.node
            .create_publisher(&topic, Some(qos))
            .map_err(|e| failure(&format!("publisher on {name}"), e))
    }

    /// A subscription to the absolute topic `name`.
    pub fn subscription<M>(&mut self, name: &str, qos: QosProfile) -> Result<Subscription<M>>
    where
        M: RosMessage + DeserializeOwned + 'static,
    {
        let topic = create_topic::<M>(&mut self.node, name, &qos)?;
        self.node
            .create_subscription(&topic, Some(qos))
            .map_err(|e| failure(&format!("subscription to {name}"), e))
    }
}

impl Drop for PeerNode {
    fn drop(&mut self) {
        self.node.stop_spinner();
        if let Some(spinner) = self.spinner.take() {
            let _ = spinner.join();
        }
    }
}

/// Runs `future` to completion, or gives up after `limit`.
pub fn block_on_timeout<T>(future: impl Future<Output = T>, limit: Duration) -> Option<T> {
    let (done, timer) = futures::channel::oneshot::channel::<()>();
    std::thread::spawn(move || {
        std::thread::sleep(limit);
        let _ = done.send(());
    });
    futures::executor::block_on(async {
        let mut future = std::pin::pin!(future.fuse());
        let mut timer = timer.fuse();
        futures::select! {
            value = future => Some(value),
            _ = timer => None,
        }
    })
}

/// A ROS domain id that no other [`DomainLease`] on this machine holds while this one
/// lives (an exclusive lock on a file per domain in the temporary directory), so that
/// tests and tools running at the same time never see each other's nodes.
#[derive(Debug)]
pub struct DomainLease {
    id: u16,
    _lock: File,
}

/// Domains tests lease by default: clear of the demo's (77) and of the measuring
/// tools' and interop checks' (150 upwards).
pub const TEST_DOMAINS: RangeInclusive<u16> = 20..=119;

impl DomainLease {
    /// Leases the first free domain of `range`.
    pub fn acquire(range: RangeInclusive<u16>) -> Result<Self> {
        let dir = std::env::temp_dir();
        let mut unopened = None;
        for id in range.clone() {
            let path: PathBuf = dir.join(format!("stereocal-ros-domain-{id}.lock"));
            // A lock file another user owns cannot be opened: that domain is theirs.
            let file = match File::options()
                .create(true)
                .truncate(false)
                .write(true)
                .open(&path)
            {
                Ok(file) => file,
                Err(e) => {
                    unopened.get_or_insert(format!("{}: {e}", path.display()));
                    continue;
                }
            };
            if file.try_lock().is_ok() {
                return Ok(Self { id, _lock: file });
            }
        }
        Err(RuntimeError::Middleware(format!(
            "every ROS domain of {}..={} is leased by another process{}",
            range.start(),
            range.end(),
            unopened.map_or(String::new(), |e| format!(
                " (or its lock cannot be opened: {e})"
            ))
        )))
    }

    /// Leases a domain of [`TEST_DOMAINS`].
    pub fn for_test() -> Result<Self> {
        Self::acquire(TEST_DOMAINS)
    }

    /// The domain id.
    pub fn id(&self) -> u16 {
        self.id
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn leases_of_one_range_are_distinct_until_released() -> Result<()> {
        let range = 200..=202;
        let a = DomainLease::acquire(range.clone())?;
        let b = DomainLease::acquire(range.clone())?;
        assert_ne!(a.id(), b.id());
        let c = DomainLease::acquire(range.clone())?;
        assert!(DomainLease::acquire(range.clone()).is_err());
        let freed = b.id();
        drop(b);
        assert_eq!(DomainLease::acquire(range)?.id(), freed);
        drop((a, c));
        Ok(())
    }
}
