//! Unified corner detection (single or multiscale).
//!
//! This module implements the coarse-to-fine detector used by the
//! `chess-corners` facade. It can:
//!
//! - run a single-scale detection when `pyramid.num_levels <= 1`, or
//! - build an image pyramid, run a coarse detector on the smallest
//!   level, and refine each seed in the base image (coarse-to-fine)
//!   before merging duplicates.
//!
//! The generic driver [`detect_multiscale`] is parameterised over
//! [`DenseDetector`], so both the ChESS and Radon detectors flow
//! through the same orchestrator. The dispatch behind
//! [`crate::Detector::detect_u8`] selects the detector ZST per
//! [`crate::DetectionStrategy`]. End users should reach detection
//! through [`crate::Detector`].

use crate::{
    DetectionStrategy, DetectorConfig, ImageRefiner, NoiseLevel, OnRefinerReject, Uncertainty,
};
use box_image_pyramid::{build_pyramid, PyramidBuffers, PyramidParams};
use chess_corners_core::{describe_corners, estimate_noise_sigma_u8, merge_corners_simple, Corner};
use chess_corners_core::{
    CenterOfMassConfig, CenterOfMassRefiner, CornerRefiner, ImageView, OrientationMethod,
    RadonBuffers, RadonDetector, Refiner, RefinerKind, Roi,
};
use chess_corners_core::{ChessBuffers, ChessDetector, CornerDescriptor, DenseDetector};

/// Bridge from `chess_corners_core::ImageView` to `box_image_pyramid::ImageView`.
fn to_pyramid_view(v: ImageView<'_>) -> box_image_pyramid::ImageView<'_> {
    // invariant: v was already validated as a coherent ImageView, so the pyramid view cannot fail.
    box_image_pyramid::ImageView::new(v.width(), v.height(), v.data()).unwrap()
}
#[cfg(feature = "tracing")]
use tracing::info_span;

/// Parameters controlling the coarse-to-fine multiscale detector.
///
/// The default keeps `num_levels = 1`, so callers start in the single-scale
/// regime unless they explicitly opt into a pyramid.
#[derive(Clone, Debug)]
#[non_exhaustive]
pub(crate) struct CoarseToFineParams {
    /// Image pyramid shape and construction parameters.
    pub pyramid: PyramidParams,
    /// ROI radius at the coarse level (ignored when `pyramid.num_levels <= 1`).
    /// Expressed in coarse-level pixels and automatically scaled to the base
    /// image, with a minimum enforced to keep refinement away from borders.
    pub refinement_radius: u32,
    /// Radius (in base-image pixels) used to merge near-duplicate refined
    /// corners after coarse-to-fine refinement.
    pub merge_radius: f32,
}

impl Default for CoarseToFineParams {
    fn default() -> Self {
        Self {
            pyramid: PyramidParams::default(),
            // Smaller coarse-level ROI around each coarse prediction. With the
            // default 3-level pyramid this maps to roughly a 12px radius
            // (~25px window) at the base resolution.
            refinement_radius: 3,
            // merge duplicates within ~3 pixels
            merge_radius: 3.0,
        }
    }
}

/// The refiners that give detected peaks their final position: `refiner`,
/// and the `fallback` that localizes the peaks `refiner` rejects (ChESS's
/// center of mass under [`OnRefinerReject::KeepCenterOfMass`]).
struct FinalRefiner {
    refiner: Refiner,
    fallback: Option<Refiner>,
}

impl FinalRefiner {
    /// Patch half-width the refiners need around a seed.
    fn radius(&self) -> i32 {
        let fallback = self.fallback.as_ref().map_or(0, |f| f.radius());
        self.refiner.radius().max(fallback)
    }

    /// Select whether both refiners report a position covariance.
    fn with_covariance(self, report: bool) -> Self {
        Self {
            refiner: self.refiner.with_covariance(report),
            fallback: self.fallback.map(|f| f.with_covariance(report)),
        }
    }
}

/// Patch half-width of the final refiner, or `0` when none runs: the
/// extra ROI margin a refined corner needs.
fn refiner_radius(refiner: Option<&FinalRefiner>) -> i32 {
    refiner.map_or(0, FinalRefiner::radius)
}

/// Refine `peaks` on `image` with `refiner`, or return them unchanged
/// when no image refiner is configured.
fn refine_peaks<D: DenseDetector>(
    detector: &D,
    peaks: Vec<Corner>,
    image: ImageView<'_>,
    response: &D::Response<'_>,
    refiner: Option<&mut FinalRefiner>,
) -> Vec<Corner> {
    match refiner {
        Some(FinalRefiner {
            refiner,
            fallback: Some(fallback),
        }) => {
            detector.refine_peaks_on_image_with_fallback(peaks, image, response, refiner, fallback)
        }
        Some(FinalRefiner {
            refiner,
            fallback: None,
        }) => detector.refine_peaks_on_image(peaks, image, response, refiner),
        None => peaks,
    }
}

/// Attach the detector's own peak-fit covariance (Radon) to the corners
/// the image refiner left at their peak, when `covariance` is wanted.
fn attach_peak_covariance<D: DenseDetector>(
    detector: &D,
    corners: &mut [Corner],
    image: ImageView<'_>,
    params: &D::Params,
    buffers: &mut D::Buffers,
    covariance: bool,
) {
    if covariance {
        detector.attach_peak_covariance(corners, image, params, buffers);
    }
}

// ---------------------------------------------------------------------------
// Descriptors and position covariance
// ---------------------------------------------------------------------------

/// One frame's detection result.
#[derive(Debug, Default)]
pub(crate) struct Frame {
    pub(crate) corners: Vec<CornerDescriptor>,
    /// The image noise σ, in gray levels, the corners' position covariances
    /// were computed with: `None` when no corner carries one (`Uncertainty::Off`,
    /// upscaled input, or no localizer reported one) or the estimate declined.
    pub(crate) noise_sigma: Option<f32>,
}
// ---------------------------------------------------------------------------
// Shared coarse-to-fine pipeline
// ---------------------------------------------------------------------------

/// A base-image ROI `(x0, y0, x1, y1)`, half-open, in pixels.
type RoiBounds = (i32, i32, i32, i32);

/// Pre-computed parameters for per-seed ROI refinement.
struct RoiContext {
    inv_scale: f32,
    border: i32,
    safe_margin: i32,
    roi_r: i32,
    base_w_i: i32,
    base_h_i: i32,
}

impl RoiContext {
    /// Compute a clamped, validated ROI around a coarse seed projected to base
    /// image coordinates. Returns `None` if the seed is too close to the border
    /// or the resulting ROI is too small.
    fn compute_roi(&self, c: &Corner) -> Option<RoiBounds> {
        let cx = (c.x * self.inv_scale).round() as i32;
        let cy = (c.y * self.inv_scale).round() as i32;

        if cx < self.safe_margin
            || cy < self.safe_margin
            || cx >= self.base_w_i - self.safe_margin
            || cy >= self.base_h_i - self.safe_margin
        {
            return None;
        }

        let mut x0 = cx - self.roi_r;
        let mut y0 = cy - self.roi_r;
        let mut x1 = cx + self.roi_r + 1;
        let mut y1 = cy + self.roi_r + 1;

        let min_xy = self.border;
        let max_x = self.base_w_i - self.border;
        let max_y = self.base_h_i - self.border;

        if x0 < min_xy {
            x0 = min_xy;
        }
        if y0 < min_xy {
            y0 = min_xy;
        }
        if x1 > max_x {
            x1 = max_x;
        }
        if y1 > max_y {
            y1 = max_y;
        }

        if x1 - x0 <= 2 * self.border || y1 - y0 <= 2 * self.border {
            return None;
        }

        Some((x0, y0, x1, y1))
    }
}

fn make_roi_context(
    base: ImageView<'_>,
    coarse_scale: f32,
    detector_border: i32,
    refine_border: i32,
    cf: &CoarseToFineParams,
) -> RoiContext {
    let border = (detector_border + refine_border).max(0);
    let safe_margin = border + 1;
    let roi_r_base = (cf.refinement_radius as f32 / coarse_scale).ceil() as i32;
    let min_roi_r = border + 2;

    RoiContext {
        inv_scale: 1.0 / coarse_scale,
        border,
        safe_margin,
        roi_r: roi_r_base.max(min_roi_r),
        base_w_i: base.width() as i32,
        base_h_i: base.height() as i32,
    }
}

// ---------------------------------------------------------------------------
// Per-frame detection stages
// ---------------------------------------------------------------------------

/// The detection stages one frame runs: full-view detection, coarse seeding,
/// and per-seed ROI refinement. The owned [`Refiner`] (if any) and `buffers`
/// are reused across coarse seeds and every ROI, matching the "no per-corner
/// allocation" contract; under `rayon` the ROIs run in parallel jobs, each
/// with buffers and a refiner of its own.
struct FrameStages<'a, D: DenseDetector> {
    detector: &'a D,
    params: &'a D::Params,
    buffers: &'a mut D::Buffers,
    refiner: Option<FinalRefiner>,
    /// Builds each parallel ROI job's own refiner.
    #[cfg(feature = "rayon")]
    shape: &'a DetectorShape,
    refine_border: i32,
    /// Whether the localizers report a covariance for final corners.
    covariance: bool,
}

/// The per-seed ROI pass over `base`: everything but the scratch, so one
/// value serves every ROI and every worker.
struct RoiPass<'a, D: DenseDetector> {
    detector: &'a D,
    params: &'a D::Params,
    refine_border: i32,
    /// Whether the detector attaches its own peak covariance.
    covariance: bool,
    base: ImageView<'a>,
}

impl<D: DenseDetector> RoiPass<'_, D> {
    /// Corners of the ROI `roi` of `base`: patch response → peaks →
    /// image-domain refinement (and the detector's own peak covariance
    /// when `covariance` is set). Positions are patch-local.
    fn corners(
        &self,
        buffers: &mut D::Buffers,
        refiner: Option<&mut FinalRefiner>,
        roi: RoiBounds,
    ) -> Vec<Corner> {
        let (detector, params, base) = (self.detector, self.params, self.base);
        let (x0, y0, _x1, _y1) = roi;
        let resp = detector.compute_response_patch(base, roi, params, buffers);
        let peaks = detector.detect_corners(&resp, params, self.refine_border);
        if peaks.is_empty() {
            return Vec::new();
        }
        // Image-domain refinement over the base image with origin [x0, y0]:
        // the refiner sees patch-local seed coords and samples base pixels
        // at (cx + x0, cy + y0).
        let patch_image =
            ImageView::with_origin(base.width(), base.height(), base.data(), [x0, y0])
                .expect("base image dimensions must match buffer length");
        let mut out = refine_peaks(detector, peaks, patch_image, &resp, refiner);
        drop(resp);
        attach_peak_covariance(
            detector,
            &mut out,
            patch_image,
            params,
            buffers,
            self.covariance,
        );
        out
    }
}

impl<D> FrameStages<'_, D>
where
    D: DenseDetector + Sync,
    D::Params: Sync,
{
    /// Response → peaks → localization over a full view, reporting a
    /// covariance when `covariance` is set. Positions are in the view's own
    /// frame.
    fn detect(&mut self, view: ImageView<'_>, covariance: bool) -> Vec<Corner> {
        let (detector, params) = (self.detector, self.params);
        let resp = detector.compute_response(view, params, self.buffers);
        let peaks = detector.detect_corners(&resp, params, self.refine_border);
        let mut out = refine_peaks(detector, peaks, view, &resp, self.refiner.as_mut());
        drop(resp);
        attach_peak_covariance(detector, &mut out, view, params, self.buffers, covariance);
        out
    }

    /// Coarse seeds over the coarsest pyramid level: the same detector and
    /// image-domain refiner as [`Self::detect`]; seeds only carve ROIs, so no
    /// covariance is computed. Positions are in the coarse-level frame.
    fn detect_seeds(&mut self, view: ImageView<'_>) -> Vec<Corner> {
        let covariance = self.covariance;
        self.refiner = self.refiner.take().map(|r| r.with_covariance(false));
        let seeds = self.detect(view, false);
        self.refiner = self.refiner.take().map(|r| r.with_covariance(covariance));
        seeds
    }

    /// Refine every ROI `(x0, y0, x1, y1)` of `rois` on `base` (bounds in
    /// base-image pixels), returning one corner list per ROI, in ROI order.
    /// Corner positions are **patch-local** (origin at the ROI's top-left).
    fn refine_rois(&mut self, base: ImageView<'_>, rois: &[RoiBounds]) -> Vec<Vec<Corner>> {
        let pass = RoiPass {
            detector: self.detector,
            params: self.params,
            refine_border: self.refine_border,
            covariance: self.covariance,
            base,
        };
        // Each ROI's corners depend only on its pixels, so a parallel job
        // with fresh buffers and refiner returns what the frame's own would;
        // `collect` keeps seed order.
        #[cfg(feature = "rayon")]
        {
            use rayon::prelude::*;
            let shape = self.shape;
            rois.par_iter()
                .map_init(
                    || (D::Buffers::default(), shape.refiner()),
                    |(buffers, refiner), &roi| pass.corners(buffers, refiner.as_mut(), roi),
                )
                .collect()
        }
        #[cfg(not(feature = "rayon"))]
        {
            rois.iter()
                .map(|&roi| pass.corners(self.buffers, self.refiner.as_mut(), roi))
                .collect()
        }
    }
}

// ---------------------------------------------------------------------------
// Generic multiscale orchestrator (driven by DenseDetector)
// ---------------------------------------------------------------------------

/// The refiner that gives a detected peak its final position.
#[derive(Clone, Debug)]
enum Localizer {
    /// ChESS's own localizer: the center of mass of its response map.
    CenterOfMass(CenterOfMassConfig),
    /// An image refiner.
    Image(RefinerKind),
    /// An image refiner, with ChESS's center of mass for the peaks it
    /// rejects.
    ImageOverCenterOfMass(RefinerKind, CenterOfMassConfig),
}

impl Localizer {
    /// The refiner, reporting a covariance when `covariance` is set.
    fn build(&self, covariance: bool) -> FinalRefiner {
        let center_of_mass = |cfg| Refiner::CenterOfMass(CenterOfMassRefiner::new(cfg));
        let (refiner, fallback) = match self {
            Self::CenterOfMass(cfg) => (center_of_mass(*cfg), None),
            Self::Image(kind) => (Refiner::from_kind(kind.clone()), None),
            Self::ImageOverCenterOfMass(kind, cfg) => {
                (Refiner::from_kind(kind.clone()), Some(center_of_mass(*cfg)))
            }
        };
        FinalRefiner { refiner, fallback }.with_covariance(covariance)
    }
}

/// The core image refiner `refiner` selects: the one place the facade lowers
/// [`DetectorConfig::refiner`].
fn core_image_refiner(refiner: Option<ImageRefiner>) -> Option<RefinerKind> {
    refiner.map(|refiner| match refiner {
        ImageRefiner::SaddlePoint(cfg) => RefinerKind::SaddlePoint(cfg),
    })
}

/// Pixel-shape arguments common to every detector path (descriptor
/// sampling + orientation + post-detection merge). Lets the generic
/// orchestrator stay parameter-symmetric over [`DenseDetector`].
struct DetectorShape {
    /// The refiner that gives the detected peaks their final position: the
    /// image refiner when one is set, else ChESS's center of mass. `None`
    /// keeps the peaks as detected (Radon's peak fit).
    localizer: Option<Localizer>,
    descriptor_ring_radius: u32,
    orientation_method: Option<OrientationMethod>,
    uncertainty: Uncertainty,
    /// Merge radius for the single-scale (no-pyramid) and ROI paths. The
    /// pyramid branches read [`CoarseToFineParams::merge_radius`], which
    /// the config lowering keeps equal to this value.
    merge_radius: f32,
}

impl DetectorShape {
    /// The final refiner, reporting a covariance when the frame's
    /// uncertainty propagates one.
    fn refiner(&self) -> Option<FinalRefiner> {
        self.localizer
            .as_ref()
            .map(|l| l.build(self.uncertainty.propagates()))
    }

    /// Lift merged corners into descriptors over the refinement image `view`
    /// (orientation fit per [`describe_corners`]), and attach each corner's
    /// position covariance in px² when the noise level is available.
    /// `uncertainty` is the frame's position-uncertainty work: the
    /// detector passes [`Uncertainty::Off`] for upscaled input, whose noise
    /// is spatially correlated.
    fn describe(&self, view: ImageView<'_>, corners: Vec<Corner>) -> Frame {
        let has_covariance = corners
            .iter()
            .any(|c| c.noise_covariance_per_unit_variance().is_some());
        let sigma = match self.uncertainty {
            _ if !has_covariance => None,
            Uncertainty::Off => None,
            Uncertainty::Propagated { noise } => match noise {
                NoiseLevel::Known(sigma) => Some(sigma),
                NoiseLevel::Estimate => {
                    estimate_noise_sigma_u8(view.data(), view.width(), view.height())
                }
            },
        };
        // `describe_corners` keeps one descriptor per corner, in order.
        let covariances: Option<Vec<_>> =
            sigma.map(|s| corners.iter().map(|c| c.position_covariance(s)).collect());
        let mut descriptors = describe_corners(
            view.data(),
            view.width(),
            view.height(),
            self.descriptor_ring_radius,
            corners,
            self.orientation_method,
        );
        if let Some(covariances) = covariances {
            for (d, cov) in descriptors.iter_mut().zip(covariances) {
                d.position_covariance = cov;
            }
        }
        Frame {
            corners: descriptors,
            noise_sigma: sigma,
        }
    }
}

/// Generic multiscale corner detection driver.
///
/// Runs a single-scale detection when `multiscale` is `None` or
/// resolves to a 1-level pyramid; otherwise builds the pyramid,
/// detects seeds on the coarsest level, and refines each seed inside
/// a base-image ROI before merging duplicates and producing
/// descriptors.
///
/// The detector is selected through the [`DenseDetector`] trait, so
/// both ChESS and Radon share the same control flow. Peak extraction
/// stays inside [`DenseDetector::detect_corners`] (integer ChESS peaks,
/// Radon peaks placed by its 3-point peak fit); the final refiner
/// (ChESS's center of mass or an image refiner) runs as a separate
/// post-detection stage via [`DenseDetector::refine_peaks_on_image`].
///
/// `descriptor_ring_radius` and `orientation_method` are sourced from
/// the ChESS-derived params even when the active detector is Radon —
/// descriptor sampling and orientation are detector-agnostic stages
/// downstream of peak extraction.
fn detect_multiscale<D>(
    base: ImageView<'_>,
    detector: &D,
    params: &D::Params,
    detector_buffers: &mut D::Buffers,
    pyramid_buffers: &mut PyramidBuffers,
    multiscale: Option<&CoarseToFineParams>,
    shape: &DetectorShape,
) -> Frame
where
    D: DenseDetector + Sync,
    D::Params: Sync,
{
    // The refiner widens the ROI margin only when one runs, so the
    // peak-fit-only Radon path keeps its full seed area near the border.
    let covariance = shape.uncertainty.propagates();
    let refiner = shape.refiner();
    let refine_border = refiner_radius(refiner.as_ref());
    let mut stages = FrameStages {
        detector,
        params,
        buffers: detector_buffers,
        refiner,
        #[cfg(feature = "rayon")]
        shape,
        refine_border,
        covariance,
    };

    let base_view = ImageView::from_u8_slice(base.width(), base.height(), base.data())
        .expect("base image dimensions must match buffer length");

    // Single-scale path: run the detector once on the full base view,
    // merge, describe.
    let Some(cf) = multiscale else {
        let mut corners = stages.detect(base_view, covariance);
        let merged = merge_corners_simple(&mut corners, shape.merge_radius);
        return shape.describe(base_view, merged);
    };

    let pyramid = build_pyramid(to_pyramid_view(base), &cf.pyramid, pyramid_buffers);
    if pyramid.levels.is_empty() {
        return Frame::default();
    }

    // Single-level pyramid: same as single-scale but on the pyramid
    // level's data (which equals the base for num_levels==1 / no
    // downsampling).
    if pyramid.levels.len() == 1 {
        let lvl = &pyramid.levels[0];
        let lvl_view = ImageView::from_u8_slice(lvl.img.width, lvl.img.height, lvl.img.data)
            .expect("pyramid level dimensions must match buffer length");
        let mut corners = stages.detect(lvl_view, covariance);
        let merged = merge_corners_simple(&mut corners, cf.merge_radius);
        return shape.describe(lvl_view, merged);
    }

    // --- Coarse-to-fine path ---

    // invariant: pyramid was built from a validated input image, so at least one level exists.
    let coarse_lvl = pyramid.levels.last().unwrap();
    let coarse_w = coarse_lvl.img.width;
    let coarse_h = coarse_lvl.img.height;

    #[cfg(feature = "tracing")]
    let coarse_span = info_span!("coarse_detect", w = coarse_w, h = coarse_h).entered();
    // invariant: coarse level dimensions come from the pyramid which already validated them.
    let coarse_view = ImageView::from_u8_slice(coarse_w, coarse_h, coarse_lvl.img.data).unwrap();
    let coarse_corners = stages.detect_seeds(coarse_view);
    #[cfg(feature = "tracing")]
    drop(coarse_span);

    if coarse_corners.is_empty() {
        return Frame::default();
    }

    let roi_ctx = make_roi_context(
        base,
        coarse_lvl.scale,
        detector.roi_border(params),
        refine_border,
        cf,
    );

    #[cfg(feature = "tracing")]
    let refine_span = info_span!(
        "refine",
        seeds = coarse_corners.len(),
        roi_r = roi_ctx.roi_r
    )
    .entered();

    let rois: Vec<RoiBounds> = coarse_corners
        .iter()
        .filter_map(|c| roi_ctx.compute_roi(c))
        .collect();
    let patches = stages.refine_rois(base, &rois);
    let mut refined: Vec<Corner> = Vec::with_capacity(patches.iter().map(Vec::len).sum());
    for (&(x0, y0, _x1, _y1), patch) in rois.iter().zip(patches) {
        // Shift patch-local refined positions to base coords.
        refined.extend(patch.into_iter().map(|mut pc| {
            pc.x += x0 as f32;
            pc.y += y0 as f32;
            pc
        }));
    }

    // Each ROI judged its peaks against itself; apply the frame-level
    // acceptance test to the union (see [`DenseDetector::retain_frame_peaks`]).
    detector.retain_frame_peaks(&mut refined, params);

    #[cfg(feature = "tracing")]
    drop(refine_span);

    #[cfg(feature = "tracing")]
    let merge_span = info_span!(
        "merge",
        merge_radius = cf.merge_radius,
        candidates = refined.len()
    )
    .entered();
    let merged = merge_corners_simple(&mut refined, cf.merge_radius);
    #[cfg(feature = "tracing")]
    drop(merge_span);

    shape.describe(base_view, merged)
}

// ---------------------------------------------------------------------------
// Detector-typed entry points (called by the facade Detector dispatch)
// ---------------------------------------------------------------------------

/// A detection pipeline that runs over whichever [`DenseDetector`] the
/// active [`DetectionStrategy`] selects. Implemented once per entry
/// point (full-frame multiscale, single-scale ROI); the strategy →
/// detector/params/[`DetectorShape`] lowering lives solely in
/// [`dispatch_strategy`], so the two entry points cannot drift on how a
/// strategy is configured.
trait StrategyPipeline {
    fn run<D>(
        self,
        base: ImageView<'_>,
        detector: &D,
        params: &D::Params,
        buffers: &mut D::Buffers,
        shape: &DetectorShape,
    ) -> Frame
    where
        D: DenseDetector + Sync,
        D::Params: Sync;
}

/// Lower `cfg.strategy` into the concrete detector marker, its params,
/// its scratch buffers, and the shared post-detection [`DetectorShape`],
/// then hand them to `pipeline`. This is the single place the
/// ChESS/Radon per-strategy configuration is assembled; entry points
/// supply only the pipeline body.
fn dispatch_strategy(
    base: ImageView<'_>,
    cfg: &DetectorConfig,
    uncertainty: Uncertainty,
    chess_buffers: &mut ChessBuffers,
    radon_buffers: &mut RadonBuffers,
    pipeline: impl StrategyPipeline,
) -> Frame {
    let image_refiner = core_image_refiner(cfg.refiner);
    match &cfg.strategy {
        DetectionStrategy::Chess(chess) => {
            let chess_params = cfg.chess_params();
            let center_of_mass = chess_params.center_of_mass;
            // An image refiner replaces the center of mass, which then runs
            // only on the peaks the image refiner rejects, and only when
            // asked to.
            let localizer = match (image_refiner, chess.on_refiner_reject) {
                (None, _) => Localizer::CenterOfMass(center_of_mass),
                (Some(kind), OnRefinerReject::Drop) => Localizer::Image(kind),
                (Some(kind), OnRefinerReject::KeepCenterOfMass) => {
                    Localizer::ImageOverCenterOfMass(kind, center_of_mass)
                }
            };
            let shape = DetectorShape {
                localizer: Some(localizer),
                descriptor_ring_radius: chess_params.ring_radius(),
                orientation_method: chess_params.orientation_method,
                uncertainty,
                merge_radius: cfg.merge_radius,
            };
            pipeline.run(base, &ChessDetector, &chess_params, chess_buffers, &shape)
        }
        DetectionStrategy::Radon(_) => {
            let radon_params = cfg.radon_detector_params();
            let shape = DetectorShape {
                localizer: image_refiner.map(Localizer::Image),
                // Radon strategies don't carry a descriptor-ring knob;
                // descriptors sample the canonical r=5 ring downstream.
                // Orientation method is top-level on DetectorConfig.
                descriptor_ring_radius: chess_corners_core::ChessParams::default().ring_radius(),
                orientation_method: cfg.orientation_method,
                uncertainty,
                merge_radius: cfg.merge_radius,
            };
            pipeline.run(base, &RadonDetector, &radon_params, radon_buffers, &shape)
        }
    }
}

/// [`StrategyPipeline`] for the full-frame coarse-to-fine detector.
struct MultiscaleRun<'a> {
    pyramid_buffers: &'a mut PyramidBuffers,
    multiscale: Option<CoarseToFineParams>,
}

impl StrategyPipeline for MultiscaleRun<'_> {
    fn run<D>(
        self,
        base: ImageView<'_>,
        detector: &D,
        params: &D::Params,
        buffers: &mut D::Buffers,
        shape: &DetectorShape,
    ) -> Frame
    where
        D: DenseDetector + Sync,
        D::Params: Sync,
    {
        detect_multiscale(
            base,
            detector,
            params,
            buffers,
            self.pyramid_buffers,
            self.multiscale.as_ref(),
            shape,
        )
    }
}

/// [`StrategyPipeline`] for the single-scale ROI detector.
struct RoiRun {
    roi: Roi,
}

impl StrategyPipeline for RoiRun {
    fn run<D>(
        self,
        base: ImageView<'_>,
        detector: &D,
        params: &D::Params,
        buffers: &mut D::Buffers,
        shape: &DetectorShape,
    ) -> Frame
    where
        D: DenseDetector + Sync,
        D::Params: Sync,
    {
        detect_roi_generic(base, self.roi, detector, params, buffers, shape)
    }
}

/// Detect corners through the generic orchestrator. The `cfg.strategy`
/// selects between [`ChessDetector`] and [`RadonDetector`]; both
/// flow through the same control flow. `uncertainty` selects the frame's
/// position-covariance work and turns it into px².
pub(crate) fn detect_with_buffers(
    base: ImageView<'_>,
    cfg: &DetectorConfig,
    uncertainty: Uncertainty,
    pyramid_buffers: &mut PyramidBuffers,
    chess_buffers: &mut ChessBuffers,
    radon_buffers: &mut RadonBuffers,
) -> Frame {
    let multiscale = cfg.coarse_to_fine_params();
    dispatch_strategy(
        base,
        cfg,
        uncertainty,
        chess_buffers,
        radon_buffers,
        MultiscaleRun {
            pyramid_buffers,
            multiscale,
        },
    )
}

/// Detect corners inside `roi` of `base` at full resolution. The
/// `cfg.strategy` selects between [`ChessDetector`] and [`RadonDetector`];
/// both flow through [`detect_roi_generic`]. This is single-scale local
/// detection: the config's multiscale/upscale sections do not participate.
pub(crate) fn detect_roi_with_buffers(
    base: ImageView<'_>,
    roi: Roi,
    cfg: &DetectorConfig,
    chess_buffers: &mut ChessBuffers,
    radon_buffers: &mut RadonBuffers,
) -> Frame {
    // ROI detection runs on the input image itself (no upscaling).
    dispatch_strategy(
        base,
        cfg,
        cfg.uncertainty,
        chess_buffers,
        radon_buffers,
        RoiRun { roi },
    )
}

/// Single-scale ROI corner detection.
///
/// Carves an inflated ROI patch — the user ROI grown by the detector's
/// peak-detection margin (response support + NMS + image-refiner
/// half-width) and clamped to the image — so a corner sitting on the ROI
/// edge is still fully inside the carved patch. It then runs the same
/// response → peak → image-domain-refine composition one coarse-to-fine
/// ROI tile uses ([`RoiPass::corners`]), keeps only peaks whose
/// detected position lands inside the (un-inflated, clamped) `roi`,
/// maps them into the base-image frame, and produces descriptors through
/// the shared merge + describe stage.
///
/// A fully out-of-range or degenerate post-clamp ROI yields no corners.
fn detect_roi_generic<D: DenseDetector>(
    base: ImageView<'_>,
    roi: Roi,
    detector: &D,
    params: &D::Params,
    detector_buffers: &mut D::Buffers,
    shape: &DetectorShape,
) -> Frame {
    let base_w = base.width() as i32;
    let base_h = base.height() as i32;

    // Clamp the requested ROI to image bounds; matches the multiscale
    // ROI-carving behaviour. A degenerate post-clamp ROI has no interior.
    let ux0 = (roi.x0() as i32).clamp(0, base_w);
    let uy0 = (roi.y0() as i32).clamp(0, base_h);
    let ux1 = (roi.x1() as i32).clamp(0, base_w);
    let uy1 = (roi.y1() as i32).clamp(0, base_h);
    if ux1 <= ux0 || uy1 <= uy0 {
        return Frame::default();
    }

    // The image-domain refiner widens the required margin only when one
    // runs.
    let mut refiner = shape.refiner();
    let refine_border = refiner_radius(refiner.as_ref());
    // Inflate by the full peak-detection margin so a corner on the ROI
    // edge keeps `roi_border + refine_border` pixels of support inside the
    // carved patch — the same margin `detect_corners` drops from the patch
    // border — and is detected/refined bit-identically to the full frame.
    let inflate = detector.roi_border(params) + refine_border;
    let ix0 = (ux0 - inflate).max(0);
    let iy0 = (uy0 - inflate).max(0);
    let ix1 = (ux1 + inflate).min(base_w);
    let iy1 = (uy1 + inflate).min(base_h);

    // Dense response over the inflated patch; peaks are patch-local.
    let resp =
        detector.compute_response_patch(base, (ix0, iy0, ix1, iy1), params, detector_buffers);
    let peaks = detector.detect_corners(&resp, params, refine_border);
    if peaks.is_empty() {
        return Frame::default();
    }

    // Keep only peaks whose detected position (mapped to the base frame)
    // lies inside the clamped user ROI. This never emits a corner outside
    // `roi`, regardless of how far the patch was inflated.
    let kept: Vec<Corner> = peaks
        .into_iter()
        .filter(|c| {
            let gx = c.x + ix0 as f32;
            let gy = c.y + iy0 as f32;
            gx >= ux0 as f32 && gx < ux1 as f32 && gy >= uy0 as f32 && gy < uy1 as f32
        })
        .collect();
    if kept.is_empty() {
        return Frame::default();
    }

    // Image-domain refinement over the base image with origin at the
    // patch top-left: the refiner sees patch-local seeds and samples base
    // pixels at (seed + origin), so its output matches the full-frame
    // refiner.
    let patch_image = ImageView::with_origin(base.width(), base.height(), base.data(), [ix0, iy0])
        .expect("base image dimensions must match buffer length");
    let mut refined = refine_peaks(detector, kept, patch_image, &resp, refiner.as_mut());
    drop(resp);
    attach_peak_covariance(
        detector,
        &mut refined,
        patch_image,
        params,
        detector_buffers,
        shape.uncertainty.propagates(),
    );
    // Shift patch-local refined positions back into the base frame.
    for c in &mut refined {
        c.x += ix0 as f32;
        c.y += iy0 as f32;
    }

    let merged = merge_corners_simple(&mut refined, shape.merge_radius);
    // The noise level is estimated over the whole image, so covariances
    // match a full-frame run.
    shape.describe(base, merged)
}

#[cfg(test)]
mod tests {
    use super::*;
    use box_image_pyramid::ImageBuffer;

    #[test]
    fn default_coarse_to_fine_config_is_single_scale() {
        let cfg = CoarseToFineParams::default();
        assert_eq!(cfg.pyramid.num_levels, 1);
        assert_eq!(cfg.pyramid.min_size, 128);
        assert_eq!(cfg.refinement_radius, 3);
        assert_eq!(cfg.merge_radius, 3.0);
    }

    #[test]
    fn chess_config_multiscale_preset_has_expected_pyramid() {
        let cfg = DetectorConfig::chess_multiscale();
        let cf = cfg
            .coarse_to_fine_params()
            .expect("chess_multiscale preset must produce CoarseToFineParams");
        assert_eq!(cf.pyramid.num_levels, 3);
        assert_eq!(cf.pyramid.min_size, 128);
        assert_eq!(cf.refinement_radius, 3);
        assert_eq!(cf.merge_radius, 3.0);
    }

    #[test]
    fn coarse_to_fine_trace_reports_timings() {
        let buf = ImageBuffer::new(32, 32);
        let view = ImageView::from_u8_slice(buf.width, buf.height, &buf.data)
            .expect("dimensions must match");
        let cfg = DetectorConfig::default();
        let mut pyramid = PyramidBuffers::default();
        let mut chess_buffers = ChessBuffers::default();
        let mut radon_buffers = RadonBuffers::default();
        let corners = detect_with_buffers(
            view,
            &cfg,
            cfg.uncertainty,
            &mut pyramid,
            &mut chess_buffers,
            &mut radon_buffers,
        );
        assert!(corners.corners.is_empty());
        assert_eq!(corners.noise_sigma, None);
    }
}
