//! Detects a calibration target in PNG images and prints what was found, for comparing
//! stereocal's detectors with other implementations (`interop/check_charuco_opencv.py`).
//!
//! ```text
//! cargo run --release -p stereocal-vision --example detect_target -- [--repeats N] BOARD.yaml IMAGE.png...
//! ```
//!
//! BOARD.yaml is a target definition (`config/boards/*.yaml`). One JSON line per image:
//! `{"image": path, "ids": [..], "corners": [[x, y], ..], "seconds": t}` (pixel centres
//! at integer coordinates), or `"ids": null` when the target was not found; `seconds`
//! is the median over `--repeats` (default 1) detections of the decoded image, on the
//! calling thread.

use std::error::Error;
use std::path::Path;
use std::time::Instant;

use serde_json::json;
use stereocal_vision::board::{Target, detector_for};
use stereocal_vision::image::{Image, Samples};

type Result<T> = std::result::Result<T, Box<dyn Error>>;

fn read_png(path: &str) -> Result<Image> {
    let grey = image::open(path)
        .map_err(|e| format!("cannot read {path}: {e}"))?
        .to_luma8();
    Ok(Image {
        width: grey.width() as usize,
        height: grey.height() as usize,
        channels: 1,
        samples: Samples::U8(grey.into_raw()),
    })
}

fn main() -> Result<()> {
    let mut args: Vec<String> = std::env::args().skip(1).collect();
    let mut repeats = 1usize;
    if args.first().map(String::as_str) == Some("--repeats") {
        repeats = args
            .get(1)
            .and_then(|n| n.parse().ok())
            .filter(|&n| n > 0)
            .ok_or("--repeats needs a positive count")?;
        args.drain(..2);
    }
    let Some((board, images)) = args.split_first() else {
        return Err("usage: detect_target [--repeats N] BOARD.yaml IMAGE.png...".into());
    };
    let target = Target::from_yaml_file(Path::new(board))?;
    let detector = detector_for(&target)?;
    for path in images {
        let image = read_png(path)?;
        let mut times = Vec::with_capacity(repeats);
        let mut found = None;
        for _ in 0..repeats {
            let start = Instant::now();
            found = detector.detect(&image)?;
            times.push(start.elapsed().as_secs_f64());
        }
        times.sort_by(f64::total_cmp);
        let seconds = times[times.len() / 2];
        let line = match found {
            Some(found) => json!({
                "image": path,
                "ids": found.ids,
                "corners": found.corners.iter().map(|p| [p.x, p.y]).collect::<Vec<_>>(),
                "seconds": seconds,
            }),
            None => json!({"image": path, "ids": null, "corners": null, "seconds": seconds}),
        };
        println!("{line}");
    }
    Ok(())
}
