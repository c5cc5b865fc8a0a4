//! camera_info files in the formats of ROS's `camera_calibration_parsers`: its YAML
//! (read and written exactly as that package writes it) and its Videre INI (read).
//!
//! Supported distortion models: `plumb_bob` (5 coefficients), `rational_polynomial`
//! (8) and `equidistant` (4).

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use serde_yaml::Value;

use crate::sensor_msgs::CameraInfo;
use crate::sensor_msgs::distortion_models::{EQUIDISTANT, PLUMB_BOB, RATIONAL_POLYNOMIAL};

/// Camera name `camera_calibration_parsers` assumes when a YAML file has none.
pub const UNKNOWN_CAMERA_NAME: &str = "unknown";

/// What was wrong with a camera_info file.
#[derive(Debug, thiserror::Error)]
pub enum CameraInfoFileError {
    /// The text is not YAML.
    #[error("malformed YAML: {0}")]
    Yaml(#[from] serde_yaml::Error),
    /// A required key is absent.
    #[error("missing key `{0}`")]
    MissingKey(String),
    /// A value has the wrong kind (e.g. a string where a number belongs).
    #[error("`{field}` must be {expected}, found {found}")]
    WrongType {
        /// Key path, e.g. `camera_matrix.data`.
        field: String,
        /// What the key should hold.
        expected: &'static str,
        /// What it holds.
        found: String,
    },
    /// A matrix has the wrong shape or its data the wrong length.
    #[error("`{field}` must be {expected}, found {found}")]
    WrongSize {
        /// Key path.
        field: String,
        /// Expected shape or length.
        expected: String,
        /// Shape or length found.
        found: String,
    },
    /// A number is NaN or infinite.
    #[error("`{field}[{index}]` is {value}, expected a finite number")]
    NotFinite {
        /// Key path of the matrix.
        field: String,
        /// Index in its row-major data.
        index: usize,
        /// The value.
        value: f64,
    },
    /// The distortion model is none of those supported.
    #[error(
        "unknown distortion model `{0}`: expected `plumb_bob`, `rational_polynomial` or `equidistant`"
    )]
    UnknownDistortionModel(String),
    /// An INI file does not have the layout `camera_calibration_parsers` writes.
    #[error("INI {}: {message}", ini_location(*.line))]
    Ini {
        /// 1-based line number (0: the file as a whole).
        line: usize,
        /// What was wrong.
        message: String,
    },
    /// The file could not be read or written.
    #[error("{}: {source}", .path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// The I/O error.
        source: std::io::Error,
    },
    /// The file's content was wrong.
    #[error("{}: {source}", .path.display())]
    InFile {
        /// The file.
        path: PathBuf,
        /// What was wrong in it.
        source: Box<CameraInfoFileError>,
    },
}

/// A camera calibration as stored in a camera_info file: the camera's name and the
/// `CameraInfo` (size, K, distortion, R, P; header, binning and ROI are not stored).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct CameraInfoFile {
    /// Name of the camera the calibration belongs to.
    pub camera_name: String,
    /// The calibration.
    pub info: CameraInfo,
}

impl CameraInfoFile {
    /// Parses the YAML of `camera_calibration_parsers` (and of the `camera_calibration`
    /// calibrator). As there, `camera_name` defaults to `unknown` and
    /// `distortion_model` to `plumb_bob`; everything else is required and checked:
    /// matrix shapes, coefficient count for the model, finite values.
    pub fn from_yaml_str(text: &str) -> Result<Self, CameraInfoFileError> {
        let doc: Value = serde_yaml::from_str(text)?;
        if !doc.is_mapping() {
            return Err(CameraInfoFileError::WrongType {
                field: "document".to_owned(),
                expected: "a mapping of calibration keys",
                found: describe(&doc),
            });
        }
        let camera_name = match doc.get("camera_name") {
            None => UNKNOWN_CAMERA_NAME.to_owned(),
            Some(value) => scalar_text(value).ok_or_else(|| CameraInfoFileError::WrongType {
                field: "camera_name".to_owned(),
                expected: "a string",
                found: describe(value),
            })?,
        };
        let width = yaml_u32(&doc, "image_width")?;
        let height = yaml_u32(&doc, "image_height")?;
        let k = yaml_matrix::<9>(&doc, "camera_matrix", 3, 3)?;
        let r = yaml_matrix::<9>(&doc, "rectification_matrix", 3, 3)?;
        let p = yaml_matrix::<12>(&doc, "projection_matrix", 3, 4)?;
        let distortion_model = match doc.get("distortion_model") {
            None => PLUMB_BOB.to_owned(),
            Some(value) => value
                .as_str()
                .ok_or_else(|| CameraInfoFileError::WrongType {
                    field: "distortion_model".to_owned(),
                    expected: "a string",
                    found: describe(value),
                })?
                .to_owned(),
        };
        let d = yaml_distortion(&doc)?;
        let info = CameraInfo {
            width,
            height,
            distortion_model,
            d,
            k,
            r,
            p,
            ..CameraInfo::default()
        };
        validate(&info)?;
        Ok(Self { camera_name, info })
    }

    /// Writes the YAML exactly as `camera_calibration_parsers` lays it out (key order,
    /// nested `rows`/`cols`/`data` maps with flow sequences). Numbers are written in
    /// their shortest form that reads back to the same `f64`.
    pub fn to_yaml_string(&self) -> Result<String, CameraInfoFileError> {
        validate(&self.info)?;
        let info = &self.info;
        let mut out = String::new();
        // Writing to a String cannot fail.
        let _ = writeln!(out, "image_width: {}", info.width);
        let _ = writeln!(out, "image_height: {}", info.height);
        let _ = writeln!(out, "camera_name: {}", yaml_string(&self.camera_name));
        write_matrix(&mut out, "camera_matrix", 3, 3, &info.k);
        let _ = writeln!(
            out,
            "distortion_model: {}",
            yaml_string(&info.distortion_model)
        );
        write_matrix(
            &mut out,
            "distortion_coefficients",
            1,
            info.d.len(),
            &info.d,
        );
        write_matrix(&mut out, "rectification_matrix", 3, 3, &info.r);
        write_matrix(&mut out, "projection_matrix", 3, 4, &info.p);
        Ok(out)
    }

    /// Parses the Videre INI format of `camera_calibration_parsers`: an `[image]`
    /// section with `width` and `height`, and a `[camera name]` section with
    /// `camera matrix`, `distortion` (5 values: plumb_bob, 8: rational_polynomial),
    /// `rectification` and `projection`, each key followed by its matrix rows.
    pub fn from_ini_str(text: &str) -> Result<Self, CameraInfoFileError> {
        parse_ini(text)
    }

    /// Reads a camera_info file: INI for `.ini`, YAML for `.yaml`/`.yml`, otherwise
    /// INI if the first meaningful line is a `[section]` header, YAML if not.
    pub fn read(path: impl AsRef<Path>) -> Result<Self, CameraInfoFileError> {
        let path = path.as_ref();
        let text = std::fs::read_to_string(path).map_err(|source| CameraInfoFileError::Io {
            path: path.to_owned(),
            source,
        })?;
        let is_ini = match path.extension().and_then(|e| e.to_str()) {
            Some(ext) if ext.eq_ignore_ascii_case("ini") => true,
            Some(ext) if ext.eq_ignore_ascii_case("yaml") || ext.eq_ignore_ascii_case("yml") => {
                false
            }
            _ => looks_like_ini(&text),
        };
        let parsed = if is_ini {
            Self::from_ini_str(&text)
        } else {
            Self::from_yaml_str(&text)
        };
        parsed.map_err(|source| CameraInfoFileError::InFile {
            path: path.to_owned(),
            source: Box::new(source),
        })
    }

    /// Writes the YAML to `path` atomically: a temporary file in the same directory,
    /// flushed to disk, then renamed over `path`. Creates the directory if needed.
    pub fn write(&self, path: impl AsRef<Path>) -> Result<(), CameraInfoFileError> {
        let path = path.as_ref();
        let text = self.to_yaml_string()?;
        let io_error = |source| CameraInfoFileError::Io {
            path: path.to_owned(),
            source,
        };
        crate::atomic_file::write(path, text.as_bytes()).map_err(io_error)
    }
}

fn ini_location(line: usize) -> String {
    if line == 0 {
        "file".to_owned()
    } else {
        format!("line {line}")
    }
}

/// Number of coefficients each supported distortion model has.
fn distortion_count(model: &str) -> Option<usize> {
    match model {
        PLUMB_BOB => Some(5),
        RATIONAL_POLYNOMIAL => Some(8),
        EQUIDISTANT => Some(4),
        _ => None,
    }
}

/// Checks what both the reader and the writer require: a supported model with its
/// number of coefficients, and finite numbers everywhere.
fn validate(info: &CameraInfo) -> Result<(), CameraInfoFileError> {
    let expected = distortion_count(&info.distortion_model).ok_or_else(|| {
        CameraInfoFileError::UnknownDistortionModel(info.distortion_model.clone())
    })?;
    if info.d.len() != expected {
        return Err(CameraInfoFileError::WrongSize {
            field: "distortion_coefficients".to_owned(),
            expected: format!("{expected} coefficients for {}", info.distortion_model),
            found: format!("{}", info.d.len()),
        });
    }
    let matrices: [(&str, &[f64]); 4] = [
        ("camera_matrix.data", &info.k),
        ("distortion_coefficients.data", &info.d),
        ("rectification_matrix.data", &info.r),
        ("projection_matrix.data", &info.p),
    ];
    for (field, data) in matrices {
        if let Some((index, &value)) = data.iter().enumerate().find(|(_, v)| !v.is_finite()) {
            return Err(CameraInfoFileError::NotFinite {
                field: field.to_owned(),
                index,
                value,
            });
        }
    }
    Ok(())
}

fn describe(value: &Value) -> String {
    match value {
        Value::Null => "nothing".to_owned(),
        Value::Bool(b) => format!("the boolean {b}"),
        Value::Number(n) => format!("the number {n}"),
        Value::String(s) => format!("the string {s:?}"),
        Value::Sequence(s) => format!("a sequence of {} items", s.len()),
        Value::Mapping(_) => "a mapping".to_owned(),
        Value::Tagged(t) => format!("a value tagged {}", t.tag),
    }
}

/// A scalar as text, as yaml-cpp's `as<std::string>()` gives it.
fn scalar_text(value: &Value) -> Option<String> {
    match value {
        Value::String(s) => Some(s.clone()),
        Value::Number(n) => Some(n.to_string()),
        Value::Bool(b) => Some(b.to_string()),
        _ => None,
    }
}

fn require<'a>(doc: &'a Value, key: &str) -> Result<&'a Value, CameraInfoFileError> {
    doc.get(key)
        .ok_or_else(|| CameraInfoFileError::MissingKey(key.to_owned()))
}

fn as_u32(value: &Value, field: &str) -> Result<u32, CameraInfoFileError> {
    value
        .as_u64()
        .and_then(|v| u32::try_from(v).ok())
        .ok_or_else(|| CameraInfoFileError::WrongType {
            field: field.to_owned(),
            expected: "a non-negative integer below 2^32",
            found: describe(value),
        })
}

fn yaml_u32(doc: &Value, key: &str) -> Result<u32, CameraInfoFileError> {
    as_u32(require(doc, key)?, key)
}

/// Reads a `{rows, cols, data}` matrix node: its declared shape and its data.
fn yaml_matrix_node(
    doc: &Value,
    key: &str,
) -> Result<(usize, usize, Vec<f64>), CameraInfoFileError> {
    let node = require(doc, key)?;
    if !node.is_mapping() {
        return Err(CameraInfoFileError::WrongType {
            field: key.to_owned(),
            expected: "a mapping with rows, cols and data",
            found: describe(node),
        });
    }
    let rows = yaml_u32(node, "rows").map_err(|e| qualify(e, key))? as usize;
    let cols = yaml_u32(node, "cols").map_err(|e| qualify(e, key))? as usize;
    let data_field = format!("{key}.data");
    let data = node
        .get("data")
        .ok_or_else(|| CameraInfoFileError::MissingKey(data_field.clone()))?;
    let items = data
        .as_sequence()
        .ok_or_else(|| CameraInfoFileError::WrongType {
            field: data_field.clone(),
            expected: "a sequence of numbers",
            found: describe(data),
        })?;
    let values = items
        .iter()
        .enumerate()
        .map(|(i, item)| {
            item.as_f64().ok_or_else(|| CameraInfoFileError::WrongType {
                field: format!("{data_field}[{i}]"),
                expected: "a number",
                found: describe(item),
            })
        })
        .collect::<Result<Vec<_>, _>>()?;
    if values.len() != rows * cols {
        return Err(CameraInfoFileError::WrongSize {
            field: data_field,
            expected: format!("{} values ({rows}x{cols})", rows * cols),
            found: format!("{}", values.len()),
        });
    }
    Ok((rows, cols, values))
}

/// Prefixes the key path of an error found inside the mapping `parent`.
fn qualify(error: CameraInfoFileError, parent: &str) -> CameraInfoFileError {
    match error {
        CameraInfoFileError::MissingKey(key) => {
            CameraInfoFileError::MissingKey(format!("{parent}.{key}"))
        }
        CameraInfoFileError::WrongType {
            field,
            expected,
            found,
        } => CameraInfoFileError::WrongType {
            field: format!("{parent}.{field}"),
            expected,
            found,
        },
        other => other,
    }
}

fn yaml_matrix<const N: usize>(
    doc: &Value,
    key: &str,
    rows: usize,
    cols: usize,
) -> Result<[f64; N], CameraInfoFileError> {
    let (found_rows, found_cols, values) = yaml_matrix_node(doc, key)?;
    let wrong_size = || CameraInfoFileError::WrongSize {
        field: key.to_owned(),
        expected: format!("{rows}x{cols}"),
        found: format!("{found_rows}x{found_cols}"),
    };
    if (found_rows, found_cols) != (rows, cols) {
        return Err(wrong_size());
    }
    values.try_into().map_err(|_| wrong_size())
}

fn yaml_distortion(doc: &Value) -> Result<Vec<f64>, CameraInfoFileError> {
    let (rows, cols, values) = yaml_matrix_node(doc, "distortion_coefficients")?;
    if rows > 1 && cols > 1 {
        return Err(CameraInfoFileError::WrongSize {
            field: "distortion_coefficients".to_owned(),
            expected: "a vector (1xN or Nx1)".to_owned(),
            found: format!("{rows}x{cols}"),
        });
    }
    Ok(values)
}

/// A number in its shortest round-trip form; integral values without a fraction like
/// yaml-cpp writes them, exponents with a `.` so YAML 1.1 readers (PyYAML) see a float.
fn yaml_number(value: f64) -> String {
    if value == value.trunc() && value.abs() < 1e15 {
        return format!("{}", value as i64);
    }
    let text = format!("{value:?}");
    match text.find('e') {
        Some(e) if !text[..e].contains('.') => format!("{}.0{}", &text[..e], &text[e..]),
        _ => text,
    }
}

/// A string as a YAML plain scalar when it reads back as the same string, otherwise
/// double-quoted.
fn yaml_string(text: &str) -> String {
    let plain = !text.is_empty()
        && text
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || matches!(c, '_' | '-' | '.' | '/'))
        && !text.starts_with(['-', '.'])
        && matches!(
            serde_yaml::from_str::<Value>(text),
            Ok(Value::String(ref s)) if s == text
        );
    if plain {
        return text.to_owned();
    }
    let mut quoted = String::from("\"");
    for c in text.chars() {
        match c {
            '"' => quoted.push_str("\\\""),
            '\\' => quoted.push_str("\\\\"),
            '\n' => quoted.push_str("\\n"),
            '\t' => quoted.push_str("\\t"),
            c if c.is_control() => {
                let _ = write!(quoted, "\\u{:04x}", c as u32);
            }
            c => quoted.push(c),
        }
    }
    quoted.push('"');
    quoted
}

fn write_matrix(out: &mut String, key: &str, rows: usize, cols: usize, data: &[f64]) {
    let values: Vec<String> = data.iter().map(|&v| yaml_number(v)).collect();
    let _ = write!(
        out,
        "{key}:\n  rows: {rows}\n  cols: {cols}\n  data: [{}]\n",
        values.join(", ")
    );
}

fn looks_like_ini(text: &str) -> bool {
    text.lines()
        .map(str::trim)
        .find(|line| !line.is_empty() && !line.starts_with(['#', ';']))
        .is_some_and(|line| line.starts_with('['))
}

/// One meaningful line of an INI file with its 1-based number.
struct IniLine<'a> {
    number: usize,
    text: &'a str,
}

fn ini_error(line: usize, message: impl Into<String>) -> CameraInfoFileError {
    CameraInfoFileError::Ini {
        line,
        message: message.into(),
    }
}

fn parse_ini(text: &str) -> Result<CameraInfoFile, CameraInfoFileError> {
    // Sections as camera_calibration_parsers splits them: trimmed lines, blank lines
    // and `#`/`;` comments skipped, a new section at each `[...]` line.
    let mut sections: Vec<Vec<IniLine>> = Vec::new();
    for (index, raw) in text.lines().enumerate() {
        let line = raw.trim();
        if line.is_empty() || line.starts_with(['#', ';']) {
            continue;
        }
        let is_header = line.contains('[') && line.contains(']');
        match sections.last_mut() {
            Some(section) if !is_header => section.push(IniLine {
                number: index + 1,
                text: line,
            }),
            _ => sections.push(vec![IniLine {
                number: index + 1,
                text: line,
            }]),
        }
    }
    if sections.is_empty() {
        return Err(ini_error(0, "no sections found"));
    }

    let mut size: Option<(u32, u32)> = None;
    let mut camera: Option<(String, CameraInfo)> = None;
    for section in &sections {
        let header = &section[0];
        match header.text {
            "[image]" => {
                let width = ini_value(section, "width")?;
                let height = ini_value(section, "height")?;
                size = Some((width, height));
            }
            "[externals]" => {}
            name if name.starts_with('[') && name.ends_with(']') => {
                if let Some((previous, _)) = &camera {
                    return Err(ini_error(
                        header.number,
                        format!("second camera section {name} after [{previous}]"),
                    ));
                }
                camera = Some(ini_camera(section, &name[1..name.len() - 1])?);
            }
            other => {
                return Err(ini_error(
                    header.number,
                    format!("expected a [section] header, found {other:?}"),
                ));
            }
        }
    }
    let (width, height) = size.ok_or_else(|| ini_error(0, "missing section [image]"))?;
    let (camera_name, mut info) =
        camera.ok_or_else(|| ini_error(0, "missing the camera's [name] section"))?;
    info.width = width;
    info.height = height;
    validate(&info)?;
    Ok(CameraInfoFile { camera_name, info })
}

/// Index of the line holding exactly `key` in a section.
fn ini_key(section: &[IniLine], key: &str) -> Result<usize, CameraInfoFileError> {
    section
        .iter()
        .position(|line| line.text == key)
        .ok_or_else(|| {
            ini_error(
                section[0].number,
                format!("missing key '{key}' in section {}", section[0].text),
            )
        })
}

fn ini_value(section: &[IniLine], key: &str) -> Result<u32, CameraInfoFileError> {
    let at = ini_key(section, key)?;
    let line = section.get(at + 1).ok_or_else(|| {
        ini_error(
            section[at].number,
            format!("'{key}' is not followed by a value"),
        )
    })?;
    line.text.parse().map_err(|_| {
        ini_error(
            line.number,
            format!(
                "'{key}' must be a non-negative integer, found {:?}",
                line.text
            ),
        )
    })
}

/// Reads the `rows` lines following `key`, each with `cols` numbers.
fn ini_matrix<const N: usize>(
    section: &[IniLine],
    key: &str,
    rows: usize,
    cols: usize,
) -> Result<[f64; N], CameraInfoFileError> {
    let at = ini_key(section, key)?;
    let mut values = Vec::with_capacity(rows * cols);
    for row in 0..rows {
        let line = section.get(at + 1 + row).ok_or_else(|| {
            ini_error(
                section[at].number,
                format!("'{key}' needs {rows} rows of {cols} numbers, found {row} rows"),
            )
        })?;
        let numbers = ini_numbers(line, key)?;
        if numbers.len() != cols {
            return Err(ini_error(
                line.number,
                format!(
                    "'{key}' row {} has {} numbers, expected {cols}",
                    row + 1,
                    numbers.len()
                ),
            ));
        }
        values.extend(numbers);
    }
    values.try_into().map_err(|_| {
        ini_error(
            section[at].number,
            format!("'{key}' must have {rows}x{cols} values"),
        )
    })
}

fn ini_numbers(line: &IniLine, key: &str) -> Result<Vec<f64>, CameraInfoFileError> {
    line.text
        .split_whitespace()
        .map(|word| {
            word.parse::<f64>().map_err(|_| {
                ini_error(
                    line.number,
                    format!("'{key}' holds {word:?}, expected a number"),
                )
            })
        })
        .collect()
}

fn ini_camera(
    section: &[IniLine],
    name: &str,
) -> Result<(String, CameraInfo), CameraInfoFileError> {
    let k = ini_matrix::<9>(section, "camera matrix", 3, 3)?;
    let r = ini_matrix::<9>(section, "rectification", 3, 3)?;
    let p = ini_matrix::<12>(section, "projection", 3, 4)?;
    let at = ini_key(section, "distortion")?;
    let line = section.get(at + 1).ok_or_else(|| {
        ini_error(
            section[at].number,
            "'distortion' is not followed by its coefficients",
        )
    })?;
    let d = ini_numbers(line, "distortion")?;
    let distortion_model = match d.len() {
        5 => PLUMB_BOB,
        8 => RATIONAL_POLYNOMIAL,
        n => {
            return Err(ini_error(
                line.number,
                format!(
                    "'distortion' has {n} coefficients, expected 5 (plumb_bob) or 8 (rational_polynomial)"
                ),
            ));
        }
    };
    let info = CameraInfo {
        distortion_model: distortion_model.to_owned(),
        d,
        k,
        r,
        p,
        ..CameraInfo::default()
    };
    Ok((name.to_owned(), info))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn numbers_are_shortest_and_read_back_exactly() {
        assert_eq!(yaml_number(500.0), "500");
        assert_eq!(yaml_number(-0.0), "0");
        assert_eq!(yaml_number(319.5), "319.5");
        assert_eq!(yaml_number(0.1), "0.1");
        assert_eq!(yaml_number(1e-20), "1.0e-20");
        assert_eq!(yaml_number(-2.5e-7), "-2.5e-7");
        for v in [0.1, 1e-20, -2.5e-7, 1e300, 123456.789, f64::MIN_POSITIVE] {
            let parsed: f64 = serde_yaml::from_str(&yaml_number(v)).expect("a YAML number");
            assert_eq!(parsed, v);
        }
    }

    #[test]
    fn strings_are_quoted_only_when_needed() {
        assert_eq!(yaml_string("narrow_stereo/left"), "narrow_stereo/left");
        assert_eq!(yaml_string("true"), "\"true\"");
        assert_eq!(yaml_string("123"), "\"123\"");
        assert_eq!(yaml_string(""), "\"\"");
        assert_eq!(yaml_string("a: b"), "\"a: b\"");
        for name in ["true", "123", "", "a: b", "say \"hi\"\n", "-x", "~"] {
            let read: String = serde_yaml::from_str(&yaml_string(name)).expect("a YAML string");
            assert_eq!(read, name);
        }
    }
}
