//! Several nodes in one process, like a ROS 2 component container:
//! `stereocal node compose FILE [--ros-args ...]` starts every node that the
//! composition file lists, each on threads of its own with its own name, parameters,
//! logging and DDS participant, and stops them all on SIGINT/SIGTERM, or as soon as one
//! of them fails (the error then names every node that failed).
//!
//! The composition file is YAML:
//!
//! ```yaml
//! nodes:
//!   - node: rectify          # which node: rectify, calibrate, pose, handeye, disparity,
//!                            # point_cloud or camera
//!     args: [-r, __ns:=/stereo/left, -r, image:=image_raw]   # its ROS arguments
//!   - node: rectify
//!     args: [-r, __ns:=/stereo/right, -r, image:=image_raw]
//! ```
//!
//! ROS arguments on the command line after the file (`--ros-args --params-file P`)
//! apply to every node, before the node's own.

use std::path::Path;
use std::thread::JoinHandle;
use std::time::Duration;

use anyhow::{Context, anyhow, bail};
use serde::Deserialize;
use stereocal_runtime::args::RosArgs;
use stereocal_runtime::logging::{self, LogConfig};
use stereocal_runtime::shutdown::Shutdown;

/// How a node of the composition is run: its `run` with its command line.
type NodeMain = fn(Vec<String>) -> anyhow::Result<()>;

/// The nodes a composition can hold, by the name the file gives them.
const NODES: [(&str, NodeMain); 7] = [
    ("rectify", |args| crate::rectify::node::run(args)),
    ("calibrate", |args| crate::calibrate::node::run(args)),
    ("pose", |args| crate::pose::node::run(args)),
    ("handeye", |args| crate::handeye::node::run(args)),
    ("disparity", |args| crate::depth::node::run(args)),
    ("point_cloud", |args| {
        crate::depth::point_cloud_node::run(args)
    }),
    ("camera", |args| crate::camera::node::run(args)),
];

/// The logger name of the composition itself.
const LOGGER_NAME: &str = "stereocal_compose";

/// How often a running composition looks whether one of its nodes has stopped.
const WATCH_PERIOD: Duration = Duration::from_millis(50);

/// One entry of a composition file.
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct ComposedNode {
    /// Which node (`rectify`, `calibrate`, `pose`, `handeye`, `disparity`, `point_cloud`,
    /// `camera`).
    pub node: String,
    /// Its ROS arguments (remaps, parameters), as after `--ros-args`.
    #[serde(default)]
    pub args: Vec<String>,
}

/// A composition file: the nodes one process runs.
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Composition {
    /// The nodes, started in this order.
    pub nodes: Vec<ComposedNode>,
}

impl Composition {
    /// Parses and checks composition `text` (from `origin`, for messages): at least one
    /// node, every one of a known kind.
    pub fn parse(origin: &Path, text: &str) -> anyhow::Result<Self> {
        let composition: Composition = serde_yaml::from_str(text)
            .with_context(|| format!("composition file {}", origin.display()))?;
        if composition.nodes.is_empty() {
            bail!(
                "composition file {}: `nodes` lists no node",
                origin.display()
            );
        }
        for (index, entry) in composition.nodes.iter().enumerate() {
            if node_main(&entry.node).is_none() {
                bail!(
                    "composition file {}: node {} is {:?}: expected one of {}",
                    origin.display(),
                    index + 1,
                    entry.node,
                    NODES.map(|(name, _)| name).join(", ")
                );
            }
        }
        Ok(composition)
    }

    /// Reads and checks the composition file at `path`.
    pub fn read(path: &Path) -> anyhow::Result<Self> {
        let text = std::fs::read_to_string(path)
            .with_context(|| format!("composition file {}", path.display()))?;
        Self::parse(path, &text)
    }
}

fn node_main(name: &str) -> Option<NodeMain> {
    NODES
        .iter()
        .find(|(known, _)| *known == name)
        .map(|(_, main)| *main)
}

/// The command line of `entry`: `--ros-args`, the arguments for every node
/// (`common`, which start with `--ros-args` when given), then the node's own.
fn command_line(common: &[String], entry: &ComposedNode) -> anyhow::Result<Vec<String>> {
    let common = match common.split_first() {
        None => &[][..],
        Some((first, rest)) if first == "--ros-args" => rest,
        Some((first, _)) => bail!("expected --ros-args after the composition file, got {first:?}"),
    };
    Ok(std::iter::once("--ros-args".to_owned())
        .chain(common.iter().cloned())
        .chain(entry.args.iter().cloned())
        .collect())
}

/// Runs the nodes of the composition file at `path` until SIGINT/SIGTERM, with
/// `common` ROS arguments for all of them. A node that stops by itself (it failed)
/// stops the others; its error is returned, naming the node.
pub fn run(path: &Path, common: &[String]) -> anyhow::Result<()> {
    let composition = Composition::read(path)?;
    // The composition logs as a node of its own, and so do the DDS libraries' threads,
    // which belong to no node.
    let (ros_args, _) = RosArgs::parse(common.iter().cloned())?;
    logging::register(LogConfig {
        logger_name: LOGGER_NAME.to_owned(),
        level: ros_args.log_level_for(LOGGER_NAME),
        stderr: ros_args.stdout_logs,
        rosout: false,
        external_lib_logs: ros_args.external_lib_logs,
    });
    let mut commands = Vec::new();
    for (index, entry) in composition.nodes.iter().enumerate() {
        let main =
            node_main(&entry.node).ok_or_else(|| anyhow!("unknown node {:?}", entry.node))?;
        let label = format!(
            "node {} ({} {})",
            index + 1,
            entry.node,
            entry.args.join(" ")
        );
        commands.push((
            label,
            entry.node.clone(),
            main,
            command_line(common, entry)?,
        ));
    }
    let shutdown = Shutdown::install()?;
    log::info!("running {} node(s) of {}", commands.len(), path.display());
    let mut running: Vec<(String, JoinHandle<anyhow::Result<()>>)> = Vec::new();
    let mut failed = Vec::new();
    for (index, (label, node, main, args)) in commands.into_iter().enumerate() {
        match std::thread::Builder::new()
            .name(format!("{node}-{}", index + 1))
            .spawn(move || main(args))
        {
            Ok(thread) => running.push((label, thread)),
            Err(e) => {
                failed.push(anyhow!("{label}: not started: {e}"));
                break;
            }
        }
    }
    while failed.is_empty()
        && !shutdown.requested()
        && !running.iter().any(|(_, thread)| thread.is_finished())
    {
        std::thread::sleep(WATCH_PERIOD);
    }
    shutdown.request();
    for (label, thread) in running {
        let outcome = thread
            .join()
            .map_err(|_| anyhow!("panicked"))
            .and_then(|result| result);
        if let Err(e) = outcome {
            failed.push(e.context(label));
        }
    }
    match failed.len() {
        0 => Ok(()),
        1 => Err(failed.remove(0)),
        _ => Err(anyhow!(
            "{} nodes failed:\n{}",
            failed.len(),
            failed
                .iter()
                .map(|e| format!("{e:#}"))
                .collect::<Vec<_>>()
                .join("\n")
        )),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_composition_lists_known_nodes_with_their_arguments() -> anyhow::Result<()> {
        let composition = Composition::parse(
            Path::new("c.yaml"),
            "nodes:\n  - node: rectify\n    args: [-r, __ns:=/left]\n  - node: calibrate\n",
        )?;
        assert_eq!(composition.nodes.len(), 2);
        assert_eq!(
            command_line(
                &["--ros-args".into(), "--log-level".into(), "warn".into()],
                &composition.nodes[0]
            )?,
            ["--ros-args", "--log-level", "warn", "-r", "__ns:=/left"]
        );
        assert_eq!(command_line(&[], &composition.nodes[1])?, ["--ros-args"]);
        assert!(command_line(&["-r".into()], &composition.nodes[0]).is_err());
        Ok(())
    }

    #[test]
    fn bad_compositions_are_refused_naming_what_is_wrong() {
        let refused = |text: &str| {
            Composition::parse(Path::new("c.yaml"), text)
                .err()
                .map(|e| format!("{e:#}"))
                .unwrap_or_default()
        };
        let unknown = refused("nodes:\n  - node: rectify\n  - node: rektify\n");
        assert!(
            unknown.contains("node 2 is \"rektify\": expected one of rectify, calibrate, pose"),
            "{unknown}"
        );
        assert!(refused("nodes: []\n").contains("lists no node"));
        assert!(refused("nodes:\n  - node: rectify\n    remap: x\n").contains("unknown field"));
        assert!(refused("nodes: [").contains("c.yaml"));
    }
}
