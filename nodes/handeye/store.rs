//! Hand-eye samples kept on disk the moment they are taken: one YAML file per sample in
//! a state directory, written atomically, read back at start-up. A killed session
//! restarts with every sample; a damaged file is named and left in place, never
//! deleted; removing or resetting moves files aside instead of deleting them.

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};
use stereocal_msgs::atomic_file;
use stereocal_msgs::sensor_msgs::CameraInfo;
use thiserror::Error;

use crate::pose::record::TransformRecord;

/// Prefix and suffix of a sample's file name: `sample-000001.yaml`.
const PREFIX: &str = "sample-";
const SUFFIX: &str = ".yaml";
/// Where removed samples go, inside the state directory.
const REMOVED: &str = "removed";

/// The target's corners a sample's pose was measured from.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct StoredCorners {
    /// Points in the target frame, metres.
    pub target_points: Vec<[f64; 3]>,
    /// Their pixels, pixel centres at integer coordinates.
    pub pixels: Vec<[f64; 2]>,
    /// The calibration of the camera whose pixels they are.
    pub camera_info: CameraInfo,
}

/// One sample as stored.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct StoredSample {
    /// Stamp of the target pose (the image), seconds.
    pub stamp: f64,
    /// The robot's pose at that stamp.
    pub base_from_tool: TransformRecord,
    /// The target's pose in the camera frame.
    pub camera_from_target: TransformRecord,
    /// The corners, when the pose was measured from an image.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub corners: Option<StoredCorners>,
}

/// A sample file that could not be read, left where it is.
#[derive(Clone, Debug, PartialEq)]
pub struct DamagedSample {
    /// The file.
    pub path: PathBuf,
    /// Why it could not be read.
    pub reason: String,
}

/// Why the store could not do what was asked.
#[derive(Debug, Error)]
pub enum StoreError {
    /// The state directory or a file in it could not be read or written.
    #[error("{path}: {source}")]
    Io {
        /// The path.
        path: PathBuf,
        /// The error.
        source: std::io::Error,
    },
    /// A sample could not be encoded.
    #[error("encoding a sample: {0}")]
    Encode(#[from] serde_yaml::Error),
    /// No sample has that index.
    #[error("no sample {index}: there are {count}")]
    NoSuchSample {
        /// The index asked for.
        index: usize,
        /// How many there are.
        count: usize,
    },
}

fn io_error(path: &Path) -> impl FnOnce(std::io::Error) -> StoreError + '_ {
    move |source| StoreError::Io {
        path: path.to_owned(),
        source,
    }
}

/// The samples of a session, in the order they were taken, each in its own file.
#[derive(Debug)]
pub struct SampleStore {
    dir: PathBuf,
    /// `(file number, sample)`, ascending.
    samples: Vec<(u64, StoredSample)>,
    next: u64,
}

impl SampleStore {
    /// Opens the state directory `dir` (creating it): every sample file in it, in the
    /// order taken, and the files that could not be read.
    pub fn open(dir: &Path) -> Result<(Self, Vec<DamagedSample>), StoreError> {
        std::fs::create_dir_all(dir).map_err(io_error(dir))?;
        let mut samples = Vec::new();
        let mut damaged = Vec::new();
        let mut next = 1;
        for entry in std::fs::read_dir(dir).map_err(io_error(dir))? {
            let path = entry.map_err(io_error(dir))?.path();
            let Some(number) = file_number(&path) else {
                continue;
            };
            next = next.max(number + 1);
            let read = std::fs::read_to_string(&path)
                .map_err(|e| e.to_string())
                .and_then(|text| {
                    serde_yaml::from_str::<StoredSample>(&text).map_err(|e| e.to_string())
                });
            match read {
                Ok(sample) => samples.push((number, sample)),
                Err(reason) => damaged.push(DamagedSample { path, reason }),
            }
        }
        samples.sort_by_key(|(number, _)| *number);
        damaged.sort_by(|a, b| a.path.cmp(&b.path));
        let store = Self {
            dir: dir.to_owned(),
            samples,
            next,
        };
        Ok((store, damaged))
    }

    /// The samples, in the order taken.
    pub fn samples(&self) -> impl Iterator<Item = &StoredSample> {
        self.samples.iter().map(|(_, s)| s)
    }

    /// Number of samples.
    pub fn len(&self) -> usize {
        self.samples.len()
    }

    /// Whether there are none.
    pub fn is_empty(&self) -> bool {
        self.samples.is_empty()
    }

    /// Keeps `sample`: its file is written (atomically) before this returns. Returns
    /// its index.
    pub fn take(&mut self, sample: StoredSample) -> Result<usize, StoreError> {
        let path = self.path_of(self.next);
        let text = serde_yaml::to_string(&sample)?;
        atomic_file::write(&path, text.as_bytes()).map_err(io_error(&path))?;
        self.samples.push((self.next, sample));
        self.next += 1;
        Ok(self.samples.len() - 1)
    }

    /// Removes the sample at `index`: its file is moved to `removed/` in the state
    /// directory, not deleted.
    pub fn remove(&mut self, index: usize) -> Result<StoredSample, StoreError> {
        if index >= self.samples.len() {
            return Err(StoreError::NoSuchSample {
                index,
                count: self.samples.len(),
            });
        }
        let number = self.samples[index].0;
        self.move_aside(number, REMOVED)?;
        Ok(self.samples.remove(index).1)
    }

    /// Removes every sample, their files moved to `reset-N/` (N counting resets) in
    /// the state directory. Returns how many there were.
    pub fn reset(&mut self) -> Result<usize, StoreError> {
        let mut n = 1;
        while self.dir.join(format!("reset-{n}")).exists() {
            n += 1;
        }
        let aside = format!("reset-{n}");
        let numbers: Vec<u64> = self.samples.iter().map(|(number, _)| *number).collect();
        for number in numbers {
            self.move_aside(number, &aside)?;
        }
        Ok(std::mem::take(&mut self.samples).len())
    }

    fn path_of(&self, number: u64) -> PathBuf {
        self.dir.join(format!("{PREFIX}{number:06}{SUFFIX}"))
    }

    fn move_aside(&self, number: u64, folder: &str) -> Result<(), StoreError> {
        let aside = self.dir.join(folder);
        std::fs::create_dir_all(&aside).map_err(io_error(&aside))?;
        let from = self.path_of(number);
        let to = aside.join(format!("{PREFIX}{number:06}{SUFFIX}"));
        std::fs::rename(&from, &to).map_err(io_error(&from))
    }
}

/// The number of a sample file's name, `None` for any other file.
fn file_number(path: &Path) -> Option<u64> {
    let name = path.file_name()?.to_str()?;
    name.strip_prefix(PREFIX)?
        .strip_suffix(SUFFIX)?
        .parse()
        .ok()
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{Isometry3, Vector3};

    fn sample(stamp: f64) -> StoredSample {
        let pose = Isometry3::new(Vector3::new(stamp, 0.1, 0.2), Vector3::new(0.0, 0.3, 0.0));
        StoredSample {
            stamp,
            base_from_tool: TransformRecord::new(&pose),
            camera_from_target: TransformRecord::new(&pose.inverse()),
            corners: Some(StoredCorners {
                target_points: vec![[0.0, 0.0, 0.0], [0.03, 0.0, 0.0]],
                pixels: vec![[512.5, 380.25], [540.0, 381.0]],
                camera_info: CameraInfo {
                    width: 1024,
                    height: 768,
                    ..CameraInfo::default()
                },
            }),
        }
    }

    #[test]
    fn samples_survive_a_restart_and_nothing_is_deleted() {
        let dir = tempfile::tempdir().unwrap();
        let state = dir.path().join("state");
        let (mut store, damaged) = SampleStore::open(&state).unwrap();
        assert!(store.is_empty() && damaged.is_empty());
        for stamp in [1.0, 2.0, 3.0] {
            store.take(sample(stamp)).unwrap();
        }
        // A killed process: a new store on the same directory has every sample, in order.
        let (mut store, damaged) = SampleStore::open(&state).unwrap();
        assert!(damaged.is_empty());
        let stamps: Vec<f64> = store.samples().map(|s| s.stamp).collect();
        assert_eq!(stamps, [1.0, 2.0, 3.0]);
        assert_eq!(store.samples().next(), Some(&sample(1.0)));

        // A damaged file is named, left in place, and the others are kept.
        std::fs::write(state.join("sample-000002.yaml"), "stamp: [not a number").unwrap();
        let (store_after, damaged) = SampleStore::open(&state).unwrap();
        assert_eq!(damaged.len(), 1);
        assert!(damaged[0].path.ends_with("sample-000002.yaml"));
        assert!(state.join("sample-000002.yaml").exists());
        assert_eq!(store_after.len(), 2);

        // Removing moves the file aside; a new sample never reuses a number.
        let removed = store.remove(0).unwrap();
        assert_eq!(removed.stamp, 1.0);
        assert!(state.join("removed/sample-000001.yaml").exists());
        assert!(!state.join("sample-000001.yaml").exists());
        assert!(matches!(
            store.remove(5),
            Err(StoreError::NoSuchSample { index: 5, count: 2 })
        ));
        store.take(sample(4.0)).unwrap();
        assert!(state.join("sample-000004.yaml").exists());

        // Resetting moves every file aside.
        assert_eq!(store.reset().unwrap(), 3);
        assert!(store.is_empty());
        assert!(state.join("reset-1/sample-000004.yaml").exists());
        let (store, _) = SampleStore::open(&state).unwrap();
        assert!(store.is_empty());
    }
}
