//! Hand-eye accuracy over a sweep of robot noise and corner noise: for each pair, many
//! synthetic sessions (`synth::corner_session`: 15 views of a 9x6 board through a
//! distorted 1024x768 camera), solved by the five AX = XB methods and by the joint
//! refinement started from Daniilidis. Not a timing bench: prints, per setup and noise
//! pair, the median error against the truth of the best classic method (the one whose
//! median is least) and of the refinement, as a markdown table.
//!
//! ```text
//! cargo bench -p stereocal-vision --bench handeye_sweep [-- --sessions N]
//! ```
//!
//! Without `--bench` (as `cargo test --benches` runs it) each cell has 3 sessions.
// A benchmark program: a failure is printed and ends the run.
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

use nalgebra::Isometry3;
use rayon::prelude::*;
use stereocal_vision::handeye::{Method, RefineOptions, Setup, calibrate, refine};
use stereocal_vision::synth::{CornerSessionSpec, RobotNoise, corner_session};

/// Robot noise: rotation degrees, translation millimetres.
const ROBOT_NOISE: [(f64, f64); 4] = [(0.0, 0.0), (0.05, 0.3), (0.1, 0.6), (0.2, 1.2)];
/// Corner noise, pixels.
const PIXEL_NOISE: [f64; 3] = [0.1, 0.3, 1.0];

/// Rotation (degrees) and translation (millimetres) errors.
type Errors = (f64, f64);

/// One session's outcome: each classic method's errors, then the refinement's.
struct Outcome {
    classic: Vec<Errors>,
    refined: Errors,
}

fn errors(found: &Isometry3<f64>, truth: &Isometry3<f64>) -> Errors {
    (
        found.rotation.angle_to(&truth.rotation).to_degrees(),
        (found.translation.vector - truth.translation.vector).norm() * 1e3,
    )
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let bench = args.iter().any(|a| a == "--bench");
    let sessions = args
        .iter()
        .position(|a| a == "--sessions")
        .and_then(|i| args.get(i + 1))
        .map(|v| v.parse().expect("--sessions N"))
        .unwrap_or(if bench { 50 } else { 3 });
    println!(
        "hand-eye noise sweep: {sessions} sessions of 15 samples per cell; median error \
         against the truth (rotation deg, translation mm)\n"
    );
    println!(
        "| setup | robot noise | corner noise | best classic method | its error | refined | refined / best |"
    );
    println!("|---|---|---|---|---|---|---|");
    for setup in [Setup::EyeInHand, Setup::EyeToHand] {
        for (robot_deg, robot_mm) in ROBOT_NOISE {
            for pixel in PIXEL_NOISE {
                let outcomes: Vec<Outcome> = (0..sessions as u64)
                    .into_par_iter()
                    .map(|seed| {
                        let s = corner_session(&CornerSessionSpec {
                            setup,
                            samples: 15,
                            pixel_noise_px: pixel,
                            robot_noise: RobotNoise {
                                rotation_rad: robot_deg.to_radians(),
                                translation_m: robot_mm * 1e-3,
                            },
                            seed: 1000 + seed,
                        });
                        let classic = Method::ALL[..5]
                            .iter()
                            .map(|&m| {
                                let c = calibrate(setup, &s.samples, m).unwrap();
                                errors(c.hand_eye.mount_from_camera(), &s.mount_from_camera)
                            })
                            .collect();
                        let start = calibrate(setup, &s.samples, Method::Daniilidis).unwrap();
                        // The refinement weighs the measurements by the noise they have
                        // (a floor keeps the noise-free robot from an infinite weight).
                        let options = RefineOptions {
                            pixel_noise_px: pixel,
                            robot_rotation_noise_rad: robot_deg.max(0.001).to_radians(),
                            robot_translation_noise_m: robot_mm.max(0.01) * 1e-3,
                        };
                        let r = refine(
                            &s.camera,
                            &s.samples,
                            &s.observations,
                            &start.hand_eye,
                            &options,
                        )
                        .unwrap();
                        Outcome {
                            classic,
                            refined: errors(r.hand_eye.mount_from_camera(), &s.mount_from_camera),
                        }
                    })
                    .collect();
                let (best_method, best) = Method::ALL[..5]
                    .iter()
                    .enumerate()
                    .map(|(k, m)| {
                        let r = median(outcomes.iter().map(|o| o.classic[k].0).collect());
                        let t = median(outcomes.iter().map(|o| o.classic[k].1).collect());
                        (m.name(), (r, t))
                    })
                    .min_by(|a, b| {
                        (a.1.0 / 0.01 + a.1.1 / 0.1).total_cmp(&(b.1.0 / 0.01 + b.1.1 / 0.1))
                    })
                    .unwrap();
                let refined = (
                    median(outcomes.iter().map(|o| o.refined.0).collect()),
                    median(outcomes.iter().map(|o| o.refined.1).collect()),
                );
                println!(
                    "| {} | {robot_deg} deg, {robot_mm} mm | {pixel} px | {best_method} | {:.4} deg, {:.3} mm | {:.4} deg, {:.3} mm | {:.2}, {:.2} |",
                    setup.name(),
                    best.0,
                    best.1,
                    refined.0,
                    refined.1,
                    refined.0 / best.0,
                    refined.1 / best.1
                );
            }
        }
    }
}
