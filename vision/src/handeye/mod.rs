//! Hand-eye calibration: where a camera sits on a robot, from the robot's poses and the
//! poses of a calibration target the camera saw at the same instants.
//!
//! Two setups, one problem. The camera is fixed to one frame of the robot, its
//! *mount*, and the target to the other, its *anchor*:
//! - eye-in-hand: the camera rides on the tool (mount = tool), the target stands still
//!   in the robot's base frame (anchor = base);
//! - eye-to-hand: the camera stands still (mount = base), the target rides on the tool
//!   (anchor = tool).
//!
//! Each [`Sample`] gives `base_from_tool` and `camera_from_target`, and every sample
//! must agree that
//! `anchor_from_target = anchor_from_mount_i * mount_from_camera * camera_from_target_i`,
//! with `anchor_from_mount_i` the robot's pose (`base_from_tool_i`) or its inverse.
//! Callers never invert anything: [`calibrate`] takes the samples as the robot and the
//! camera report them and returns [`HandEye`], whose variant names the frames.
//!
//! Methods, one file each:
//! - `AX = XB` on the motions between pairs of samples: Tsai-Lenz (`tsai.rs`),
//!   Park-Martin (`park.rs`), Horaud-Dornaika (`horaud.rs`), Andreff (`andreff.rs`) and
//!   Daniilidis (`daniilidis.rs`); the anchor's target pose is then the mean over the
//!   samples;
//! - `AX = ZB` on the samples themselves (robot-world hand-eye), which returns both
//!   transforms: Shah (`shah.rs`) and Li (`li.rs`).
//!
//! [`refine()`] then refines any method's result jointly with the target's pose and the
//! robot poses on the pixels of the target's points over all samples.
//!
//! A set of samples whose motions cannot determine the transform (too few, too little
//! rotation, all rotation axes parallel) is refused with advice on the poses to add;
//! one that determines it weakly is solved with a warning.

mod andreff;
mod daniilidis;
mod error;
mod horaud;
mod li;
mod motion;
mod park;
mod refine;
mod screen;
mod shah;
mod tsai;

pub use error::HandEyeError;
pub use motion::{MotionSpread, motion_spread};
pub use refine::{RefineOptions, RefinedHandEye, TargetObservation, Uncertainty, refine};
pub use screen::{RejectedSample, calibrate_screened};

use nalgebra::{Isometry3, Matrix3, Rotation3, Translation3, UnitQuaternion, Vector3};

use crate::rotation::nearest_rotation;

/// Where the camera is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Setup {
    /// The camera rides on the robot's tool; the target stands still.
    EyeInHand,
    /// The camera stands still; the target rides on the robot's tool.
    EyeToHand,
}

impl Setup {
    /// The name used on the command line and in files: `eye-in-hand`, `eye-to-hand`.
    pub fn name(self) -> &'static str {
        match self {
            Self::EyeInHand => "eye-in-hand",
            Self::EyeToHand => "eye-to-hand",
        }
    }

    /// The name of the frame the camera is fixed to: `tool` or `base`.
    pub fn mount(self) -> &'static str {
        match self {
            Self::EyeInHand => "tool",
            Self::EyeToHand => "base",
        }
    }

    /// `anchor_from_mount` at a robot pose: the pose itself, or its inverse.
    fn anchor_from_mount(self, base_from_tool: &Isometry3<f64>) -> Isometry3<f64> {
        match self {
            Self::EyeInHand => *base_from_tool,
            Self::EyeToHand => base_from_tool.inverse(),
        }
    }
}

/// The robot's pose and the target's pose as the camera saw it, at one instant.
#[derive(Clone, Debug, PartialEq)]
pub struct Sample {
    /// The tool in the robot's base frame, as the robot reports it.
    pub base_from_tool: Isometry3<f64>,
    /// The target in the camera frame, as pose estimation measured it.
    pub camera_from_target: Isometry3<f64>,
}

/// A hand-eye method.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Method {
    /// Tsai and Lenz 1989: rotation from modified Rodrigues vectors, then translation.
    Tsai,
    /// Park and Martin 1994: rotation on the Lie algebra, then translation.
    Park,
    /// Horaud and Dornaika 1995: rotation as a unit quaternion, then translation.
    Horaud,
    /// Andreff, Horaud and Espiau 1999: rotation and translation from one linear system.
    Andreff,
    /// Daniilidis 1999: rotation and translation together as a dual quaternion.
    Daniilidis,
    /// Shah 2013 (`AX = ZB`): rotations from a Kronecker product, then translations.
    Shah,
    /// Li, Wang and Wu 2010 (`AX = ZB`): rotations and translations from one linear
    /// system.
    Li,
}

impl Method {
    /// Every method, in the order reports list them.
    pub const ALL: [Method; 7] = [
        Method::Tsai,
        Method::Park,
        Method::Horaud,
        Method::Andreff,
        Method::Daniilidis,
        Method::Shah,
        Method::Li,
    ];

    /// The method's name in lower case, as JSON and the command line use it.
    pub fn name(self) -> &'static str {
        match self {
            Self::Tsai => "tsai",
            Self::Park => "park",
            Self::Horaud => "horaud",
            Self::Andreff => "andreff",
            Self::Daniilidis => "daniilidis",
            Self::Shah => "shah",
            Self::Li => "li",
        }
    }
}

/// A hand-eye calibration: the camera's pose on what carries it and the target's pose
/// on what holds it, named by the setup's frames.
#[derive(Clone, Debug, PartialEq)]
pub enum HandEye {
    /// The camera on the tool, the target in the base frame.
    EyeInHand {
        /// The camera in the tool frame.
        tool_from_camera: Isometry3<f64>,
        /// The target in the robot's base frame.
        base_from_target: Isometry3<f64>,
    },
    /// The camera in the base frame, the target on the tool.
    EyeToHand {
        /// The camera in the robot's base frame.
        base_from_camera: Isometry3<f64>,
        /// The target in the tool frame.
        tool_from_target: Isometry3<f64>,
    },
}

impl HandEye {
    fn new(
        setup: Setup,
        mount_from_camera: Isometry3<f64>,
        anchor_from_target: Isometry3<f64>,
    ) -> Self {
        match setup {
            Setup::EyeInHand => Self::EyeInHand {
                tool_from_camera: mount_from_camera,
                base_from_target: anchor_from_target,
            },
            Setup::EyeToHand => Self::EyeToHand {
                base_from_camera: mount_from_camera,
                tool_from_target: anchor_from_target,
            },
        }
    }

    /// The setup this calibration is of.
    pub fn setup(&self) -> Setup {
        match self {
            Self::EyeInHand { .. } => Setup::EyeInHand,
            Self::EyeToHand { .. } => Setup::EyeToHand,
        }
    }

    /// The camera in the frame it is fixed to: `tool_from_camera` or
    /// `base_from_camera`.
    pub fn mount_from_camera(&self) -> &Isometry3<f64> {
        match self {
            Self::EyeInHand {
                tool_from_camera, ..
            } => tool_from_camera,
            Self::EyeToHand {
                base_from_camera, ..
            } => base_from_camera,
        }
    }

    /// The target in the frame it is fixed to: `base_from_target` or
    /// `tool_from_target`.
    pub fn anchor_from_target(&self) -> &Isometry3<f64> {
        match self {
            Self::EyeInHand {
                base_from_target, ..
            } => base_from_target,
            Self::EyeToHand {
                tool_from_target, ..
            } => tool_from_target,
        }
    }

    /// Where this calibration puts the target in the camera frame for a robot pose:
    /// what the camera should measure at that pose.
    pub fn predicted_camera_from_target(&self, base_from_tool: &Isometry3<f64>) -> Isometry3<f64> {
        let anchor_from_mount = self.setup().anchor_from_mount(base_from_tool);
        (anchor_from_mount * self.mount_from_camera()).inverse() * self.anchor_from_target()
    }
}

impl HandEye {
    /// How far a sample's measured target pose is from this calibration's prediction
    /// for its robot pose.
    pub fn residual(&self, sample: &Sample) -> SampleResidual {
        let predicted = self.predicted_camera_from_target(&sample.base_from_tool);
        let error = predicted.inverse() * sample.camera_from_target;
        SampleResidual {
            rotation_rad: error.rotation.angle(),
            translation_m: (predicted.translation.vector
                - sample.camera_from_target.translation.vector)
                .norm(),
        }
    }
}

/// How far one sample's measured target pose is from the calibration's prediction.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SampleResidual {
    /// Rotation between the measured and the predicted `camera_from_target`, radians.
    pub rotation_rad: f64,
    /// Distance between the measured and the predicted target origin, metres.
    pub translation_m: f64,
}

impl SampleResidual {
    /// The residual as one number, for comparing samples and methods: the larger of its
    /// rotation over 0.1 degree and its translation over 1 mm.
    pub fn scaled(&self) -> f64 {
        (self.rotation_rad / (0.1 * std::f64::consts::PI / 180.0)).max(self.translation_m / 1e-3)
    }
}

/// One method's calibration.
#[derive(Clone, Debug, PartialEq)]
pub struct Calibration {
    /// The method that computed it.
    pub method: Method,
    /// The transforms.
    pub hand_eye: HandEye,
    /// Each sample's disagreement with it, in sample order.
    pub residuals: Vec<SampleResidual>,
    /// What makes the samples a weak basis for it, with the poses to add.
    pub warnings: Vec<String>,
}

/// The least number of samples: two motions with distinct rotation axes.
pub const MIN_SAMPLES: usize = 3;

/// Calibrates with `method` from `samples` of a `setup`.
///
/// Errors: [`HandEyeError::TooFewSamples`] below [`MIN_SAMPLES`],
/// [`HandEyeError::NonFinite`] for a sample with NaN or infinity,
/// [`HandEyeError::Degenerate`] when the motions cannot determine the transform (see
/// [`motion_spread`]), [`HandEyeError::NoSolution`] when the method's numerics fail.
pub fn calibrate(
    setup: Setup,
    samples: &[Sample],
    method: Method,
) -> Result<Calibration, HandEyeError> {
    if samples.len() < MIN_SAMPLES {
        return Err(HandEyeError::TooFewSamples {
            needed: MIN_SAMPLES,
            got: samples.len(),
        });
    }
    for (index, sample) in samples.iter().enumerate() {
        if !is_finite(&sample.base_from_tool) {
            return Err(HandEyeError::NonFinite {
                index,
                what: "robot pose",
            });
        }
        if !is_finite(&sample.camera_from_target) {
            return Err(HandEyeError::NonFinite {
                index,
                what: "target pose",
            });
        }
    }
    let spread = motion_spread(setup, samples);
    spread.check()?;
    let anchor_from_mount: Vec<Isometry3<f64>> = samples
        .iter()
        .map(|s| setup.anchor_from_mount(&s.base_from_tool))
        .collect();
    let camera_from_target: Vec<Isometry3<f64>> =
        samples.iter().map(|s| s.camera_from_target).collect();
    let failed = |reason: &str| HandEyeError::NoSolution {
        method: method.name(),
        reason: reason.into(),
    };
    let (mount_from_camera, anchor_from_target) = match method {
        Method::Shah | Method::Li => {
            // AX = ZB with A = camera_from_target, X = target_from_anchor,
            // Z = camera_from_mount, B = mount_from_anchor.
            let mount_from_anchor: Vec<Isometry3<f64>> =
                anchor_from_mount.iter().map(|p| p.inverse()).collect();
            let (target_from_anchor, camera_from_mount) = match method {
                Method::Shah => shah::solve(&camera_from_target, &mount_from_anchor),
                _ => li::solve(&camera_from_target, &mount_from_anchor),
            }
            .map_err(failed)?;
            (camera_from_mount.inverse(), target_from_anchor.inverse())
        }
        _ => {
            let motions = motion::pairs(&anchor_from_mount, &camera_from_target);
            let mount_from_camera = match method {
                Method::Tsai => tsai::solve(&motions),
                Method::Park => park::solve(&motions),
                Method::Horaud => horaud::solve(&motions),
                Method::Andreff => andreff::solve(&motions),
                _ => daniilidis::solve(&motions),
            }
            .map_err(failed)?;
            let anchor_from_target =
                mean_pose(anchor_from_mount.iter().zip(&camera_from_target).map(
                    |(anchor_from_mount, camera_from_target)| {
                        anchor_from_mount * mount_from_camera * camera_from_target
                    },
                ))
                .ok_or_else(|| failed("the target poses have no mean"))?;
            (mount_from_camera, anchor_from_target)
        }
    };
    if !is_finite(&mount_from_camera) || !is_finite(&anchor_from_target) {
        return Err(failed("non-finite result"));
    }
    let hand_eye = HandEye::new(setup, mount_from_camera, anchor_from_target);
    let residuals = samples.iter().map(|s| hand_eye.residual(s)).collect();
    Ok(Calibration {
        method,
        hand_eye,
        residuals,
        warnings: spread.warnings(setup),
    })
}

fn is_finite(pose: &Isometry3<f64>) -> bool {
    pose.translation.vector.iter().all(|v| v.is_finite())
        && pose.rotation.coords.iter().all(|v| v.is_finite())
}

/// The mean of poses: the rotation nearest to the sum of their rotation matrices (the
/// chordal mean) and the mean translation; `None` for no poses.
fn mean_pose(poses: impl Iterator<Item = Isometry3<f64>>) -> Option<Isometry3<f64>> {
    let mut rotation_sum = Matrix3::zeros();
    let mut translation_sum = Vector3::zeros();
    let mut count = 0usize;
    for pose in poses {
        rotation_sum += pose.rotation.to_rotation_matrix().matrix();
        translation_sum += pose.translation.vector;
        count += 1;
    }
    if count == 0 {
        return None;
    }
    let rotation = nearest_rotation(&rotation_sum)?;
    Some(isometry(&rotation, &(translation_sum / count as f64)))
}

/// The rotation nearest to a matrix estimated only up to scale and sign: scaled to a
/// positive determinant, then made orthonormal (OpenCV's `normalizeRotation`); `None`
/// when the determinant vanishes.
fn normalize_rotation(m: &Matrix3<f64>) -> Result<Matrix3<f64>, &'static str> {
    let determinant = m.determinant();
    if determinant.is_nan() || determinant.abs() < f64::from(f32::EPSILON) {
        return Err("the estimated rotation matrix is singular");
    }
    nearest_rotation(&(m * determinant.signum()))
        .ok_or("the estimated rotation has no nearest rotation")
}

/// The isometry of a rotation matrix (taken as exact) and a translation.
fn isometry(rotation: &Matrix3<f64>, translation: &Vector3<f64>) -> Isometry3<f64> {
    Isometry3::from_parts(
        Translation3::from(*translation),
        UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(*rotation)),
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::synth::gaussian;
    use rand::{RngExt, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    /// A pose as OpenCV's hand-eye test draws it: a rotation vector of random direction
    /// (components uniform in [-1, 1], not normalized) times an angle in
    /// `[min, max]` degrees of random sign, and a translation whose components are in
    /// `[min, max]` metres with random signs.
    fn random_pose(
        rng: &mut ChaCha8Rng,
        degrees: (f64, f64),
        metres: (f64, f64),
    ) -> Isometry3<f64> {
        let sign = |rng: &mut ChaCha8Rng| if rng.random_bool(0.5) { 1.0 } else { -1.0 };
        let axis = Vector3::from_fn(|_, _| rng.random_range(-1.0..1.0));
        let angle = rng.random_range(degrees.0..degrees.1).to_radians() * sign(rng);
        let t = Vector3::from_fn(|_, _| rng.random_range(metres.0..metres.1) * sign(rng));
        Isometry3::new(t, axis * angle)
    }

    /// A pose moved by Gaussian noise on its rotation vector (radians) and translation
    /// (metres), as OpenCV's test adds it.
    fn noisy(rng: &mut ChaCha8Rng, pose: &Isometry3<f64>, rad: f64, metres: f64) -> Isometry3<f64> {
        let r = pose.rotation.scaled_axis() + Vector3::from_fn(|_, _| gaussian(rng, rad));
        let t = pose.translation.vector + Vector3::from_fn(|_, _| gaussian(rng, metres));
        Isometry3::new(t, r)
    }

    /// Ten samples of a setup in OpenCV's protocol, with the true `mount_from_camera`
    /// and `anchor_from_target`; noise (rotation rad, translation m) on the target poses
    /// and on the robot poses.
    fn session(
        rng: &mut ChaCha8Rng,
        setup: Setup,
        target_noise: (f64, f64),
        robot_noise: (f64, f64),
    ) -> (Vec<Sample>, Isometry3<f64>, Isometry3<f64>) {
        let (mount_from_camera, anchor_from_target) = match setup {
            Setup::EyeInHand => (
                random_pose(rng, (10.0, 50.0), (0.05, 0.5)),
                random_pose(rng, (5.0, 85.0), (0.5, 3.5)),
            ),
            Setup::EyeToHand => (
                random_pose(rng, (10.0, 50.0), (0.5, 3.5)),
                random_pose(rng, (5.0, 85.0), (0.05, 0.5)),
            ),
        };
        let samples = (0..10)
            .map(|_| {
                let base_from_tool = random_pose(rng, (5.0, 45.0), (0.5, 1.5));
                let anchor_from_mount = setup.anchor_from_mount(&base_from_tool);
                let camera_from_target =
                    (anchor_from_mount * mount_from_camera).inverse() * anchor_from_target;
                Sample {
                    base_from_tool: noisy(rng, &base_from_tool, robot_noise.0, robot_noise.1),
                    camera_from_target: noisy(
                        rng,
                        &camera_from_target,
                        target_noise.0,
                        target_noise.1,
                    ),
                }
            })
            .collect();
        (samples, mount_from_camera, anchor_from_target)
    }

    fn errors(found: &Isometry3<f64>, truth: &Isometry3<f64>) -> (f64, f64) {
        (
            found.rotation.angle_to(&truth.rotation),
            (found.translation.vector - truth.translation.vector).norm(),
        )
    }

    #[test]
    fn every_method_recovers_exact_transforms_in_both_setups() {
        let mut rng = ChaCha8Rng::seed_from_u64(1);
        for setup in [Setup::EyeInHand, Setup::EyeToHand] {
            for _ in 0..20 {
                let (samples, mount_from_camera, anchor_from_target) =
                    session(&mut rng, setup, (0.0, 0.0), (0.0, 0.0));
                for method in Method::ALL {
                    let c = calibrate(setup, &samples, method).unwrap();
                    assert_eq!(c.hand_eye.setup(), setup);
                    let (r, t) = errors(c.hand_eye.mount_from_camera(), &mount_from_camera);
                    assert!(r < 1e-9 && t < 1e-9, "{setup:?} {method:?}: {r} rad, {t} m");
                    let (r, t) = errors(c.hand_eye.anchor_from_target(), &anchor_from_target);
                    assert!(
                        r < 1e-9 && t < 1e-9,
                        "{setup:?} {method:?} target: {r} rad, {t} m"
                    );
                    assert!(
                        c.residuals
                            .iter()
                            .all(|e| e.rotation_rad < 1e-9 && e.translation_m < 1e-9)
                    );
                    assert!(c.warnings.is_empty(), "{:?}", c.warnings);
                }
            }
        }
    }

    /// OpenCV's noisy protocol and its tolerances (the norm of the rotation vector
    /// difference, radians; translation, metres): every trial of every method within
    /// them.
    #[test]
    fn noisy_sessions_stay_within_opencvs_tolerances() {
        let mut rng = ChaCha8Rng::seed_from_u64(2);
        for setup in [Setup::EyeInHand, Setup::EyeToHand] {
            for _ in 0..100 {
                let (samples, mount_from_camera, _) =
                    session(&mut rng, setup, (0.002, 0.005), (0.001, 0.001));
                for method in Method::ALL {
                    let c = calibrate(setup, &samples, method).unwrap();
                    let found = c.hand_eye.mount_from_camera();
                    let r = (found.rotation.scaled_axis()
                        - mount_from_camera.rotation.scaled_axis())
                    .norm();
                    let t =
                        (found.translation.vector - mount_from_camera.translation.vector).norm();
                    let (max_r, max_t) = match method {
                        Method::Andreff | Method::Daniilidis => (1e-2, 7e-2),
                        _ => (2e-2, 5e-2),
                    };
                    assert!(
                        r < max_r && t < max_t,
                        "{setup:?} {method:?}: {r} rad, {t} m"
                    );
                }
            }
        }
    }

    #[test]
    fn refuses_too_few_non_finite_and_degenerate_samples() {
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        let (samples, _, _) = session(&mut rng, Setup::EyeInHand, (0.0, 0.0), (0.0, 0.0));
        assert!(matches!(
            calibrate(Setup::EyeInHand, &samples[..2], Method::Tsai),
            Err(HandEyeError::TooFewSamples { needed: 3, got: 2 })
        ));
        let mut bad = samples.clone();
        bad[4].camera_from_target.translation.vector.x = f64::NAN;
        assert!(matches!(
            calibrate(Setup::EyeInHand, &bad, Method::Park),
            Err(HandEyeError::NonFinite {
                index: 4,
                what: "target pose"
            })
        ));
        // Every pose turns the tool about the same axis: the translation along it is
        // undetermined.
        let tool_from_camera =
            Isometry3::new(Vector3::new(0.05, 0.02, 0.1), Vector3::new(0.2, -0.1, 0.3));
        let base_from_target =
            Isometry3::new(Vector3::new(1.0, 0.2, -0.3), Vector3::new(0.0, 2.8, 0.0));
        let one_axis: Vec<Sample> = (0..8)
            .map(|i| {
                let base_from_tool = Isometry3::new(
                    Vector3::new(0.6 + 0.05 * f64::from(i), 0.1, 0.5),
                    Vector3::z() * (0.3 * f64::from(i)),
                );
                Sample {
                    base_from_tool,
                    camera_from_target: (base_from_tool * tool_from_camera).inverse()
                        * base_from_target,
                }
            })
            .collect();
        for method in Method::ALL {
            let error = calibrate(Setup::EyeInHand, &one_axis, method).unwrap_err();
            let HandEyeError::Degenerate(message) = error else {
                panic!("{method:?}: {error}");
            };
            assert!(message.contains("one axis"), "{message}");
        }
        // Pure translations: no rotation to find the camera's from.
        let translations: Vec<Sample> = (0..6)
            .map(|i| {
                let base_from_tool = Isometry3::translation(0.5 + 0.1 * f64::from(i), 0.0, 0.4);
                Sample {
                    base_from_tool,
                    camera_from_target: (base_from_tool * tool_from_camera).inverse()
                        * base_from_target,
                }
            })
            .collect();
        let error = calibrate(Setup::EyeInHand, &translations, Method::Daniilidis).unwrap_err();
        assert!(
            matches!(&error, HandEyeError::Degenerate(m) if m.contains("turned by at most")),
            "{error}"
        );
    }

    #[test]
    fn small_rotations_are_solved_with_a_warning() {
        let mut rng = ChaCha8Rng::seed_from_u64(4);
        let tool_from_camera = random_pose(&mut rng, (10.0, 50.0), (0.05, 0.5));
        let base_from_target = random_pose(&mut rng, (5.0, 85.0), (0.5, 3.5));
        let samples: Vec<Sample> = (0..10)
            .map(|_| {
                let base_from_tool = random_pose(&mut rng, (2.0, 5.0), (0.5, 1.5));
                Sample {
                    base_from_tool,
                    camera_from_target: (base_from_tool * tool_from_camera).inverse()
                        * base_from_target,
                }
            })
            .collect();
        let c = calibrate(Setup::EyeInHand, &samples, Method::Park).unwrap();
        assert!(
            c.warnings.iter().any(|w| w.contains("turned by at most")),
            "{:?}",
            c.warnings
        );
        let (r, t) = errors(c.hand_eye.mount_from_camera(), &tool_from_camera);
        assert!(r < 1e-9 && t < 1e-9);
    }

    /// Two of ten samples with a target pose 5 degrees and 3 cm off (a misdetection):
    /// both are left out with their reason, and the result is as good as without them.
    #[test]
    fn screening_leaves_out_samples_that_disagree() {
        let mut rng = ChaCha8Rng::seed_from_u64(5);
        for setup in [Setup::EyeInHand, Setup::EyeToHand] {
            for _ in 0..10 {
                let (clean, mount_from_camera, _) =
                    session(&mut rng, setup, (0.0005, 0.0005), (0.0002, 0.0002));
                let mut samples = clean.clone();
                let off =
                    Isometry3::new(Vector3::new(0.03, 0.0, 0.0), Vector3::new(0.0, 0.087, 0.0));
                for bad in [2, 7] {
                    samples[bad].camera_from_target = off * samples[bad].camera_from_target;
                }
                for method in Method::ALL {
                    let (c, rejected) = calibrate_screened(setup, &samples, method).unwrap();
                    let mut indices: Vec<usize> = rejected.iter().map(|r| r.index).collect();
                    indices.sort_unstable();
                    assert_eq!(indices, vec![2, 7], "{setup:?} {method:?}: {rejected:?}");
                    assert!(rejected.iter().all(|r| r.reason.contains("disagrees")));
                    let kept: Vec<Sample> = clean
                        .iter()
                        .enumerate()
                        .filter(|(i, _)| ![2, 7].contains(i))
                        .map(|(_, s)| s.clone())
                        .collect();
                    let reference = calibrate(setup, &kept, method).unwrap();
                    let (r, t) = errors(
                        c.hand_eye.mount_from_camera(),
                        reference.hand_eye.mount_from_camera(),
                    );
                    assert!(
                        r < 1e-12 && t < 1e-12,
                        "{setup:?} {method:?}: {r} rad, {t} m"
                    );
                    let (r, t) = errors(c.hand_eye.mount_from_camera(), &mount_from_camera);
                    assert!(r < 0.01 && t < 0.02, "{setup:?} {method:?}: {r} rad, {t} m");
                }
                // Clean samples: nothing left out.
                let (_, rejected) = calibrate_screened(setup, &clean, Method::Park).unwrap();
                assert!(rejected.is_empty(), "{setup:?}: {rejected:?}");
            }
        }
    }
}
