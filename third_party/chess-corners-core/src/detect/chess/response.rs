//! Dense ChESS response computation for 8-bit grayscale inputs.
use super::ring::RingOffsets;
use crate::uncertainty::{PixelGradients, PixelTile};
use crate::{ChessParams, ResponseMap};

#[cfg(feature = "rayon")]
use rayon::prelude::*;

#[cfg(feature = "simd")]
use core::simd::Simd;

#[cfg(feature = "simd")]
use std::simd::prelude::{SimdFloat, SimdInt, SimdUint};

#[cfg(feature = "simd")]
const LANES: usize = 16;

#[cfg(feature = "simd")]
type U8s = Simd<u8, LANES>;

#[cfg(feature = "simd")]
type I16s = Simd<i16, LANES>;

#[cfg(feature = "simd")]
type I32s = Simd<i32, LANES>;

#[cfg(feature = "simd")]
type F32s = Simd<f32, LANES>;

#[cfg(feature = "tracing")]
use tracing::instrument;

/// Rectangular region of interest with half-open coordinate semantics
/// `[x0, x1) × [y0, y1)`.
///
/// Coordinates are in image-pixel space relative to the
/// [`ImageView`](crate::ImageView)'s `origin` offset. The invariants
/// `x0 < x1` and `y0 < y1` are enforced by [`Roi::new`], which returns
/// `None` when they are violated.
#[derive(Clone, Copy, Debug)]
pub struct Roi {
    x0: usize,
    y0: usize,
    x1: usize,
    y1: usize,
}

impl Roi {
    /// Create a new ROI. Returns `None` if `x0 >= x1` or `y0 >= y1`.
    pub fn new(x0: usize, y0: usize, x1: usize, y1: usize) -> Option<Self> {
        if x0 < x1 && y0 < y1 {
            Some(Self { x0, y0, x1, y1 })
        } else {
            None
        }
    }

    /// Left edge of the ROI (inclusive).
    #[inline]
    pub fn x0(&self) -> usize {
        self.x0
    }
    /// Top edge of the ROI (inclusive).
    #[inline]
    pub fn y0(&self) -> usize {
        self.y0
    }
    /// Right edge of the ROI (exclusive).
    #[inline]
    pub fn x1(&self) -> usize {
        self.x1
    }
    /// Bottom edge of the ROI (exclusive).
    #[inline]
    pub fn y1(&self) -> usize {
        self.y1
    }
}

#[inline]
fn ring_from_params(params: &ChessParams) -> (RingOffsets, &'static [(i32, i32); 16]) {
    let ring = params.ring();
    (ring, ring.offsets())
}

/// Compute the dense ChESS response for an 8-bit grayscale image.
///
/// The response at each valid pixel center is computed from a 16‑sample ring
/// around the pixel and a 5‑pixel cross at the center. For a given center
/// `c`, let `s[0..16)` be the ring samples in the canonical order:
///
/// - `SR` (sum of “square” responses) compares four opposite quadrants on
///   the ring:
///
///   ```text
///   SR = sum_{k=0..3} | (s[k] + s[k+8]) - (s[k+4] + s[k+12]) |
///   ```
///
/// - `DR` (sum of “difference” responses) enforces edge‑like structure:
///
///   ```text
///   DR = sum_{k=0..7} | s[k] - s[k+8] |
///   ```
///
/// - `μₙ` is the mean of all 16 ring samples.
/// - `μₗ` is the local mean of the 5‑pixel cross at the center
///   (`c`, `north`, `south`, `east`, `west`).
///
/// The final ChESS response is:
///
/// ```text
/// R = SR - DR - 16 * |μₙ - μₗ|
/// ```
///
/// where high positive values correspond to chessboard‑like corners.
///
/// # Score contract
///
/// `R` is the **unnormalized** ChESS response defined by Bennett and
/// Lasenby (2014). The units are 8-bit pixel sums — not normalized
/// to `[0, 1]`, not divided by a local scale, not divided by the
/// scene max. Every term is linear in the pixel values, so with 8-bit
/// input `R` is bounded by `SR − DR − 16·MR ∈ [−24·255, 8·255]`
/// (≈ `[−6120, 2040]`); in practice chessboard corners produce scores
/// well below that upper bound.
///
/// The paper's acceptance criterion is simply `R > 0`. That is what
/// [`ChessParams`]`::default()` encodes via `threshold = 0.0`
/// combined with a strict comparison in
/// [`crate::detect_corners_from_response`]. The `threshold` field is an
/// **absolute floor layered on top** of the paper's score — a
/// convenience for trading off sensitivity vs false positives, not part
/// of the score definition.
///
/// # Implementation strategy
///
/// Internally the image is processed row‑by‑row, but only pixels whose
/// full ring lies inside the image bounds are evaluated; border pixels
/// are left at zero in the returned [`ResponseMap`].
///
/// - Without any features, `chess_response_u8` uses a straightforward
///   nested `for y { for x { ... } }` scalar loop and relies on the
///   compiler’s auto‑vectorization in release builds.
/// - With the `rayon` feature, the work is split into independent row
///   slices and processed in parallel using `rayon::par_chunks_mut`.
/// - With the `simd` feature, the inner loop over `x` is rewritten to
///   operate on `LANES` pixels at a time using portable SIMD vectors
///   (currently 16 lanes of `u8`). The ring samples and the 5‑pixel
///   local-mean cross are gathered into SIMD registers, `SR`/`DR`/`μₙ`/`μₗ`
///   are accumulated in vector lanes, and the final response is stored a
///   full vector at a time.
/// - With both `rayon` and `simd` enabled, each row is processed in
///   parallel *and* each row uses the SIMD‑accelerated inner loop.
///
/// All feature combinations produce the same output values (within a
/// small tolerance for floating‑point rounding), and differ only in
/// performance characteristics.
///
/// # Panics
///
/// Panics if `img.len() != w * h`.
#[cfg_attr(
    feature = "tracing",
    instrument(level = "info", skip(img, params), fields(w, h))
)]
pub fn chess_response_u8(img: &[u8], w: usize, h: usize, params: &ChessParams) -> ResponseMap {
    let mut map = ResponseMap::new(0, 0, Vec::new());
    chess_response_u8_into(img, w, h, params, &mut map);
    map
}

/// [`chess_response_u8`] written into `map`, reusing its allocation: the same
/// response, bit for bit, without a fresh `w * h` buffer for every image.
///
/// # Panics
///
/// Panics if `img.len() != w * h`.
pub fn chess_response_u8_into(
    img: &[u8],
    w: usize,
    h: usize,
    params: &ChessParams,
    map: &mut ResponseMap,
) {
    assert_eq!(
        img.len(),
        w * h,
        "chess_response_u8: img.len() ({}) must equal w*h ({w} * {h} = {})",
        img.len(),
        w * h,
    );
    let data = std::mem::take(&mut map.data);
    // rayon path compiled only when feature is enabled
    #[cfg(feature = "rayon")]
    {
        *map = compute_response_parallel(img, w, h, params, data);
    }
    #[cfg(not(feature = "rayon"))]
    {
        *map = compute_response_sequential(img, w, h, params, data);
    }
}

/// `data` resized to `w * h` with every pixel outside `[x0, x1) x [y0, y1)` set to
/// zero, as a fresh zeroed buffer would have them; the pixels inside keep what they
/// held, for the row kernels to overwrite.
fn response_buffer(
    mut data: Vec<f32>,
    w: usize,
    h: usize,
    (x0, x1): (usize, usize),
    (y0, y1): (usize, usize),
) -> Vec<f32> {
    data.truncate(w * h);
    data.resize(w * h, 0.0);
    if x0 >= x1 || y0 >= y1 || x1 > w || y1 > h {
        data.fill(0.0);
        return data;
    }
    data[..y0 * w].fill(0.0);
    data[y1 * w..].fill(0.0);
    for row in data[y0 * w..y1 * w].chunks_exact_mut(w) {
        row[..x0].fill(0.0);
        row[x1..].fill(0.0);
    }
    data
}

/// Always uses the scalar implementation (no rayon, no SIMD); the
/// golden reference for the SIMD-equivalence tests.
#[cfg(all(test, feature = "simd"))]
fn chess_response_u8_scalar(img: &[u8], w: usize, h: usize, params: &ChessParams) -> ResponseMap {
    compute_response_sequential_scalar(img, w, h, params)
}

/// Compute the ChESS response only inside a rectangular ROI of the image.
///
/// The ROI is given in image coordinates [x0, x1) × [y0, y1) via [`Roi`]. The
/// returned [`ResponseMap`] has width (x1 - x0) and height (y1 - y0), with
/// coordinates relative to (x0, y0).
///
/// Pixels where the ChESS ring would go out of bounds (w.r.t. the *full*
/// image) are left at 0.0, and will be ignored by the detector because they
/// lie inside the border margin. Internally this reuses the same scalar,
/// SIMD, and optional `rayon` row kernels as [`chess_response_u8`], so ROI
/// refinement benefits from the same feature combinations as the full-frame
/// response path.
///
/// # Panics
///
/// Panics if `img.len() != img_w * img_h` (the *full* image, not the ROI).
#[cfg_attr(
    feature = "tracing",
    instrument(
        level = "debug",
        skip(img, params),
        fields(img_w, img_h, roi_w = roi.x1 - roi.x0, roi_h = roi.y1 - roi.y0)
    )
)]
pub fn chess_response_u8_patch(
    img: &[u8],
    img_w: usize,
    img_h: usize,
    params: &ChessParams,
    roi: Roi,
) -> ResponseMap {
    assert_eq!(
        img.len(),
        img_w * img_h,
        "chess_response_u8_patch: img.len() ({}) must equal img_w*img_h ({img_w} * {img_h} = {})",
        img.len(),
        img_w * img_h,
    );
    let Roi { x0, y0, x1, y1 } = roi;

    // Clamp ROI to the image bounds
    let x0 = x0.min(img_w);
    let y0 = y0.min(img_h);
    let x1 = x1.min(img_w);
    let y1 = y1.min(img_h);

    if x1 <= x0 || y1 <= y0 {
        return ResponseMap {
            w: 0,
            h: 0,
            data: Vec::new(),
            chess_ring: None,
        };
    }

    let patch_w = x1 - x0;
    let patch_h = y1 - y0;
    let mut data = vec![0.0f32; patch_w * patch_h];
    #[cfg(not(feature = "simd"))]
    let kernel = RowKernel::detect();

    let (ring_kind, ring) = ring_from_params(params);
    let r = ring_kind.radius() as i32;

    // Safe region for ring centers in *global* image coordinates
    let gx0 = r as usize;
    let gy0 = r as usize;
    let gx1 = img_w - r as usize;
    let gy1 = img_h - r as usize;

    for py in 0..patch_h {
        let gy = y0 + py;
        if gy < gy0 || gy >= gy1 {
            continue;
        }

        // Global x-range where the ring is valid on this row.
        let row_gx0 = x0.max(gx0);
        let row_gx1 = x1.min(gx1);
        if row_gx0 >= row_gx1 {
            continue;
        }

        let row = &mut data[py * patch_w..(py + 1) * patch_w];
        let rel_start = row_gx0 - x0;
        let rel_end = row_gx1 - x0;
        let dst_row = &mut row[rel_start..rel_end];

        #[cfg(feature = "simd")]
        {
            compute_row_range_simd(img, img_w, gy as i32, ring, dst_row, row_gx0, row_gx1);
        }

        #[cfg(not(feature = "simd"))]
        {
            compute_row_range(
                kernel, img, img_w, gy as i32, ring, dst_row, row_gx0, row_gx1,
            );
        }
    }

    ResponseMap {
        w: patch_w,
        h: patch_h,
        data,
        chess_ring: Some(ring_kind),
    }
}

#[cfg(not(feature = "rayon"))]
fn compute_response_sequential(
    img: &[u8],
    w: usize,
    h: usize,
    params: &ChessParams,
    data: Vec<f32>,
) -> ResponseMap {
    let (ring_kind, ring) = ring_from_params(params);
    let r = ring_kind.radius() as i32;

    #[cfg(not(feature = "simd"))]
    let kernel = RowKernel::detect();

    // only evaluate where full ring fits
    let x0 = r as usize;
    let y0 = r as usize;
    let x1 = w - r as usize;
    let y1 = h - r as usize;
    let mut data = response_buffer(data, w, h, (x0, x1), (y0, y1));

    for y in y0..y1 {
        let row = &mut data[y * w..(y + 1) * w];
        let dst_row = &mut row[x0..x1];

        #[cfg(feature = "simd")]
        {
            compute_row_range_simd(img, w, y as i32, ring, dst_row, x0, x1);
        }

        #[cfg(not(feature = "simd"))]
        {
            compute_row_range(kernel, img, w, y as i32, ring, dst_row, x0, x1);
        }
    }

    ResponseMap {
        w,
        h,
        data,
        chess_ring: Some(ring_kind),
    }
}

#[cfg(all(test, feature = "simd"))]
fn compute_response_sequential_scalar(
    img: &[u8],
    w: usize,
    h: usize,
    params: &ChessParams,
) -> ResponseMap {
    let (ring_kind, ring) = ring_from_params(params);
    let r = ring_kind.radius() as i32;

    let mut data = vec![0.0f32; w * h];

    // only evaluate where full ring fits
    let x0 = r as usize;
    let y0 = r as usize;
    let x1 = w - r as usize;
    let y1 = h - r as usize;

    for y in y0..y1 {
        let row = &mut data[y * w..(y + 1) * w];
        let dst_row = &mut row[x0..x1];
        compute_row_range_scalar(img, w, y as i32, ring, dst_row, x0, x1);
    }

    ResponseMap {
        w,
        h,
        data,
        chess_ring: Some(ring_kind),
    }
}

#[cfg(feature = "rayon")]
fn compute_response_parallel(
    img: &[u8],
    w: usize,
    h: usize,
    params: &ChessParams,
    data: Vec<f32>,
) -> ResponseMap {
    let (ring_kind, ring) = ring_from_params(params);
    let r = ring_kind.radius() as i32;
    #[cfg(not(feature = "simd"))]
    let kernel = RowKernel::detect();

    // ring margin
    let x0 = r as usize;
    let y0 = r as usize;
    let x1 = w - r as usize;
    let y1 = h - r as usize;
    let mut data = response_buffer(data, w, h, (x0, x1), (y0, y1));

    // Parallelize over rows. We keep the exact same logic and write
    // each row's slice independently.
    data.par_chunks_mut(w).enumerate().for_each(|(y, row)| {
        let y_i = y as i32;
        if y_i < y0 as i32 || y_i >= y1 as i32 {
            return;
        }

        let dst_row = &mut row[x0..x1];

        #[cfg(feature = "simd")]
        {
            compute_row_range_simd(img, w, y_i, ring, dst_row, x0, x1);
        }

        #[cfg(not(feature = "simd"))]
        {
            compute_row_range(kernel, img, w, y_i, ring, dst_row, x0, x1);
        }
    });

    ResponseMap {
        w,
        h,
        data,
        chess_ring: Some(ring_kind),
    }
}

// Fallback stub: when the `rayon` feature is off, `chess_response_u8` takes
// the sequential branch directly and never calls `compute_response_parallel`.
// The stub keeps the name defined so no `#[cfg]` guards are needed at call
// sites that are themselves already gated on `#[cfg(feature = "rayon")]`.
#[cfg(not(feature = "rayon"))]
#[cfg_attr(not(feature = "rayon"), allow(dead_code))]
fn compute_response_parallel(
    img: &[u8],
    w: usize,
    h: usize,
    params: &ChessParams,
    data: Vec<f32>,
) -> ResponseMap {
    compute_response_sequential(img, w, h, params, data)
}

/// Low-level ChESS response at a single pixel center.
///
/// This is the scalar reference implementation used by both the sequential
/// and SIMD paths:
///
/// - gathers 16 ring samples around `(x, y)` using the offsets defined in
///   [`crate::ring`],
/// - computes `SR`, `DR`, the ring mean `μₙ`, and the 5‑pixel local mean
///   `μₗ`, and
/// - returns `R = SR - DR - 16 * |μₙ - μₗ|` as a `f32`.
///
/// Callers are responsible for ensuring that `(x, y)` is far enough from the
/// image border so that all ring and 5‑pixel cross accesses are in‑bounds.
#[inline(always)]
fn chess_response_at_u8(img: &[u8], w: usize, x: i32, y: i32, ring: &[(i32, i32); 16]) -> f32 {
    // gather ring samples into i32
    let mut s = [0i32; 16];
    for k in 0..16 {
        let (dx, dy) = ring[k];
        let xx = (x + dx) as usize;
        let yy = (y + dy) as usize;
        s[k] = img[yy * w + xx] as i32;
    }

    // SR
    let mut sr = 0i32;
    for k in 0..4 {
        let a = s[k] + s[k + 8];
        let b = s[k + 4] + s[k + 12];
        sr += (a - b).abs();
    }

    // DR
    let mut dr = 0i32;
    for k in 0..8 {
        dr += (s[k] - s[k + 8]).abs();
    }

    // neighbor mean
    let sum_ring: i32 = s.iter().sum();
    let mu_n = sum_ring as f32 / 16.0;

    // local mean (5 px cross)
    let c = img[(y as usize) * w + (x as usize)] as f32;
    let n = img[((y - 1) as usize) * w + (x as usize)] as f32;
    let s0 = img[((y + 1) as usize) * w + (x as usize)] as f32;
    let e = img[(y as usize) * w + ((x + 1) as usize)] as f32;
    let w0 = img[(y as usize) * w + ((x - 1) as usize)] as f32;
    let mu_l = (c + n + s0 + e + w0) / 5.0;

    let mr = (mu_n - mu_l).abs();

    (sr as f32) - (dr as f32) - 16.0 * mr
}

/// The 5-pixel cross of the ChESS local mean `μₗ`.
const CROSS: [(i32, i32); 5] = [(0, 0), (0, -1), (0, 1), (1, 0), (-1, 0)];

/// The pixels the ChESS response at one pixel reads — the 16 ring samples,
/// then the 5-pixel cross — as index offsets into a [`PixelTile`] and a
/// [`PixelGradients`] support, so [`Self::add_gradient`] needs no
/// per-pixel address arithmetic.
pub(crate) struct ResponseStencil {
    tile: [isize; 21],
    grads: [isize; 21],
}

impl ResponseStencil {
    /// The stencil of `ring` for `tile` and `grads` (their row strides).
    pub(crate) fn new(ring: &[(i32, i32); 16], tile: &PixelTile, grads: &PixelGradients) -> Self {
        let offsets = |side: usize| {
            core::array::from_fn(|k| {
                let (dx, dy) = if k < 16 { ring[k] } else { CROSS[k - 16] };
                dy as isize * side as isize + dx as isize
            })
        };
        Self {
            tile: offsets(tile.side()),
            grads: offsets(grads.side()),
        }
    }

    /// Add `scale·∂R/∂I` of the ChESS response `R` at pixel `(x, y)` to
    /// `grads`, for every pixel `R` reads (all in `tile`). `R` is
    /// piecewise linear in the pixels; each `|·|` term contributes the sign
    /// of its argument (0 where it is exactly 0).
    #[inline]
    pub(crate) fn add_gradient(
        &self,
        tile: &PixelTile,
        x: i32,
        y: i32,
        scale: [f32; 2],
        grads: &mut PixelGradients,
    ) {
        let (data, at) = (tile.data(), tile.index(x, y) as isize);
        let px = |k: usize| data[(at + self.tile[k]) as usize] as i32;
        let s: [i32; 16] = core::array::from_fn(px);
        let mut coef = [0i32; 16];
        for k in 0..4 {
            let sg = ((s[k] + s[k + 8]) - (s[k + 4] + s[k + 12])).signum();
            coef[k] += sg;
            coef[k + 8] += sg;
            coef[k + 4] -= sg;
            coef[k + 12] -= sg;
        }
        for k in 0..8 {
            let sd = (s[k] - s[k + 8]).signum();
            coef[k] -= sd;
            coef[k + 8] += sd;
        }
        // 80·(μₙ − μₗ) = 5·Σ ring − 16·Σ cross, exactly in integers.
        let sm = (5 * s.iter().sum::<i32>() - 16 * (16..21).map(px).sum::<i32>()).signum();
        // R −= 16·|μₙ − μₗ|: −sign/1 per ring sample, +16·sign/5 per cross
        // pixel. A zero coefficient adds a signed zero, which leaves every
        // gradient as it is, so every ring pixel is added.
        let at = grads.index(x, y) as isize;
        for k in 0..16 {
            let c = (coef[k] - sm) as f32;
            grads.add_at((at + self.grads[k]) as usize, [scale[0] * c, scale[1] * c]);
        }
        if sm != 0 {
            let c = 3.2 * sm as f32;
            for &offset in &self.grads[16..] {
                grads.add_at((at + offset) as usize, [scale[0] * c, scale[1] * c]);
            }
        }
    }
}

// The scalar row kernel is the production path when SIMD is off; in a
// SIMD build the dense paths use `compute_row_range_simd`, so the scalar
// kernel survives only as the golden reference behind the
// `#[cfg(all(test, feature = "simd"))]` scalar response above.
#[cfg(any(not(feature = "simd"), test))]
fn compute_row_range_scalar(
    img: &[u8],
    w: usize,
    y: i32,
    ring: &[(i32, i32); 16],
    dst_row: &mut [f32],
    x_start: usize,
    x_end: usize,
) {
    for (offset, x) in (x_start..x_end).enumerate() {
        dst_row[offset] = chess_response_at_u8(img, w, x as i32, y, ring);
    }
}

/// The row kernel of the dense and ROI response paths, chosen once per
/// response map from what the CPU supports. Every kernel gives the same
/// `f32` values, bit for bit.
#[cfg(not(feature = "simd"))]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum RowKernel {
    /// [`compute_row_range_scalar`]: any CPU.
    Scalar,
    /// [`avx2::compute_row_range`]: x86-64 with AVX2.
    #[cfg(target_arch = "x86_64")]
    Avx2,
}

#[cfg(not(feature = "simd"))]
impl RowKernel {
    /// The fastest kernel this CPU runs.
    fn detect() -> Self {
        #[cfg(target_arch = "x86_64")]
        if std::is_x86_feature_detected!("avx2") {
            return Self::Avx2;
        }
        Self::Scalar
    }
}

/// The ChESS response of the pixels `x_start..x_end` of row `y` into
/// `dst_row`, with `kernel`.
#[cfg(not(feature = "simd"))]
#[allow(clippy::too_many_arguments)]
#[inline]
fn compute_row_range(
    kernel: RowKernel,
    img: &[u8],
    w: usize,
    y: i32,
    ring: &[(i32, i32); 16],
    dst_row: &mut [f32],
    x_start: usize,
    x_end: usize,
) {
    match kernel {
        RowKernel::Scalar => compute_row_range_scalar(img, w, y, ring, dst_row, x_start, x_end),
        #[cfg(target_arch = "x86_64")]
        // SAFETY: `RowKernel::Avx2` is only chosen when the CPU has AVX2.
        RowKernel::Avx2 => unsafe {
            avx2::compute_row_range(img, w, y, ring, dst_row, x_start, x_end)
        },
    }
}

/// The ChESS response sixteen pixels a step with AVX2 on stable Rust.
///
/// The integer parts (ring samples, `SR`, `DR`, the ring and cross sums)
/// are exact in 16-bit lanes (at most 16·255 = 4080); the `f32` part runs
/// the scalar kernel's operations in the scalar kernel's order, without
/// fused multiply-adds, so every value equals
/// [`chess_response_at_u8`]'s bit for bit.
#[cfg(all(target_arch = "x86_64", any(not(feature = "simd"), test)))]
mod avx2 {
    use super::chess_response_at_u8;
    use core::arch::x86_64::*;

    /// Pixels per step.
    const LANES: usize = 16;

    /// Sixteen bytes of `img` from `at`, widened to 16-bit lanes.
    #[inline]
    #[target_feature(enable = "avx2")]
    fn load16(img: &[u8], at: usize) -> __m256i {
        let bytes = &img[at..at + LANES];
        // SAFETY: `bytes` holds the sixteen bytes read (unaligned load).
        let v = unsafe { _mm_loadu_si128(bytes.as_ptr().cast::<__m128i>()) };
        _mm256_cvtepu8_epi16(v)
    }

    /// Sixteen 16-bit integers as two vectors of eight `f32` (exact).
    #[inline]
    #[target_feature(enable = "avx2")]
    fn to_f32(v: __m256i) -> (__m256, __m256) {
        let lo = _mm256_cvtepi16_epi32(_mm256_castsi256_si128(v));
        let hi = _mm256_cvtepi16_epi32(_mm256_extracti128_si256::<1>(v));
        (_mm256_cvtepi32_ps(lo), _mm256_cvtepi32_ps(hi))
    }

    /// `SR - DR - 16·|sum/16 - local/5|` in the scalar kernel's order.
    #[inline]
    #[target_feature(enable = "avx2")]
    fn response(sr: __m256, dr: __m256, sum: __m256, local: __m256) -> __m256 {
        // Dividing by 16 is multiplying by 2^-4, exact either way.
        let mu_n = _mm256_mul_ps(sum, _mm256_set1_ps(0.0625));
        let mu_l = _mm256_div_ps(local, _mm256_set1_ps(5.0));
        let mr = _mm256_andnot_ps(_mm256_set1_ps(-0.0), _mm256_sub_ps(mu_n, mu_l));
        _mm256_sub_ps(
            _mm256_sub_ps(sr, dr),
            _mm256_mul_ps(_mm256_set1_ps(16.0), mr),
        )
    }

    /// The AVX2 counterpart of [`super::compute_row_range_scalar`]; the
    /// pixels past the last full step take the scalar kernel.
    ///
    /// # Safety
    ///
    /// The CPU must support AVX2.
    #[target_feature(enable = "avx2")]
    pub(super) unsafe fn compute_row_range(
        img: &[u8],
        w: usize,
        y: i32,
        ring: &[(i32, i32); 16],
        dst_row: &mut [f32],
        x_start: usize,
        x_end: usize,
    ) {
        // Index of ring sample k of pixel x: ring_bases[k] + x.
        let ring_bases: [isize; 16] = core::array::from_fn(|k| {
            let (dx, dy) = ring[k];
            ((y + dy) as usize * w) as isize + dx as isize
        });
        let row = y as usize * w;
        let mut x = x_start;
        while x + LANES <= x_end {
            let mut s = [_mm256_setzero_si256(); 16];
            for (v, &base) in s.iter_mut().zip(&ring_bases) {
                *v = load16(img, (base + x as isize) as usize);
            }

            let mut sum = s[0];
            for v in &s[1..] {
                sum = _mm256_add_epi16(sum, *v);
            }
            let mut sr = _mm256_setzero_si256();
            for k in 0..4 {
                let a = _mm256_add_epi16(s[k], s[k + 8]);
                let b = _mm256_add_epi16(s[k + 4], s[k + 12]);
                sr = _mm256_add_epi16(sr, _mm256_abs_epi16(_mm256_sub_epi16(a, b)));
            }
            let mut dr = _mm256_setzero_si256();
            for k in 0..8 {
                dr = _mm256_add_epi16(dr, _mm256_abs_epi16(_mm256_sub_epi16(s[k], s[k + 8])));
            }
            let at = row + x;
            let local = _mm256_add_epi16(
                _mm256_add_epi16(
                    _mm256_add_epi16(load16(img, at), load16(img, at - w)),
                    _mm256_add_epi16(load16(img, at + w), load16(img, at + 1)),
                ),
                load16(img, at - 1),
            );

            let (sr_lo, sr_hi) = to_f32(sr);
            let (dr_lo, dr_hi) = to_f32(dr);
            let (sum_lo, sum_hi) = to_f32(sum);
            let (local_lo, local_hi) = to_f32(local);
            let out = &mut dst_row[x - x_start..x - x_start + LANES];
            // SAFETY: `out` holds the sixteen `f32` written (unaligned stores).
            unsafe {
                _mm256_storeu_ps(out.as_mut_ptr(), response(sr_lo, dr_lo, sum_lo, local_lo));
                _mm256_storeu_ps(
                    out.as_mut_ptr().add(8),
                    response(sr_hi, dr_hi, sum_hi, local_hi),
                );
            }
            x += LANES;
        }
        while x < x_end {
            dst_row[x - x_start] = chess_response_at_u8(img, w, x as i32, y, ring);
            x += 1;
        }
    }
}

#[cfg(feature = "simd")]
fn compute_row_range_simd(
    img: &[u8],
    w: usize,
    y: i32,
    ring: &[(i32, i32); 16],
    dst_row: &mut [f32],
    x_start: usize,
    x_end: usize,
) {
    let y_usize = y as usize;

    // Precompute row bases for each ring sample to avoid recomputing (y+dy)*w.
    let mut ring_bases: [isize; 16] = [0; 16];
    for k in 0..16 {
        let (dx, dy) = ring[k];
        let yy = (y + dy) as usize;
        ring_bases[k] = (yy * w) as isize + dx as isize;
    }

    let mut x = x_start;

    while x + LANES <= x_end {
        // Gather ring samples for LANES pixels starting at x
        let mut s: [I16s; 16] = [I16s::splat(0); 16];

        for k in 0..16 {
            let base = (ring_bases[k] + x as isize) as usize;

            // SAFETY: x range + radius guarantees we stay in bounds
            let v_u8 = U8s::from_slice(&img[base..base + LANES]);
            s[k] = v_u8.cast::<i16>();
        }

        // Sum of ring values (for neighbor mean)
        let mut sum_ring_v = I32s::splat(0);
        for &v in &s {
            sum_ring_v += v.cast::<i32>();
        }

        // SR
        let mut sr_v = I32s::splat(0);
        for k in 0..4 {
            let a = s[k].cast::<i32>() + s[k + 8].cast::<i32>();
            let b = s[k + 4].cast::<i32>() + s[k + 12].cast::<i32>();
            sr_v += (a - b).abs();
        }

        // DR
        let mut dr_v = I32s::splat(0);
        for k in 0..8 {
            let a = s[k].cast::<i32>();
            let b = s[k + 8].cast::<i32>();
            dr_v += (a - b).abs();
        }

        // Local mean of the 5-pixel cross for all LANES centers at once.
        // Center/north/south lie at the lane columns; east/west are the
        // same rows shifted by +/-1 column. Every term is therefore a
        // contiguous LANES-wide run, so the cross reduces to five slice
        // loads (the same bytes the scalar path read per lane) with no
        // per-lane gather.
        let row_c = y_usize * w + x;
        let c_v = U8s::from_slice(&img[row_c..row_c + LANES]).cast::<i16>();
        let n_v = U8s::from_slice(&img[row_c - w..row_c - w + LANES]).cast::<i16>();
        let s_v = U8s::from_slice(&img[row_c + w..row_c + w + LANES]).cast::<i16>();
        let e_v = U8s::from_slice(&img[row_c + 1..row_c + 1 + LANES]).cast::<i16>();
        let w_v = U8s::from_slice(&img[row_c - 1..row_c - 1 + LANES]).cast::<i16>();

        // Sum of the five 0..=255 samples fits in i16 (<= 1275) and is
        // exact in f32, so casting the integer sum and dividing by 5.0
        // reproduces the scalar `(c + n + s0 + e + w0) / 5.0` bit-for-bit.
        let local_sum = c_v + n_v + s_v + e_v + w_v;

        let mu_n = sum_ring_v.cast::<f32>() / F32s::splat(16.0);
        let mu_l = local_sum.cast::<f32>() / F32s::splat(5.0);
        let mr = (mu_n - mu_l).abs();

        // R = SR - DR - 16*MR, lane-wise in the same operation order as the
        // scalar path (plain mul/sub, no fused multiply-add), stored to the
        // contiguous output run.
        let resp = sr_v.cast::<f32>() - dr_v.cast::<f32>() - F32s::splat(16.0) * mr;
        let px = x - x_start;
        resp.copy_to_slice(&mut dst_row[px..px + LANES]);

        x += LANES;
    }

    // Tail: scalar for remaining pixels
    while x < x_end {
        let px = x - x_start;
        let resp = chess_response_at_u8(img, w, x as i32, y, ring);
        dst_row[px] = resp;
        x += 1;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::detect::chess::ring::RING5;

    fn idx(w: usize, x: usize, y: usize) -> usize {
        y * w + x
    }

    #[test]
    #[should_panic(expected = "chess_response_u8: img.len()")]
    fn chess_response_u8_panics_on_dimension_mismatch() {
        let img = vec![0u8; 10];
        let params = ChessParams::default();
        let _ = chess_response_u8(&img, 4, 4, &params);
    }

    #[test]
    #[should_panic(expected = "chess_response_u8_patch: img.len()")]
    fn chess_response_u8_patch_panics_on_dimension_mismatch() {
        let img = vec![0u8; 10];
        let params = ChessParams::default();
        let roi = Roi::new(0, 0, 2, 2).unwrap();
        let _ = chess_response_u8_patch(&img, 4, 4, &params, roi);
    }

    #[test]
    fn response_matches_manual_ring_layout() {
        let params = ChessParams::default();
        let w = 11usize;
        let h = 11usize;
        let cx = 5usize;
        let cy = 5usize;
        let mut img = vec![0u8; w * h];

        // Populate the 16 ring samples with the sequence 0..15.
        for (i, (dx, dy)) in RING5.iter().enumerate() {
            let x = (cx as i32 + dx) as usize;
            let y = (cy as i32 + dy) as usize;
            img[idx(w, x, y)] = i as u8;
        }

        // Fill the 5-pixel cross used in the local mean with distinct values.
        for (dx, dy, v) in [
            (0, 0, 10u8),
            (0, -1, 20u8),
            (0, 1, 30u8),
            (1, 0, 40u8),
            (-1, 0, 50u8),
        ] {
            let x = (cx as i32 + dx) as usize;
            let y = (cy as i32 + dy) as usize;
            img[idx(w, x, y)] = v;
        }

        let resp = chess_response_u8(&img, w, h, &params);
        let center = resp.at(cx, cy);

        // Expected value computed from the ring/cross assignments above.
        let expected = -392.0_f32;
        assert!(
            (center - expected).abs() < 1e-3,
            "expected center response {expected}, got {center}"
        );

        for (i, v) in resp.data().iter().enumerate() {
            if i == idx(w, cx, cy) {
                continue;
            }
            assert!(
                v.abs() < 1e-6,
                "non-center response should stay zero (idx={i}, val={v})"
            );
        }
    }

    /// Deterministic pseudo-random bytes (xorshift64*).
    fn random_bytes(len: usize, seed: u64) -> Vec<u8> {
        let mut state = seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1;
        (0..len)
            .map(|_| {
                state ^= state >> 12;
                state ^= state << 25;
                state ^= state >> 27;
                (state.wrapping_mul(0x2545_F491_4F6C_DD1D) >> 56) as u8
            })
            .collect()
    }

    /// Images of odd sizes: uniform noise, pure black and white (the
    /// extremes of the integer sums), and a blurred board-like pattern.
    fn test_images() -> Vec<(usize, usize, Vec<u8>)> {
        let mut images = Vec::new();
        for (i, &(w, h)) in [(23, 21), (37, 29), (101, 53), (257, 31), (641, 27)]
            .iter()
            .enumerate()
        {
            let noise = random_bytes(w * h, 1 + i as u64);
            let extremes = noise
                .iter()
                .map(|&v| if v < 128 { 0 } else { 255 })
                .collect();
            let board = (0..w * h)
                .map(|k| {
                    let (x, y) = ((k % w) as f32, (k / w) as f32);
                    let v = (x * 0.37 + y * 0.11).sin() * (y * 0.29 - x * 0.13).cos();
                    (127.5 + 127.5 * v.clamp(-1.0, 1.0)) as u8
                })
                .collect();
            images.push((w, h, noise));
            images.push((w, h, extremes));
            images.push((w, h, board));
        }
        images
    }

    #[cfg(target_arch = "x86_64")]
    #[test]
    fn avx2_rows_match_scalar_bit_for_bit() {
        use crate::detect::chess::ring::RING10;
        if !std::is_x86_feature_detected!("avx2") {
            eprintln!("skipped: this CPU has no AVX2");
            return;
        }
        for (w, h, img) in test_images() {
            for (r, ring) in [(5usize, &RING5), (10, &RING10)] {
                if w <= 2 * r || h <= 2 * r {
                    continue;
                }
                let (x0, x1) = (r, w - r);
                // Full rows, and ranges that start and end off the 16-pixel grid.
                let ranges = [(x0, x1), (x0 + 1, x1), (x0 + 3, x1 - 2), (x1 - 1, x1)];
                for y in r..h - r {
                    for &(a, b) in &ranges {
                        if a >= b {
                            continue;
                        }
                        let mut scalar = vec![0.0f32; b - a];
                        let mut avx = vec![1.0f32; b - a];
                        compute_row_range_scalar(&img, w, y as i32, ring, &mut scalar, a, b);
                        // SAFETY: checked above that the CPU has AVX2.
                        unsafe { avx2::compute_row_range(&img, w, y as i32, ring, &mut avx, a, b) };
                        for (x, (s, v)) in scalar.iter().zip(&avx).enumerate() {
                            assert_eq!(
                                s.to_bits(),
                                v.to_bits(),
                                "{w}x{h} r{r} row {y} pixel {}: scalar {s}, avx2 {v}",
                                a + x
                            );
                        }
                    }
                }
            }
        }
    }

    /// The dense and ROI responses (whatever kernel this CPU runs) equal
    /// the scalar kernel's, bit for bit.
    #[cfg(not(feature = "simd"))]
    #[test]
    fn dense_and_patch_responses_match_scalar_bit_for_bit() {
        let params = ChessParams::default();
        let r = params.ring().radius() as usize;
        let ring = params.ring().offsets();
        for (w, h, img) in test_images() {
            let mut scalar = vec![0.0f32; w * h];
            for y in r..h - r {
                let row = &mut scalar[y * w + r..y * w + w - r];
                compute_row_range_scalar(&img, w, y as i32, ring, row, r, w - r);
            }
            let dense = chess_response_u8(&img, w, h, &params);
            assert!(dense
                .data()
                .iter()
                .zip(&scalar)
                .all(|(a, b)| a.to_bits() == b.to_bits()));

            let (px0, py0, px1, py1) = (3, 2, w - 4, h - 1);
            let roi = Roi::new(px0, py0, px1, py1).unwrap();
            let patch = chess_response_u8_patch(&img, w, h, &params, roi);
            for py in 0..py1 - py0 {
                for px in 0..px1 - px0 {
                    let (a, b) = (patch.at(px, py), scalar[(py0 + py) * w + px0 + px]);
                    assert_eq!(a.to_bits(), b.to_bits(), "{w}x{h} patch ({px}, {py})");
                }
            }
        }
    }

    /// A map reused for image after image, larger and smaller, holds each
    /// image's response bit for bit as a fresh one does, its border zero.
    #[test]
    fn response_into_a_reused_map_matches_a_fresh_one() {
        let params = ChessParams::default();
        let mut map = ResponseMap::new(0, 0, Vec::new());
        let images = test_images();
        for (w, h, img) in images.iter().chain(images.iter().rev()) {
            chess_response_u8_into(img, *w, *h, &params, &mut map);
            let fresh = chess_response_u8(img, *w, *h, &params);
            assert_eq!((map.width(), map.height()), (*w, *h));
            assert!(map
                .data()
                .iter()
                .zip(fresh.data())
                .all(|(a, b)| a.to_bits() == b.to_bits()));
            assert_eq!(map.data().len(), fresh.data().len());
        }
    }

    #[cfg(feature = "simd")]
    #[test]
    fn simd_matches_scalar_reasonably() {
        let params = ChessParams::default();
        let img = image::GrayImage::from_fn(256, 256, |x, y| image::Luma([(x ^ y) as u8]));
        let w = img.width() as usize;
        let h = img.height() as usize;

        let ref_map = chess_response_u8_scalar(img.as_raw(), w, h, &params);
        let simd_map = chess_response_u8(img.as_raw(), w, h, &params);

        let eps = 1e-3_f32;
        for (a, b) in ref_map.data().iter().zip(simd_map.data().iter()) {
            assert!((a - b).abs() <= eps, "diff: {a} vs {b}");
        }
    }

    #[cfg(all(feature = "simd", feature = "rayon"))]
    #[test]
    fn simd_parallel_matches_scalar() {
        let params = ChessParams::default();
        let img = image::GrayImage::from_fn(192, 192, |x, y| {
            image::Luma([(x.wrapping_mul(7) ^ y) as u8])
        });
        let w = img.width() as usize;
        let h = img.height() as usize;

        let ref_map = chess_response_u8_scalar(img.as_raw(), w, h, &params);
        let simd_map = chess_response_u8(img.as_raw(), w, h, &params);

        let eps = 1e-3_f32;
        for (a, b) in ref_map.data().iter().zip(simd_map.data().iter()) {
            assert!((a - b).abs() <= eps, "diff: {a} vs {b}");
        }
    }
}
