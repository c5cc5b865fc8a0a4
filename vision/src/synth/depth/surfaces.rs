//! The surfaces of depth scenes and where a ray meets them: rectangles (planes when
//! unbounded, boxes as six of them) and upright cylinders for thin poles.

use nalgebra::{Point3, Vector3};

/// A surface patch of a depth scene, with the index of its texture.
#[derive(Clone, Debug, PartialEq)]
pub enum Shape {
    /// A rectangle through `centre` spanned by the unit vectors `u` and `v`, of
    /// half-sizes `half_u` and `half_v` metres (infinite for a plane).
    Rectangle {
        /// Centre, metres, in the left camera frame.
        centre: Point3<f64>,
        /// First in-plane axis (unit).
        u: Vector3<f64>,
        /// Second in-plane axis (unit, orthogonal to `u`).
        v: Vector3<f64>,
        /// Half-size along `u`, metres.
        half_u: f64,
        /// Half-size along `v`, metres.
        half_v: f64,
    },
    /// A cylinder with its axis along the camera's y axis (upright).
    Pole {
        /// Axis position: x, metres.
        x: f64,
        /// Axis position: z, metres.
        z: f64,
        /// Radius, metres.
        radius: f64,
        /// Top end (y, metres; y points down).
        top: f64,
        /// Bottom end.
        bottom: f64,
    },
}

/// Where a ray met a surface.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Hit {
    /// Ray parameter: the depth (z) of the hit along a ray whose direction has z = 1.
    pub(crate) t: f64,
    /// Surface coordinates, metres.
    pub(crate) u: f64,
    pub(crate) v: f64,
    /// Unit normal.
    pub(crate) normal: Vector3<f64>,
}

impl Shape {
    /// The first hit of the ray `origin + t * direction` with `t > 0`.
    pub(crate) fn hit(&self, origin: &Point3<f64>, direction: &Vector3<f64>) -> Option<Hit> {
        match *self {
            Shape::Rectangle {
                centre,
                u,
                v,
                half_u,
                half_v,
            } => {
                let normal = u.cross(&v);
                let along = normal.dot(direction);
                if along.abs() < 1e-12 {
                    return None;
                }
                let t = normal.dot(&(centre - origin)) / along;
                if t <= 1e-9 {
                    return None;
                }
                let offset = origin + t * direction - centre;
                let (a, b) = (offset.dot(&u), offset.dot(&v));
                (a.abs() <= half_u && b.abs() <= half_v).then_some(Hit {
                    t,
                    u: a,
                    v: b,
                    normal,
                })
            }
            Shape::Pole {
                x,
                z,
                radius,
                top,
                bottom,
            } => {
                // Solve |(o + t d) - axis|^2 = r^2 in the x-z plane.
                let (ox, oz) = (origin.x - x, origin.z - z);
                let (dx, dz) = (direction.x, direction.z);
                let a = dx * dx + dz * dz;
                let b = 2.0 * (ox * dx + oz * dz);
                let c = ox * ox + oz * oz - radius * radius;
                let discriminant = b * b - 4.0 * a * c;
                if a <= 0.0 || discriminant < 0.0 {
                    return None;
                }
                let t = (-b - discriminant.sqrt()) / (2.0 * a);
                if t <= 1e-9 {
                    return None;
                }
                let point = origin + t * direction;
                if point.y < top || point.y > bottom {
                    return None;
                }
                let (nx, nz) = ((point.x - x) / radius, (point.z - z) / radius);
                Some(Hit {
                    t,
                    u: nz.atan2(nx) * radius,
                    v: point.y,
                    normal: Vector3::new(nx, 0.0, nz),
                })
            }
        }
    }
}

/// The six faces of a box of `size` (x, y, z extents, metres) centred at `centre`,
/// turned by `yaw` radians about the y axis.
pub fn box_faces(centre: Point3<f64>, size: Vector3<f64>, yaw: f64) -> Vec<Shape> {
    let (sin, cos) = yaw.sin_cos();
    let x = Vector3::new(cos, 0.0, -sin);
    let y = Vector3::y();
    let z = Vector3::new(sin, 0.0, cos);
    let half = size / 2.0;
    let face = |normal: Vector3<f64>,
                distance: f64,
                u: Vector3<f64>,
                half_u: f64,
                v: Vector3<f64>,
                half_v: f64| {
        Shape::Rectangle {
            centre: centre + normal * distance,
            u,
            v,
            half_u,
            half_v,
        }
    };
    vec![
        face(-z, half.z, x, half.x, y, half.y),
        face(z, half.z, x, half.x, y, half.y),
        face(-x, half.x, z, half.z, y, half.y),
        face(x, half.x, z, half.z, y, half.y),
        face(-y, half.y, x, half.x, z, half.z),
        face(y, half.y, x, half.x, z, half.z),
    ]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rays_meet_rectangles_poles_and_boxes_where_expected() {
        let origin = Point3::origin();
        let wall = Shape::Rectangle {
            centre: Point3::new(0.0, 0.0, 2.0),
            u: Vector3::x(),
            v: Vector3::y(),
            half_u: 0.5,
            half_v: 0.5,
        };
        let hit = wall.hit(&origin, &Vector3::new(0.1, 0.0, 1.0)).unwrap();
        assert!((hit.t - 2.0).abs() < 1e-12 && (hit.u - 0.2).abs() < 1e-12);
        assert!(wall.hit(&origin, &Vector3::new(0.3, 0.0, 1.0)).is_none());

        let pole = Shape::Pole {
            x: 0.0,
            z: 1.0,
            radius: 0.01,
            top: -1.0,
            bottom: 1.0,
        };
        let hit = pole.hit(&origin, &Vector3::new(0.0, 0.0, 1.0)).unwrap();
        assert!((hit.t - 0.99).abs() < 1e-12);
        assert!(pole.hit(&origin, &Vector3::new(0.02, 0.0, 1.0)).is_none());
        assert!(pole.hit(&origin, &Vector3::new(0.0, 1.5, 1.0)).is_none());

        let faces = box_faces(Point3::new(0.0, 0.0, 1.0), Vector3::new(0.2, 0.2, 0.2), 0.0);
        let nearest = faces
            .iter()
            .filter_map(|f| f.hit(&origin, &Vector3::new(0.0, 0.0, 1.0)))
            .map(|h| h.t)
            .fold(f64::INFINITY, f64::min);
        assert!((nearest - 0.9).abs() < 1e-12);
    }
}
