//! camera_info_manager's part of camera_node: the calibration read from
//! `camera_info_url` (`file://` or `package://`, `${NAME}` and `${ROS_HOME}`
//! substituted, camera_info_manager's default when empty), an uncalibrated camera_info
//! of the captured size when there is none or it is for another size, and
//! `set_camera_info`, which writes the file atomically before it answers and is
//! published from the next frame on.

use std::path::PathBuf;

use stereocal_msgs::CameraInfoFile;
use stereocal_msgs::sensor_msgs::CameraInfo;
use stereocal_msgs::std_msgs::Header;
use stereocal_runtime::camera_info_url::{camera_info_path, ros_home};

/// The camera's calibration and where it is kept.
#[derive(Debug)]
pub struct CameraInfoManager {
    camera_name: String,
    url: String,
    path: Result<PathBuf, String>,
    calibration: Option<CameraInfo>,
    problem: Option<String>,
}

impl CameraInfoManager {
    /// The calibration of camera `camera_name` at `url`, read now. A missing or bad
    /// file is not an error: the camera is uncalibrated, and [`Self::problem`] says why.
    pub fn load(camera_name: &str, url: &str) -> Self {
        let path = camera_info_path(url, camera_name, &ros_home());
        let mut manager = CameraInfoManager {
            camera_name: camera_name.to_owned(),
            url: url.to_owned(),
            path,
            calibration: None,
            problem: None,
        };
        match &manager.path {
            Err(e) => manager.problem = Some(format!("camera_info_url {e}")),
            Ok(path) if !path.exists() => {
                manager.problem = Some(format!(
                    "no calibration at {}: publishing an uncalibrated camera_info until \
                     set_camera_info stores one",
                    path.display()
                ));
            }
            Ok(path) => match CameraInfoFile::read(path) {
                Ok(file) => {
                    if file.camera_name != camera_name {
                        log::warn!(
                            "{} is the calibration of camera {:?}, not {camera_name:?}: using it",
                            path.display(),
                            file.camera_name
                        );
                    }
                    log::info!("calibration of {camera_name} read from {}", path.display());
                    manager.calibration = Some(file.info);
                }
                Err(e) => manager.problem = Some(format!("calibration not read: {e}")),
            },
        }
        manager
    }

    /// Why there is no calibration (the file is missing or bad, the URL unusable).
    pub fn problem(&self) -> Option<&str> {
        self.problem.as_deref()
    }

    /// The URL as given.
    pub fn url(&self) -> &str {
        &self.url
    }

    /// The camera_info of a `width` x `height` image with `header`: the calibration
    /// when it is for that size, else an uncalibrated one (all-zero K, R, P and no
    /// distortion, as camera_info_manager publishes); and a warning when a calibration
    /// of another size was left out.
    pub fn camera_info(
        &self,
        width: u32,
        height: u32,
        header: Header,
    ) -> (CameraInfo, Option<String>) {
        match &self.calibration {
            Some(info) if (info.width, info.height) == (width, height) => (
                CameraInfo {
                    header,
                    ..info.clone()
                },
                None,
            ),
            other => {
                let warning = other.as_ref().map(|info| {
                    format!(
                        "the calibration is for {}x{} images, the camera captures {width}x{height}: \
                         publishing an uncalibrated camera_info",
                        info.width, info.height
                    )
                });
                (
                    CameraInfo {
                        header,
                        width,
                        height,
                        distortion_model: "plumb_bob".into(),
                        d: vec![0.0; 5],
                        ..CameraInfo::default()
                    },
                    warning,
                )
            }
        }
    }

    /// Stores `info` as the camera's calibration: written atomically to the URL's file
    /// (a temporary file renamed into place) before this returns, then published. The
    /// confirmation, or why it was not stored (nothing changes then).
    pub fn set(&mut self, info: CameraInfo) -> Result<String, String> {
        if info.width == 0 || info.height == 0 {
            return Err(format!(
                "a camera_info of {}x{} pixels has no image size",
                info.width, info.height
            ));
        }
        let path = self
            .path
            .as_ref()
            .map_err(|e| format!("camera_info_url {e}"))?;
        let file = CameraInfoFile {
            camera_name: self.camera_name.clone(),
            info: CameraInfo {
                header: Header::default(),
                ..info
            },
        };
        file.write(path)
            .map_err(|e| format!("calibration not stored: {e}"))?;
        self.calibration = Some(file.info);
        self.problem = None;
        Ok(format!("calibration written to {}", path.display()))
    }
}
