//! The scenario player FMU (an OSMP SensorView source) through the in-process ABI: what it publishes
//! is decoded independently (the generated OSI types) and compared with `ScenarioConfig`'s own
//! SensorView of the same time; parameters (scenario file, inline JSON, sensor, trace) and their
//! errors; the initial view as an InitialUnknown; the end of the recording; and a source → radar
//! chain in one process.

mod common;

use common::*;
use osiris_fmu::descriptor::{SourceBuild, SourceRole, SourceSettings};
use osiris_fmu::variables::vr;
use osiris_fmu::variables::vr::source as svr;
use osiris_fmu::{FmuDescriptor, sources};
use osiris_proto::trace::OsiTraceWriter;
use osiris_proto::{Message, osi3};
use osiris_scenario::{ScenarioConfig, SensorMount};

fn scenario_fmu() -> Inst {
    Inst::new(&sources::scenario::DESCRIPTOR)
}

fn instance_with_resources(dir: &std::path::Path) -> Inst {
    Inst::try_new(
        &sources::scenario::DESCRIPTOR,
        Opts {
            resources: Some(Some(dir_uri(dir))),
            ..Opts::default()
        },
    )
    .unwrap_or_else(|log| panic!("instantiate failed: {:?}", log.records()))
}

/// The published `OSMPSensorViewOut`, decoded (None for 0/0/0).
fn view_out(i: &Inst) -> Option<osi3::SensorView> {
    let (s, t) = i.get_ints(&svr::integer::SENSOR_VIEW_OUT);
    assert_eq!(s, OK, "{:?}", i.records());
    read_triple([t[0], t[1], t[2]]).map(|b| osi3::SensorView::decode(b.as_slice()).unwrap())
}

fn valid(i: &Inst) -> bool {
    let mut v = -1;
    let s = unsafe { osiris_fmu::abi::get_boolean(i.c, &svr::boolean::VALID, 1, &mut v) };
    assert_eq!(s, OK);
    v != 0
}

fn count(i: &Inst) -> i32 {
    let (s, c) = i.get_ints(&[svr::integer::COUNT]);
    assert_eq!(s, OK);
    c[0]
}

/// The error records of an instance's log, joined.
fn errors(i: &Inst) -> String {
    i.records()
        .iter()
        .filter(|r| r.status == ERROR as i32)
        .map(|r| r.message.clone())
        .collect::<Vec<_>>()
        .join("\n")
}

fn mount<'a>(c: &'a ScenarioConfig, name: &str) -> &'a SensorMount {
    c.sensor(name).unwrap()
}

#[test]
fn plays_the_built_in_scenario_at_each_communication_point() {
    let c = ScenarioConfig::default();
    let first = &c.sensors[0];
    let i = scenario_fmu();
    i.init();
    // Initialization publishes the view at the start time.
    assert_eq!(view_out(&i).unwrap(), c.sensor_view(0, first));
    assert!(valid(&i));
    // fmi2DoStep(t, h) publishes the view at t + h.
    let mut t = 0.0;
    for k in 0..c.step_count() {
        assert_eq!(i.step(t, c.step_s), OK, "{:?}", i.records().last());
        t += c.step_s;
        let expected = c.sensor_view(k + 1, first);
        let got = view_out(&i).expect("a view inside the scenario");
        assert_eq!(got, expected, "step {}", k + 1);
        assert!(valid(&i));
        assert_eq!(
            count(&i) as usize,
            expected.global_ground_truth.unwrap().moving_object.len()
        );
    }
    // The last doStep reached t = duration_s; past it there is no view.
    assert_eq!(i.step(t, c.step_s), OK);
    assert!(view_out(&i).is_none());
    assert!(!valid(&i));
    assert_eq!(count(&i), 0);
    assert_all_formats_are_percent_s(&i.records());
}

#[test]
fn the_sensor_parameter_picks_the_mount_and_a_start_time_the_step() {
    let c = ScenarioConfig::default();
    let i = scenario_fmu();
    assert_eq!(i.set_strings(&[svr::string::SENSOR], &["front_lidar"]), OK);
    assert_eq!(
        unsafe { osiris_fmu::abi::setup_experiment(i.c, 0, 0.0, 0.5, 0, 0.0) },
        OK
    );
    assert_eq!(i.enter(), OK);
    assert_eq!(i.exit(), OK);
    let view = view_out(&i).unwrap();
    assert_eq!(view, c.sensor_view(50, mount(&c, "front_lidar")));
    assert_eq!(view.lidar_sensor_view.len(), 1);
    assert_eq!(view.sensor_id, Some(osiris_proto::id(30)));
    // Between scenario steps: the constant-velocity motion at that time.
    assert_eq!(i.step(0.5, 0.005), OK);
    assert_eq!(
        view_out(&i).unwrap(),
        c.sensor_view_at(0.505, mount(&c, "front_lidar"))
    );
    let (s, v) = i.get_strings(&[
        svr::string::SCENARIO,
        svr::string::TRACE_PATH,
        svr::string::SENSOR,
    ]);
    assert_eq!(s, OK);
    assert_eq!(v, ["scenario.json", "", "front_lidar"]);
}

#[test]
fn inline_json_and_a_scenario_file_in_the_resources() {
    let mut c = ScenarioConfig {
        step_s: 0.05,
        duration_s: 1.0,
        ..ScenarioConfig::default()
    };
    c.road_users.truncate(2);
    c.sensors.reverse();
    // Inline JSON.
    let i = scenario_fmu();
    let json = serde_json_compact(&c);
    assert_eq!(i.set_strings(&[svr::string::SCENARIO], &[&json]), OK);
    i.init();
    assert_eq!(view_out(&i).unwrap(), c.sensor_view(0, &c.sensors[0]));
    assert_eq!(count(&i), 3);
    // A file relative to the resources directory.
    let dir = tempfile::tempdir().unwrap();
    std::fs::create_dir(dir.path().join("scenarios")).unwrap();
    std::fs::write(
        dir.path().join("scenarios").join("short.json"),
        c.to_json_pretty(),
    )
    .unwrap();
    let i = instance_with_resources(dir.path());
    assert_eq!(
        i.set_strings(&[svr::string::SCENARIO], &["scenarios/short.json"]),
        OK
    );
    i.init();
    assert_eq!(i.step(0.0, 0.05), OK);
    assert_eq!(view_out(&i).unwrap(), c.sensor_view(1, &c.sensors[0]));
    // An empty `scenario`: the built-in scenario, even without resources.
    let i = Inst::try_new(
        &sources::scenario::DESCRIPTOR,
        Opts {
            resources: Some(None),
            ..Opts::default()
        },
    )
    .unwrap();
    assert_eq!(i.set_strings(&[svr::string::SCENARIO], &[""]), OK);
    i.init();
    let d = ScenarioConfig::default();
    assert_eq!(view_out(&i).unwrap(), d.sensor_view(0, &d.sensors[0]));
}

/// The start value without a resource location: the built-in scenario, with a warning.
#[test]
fn no_resource_location_plays_the_built_in_scenario_with_a_warning() {
    let i = Inst::try_new(
        &sources::scenario::DESCRIPTOR,
        Opts {
            resources: Some(None),
            ..Opts::default()
        },
    )
    .unwrap();
    assert_eq!(i.setup(), OK);
    assert_eq!(i.enter(), OK);
    assert_eq!(i.exit(), WARNING);
    assert!(i.log.contains("no resource location"), "{:?}", i.records());
    let d = ScenarioConfig::default();
    assert_eq!(view_out(&i).unwrap(), d.sensor_view(0, &d.sensors[0]));
}

fn serde_json_compact(c: &ScenarioConfig) -> String {
    // The pretty JSON on one line (inline JSON is what a master passes as a String parameter).
    c.to_json_pretty().lines().map(str::trim).collect()
}

#[test]
fn the_initial_view_is_an_initial_unknown_recomputed_after_a_parameter_change() {
    let c = ScenarioConfig::default();
    let i = scenario_fmu();
    assert_eq!(i.setup(), OK);
    assert_eq!(i.enter(), OK);
    // Reading an output in initialization mode computes it.
    assert_eq!(view_out(&i).unwrap(), c.sensor_view(0, &c.sensors[0]));
    assert!(valid(&i));
    assert_eq!(count(&i), 6);
    // A parameter change in initialization mode recomputes it.
    assert_eq!(i.set_strings(&[svr::string::SENSOR], &["front_radar"]), OK);
    assert_eq!(
        view_out(&i).unwrap(),
        c.sensor_view(0, mount(&c, "front_radar"))
    );
    assert_eq!(i.exit(), OK);
    assert_eq!(
        view_out(&i).unwrap(),
        c.sensor_view(0, mount(&c, "front_radar"))
    );
    // Fixed parameters cannot change after initialization; outputs and unknown VRs are rejected.
    assert_eq!(
        i.set_strings(&[svr::string::SENSOR], &["front_lidar"]),
        ERROR
    );
    assert_eq!(
        i.set_ints(&[svr::integer::SENSOR_VIEW_OUT_SIZE], &[4]),
        ERROR
    );
    assert!(i.log.contains("is an output"));
    assert_eq!(i.get_reals(&[vr::real::RANGE_M]).0, ERROR);
    assert_eq!(i.get_ints(&[9]).0, ERROR);
    assert!(i.log.contains("unknown Integer value reference 9"));
    // The instance is still usable.
    assert_eq!(i.step(0.0, 0.01), OK);
    assert_eq!(
        view_out(&i).unwrap(),
        c.sensor_view(1, mount(&c, "front_radar"))
    );
}

#[test]
fn outputs_are_double_buffered() {
    let i = scenario_fmu();
    i.init();
    assert_eq!(i.step(0.0, 0.01), OK);
    let t1 = i.triple(svr::integer::SENSOR_VIEW_OUT);
    let b1 = read_triple(t1).unwrap();
    assert_eq!(i.step(0.01, 0.01), OK);
    let t2 = i.triple(svr::integer::SENSOR_VIEW_OUT);
    assert_ne!(t1[..2], t2[..2], "a new buffer");
    // The buffer of the step before is intact until the next step starts.
    assert_eq!(read_triple(t1).unwrap(), b1);
}

/// Bad parameters fail initialization with `fmi2Error` naming the parameter and the file; the
/// instance can be reset and used.
#[test]
fn bad_parameters_are_errors_naming_the_parameter() {
    let dir = resources_dir_of(&sources::scenario::DESCRIPTOR);
    std::fs::write(
        dir.path().join("bad.json"),
        "{\n  \"duration_s\": 2.0,\n  \"speed\": 1\n}",
    )
    .unwrap();
    let missing_trace = dir.path().join("nowhere").join("views.osi");
    /// (what, the String parameters set, the texts the error must hold).
    type Case<'a> = (&'a str, Vec<(u32, String)>, Vec<&'a str>);
    let cases: Vec<Case> = vec![
        (
            "missing trace",
            vec![(svr::string::TRACE_PATH, missing_trace.display().to_string())],
            vec!["parameter `trace_path`", "nowhere/views.osi"],
        ),
        (
            "trace relative to the resources, missing",
            vec![(svr::string::TRACE_PATH, "views.osi".into())],
            vec!["parameter `trace_path`", "views.osi"],
        ),
        (
            "unsupported trace format",
            vec![(svr::string::TRACE_PATH, "views.bag".into())],
            vec!["parameter `trace_path`", "unsupported format `.bag`"],
        ),
        (
            "missing scenario file",
            vec![(svr::string::SCENARIO, "missing.json".into())],
            vec!["parameter `scenario`", "missing.json"],
        ),
        (
            "bad scenario file",
            vec![(svr::string::SCENARIO, "bad.json".into())],
            vec!["parameter `scenario`", "bad.json", "line 3", "`speed`"],
        ),
        (
            "bad inline JSON",
            vec![(svr::string::SCENARIO, "{\"duration_s\": -1".into())],
            vec!["parameter `scenario` (inline JSON)", "line 1"],
        ),
        (
            "invalid scenario values",
            vec![(
                svr::string::SCENARIO,
                serde_json_compact(&ScenarioConfig {
                    step_s: -0.01,
                    ..ScenarioConfig::default()
                }),
            )],
            vec!["parameter `scenario` (inline JSON)", "`step_s`"],
        ),
        (
            "unknown sensor",
            vec![(svr::string::SENSOR, "rear_radar".into())],
            vec![
                "parameter `sensor` = \"rear_radar\"",
                "`front_camera`, `front_radar`, `front_lidar`",
            ],
        ),
        (
            "both scenario and trace",
            vec![
                (svr::string::SCENARIO, "scenario.json".into()),
                (svr::string::TRACE_PATH, "views.osi".into()),
            ],
            vec!["either `scenario`", "`trace_path`", "not both"],
        ),
    ];
    for (what, params, needles) in cases {
        let i = instance_with_resources(dir.path());
        for (r, value) in &params {
            assert_eq!(i.set_strings(&[*r], &[value]), OK, "{what}");
        }
        assert_eq!(i.setup(), OK);
        assert_eq!(i.enter(), OK);
        assert_eq!(i.exit(), ERROR, "{what}: {:?}", i.records());
        let e = errors(&i);
        for n in needles {
            assert!(e.contains(n), "{what}: `{n}` not in {e}");
        }
        // The error state: no stepping; the outputs read as "no view"; reset recovers.
        assert_eq!(i.step(0.0, 0.01), ERROR, "{what}");
        assert!(view_out(&i).is_none());
        assert_eq!(i.reset(), OK);
        i.init();
        assert!(view_out(&i).is_some(), "{what}: after reset");
        assert_all_formats_are_percent_s(&i.records());
    }
}

/// The error is also reported when the importer reads an output during initialization.
#[test]
fn a_bad_parameter_fails_the_initial_get() {
    let i = scenario_fmu();
    assert_eq!(i.set_strings(&[svr::string::SENSOR], &["nope"]), OK);
    assert_eq!(i.setup(), OK);
    assert_eq!(i.enter(), OK);
    assert_eq!(i.get_ints(&svr::integer::SENSOR_VIEW_OUT).0, ERROR);
    assert!(errors(&i).contains("`nope`"));
    assert_eq!(i.exit(), ERROR, "the instance is in the error state");
}

fn write_trace(path: &std::path::Path, frames: &[Vec<u8>]) {
    let mut w = OsiTraceWriter::create(path).unwrap();
    for f in frames {
        w.write_raw(f).unwrap();
    }
    w.finish().unwrap();
}

#[test]
fn plays_a_trace_byte_for_byte_and_warns_about_skipped_frames() {
    let c = ScenarioConfig::default();
    let radar = mount(&c, "front_radar");
    let dir = tempfile::tempdir().unwrap();
    let mut frames: Vec<Vec<u8>> = (0..10)
        .map(|k| c.sensor_view(k, radar).encode_to_vec())
        .collect();
    frames.insert(4, vec![0xff; 9]); // not a SensorView
    write_trace(&dir.path().join("radar.osi"), &frames);
    let i = instance_with_resources(dir.path());
    assert_eq!(
        i.set_strings(
            &[
                svr::string::TRACE_PATH,
                svr::string::SCENARIO,
                svr::string::SENSOR
            ],
            &["radar.osi", "", "front_radar"],
        ),
        OK
    );
    assert_eq!(i.setup(), OK);
    assert_eq!(i.enter(), OK);
    // The ignored `sensor` is a warning.
    assert_eq!(i.exit(), WARNING);
    assert!(i.log.contains("`sensor` = \"front_radar\" is ignored"));
    let published = |i: &Inst| read_triple(i.triple(svr::integer::SENSOR_VIEW_OUT));
    assert_eq!(published(&i).unwrap(), frames[0]);
    let mut t = 0.0;
    let mut statuses = Vec::new();
    for k in 1..10 {
        statuses.push(i.step(t, c.step_s));
        t += c.step_s;
        let expected = if k < 4 { &frames[k] } else { &frames[k + 1] };
        assert_eq!(published(&i).as_ref(), Some(expected), "step {k}");
        assert_eq!(count(&i), 6);
    }
    // The bad frame is a warning naming the file and the frame when the player reads past it.
    assert_eq!(statuses.iter().filter(|s| **s == WARNING).count(), 1);
    assert!(
        i.log.contains("radar.osi`: frame 4: not a SensorView"),
        "{:?}",
        i.records()
    );
    // After the last message: no view.
    assert_eq!(i.step(t, c.step_s), OK);
    assert!(published(&i).is_none());
    assert!(!valid(&i));
}

#[test]
fn a_trace_that_breaks_off_is_an_error_naming_the_file() {
    let c = ScenarioConfig::default();
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("cut.osi");
    let frames: Vec<Vec<u8>> = (0..3)
        .map(|k| c.sensor_view(k, &c.sensors[0]).encode_to_vec())
        .collect();
    write_trace(&path, &frames);
    let mut bytes = std::fs::read(&path).unwrap();
    bytes.truncate(bytes.len() - 10);
    std::fs::write(&path, bytes).unwrap();
    let i = instance_with_resources(dir.path());
    assert_eq!(
        i.set_strings(
            &[svr::string::TRACE_PATH, svr::string::SCENARIO],
            &["cut.osi", ""]
        ),
        OK
    );
    i.init();
    // Reading ahead past frame 1 hits the truncated frame 2.
    assert_eq!(i.step(0.0, c.step_s), ERROR);
    let e = errors(&i);
    assert!(e.contains("cut.osi") && e.contains("frame 2"), "{e}");
    assert!(view_out(&i).is_none());
}

/// A source → radar chain in one process: each step the radar gets the source's current output.
#[test]
fn drives_the_radar_in_process() {
    let source = scenario_fmu();
    assert_eq!(
        source.set_strings(&[svr::string::SENSOR], &["front_radar"]),
        OK
    );
    source.init();
    let radar = Inst::radar();
    assert_eq!(radar.set_strings(&[vr::string::MODE], &["ideal"]), OK);
    radar.init();
    let mut t = 0.0;
    let h = 0.05;
    let mut seen = std::collections::HashSet::new();
    for _ in 0..10 {
        let triple = source.triple(svr::integer::SENSOR_VIEW_OUT);
        assert_eq!(radar.set_ints(&vr::integer::SENSOR_VIEW_IN, &triple), OK);
        assert_eq!(radar.step(t, h), OK, "{:?}", radar.records().last());
        assert_eq!(source.step(t, h), OK);
        let sd = radar.sensor_data().expect("SensorData");
        let ts = osiris_proto::timestamp_to_seconds(sd.timestamp.as_ref().unwrap());
        assert!(
            (ts - t).abs() < 1e-9,
            "the radar sees the world at its communication point: {ts} s at {t} s"
        );
        for o in &sd.moving_object {
            if let Some(id) = o.header.as_ref().and_then(|h| h.ground_truth_id.first()) {
                seen.insert(id.value.unwrap());
            }
        }
        t += h;
    }
    // The car 40 m ahead (id 100) and the truck (id 101) are detected.
    assert!(seen.contains(&100) && seen.contains(&101), "{seen:?}");
}

fn panicking_source(_: &SourceSettings<'_>) -> Result<SourceBuild, String> {
    panic!("deliberate test panic in a source builder")
}

static PANICKING: FmuDescriptor = FmuDescriptor::source(
    "panicking source",
    "osiris_panicking_source",
    "test",
    SourceRole {
        build_source: panicking_source,
        default_experiment: || (0.01, 1.0),
        resources: Vec::new,
    },
);

#[test]
fn a_panicking_source_is_fatal_not_undefined_behaviour() {
    let i = Inst::new(&PANICKING);
    assert_eq!(i.setup(), OK);
    assert_eq!(i.enter(), OK);
    assert_eq!(i.exit(), FATAL);
    assert!(i.log.contains("deliberate test panic"));
    assert_eq!(i.step(0.0, 0.01), ERROR);
    assert_eq!(i.reset(), ERROR);
}
