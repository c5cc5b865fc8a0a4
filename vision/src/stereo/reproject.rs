//! From disparity to depth and to 3D points, through the rectified projections of a
//! horizontal stereo pair (ROS `camera_info.P`, OpenCV's `P1`/`P2`) or OpenCV's `Q`.

use nalgebra::{Matrix3x4, Matrix4, Point3};
use rayon::prelude::*;
use thiserror::Error;

use super::DisparityMap;

/// Why two projections do not describe a rectified horizontal pair.
#[derive(Debug, Error, PartialEq)]
pub enum ReprojectionError {
    /// The projections do not share the focal lengths and the principal row.
    #[error(
        "the projections are not of one rectified pair: left fx {left_fx}, fy {left_fy}, cy {left_cy} against right fx {right_fx}, fy {right_fy}, cy {right_cy}"
    )]
    NotRectified {
        /// Left fx.
        left_fx: f64,
        /// Left fy.
        left_fy: f64,
        /// Left cy.
        left_cy: f64,
        /// Right fx.
        right_fx: f64,
        /// Right fy.
        right_fy: f64,
        /// Right cy.
        right_cy: f64,
    },
    /// The baseline is vertical: rows are not epipolar lines.
    #[error(
        "the right projection has a vertical offset (P[1][3] = {0}): a vertical rig; disparity runs along rows only"
    )]
    Vertical(f64),
    /// The right camera is not to the right of the left one.
    #[error(
        "the baseline is {0} m: the right camera must be to the right of the left one (are the two swapped?)"
    )]
    Baseline(f64),
    /// A value is not finite or a focal length not positive.
    #[error("the projection matrices are not usable: {0}")]
    Degenerate(String),
}

/// The geometry that turns a disparity into a point of the rectified left camera
/// (x right, y down, z forward, metres).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Reprojection {
    /// Focal length along x, pixels.
    pub fx: f64,
    /// Focal length along y, pixels.
    pub fy: f64,
    /// Principal point x of the left image.
    pub cx_left: f64,
    /// Principal point x of the right image.
    pub cx_right: f64,
    /// Principal point y of both images.
    pub cy: f64,
    /// Distance between the two optical centres, metres (positive).
    pub baseline: f64,
}

impl Reprojection {
    /// The reprojection of a pair rectified to the projections `left` and `right`
    /// (`P = [f 0 cx Tx; 0 f cy Ty; 0 0 1 0]`, `Tx = -f * baseline` on the right).
    /// Relative tolerance 1e-6 on the shared entries.
    pub fn from_projections(
        left: &Matrix3x4<f64>,
        right: &Matrix3x4<f64>,
    ) -> Result<Self, ReprojectionError> {
        if left.iter().chain(right.iter()).any(|v| !v.is_finite()) {
            return Err(ReprojectionError::Degenerate(
                "an entry is not finite".into(),
            ));
        }
        let (fx, fy, cy) = (left[(0, 0)], left[(1, 1)], left[(1, 2)]);
        if fx <= 0.0 || fy <= 0.0 {
            return Err(ReprojectionError::Degenerate(format!(
                "focal lengths {fx}, {fy} must be positive"
            )));
        }
        let close = |a: f64, b: f64| (a - b).abs() <= 1e-6 * a.abs().max(b.abs()).max(1.0);
        if !(close(fx, right[(0, 0)]) && close(fy, right[(1, 1)]) && close(cy, right[(1, 2)])) {
            return Err(ReprojectionError::NotRectified {
                left_fx: fx,
                left_fy: fy,
                left_cy: cy,
                right_fx: right[(0, 0)],
                right_fy: right[(1, 1)],
                right_cy: right[(1, 2)],
            });
        }
        let vertical = right[(1, 3)] - left[(1, 3)];
        if !close(vertical + fy, fy) {
            return Err(ReprojectionError::Vertical(right[(1, 3)]));
        }
        let baseline = (left[(0, 3)] - right[(0, 3)]) / fx;
        if baseline <= 0.0 {
            return Err(ReprojectionError::Baseline(baseline));
        }
        Ok(Self {
            fx,
            fy,
            cx_left: left[(0, 2)],
            cx_right: right[(0, 2)],
            cy,
            baseline,
        })
    }

    /// OpenCV's `Q` of `stereoRectify`: `Q [x y d 1]^T = [X Y Z W]^T`, the point being
    /// `(X, Y, Z) / W`. With `fx != fy` it scales y by `fx / fy` wrongly, as OpenCV's
    /// does; [`Self::point`] does not.
    pub fn q(&self) -> Matrix4<f64> {
        let tx = -self.baseline;
        Matrix4::new(
            1.0,
            0.0,
            0.0,
            -self.cx_left,
            0.0,
            1.0,
            0.0,
            -self.cy,
            0.0,
            0.0,
            0.0,
            self.fx,
            0.0,
            0.0,
            -1.0 / tx,
            (self.cx_left - self.cx_right) / tx,
        )
    }

    /// The reprojection of OpenCV's `Q` (square pixels).
    pub fn from_q(q: &Matrix4<f64>) -> Result<Self, ReprojectionError> {
        if q.iter().any(|v| !v.is_finite()) || q[(2, 3)] <= 0.0 || q[(3, 2)] == 0.0 {
            return Err(ReprojectionError::Degenerate(
                "Q needs a positive focal length Q[2][3] and a baseline term Q[3][2]".into(),
            ));
        }
        let tx = -1.0 / q[(3, 2)];
        let baseline = -tx;
        if baseline <= 0.0 {
            return Err(ReprojectionError::Baseline(baseline));
        }
        let cx_left = -q[(0, 3)];
        Ok(Self {
            fx: q[(2, 3)],
            fy: q[(2, 3)],
            cx_left,
            cx_right: cx_left - q[(3, 3)] * tx,
            cy: -q[(1, 3)],
            baseline,
        })
    }

    /// The disparity of a point at depth `z` metres.
    pub fn disparity(&self, z: f64) -> f64 {
        self.fx * self.baseline / z + (self.cx_left - self.cx_right)
    }

    /// Depth (metres) of a disparity; `None` for an invalid disparity or a point not in
    /// front of the cameras.
    pub fn depth(&self, disparity: f32) -> Option<f64> {
        let d = f64::from(disparity) - (self.cx_left - self.cx_right);
        (d > 0.0).then(|| self.fx * self.baseline / d)
    }

    /// The point seen at the left pixel `(x, y)` with `disparity`, in the rectified left
    /// camera frame.
    pub fn point(&self, x: f64, y: f64, disparity: f32) -> Option<Point3<f64>> {
        let z = self.depth(disparity)?;
        Some(Point3::new(
            (x - self.cx_left) * z / self.fx,
            (y - self.cy) * z / self.fy,
            z,
        ))
    }

    /// Depth per pixel of `map` (metres, NaN where there is none).
    pub fn depth_map(&self, map: &DisparityMap) -> Vec<f32> {
        map.data
            .par_iter()
            .map(|&d| self.depth(d).map_or(f32::NAN, |z| z as f32))
            .collect()
    }

    /// Points per pixel of `map`, row after row (an organized cloud, NaN where there is
    /// none), in the rectified left camera frame.
    pub fn points(&self, map: &DisparityMap) -> Vec<[f32; 3]> {
        let width = map.width.max(1);
        map.data
            .par_chunks(width)
            .enumerate()
            .flat_map_iter(|(y, row)| {
                row.iter().enumerate().map(move |(x, &d)| {
                    self.point(x as f64, y as f64, d)
                        .map_or([f32::NAN; 3], |p| [p.x as f32, p.y as f32, p.z as f32])
                })
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pair() -> (Matrix3x4<f64>, Matrix3x4<f64>) {
        let left = Matrix3x4::new(
            600.0, 0.0, 320.0, 0.0, 0.0, 600.0, 240.0, 0.0, 0.0, 0.0, 1.0, 0.0,
        );
        let mut right = left;
        right[(0, 2)] = 330.0;
        right[(0, 3)] = -600.0 * 0.09;
        (left, right)
    }

    #[test]
    fn a_point_reprojects_to_where_it_was_seen() {
        let (left, right) = pair();
        let r = Reprojection::from_projections(&left, &right).unwrap();
        let point = Point3::new(0.3, -0.2, 1.7);
        let seen_left = left * point.to_homogeneous();
        let seen_right = right * point.to_homogeneous();
        let (xl, y) = (seen_left.x / seen_left.z, seen_left.y / seen_left.z);
        let xr = seen_right.x / seen_right.z;
        let back = r.point(xl, y, (xl - xr) as f32).unwrap();
        assert!((back - point).norm() < 1e-5, "{back}");
        assert!((r.disparity(1.7) - (xl - xr)).abs() < 1e-9);

        let q = r.q();
        let h = q * nalgebra::Vector4::new(xl, y, xl - xr, 1.0);
        assert!((h.xyz() / h.w - point.coords).norm() < 1e-9);
        let from_q = Reprojection::from_q(&q).unwrap();
        assert!((from_q.baseline - 0.09).abs() < 1e-12 && (from_q.cx_right - 330.0).abs() < 1e-9);
    }

    #[test]
    fn projections_of_no_horizontal_pair_are_refused() {
        let (left, right) = pair();
        let mut vertical = right;
        vertical[(0, 3)] = 0.0;
        vertical[(1, 3)] = -54.0;
        assert!(matches!(
            Reprojection::from_projections(&left, &vertical),
            Err(ReprojectionError::Vertical(_))
        ));
        let mut other = right;
        other[(1, 1)] = 610.0;
        assert!(matches!(
            Reprojection::from_projections(&left, &other),
            Err(ReprojectionError::NotRectified { .. })
        ));
        assert!(matches!(
            Reprojection::from_projections(&right, &left),
            Err(ReprojectionError::Baseline(_))
        ));
    }
}
