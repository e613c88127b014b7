//! The built-in scenario is valid input: every SensorView it generates passes the screening the
//! FMUs apply (`osiris_models::input`), so the default run logs no input warning.

use osiris::scenario::ScenarioConfig;
use osiris_models::input::screen_view;

#[test]
fn the_built_in_scenario_passes_the_input_screening() {
    let scenario = ScenarioConfig::default();
    let steps = scenario.step_count();
    assert!(steps > 0);
    for step in (0..steps).step_by(7).chain([steps - 1]) {
        for mount in &scenario.sensors {
            let mut view = scenario.sensor_view(step, mount);
            let before = view.clone();
            let s = screen_view(&mut view);
            assert!(s.is_clean(), "step {step}, {}: {:?}", mount.name, s.issues);
            assert_eq!(view, before);
        }
    }
}
