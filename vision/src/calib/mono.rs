//! Mono calibration: closed-form start, Levenberg-Marquardt on the reprojection error,
//! rejection of views that do not fit, and the uncertainty of the intrinsics.

use nalgebra::{DMatrix, Isometry3, Point2};
use serde::{Deserialize, Serialize};

use super::bundle::{self, Termination};
use super::init::{fisheye_intrinsics, initial_pose, pinhole_intrinsics, tilt};
use super::invertibility::invertible_over_image;
use super::parameters::{FixedParameters, Parameterization, coefficient_count, tangential_indices};
use super::rejection::{RejectedView, RejectionOptions, RejectionReason, worst_view};
use super::reprojection::{MonoProblem, MonoState, squared_errors};
use super::{CalibError, View};
use crate::camera::{CameraModel, Distortion, DistortionModel};
use crate::geometry::homography_dlt;

/// Views below which the intrinsics are not determined.
pub const MIN_VIEWS: usize = 3;

/// Indices of rational_polynomial's denominator coefficients `k4, k5, k6` in
/// camera_info order.
const RATIONAL_DENOMINATOR: [usize; 3] = [5, 6, 7];

/// A rational_polynomial fit that stays invertible beyond the image corners, for when
/// the free fit did not. Numerator and denominator can grow together along a nearly
/// flat valley of the cost, where the lens fits the corners as well but folds back, or
/// has a pole, before the image border. So the lens is fitted again from `solved`'s
/// intrinsics and poses: first with the denominator held at its initial value
/// (`initial_distortion`, zero without a guess: plumb_bob's shape), then with every
/// coefficient free but only through lenses that stay invertible. Returns the state
/// and its solution.
fn invertible_rational(
    views: Vec<&View>,
    solved: MonoState,
    initial_distortion: Distortion,
    options: &MonoOptions,
    termination: Termination,
) -> (MonoState, bundle::Solution<MonoState>) {
    let mut held = options.fixed.clone();
    held.distortion.extend(RATIONAL_DENOMINATOR);
    let numerator_only = MonoProblem {
        views,
        parameterization: Parameterization::new(options.model, &held, aspect_ratio(options)),
        keep_invertible: false,
    };
    let start = MonoState {
        camera: CameraModel {
            distortion: initial_distortion,
            ..solved.camera
        },
        camera_from_target: solved.camera_from_target,
    };
    let first = bundle::solve(&numerator_only, start, termination);
    if !invertible_over_image(&first.state.camera) {
        // A lens that folds even in plumb_bob's shape: no invertible fit to move from.
        return (first.state.clone(), first);
    }
    let problem = MonoProblem {
        views: numerator_only.views,
        parameterization: Parameterization::new(
            options.model,
            &options.fixed,
            aspect_ratio(options),
        ),
        keep_invertible: true,
    };
    let solution = bundle::solve(&problem, first.state, termination);
    (solution.state.clone(), solution)
}

/// Views whose largest tilt is below this many degrees cannot fix the focal length.
const MIN_TILT_DEGREES: f64 = 5.0;

/// What to estimate and how.
#[derive(Clone, Debug, PartialEq)]
pub struct MonoOptions {
    /// The distortion model to estimate.
    pub model: DistortionModel,
    /// Parameters held at their initial values.
    pub fixed: FixedParameters,
    /// A starting camera (OpenCV's `CALIB_USE_INTRINSIC_GUESS`), whose distortion model
    /// must be `model`; without one the intrinsics start from a closed form.
    pub guess: Option<CameraModel>,
    /// Rejection of views that do not fit; `None` keeps every view.
    pub rejection: Option<RejectionOptions>,
    /// Maximum number of Levenberg-Marquardt iterations per solve.
    pub max_iterations: usize,
}

impl MonoOptions {
    /// All parameters of `model` free, no guess, default rejection.
    pub fn new(model: DistortionModel) -> Self {
        Self {
            model,
            fixed: FixedParameters::default(),
            guess: None,
            rejection: Some(RejectionOptions::default()),
            max_iterations: 100,
        }
    }
}

/// How one view fits the calibration.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ViewFit {
    /// Index of the view in the input.
    pub index: usize,
    /// Pose of the target in the camera frame.
    pub camera_from_target: Isometry3<f64>,
    /// Root mean square reprojection error over the view's corners, pixels.
    pub rms: f64,
    /// Largest corner reprojection error, pixels.
    pub max_error: f64,
}

/// Standard deviations of the intrinsics, as OpenCV's `calibrateCameraExtended`: the
/// diagonal of the inverse normal matrix scaled by the residual variance
/// `sum(r^2) / (2 * corners - free parameters)`. Held parameters have zero.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct IntrinsicStdDev {
    /// Of `fx`, pixels.
    pub fx: f64,
    /// Of `fy`, pixels.
    pub fy: f64,
    /// Of `cx`, pixels.
    pub cx: f64,
    /// Of `cy`, pixels.
    pub cy: f64,
    /// Of each distortion coefficient, camera_info order.
    pub distortion: Vec<f64>,
}

/// A mono calibration.
#[derive(Clone, Debug, PartialEq)]
pub struct MonoCalibration {
    /// The calibrated camera.
    pub camera: CameraModel,
    /// Root mean square reprojection error over every corner of the views used, pixels
    /// (OpenCV's `calibrateCamera` return value).
    pub rms: f64,
    /// The views used, in input order.
    pub views: Vec<ViewFit>,
    /// The views left out, with the reason.
    pub rejected: Vec<RejectedView>,
    /// Uncertainty of the intrinsics; `None` when the normal matrix is singular.
    pub std_dev: Option<IntrinsicStdDev>,
}

/// Calibrates one camera from views of a planar target (points at `z = 0` in the
/// target frame) with their detected pixels (pixel centres at integer coordinates) in
/// images of `width` x `height`.
pub fn calibrate_mono(
    views: &[View],
    width: u32,
    height: u32,
    options: &MonoOptions,
) -> Result<MonoCalibration, CalibError> {
    if width == 0 || height == 0 {
        return Err(CalibError::EmptyImage { width, height });
    }
    for (i, view) in views.iter().enumerate() {
        view.validate(i)?;
    }
    let model = options.model;
    let count = coefficient_count(model);
    if let Some(&index) = options.fixed.distortion.iter().find(|&&i| i >= count) {
        return Err(CalibError::InvalidFixedCoefficient {
            index,
            model: model.ros_name(),
            count,
        });
    }
    let needed = if options.fixed.focal_length && options.fixed.principal_point {
        1
    } else {
        MIN_VIEWS
    };
    let mut rejected = Vec::new();
    let camera = initial_camera(views, width, height, options, &mut rejected)?;
    let mut used = Vec::new();
    let mut poses = Vec::new();
    for (i, view) in views.iter().enumerate() {
        if rejected.iter().any(|r: &RejectedView| r.index == i) {
            continue;
        }
        match initial_pose(&camera, view) {
            Some(pose) => {
                used.push(i);
                poses.push(pose);
            }
            None => rejected.push(RejectedView {
                index: i,
                reason: RejectionReason::NoPose,
            }),
        }
    }
    if used.len() < needed {
        return Err(CalibError::TooFewViews {
            usable: used.len(),
            needed,
            rejected: rejected.len(),
        });
    }
    let termination = Termination {
        max_iterations: options.max_iterations,
        ..Termination::default()
    };
    // Poses first, with the intrinsics held, so the joint solve starts near a minimum.
    let state = MonoState {
        camera,
        camera_from_target: poses,
    };
    let pose_problem = MonoProblem {
        views: used.iter().map(|&i| &views[i]).collect(),
        parameterization: Parameterization::none(),
        keep_invertible: false,
    };
    let initial_distortion = state.camera.distortion.clone();
    let mut state = bundle::solve(
        &pose_problem,
        state,
        Termination {
            max_iterations: 20,
            ..termination
        },
    )
    .state;
    let parameterization = Parameterization::new(model, &options.fixed, aspect_ratio(options));
    let mut solution;
    let rejected_before_solve = rejected.len();
    loop {
        let problem = MonoProblem {
            views: used.iter().map(|&i| &views[i]).collect(),
            parameterization: parameterization.clone(),
            keep_invertible: false,
        };
        solution = bundle::solve(&problem, state, termination);
        state = solution.state.clone();
        // Distortion left out of the closed-form start fakes perspective, so the
        // views' tilts are judged on the solved poses.
        if !options.fixed.focal_length && rejected_before_solve == rejected.len() {
            check_tilts(&state.camera_from_target)?;
        }
        let Some(rejection) = &options.rejection else {
            break;
        };
        let limit = (rejection.max_rejected_fraction * views.len() as f64).floor() as usize;
        if rejected.len() >= limit || used.len() <= needed {
            break;
        }
        let errors: Vec<Vec<f64>> = used
            .iter()
            .zip(&state.camera_from_target)
            .map(|(&i, pose)| corner_errors(&state.camera, pose, &views[i]))
            .collect();
        let Some((position, reason)) = worst_view(&errors, rejection) else {
            break;
        };
        rejected.push(RejectedView {
            index: used.remove(position),
            reason,
        });
        state.camera_from_target.remove(position);
    }
    if model == DistortionModel::RationalPolynomial && !invertible_over_image(&state.camera) {
        (state, solution) = invertible_rational(
            used.iter().map(|&i| &views[i]).collect(),
            state,
            initial_distortion,
            options,
            termination,
        );
    }
    if !parameters_finite(&state) {
        return Err(CalibError::Diverged);
    }
    rejected.sort_by_key(|r| r.index);
    let corners: usize = used.iter().map(|&i| views[i].pixels.len()).sum();
    let total: f64 = solution.view_costs.iter().sum();
    let free = parameterization.len() + 6 * used.len();
    let sigma2 = total / (2 * corners).saturating_sub(free).max(1) as f64;
    let std_dev = solution
        .shared_inverse
        .as_ref()
        .map(|inverse| std_devs(&parameterization, inverse, sigma2, count));
    let fits = used
        .iter()
        .zip(&state.camera_from_target)
        .map(|(&index, pose)| {
            let errors = corner_errors(&state.camera, pose, &views[index]);
            ViewFit {
                index,
                camera_from_target: *pose,
                rms: (errors.iter().map(|e| e * e).sum::<f64>() / errors.len() as f64).sqrt(),
                max_error: errors.iter().copied().fold(0.0, f64::max),
            }
        })
        .collect();
    Ok(MonoCalibration {
        rms: (total / corners as f64).sqrt(),
        camera: state.camera,
        views: fits,
        rejected,
        std_dev,
    })
}

/// Equidistant intrinsics to start from: `cv::fisheye::calibrate`'s start (a 180-degree
/// field of view across the larger side) can be far from a narrower lens, where the
/// homographies of its undistorted corners put targets behind the camera; so focal
/// lengths from half to four times that one are tried, each with every view's pose
/// refined, and the one that fits best is kept.
fn fisheye_focal_search(views: &[View], width: u32, height: u32) -> crate::camera::Intrinsics {
    let start = fisheye_intrinsics(width, height);
    let mut best = (f64::INFINITY, start);
    for step in -2..=4 {
        let factor = 2f64.powf(f64::from(step) * 0.5);
        let intrinsics = crate::camera::Intrinsics {
            fx: start.fx * factor,
            fy: start.fy * factor,
            ..start
        };
        let camera = CameraModel {
            width,
            height,
            intrinsics,
            distortion: Distortion::Equidistant { coeffs: [0.0; 4] },
        };
        let mut cost = 0.0;
        for view in views {
            let Some(pose) = initial_pose(&camera, view) else {
                continue;
            };
            let problem = MonoProblem {
                views: vec![view],
                parameterization: Parameterization::none(),
                keep_invertible: false,
            };
            let state = MonoState {
                camera: camera.clone(),
                camera_from_target: vec![pose],
            };
            let termination = Termination {
                max_iterations: 10,
                ..Termination::default()
            };
            let solved = bundle::solve(&problem, state, termination);
            // A robust total: one unusable view must not decide.
            cost += solved.view_costs[0].min(1e4 * view.pixels.len() as f64);
        }
        if cost < best.0 {
            best = (cost, intrinsics);
        }
    }
    best.1
}

/// Refuses views that are all nearly fronto-parallel: they leave the focal length
/// unobservable.
fn check_tilts(poses: &[Isometry3<f64>]) -> Result<(), CalibError> {
    let max_tilt = poses.iter().map(tilt).fold(0.0, f64::max).to_degrees();
    if max_tilt < MIN_TILT_DEGREES {
        return Err(CalibError::FrontoParallel {
            max_tilt_degrees: max_tilt,
        });
    }
    Ok(())
}

/// Per-corner reprojection errors of a view in pixels (infinite behind the camera).
pub(crate) fn corner_errors(camera: &CameraModel, pose: &Isometry3<f64>, view: &View) -> Vec<f64> {
    squared_errors(camera, pose, view)
        .into_iter()
        .map(|e| e.map_or(f64::INFINITY, f64::sqrt))
        .collect()
}

fn aspect_ratio(options: &MonoOptions) -> f64 {
    options
        .guess
        .as_ref()
        .map_or(1.0, |g| g.intrinsics.fx / g.intrinsics.fy)
}

/// The starting camera: the guess, or the closed form of the model; views whose
/// corners have no homography are rejected.
fn initial_camera(
    views: &[View],
    width: u32,
    height: u32,
    options: &MonoOptions,
    rejected: &mut Vec<RejectedView>,
) -> Result<CameraModel, CalibError> {
    let model = options.model;
    let mut camera = if let Some(guess) = &options.guess {
        if guess.distortion.model() != model || guess.width != width || guess.height != height {
            return Err(CalibError::GuessMismatch {
                guess: format!(
                    "{} at {}x{}",
                    guess.distortion.model().ros_name(),
                    guess.width,
                    guess.height
                ),
                requested: format!("{} at {width}x{height}", model.ros_name()),
            });
        }
        guess.clone()
    } else {
        let distortion = Distortion::from_coeffs(model, &[]).unwrap_or_else(Distortion::none);
        let intrinsics = match model {
            DistortionModel::Equidistant => fisheye_focal_search(views, width, height),
            DistortionModel::PlumbBob | DistortionModel::RationalPolynomial => {
                let mut homographies = Vec::new();
                for (i, view) in views.iter().enumerate() {
                    let plane: Vec<Point2<f64>> =
                        view.points_in_target.iter().map(|p| p.xy()).collect();
                    match homography_dlt(&plane, &view.pixels) {
                        Ok(h) => homographies.push(h),
                        Err(_) => rejected.push(RejectedView {
                            index: i,
                            reason: RejectionReason::NoPose,
                        }),
                    }
                }
                let needed = if options.fixed.focal_length {
                    1
                } else {
                    MIN_VIEWS
                };
                if homographies.len() < needed {
                    return Err(CalibError::TooFewViews {
                        usable: homographies.len(),
                        needed,
                        rejected: rejected.len(),
                    });
                }
                let ratio = options.fixed.aspect_ratio.then_some(1.0);
                pinhole_intrinsics(&homographies, width, height, ratio).ok_or(
                    CalibError::FrontoParallel {
                        max_tilt_degrees: 0.0,
                    },
                )?
            }
        };
        CameraModel {
            width,
            height,
            intrinsics,
            distortion,
        }
    };
    if options.fixed.zero_tangential {
        let mut coeffs = camera.distortion.coeffs().to_vec();
        for &i in tangential_indices(model) {
            coeffs[i] = 0.0;
        }
        camera.distortion = Distortion::from_coeffs(model, &coeffs).unwrap_or(camera.distortion);
    }
    Ok(camera)
}

fn parameters_finite(state: &MonoState) -> bool {
    let k = &state.camera.intrinsics;
    [k.fx, k.fy, k.cx, k.cy]
        .iter()
        .chain(state.camera.distortion.coeffs())
        .all(|x| x.is_finite())
        && state
            .camera_from_target
            .iter()
            .all(|p| p.translation.vector.iter().all(|x| x.is_finite()))
}

fn std_devs(
    parameterization: &Parameterization,
    inverse: &DMatrix<f64>,
    sigma2: f64,
    count: usize,
) -> IntrinsicStdDev {
    let free: Vec<f64> = (0..parameterization.len())
        .map(|c| (inverse[(c, c)] * sigma2).max(0.0).sqrt())
        .collect();
    let full = parameterization.full_std_devs(&free, 4 + count);
    IntrinsicStdDev {
        fx: full[0],
        fy: full[1],
        cx: full[2],
        cy: full[3],
        distortion: full[4..].to_vec(),
    }
}
