//! Converts raw YUYV frames with camera_node's conversion, for the interop check
//! against OpenCV (`interop/check_yuyv_opencv.py`):
//! `yuyv_convert IN.yuyv WIDTH HEIGHT OUT.rgb OUT.mono` writes the rgb8 and mono8
//! pixels of the YUYV image in IN (rows of 2 x WIDTH bytes).

use anyhow::{Context, bail};
use stereocal::camera::yuyv::{yuyv_to_mono8, yuyv_to_rgb8};

fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let [input, width, height, rgb_out, mono_out] = args.as_slice() else {
        bail!("usage: yuyv_convert IN.yuyv WIDTH HEIGHT OUT.rgb OUT.mono");
    };
    let width: usize = width.parse().context("WIDTH")?;
    let height: usize = height.parse().context("HEIGHT")?;
    let yuyv = std::fs::read(input).with_context(|| input.clone())?;
    std::fs::write(rgb_out, yuyv_to_rgb8(&yuyv, width, height, width * 2)?)?;
    std::fs::write(mono_out, yuyv_to_mono8(&yuyv, width, height, width * 2)?)?;
    Ok(())
}
