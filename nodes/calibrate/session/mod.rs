//! A live calibration session: frames are offered one at a time (mono, or a
//! synchronized stereo pair); each is judged as ROS camera_calibration judges it (the
//! board found in every camera, whole for a chessboard or in part for a ChArUco board,
//! not moving, sharp, and adding coverage), the kept samples are stored on disk after
//! every change, and the session calibrates from them on request. `calibrate_node`
//! drives it; tests drive it directly.

mod annotate;
mod store;

use std::path::{Path, PathBuf};

use rayon::prelude::*;
use serde::Serialize;
use stereocal_msgs::builtin_interfaces::Time;
use stereocal_vision::board::{BoardError, Detection, Gray, Target, TargetDetector, detector_for};
use stereocal_vision::calib::quality::{
    ENOUGH_SAMPLES, EdgeLayout, FrameChecks, MONO_RANGES, STEREO_RANGES, SampleParams, is_new,
    progress, sample_params,
};
use stereocal_vision::camera::DistortionModel;
use stereocal_vision::image::Image;
use thiserror::Error;

use crate::calibrate::stage::{
    CalibrationOutcome, CalibrationStageError, CameraFrames, Frame, FrameCorners, calibrate_pair,
    calibrate_target_camera,
};

pub use annotate::annotate;
pub use store::{STORE_FILE, Sample, store_path};

/// How a session judges frames.
#[derive(Clone, Debug, PartialEq)]
pub struct SessionConfig {
    /// The calibration target.
    pub target: Target,
    /// One camera name (mono) or ["left", "right"] (stereo), in the order images are offered.
    pub cameras: Vec<String>,
    /// Lens distortion model to calibrate.
    pub model: DistortionModel,
    /// The sharpness and motion checks a frame must pass (the offline command applies
    /// the same); board speed is measured in the first camera.
    pub checks: FrameChecks,
}

impl SessionConfig {
    /// A configuration with the default [`FrameChecks`].
    pub fn new(target: Target, cameras: Vec<String>, model: DistortionModel) -> Self {
        Self {
            target,
            cameras,
            model,
            checks: FrameChecks::default(),
        }
    }
}

/// Why a session could not open, judge a frame or store its samples. Each message says
/// what to do.
#[derive(Debug, Error)]
pub enum SessionError {
    /// The configuration cannot be used.
    #[error("calibration session: {0}")]
    Config(String),
    /// The store exists but cannot be read.
    #[error("cannot read the calibration session store {path}: {message}")]
    StoreRead {
        /// The store file.
        path: PathBuf,
        /// What went wrong.
        message: String,
    },
    /// The store is not a session store, or is damaged.
    #[error(
        "the calibration session store {path} is damaged: {message}; delete it to start a new session, or choose another state_dir"
    )]
    StoreDamaged {
        /// The store file.
        path: PathBuf,
        /// What is wrong with it.
        message: String,
    },
    /// The store holds another session.
    #[error(
        "the calibration session store {path} holds samples of {stored}, not of {configured}: reset the session (delete the file) or choose another state_dir"
    )]
    StoreMismatch {
        /// The store file.
        path: PathBuf,
        /// The stored target and cameras.
        stored: String,
        /// The configured target and cameras.
        configured: String,
    },
    /// The store cannot be written.
    #[error("cannot write the calibration session store {path}: {message}")]
    StoreWrite {
        /// The store file.
        path: PathBuf,
        /// What went wrong.
        message: String,
    },
    /// A frame came with the wrong number of images.
    #[error(
        "offered {offered} images for cameras {cameras:?}: expected one image per camera, in that order"
    )]
    ImageCount {
        /// Images offered.
        offered: usize,
        /// The session's cameras.
        cameras: Vec<String>,
    },
    /// An image is malformed.
    #[error("camera {camera}: {source}")]
    Image {
        /// The camera.
        camera: String,
        /// What is wrong with the image.
        source: BoardError,
    },
}

/// What the session made of an offered frame.
#[derive(Clone, Debug, PartialEq)]
pub enum Verdict {
    /// Kept as a new sample (and stored).
    Added,
    /// Usable, but too close to a kept sample to add coverage.
    NotNew,
    /// Not usable; the reason says what to do.
    Refused(String),
}

/// The verdict on an offered frame, with what was detected in each camera (in camera
/// order; `None` where the board was not found).
#[derive(Clone, Debug, PartialEq)]
pub struct Offer {
    /// The verdict.
    pub verdict: Verdict,
    /// The board found in each camera.
    pub detections: Vec<Option<Detection>>,
}

/// Coverage of one camera, as camera_calibration's progress bars, each in `[0, 1]`.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct CameraCoverage {
    /// The camera.
    pub name: String,
    /// Horizontal spread of the kept views.
    pub x: f64,
    /// Vertical spread.
    pub y: f64,
    /// Largest board size.
    pub size: f64,
    /// Largest skew (tilt).
    pub skew: f64,
}

/// Coverage per camera as camera_calibration's progress bars (x, y, size, skew each in
/// [0, 1]), the number of samples, and whether calibration can start
/// (camera_calibration's goodenough: every bar full, or [`ENOUGH_SAMPLES`] samples).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Progress {
    /// Coverage per camera, in camera order.
    pub cameras: Vec<CameraCoverage>,
    /// Samples kept.
    pub samples: usize,
    /// Whether calibration can start.
    pub ready: bool,
}

impl Progress {
    /// One line for a log or a status topic:
    /// `12 samples; left: x 80% y 65% size 40% skew 30%; right: ...; collecting`.
    pub fn status_line(&self) -> String {
        let mut line = format!(
            "{} sample{}",
            self.samples,
            if self.samples == 1 { "" } else { "s" }
        );
        for camera in &self.cameras {
            line.push_str(&format!(
                "; {}: x {:.0}% y {:.0}% size {:.0}% skew {:.0}%",
                camera.name,
                camera.x * 100.0,
                camera.y * 100.0,
                camera.size * 100.0,
                camera.skew * 100.0
            ));
        }
        line.push_str(if self.ready {
            "; ready to calibrate"
        } else {
            "; collecting: move the board to fill the bars"
        });
        line
    }

    /// The progress as JSON:
    /// `{"samples": n, "ready": b, "cameras": [{"name", "x", "y", "size", "skew"}]}`.
    pub fn to_json(&self) -> serde_json::Value {
        serde_json::to_value(self).unwrap_or(serde_json::Value::Null)
    }
}

/// A kept sample with its coverage parameters per camera.
#[derive(Clone, Debug)]
struct Kept {
    sample: Sample,
    params: Vec<SampleParams>,
}

/// A calibration session: the kept samples of one target seen by one camera or a
/// stereo pair, stored in a folder.
pub struct CalibrationSession {
    config: SessionConfig,
    layout: EdgeLayout,
    detector: Box<dyn TargetDetector + Send + Sync>,
    store_path: PathBuf,
    image_sizes: Option<Vec<(usize, usize)>>,
    kept: Vec<Kept>,
    previous: Option<(Time, Vec<Option<Detection>>)>,
}

impl std::fmt::Debug for CalibrationSession {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("CalibrationSession")
            .field("config", &self.config)
            .field("store_path", &self.store_path)
            .field("samples", &self.kept.len())
            .finish_non_exhaustive()
    }
}

impl CalibrationSession {
    /// Opens (creating) the session stored in `store_dir`, loading the samples an earlier
    /// run saved there; an error if the store holds another target/cameras (says to reset
    /// or choose another state_dir), never silently overwritten.
    pub fn open(config: SessionConfig, store_dir: &Path) -> Result<Self, SessionError> {
        if config.cameras.is_empty() || config.cameras.len() > 2 {
            return Err(SessionError::Config(format!(
                "{} cameras {:?}: expected one camera (mono) or two (stereo: left, right)",
                config.cameras.len(),
                config.cameras
            )));
        }
        let detector =
            detector_for(&config.target).map_err(|e| SessionError::Config(e.to_string()))?;
        let store_path = store_path(store_dir);
        let mut session = Self {
            layout: EdgeLayout::of(&config.target),
            detector,
            store_path,
            image_sizes: None,
            kept: Vec::new(),
            previous: None,
            config,
        };
        if let Some(stored) = store::load(&session.store_path)? {
            if stored.target != session.config.target || stored.cameras != session.config.cameras {
                return Err(SessionError::StoreMismatch {
                    path: session.store_path.clone(),
                    stored: describe(&stored.target, &stored.cameras),
                    configured: describe(&session.config.target, &session.config.cameras),
                });
            }
            session.image_sizes = stored.image_sizes;
            for sample in stored.samples {
                let params = session.params(&sample.detections).ok_or_else(|| {
                    SessionError::StoreDamaged {
                        path: session.store_path.clone(),
                        message: format!(
                            "the sample at {}.{:09} s does not span a board",
                            sample.stamp.sec, sample.stamp.nanosec
                        ),
                    }
                })?;
                session.kept.push(Kept { sample, params });
            }
        }
        Ok(session)
    }

    /// The session's configuration.
    pub fn config(&self) -> &SessionConfig {
        &self.config
    }

    /// The store file.
    pub fn store_file(&self) -> &Path {
        &self.store_path
    }

    /// Judges one synchronized frame: one image per camera in `cameras` order. Detects the
    /// target, refuses blurred/moving/partial frames, keeps it when it adds coverage (ROS
    /// camera_calibration's is_good_sample), and on Added saves the samples atomically
    /// before returning.
    ///
    /// Checks, in order: the board is found in every camera (a chessboard whole, a
    /// ChArUco board at least in part); the images have the size of the kept samples'
    /// images; the [`FrameChecks`] of `checks` (board speed measured in the first
    /// camera, sharpness in every camera); its view (in the first camera, as
    /// camera_calibration judges a stereo pair by its left view) is farther than
    /// [`NOVELTY_DISTANCE`](stereocal_vision::calib::quality::NOVELTY_DISTANCE) from every
    /// kept one.
    pub fn offer(&mut self, stamp: Time, images: &[&Image]) -> Result<Offer, SessionError> {
        if images.len() != self.config.cameras.len() {
            return Err(SessionError::ImageCount {
                offered: images.len(),
                cameras: self.config.cameras.clone(),
            });
        }
        let grays = images
            .iter()
            .zip(&self.config.cameras)
            .map(|(image, camera)| {
                Gray::from_image(image).map_err(|source| SessionError::Image {
                    camera: camera.clone(),
                    source,
                })
            })
            .collect::<Result<Vec<_>, _>>()?;
        let detections: Vec<Option<Detection>> = grays
            .par_iter()
            .map(|gray| self.detector.detect_gray(gray))
            .collect();
        let previous = self.previous.replace((stamp, detections.clone()));
        let verdict = self.judge(stamp, &grays, &detections, previous)?;
        Ok(Offer {
            verdict,
            detections,
        })
    }

    fn judge(
        &mut self,
        stamp: Time,
        grays: &[Gray],
        detections: &[Option<Detection>],
        previous: Option<(Time, Vec<Option<Detection>>)>,
    ) -> Result<Verdict, SessionError> {
        let missing: Vec<&str> = self
            .config
            .cameras
            .iter()
            .zip(detections)
            .filter(|(_, d)| d.is_none())
            .map(|(name, _)| name.as_str())
            .collect();
        if !missing.is_empty() {
            let board = match &self.config.target {
                Target::Chessboard(b) => format!("whole {}x{} board", b.cols, b.rows),
                Target::Circles(_) | Target::Acircles(_) => {
                    format!("whole {}", self.config.target.describe())
                }
                target @ Target::Charuco(_) => target.describe(),
            };
            return Ok(Verdict::Refused(format!(
                "no {board} found in {}: keep the whole board in view{}, well lit and in focus, and hold it still",
                missing.join(" and "),
                if self.config.cameras.len() > 1 {
                    " of both cameras"
                } else {
                    ""
                }
            )));
        }
        let found: Vec<Detection> = detections.iter().flatten().cloned().collect();
        let sizes: Vec<(usize, usize)> = grays.iter().map(|g| (g.width, g.height)).collect();
        if let Some(kept) = &self.image_sizes
            && *kept != sizes
        {
            return Ok(Verdict::Refused(format!(
                "images are {} but the kept samples' are {}: reset the session to calibrate at the new size",
                sizes_text(&sizes),
                sizes_text(kept)
            )));
        }
        let checks = &self.config.checks;
        // Board speed is measured in the first camera, against the previous frame's.
        if let Some((before, Some(Some(earlier)))) = previous.as_ref().map(|(t, d)| (t, d.first()))
            && let Some(current) = found.first()
            && let Err(refusal) = checks.check_motion(earlier, current, stamp.seconds_since(before))
        {
            return Ok(Verdict::Refused(refusal.to_string()));
        }
        for ((gray, detection), camera) in grays.iter().zip(&found).zip(&self.config.cameras) {
            if let Err(refusal) = checks.check_sharpness(gray, detection, &self.layout) {
                return Ok(Verdict::Refused(format!("{camera}: {refusal}")));
            }
        }
        let Some(params) = self.params_at(&found, &sizes) else {
            return Ok(Verdict::Refused(
                "the board's outer corners do not span an area: detection failed".to_owned(),
            ));
        };
        let kept: Vec<SampleParams> = self.kept.iter().map(|k| k.params[0]).collect();
        if !is_new(&params[0], &kept) {
            return Ok(Verdict::NotNew);
        }
        self.kept.push(Kept {
            sample: Sample {
                stamp,
                detections: found,
            },
            params,
        });
        self.image_sizes = Some(sizes);
        if let Err(e) = self.save() {
            self.kept.pop();
            if self.kept.is_empty() {
                self.image_sizes = None;
            }
            return Err(e);
        }
        Ok(Verdict::Added)
    }

    /// The number of kept samples.
    pub fn sample_count(&self) -> usize {
        self.kept.len()
    }

    /// The kept samples, in the order they were kept.
    pub fn samples(&self) -> impl Iterator<Item = &Sample> {
        self.kept.iter().map(|k| &k.sample)
    }

    /// Coverage per camera, the number of samples and whether calibration can start.
    pub fn progress(&self) -> Progress {
        let ranges = if self.config.cameras.len() > 1 {
            &STEREO_RANGES
        } else {
            &MONO_RANGES
        };
        let cameras: Vec<CameraCoverage> = self
            .config
            .cameras
            .iter()
            .enumerate()
            .map(|(k, name)| {
                let params: Vec<SampleParams> = self.kept.iter().map(|s| s.params[k]).collect();
                let [x, y, size, skew] = progress(&params, ranges);
                CameraCoverage {
                    name: name.clone(),
                    x,
                    y,
                    size,
                    skew,
                }
            })
            .collect();
        let full = !self.kept.is_empty()
            && cameras
                .iter()
                .all(|c| [c.x, c.y, c.size, c.skew].iter().all(|&p| p >= 1.0));
        Progress {
            ready: self.kept.len() >= ENOUGH_SAMPLES || full,
            samples: self.kept.len(),
            cameras,
        }
    }

    /// Calibrates from the kept samples (mono or stereo via crate::calibrate::stage).
    pub fn calibrate(&self) -> Result<CalibrationOutcome, CalibrationStageError> {
        let frames: Vec<CameraFrames> = self
            .config
            .cameras
            .iter()
            .enumerate()
            .map(|(k, name)| {
                let (width, height) = self
                    .image_sizes
                    .as_ref()
                    .and_then(|s| s.get(k).copied())
                    .unwrap_or((0, 0));
                CameraFrames {
                    name: name.clone(),
                    width: width as u32,
                    height: height as u32,
                    frames: self
                        .kept
                        .iter()
                        .map(|kept| Frame {
                            stamp: kept.sample.stamp,
                            corners: FrameCorners::from_detection(
                                &kept.sample.detections[k],
                                &self.config.target,
                            ),
                        })
                        .collect(),
                }
            })
            .collect();
        match frames.as_slice() {
            [left, right] => calibrate_pair(left, right, self.config.model, &self.config.target),
            [camera] => calibrate_target_camera(camera, self.config.model, &self.config.target)
                .map(|(_, result)| CalibrationOutcome {
                    cameras: vec![result],
                    stereo: None,
                }),
            _ => Err(CalibrationStageError::NoBoardFound {
                camera: self.config.cameras.join(", "),
                frames: self.kept.len(),
            }),
        }
    }

    /// Forgets every sample (and the stored copy).
    pub fn reset(&mut self) -> Result<(), SessionError> {
        self.kept.clear();
        self.image_sizes = None;
        self.previous = None;
        self.save()
    }

    /// Writes the kept samples to the store.
    fn save(&self) -> Result<(), SessionError> {
        store::save(
            &self.store_path,
            &store::StoredSession {
                target: self.config.target.clone(),
                cameras: self.config.cameras.clone(),
                image_sizes: self.image_sizes.clone(),
                samples: self.kept.iter().map(|k| k.sample.clone()).collect(),
            },
        )
    }

    /// The coverage parameters of a sample's detections at the session's image sizes.
    fn params(&self, detections: &[Detection]) -> Option<Vec<SampleParams>> {
        self.params_at(detections, self.image_sizes.as_ref()?)
    }

    fn params_at(
        &self,
        detections: &[Detection],
        sizes: &[(usize, usize)],
    ) -> Option<Vec<SampleParams>> {
        if detections.len() != sizes.len() {
            return None;
        }
        detections
            .iter()
            .zip(sizes)
            .map(|(d, &(w, h))| {
                let (cols, rows) = self.layout.grid();
                sample_params(d, cols, rows, w, h)
            })
            .collect()
    }
}

fn describe(target: &Target, cameras: &[String]) -> String {
    let board = match target {
        Target::Chessboard(b) => format!(
            "a {}x{} chessboard of {} m squares",
            b.cols, b.rows, b.square_size
        ),
        Target::Charuco(b) => format!(
            "a {}x{} ChArUco board of {} m squares",
            b.squares_x, b.squares_y, b.square_size
        ),
        Target::Circles(g) | Target::Acircles(g) => {
            format!("a {} at a spacing of {} m", target.describe(), g.spacing)
        }
    };
    format!("{board} seen by {cameras:?}")
}

fn sizes_text(sizes: &[(usize, usize)]) -> String {
    sizes
        .iter()
        .map(|(w, h)| format!("{w}x{h}"))
        .collect::<Vec<_>>()
        .join(" and ")
}

#[cfg(test)]
mod tests {
    use nalgebra::Point2;
    use stereocal_vision::board::Chessboard;

    use super::*;

    /// A 3x3 board of `side` px squares, its first corner at `(x, y)`, rows sheared
    /// right by `shear` px each.
    fn board(x: f64, y: f64, side: f64, shear: f64) -> Detection {
        Detection {
            corners: (0..9)
                .map(|k| {
                    let (i, j) = ((k % 3) as f64, (k / 3) as f64);
                    Point2::new(x + side * i + shear * j, y + side * j)
                })
                .collect(),
            ids: (0..9).collect(),
            square_px: side,
        }
    }

    fn open_with(samples: Vec<Detection>) -> CalibrationSession {
        let dir = tempfile::tempdir().unwrap();
        let target = Target::Chessboard(Chessboard::new(3, 3, 0.05).unwrap());
        let config = SessionConfig::new(
            target.clone(),
            vec!["camera".to_owned()],
            DistortionModel::PlumbBob,
        );
        store::save(
            &store_path(dir.path()),
            &store::StoredSession {
                target,
                cameras: config.cameras.clone(),
                image_sizes: Some(vec![(640, 480)]),
                samples: samples
                    .into_iter()
                    .enumerate()
                    .map(|(k, d)| Sample {
                        stamp: Time {
                            sec: k as i32,
                            nanosec: 0,
                        },
                        detections: vec![d],
                    })
                    .collect(),
            },
        )
        .unwrap();
        CalibrationSession::open(config, dir.path()).unwrap()
    }

    #[test]
    fn ready_when_every_bar_is_full_or_with_enough_samples() {
        // Small boards in opposite corners span X and Y; a large one fills size; a
        // sheared one fills skew.
        let covering = vec![
            board(5.0, 5.0, 20.0, 0.0),
            board(590.0, 430.0, 20.0, 0.0),
            board(100.0, 60.0, 150.0, 0.0),
            board(200.0, 200.0, 40.0, 60.0),
        ];
        let session = open_with(covering.clone());
        let progress = session.progress();
        let c = &progress.cameras[0];
        assert_eq!([c.x, c.y, c.size, c.skew], [1.0; 4], "{progress:?}");
        assert!(progress.ready);
        assert!(progress.status_line().ends_with("ready to calibrate"));

        let session = open_with(covering[..3].to_vec());
        let progress = session.progress();
        assert!(
            progress.cameras[0].skew < 1.0 && !progress.ready,
            "{progress:?}"
        );

        // Many samples suffice whatever the coverage.
        let same: Vec<Detection> = (0..ENOUGH_SAMPLES)
            .map(|k| board(300.0 + k as f64 * 0.01, 200.0, 30.0, 0.0))
            .collect();
        let progress = open_with(same[..ENOUGH_SAMPLES - 1].to_vec()).progress();
        assert!(!progress.ready);
        let progress = open_with(same).progress();
        assert!(
            progress.ready && progress.cameras[0].x < 0.01,
            "{progress:?}"
        );
    }

    #[test]
    fn configurations_that_cannot_work_are_refused() {
        let dir = tempfile::tempdir().unwrap();
        let target = Target::Chessboard(Chessboard::new(3, 3, 0.05).unwrap());
        for cameras in [vec![], vec!["a".to_owned(), "b".to_owned(), "c".to_owned()]] {
            let config = SessionConfig::new(target.clone(), cameras, DistortionModel::PlumbBob);
            assert!(matches!(
                CalibrationSession::open(config, dir.path()),
                Err(SessionError::Config(_))
            ));
        }
        let config =
            SessionConfig::new(target, vec!["camera".to_owned()], DistortionModel::PlumbBob);
        let session = CalibrationSession::open(config, dir.path()).unwrap();
        assert!(matches!(
            session.calibrate(),
            Err(CalibrationStageError::NoBoardFound { frames: 0, .. })
        ));
    }
}
