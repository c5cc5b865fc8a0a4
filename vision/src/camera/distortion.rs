use nalgebra::{Matrix2, Matrix2xX, Vector2};
use serde::{Deserialize, Serialize};

/// The lens distortion models of ROS camera_info (`distortion_model`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum DistortionModel {
    /// Brown-Conrady `plumb_bob`: radial k1, k2, k3 and tangential p1, p2.
    PlumbBob,
    /// `rational_polynomial`: radial k1..k6 (numerator k1..k3, denominator k4..k6) and
    /// tangential p1, p2.
    RationalPolynomial,
    /// Fisheye `equidistant` (Kannala-Brandt, OpenCV's fisheye model): k1..k4 on the
    /// angle from the optical axis.
    Equidistant,
}

impl DistortionModel {
    /// The camera_info name of the model.
    pub fn ros_name(self) -> &'static str {
        match self {
            Self::PlumbBob => "plumb_bob",
            Self::RationalPolynomial => "rational_polynomial",
            Self::Equidistant => "equidistant",
        }
    }

    /// The model a camera_info `distortion_model` names, if known.
    pub fn from_ros_name(name: &str) -> Option<Self> {
        match name {
            "plumb_bob" => Some(Self::PlumbBob),
            "rational_polynomial" => Some(Self::RationalPolynomial),
            "equidistant" => Some(Self::Equidistant),
            _ => None,
        }
    }
}

/// Lens distortion: a model and its coefficients, in camera_info order
/// (plumb_bob: k1 k2 p1 p2 k3; rational_polynomial: k1 k2 p1 p2 k3 k4 k5 k6;
/// equidistant: k1 k2 k3 k4).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub enum Distortion {
    /// Brown-Conrady radial-tangential.
    PlumbBob {
        /// k1, k2, p1, p2, k3.
        coeffs: [f64; 5],
    },
    /// Rational radial with tangential terms.
    RationalPolynomial {
        /// k1, k2, p1, p2, k3, k4, k5, k6.
        coeffs: [f64; 8],
    },
    /// Fisheye equidistant.
    Equidistant {
        /// k1, k2, k3, k4.
        coeffs: [f64; 4],
    },
}

impl Distortion {
    /// No distortion, in the plumb_bob model.
    pub fn none() -> Self {
        Self::PlumbBob { coeffs: [0.0; 5] }
    }

    /// The model of these coefficients.
    pub fn model(&self) -> DistortionModel {
        match self {
            Self::PlumbBob { .. } => DistortionModel::PlumbBob,
            Self::RationalPolynomial { .. } => DistortionModel::RationalPolynomial,
            Self::Equidistant { .. } => DistortionModel::Equidistant,
        }
    }

    /// The coefficients in camera_info order.
    pub fn coeffs(&self) -> &[f64] {
        match self {
            Self::PlumbBob { coeffs } => coeffs,
            Self::RationalPolynomial { coeffs } => coeffs,
            Self::Equidistant { coeffs } => coeffs,
        }
    }

    /// Builds a distortion from a model and camera_info coefficients. Missing trailing
    /// coefficients are zero (ROS writes 5 for plumb_bob, some tools fewer); returns
    /// `None` when more are given than the model has.
    pub fn from_coeffs(model: DistortionModel, d: &[f64]) -> Option<Self> {
        fn padded<const N: usize>(d: &[f64]) -> Option<[f64; N]> {
            if d.len() > N {
                return None;
            }
            let mut out = [0.0; N];
            out[..d.len()].copy_from_slice(d);
            Some(out)
        }
        Some(match model {
            DistortionModel::PlumbBob => Self::PlumbBob { coeffs: padded(d)? },
            DistortionModel::RationalPolynomial => Self::RationalPolynomial { coeffs: padded(d)? },
            DistortionModel::Equidistant => Self::Equidistant { coeffs: padded(d)? },
        })
    }

    /// Maps an undistorted normalized coordinate `(X/Z, Y/Z)` to its distorted
    /// normalized coordinate, exactly as OpenCV's `projectPoints` (pinhole models) and
    /// `fisheye::projectPoints` (equidistant).
    pub fn distort(&self, p: &Vector2<f64>) -> Vector2<f64> {
        let (x, y) = (p.x, p.y);
        let r2 = x * x + y * y;
        match self {
            Self::PlumbBob { coeffs } => {
                let [k1, k2, p1, p2, k3] = *coeffs;
                let radial = 1.0 + r2 * (k1 + r2 * (k2 + r2 * k3));
                tangential(x, y, r2, radial, p1, p2)
            }
            Self::RationalPolynomial { coeffs } => {
                let [k1, k2, p1, p2, k3, k4, k5, k6] = *coeffs;
                let radial = (1.0 + r2 * (k1 + r2 * (k2 + r2 * k3)))
                    / (1.0 + r2 * (k4 + r2 * (k5 + r2 * k6)));
                tangential(x, y, r2, radial, p1, p2)
            }
            Self::Equidistant { coeffs } => {
                let [k1, k2, k3, k4] = *coeffs;
                let r = r2.sqrt();
                if r < 1e-12 {
                    // The limit of theta_d / r as r -> 0 is 1.
                    return *p;
                }
                let theta = r.atan();
                let t2 = theta * theta;
                let theta_d = theta * (1.0 + t2 * (k1 + t2 * (k2 + t2 * (k3 + t2 * k4))));
                p * (theta_d / r)
            }
        }
    }
}

/// A distorted normalized coordinate with its derivatives.
#[derive(Clone, Debug, PartialEq)]
pub struct DistortionJacobians {
    /// The distorted normalized coordinate.
    pub distorted: Vector2<f64>,
    /// Derivative of the distorted coordinate with respect to the undistorted one.
    pub d_distorted_d_undistorted: Matrix2<f64>,
    /// Derivative of the distorted coordinate with respect to the coefficients, one
    /// column per coefficient in camera_info order ([`Distortion::coeffs`]).
    pub d_distorted_d_coeffs: Matrix2xX<f64>,
}

impl Distortion {
    /// [`Distortion::distort`] with its analytic derivatives with respect to the
    /// undistorted coordinate and to the coefficients.
    pub fn distort_with_jacobians(&self, p: &Vector2<f64>) -> DistortionJacobians {
        let (x, y) = (p.x, p.y);
        let r2 = x * x + y * y;
        let d_coeffs = match self {
            Self::PlumbBob { .. } => {
                let (r4, r6) = (r2 * r2, r2 * r2 * r2);
                Matrix2xX::from_column_slice(&[
                    x * r2,
                    y * r2,
                    x * r4,
                    y * r4,
                    2.0 * x * y,
                    r2 + 2.0 * y * y,
                    r2 + 2.0 * x * x,
                    2.0 * x * y,
                    x * r6,
                    y * r6,
                ])
            }
            Self::RationalPolynomial { coeffs } => {
                let [k1, k2, _, _, k3, k4, k5, k6] = *coeffs;
                let (r4, r6) = (r2 * r2, r2 * r2 * r2);
                let num = 1.0 + r2 * (k1 + r2 * (k2 + r2 * k3));
                let den = 1.0 + r2 * (k4 + r2 * (k5 + r2 * k6));
                let rad = num / den;
                let (gx, gy) = (x / den, y / den);
                Matrix2xX::from_column_slice(&[
                    gx * r2,
                    gy * r2,
                    gx * r4,
                    gy * r4,
                    2.0 * x * y,
                    r2 + 2.0 * y * y,
                    r2 + 2.0 * x * x,
                    2.0 * x * y,
                    gx * r6,
                    gy * r6,
                    -gx * rad * r2,
                    -gy * rad * r2,
                    -gx * rad * r4,
                    -gy * rad * r4,
                    -gx * rad * r6,
                    -gy * rad * r6,
                ])
            }
            Self::Equidistant { .. } => {
                let r = r2.sqrt();
                if r < 1e-12 {
                    Matrix2xX::zeros(4)
                } else {
                    let theta = r.atan();
                    let t2 = theta * theta;
                    let (ux, uy) = (x / r, y / r);
                    let t3 = theta * t2;
                    let t5 = t3 * t2;
                    let t7 = t5 * t2;
                    let t9 = t7 * t2;
                    Matrix2xX::from_column_slice(&[
                        ux * t3,
                        uy * t3,
                        ux * t5,
                        uy * t5,
                        ux * t7,
                        uy * t7,
                        ux * t9,
                        uy * t9,
                    ])
                }
            }
        };
        DistortionJacobians {
            distorted: self.distort(p),
            d_distorted_d_undistorted: self.distort_jacobian_point(p),
            d_distorted_d_coeffs: d_coeffs,
        }
    }

    /// The derivative of [`Distortion::distort`] with respect to the undistorted
    /// coordinate.
    pub(crate) fn distort_jacobian_point(&self, p: &Vector2<f64>) -> Matrix2<f64> {
        self.distort_with_point_jacobian(p).1
    }

    /// [`Distortion::distort`] and its derivative with respect to the undistorted
    /// coordinate, sharing the radial terms: what pose refinement and undistortion
    /// evaluate for every point at every iteration.
    #[inline(always)]
    pub(crate) fn distort_with_point_jacobian(
        &self,
        p: &Vector2<f64>,
    ) -> (Vector2<f64>, Matrix2<f64>) {
        let (x, y) = (p.x, p.y);
        let r2 = x * x + y * y;
        let (rad, drad, p1, p2) = match self {
            Self::PlumbBob { coeffs } => {
                let [k1, k2, p1, p2, k3] = *coeffs;
                let rad = 1.0 + r2 * (k1 + r2 * (k2 + r2 * k3));
                let drad = k1 + r2 * (2.0 * k2 + r2 * 3.0 * k3);
                (rad, drad, p1, p2)
            }
            Self::RationalPolynomial { coeffs } => {
                let [k1, k2, p1, p2, k3, k4, k5, k6] = *coeffs;
                let num = 1.0 + r2 * (k1 + r2 * (k2 + r2 * k3));
                let den = 1.0 + r2 * (k4 + r2 * (k5 + r2 * k6));
                let dnum = k1 + r2 * (2.0 * k2 + r2 * 3.0 * k3);
                let dden = k4 + r2 * (2.0 * k5 + r2 * 3.0 * k6);
                (num / den, (dnum * den - num * dden) / (den * den), p1, p2)
            }
            Self::Equidistant { coeffs } => {
                let r = r2.sqrt();
                if r < 1e-12 {
                    return (*p, Matrix2::identity());
                }
                let [k1, k2, k3, k4] = *coeffs;
                let theta = r.atan();
                let t2 = theta * theta;
                let theta_d = theta * (1.0 + t2 * (k1 + t2 * (k2 + t2 * (k3 + t2 * k4))));
                let dtheta_d =
                    1.0 + t2 * (3.0 * k1 + t2 * (5.0 * k2 + t2 * (7.0 * k3 + t2 * 9.0 * k4)));
                // distorted = p * s(r) with s = theta_d / r; d/dp = s I + s'(r) p p^T / r.
                let scale = theta_d / r;
                let dscale = (dtheta_d / (1.0 + r2) - scale) / r;
                let outer = p * p.transpose() * (dscale / r);
                return (p * scale, Matrix2::identity() * scale + outer);
            }
        };
        // radial = rad(r2), d r2 / dx = 2x.
        let off_diagonal = 2.0 * x * y * drad + 2.0 * p1 * x + 2.0 * p2 * y;
        (
            tangential(x, y, r2, rad, p1, p2),
            Matrix2::new(
                rad + 2.0 * x * x * drad + 2.0 * p1 * y + 6.0 * p2 * x,
                off_diagonal,
                off_diagonal,
                rad + 2.0 * y * y * drad + 6.0 * p1 * y + 2.0 * p2 * x,
            ),
        )
    }
}

fn tangential(x: f64, y: f64, r2: f64, radial: f64, p1: f64, p2: f64) -> Vector2<f64> {
    Vector2::new(
        x * radial + 2.0 * p1 * x * y + p2 * (r2 + 2.0 * x * x),
        y * radial + p1 * (r2 + 2.0 * y * y) + 2.0 * p2 * x * y,
    )
}
