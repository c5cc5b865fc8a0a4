//! The measuring tools: the binaries `dds_latency` (the bare DDS transport between two
//! processes), `rectify_latency` (`rectify_node` end to end), `composed_latency`
//! (the stereo rectify pair composed in one process) and `decode_timing`
//! (CompressedImage decoding), whose sources are in this folder,
//! and what they share with the replay of bags through nodes: image geometries to
//! measure, the synthetic [`camera`], the reliability of an endpoint, and latency
//! percentiles.

use std::time::Duration;

pub mod camera;

/// One image geometry and 8-bit encoding to measure.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ImageSize {
    /// Width, pixels.
    pub width: u32,
    /// Height, pixels.
    pub height: u32,
    /// 1 for mono8, 3 for rgb8.
    pub channels: u32,
}

impl ImageSize {
    /// The ROS encoding: `mono8` or `rgb8`.
    pub fn encoding(&self) -> &'static str {
        if self.channels == 3 { "rgb8" } else { "mono8" }
    }

    /// Bytes of one image.
    pub fn data_len(&self) -> usize {
        self.width as usize * self.height as usize * self.channels as usize
    }
}

impl std::str::FromStr for ImageSize {
    type Err = String;

    /// Parses `WIDTHxHEIGHT:ENCODING`, e.g. `640x480:mono8`; at least 16x16.
    fn from_str(s: &str) -> Result<Self, String> {
        let expected = || format!("'{s}': expected WIDTHxHEIGHT:ENCODING, e.g. 640x480:mono8");
        let (dims, encoding) = s.split_once(':').ok_or_else(expected)?;
        let (w, h) = dims.split_once('x').ok_or_else(expected)?;
        let width: u32 = w.trim().parse().map_err(|_| expected())?;
        let height: u32 = h.trim().parse().map_err(|_| expected())?;
        let channels = match encoding.trim() {
            "mono8" => 1,
            "rgb8" => 3,
            other => return Err(format!("'{other}': encoding must be mono8 or rgb8")),
        };
        if width < 16 || height < 16 {
            return Err(format!("'{s}': images must be at least 16x16"));
        }
        Ok(Self {
            width,
            height,
            channels,
        })
    }
}

impl std::fmt::Display for ImageSize {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}x{} {}", self.width, self.height, self.encoding())
    }
}

/// Reliability of a DDS endpoint, as chosen on a measuring tool's command line.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum Reliability {
    /// Reliable: lost samples are repaired.
    Reliable,
    /// Best effort: lost samples stay lost.
    BestEffort,
}

/// Latency percentiles, milliseconds.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Percentiles {
    /// Median.
    pub p50: f64,
    /// 90th percentile.
    pub p90: f64,
    /// 99th percentile.
    pub p99: f64,
    /// Largest.
    pub max: f64,
}

/// Nearest-rank percentiles of `latencies`; `None` when empty.
pub fn percentiles(latencies: &[Duration]) -> Option<Percentiles> {
    let mut sorted = latencies.to_vec();
    sorted.sort_unstable();
    let n = sorted.len();
    let ms = |d: Duration| d.as_secs_f64() * 1e3;
    let rank = |p: f64| {
        let r = (p / 100.0 * n as f64).ceil() as usize;
        ms(sorted[r.clamp(1, n) - 1])
    };
    (n > 0).then(|| Percentiles {
        p50: rank(50.0),
        p90: rank(90.0),
        p99: rank(99.0),
        max: ms(sorted[n - 1]),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sizes_parse_and_bad_ones_are_refused() {
        let s: ImageSize = "1920x1080:rgb8".parse().expect("size");
        assert_eq!((s.width, s.height, s.channels), (1920, 1080, 3));
        assert_eq!(s.data_len(), 1920 * 1080 * 3);
        assert_eq!(s.to_string(), "1920x1080 rgb8");
        for bad in ["640x480", "640x480:bgr16", "8x8:mono8", "x480:mono8"] {
            assert!(bad.parse::<ImageSize>().is_err(), "{bad}");
        }
    }

    #[test]
    fn nearest_rank_percentiles() {
        let latencies: Vec<Duration> = (1..=100).map(Duration::from_millis).collect();
        let p = percentiles(&latencies).expect("percentiles");
        assert_eq!((p.p50, p.p90, p.p99, p.max), (50.0, 90.0, 99.0, 100.0));
        assert!(percentiles(&[]).is_none());
    }
}
