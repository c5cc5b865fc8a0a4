//! camera_info_manager's URLs: where a camera's calibration is kept, as ROS camera
//! drivers and calibrators name it (`file://${ROS_HOME}/camera_info/${NAME}.yaml`, or
//! `package://PACKAGE/path.yaml` in an installed ROS package's share directory).

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
/// [`DEFAULT_CAMERA_INFO_URL`]; `package://PACKAGE/path` is `share/PACKAGE/path` under
/// the first prefix of `AMENT_PREFIX_PATH` that has the package. Only `file://` URLs
/// with an absolute path and `package://` URLs are supported; the error says what to
/// write instead.
pub fn camera_info_path(url: &str, camera_name: &str, ros_home: &Path) -> Result<PathBuf, String> {
    let prefixes: Vec<PathBuf> = std::env::var_os("AMENT_PREFIX_PATH")
        .map(|paths| std::env::split_paths(&paths).collect())
        .unwrap_or_default();
    resolve_camera_info_url(url, camera_name, ros_home, &prefixes)
}

/// [`camera_info_path`] with the install prefixes `package://` URLs are looked up in
/// (`AMENT_PREFIX_PATH`'s, in order).
pub fn resolve_camera_info_url(
    url: &str,
    camera_name: &str,
    ros_home: &Path,
    ament_prefixes: &[PathBuf],
) -> Result<PathBuf, String> {
    let url = if url.is_empty() {
        DEFAULT_CAMERA_INFO_URL
    } else {
        url
    };
    let resolved = url
        .replace("${NAME}", camera_name)
        .replace("${ROS_HOME}", &ros_home.to_string_lossy());
    if let Some(rest) = resolved.strip_prefix("package://") {
        return package_path(url, rest, ament_prefixes);
    }
    let Some(path) = resolved.strip_prefix("file://") else {
        return Err(format!(
            "{url:?} is not supported: only file:// URLs (file:///absolute/path.yaml) and \
             package:// URLs (package://PACKAGE/path.yaml) name a camera_info file"
        ));
    };
    if !path.starts_with('/') {
        return Err(format!(
            "{url:?} has no absolute path: write file:///absolute/path.yaml"
        ));
    }
    Ok(PathBuf::from(path))
}

/// The file of `package://PACKAGE/path` (`rest` is `PACKAGE/path`): `path` in the share
/// directory of the first prefix that installs `PACKAGE` (its ament resource index
/// entry, or a `share/PACKAGE` directory).
fn package_path(url: &str, rest: &str, prefixes: &[PathBuf]) -> Result<PathBuf, String> {
    let (package, path) = rest
        .split_once('/')
        .filter(|(package, path)| !package.is_empty() && !path.is_empty())
        .ok_or_else(|| format!("{url:?} names no file: write package://PACKAGE/path.yaml"))?;
    prefixes
        .iter()
        .find(|prefix| {
            prefix
                .join("share/ament_index/resource_index/packages")
                .join(package)
                .is_file()
                || prefix.join("share").join(package).is_dir()
        })
        .map(|prefix| prefix.join("share").join(package).join(path))
        .ok_or_else(|| {
            format!(
                "{url:?}: package {package:?} is not installed in any prefix of \
                 AMENT_PREFIX_PATH ({} searched)",
                prefixes.len()
            )
        })
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

    #[test]
    fn package_urls_resolve_in_the_first_prefix_that_installs_the_package() {
        let dir = std::env::temp_dir().join(format!("camera_info_url_{}", std::process::id()));
        let (first, second) = (dir.join("first"), dir.join("second"));
        let made = std::fs::create_dir_all(first.join("share/other"))
            .and_then(|()| std::fs::create_dir_all(second.join("share/my_camera")));
        assert!(made.is_ok(), "{made:?}");
        let prefixes = [first.clone(), second.clone()];
        let home = Path::new("/home/robot/.ros");
        assert_eq!(
            resolve_camera_info_url(
                "package://my_camera/cal/${NAME}.yaml",
                "left",
                home,
                &prefixes
            ),
            Ok(second.join("share/my_camera/cal/left.yaml"))
        );
        let missing =
            resolve_camera_info_url("package://nowhere/cal.yaml", "left", home, &prefixes);
        assert!(missing.is_err_and(|e| e.contains("\"nowhere\" is not installed")));
        let bare = resolve_camera_info_url("package://my_camera", "left", home, &prefixes);
        assert!(bare.is_err_and(|e| e.contains("names no file")));
        let _ = std::fs::remove_dir_all(&dir);
    }
}
