//! Detects a calibration target in PNG images and prints what was found, for comparing
//! stereocal's detectors with other implementations (`interop/check_charuco_opencv.py`).
//!
//! ```text
//! cargo run --release -p stereocal-vision --example detect_target -- BOARD.yaml IMAGE.png...
//! ```
//!
//! BOARD.yaml is a target definition (`config/boards/*.yaml`). One JSON line per image:
//! `{"image": path, "ids": [..], "corners": [[x, y], ..]}` (pixel centres at integer
//! coordinates), or `"ids": null` when the target was not found.

use std::error::Error;
use std::path::Path;

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
    let args: Vec<String> = std::env::args().skip(1).collect();
    let Some((board, images)) = args.split_first() else {
        return Err("usage: detect_target BOARD.yaml IMAGE.png...".into());
    };
    let target = Target::from_yaml_file(Path::new(board))?;
    let detector = detector_for(&target)?;
    for path in images {
        let line = match detector.detect(&read_png(path)?)? {
            Some(found) => json!({
                "image": path,
                "ids": found.ids,
                "corners": found.corners.iter().map(|p| [p.x, p.y]).collect::<Vec<_>>(),
            }),
            None => json!({"image": path, "ids": null, "corners": null}),
        };
        println!("{line}");
    }
    Ok(())
}
