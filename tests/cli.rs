//! `osiris package` and `osiris run` end to end: the FMU archives follow FMI 2.0 §2.3, the main job
//! writes SensorData traces that decode and hold what the scenario puts in front of each sensor, a
//! SensorView trace works as a scenario source, and bad inputs give clear errors.

use std::collections::BTreeSet;
use std::io::Read;
use std::path::{Path, PathBuf};
use std::sync::OnceLock;

use clap::Parser;
use osiris::cli::{Cli, main_with};
use osiris::package::{PackageOptions, package};
use osiris::scenario::ScenarioConfig;
use osiris::trace::{OsiTraceReader, OsiTraceWriter, read_messages};
use osiris_models::SensorKind;
use osiris_proto::{Message, osi3, perception};

/// The three FMUs, packaged once per test process (libraries of the test profile, built if needed)
/// into cargo's per-target scratch folder, which the next run overwrites (a static temporary folder
/// would never be removed: statics are not dropped).
fn fmu_dir() -> &'static Path {
    static DIR: OnceLock<PathBuf> = OnceLock::new();
    DIR.get_or_init(|| {
        let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("cli-fmus");
        let opts = PackageOptions {
            out_dir: dir.clone(),
            ..PackageOptions::default()
        };
        let written = package(&opts).unwrap_or_else(|e| panic!("packaging failed: {e}"));
        assert_eq!(written.len(), 3);
        dir
    })
}

fn run_cli(args: &[&str]) -> anyhow::Result<()> {
    let mut argv = vec!["osiris"];
    argv.extend_from_slice(args);
    main_with(Cli::try_parse_from(argv)?)
}

fn files_in(dir: &Path) -> Vec<PathBuf> {
    let mut v: Vec<PathBuf> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect();
    v.sort();
    v
}

/// The SensorData trace of a sensor in `out` (standard name `<UTC>_sd_380_014_<frames>_<name>.osi`).
fn sd_trace(out: &Path, sensor: &str) -> PathBuf {
    let suffix = format!("_{}.osi", sensor.replace('_', "-"));
    files_in(out)
        .into_iter()
        .find(|p| {
            let n = p.file_name().unwrap().to_string_lossy();
            n.contains("_sd_380_") && n.ends_with(&suffix)
        })
        .unwrap_or_else(|| panic!("no SensorData trace for {sensor} in {:?}", files_in(out)))
}

#[test]
fn fmu_archives_follow_the_fmi_layout() {
    for kind in SensorKind::ALL {
        let path = fmu_dir().join(format!("{}.fmu", kind.name()));
        let mut zip = zip::ZipArchive::new(std::fs::File::open(&path).unwrap()).unwrap();
        let names: BTreeSet<String> = zip.file_names().map(str::to_owned).collect();
        let expected: BTreeSet<String> = [
            "modelDescription.xml".to_owned(),
            format!("binaries/linux64/osiris_{}.so", kind.name()),
            "resources/config.json".to_owned(),
            "documentation/index.html".to_owned(),
            "documentation/externalDependencies.txt".to_owned(),
        ]
        .into();
        assert_eq!(names, expected, "{}", path.display());
        for i in 0..zip.len() {
            let f = zip.by_index(i).unwrap();
            // FMI 2.0 §2.3: deflate or stored, no encryption, no backslashes, no zip64.
            assert!(matches!(
                f.compression(),
                zip::CompressionMethod::Deflated | zip::CompressionMethod::Stored
            ));
            assert!(!f.encrypted());
            assert!(!f.name().contains('\\'));
        }
        // The archive's modelDescription is the checked-in one.
        let mut xml = String::new();
        zip.by_name("modelDescription.xml")
            .unwrap()
            .read_to_string(&mut xml)
            .unwrap();
        let checked_in = std::fs::read_to_string(
            Path::new(env!("CARGO_MANIFEST_DIR"))
                .join(format!("modelDescription/{}.xml", kind.name())),
        )
        .unwrap();
        assert_eq!(
            xml,
            checked_in,
            "{} modelDescription differs from the checked-in file",
            kind.name()
        );
        // The shipped config is the sensor's built-in configuration and parses.
        let mut cfg = String::new();
        zip.by_name("resources/config.json")
            .unwrap()
            .read_to_string(&mut cfg)
            .unwrap();
        let parsed = osiris_models::SensorConfig::from_json_str(&cfg).unwrap();
        assert_eq!(parsed, osiris_models::SensorConfig::default_for(kind));
    }
}

#[test]
fn main_job_writes_traces_that_show_the_scenario() {
    let out = tempfile::tempdir().unwrap();
    let fmus = fmu_dir().to_str().unwrap();
    run_cli(&[
        "run",
        "--fmu-dir",
        fmus,
        "--out",
        out.path().to_str().unwrap(),
        "--max-frames",
        "60",
        "--quiet",
    ])
    .unwrap();

    let scenario = ScenarioConfig::default();
    // 0.6 s of the scenario: 20 camera, 12 radar and 6 LiDAR cycles.
    let steps: usize = 60;
    let object_ids = |sd: &osi3::SensorData| -> BTreeSet<u64> {
        sd.moving_object
            .iter()
            .flat_map(|o| o.header.as_ref().unwrap().ground_truth_id.iter())
            .map(|i| i.value.unwrap())
            .collect()
    };
    // Ground truth of the feature detections: the PerceptionData's (radar peaks and LiDAR points
    // are the detections, index for index); the OSI `object_id` names the detected object.
    let feature_ids = |p: &perception::PerceptionData| -> BTreeSet<u64> {
        p.radar
            .iter()
            .flat_map(|r| r.peak.iter().filter_map(|k| k.object_id?.value))
            .chain(p.lidar.iter().flat_map(|l| l.object_id.iter().copied()))
            .filter(|&i| i != osiris_proto::INVALID_ID)
            .collect()
    };
    for mount in &scenario.sensors {
        let frames: Vec<osi3::SensorData> =
            read_messages(sd_trace(out.path(), &mount.name)).unwrap();
        // Each sensor runs at its own cycle, rounded to a multiple of the scenario step.
        let defaults = osiris_models::SensorConfig::default_for(mount.kind);
        let k = (defaults.update_cycle_s / scenario.step_s).round().max(1.0) as usize;
        let expected = steps.div_ceil(k);
        assert_eq!(frames.len(), expected, "{}", mount.name);
        assert_eq!(defaults.mode, osiris_models::ModelMode::Physical);
        let first = &frames[0];
        // What the sensor saw in its first cycle: the camera's recognised objects (per frame, no
        // tracker); the radar's and LiDAR's feature detections (their trackers confirm objects
        // after a few cycles).
        let pd_all: Vec<perception::PerceptionData> =
            read_messages(out.path().join(format!("{}.perception.osi", mount.name))).unwrap();
        let pd_first = &pd_all[0];
        let ids = if mount.kind == SensorKind::Camera {
            object_ids(first)
        } else {
            feature_ids(pd_first)
        };
        // OSI 3.8.0 detection semantics in every frame (`osiris_models::semantics`).
        for (k, sd) in frames.iter().enumerate() {
            let v = osiris_models::semantics::violations(sd, None);
            assert!(v.is_empty(), "{} frame {k}: {v:?}", mount.name);
        }
        // The car 40 m ahead of the ego in the same lane (id 100) is seen by every front sensor.
        assert!(ids.contains(&100), "{}: {ids:?}", mount.name);
        // The host vehicle (id 1) is never part of its own sensors' scene.
        assert!(!ids.contains(&scenario.ego_id()), "{}", mount.name);
        // The car behind the ego (id 102) is outside the camera's and radar's forward field of view.
        if mount.kind != SensorKind::Lidar {
            assert!(!ids.contains(&102), "{}: {ids:?}", mount.name);
        } else {
            assert!(ids.contains(&102), "{}: {ids:?}", mount.name);
        }
        // Every sensor reports the car ahead as a (tracked) object, the physical ones once their
        // tracker confirmed it.
        let reported = frames
            .iter()
            .rposition(|sd| object_ids(sd).contains(&100))
            .unwrap_or_else(|| panic!("{}: the car ahead is never reported", mount.name));
        let last = &frames[reported];
        // Mounting position: SensorData's equals the SensorView's (the scenario's mounting).
        let mp = first.mounting_position.as_ref().unwrap();
        let pos = mp.position.as_ref().unwrap();
        let m = mount.mounting();
        assert_eq!(
            [pos.x.unwrap(), pos.y.unwrap(), pos.z.unwrap()],
            m.position_m
        );
        let fd = first.feature_data.as_ref().unwrap();
        let headers: Vec<_> = match mount.kind {
            SensorKind::Radar => fd.radar_sensor.iter().map(|d| d.header.as_ref()).collect(),
            SensorKind::Lidar => fd.lidar_sensor.iter().map(|d| d.header.as_ref()).collect(),
            SensorKind::Camera => fd.camera_sensor.iter().map(|d| d.header.as_ref()).collect(),
        };
        assert_eq!(headers.len(), 1, "{}", mount.name);
        assert_eq!(headers[0].unwrap().mounting_position.as_ref(), Some(mp));
        // The car ahead is in front of the sensor in the sensor frame (the gap closes from 40 m by
        // 5 m/s: the ego is faster).
        let car = last
            .moving_object
            .iter()
            .find(|o| {
                o.header
                    .as_ref()
                    .unwrap()
                    .ground_truth_id
                    .first()
                    .and_then(|g| g.value)
                    == Some(100)
            })
            .unwrap();
        let p = car.base.as_ref().unwrap().position.as_ref().unwrap();
        assert!(
            p.x.unwrap() > 20.0 && p.x.unwrap() < 45.0 && p.y.unwrap().abs() < 1.0,
            "{}: {p:?}",
            mount.name
        );

        // PerceptionData trace: one message per sensor step, of this sensor's kind.
        let pd: Vec<perception::PerceptionData> =
            read_messages(out.path().join(format!("{}.perception.osi", mount.name))).unwrap();
        assert_eq!(pd.len(), expected);
        assert_eq!(pd[0].model_mode.as_deref(), Some(defaults.mode.name()));
        match mount.kind {
            SensorKind::Radar => assert!(!pd[0].radar.as_ref().unwrap().peak.is_empty()),
            SensorKind::Lidar => assert!(!pd[0].lidar.as_ref().unwrap().x_m.is_empty()),
            SensorKind::Camera => assert!(!pd[0].camera.as_ref().unwrap().image.is_empty()),
        }
    }
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.path().join("summary.json")).unwrap())
            .unwrap();
    assert_eq!(summary["frames"], steps);
    assert!(
        std::fs::read_to_string(out.path().join("summary.txt"))
            .unwrap()
            .contains("front_radar")
    );
}

#[test]
fn a_sensor_view_trace_is_a_scenario_source() {
    let dir = tempfile::tempdir().unwrap();
    let scenario = ScenarioConfig::default();
    let radar = scenario
        .sensors
        .iter()
        .find(|m| m.kind == SensorKind::Radar)
        .unwrap();
    let sv_path = dir.path().join("sv.osi");
    let mut w = OsiTraceWriter::create(&sv_path).unwrap();
    for step in 0..10 {
        w.write_message(&scenario.sensor_view(step, radar)).unwrap();
    }
    w.finish().unwrap();

    let out = dir.path().join("out");
    run_cli(&[
        "run",
        "--trace",
        sv_path.to_str().unwrap(),
        "--sensors",
        "radar",
        "--fmu-dir",
        fmu_dir().to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--param",
        "range_m=60",
        "--every-frame",
        "--quiet",
    ])
    .unwrap();
    let frames: Vec<osi3::SensorData> = read_messages(sd_trace(&out, "radar")).unwrap();
    assert_eq!(frames.len(), 10);
    // range_m=60 overrides the 100 m default: every detection is within 60 m, and the board 130 m
    // ahead (id 501) is gone.
    for sd in &frames {
        for o in &sd.moving_object {
            let p = o.base.as_ref().unwrap().position.as_ref().unwrap();
            assert!(p.x.unwrap().hypot(p.y.unwrap()) < 60.0 + 5.0);
        }
        assert!(
            sd.stationary_object
                .iter()
                .all(|o| o.header.as_ref().unwrap().ground_truth_id[0].value != Some(501))
        );
    }
    // The timestamps are the SensorViews'.
    let reader = OsiTraceReader::open(sd_trace(&out, "radar")).unwrap();
    let times: Vec<f64> = reader
        .map(|b| {
            let sd = osi3::SensorData::decode(b.unwrap().as_slice()).unwrap();
            osiris_proto::timestamp_to_seconds(sd.timestamp.as_ref().unwrap())
        })
        .collect();
    for (i, t) in times.iter().enumerate() {
        assert!((t - scenario.time_s(i)).abs() < 1e-9, "frame {i}: {t}");
    }
}

#[test]
fn bad_inputs_give_clear_errors() {
    let dir = tempfile::tempdir().unwrap();
    let fmus = fmu_dir().to_str().unwrap();
    let out = dir.path().join("out");
    let out = out.to_str().unwrap();

    // A scenario JSON with a typo names the file, the line and the key.
    let bad = dir.path().join("bad.json");
    std::fs::write(
        &bad,
        "{\n  \"duration_s\": 1.0,\n  \"step_s\": 0.1,\n  \"egoo\": {}\n}\n",
    )
    .unwrap();
    let e = run_cli(&[
        "run",
        "--scenario",
        bad.to_str().unwrap(),
        "--fmu-dir",
        fmus,
        "--out",
        out,
        "--quiet",
    ])
    .unwrap_err();
    let msg = format!("{e:#}");
    assert!(
        msg.contains("bad.json") && msg.contains("line 4") && msg.contains("egoo"),
        "{msg}"
    );

    // A parameter the FMU does not have.
    let e = run_cli(&[
        "run",
        "--param",
        "rang_m=5",
        "--fmu-dir",
        fmus,
        "--out",
        out,
        "--quiet",
    ])
    .unwrap_err();
    assert!(format!("{e:#}").contains("rang_m"), "{e:#}");

    // A malformed parameter value.
    let e = run_cli(&[
        "run",
        "--param",
        "range_m=far",
        "--fmu-dir",
        fmus,
        "--out",
        out,
        "--quiet",
    ])
    .unwrap_err();
    assert!(format!("{e:#}").contains("range_m=far"), "{e:#}");

    // An invalid configuration value is refused by the FMU with its reason.
    let e = run_cli(&[
        "run",
        "--param",
        "range_m=-1",
        "--fmu-dir",
        fmus,
        "--out",
        out,
        "--quiet",
    ])
    .unwrap_err();
    assert!(format!("{e:#}").contains("range_m"), "{e:#}");

    // A truncated SensorView trace names the file and the frame.
    let scenario = ScenarioConfig::default();
    let sv = scenario
        .sensor_view(0, &scenario.sensors[1])
        .encode_to_vec();
    let trunc = dir.path().join("trunc.osi");
    let mut bytes = (sv.len() as u32).to_le_bytes().to_vec();
    bytes.extend_from_slice(&sv[..sv.len() / 2]);
    std::fs::write(&trunc, bytes).unwrap();
    let e = run_cli(&[
        "run",
        "--trace",
        trunc.to_str().unwrap(),
        "--fmu-dir",
        fmus,
        "--out",
        out,
        "--quiet",
    ])
    .unwrap_err();
    let msg = format!("{e:#}");
    assert!(msg.contains("trunc.osi"), "{msg}");

    // A missing FMU folder tells how to make it.
    let e = run_cli(&[
        "run",
        "--fmu-dir",
        dir.path().join("nope").to_str().unwrap(),
        "--out",
        out,
    ])
    .unwrap_err();
    assert!(format!("{e:#}").contains("osiris package"), "{e:#}");
}

#[test]
fn readme_lists_every_named_effect() {
    let readme =
        std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("README.md")).unwrap();
    for e in osiris_models::effects::catalogue() {
        assert!(
            readme.contains(&format!("`{}`", e.name)),
            "README.md does not document `{}`",
            e.name
        );
    }
    // `osiris effects --json` lists the same catalogue as JSON (run as a process: its output stays
    // out of the test log).
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_osiris"))
        .args(["effects", "--json"])
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let listed: Vec<serde_json::Value> = serde_json::from_slice(&out.stdout).unwrap();
    let names: BTreeSet<&str> = listed.iter().filter_map(|e| e["name"].as_str()).collect();
    for e in osiris_models::effects::catalogue() {
        assert!(
            names.contains(e.name),
            "`osiris effects --json` lacks {}",
            e.name
        );
    }
}
