//! Seeded synthetic scenes for the tests that measure against rendered frames: one
//! camera, a board in front of it at sampled poses, rendered over a seeded background.

use std::sync::Arc;

use nalgebra::{Isometry3, UnitQuaternion};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use stereocal_vision::camera::{CameraModel, DistortionModel};
use stereocal_vision::image::Image;
use stereocal_vision::synth::{
    Background, Chessboard, Coverage, Photometry, PixelFormat, PoseRanges, PoseSampler, Renderer,
    Shot, synthetic_camera,
};

/// A realistic camera at its worst: defocused, noisy, with light falling unevenly
/// on the board and strong vignetting.
pub fn hard_photometry() -> Photometry {
    Photometry {
        defocus_sigma: 1.8,
        read_noise: 4.0,
        shot_noise: 4.0,
        board_light_gradient: [0.5, -0.4],
        vignetting: 0.5,
        ..Photometry::realistic()
    }
}

/// A synthetic camera looking at a board: the camera, the board, its renderer and
/// the sampled `camera_from_target` poses.
pub struct Scene {
    pub camera: CameraModel,
    pub board: Chessboard,
    pub renderer: Renderer,
    pub poses: Vec<Isometry3<f64>>,
}

impl Scene {
    /// A `width`x`height` camera of `model` drawn from `seed`, and `views` poses of
    /// `board` sampled for `coverage` from the same generator; the background is
    /// seeded with `seed` too.
    pub fn new(
        seed: u64,
        model: DistortionModel,
        width: u32,
        height: u32,
        board: Chessboard,
        coverage: Coverage,
        views: usize,
    ) -> Scene {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let camera = synthetic_camera(model, width, height, &mut rng);
        let renderer = Renderer::new(
            camera.clone(),
            board,
            Arc::new(Background::new(seed)),
            UnitQuaternion::identity(),
        );
        let sampler = PoseSampler::new(
            vec![(&camera, Isometry3::identity())],
            board,
            PoseRanges::default(),
        );
        let poses = (0..views)
            .map(|index| sampler.sample(&mut rng, index, coverage).unwrap())
            .collect();
        Scene {
            camera,
            board,
            renderer,
            poses,
        }
    }

    /// [`Scene::new`] with a 1280x720 plumb-bob camera, the detection tests' camera.
    pub fn hd(seed: u64, board: Chessboard, coverage: Coverage, views: usize) -> Scene {
        Scene::new(
            seed,
            DistortionModel::PlumbBob,
            1280,
            720,
            board,
            coverage,
            views,
        )
    }

    /// The Mono8 view of the board at `pose`, 8x8 supersampled, with noise from
    /// `noise_seed`.
    pub fn render(&self, pose: &Isometry3<f64>, photometry: Photometry, noise_seed: u64) -> Image {
        self.render_supersampled(pose, photometry, 8, noise_seed)
    }

    /// The Mono8 view of the board at `pose` with `supersampling`x`supersampling`
    /// samples per pixel and noise from `noise_seed`.
    pub fn render_supersampled(
        &self,
        pose: &Isometry3<f64>,
        photometry: Photometry,
        supersampling: usize,
        noise_seed: u64,
    ) -> Image {
        self.renderer.render(&Shot {
            camera_from_target: *pose,
            motion_to: None,
            photometry,
            supersampling,
            format: PixelFormat::Mono8,
            noise_seed,
        })
    }
}
