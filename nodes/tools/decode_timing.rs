//! `decode_timing`: how long `sensor_msgs/CompressedImage` decoding takes, the way every
//! node and command decodes (`convert::image_msg_from_compressed`), for a side-by-side
//! comparison with OpenCV's `imdecode` (`interop/bench_decode_opencv.py`).
//!
//! `decode_timing FILE FORMAT CALLS REPEATS` decodes the JPEG or PNG in FILE, with the
//! CompressedImage `format` FORMAT, CALLS times per batch, REPEATS batches, on one
//! thread, and prints one JSON object: `{"width", "height", "encoding",
//! "median_ms"}` (the median over the batches of the time per call).

use std::process::ExitCode;
use std::time::Instant;

use stereocal::convert::image_msg_from_compressed;
use stereocal_msgs::sensor_msgs::CompressedImage;

fn run(args: &[String]) -> Result<String, String> {
    let [file, format, calls, repeats] = args else {
        return Err("usage: decode_timing FILE FORMAT CALLS REPEATS".into());
    };
    let data = std::fs::read(file).map_err(|e| format!("{file}: {e}"))?;
    let calls: usize = calls.parse().map_err(|e| format!("CALLS {calls}: {e}"))?;
    let repeats: usize = repeats
        .parse()
        .map_err(|e| format!("REPEATS {repeats}: {e}"))?;
    if calls == 0 || repeats == 0 {
        return Err("CALLS and REPEATS must be at least 1".into());
    }
    let message = CompressedImage {
        format: format.clone(),
        data,
        ..CompressedImage::default()
    };
    let first = image_msg_from_compressed(&message).map_err(|e| e.to_string())?;
    let mut batches = Vec::with_capacity(repeats);
    for _ in 0..repeats {
        let started = Instant::now();
        for _ in 0..calls {
            std::hint::black_box(
                image_msg_from_compressed(std::hint::black_box(&message))
                    .map_err(|e| e.to_string())?,
            );
        }
        batches.push(started.elapsed().as_secs_f64() * 1e3 / calls as f64);
    }
    batches.sort_by(f64::total_cmp);
    Ok(format!(
        "{{\"width\": {}, \"height\": {}, \"encoding\": \"{}\", \"median_ms\": {}}}",
        first.width,
        first.height,
        first.encoding,
        batches[batches.len() / 2]
    ))
}

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    match run(&args) {
        Ok(json) => {
            println!("{json}");
            ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("decode_timing: {e}");
            ExitCode::FAILURE
        }
    }
}
