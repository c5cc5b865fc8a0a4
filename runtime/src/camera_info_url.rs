//! camera_info_manager's URLs: where a camera's calibration is kept, as ROS camera
//! drivers and calibrators name it (`file://${ROS_HOME}/camera_info/${NAME}.yaml`).

use std::path::{Path, PathBuf};

/// camera_info_manager's default URL: `${ROS_HOME}` and `${NAME}` are substituted.
pub const DEFAULT_CAMERA_INFO_URL: &str = "file://${ROS_HOME}/camera_info/${NAME}.yaml";

/// The directory ROS keeps its files in: `$ROS_HOME`, else `~/.ros`.
pub fn ros_home() -> PathBuf {
    match std::env::var_os("ROS_HOME") {
        Some(home) if !home.is_empty() => PathBuf::from(home),
        _ => std::env::var_os("HOME")
            .map(PathBuf::from)
            .unwrap_or_default()
            .join(".ros"),
    }
}

/// The file a camera_info URL names, as camera_info_manager resolves it: `${NAME}` is
/// the camera's name and `${ROS_HOME}` is `ros_home`; an empty URL is
/// [`DEFAULT_CAMERA_INFO_URL`]. Only `file://` URLs with an absolute path are supported;
/// the error says what to write instead.
pub fn camera_info_path(url: &str, camera_name: &str, ros_home: &Path) -> Result<PathBuf, String> {
    let url = if url.is_empty() {
        DEFAULT_CAMERA_INFO_URL
    } else {
        url
    };
    let resolved = url
        .replace("${NAME}", camera_name)
        .replace("${ROS_HOME}", &ros_home.to_string_lossy());
    let Some(path) = resolved.strip_prefix("file://") else {
        return Err(format!(
            "{url:?} is not supported: only file:// URLs (file:///absolute/path.yaml) can be written"
        ));
    };
    if !path.starts_with('/') {
        return Err(format!(
            "{url:?} has no absolute path: write file:///absolute/path.yaml"
        ));
    }
    Ok(PathBuf::from(path))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn urls_resolve_like_camera_info_manager() {
        let home = Path::new("/home/robot/.ros");
        let default = Ok(PathBuf::from("/home/robot/.ros/camera_info/left.yaml"));
        assert_eq!(
            camera_info_path(DEFAULT_CAMERA_INFO_URL, "left", home),
            default
        );
        assert_eq!(camera_info_path("", "left", home), default);
        assert_eq!(
            camera_info_path("file:///tmp/cal/${NAME}.yaml", "right", home),
            Ok(PathBuf::from("/tmp/cal/right.yaml"))
        );
        let http = camera_info_path("http://host/left.yaml", "left", home);
        assert!(http.is_err_and(|e| e.contains("only file://")));
        let relative = camera_info_path("file://cal/left.yaml", "left", home);
        assert!(relative.is_err_and(|e| e.contains("absolute")));
    }
}
