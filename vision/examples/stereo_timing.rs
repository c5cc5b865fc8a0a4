//! Times semi-global matching (or block matching) per pair, for the side by side
//! comparison with OpenCV's StereoSGBM and StereoBM (`interop/bench_depth_opencv.py`),
//! and writes each disparity map.
//!
//! ```text
//! stereo_timing PAIRS.json [--repeats N] [--threads N]
//! ```
//!
//! PAIRS.json: `{"algorithm": "sgm" | "bm", "params": .., "pairs": [{"left": PNG,
//! "right": PNG, "out": PFM}, ..]}` (mono8 PNGs of a rectified pair; `params` as
//! [`SgmParams`] or, for `"bm"`, [`BmParams`] serializes; `algorithm` defaults to sgm).
//! Each pair is matched once untimed, then `--repeats` times; printed as JSON: per pair
//! the median and the smallest time, milliseconds, and the density. The disparity
//! (NaN invalid) goes to `out` as a little-endian PFM, rows bottom to top. `--threads`
//! sets the size of the thread pool (default: all the machine's threads).

use std::path::PathBuf;
use std::time::Instant;

use anyhow::{Context, Result, anyhow, bail};
use serde::Deserialize;
use stereocal_vision::image::{Image, Samples};
use stereocal_vision::stereo::{
    BlockMatcher, BmParams, DisparityMap, SemiGlobalMatcher, SgmParams,
};

#[derive(Deserialize)]
struct Pair {
    left: PathBuf,
    right: PathBuf,
    out: PathBuf,
}

#[derive(Deserialize)]
struct Pairs {
    #[serde(default)]
    algorithm: Algorithm,
    params: serde_json::Value,
    pairs: Vec<Pair>,
}

#[derive(Deserialize, Default, Clone, Copy)]
#[serde(rename_all = "snake_case")]
enum Algorithm {
    #[default]
    Sgm,
    Bm,
}

/// The matcher the pairs file asks for.
enum Matcher {
    Sgm(Box<SemiGlobalMatcher>),
    Bm(BlockMatcher),
}

impl Matcher {
    fn new(algorithm: Algorithm, params: serde_json::Value) -> Result<Self> {
        Ok(match algorithm {
            Algorithm::Sgm => Self::Sgm(Box::new(SemiGlobalMatcher::new(
                serde_json::from_value::<SgmParams>(params).context("SGM params")?,
            ))),
            Algorithm::Bm => Self::Bm(BlockMatcher::new(
                serde_json::from_value::<BmParams>(params).context("BM params")?,
            )),
        })
    }

    fn compute_into(&mut self, left: &Image, right: &Image, out: &mut DisparityMap) -> Result<()> {
        match self {
            Self::Sgm(m) => m.compute_into(left, right, out)?,
            Self::Bm(m) => m.compute_into(left, right, out)?,
        }
        Ok(())
    }
}

struct Args {
    pairs: PathBuf,
    repeats: usize,
    threads: usize,
}

fn parse_args() -> Result<Args> {
    let mut raw = std::env::args().skip(1);
    let mut pairs = None;
    let mut args = Args {
        pairs: PathBuf::new(),
        repeats: 7,
        threads: 0,
    };
    while let Some(arg) = raw.next() {
        let mut value = || raw.next().ok_or_else(|| anyhow!("{arg} needs a value"));
        match arg.as_str() {
            "--repeats" => args.repeats = value()?.parse().context("--repeats")?,
            "--threads" => args.threads = value()?.parse().context("--threads")?,
            _ if arg.starts_with("--") => bail!("unknown option {arg}"),
            _ => pairs = Some(PathBuf::from(arg)),
        }
    }
    args.pairs = pairs
        .ok_or_else(|| anyhow!("usage: stereo_timing PAIRS.json [--repeats N] [--threads N]"))?;
    if args.repeats == 0 {
        bail!("--repeats must be at least 1");
    }
    Ok(args)
}

fn read_mono(path: &PathBuf) -> Result<Image> {
    let grey = image::open(path)
        .with_context(|| format!("cannot read {}", path.display()))?
        .into_luma8();
    let (width, height) = grey.dimensions();
    Ok(Image::new(
        width as usize,
        height as usize,
        1,
        Samples::U8(grey.into_raw()),
    )?)
}

fn write_pfm(path: &PathBuf, map: &DisparityMap) -> Result<()> {
    let mut bytes = format!("Pf\n{} {}\n-1.0\n", map.width, map.height).into_bytes();
    for row in map.data.chunks(map.width.max(1)).rev() {
        for value in row {
            bytes.extend_from_slice(&value.to_le_bytes());
        }
    }
    std::fs::write(path, bytes).with_context(|| format!("cannot write {}", path.display()))
}

fn main() -> Result<()> {
    let args = parse_args()?;
    let text = std::fs::read_to_string(&args.pairs)
        .with_context(|| format!("cannot read {}", args.pairs.display()))?;
    let input: Pairs = serde_json::from_str(&text)
        .with_context(|| format!("{} is not a pairs file", args.pairs.display()))?;
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(args.threads)
        .build()?;
    let mut matcher = Matcher::new(input.algorithm, input.params)?;
    let mut report = Vec::new();
    for pair in &input.pairs {
        let (left, right) = (read_mono(&pair.left)?, read_mono(&pair.right)?);
        let mut map = DisparityMap {
            width: 0,
            height: 0,
            min_disparity: 0,
            disparity_range: 0,
            data: Vec::new(),
        };
        pool.install(|| matcher.compute_into(&left, &right, &mut map))?;
        let mut times = Vec::with_capacity(args.repeats);
        for _ in 0..args.repeats {
            let start = Instant::now();
            pool.install(|| matcher.compute_into(&left, &right, &mut map))?;
            times.push(start.elapsed().as_secs_f64() * 1e3);
        }
        times.sort_by(f64::total_cmp);
        write_pfm(&pair.out, &map)?;
        report.push(serde_json::json!({
            "left": pair.left,
            "median_ms": times[times.len() / 2],
            "min_ms": times[0],
            "density": map.density(),
        }));
    }
    println!(
        "{}",
        serde_json::to_string_pretty(&serde_json::json!({
            "threads": pool.current_num_threads(),
            "pairs": report,
        }))?
    );
    Ok(())
}
