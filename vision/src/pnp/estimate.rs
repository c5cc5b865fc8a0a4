//! The pose of a target from its points' pixels, under one rule: a pose is returned
//! only when it is finite, puts every point in front of the camera, explains the
//! pixels within the bound asked for and is not one of two equally good poses.

use std::borrow::Cow;

use nalgebra::{Isometry3, Matrix3, Matrix6, Vector3};

use super::epnp::epnp;
use super::ippe::ippe;
use super::ransac::{P3p, RansacOptions, ransac};
use super::refine::{Refined, refine, refine_excess};
use super::sqpnp::sqpnp;
use super::{Correspondences, PnpError};
use crate::camera::CameraModel;

/// How [`estimate_pose`] judges a pose.
#[derive(Clone, Debug, PartialEq)]
pub struct PoseOptions {
    /// Poses whose RMS reprojection error is above this are refused, pixels.
    pub max_rms_px: f64,
    /// For a planar target, how many standard deviations of pixel noise a distinct
    /// second pose must be worse than the best (`sqrt((SSE2 - SSE1) / sigma^2)`, the
    /// squared errors summed over the points): below it the pose is refused as
    /// ambiguous.
    pub min_ambiguity_significance: f64,
    /// The least standard deviation of pixel noise assumed, pixels: the corner
    /// detector's noise on a sharp image. The residuals' own spread is used when
    /// larger. It scales the covariance and the ambiguity test; exact pixels would
    /// otherwise claim a pose known perfectly.
    pub pixel_noise_px: f64,
    /// RANSAC (around P3P) to drop outliers before solving; `None` trusts every
    /// correspondence, as with a board detector's corners.
    pub outlier_rejection: Option<RansacOptions>,
}

impl Default for PoseOptions {
    fn default() -> Self {
        Self {
            max_rms_px: 2.0,
            min_ambiguity_significance: 3.0,
            pixel_noise_px: 0.1,
            outlier_rejection: None,
        }
    }
}

/// Which solver gave the starting point of the returned pose.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Solver {
    /// [`super::sqpnp::sqpnp`].
    Sqpnp,
    /// [`super::ippe::ippe`].
    Ippe,
    /// [`super::epnp::epnp`].
    Epnp,
}

/// The second pose of a planar target, and how much worse it explains the pixels.
#[derive(Clone, Debug, PartialEq)]
pub struct PlanarAmbiguity {
    /// Second-best RMS error over the best's (larger is less ambiguous).
    pub ratio: f64,
    /// How many standard deviations of pixel noise the second pose is worse:
    /// `sqrt((SSE2 - SSE1) / sigma^2)`.
    pub significance: f64,
    /// The second pose, refined until its squared error's excess over the best's is
    /// known to a thousandth.
    pub camera_from_target: Isometry3<f64>,
    /// Its RMS reprojection error, pixels.
    pub rms_px: f64,
    /// Rotation between the two poses, radians.
    pub angle: f64,
}

/// A pose and how well it is known.
#[derive(Clone, Debug, PartialEq)]
pub struct PoseEstimate {
    /// The pose, mapping target points to the camera frame.
    pub camera_from_target: Isometry3<f64>,
    /// Reprojection error of each correspondence used, pixels.
    pub errors_px: Vec<f64>,
    /// Root mean square of `errors_px`.
    pub rms_px: f64,
    /// Row-major 6x6 covariance of the pose, in ROS's order `(x, y, z, rotation about
    /// X, rotation about Y, rotation about Z)`: the target origin's position and a
    /// small rotation about the camera frame's fixed axes (metres, radians).
    pub covariance: Matrix6<f64>,
    /// The pixel noise the covariance assumes, pixels.
    pub pixel_noise_px: f64,
    /// For a planar target with a distinct second pose: that pose and its error.
    pub ambiguity: Option<PlanarAmbiguity>,
    /// Indices of the correspondences used (all, unless outliers were rejected).
    pub inliers: Vec<usize>,
    /// The solver whose pose refinement started from.
    pub solver: Solver,
}

/// Estimates `camera_from_target` from 4 or more correspondences seen by `camera`.
///
/// Planar targets start from both IPPE poses (and SQPnP's minima when those refine to one
/// minimum or explain the pixels no better than `options.max_rms_px`), others from SQPnP's minima (EPnP when
/// those find nothing); every distinct start is refined on the pixel error through the
/// full camera model and the best is kept. The pose is refused, with the reason, when
/// the points are degenerate (coincident or on one line), the pose is not determined, points
/// would be behind the camera, the error is above `options.max_rms_px`, or a distinct
/// second pose of a planar target explains the pixels within
/// `options.min_ambiguity_significance` standard deviations of noise as well.
pub fn estimate_pose(
    camera: &CameraModel,
    correspondences: &Correspondences,
    options: &PoseOptions,
) -> Result<PoseEstimate, PnpError> {
    if correspondences.len() < 4 {
        return Err(PnpError::TooFewPoints {
            needed: 4,
            got: correspondences.len(),
        });
    }
    let (used, inliers) = match &options.outlier_rejection {
        Some(ransac_options) => {
            let found = ransac(camera, correspondences, &P3p, ransac_options)?;
            (
                Cow::Owned(subset(correspondences, &found.inliers)),
                found.inliers,
            )
        }
        None => (
            Cow::Borrowed(correspondences),
            (0..correspondences.len()).collect(),
        ),
    };
    let shape = Shape::of(&used.target_points)?;
    // A planar target starts from both IPPE poses, and SQPnP is asked as well when they
    // refine to one minimum (a plane has two, and the other may lie elsewhere) or
    // explain the pixels no better than the bound allows; any other target starts from
    // SQPnP's minima, and EPnP is the last resort.
    let mut search = StartSearch::new(options);
    let ippe_starts = match shape {
        Shape::Planar => ippe_starts(&used),
        Shape::General => Vec::new(),
    };
    if ippe_starts.is_empty() {
        search.refine_all(camera, &used, sqpnp_starts(&used));
    } else {
        search.refine_all(camera, &used, ippe_starts);
        if search.minima() < 2
            || search
                .refined
                .first()
                .is_none_or(|c| c.refined.rms_px > options.max_rms_px)
        {
            search.refine_all(camera, &used, sqpnp_starts(&used));
        }
    }
    if search.refined.is_empty()
        && let Ok(pose) = epnp(&used.target_points, &used.normalized)
    {
        search.refine_all(camera, &used, vec![(pose, Solver::Epnp)]);
    }
    let (best, solver) = search.best(camera, &used)?;
    let refined = &search.refined;
    let behind = used
        .target_points
        .iter()
        .filter(|p| (best.camera_from_target * *p).z <= 0.0)
        .count();
    if behind > 0 {
        return Err(PnpError::BehindCamera {
            count: behind,
            total: used.len(),
        });
    }
    if best.rms_px > options.max_rms_px {
        return Err(PnpError::ReprojectionError {
            rms_px: best.rms_px,
            bound_px: options.max_rms_px,
        });
    }
    let pixel_noise_px = measured_noise(&best)
        .max(options.pixel_noise_px)
        .max(f64::MIN_POSITIVE);
    let covariance = covariance(&best, pixel_noise_px)?;
    let ambiguity = match shape {
        Shape::Planar => second_pose(&best, refined, &covariance, pixel_noise_px),
        Shape::General => None,
    };
    if let Some(a) = &ambiguity
        && a.significance < options.min_ambiguity_significance
    {
        return Err(PnpError::Ambiguous {
            significance: a.significance,
            min_significance: options.min_ambiguity_significance,
            best_rms_px: best.rms_px,
            second_rms_px: a.rms_px,
            angle_deg: a.angle.to_degrees(),
        });
    }
    Ok(PoseEstimate {
        camera_from_target: best.camera_from_target,
        errors_px: best.residuals.iter().map(|r| r.norm()).collect(),
        rms_px: best.rms_px,
        covariance,
        pixel_noise_px,
        ambiguity,
        inliers,
        solver,
    })
}

/// Whether the target points span a plane or space.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Shape {
    Planar,
    General,
}

impl Shape {
    /// The shape of a point set from the singular values of its centred coordinates;
    /// coincident or collinear points are refused.
    fn of(points: &[nalgebra::Point3<f64>]) -> Result<Self, PnpError> {
        let n = points.len() as f64;
        let centroid = points
            .iter()
            .fold(Vector3::zeros(), |acc, p| acc + p.coords)
            / n;
        let scatter = points.iter().fold(Matrix3::zeros(), |acc, p| {
            let d = p.coords - centroid;
            acc + d * d.transpose()
        });
        let mut spread: Vec<f64> = scatter
            .symmetric_eigenvalues()
            .iter()
            .map(|v| v.max(0.0).sqrt())
            .collect();
        spread.sort_by(|a, b| b.total_cmp(a));
        let [largest, middle, smallest] = [spread[0], spread[1], spread[2]];
        if largest <= f64::EPSILON * centroid.norm().max(1.0) {
            return Err(PnpError::Degenerate("all target points coincide".into()));
        }
        if middle <= 1e-9 * largest {
            return Err(PnpError::Degenerate(
                "all target points lie on one line".into(),
            ));
        }
        Ok(if smallest <= 1e-9 * largest {
            Self::Planar
        } else {
            Self::General
        })
    }
}

/// Both IPPE poses of a planar target, best first; none when IPPE fails.
fn ippe_starts(c: &Correspondences) -> Vec<(Isometry3<f64>, Solver)> {
    let Ok(solutions) = ippe(&c.target_points, &c.normalized) else {
        return Vec::new();
    };
    let mut starts = vec![(solutions.best, Solver::Ippe)];
    if solutions.second_rms.is_finite() {
        starts.push((solutions.second, Solver::Ippe));
    }
    starts
}

/// SQPnP's minima, best first.
fn sqpnp_starts(c: &Correspondences) -> Vec<(Isometry3<f64>, Solver)> {
    sqpnp(&c.target_points, &c.normalized)
        .map(|minima| {
            minima
                .into_iter()
                .map(|m| (m.camera_from_target, Solver::Sqpnp))
                .collect()
        })
        .unwrap_or_default()
}

/// A start refined.
#[derive(Clone)]
struct Candidate {
    refined: Refined,
    solver: Solver,
    /// Whether refinement reached the minimum in full, rather than stopping once the
    /// pose was known to be worse than the best (see [`refine_excess`]).
    converged: bool,
}

/// The starts tried and what they refined to, best first.
struct StartSearch {
    tried: Vec<Isometry3<f64>>,
    refined: Vec<Candidate>,
    last_error: Option<PnpError>,
    /// Standard deviations of pixel noise by which a pose must be worse than the best
    /// before its refinement may stop short of its minimum.
    clearly_worse: f64,
    pixel_noise_px: f64,
}

/// Rotation within which two refined poses are one minimum reached twice, radians
/// (0.06 degrees): refinement in a flat valley may stop a few millionths of a radian
/// short; distinct minima are degrees apart.
const SAME_MINIMUM_RAD: f64 = 1e-3;

/// How many times the ambiguity test's significance a pose must be worse than the best
/// before its refinement may stop short of its minimum: far from the line the test
/// draws, where a thousandth of the excess cannot move a pose across it.
const CLEARLY_WORSE: f64 = 10.0;

impl StartSearch {
    fn new(options: &PoseOptions) -> Self {
        Self {
            tried: Vec::new(),
            refined: Vec::new(),
            last_error: None,
            clearly_worse: CLEARLY_WORSE * options.min_ambiguity_significance.max(1.0),
            pixel_noise_px: options.pixel_noise_px,
        }
    }

    /// Refines each start that does not nearly repeat one tried before (it would refine
    /// to the same minimum). The first pose is refined in full; later ones only until
    /// they are known to be worse than the best so far, or in full when they are not.
    fn refine_all(
        &mut self,
        camera: &CameraModel,
        c: &Correspondences,
        starts: Vec<(Isometry3<f64>, Solver)>,
    ) {
        for (start, solver) in starts {
            if self.tried.iter().any(|kept| same_start(kept, &start)) {
                continue;
            }
            self.tried.push(start);
            let result = match self.refined.first() {
                Some(best) => {
                    let noise = measured_noise(&best.refined).max(self.pixel_noise_px);
                    let margin = (self.clearly_worse * noise).powi(2);
                    refine_excess(camera, c, &start, squared_error(&best.refined), margin)
                }
                None => refine(camera, c, &start).map(|r| (r, true)),
            };
            match result {
                Ok((refined, converged)) if is_finite(&refined) => {
                    let candidate = Candidate {
                        refined,
                        solver,
                        converged,
                    };
                    let at = self
                        .refined
                        .partition_point(|kept| kept.refined.rms_px <= candidate.refined.rms_px);
                    self.refined.insert(at, candidate);
                }
                Ok(_) => self.last_error = Some(PnpError::NoSolution("refinement diverged".into())),
                Err(e) => self.last_error = Some(e),
            }
        }
    }

    /// How many distinct poses the starts refined to.
    fn minima(&self) -> usize {
        let mut distinct: Vec<&Isometry3<f64>> = Vec::new();
        for c in &self.refined {
            let pose = &c.refined.camera_from_target;
            if !distinct
                .iter()
                .any(|kept| kept.rotation.angle_to(&pose.rotation) <= SAME_MINIMUM_RAD)
            {
                distinct.push(pose);
            }
        }
        distinct.len()
    }

    /// The best pose, refined in full, and the solver it started from.
    fn best(
        &mut self,
        camera: &CameraModel,
        c: &Correspondences,
    ) -> Result<(Refined, Solver), PnpError> {
        let Some(best) = self.refined.first_mut() else {
            return Err(self.last_error.take().unwrap_or(PnpError::NoSolution(
                "no solver found a pose with every point in front of the camera".into(),
            )));
        };
        if !best.converged {
            best.refined = refine(camera, c, &best.refined.camera_from_target)?;
            best.converged = true;
        }
        Ok((best.refined.clone(), best.solver))
    }
}

/// The sum of a refined pose's squared pixel errors.
fn squared_error(r: &Refined) -> f64 {
    r.residuals.iter().map(|v| v.norm_squared()).sum()
}

/// Whether two starting poses are so close (a hundredth of a degree, a ten-thousandth
/// of the distance) that they refine to the same minimum.
fn same_start(a: &Isometry3<f64>, b: &Isometry3<f64>) -> bool {
    let distance = a.translation.vector.norm().max(f64::MIN_POSITIVE);
    a.rotation.angle_to(&b.rotation) < 1e-2_f64.to_radians()
        && (a.translation.vector - b.translation.vector).norm() < 1e-4 * distance
}

fn is_finite(r: &Refined) -> bool {
    r.rms_px.is_finite()
        && r.camera_from_target
            .translation
            .vector
            .iter()
            .all(|v| v.is_finite())
        && r.camera_from_target
            .rotation
            .coords
            .iter()
            .all(|v| v.is_finite())
}

/// The correspondences at `indices`.
fn subset(c: &Correspondences, indices: &[usize]) -> Correspondences {
    let pick = |i: &usize| *i < c.len();
    Correspondences {
        target_points: indices
            .iter()
            .filter(|i| pick(i))
            .map(|&i| c.target_points[i])
            .collect(),
        pixels: indices
            .iter()
            .filter(|i| pick(i))
            .map(|&i| c.pixels[i])
            .collect(),
        normalized: indices
            .iter()
            .filter(|i| pick(i))
            .map(|&i| c.normalized[i])
            .collect(),
    }
}

/// The pixel noise the residuals show: their variance with the pose's six degrees of
/// freedom taken out.
fn measured_noise(r: &Refined) -> f64 {
    let dof = (2 * r.residuals.len()).saturating_sub(6).max(1);
    let sum: f64 = r.residuals.iter().map(|v| v.norm_squared()).sum();
    (sum / dof as f64).sqrt()
}

/// The pose covariance in ROS's order from the refinement's information matrix.
///
/// Refinement perturbs the pose on the left, `X -> exp(omega) X + tau` in the camera
/// frame; ROS's pose covariance is of the position `t` and a rotation about fixed
/// axes, so `d_rotation = omega` and `d_position = omega x t + tau`.
fn covariance(r: &Refined, pixel_noise_px: f64) -> Result<Matrix6<f64>, PnpError> {
    let inverse = r
        .information
        .try_inverse()
        .filter(|m| m.iter().all(|v| v.is_finite()));
    let Some(left) = inverse.map(|m| m * pixel_noise_px.powi(2)) else {
        return Err(PnpError::Degenerate(
            "the points do not determine all six degrees of freedom of the pose".into(),
        ));
    };
    let t = r.camera_from_target.translation.vector;
    let mut ros_from_left = Matrix6::zeros();
    ros_from_left
        .fixed_view_mut::<3, 3>(0, 0)
        .copy_from(&(-t.cross_matrix()));
    ros_from_left
        .fixed_view_mut::<3, 3>(0, 3)
        .copy_from(&Matrix3::identity());
    ros_from_left
        .fixed_view_mut::<3, 3>(3, 0)
        .copy_from(&Matrix3::identity());
    Ok(ros_from_left * left * ros_from_left.transpose())
}

/// The best refined pose that is distinct from `best`: further from it than three
/// standard deviations of its rotation, so not the same pose seen through noise.
fn second_pose(
    best: &Refined,
    refined: &[Candidate],
    covariance: &Matrix6<f64>,
    pixel_noise_px: f64,
) -> Option<PlanarAmbiguity> {
    let n = best.residuals.len() as f64;
    let rotation_sigma = covariance
        .fixed_view::<3, 3>(3, 3)
        .into_owned()
        .symmetric_eigenvalues()
        .max()
        .max(0.0)
        .sqrt();
    let same_pose_within = (3.0 * rotation_sigma).max(1e-6);
    refined
        .iter()
        .map(|Candidate { refined: r, .. }| {
            let angle = best
                .camera_from_target
                .rotation
                .angle_to(&r.camera_from_target.rotation);
            (r, angle)
        })
        .filter(|(_, angle)| *angle > same_pose_within)
        .min_by(|a, b| a.0.rms_px.total_cmp(&b.0.rms_px))
        .map(|(r, angle)| PlanarAmbiguity {
            ratio: if best.rms_px > 0.0 {
                r.rms_px / best.rms_px
            } else {
                f64::INFINITY
            },
            significance: (n * (r.rms_px.powi(2) - best.rms_px.powi(2)))
                .max(0.0)
                .sqrt()
                / pixel_noise_px,
            camera_from_target: r.camera_from_target,
            rms_px: r.rms_px,
            angle,
        })
}
