//! A device's V4L2 controls as node parameters, settable while the node runs: each
//! control becomes a parameter named after it in snake case (`Brightness` is
//! `brightness`, `Exposure Time, Absolute` is `exposure_time_absolute`), an integer with
//! the control's range, a bool, or a menu's value with its items in the description.
//! Its default is the device's value at start-up; a params file or `-p` value is set on
//! the device when it starts, and every later change as it is made.

use std::collections::HashMap;

use ros2_client::ParameterValue;
use stereocal_runtime::node::RosNode;
use stereocal_runtime::params::ParamSpec;

use super::device::{CameraDevice, Control, ControlKind};

/// The parameter name of a control name: lower case, every run of other characters
/// than letters and digits one `_`.
pub fn param_name(control: &str) -> String {
    let mut name = String::new();
    for c in control.chars() {
        if c.is_ascii_alphanumeric() {
            name.push(c.to_ascii_lowercase());
        } else if !name.is_empty() && !name.ends_with('_') {
            name.push('_');
        }
    }
    name.trim_end_matches('_').to_owned()
}

/// The parameter of `control`.
pub fn spec(control: &Control) -> ParamSpec {
    let name = param_name(&control.name);
    let spec = match &control.kind {
        ControlKind::Integer { min, max, step } => ParamSpec::new(
            &name,
            ParameterValue::Integer(control.value),
            &format!(
                "V4L2 control {:?}: {min} to {max} in steps of {step}",
                control.name
            ),
        )
        .integer_range(*min..=*max),
        ControlKind::Boolean => ParamSpec::new(
            &name,
            ParameterValue::Boolean(control.value != 0),
            &format!("V4L2 control {:?}", control.name),
        ),
        ControlKind::Menu { items } => {
            let listed: Vec<String> = items
                .iter()
                .map(|(v, label)| format!("{v} {label}"))
                .collect();
            let min = items.iter().map(|(v, _)| *v).min().unwrap_or(0);
            let max = items.iter().map(|(v, _)| *v).max().unwrap_or(0);
            ParamSpec::new(
                &name,
                ParameterValue::Integer(control.value),
                &format!("V4L2 control {:?}: {}", control.name, listed.join(", ")),
            )
            .integer_range(min..=max)
        }
    };
    spec.settable_while_running()
}

/// The value of a control parameter for the device.
fn device_value(value: &ParameterValue) -> Option<i64> {
    match value {
        ParameterValue::Integer(v) => Some(*v),
        ParameterValue::Boolean(b) => Some(i64::from(*b)),
        _ => None,
    }
}

/// The controls exposed as parameters and the values last set on the device.
#[derive(Debug, Default)]
pub struct ControlParams {
    controls: Vec<(String, u32)>,
    on_device: HashMap<u32, i64>,
}

impl ControlParams {
    /// The parameters of `controls`, leaving out those whose names are taken by
    /// `taken` (the node's own parameters) or by an earlier control.
    pub fn new(controls: &[Control], taken: &[String]) -> (Self, Vec<ParamSpec>) {
        let mut params = ControlParams::default();
        let mut specs = Vec::new();
        for control in controls {
            let spec = spec(control);
            if spec.name.is_empty()
                || taken.contains(&spec.name)
                || specs.iter().any(|s: &ParamSpec| s.name == spec.name)
            {
                log::warn!(
                    "V4L2 control {:?} not exposed: its parameter name {:?} is taken",
                    control.name,
                    spec.name
                );
                continue;
            }
            params.controls.push((spec.name.clone(), control.id));
            params.on_device.insert(control.id, control.value);
            specs.push(spec);
        }
        (params, specs)
    }

    /// Reads the values on a device that has just started.
    pub fn device_started(&mut self, device: &dyn CameraDevice) {
        match device.controls() {
            Ok(controls) => {
                self.on_device = controls.into_iter().map(|c| (c.id, c.value)).collect();
            }
            Err(e) => log::warn!("controls not read: {e}"),
        }
    }

    /// Sets on `device` every control parameter of `node` whose value differs from the
    /// device's; the device's refusals, each naming the parameter.
    pub fn apply(&mut self, node: &RosNode, device: &mut dyn CameraDevice) -> Vec<String> {
        let mut refusals = Vec::new();
        for (name, id) in &self.controls {
            let Some(value) = node.param(name).ok().as_ref().and_then(device_value) else {
                continue;
            };
            if self.on_device.get(id) == Some(&value) {
                continue;
            }
            // Recorded either way: a refused value is not tried again on every frame.
            self.on_device.insert(*id, value);
            match device.set_control(*id, value) {
                Ok(()) => log::info!("{name} set to {value}"),
                Err(e) => refusals.push(format!("{name}: {e}")),
            }
        }
        refusals
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn control_names_become_snake_case_parameter_names() {
        assert_eq!(param_name("Brightness"), "brightness");
        assert_eq!(
            param_name("Exposure Time, Absolute"),
            "exposure_time_absolute"
        );
        assert_eq!(param_name("White Balance (Auto)"), "white_balance_auto");
        assert_eq!(param_name("  "), "");
    }

    #[test]
    fn controls_become_parameters_with_their_ranges() {
        let controls = [
            Control {
                id: 1,
                name: "Gain".into(),
                kind: ControlKind::Integer {
                    min: 0,
                    max: 255,
                    step: 1,
                },
                value: 32,
            },
            Control {
                id: 2,
                name: "Auto Exposure".into(),
                kind: ControlKind::Menu {
                    items: vec![
                        (1, "Manual Mode".into()),
                        (3, "Aperture Priority Mode".into()),
                    ],
                },
                value: 3,
            },
            Control {
                id: 3,
                name: "Frame ID".into(),
                kind: ControlKind::Boolean,
                value: 0,
            },
        ];
        let (params, specs) = ControlParams::new(&controls, &["frame_id".to_owned()]);
        assert_eq!(specs.len(), 2, "frame_id is the node's own");
        assert_eq!(params.controls.len(), 2);
        assert_eq!(specs[0].default, ParameterValue::Integer(32));
        assert!(specs[0].accept(ParameterValue::Integer(256)).is_err());
        assert!(!specs[0].read_only);
        assert!(
            specs[1]
                .description
                .contains("1 Manual Mode, 3 Aperture Priority Mode")
        );
        assert!(specs[1].accept(ParameterValue::Integer(3)).is_ok());
        assert!(specs[1].accept(ParameterValue::Integer(4)).is_err());
    }
}
