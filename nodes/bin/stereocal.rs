//! The `stereocal` command line: offline processing of bags, synthetic scenes and the demo.

fn main() -> anyhow::Result<()> {
    anyhow::bail!("no command yet")
}
