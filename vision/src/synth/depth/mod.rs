//! Rectified stereo pairs of textured 3D scenes with exact ground-truth disparity and
//! occlusion masks: the test bed of dense stereo matching.
//!
//! Both cameras are ideal pinholes with the same intrinsics and orientation; the right
//! one sits `baseline` metres along the left one's x axis. So the pair is rectified by
//! construction, and a point at depth `z` has the disparity `f * baseline / z`. Pixels
//! are rendered by supersampling; the ground truth is that of the ray through the
//! pixel's centre.

mod surfaces;
mod texture;

pub use surfaces::{Shape, box_faces};
pub use texture::Texture;

use nalgebra::{Point3, Vector3};
use rayon::prelude::*;

use super::photometry::Radiance;
use crate::image::{Image, Samples};
use surfaces::Hit;

/// A surface of a depth scene: its shape and how it looks.
#[derive(Clone, Debug, PartialEq)]
pub struct Surface {
    /// Geometry, in the left camera frame.
    pub shape: Shape,
    /// Appearance.
    pub texture: Texture,
}

/// How the pair is exposed and degraded.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PairPhotometry {
    /// Defocus blur, standard deviation of a Gaussian, pixels.
    pub defocus_sigma: f64,
    /// Read noise, grey levels.
    pub read_noise: f32,
    /// Shot noise at full scale, grey levels.
    pub shot_noise: f32,
    /// Gain of the right camera relative to the left.
    pub right_gain: f32,
    /// Offset of the right camera, fraction of full scale.
    pub right_offset: f32,
}

impl PairPhotometry {
    /// A good real pair: slight defocus, the noise of a machine-vision sensor, and
    /// right exposure 4 % brighter plus an offset of 2 grey levels, as two cameras of
    /// one model differ.
    pub fn realistic() -> Self {
        Self {
            defocus_sigma: 0.5,
            read_noise: 1.0,
            shot_noise: 2.0,
            right_gain: 1.04,
            right_offset: 2.0 / 255.0,
        }
    }
}

/// A scene in front of a rectified stereo pair.
#[derive(Clone, Debug, PartialEq)]
pub struct DepthScene {
    /// Image width, pixels.
    pub width: usize,
    /// Image height, pixels.
    pub height: usize,
    /// Focal length of both cameras, pixels.
    pub focal: f64,
    /// Distance between the optical centres, metres.
    pub baseline: f64,
    /// The surfaces.
    pub surfaces: Vec<Surface>,
}

/// Ground truth of the left image of a rendered pair.
#[derive(Clone, Debug, PartialEq)]
pub struct DisparityTruth {
    /// Width, pixels.
    pub width: usize,
    /// Height, pixels.
    pub height: usize,
    /// Disparity of each left pixel's centre, row after row (NaN where the ray meets
    /// nothing).
    pub disparity: Vec<f32>,
    /// Whether the point a left pixel sees is also seen by the right camera (not
    /// occluded and inside its image).
    pub visible: Vec<bool>,
}

/// A rendered pair and its truth.
#[derive(Clone, Debug, PartialEq)]
pub struct DepthPair {
    /// Left image (mono8).
    pub left: Image,
    /// Right image (mono8).
    pub right: Image,
    /// Truth of the left image.
    pub truth: DisparityTruth,
}

/// Samples per pixel along each axis.
const SUPERSAMPLING: usize = 3;
/// Direction towards the light (unit), for gentle shading of surfaces by orientation.
const LIGHT: [f64; 3] = [-0.3, -0.6, -0.74];

/// The cameras of a depth scene.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DepthRig {
    /// Image width, pixels.
    pub width: usize,
    /// Image height, pixels.
    pub height: usize,
    /// Focal length of both cameras, pixels.
    pub focal: f64,
    /// Distance between the optical centres, metres.
    pub baseline: f64,
}

impl DepthRig {
    /// The geometry of the stereo depth report we were built from: two webcams 9 cm
    /// apart at 640x480, f = 600 px.
    pub const WEBCAMS: DepthRig = DepthRig {
        width: 640,
        height: 480,
        focal: 600.0,
        baseline: 0.09,
    };

    /// The same field of view at another resolution: the focal length scales with the
    /// width.
    pub fn with_size(self, width: usize, height: usize) -> Self {
        Self {
            width,
            height,
            focal: self.focal * width as f64 / self.width as f64,
            ..self
        }
    }
}

impl DepthScene {
    /// A room-like scene: a back wall at 4 m, a floor, a slanted board, boxes at 1 to
    /// 2 m, a weakly textured patch, and thin poles of 4 and 8 mm radius. Every depth
    /// is at least 0.65 m: with [`DepthRig::WEBCAMS`], disparities below 84 px.
    pub fn standard(rig: DepthRig, seed: u64) -> Self {
        let DepthRig {
            width,
            height,
            focal,
            baseline,
        } = rig;
        let mut next = seed;
        let mut texture = |albedo: f32, contrast: f32| {
            next = next.wrapping_add(0x9e37_79b9_7f4a_7c15);
            Texture::new(albedo, contrast, next)
        };
        let plane = |centre: Point3<f64>, u: Vector3<f64>, v: Vector3<f64>| Shape::Rectangle {
            centre,
            u,
            v,
            half_u: f64::INFINITY,
            half_v: f64::INFINITY,
        };
        let mut surfaces = vec![
            Surface {
                shape: plane(Point3::new(0.0, 0.0, 4.0), Vector3::x(), Vector3::y()),
                texture: texture(0.55, 0.7),
            },
            Surface {
                shape: plane(Point3::new(0.0, 0.45, 2.0), Vector3::x(), Vector3::z()),
                texture: texture(0.45, 0.6),
            },
        ];
        let board_yaw: f64 = 0.7;
        surfaces.push(Surface {
            shape: Shape::Rectangle {
                centre: Point3::new(-0.75, -0.15, 2.2),
                u: Vector3::new(board_yaw.cos(), 0.0, -board_yaw.sin()),
                v: Vector3::y(),
                half_u: 0.35,
                half_v: 0.3,
            },
            texture: texture(0.6, 0.8),
        });
        for (centre, size, yaw) in [
            (
                Point3::new(0.45, 0.2, 1.3),
                Vector3::new(0.3, 0.5, 0.3),
                0.5,
            ),
            (
                Point3::new(-0.2, 0.25, 1.9),
                Vector3::new(0.4, 0.4, 0.4),
                -0.3,
            ),
        ] {
            let look = texture(0.5, 0.7);
            surfaces.extend(
                box_faces(centre, size, yaw)
                    .into_iter()
                    .map(|shape| Surface {
                        shape,
                        texture: look.clone(),
                    }),
            );
        }
        // A weakly textured panel: 2 % contrast, a few grey levels.
        surfaces.push(Surface {
            shape: Shape::Rectangle {
                centre: Point3::new(0.55, -0.45, 2.6),
                u: Vector3::x(),
                v: Vector3::y(),
                half_u: 0.3,
                half_v: 0.2,
            },
            texture: texture(0.7, 0.02),
        });
        for (x, z, radius) in [(0.05, 0.9, 0.008), (-0.45, 1.1, 0.004), (0.95, 1.6, 0.006)] {
            surfaces.push(Surface {
                shape: Shape::Pole {
                    x,
                    z,
                    radius,
                    top: -2.0,
                    bottom: 0.45,
                },
                texture: texture(0.35, 0.5),
            });
        }
        Self {
            width,
            height,
            focal,
            baseline,
            surfaces,
        }
    }

    /// A textured wall facing the cameras at `distance` metres, filling the view.
    pub fn wall(rig: DepthRig, distance: f64, seed: u64) -> Self {
        let DepthRig {
            width,
            height,
            focal,
            baseline,
        } = rig;
        Self {
            width,
            height,
            focal,
            baseline,
            surfaces: vec![Surface {
                shape: Shape::Rectangle {
                    centre: Point3::new(0.0, 0.0, distance),
                    u: Vector3::x(),
                    v: Vector3::y(),
                    half_u: f64::INFINITY,
                    half_v: f64::INFINITY,
                },
                texture: Texture::new(0.5, 0.7, seed),
            }],
        }
    }

    /// Principal point of both cameras: the image centre.
    pub fn principal_point(&self) -> (f64, f64) {
        (
            (self.width as f64 - 1.0) / 2.0,
            (self.height as f64 - 1.0) / 2.0,
        )
    }

    /// Renders the pair through `photometry`, sensor noise seeded by `seed`.
    pub fn render(&self, photometry: &PairPhotometry, seed: u64) -> DepthPair {
        let left_centre = Point3::origin();
        let right_centre = Point3::new(self.baseline, 0.0, 0.0);
        let left = self.render_view(&left_centre, photometry, 1.0, 0.0, seed);
        let right = self.render_view(
            &right_centre,
            photometry,
            photometry.right_gain,
            photometry.right_offset,
            seed ^ 0x5bd1_e995,
        );
        DepthPair {
            left,
            right,
            truth: self.truth(&right_centre),
        }
    }

    fn ray(&self, x: f64, y: f64) -> Vector3<f64> {
        let (cx, cy) = self.principal_point();
        Vector3::new((x - cx) / self.focal, (y - cy) / self.focal, 1.0)
    }

    fn nearest(&self, origin: &Point3<f64>, direction: &Vector3<f64>) -> Option<(Hit, usize)> {
        self.surfaces
            .iter()
            .enumerate()
            .filter_map(|(i, s)| s.shape.hit(origin, direction).map(|h| (h, i)))
            .min_by(|a, b| a.0.t.total_cmp(&b.0.t))
    }

    fn render_view(
        &self,
        centre: &Point3<f64>,
        photometry: &PairPhotometry,
        gain: f32,
        offset: f32,
        seed: u64,
    ) -> Image {
        let light = Vector3::from(LIGHT).normalize();
        let step = 1.0 / SUPERSAMPLING as f64;
        let mut radiance = Radiance {
            width: self.width,
            height: self.height,
            channels: 1,
            data: vec![0.0; self.width * self.height],
        };
        radiance
            .data
            .par_chunks_mut(self.width)
            .enumerate()
            .for_each(|(y, row)| {
                for (x, value) in row.iter_mut().enumerate() {
                    let mut sum = 0.0f32;
                    for sy in 0..SUPERSAMPLING {
                        for sx in 0..SUPERSAMPLING {
                            let px = x as f64 - 0.5 + (sx as f64 + 0.5) * step;
                            let py = y as f64 - 0.5 + (sy as f64 + 0.5) * step;
                            let direction = self.ray(px, py);
                            if let Some((hit, i)) = self.nearest(centre, &direction) {
                                let footprint = hit.t / self.focal;
                                let reflectance = self.surfaces[i]
                                    .texture
                                    .reflectance(hit.u, hit.v, footprint);
                                let shading = 0.7 + 0.3 * hit.normal.dot(&light).abs() as f32;
                                sum += reflectance * shading;
                            }
                        }
                    }
                    *value = gain * sum / (SUPERSAMPLING * SUPERSAMPLING) as f32 + offset;
                }
            });
        radiance.blur(photometry.defocus_sigma);
        radiance.add_noise(photometry.read_noise, photometry.shot_noise, seed);
        let samples = radiance.quantize();
        Image {
            width: self.width,
            height: self.height,
            channels: 1,
            samples: Samples::U8(samples),
        }
    }

    fn truth(&self, right_centre: &Point3<f64>) -> DisparityTruth {
        let pixels: Vec<(f32, bool)> = (0..self.width * self.height)
            .into_par_iter()
            .map(|i| {
                let (x, y) = ((i % self.width) as f64, (i / self.width) as f64);
                let direction = self.ray(x, y);
                let Some((hit, _)) = self.nearest(&Point3::origin(), &direction) else {
                    return (f32::NAN, false);
                };
                let point = Point3::from(direction * hit.t);
                let disparity = self.focal * self.baseline / hit.t;
                let x_right = x - disparity;
                let inside = x_right >= -0.5 && x_right < self.width as f64 - 0.5;
                // The right camera sees the point when nothing lies before it on the
                // ray from the right centre (the same depth, since both look along z).
                let to_point = (point - right_centre) / hit.t;
                let unoccluded = self
                    .nearest(right_centre, &to_point)
                    .is_some_and(|(h, _)| h.t >= hit.t * (1.0 - 1e-9));
                (disparity as f32, inside && unoccluded)
            })
            .collect();
        DisparityTruth {
            width: self.width,
            height: self.height,
            disparity: pixels.iter().map(|p| p.0).collect(),
            visible: pixels.iter().map(|p| p.1).collect(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_wall_has_the_disparity_of_its_depth_and_shifts_by_it() {
        let scene = DepthScene::wall(DepthRig::WEBCAMS, 1.5, 3);
        let ideal = PairPhotometry {
            defocus_sigma: 0.0,
            read_noise: 0.0,
            shot_noise: 0.0,
            right_gain: 1.0,
            right_offset: 0.0,
        };
        let pair = scene.render(&ideal, 1);
        let expected = 600.0 * 0.09 / 1.5;
        assert!(
            pair.truth
                .disparity
                .iter()
                .all(|&d| (d - expected as f32).abs() < 1e-4)
        );
        // Every pixel but the left strip the right camera does not see is visible.
        let hidden = pair.truth.visible.iter().filter(|v| !**v).count();
        assert_eq!(hidden, 36 * 480);
        // The right image is the left one shifted by the (integer) disparity.
        let (Samples::U8(l), Samples::U8(r)) = (&pair.left.samples, &pair.right.samples) else {
            panic!("mono8 expected");
        };
        let (y, shift) = (200, expected as usize);
        let differences: Vec<i32> = (100..600)
            .map(|x| i32::from(l[y * 640 + x]) - i32::from(r[y * 640 + x - shift]))
            .collect();
        assert!(differences.iter().all(|d| d.abs() <= 1), "{differences:?}");
    }

    #[test]
    fn the_standard_scene_has_occlusions_and_near_and_far_surfaces() {
        let scene = DepthScene::standard(DepthRig::WEBCAMS, 5);
        let pair = scene.render(&PairPhotometry::realistic(), 2);
        let truth = &pair.truth;
        let (lo, hi) = truth
            .disparity
            .iter()
            .fold((f32::INFINITY, 0.0f32), |(lo, hi), &d| {
                (lo.min(d), hi.max(d))
            });
        assert!(lo > 13.0 && lo < 14.0, "{lo}");
        assert!(hi > 40.0 && hi < 84.0, "{hi}");
        let occluded = truth.visible.iter().filter(|v| !**v).count();
        // The left strip and the shadows of boxes and poles.
        assert!(
            occluded > 480 * 14 && occluded < 640 * 480 / 5,
            "{occluded}"
        );
    }
}
