//! The calibration report, `report.html`: one self-contained HTML page (inline SVG
//! charts, the rectified pair as a PNG data URI, no scripts, no external links) that
//! shows what a calibration did: a summary of the results, per-view error bars,
//! residual scatter, corner coverage, the distortion field and a rectified pair with
//! epipolar lines (the undistorted image for a mono camera).
//!
//! Conventions: pixels with pixel centres at integer coordinates; residuals are
//! detected minus reprojected pixels; transforms named `a_from_b`.

mod coverage;
mod distortion;
pub(crate) mod html;
mod per_view;
mod rectified_pair;
mod residuals;
mod sample;
mod summary;
pub(crate) mod svg;
mod views;

use std::path::{Path, PathBuf};

use stereocal_msgs::atomic_file;
use stereocal_vision::rectify::{MapError, RemapError};
use thiserror::Error;

use crate::calibrate::result::CalibrationResult;
use crate::calibrate::stage::{CalibrationOutcome, CameraFrames};
use stereocal_rosbag::BagError;

pub use coverage::COVERAGE_COLUMNS;
pub use rectified_pair::{EPIPOLAR_LINE_HALF_WIDTH, EPIPOLAR_LINES};
pub use sample::{SampleImage, SampleImages, read_sample, sample_stamp};

/// What the report is made from.
#[derive(Clone, Copy, Debug)]
pub struct ReportInputs<'a> {
    /// The calibration.
    pub outcome: &'a CalibrationOutcome,
    /// Its results, which the summary shows.
    pub result: &'a CalibrationResult,
    /// The frames each camera was calibrated from, in the order of `outcome.cameras`.
    pub frames: &'a [CameraFrames],
    /// Raw images of one frame (one per camera, same order), shown rectified with the
    /// result; `None` leaves the picture out.
    pub sample: Option<&'a SampleImages>,
}

/// Why the report could not be made.
#[derive(Debug, Error)]
pub enum ReportError {
    /// The frames given do not belong to the calibration's cameras.
    #[error(
        "the calibration has cameras [{cameras}] but frames were given for [{frames}], in that order"
    )]
    CameraMismatch {
        /// The calibration's camera names.
        cameras: String,
        /// The names of the frames' cameras.
        frames: String,
    },
    /// A chart could not be drawn.
    #[error("drawing the {chart} chart: {message}")]
    Chart {
        /// Which chart.
        chart: &'static str,
        /// What the plotting library said.
        message: String,
    },
    /// The sample images do not fit the calibration.
    #[error("sample images: {0}")]
    Sample(String),
    /// No rectification map could be built for a sample image.
    #[error("rectifying the {camera} sample image: {source}")]
    Map {
        /// The camera.
        camera: String,
        /// Why.
        source: MapError,
    },
    /// A sample image could not be remapped.
    #[error("rectifying the {camera} sample image: {source}")]
    Remap {
        /// The camera.
        camera: String,
        /// Why.
        source: RemapError,
    },
    /// The rectified picture could not be encoded.
    #[error("encoding the rectified picture as PNG: {0}")]
    Png(#[from] image::ImageError),
    /// The rectified picture of mono images could not be encoded.
    #[error("encoding the rectified picture as a palette PNG: {0}")]
    PalettePng(#[from] png::EncodingError),
    /// The bag could not be read for the sample images.
    #[error("reading the sample images from the bag: {0}")]
    Bag(#[from] BagError),
    /// The report file could not be written.
    #[error("writing {path}: {source}")]
    Write {
        /// The report's path.
        path: PathBuf,
        /// Why.
        source: std::io::Error,
    },
}

/// The report as one HTML document.
pub fn render_report(inputs: &ReportInputs) -> Result<String, ReportError> {
    let outcome = inputs.outcome;
    let names = |it: &mut dyn Iterator<Item = &str>| it.collect::<Vec<_>>().join(", ");
    let camera_names = names(&mut outcome.cameras.iter().map(|c| c.name.as_str()));
    let frame_names = names(&mut inputs.frames.iter().map(|f| f.name.as_str()));
    if camera_names != frame_names {
        return Err(ReportError::CameraMismatch {
            cameras: camera_names,
            frames: frame_names,
        });
    }
    let cameras: Vec<views::CameraViews> = outcome
        .cameras
        .iter()
        .zip(inputs.frames)
        .map(|(result, frames)| views::CameraViews::new(result, frames))
        .collect();

    let mut page = html::Page::new("Calibration report");
    page.section("Summary", &summary::summary(inputs.result));
    let mut per_view = String::new();
    let mut residual = String::new();
    let mut cover = String::new();
    let mut field = String::new();
    for camera in &cameras {
        per_view.push_str(&per_view::chart(camera)?);
        residual.push_str(&residuals::chart(camera)?);
        cover.push_str(&coverage::chart(camera)?);
        field.push_str(&distortion::chart(camera)?);
    }
    let side_by_side = |figures: &str| format!("<div class=\"cameras\">{figures}</div>");
    page.section("Per-view reprojection error", &side_by_side(&per_view));
    page.section("Residuals", &side_by_side(&residual));
    page.section("Coverage", &side_by_side(&cover));
    page.section("Distortion field", &side_by_side(&field));
    let picture = match inputs.sample {
        Some(sample) => rectified_pair::figure(outcome, sample)?,
        None => html::paragraph("No sample images were kept: no picture to show."),
    };
    let title = if outcome.stereo.is_some() {
        "Rectified pair"
    } else {
        "Undistorted image"
    };
    page.section(title, &picture);
    Ok(page.finish())
}

/// Renders the report and writes it to `path` atomically.
pub fn write_report(path: &Path, inputs: &ReportInputs) -> Result<(), ReportError> {
    let text = render_report(inputs)?;
    atomic_file::write(path, text.as_bytes()).map_err(|source| ReportError::Write {
        path: path.to_path_buf(),
        source,
    })
}
