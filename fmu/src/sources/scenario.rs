//! The scenario player FMU (`osiris_scenario`): an OSMP SensorView source that plays the built-in
//! scenario, a scenario JSON, or a recorded SensorView trace ([`osiris_scenario::Player`]), so that
//! any OSMP sensor FMU can be driven from osiris scenarios.
//!
//! Parameters ([`crate::variables::SOURCE_VARIABLES`]):
//! * `scenario` (start `scenario.json`, the built-in scenario shipped in `resources/`): a JSON file
//!   path relative to the resources directory or absolute, inline JSON starting with `{`, or empty
//!   for the built-in scenario.
//! * `trace_path` (start empty): a SensorView trace (`.osi` or `.mcap`) to play instead, relative to the
//!   resources directory or absolute. Setting both `scenario` and `trace_path` is an error.
//! * `sensor` (start empty): the scenario's sensor mount whose view is played; empty: the first of
//!   the scenario's `sensors`. For an `.mcap` trace: the SensorView channel to play (its topic, or
//!   the sensor whose recorded input it is, `<sensor>.OSMPSensorViewIn`; empty: the only one).
//!   Unused (a warning) for an `.osi` trace.
//!
//! Time: the FMI time is the scenario's own time (step `k` at `k · step_s`) or, for a trace, the
//! time since its first message; see [`osiris_scenario::player`].

use std::path::{Path, PathBuf};

use osiris_scenario::{Player, ScenarioConfig};

use crate::descriptor::{
    FmuDescriptor, SourceBuild, SourceFrame, SourceRole, SourceSettings, ViewSource,
};

/// Descriptor of the scenario player FMU: modelIdentifier `osiris_scenario`, default experiment =
/// the built-in scenario's steps and duration.
pub static DESCRIPTOR: FmuDescriptor = FmuDescriptor::source(
    "osiris scenario",
    "osiris_scenario",
    "osiris scenario player: an OSMP 1.6.0 SensorView source (OSI 3.8.0 SensorView out in \
     OSMPSensorViewOut, nothing in). Plays the built-in scenario (a straight 3-lane road with \
     vehicles, a cyclist, a pedestrian, a guardrail and static targets), a scenario JSON \
     (parameter scenario), or a recorded SensorView trace (parameter trace_path), as the view of \
     one of the scenario's sensor mounts (parameter sensor; the view carries the global ground \
     truth and that mount), so that any OSMP sensor FMU can be driven from it.",
    SourceRole {
        build_source: build,
        default_experiment,
        resources,
    },
);

/// `(stepSize, stopTime)` of the built-in scenario.
fn default_experiment() -> (f64, f64) {
    let c = ScenarioConfig::default();
    (c.step_s, c.duration_s)
}

/// The built-in scenario as pretty JSON: the content of the FMU's `resources/scenario.json` (what
/// the `scenario` parameter's start value names).
pub fn default_scenario_json() -> String {
    let mut json = ScenarioConfig::default().to_json_pretty();
    json.push('\n');
    json
}

fn resources() -> Vec<(&'static str, String)> {
    vec![("scenario.json", default_scenario_json())]
}

impl ViewSource for Player {
    fn view_at(
        &mut self,
        t_s: f64,
        notes: &mut Vec<String>,
    ) -> Result<Option<SourceFrame<'_>>, String> {
        let view = Player::view_at(self, t_s, notes).map_err(|e| e.to_string())?;
        Ok(view.map(|v| SourceFrame {
            bytes: v.bytes,
            count: v
                .view
                .global_ground_truth
                .as_ref()
                .map_or(0, |gt| gt.moving_object.len()),
        }))
    }
}

/// A non-empty trimmed parameter value.
fn given(value: Option<&str>) -> Option<&str> {
    value.map(str::trim).filter(|v| !v.is_empty())
}

/// A file parameter's path: absolute as given, else relative to the resources directory.
fn resolve(param: &str, value: &str, resources: Option<&Path>) -> Result<PathBuf, String> {
    let path = Path::new(value);
    if path.is_absolute() {
        return Ok(path.to_path_buf());
    }
    match resources {
        Some(dir) => Ok(dir.join(path)),
        None => Err(format!(
            "parameter `{param}` = {value:?} is a path relative to the FMU's resources directory, \
             but fmi2Instantiate got no resource location; pass one or use an absolute path"
        )),
    }
}

/// Build the player from the parameters (see the module documentation).
fn build(s: &SourceSettings<'_>) -> Result<SourceBuild, String> {
    let mut warnings = Vec::new();
    if let Some(trace) = given(s.trace_path) {
        if let Some(scenario) = given(s.scenario) {
            return Err(format!(
                "set either `scenario` ({scenario:?}) or `trace_path` ({trace:?}), not both"
            ));
        }
        let path = resolve("trace_path", trace, s.resources_dir)?;
        let is_mcap = path
            .extension()
            .is_some_and(|e| e.eq_ignore_ascii_case("mcap"));
        let sensor = given(s.sensor);
        if let (Some(sensor), false) = (sensor, is_mcap) {
            warnings.push(format!(
                "parameter `sensor` = {sensor:?} is ignored: an .osi trace plays its SensorViews \
                 as recorded"
            ));
        }
        let player = Player::trace(&path, sensor.filter(|_| is_mcap), &mut warnings)
            .map_err(|e| format!("parameter `trace_path`: {e}"))?;
        let summary = player.describe();
        return Ok(SourceBuild {
            source: Box::new(player),
            warnings,
            summary,
        });
    }

    let (config, origin) = match s.scenario {
        // The start value names the shipped resources/scenario.json, the built-in scenario.
        None if s.resources_dir.is_none() => {
            warnings.push(
                "no resource location was passed to fmi2Instantiate, so `scenario` = \
                 \"scenario.json\" cannot be read; playing the built-in scenario (which the \
                 shipped resources/scenario.json holds)"
                    .to_owned(),
            );
            (
                ScenarioConfig::default(),
                "the built-in scenario".to_owned(),
            )
        }
        value => {
            let text = value.unwrap_or("scenario.json").trim();
            if text.is_empty() {
                (
                    ScenarioConfig::default(),
                    "the built-in scenario".to_owned(),
                )
            } else if text.starts_with('{') {
                let c = ScenarioConfig::from_json_str(text)
                    .map_err(|e| format!("parameter `scenario` (inline JSON): {e}"))?;
                (c, "inline JSON".to_owned())
            } else {
                let path = resolve("scenario", text, s.resources_dir)?;
                let c = ScenarioConfig::from_json_file(&path)
                    .map_err(|e| format!("parameter `scenario`: {e}"))?;
                (c, format!("`{}`", path.display()))
            }
        }
    };
    let sensor = given(s.sensor);
    let player = Player::scenario(config, sensor).map_err(|e| match sensor {
        Some(name) => format!("parameter `sensor` = {name:?}: {e} (scenario from {origin})"),
        None => format!("{e} (scenario from {origin})"),
    })?;
    let summary = format!("{} from {origin}", player.describe());
    Ok(SourceBuild {
        source: Box::new(player),
        warnings,
        summary,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn default_experiment_is_the_built_in_scenario() {
        let c = ScenarioConfig::default();
        assert_eq!(DESCRIPTOR.default_step_size_s(), c.step_s);
        assert_eq!(DESCRIPTOR.default_stop_time_s(), Some(c.duration_s));
        assert_eq!(
            ScenarioConfig::from_json_str(&default_scenario_json()).unwrap(),
            c
        );
    }
}
