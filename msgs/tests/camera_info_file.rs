//! camera_info files: the YAML and INI that ROS's `camera_calibration_parsers` writes,
//! round trips, and the errors bad files give.

use stereocal_msgs::sensor_msgs::CameraInfo;
use stereocal_msgs::{CameraInfoFile, CameraInfoFileError};

/// Laid out exactly as `camera_calibration_parsers::writeCalibrationYml` (yaml-cpp)
/// writes it.
const PARSERS_YAML: &str = "image_width: 640
image_height: 480
camera_name: narrow_stereo/left
camera_matrix:
  rows: 3
  cols: 3
  data: [430.15433, 0, 311.71339, 0, 430.60326, 221.06508, 0, 0, 1]
distortion_model: plumb_bob
distortion_coefficients:
  rows: 1
  cols: 5
  data: [-0.363528, 0.16982, -0.00034, 0.000201, -0.04]
rectification_matrix:
  rows: 3
  cols: 3
  data: [0.9999, -0.0026, 0.0135, 0.0026, 1, 0.0001, -0.0135, -0.0001, 0.9999]
projection_matrix:
  rows: 3
  cols: 4
  data: [295.53, 0, 285.55, -17.5, 0, 295.53, 223.29, 0, 0, 0, 1, 0]
";

/// As the `camera_calibration` calibrator (Python) writes it: numpy-formatted flow
/// sequences spread over lines.
const CALIBRATOR_YAML: &str = "image_width: 640
image_height: 480
camera_name: narrow_stereo
camera_matrix:
  rows: 3
  cols: 3
  data: [ 430.15433,    0.     ,  311.71339,
            0.     ,  430.60326,  221.06508,
            0.     ,    0.     ,    1.     ]
distortion_model: rational_polynomial
distortion_coefficients:
  rows: 1
  cols: 8
  data: [-0.363528, 0.099230, -0.000340, 0.000201, 0.000000, 0.01, -0.002, 0.0003]
rectification_matrix:
  rows: 3
  cols: 3
  data: [ 1.,  0.,  0.,
          0.,  1.,  0.,
          0.,  0.,  1.]
projection_matrix:
  rows: 3
  cols: 4
  data: [ 295.53397,    0.     ,  285.55511,    0.     ,
            0.     ,  344.50204,  221.51908,    0.     ,
            0.     ,    0.     ,    1.     ,    0.     ]
";

/// As `camera_calibration_parsers::writeCalibrationIni` writes it (fixed, 5 decimals,
/// a space after every number).
const PARSERS_INI: &str = "# Camera intrinsics

[image]

width
640

height
480

[mono_left]

camera matrix
430.15433 0.00000 311.71339 
0.00000 430.60326 221.06508 
0.00000 0.00000 1.00000 

distortion
-0.36353 0.16982 -0.00034 0.00020 -0.04000 


rectification
1.00000 0.00000 0.00000 
0.00000 1.00000 0.00000 
0.00000 0.00000 1.00000 

projection
295.53397 0.00000 285.55511 0.00000 
0.00000 344.50204 221.51908 0.00000 
0.00000 0.00000 1.00000 0.00000 
";

fn equidistant() -> CameraInfoFile {
    CameraInfoFile {
        camera_name: "fisheye".to_owned(),
        info: CameraInfo {
            width: 1280,
            height: 800,
            distortion_model: "equidistant".to_owned(),
            d: vec![0.0123, -0.004567, 1.5e-9, -2.25e-12],
            k: [410.25, 0.0, 639.5, 0.0, 410.0625, 399.5, 0.0, 0.0, 1.0],
            r: [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0],
            p: [
                300.0, 0.0, 639.5, 0.0, 0.0, 300.0, 399.5, 0.0, 0.0, 0.0, 1.0, 0.0,
            ],
            ..CameraInfo::default()
        },
    }
}

#[test]
fn reads_yaml_as_camera_calibration_parsers_writes_it() {
    let file = CameraInfoFile::from_yaml_str(PARSERS_YAML).expect("valid file");
    assert_eq!(file.camera_name, "narrow_stereo/left");
    assert_eq!((file.info.width, file.info.height), (640, 480));
    assert_eq!(file.info.distortion_model, "plumb_bob");
    assert_eq!(
        file.info.d,
        vec![-0.363528, 0.16982, -0.00034, 0.000201, -0.04]
    );
    assert_eq!(
        file.info.k,
        [
            430.15433, 0.0, 311.71339, 0.0, 430.60326, 221.06508, 0.0, 0.0, 1.0
        ]
    );
    assert_eq!(file.info.r[1], -0.0026);
    assert_eq!(file.info.p[3], -17.5);
}

#[test]
fn writes_yaml_byte_for_byte_like_camera_calibration_parsers() {
    let file = CameraInfoFile::from_yaml_str(PARSERS_YAML).expect("valid file");
    assert_eq!(file.to_yaml_string().expect("writable"), PARSERS_YAML);
}

#[test]
fn reads_the_calibrators_multi_line_yaml() {
    let file = CameraInfoFile::from_yaml_str(CALIBRATOR_YAML).expect("valid file");
    assert_eq!(file.camera_name, "narrow_stereo");
    assert_eq!(file.info.distortion_model, "rational_polynomial");
    assert_eq!(file.info.d.len(), 8);
    assert_eq!(file.info.d[7], 0.0003);
    assert_eq!(file.info.p[5], 344.50204);
    assert_eq!(file.info.p[11], 0.0);
}

#[test]
fn yaml_round_trips_every_model_exactly() {
    let plumb_bob = CameraInfoFile::from_yaml_str(PARSERS_YAML).expect("valid");
    let rational = CameraInfoFile::from_yaml_str(CALIBRATOR_YAML).expect("valid");
    for file in [plumb_bob, rational, equidistant()] {
        let text = file.to_yaml_string().expect("writable");
        assert_eq!(
            CameraInfoFile::from_yaml_str(&text).expect("reads back"),
            file
        );
    }
}

#[test]
fn yaml_defaults_name_and_model_like_the_parsers() {
    let text = PARSERS_YAML
        .replace("camera_name: narrow_stereo/left\n", "")
        .replace("distortion_model: plumb_bob\n", "");
    let file = CameraInfoFile::from_yaml_str(&text).expect("valid");
    assert_eq!(file.camera_name, "unknown");
    assert_eq!(file.info.distortion_model, "plumb_bob");
}

#[test]
fn reads_ini_as_camera_calibration_parsers_writes_it() {
    let file = CameraInfoFile::from_ini_str(PARSERS_INI).expect("valid file");
    assert_eq!(file.camera_name, "mono_left");
    assert_eq!((file.info.width, file.info.height), (640, 480));
    assert_eq!(file.info.distortion_model, "plumb_bob");
    assert_eq!(
        file.info.d,
        vec![-0.36353, 0.16982, -0.00034, 0.0002, -0.04]
    );
    assert_eq!(file.info.k[0], 430.15433);
    assert_eq!(file.info.r, [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0]);
    assert_eq!(file.info.p[6], 221.51908);
}

#[test]
fn ini_with_eight_coefficients_and_externals_is_rational_polynomial() {
    let text = PARSERS_INI
        .replace(
            "-0.36353 0.16982 -0.00034 0.00020 -0.04000 ",
            "1 2 3 4 5 6 7 8",
        )
        .replace(
            "[mono_left]",
            "[externals]\n\ntranslation\n0.0 0.0 0.0\n\nrotation\n0.0 0.0 0.0\n\n; comment\n[mono_left]",
        );
    let file = CameraInfoFile::from_ini_str(&text).expect("valid file");
    assert_eq!(file.info.distortion_model, "rational_polynomial");
    assert_eq!(file.info.d, vec![1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0]);
}

#[test]
fn bad_ini_names_the_line() {
    let short_row = PARSERS_INI.replace(
        "0.00000 0.00000 1.00000 \n\ndistortion",
        "0.00000 1.00000\n\ndistortion",
    );
    let error = CameraInfoFile::from_ini_str(&short_row).expect_err("short row");
    assert!(
        matches!(error, CameraInfoFileError::Ini { line: 16, .. }),
        "{error}"
    );
    assert!(
        error
            .to_string()
            .contains("'camera matrix' row 3 has 2 numbers, expected 3"),
        "{error}"
    );

    let no_projection = PARSERS_INI.replace("projection", "projektion");
    let error = CameraInfoFile::from_ini_str(&no_projection).expect_err("missing key");
    assert!(
        error.to_string().contains("missing key 'projection'"),
        "{error}"
    );

    let no_image = PARSERS_INI.replace("[image]\n\nwidth\n640\n\nheight\n480\n", "");
    let error = CameraInfoFile::from_ini_str(&no_image).expect_err("no [image]");
    assert_eq!(error.to_string(), "INI file: missing section [image]");

    let six = PARSERS_INI.replace("-0.04000 ", "-0.04000 0.1");
    let error = CameraInfoFile::from_ini_str(&six).expect_err("six coefficients");
    assert!(error.to_string().contains("has 6 coefficients"), "{error}");
}

#[test]
fn bad_yaml_errors_name_the_field() {
    #[track_caller]
    fn error_of(text: &str) -> String {
        CameraInfoFile::from_yaml_str(text)
            .expect_err("invalid file")
            .to_string()
    }

    let missing = PARSERS_YAML.replace("image_height: 480\n", "");
    assert_eq!(error_of(&missing), "missing key `image_height`");

    let wrong_shape = PARSERS_YAML
        .replacen(
            "cols: 3\n  data: [430.15433, 0, 311.71339, 0, 430.60326, 221.06508]",
            "",
            1,
        )
        .replace(
            "data: [430.15433, 0, 311.71339, 0, 430.60326, 221.06508, 0, 0, 1]",
            "data: [430.15433, 0, 311.71339, 0, 430.60326, 221.06508]",
        );
    assert_eq!(
        error_of(&wrong_shape),
        "`camera_matrix.data` must be 9 values (3x3), found 6"
    );

    let declared_2x3 = PARSERS_YAML.replacen("rows: 3\n  cols: 4", "rows: 4\n  cols: 3", 1);
    assert_eq!(
        error_of(&declared_2x3),
        "`projection_matrix` must be 3x4, found 4x3"
    );

    let nan = PARSERS_YAML.replace("221.06508", ".nan");
    assert_eq!(
        error_of(&nan),
        "`camera_matrix.data[5]` is NaN, expected a finite number"
    );

    let infinite = PARSERS_YAML.replace("-0.04]", "-.inf]");
    assert_eq!(
        error_of(&infinite),
        "`distortion_coefficients.data[4]` is -inf, expected a finite number"
    );

    let unknown = PARSERS_YAML.replace("plumb_bob", "kannala_brandt");
    assert_eq!(
        error_of(&unknown),
        "unknown distortion model `kannala_brandt`: expected `plumb_bob`, `rational_polynomial` or `equidistant`"
    );

    let four = PARSERS_YAML
        .replace("cols: 5", "cols: 4")
        .replace(", -0.04]", "]");
    assert_eq!(
        error_of(&four),
        "`distortion_coefficients` must be 5 coefficients for plumb_bob, found 4"
    );

    let text_value = PARSERS_YAML.replace("image_width: 640", "image_width: wide");
    assert_eq!(
        error_of(&text_value),
        "`image_width` must be a non-negative integer below 2^32, found the string \"wide\""
    );

    let not_number = PARSERS_YAML.replace("0.000201", "x");
    assert_eq!(
        error_of(&not_number),
        "`distortion_coefficients.data[3]` must be a number, found the string \"x\""
    );

    let no_rows = PARSERS_YAML.replacen("  rows: 3\n", "", 1);
    assert_eq!(error_of(&no_rows), "missing key `camera_matrix.rows`");

    let malformed = PARSERS_YAML.replace("data: [295.53,", "data: [295.53 },");
    assert!(error_of(&malformed).starts_with("malformed YAML: "));
    assert!(error_of("- just\n- a list\n").contains("`document` must be a mapping"));
}

#[test]
fn write_refuses_what_it_could_not_read_back() {
    let mut file = equidistant();
    file.info.k[4] = f64::NAN;
    assert!(matches!(
        file.to_yaml_string(),
        Err(CameraInfoFileError::NotFinite { index: 4, .. })
    ));
    let mut file = equidistant();
    file.info.d.push(0.0);
    assert!(matches!(
        file.to_yaml_string(),
        Err(CameraInfoFileError::WrongSize { .. })
    ));
}

#[test]
fn names_that_yaml_would_misread_are_quoted() {
    for name in ["true", "1234", "", "left: camera", "~"] {
        let mut file = equidistant();
        file.camera_name = name.to_owned();
        let text = file.to_yaml_string().expect("writable");
        assert_eq!(
            CameraInfoFile::from_yaml_str(&text)
                .expect("reads back")
                .camera_name,
            name
        );
    }
}

#[test]
fn files_are_written_atomically_and_read_by_extension_or_content() {
    let dir = tempfile::tempdir().expect("temp dir");
    let path = dir.path().join("camera_info").join("fisheye.yaml");
    let file = equidistant();
    file.write(&path).expect("written");
    assert_eq!(CameraInfoFile::read(&path).expect("read back"), file);

    // Overwriting leaves exactly the one file, with the new content.
    let mut changed = file.clone();
    changed.camera_name = "fisheye_2".to_owned();
    changed.write(&path).expect("overwritten");
    let entries: Vec<_> = std::fs::read_dir(path.parent().expect("dir"))
        .expect("listable")
        .collect();
    assert_eq!(entries.len(), 1);
    assert_eq!(CameraInfoFile::read(&path).expect("read back"), changed);

    let ini = dir.path().join("left.ini");
    std::fs::write(&ini, PARSERS_INI).expect("written");
    assert_eq!(
        CameraInfoFile::read(&ini).expect("INI").camera_name,
        "mono_left"
    );
    let no_extension = dir.path().join("left_calibration");
    std::fs::write(&no_extension, PARSERS_INI).expect("written");
    assert_eq!(
        CameraInfoFile::read(&no_extension)
            .expect("INI by content")
            .camera_name,
        "mono_left"
    );
    std::fs::write(&no_extension, PARSERS_YAML).expect("written");
    assert_eq!(
        CameraInfoFile::read(&no_extension)
            .expect("YAML by content")
            .camera_name,
        "narrow_stereo/left"
    );

    let missing = dir.path().join("missing.yaml");
    let error = CameraInfoFile::read(&missing).expect_err("no such file");
    assert!(
        error
            .to_string()
            .starts_with(&missing.display().to_string()),
        "{error}"
    );
    let bad = dir.path().join("bad.yaml");
    std::fs::write(&bad, PARSERS_YAML.replace("image_width: 640\n", "")).expect("written");
    let error = CameraInfoFile::read(&bad).expect_err("missing key");
    assert_eq!(
        error.to_string(),
        format!("{}: missing key `image_width`", bad.display())
    );
}
