//! The kept samples on disk, so a session survives a restart: one small JSON file of
//! the target, the cameras with their image sizes, and per sample its stamp and each
//! camera's detected corners. It is written atomically (a crash leaves the previous
//! copy whole) after every change.

use std::path::{Path, PathBuf};

use nalgebra::Point2;
use serde::{Deserialize, Serialize};
use stereocal_msgs::atomic_file;
use stereocal_msgs::builtin_interfaces::Time;
use stereocal_vision::board::{Detection, Target};

use super::SessionError;

/// Name of the store file inside a session's folder.
pub const STORE_FILE: &str = "calibration_session.json";

/// Format tag written in every store, checked on load.
const FORMAT: &str = "stereocal calibration session";

/// Version of the store's layout.
const VERSION: u32 = 1;

/// One kept sample: a synchronized frame with the board found in every camera.
#[derive(Clone, Debug, PartialEq)]
pub struct Sample {
    /// The frame's header stamp.
    pub stamp: Time,
    /// The board found in each camera, in the session's camera order.
    pub detections: Vec<Detection>,
}

/// Everything a session keeps.
#[derive(Clone, Debug, PartialEq)]
pub struct StoredSession {
    /// The target.
    pub target: Target,
    /// Camera names, in offer order.
    pub cameras: Vec<String>,
    /// Image size (width, height) of each camera; `None` before the first sample.
    pub image_sizes: Option<Vec<(usize, usize)>>,
    /// The kept samples, in the order they were kept.
    pub samples: Vec<Sample>,
}

#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct File {
    format: String,
    version: u32,
    target: Target,
    cameras: Vec<String>,
    #[serde(default)]
    image_sizes: Option<Vec<[usize; 2]>>,
    samples: Vec<FileSample>,
}

#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct FileSample {
    stamp: Time,
    views: Vec<FileView>,
}

#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct FileView {
    ids: Vec<usize>,
    corners: Vec<[f64; 2]>,
    square_px: f64,
}

/// The store file of the session kept in `dir`.
pub fn store_path(dir: &Path) -> PathBuf {
    dir.join(STORE_FILE)
}

/// Reads the store at `path`: `None` when there is none; an error naming the file when
/// it cannot be read or is damaged (not the store's JSON, an unknown version, views that
/// do not match the cameras, corners and ids of different lengths, non-finite corners).
pub fn load(path: &Path) -> Result<Option<StoredSession>, SessionError> {
    let bytes = match std::fs::read(path) {
        Ok(bytes) => bytes,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(None),
        Err(e) => {
            return Err(SessionError::StoreRead {
                path: path.to_path_buf(),
                message: e.to_string(),
            });
        }
    };
    let damaged = |message: String| SessionError::StoreDamaged {
        path: path.to_path_buf(),
        message,
    };
    let file: File = serde_json::from_slice(&bytes).map_err(|e| damaged(e.to_string()))?;
    if file.format != FORMAT || file.version != VERSION {
        return Err(damaged(format!(
            "expected format \"{FORMAT}\" version {VERSION}, found \"{}\" version {}",
            file.format, file.version
        )));
    }
    file.target.validate().map_err(|e| damaged(e.to_string()))?;
    if let Some(sizes) = &file.image_sizes
        && sizes.len() != file.cameras.len()
    {
        return Err(damaged(format!(
            "{} image sizes for {} cameras",
            sizes.len(),
            file.cameras.len()
        )));
    }
    if file.image_sizes.is_none() && !file.samples.is_empty() {
        return Err(damaged("samples without image sizes".to_owned()));
    }
    let corner_count = file.target.object_points().len();
    let mut samples = Vec::with_capacity(file.samples.len());
    for (index, sample) in file.samples.into_iter().enumerate() {
        if sample.views.len() != file.cameras.len() {
            return Err(damaged(format!(
                "sample {index} has {} views for {} cameras",
                sample.views.len(),
                file.cameras.len()
            )));
        }
        let mut detections = Vec::with_capacity(sample.views.len());
        for view in sample.views {
            let valid = view.ids.len() == view.corners.len()
                && !view.ids.is_empty()
                && view.ids.iter().all(|&id| id < corner_count)
                && view.corners.iter().flatten().all(|c| c.is_finite())
                && view.square_px.is_finite();
            if !valid {
                return Err(damaged(format!(
                    "sample {index} has a view whose corners do not match its ids or the target"
                )));
            }
            detections.push(Detection {
                corners: view
                    .corners
                    .iter()
                    .map(|c| Point2::new(c[0], c[1]))
                    .collect(),
                ids: view.ids,
                square_px: view.square_px,
            });
        }
        samples.push(Sample {
            stamp: sample.stamp,
            detections,
        });
    }
    Ok(Some(StoredSession {
        target: file.target,
        cameras: file.cameras,
        image_sizes: file
            .image_sizes
            .map(|sizes| sizes.into_iter().map(|[w, h]| (w, h)).collect()),
        samples,
    }))
}

/// Writes `session` to `path` atomically.
pub fn save(path: &Path, session: &StoredSession) -> Result<(), SessionError> {
    let file = File {
        format: FORMAT.to_owned(),
        version: VERSION,
        target: session.target.clone(),
        cameras: session.cameras.clone(),
        image_sizes: session
            .image_sizes
            .as_ref()
            .map(|sizes| sizes.iter().map(|&(w, h)| [w, h]).collect()),
        samples: session
            .samples
            .iter()
            .map(|sample| FileSample {
                stamp: sample.stamp,
                views: sample
                    .detections
                    .iter()
                    .map(|d| FileView {
                        ids: d.ids.clone(),
                        corners: d.corners.iter().map(|c| [c.x, c.y]).collect(),
                        square_px: d.square_px,
                    })
                    .collect(),
            })
            .collect(),
    };
    let write_error = |message: String| SessionError::StoreWrite {
        path: path.to_path_buf(),
        message,
    };
    let bytes = serde_json::to_vec(&file).map_err(|e| write_error(e.to_string()))?;
    atomic_file::write(path, &bytes).map_err(|e| write_error(e.to_string()))
}

#[cfg(test)]
mod tests {
    use stereocal_vision::board::Chessboard;

    use super::*;

    fn session() -> StoredSession {
        let target = Target::Chessboard(Chessboard::new(3, 2, 0.03).unwrap());
        let detection = |dx: f64| Detection {
            corners: (0..6)
                .map(|k| Point2::new(10.25 + dx + k as f64, 20.5 + 1.0 / 3.0))
                .collect(),
            ids: (0..6).collect(),
            square_px: 12.5,
        };
        StoredSession {
            target,
            cameras: vec!["left".to_owned(), "right".to_owned()],
            image_sizes: Some(vec![(640, 480), (640, 480)]),
            samples: vec![
                Sample {
                    stamp: Time {
                        sec: 10,
                        nanosec: 5,
                    },
                    detections: vec![detection(0.0), detection(-30.0)],
                },
                Sample {
                    stamp: Time {
                        sec: 11,
                        nanosec: 7,
                    },
                    detections: vec![detection(100.0), detection(70.0)],
                },
            ],
        }
    }

    #[test]
    fn round_trips_exactly() {
        let dir = tempfile::tempdir().unwrap();
        let path = store_path(dir.path());
        assert_eq!(load(&path).unwrap(), None);
        let stored = session();
        save(&path, &stored).unwrap();
        assert_eq!(load(&path).unwrap(), Some(stored));
    }

    #[test]
    fn damaged_stores_are_errors_naming_the_file() {
        let dir = tempfile::tempdir().unwrap();
        let path = store_path(dir.path());
        save(&path, &session()).unwrap();
        let good = std::fs::read_to_string(&path).unwrap();
        let damaged = [
            good[..good.len() / 2].to_owned(),
            String::new(),
            good.replace("\"version\":1", "\"version\":9"),
            good.replace("\"ids\":[0,1,2,3,4,5]", "\"ids\":[0,1,2,3,4,99]"),
            good.replace("\"ids\":[0,1,2,3,4,5]", "\"ids\":[0,1]"),
            good.replace("[[640,480],[640,480]]", "[[640,480]]"),
            good.replace("\"cameras\":[\"left\",\"right\"]", "\"cameras\":[\"left\"]"),
        ];
        for text in damaged {
            assert_ne!(text, good);
            std::fs::write(&path, &text).unwrap();
            let error = load(&path).unwrap_err();
            assert!(
                matches!(error, SessionError::StoreDamaged { .. }),
                "{error:?}"
            );
            assert!(
                error.to_string().contains(&path.display().to_string()),
                "{error}"
            );
        }
    }
}
