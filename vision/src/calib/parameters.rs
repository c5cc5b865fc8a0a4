//! Which intrinsic parameters a calibration estimates, and the map from the free
//! parameters to the full set `fx, fy, cx, cy, d0..dn` (distortion in camera_info
//! order).

use serde::{Deserialize, Serialize};

use crate::camera::{CameraModel, Distortion, DistortionModel, Intrinsics};

/// Intrinsic parameters held at their initial values during calibration (OpenCV's
/// `CALIB_FIX_*` flags). Initial values come from the intrinsic guess when one is given,
/// otherwise from the closed-form initialization (distortion zero, square pixels).
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct FixedParameters {
    /// Hold `fx` and `fy`.
    pub focal_length: bool,
    /// Hold the ratio `fx / fy` (1 without a guess); `fy` stays free.
    pub aspect_ratio: bool,
    /// Hold `cx` and `cy`.
    pub principal_point: bool,
    /// Set the tangential coefficients `p1`, `p2` to zero and hold them (pinhole models;
    /// the equidistant model has none).
    pub zero_tangential: bool,
    /// Indices, in camera_info order, of distortion coefficients held at their initial
    /// values: e.g. `[4]` holds plumb_bob's `k3`, `[5, 6, 7]` rational_polynomial's
    /// `k4..k6`, `[2, 3]` equidistant's `k3`, `k4`.
    pub distortion: Vec<usize>,
}

/// Number of full intrinsic parameters before the distortion coefficients.
pub(crate) const PINHOLE_PARAMETERS: usize = 4;

/// Indices of the tangential coefficients `p1`, `p2` in camera_info order, for the
/// models that have them.
pub(crate) fn tangential_indices(model: DistortionModel) -> &'static [usize] {
    match model {
        DistortionModel::PlumbBob | DistortionModel::RationalPolynomial => &[2, 3],
        DistortionModel::Equidistant => &[],
    }
}

/// Number of distortion coefficients of a model.
pub(crate) fn coefficient_count(model: DistortionModel) -> usize {
    match model {
        DistortionModel::PlumbBob => 5,
        DistortionModel::RationalPolynomial => 8,
        DistortionModel::Equidistant => 4,
    }
}

/// The free parameters: each is a list of `(full index, coefficient)`, so that a step
/// `d` on the free parameters moves full parameter `i` by `sum coefficient * d`.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Parameterization {
    free: Vec<Vec<(usize, f64)>>,
}

impl Parameterization {
    /// The free parameters of a camera with the given model and fixed parameters;
    /// `aspect_ratio` is the `fx / fy` held by [`FixedParameters::aspect_ratio`].
    pub(crate) fn new(model: DistortionModel, fixed: &FixedParameters, aspect_ratio: f64) -> Self {
        let mut free = Vec::new();
        if !fixed.focal_length {
            if fixed.aspect_ratio {
                free.push(vec![(0, aspect_ratio), (1, 1.0)]);
            } else {
                free.push(vec![(0, 1.0)]);
                free.push(vec![(1, 1.0)]);
            }
        }
        if !fixed.principal_point {
            free.push(vec![(2, 1.0)]);
            free.push(vec![(3, 1.0)]);
        }
        let tangential = tangential_indices(model);
        for k in 0..coefficient_count(model) {
            let held =
                fixed.distortion.contains(&k) || (fixed.zero_tangential && tangential.contains(&k));
            if !held {
                free.push(vec![(PINHOLE_PARAMETERS + k, 1.0)]);
            }
        }
        Self { free }
    }

    /// A parameterization with no free parameters.
    pub(crate) fn none() -> Self {
        Self { free: Vec::new() }
    }

    /// Number of free parameters.
    pub(crate) fn len(&self) -> usize {
        self.free.len()
    }

    /// Writes the 2 x free Jacobian, row-major, into `out` from the full Jacobian's
    /// rows (`full_row(r)[i]` is the derivative of pixel coordinate `r` by full
    /// parameter `i`).
    pub(crate) fn free_jacobian(&self, full: &[[f64; 12]; 2], out: &mut [f64]) {
        let n = self.free.len();
        for (c, column) in self.free.iter().enumerate() {
            for r in 0..2 {
                out[r * n + c] = column.iter().map(|&(i, k)| full[r][i] * k).sum();
            }
        }
    }

    /// The camera moved by the free-parameter step `d`.
    pub(crate) fn apply(&self, camera: &CameraModel, d: &[f64]) -> CameraModel {
        let mut full = full_parameters(camera);
        for (column, step) in self.free.iter().zip(d) {
            for &(i, k) in column {
                full[i] += k * step;
            }
        }
        camera_from_full(camera, &full)
    }

    /// Standard deviations of the full parameters (`full_len` of them) from those of
    /// the free ones; held parameters get zero.
    pub(crate) fn full_std_devs(&self, free_std: &[f64], full_len: usize) -> Vec<f64> {
        let mut full = vec![0.0; full_len];
        for (column, std) in self.free.iter().zip(free_std) {
            for &(i, k) in column {
                full[i] = k.abs() * std;
            }
        }
        full
    }
}

/// `fx, fy, cx, cy` then the distortion coefficients.
pub(crate) fn full_parameters(camera: &CameraModel) -> Vec<f64> {
    let i = &camera.intrinsics;
    let mut full = vec![i.fx, i.fy, i.cx, i.cy];
    full.extend_from_slice(camera.distortion.coeffs());
    full
}

fn camera_from_full(camera: &CameraModel, full: &[f64]) -> CameraModel {
    let model = camera.distortion.model();
    CameraModel {
        width: camera.width,
        height: camera.height,
        intrinsics: Intrinsics {
            fx: full[0],
            fy: full[1],
            cx: full[2],
            cy: full[3],
        },
        distortion: Distortion::from_coeffs(model, &full[PINHOLE_PARAMETERS..])
            .unwrap_or_else(|| camera.distortion.clone()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn camera() -> CameraModel {
        CameraModel {
            width: 640,
            height: 480,
            intrinsics: Intrinsics {
                fx: 500.0,
                fy: 400.0,
                cx: 320.0,
                cy: 240.0,
            },
            distortion: Distortion::PlumbBob {
                coeffs: [0.1, 0.0, 0.0, 0.0, 0.0],
            },
        }
    }

    #[test]
    fn all_free_has_every_parameter() {
        let p = Parameterization::new(DistortionModel::PlumbBob, &FixedParameters::default(), 1.0);
        assert_eq!(p.len(), 9);
    }

    #[test]
    fn fixed_aspect_ratio_moves_both_focal_lengths() {
        let fixed = FixedParameters {
            aspect_ratio: true,
            principal_point: true,
            zero_tangential: true,
            distortion: vec![4],
            ..FixedParameters::default()
        };
        let p = Parameterization::new(DistortionModel::PlumbBob, &fixed, 1.25);
        assert_eq!(p.len(), 3);
        let moved = p.apply(&camera(), &[4.0, 0.01, 0.02]);
        assert_eq!(moved.intrinsics.fx, 505.0);
        assert_eq!(moved.intrinsics.fy, 404.0);
        assert_eq!(moved.intrinsics.cx, 320.0);
        assert_eq!(moved.distortion.coeffs(), &[0.11, 0.02, 0.0, 0.0, 0.0]);
        let mut full = [[0.0; 12]; 2];
        full[0][0] = 2.0;
        full[1][1] = 3.0;
        let mut out = [0.0; 6];
        p.free_jacobian(&full, &mut out);
        assert_eq!(out[0], 2.5);
        assert_eq!(out[3], 3.0);
    }
}
