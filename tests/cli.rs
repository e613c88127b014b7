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
use osiris::trace::mcap::McapTraceReader;
use osiris::trace::{OsiTraceReader, OsiTraceWriter, parse_trace_file_name, read_messages};
use osiris_models::SensorKind;
use osiris_proto::{Message, osi3, perception};

/// The three sensor FMUs and scenario.fmu, packaged once per test process (libraries of the test profile, built if needed)
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
        assert_eq!(written.len(), 4);
        assert!(written[3].ends_with("scenario.fmu"), "{written:?}");
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
    typed_trace(out, "sd", sensor)
}

/// The `.osi` trace of type `ty` (`sd`, `sv`) of a sensor in `out`.
fn typed_trace(out: &Path, ty: &str, sensor: &str) -> PathBuf {
    let suffix = format!("_{}.osi", sensor.replace(['_', ' '], "-"));
    files_in(out)
        .into_iter()
        .find(|p| {
            let n = p.file_name().unwrap().to_string_lossy();
            n.contains(&format!("_{ty}_380_")) && n.ends_with(&suffix)
        })
        .unwrap_or_else(|| panic!("no `{ty}` trace for {sensor} in {:?}", files_in(out)))
}

/// The run's `.mcap` trace in `out`.
fn mcap_trace(out: &Path) -> PathBuf {
    let found: Vec<PathBuf> = files_in(out)
        .into_iter()
        .filter(|p| p.extension().is_some_and(|e| e == "mcap"))
        .collect();
    assert_eq!(found.len(), 1, "{:?}", files_in(out));
    found[0].clone()
}

/// The raw frames of an `.osi` trace.
fn raw_frames(path: &Path) -> Vec<Vec<u8>> {
    OsiTraceReader::open(path)
        .unwrap()
        .collect::<Result<_, _>>()
        .unwrap()
}

/// The messages of an `.mcap` channel.
fn mcap_frames(reader: &McapTraceReader, topic: &str) -> Vec<Vec<u8>> {
    reader
        .topic_messages(topic)
        .unwrap()
        .map(|m| m.unwrap().data)
        .collect()
}

/// Every file in `out` is a finished trace or summary: no `.part` left.
fn assert_no_partial_files(out: &Path) {
    for p in files_in(out) {
        assert!(
            !p.to_string_lossy().ends_with(".part"),
            "left over: {}",
            p.display()
        );
    }
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
fn scenario_fmu_archive_holds_the_player_and_the_built_in_scenario() {
    let path = fmu_dir().join("scenario.fmu");
    let mut zip = zip::ZipArchive::new(std::fs::File::open(&path).unwrap()).unwrap();
    let names: BTreeSet<&str> = zip.file_names().collect();
    assert_eq!(
        names,
        [
            "modelDescription.xml",
            "binaries/linux64/osiris_scenario.so",
            "resources/scenario.json",
            "documentation/index.html",
            "documentation/externalDependencies.txt",
        ]
        .into()
    );
    let mut read = |name: &str| {
        let mut text = String::new();
        zip.by_name(name)
            .unwrap()
            .read_to_string(&mut text)
            .unwrap();
        text
    };
    let checked_in = std::fs::read_to_string(
        Path::new(env!("CARGO_MANIFEST_DIR")).join("modelDescription/scenario.xml"),
    )
    .unwrap();
    assert_eq!(read("modelDescription.xml"), checked_in);
    assert_eq!(
        ScenarioConfig::from_json_str(&read("resources/scenario.json")).unwrap(),
        ScenarioConfig::default()
    );
    assert!(read("documentation/index.html").contains("SensorView source"));
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
        // Each sensor runs at its own cycle on the master's clock: once per instant n·cycle up to
        // the last frame's time plus half a step (the instants the frames serve).
        let defaults = osiris_models::SensorConfig::default_for(mount.kind);
        let last = scenario.time_s(steps - 1) + 0.5 * scenario.step_s;
        let expected = (last / defaults.update_cycle_s + 1e-9).floor() as usize + 1;
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
fn effects_page_lists_every_named_effect() {
    let page =
        std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("docs/effects.md"))
            .unwrap();
    for e in osiris_models::registry::catalogue() {
        assert!(
            page.contains(&format!("| `{}` |", e.name)),
            "docs/effects.md does not document `{}`",
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
    for e in osiris_models::registry::catalogue() {
        assert!(
            names.contains(e.name),
            "`osiris effects --json` lacks {}",
            e.name
        );
    }
}

#[test]
fn trace_names_carry_their_message_counts_and_the_mcap_holds_the_same_messages() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    run_cli(&[
        "run",
        "--sensors",
        "radar,lidar",
        "--param",
        "mode=ideal",
        "--fmu-dir",
        fmu_dir().to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--max-frames",
        "40",
        "--format",
        "both",
        "--quiet",
    ])
    .unwrap();
    assert_no_partial_files(&out);
    let mcap = McapTraceReader::open(mcap_trace(&out)).unwrap();
    let meta = mcap.osi_trace_metadata().expect("net.asam.osi.trace");
    for key in [
        "version",
        "min_osi_version",
        "max_osi_version",
        "min_protobuf_version",
        "max_protobuf_version",
        "creation_time",
        "description",
    ] {
        assert!(meta.contains_key(key), "{key}: {meta:?}");
    }
    assert_eq!(meta["version"], "3.8.0");
    let mut largest = 0;
    // 40 frames of 0.01 s: radar (0.05 s) 8 cycles, LiDAR (0.1 s) 4.
    for (sensor, cycles) in [("front_radar", 8), ("front_lidar", 4)] {
        let sd = sd_trace(&out, sensor);
        let sv = typed_trace(&out, "sv", sensor);
        let pd = out.join(format!("{sensor}.perception.osi"));
        for (path, ty) in [(&sd, "sd"), (&sv, "sv")] {
            let frames = raw_frames(path);
            assert_eq!(frames.len(), cycles, "{}", path.display());
            let (t, osi, n) = parse_trace_file_name(path).unwrap();
            assert_eq!((t.as_str(), osi.as_str(), n), (ty, "380", cycles as u64));
        }
        // The .mcap channels hold the same messages, byte for byte, with the channel metadata.
        for (topic, path, schema) in [
            ("OSMPSensorDataOut", &sd, "osi3.SensorData"),
            ("OSMPSensorViewIn", &sv, "osi3.SensorView"),
            ("PerceptionDataOut", &pd, "osiris.perception.PerceptionData"),
        ] {
            let topic = format!("{sensor}.{topic}");
            let ch = mcap.channel(&topic).unwrap_or_else(|| panic!("{topic}"));
            assert_eq!(ch.schema_name.as_deref(), Some(schema));
            assert_eq!(ch.message_encoding, "protobuf");
            assert_eq!(ch.message_count, Some(cycles as u64), "{topic}");
            if schema.starts_with("osi3.") {
                assert_eq!(
                    ch.metadata["net.asam.osi.trace.channel.osi_version"],
                    "3.8.0"
                );
                assert_eq!(
                    ch.metadata["net.asam.osi.trace.channel.protobuf_version"],
                    osiris_proto::PROTOBUF_VERSION
                );
            }
            assert_eq!(mcap_frames(&mcap, &topic), raw_frames(path), "{topic}");
            largest = largest.max(cycles);
        }
        // publish_time = log_time = the message's timestamp.
        for (m, sd) in mcap
            .topic_messages(&format!("{sensor}.OSMPSensorDataOut"))
            .unwrap()
            .zip(read_messages::<osi3::SensorData>(&sd).unwrap())
        {
            let m = m.unwrap();
            let ts = osiris_proto::timestamp_to_nanos(sd.timestamp.as_ref().unwrap());
            assert_eq!((m.log_time, m.publish_time), (ts as u64, ts as u64));
        }
    }
    let (ty, osi, n) = parse_trace_file_name(&mcap_trace(&out)).unwrap();
    assert_eq!(
        (ty.as_str(), osi.as_str(), n),
        ("multi", "380", largest as u64)
    );

    // The summary names every file it wrote.
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    assert_eq!(
        summary["mcap_trace"].as_str().unwrap(),
        mcap_trace(&out).display().to_string()
    );
    for s in summary["sensors"].as_array().unwrap() {
        for key in ["sensor_data_trace", "sensor_view_trace", "perception_trace"] {
            assert!(Path::new(s[key].as_str().unwrap()).is_file(), "{key}: {s}");
        }
    }

    // The .mcap replays as a SensorView trace: one channel chosen with --channel.
    let replay = dir.path().join("replay");
    let e = run_cli(&[
        "run",
        "--trace",
        mcap_trace(&out).to_str().unwrap(),
        "--sensors",
        "radar",
        "--fmu-dir",
        fmu_dir().to_str().unwrap(),
        "--out",
        replay.to_str().unwrap(),
        "--quiet",
    ])
    .unwrap_err();
    let msg = format!("{e:#}");
    assert!(
        msg.contains("2 channels of osi3.SensorView")
            && msg.contains("--channel")
            && msg.contains("front_radar.OSMPSensorViewIn"),
        "{msg}"
    );
    run_cli(&[
        "run",
        "--trace",
        mcap_trace(&out).to_str().unwrap(),
        "--channel",
        "front_radar.OSMPSensorViewIn",
        "--sensors",
        "radar",
        "--param",
        "mode=ideal",
        "--every-frame",
        "--fmu-dir",
        fmu_dir().to_str().unwrap(),
        "--out",
        replay.to_str().unwrap(),
        "--format",
        "mcap",
        "--quiet",
    ])
    .unwrap();
    assert_no_partial_files(&replay);
    // `--format mcap` writes no .osi trace.
    assert!(
        files_in(&replay)
            .iter()
            .all(|p| p.extension().is_none_or(|e| e != "osi")),
        "{:?}",
        files_in(&replay)
    );
    let again = McapTraceReader::open(mcap_trace(&replay)).unwrap();
    // Every replayed SensorView is the recorded one.
    assert_eq!(
        mcap_frames(&again, "radar.OSMPSensorViewIn"),
        mcap_frames(&mcap, "front_radar.OSMPSensorViewIn")
    );
    let e = run_cli(&[
        "run",
        "--trace",
        mcap_trace(&out).to_str().unwrap(),
        "--channel",
        "front_radar.OSMPSensorDataOut",
        "--sensors",
        "radar",
        "--fmu-dir",
        fmu_dir().to_str().unwrap(),
        "--out",
        replay.to_str().unwrap(),
        "--quiet",
    ])
    .unwrap_err();
    assert!(
        format!("{e:#}").contains("expected osi3.SensorView"),
        "{e:#}"
    );
}

#[test]
fn export_reads_a_perception_channel_of_an_mcap_trace() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    run_cli(&[
        "run",
        "--sensors",
        "lidar,radar",
        "--param",
        "mode=physical",
        "--fmu-dir",
        fmu_dir().to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--max-frames",
        "12",
        "--format",
        "both",
        "--quiet",
    ])
    .unwrap();
    let mcap = mcap_trace(&out);
    let e = run_cli(&[
        "export",
        mcap.to_str().unwrap(),
        "--out",
        dir.path().join("x.pcd").to_str().unwrap(),
    ])
    .unwrap_err();
    let msg = format!("{e:#}");
    assert!(
        msg.contains("2 channels of osiris.perception.PerceptionData")
            && msg.contains("front_lidar.PerceptionDataOut"),
        "{msg}"
    );
    let from_mcap = dir.path().join("mcap.pcd");
    let from_osi = dir.path().join("osi.pcd");
    run_cli(&[
        "export",
        mcap.to_str().unwrap(),
        "--channel",
        "front_lidar.PerceptionDataOut",
        "--out",
        from_mcap.to_str().unwrap(),
    ])
    .unwrap();
    run_cli(&[
        "export",
        out.join("front_lidar.perception.osi").to_str().unwrap(),
        "--out",
        from_osi.to_str().unwrap(),
    ])
    .unwrap();
    let a = std::fs::read(&from_mcap).unwrap();
    assert!(a.len() > 1000);
    assert_eq!(a, std::fs::read(&from_osi).unwrap());
    let e = run_cli(&[
        "export",
        out.join("front_lidar.perception.osi").to_str().unwrap(),
        "--channel",
        "x",
        "--out",
        from_osi.to_str().unwrap(),
    ])
    .unwrap_err();
    assert!(format!("{e:#}").contains("for .mcap traces"), "{e:#}");
}

/// The official OSMP example FMUs (`shared/fixtures/osmp-dummy/` beside the repository, or the folder
/// `$OSIRIS_OSMP_DUMMY_DIR`). A missing fixture fails the test: these are the foreign FMUs the master
/// is checked against.
fn osmp_dummy(name: &str) -> PathBuf {
    let dir = std::env::var_os("OSIRIS_OSMP_DUMMY_DIR").map_or_else(
        || Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/fixtures/osmp-dummy"),
        PathBuf::from,
    );
    let path = dir.join(name);
    assert!(
        path.is_file(),
        "{} is missing: the foreign-FMU tests need the OSMP example FMUs in shared/fixtures/osmp-dummy/",
        path.display()
    );
    path
}

/// Runs the `osiris` binary (the OSMP examples link the system protobuf, and two of them in one
/// process abort: each run gets its own process).
fn osiris_process(args: &[&str]) -> std::process::Output {
    std::process::Command::new(env!("CARGO_BIN_EXE_osiris"))
        .args(args)
        .output()
        .unwrap()
}

fn summary_of(out: &Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap()
}

#[test]
fn a_foreign_osmp_sensor_fmu_runs_in_the_master() {
    let dummy = osmp_dummy("OSMPDummySensor.fmu");
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    let run = osiris_process(&[
        "run",
        "--fmu",
        dummy.to_str().unwrap(),
        "--fmu",
        &format!("second={}", dummy.display()),
        "--max-frames",
        "50",
        "--format",
        "both",
        "--out",
        out.to_str().unwrap(),
        "--quiet",
    ]);
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    assert_no_partial_files(&out);
    let summary = summary_of(&out);
    let sensors = summary["sensors"].as_array().unwrap();
    assert_eq!(sensors.len(), 2);
    // Labelled by its modelName, or the name given.
    assert_eq!(sensors[0]["sensor"], "OSMP Dummy Sensor FMU");
    assert_eq!(sensors[0]["kind"], "OSMP Dummy Sensor FMU");
    assert_eq!(sensors[1]["sensor"], "second");
    let text = String::from_utf8_lossy(&run.stdout);
    assert!(
        text.contains("[second] OSMP Dummy Sensor FMU FMU") && !text.contains("camera"),
        "{text}"
    );
    // Its cycle is 0.02 s: 25 steps over 50 frames of 0.01 s; no PerceptionData output, no file.
    for (s, name) in [
        (&sensors[0], "OSMP Dummy Sensor FMU"),
        (&sensors[1], "second"),
    ] {
        assert_eq!(s["frames"], 25, "{s}");
        assert!(s["perception_trace"].is_null(), "{s}");
        let sd: Vec<osi3::SensorData> = read_messages(typed_trace(&out, "sd", name)).unwrap();
        assert_eq!(sd.len(), 25);
        // The example reports the moving objects in front of it: the car 40 m ahead (id 100).
        assert!(
            sd.iter().any(|d| d.moving_object.iter().any(|o| o
                .header
                .as_ref()
                .is_some_and(|h| h.ground_truth_id.iter().any(|g| g.value == Some(100))))),
            "{name}"
        );
        // Its SensorData times are its communication points' ends: exactly 0.02 s apart.
        for w in sd.windows(2) {
            let dt = osiris_proto::timestamp_to_seconds(w[1].timestamp.as_ref().unwrap())
                - osiris_proto::timestamp_to_seconds(w[0].timestamp.as_ref().unwrap());
            assert!((dt - 0.02).abs() < 1e-6, "{dt}");
        }
        assert_eq!(
            raw_frames(&typed_trace(&out, "sv", name)).len(),
            25,
            "{name}: the SensorViews it got"
        );
    }
    assert!(
        !files_in(&out)
            .iter()
            .any(|p| p.to_string_lossy().contains("perception")),
        "{:?}",
        files_in(&out)
    );
    let mcap = McapTraceReader::open(mcap_trace(&out)).unwrap();
    let topics: BTreeSet<&str> = mcap.channels().iter().map(|c| c.topic.as_str()).collect();
    assert_eq!(
        topics,
        [
            "OSMP Dummy Sensor FMU.OSMPSensorDataOut",
            "OSMP Dummy Sensor FMU.OSMPSensorViewIn",
            "second.OSMPSensorDataOut",
            "second.OSMPSensorViewIn",
        ]
        .into()
    );
    assert_eq!(
        mcap_frames(&mcap, "second.OSMPSensorDataOut"),
        raw_frames(&typed_trace(&out, "sd", "second"))
    );

    // A source FMU is not a sensor: the error names the FMU and the missing variable.
    let bad = osiris_process(&[
        "run",
        "--fmu",
        osmp_dummy("OSMPDummySource.fmu").to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]);
    let err = String::from_utf8_lossy(&bad.stderr);
    assert_eq!(bad.status.code(), Some(2), "{err}");
    assert!(
        err.contains("OSMPDummySource.fmu") && err.contains("OSMPSensorViewIn"),
        "{err}"
    );
}

#[test]
fn a_foreign_osmp_source_fmu_feeds_the_sensors() {
    let source = osmp_dummy("OSMPDummySource.fmu");
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    let run = osiris_process(&[
        "run",
        "--source",
        source.to_str().unwrap(),
        "--sensors",
        "radar,lidar",
        "--param",
        "mode=ideal",
        "--duration",
        "0.6",
        "--format",
        "both",
        "--fmu-dir",
        fmu_dir().to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--quiet",
    ]);
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    let summary = summary_of(&out);
    // The source's own step (DefaultExperiment stepSize 0.02 s): 30 frames at 0.02 … 0.60 s.
    assert_eq!(summary["frames"], 30);
    assert!((summary["end_time_s"].as_f64().unwrap() - 0.62).abs() < 1e-9);
    // Radar 0.05 s from t0 = 0.02 s over frames up to 0.60 s (+ half a step): 12 cycles; LiDAR 6.
    for (sensor, cycles) in [("radar", 12usize), ("lidar", 6)] {
        let sv: Vec<osi3::SensorView> = read_messages(typed_trace(&out, "sv", sensor)).unwrap();
        assert_eq!(sv.len(), cycles, "{sensor}");
        // The SensorViews are the source's: its moving objects, its timestamps on the master's
        // 0.02 s frames nearest to each cycle.
        for (n, v) in sv.iter().enumerate() {
            let gt = v.global_ground_truth.as_ref().unwrap();
            assert!(!gt.moving_object.is_empty(), "{sensor} {n}");
            let t = osiris_proto::timestamp_to_seconds(v.timestamp.as_ref().unwrap());
            let instant = 0.02 + n as f64 * if sensor == "radar" { 0.05 } else { 0.1 };
            assert!(
                (t - instant).abs() <= 0.01 + 1e-6,
                "{sensor} {n}: {t} for {instant}"
            );
        }
        let sd: Vec<osi3::SensorData> = read_messages(sd_trace(&out, sensor)).unwrap();
        assert_eq!(sd.len(), cycles, "{sensor}");
    }
    let mcap = McapTraceReader::open(mcap_trace(&out)).unwrap();
    assert_eq!(
        mcap_frames(&mcap, "radar.OSMPSensorViewIn"),
        raw_frames(&typed_trace(&out, "sv", "radar"))
    );
    assert!(mcap.osi_trace_metadata().unwrap()["data_sources"].contains("OSMP Dummy Source FMU"));

    // A sensor FMU is not a source.
    let bad = osiris_process(&[
        "run",
        "--source",
        osmp_dummy("OSMPDummySensor.fmu").to_str().unwrap(),
        "--sensors",
        "radar",
        "--fmu-dir",
        fmu_dir().to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]);
    let err = String::from_utf8_lossy(&bad.stderr);
    assert!(
        err.contains("OSMPDummySensor.fmu") && err.contains("OSMPSensorViewOut"),
        "{err}"
    );
}

/// CI's chain in the master: our scenario.fmu as the `--source` of our radar.fmu. The SensorViews the
/// radar got are the built-in scenario's (its first mount's view at each step the radar fired), and
/// the radar tracks the car ahead.
#[test]
fn scenario_fmu_is_a_source_for_the_radar_in_the_master() {
    let scenario_fmu = fmu_dir().join("scenario.fmu");
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    run_cli(&[
        "run",
        "--source",
        scenario_fmu.to_str().unwrap(),
        "--sensors",
        "radar",
        "--duration",
        "0.5",
        "--fmu-dir",
        fmu_dir().to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--quiet",
    ])
    .unwrap();
    let scenario = ScenarioConfig::default();
    let mount = &scenario.sensors[0];
    let sv: Vec<osi3::SensorView> = read_messages(typed_trace(&out, "sv", "radar")).unwrap();
    // The radar's 0.05 s cycle over 0.5 s of 0.01 s frames.
    assert_eq!(sv.len(), 10);
    for v in &sv {
        let t = osiris_proto::timestamp_to_seconds(v.timestamp.as_ref().unwrap());
        let step = (t / scenario.step_s).round() as usize;
        assert!((t - step as f64 * scenario.step_s).abs() < 1e-9, "{t}");
        assert_eq!(v, &scenario.sensor_view(step, mount), "step {step}");
    }
    let sd: Vec<osi3::SensorData> = read_messages(sd_trace(&out, "radar")).unwrap();
    let tracked: Vec<u64> = sd
        .iter()
        .flat_map(|m| &m.moving_object)
        .filter_map(|o| o.header.as_ref())
        .flat_map(|h| h.ground_truth_id.iter().filter_map(|i| i.value))
        .collect();
    assert!(tracked.contains(&100), "{tracked:?}");
}

/// The `id` of a report section (`sensor-` + the name, characters other than letters, digits, `-`
/// and `_` as `-`).
fn section_id(name: &str) -> String {
    let slug: String = name
        .chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || c == '-' || c == '_' {
                c
            } else {
                '-'
            }
        })
        .collect();
    format!("id=\"sensor-{slug}\"")
}

/// CSV rows without the header, each without its first column (the sensor name).
fn csv_rows_without_sensor(path: &Path) -> Vec<String> {
    std::fs::read_to_string(path)
        .unwrap()
        .lines()
        .skip(1)
        .map(|l| l.split_once(',').unwrap().1.to_owned())
        .collect()
}

#[test]
fn run_writes_a_report_and_view_rebuilds_it_from_the_traces() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("run");
    let fmus = fmu_dir().to_str().unwrap();
    run_cli(&[
        "run",
        "--fmu-dir",
        fmus,
        "--out",
        out.to_str().unwrap(),
        "--max-frames",
        "30",
        "--format",
        "both",
        "--quiet",
    ])
    .unwrap();
    let summary = summary_of(&out);
    for key in ["report", "objects_csv", "frames_csv"] {
        let p = summary[key]
            .as_str()
            .unwrap_or_else(|| panic!("{key}: {summary}"));
        assert!(Path::new(p).is_file(), "{key}: {p}");
    }
    let text = std::fs::read_to_string(out.join("summary.txt")).unwrap();
    assert!(text.contains("report.html"), "{text}");
    let html = std::fs::read_to_string(out.join("report.html")).unwrap();
    for (name, kind) in [
        ("front_camera", "camera"),
        ("front_radar", "radar"),
        ("front_lidar", "lidar"),
    ] {
        let tag = format!("{} class=\"sensor\" data-kind=\"{kind}\"", section_id(name));
        assert!(html.contains(&tag), "{tag}");
    }
    // Self-contained: no external references.
    for external in ["src=\"http", "href=\"http", "<link", "src=\"file"] {
        assert!(!html.contains(external), "{external}");
    }
    assert!(
        html.contains("data:image/jpeg;base64,"),
        "camera frames embedded"
    );
    // The objects table has rows for every sensor, detected ones among them.
    let objects = std::fs::read_to_string(out.join("objects.csv")).unwrap();
    for name in ["front_camera", "front_radar", "front_lidar"] {
        assert!(
            objects
                .lines()
                .any(|l| l.starts_with(&format!("{name},")) && l.split(',').nth(8) == Some("1")),
            "{name}: no detected ground truth in objects.csv"
        );
    }
    let frames = std::fs::read_to_string(out.join("frames.csv")).unwrap();
    let radar_frames: Vec<&str> = frames
        .lines()
        .filter(|l| l.starts_with("front_radar,"))
        .collect();
    assert!(!radar_frames.is_empty());
    // The FMU step wall time is measured by the master.
    assert!(
        radar_frames.iter().all(|l| !l.ends_with(',')),
        "{radar_frames:?}"
    );

    // `osiris view` on the run's .osi traces of the radar: the same KPI rows (but the wall time).
    let view_out = dir.path().join("view-osi");
    let sd = sd_trace(&out, "front_radar");
    let sv = typed_trace(&out, "sv", "front_radar");
    let pd = out.join("front_radar.perception.osi");
    run_cli(&[
        "view",
        sd.to_str().unwrap(),
        "--sensor-view",
        sv.to_str().unwrap(),
        "--perception",
        pd.to_str().unwrap(),
        "--out",
        view_out.to_str().unwrap(),
    ])
    .unwrap();
    let run_objects: Vec<String> = csv_rows_without_sensor(&out.join("objects.csv"))
        .into_iter()
        .zip(objects.lines().skip(1))
        .filter(|(_, l)| l.starts_with("front_radar,"))
        .map(|(r, _)| r)
        .collect();
    assert_eq!(
        csv_rows_without_sensor(&view_out.join("objects.csv")),
        run_objects
    );
    let view_html = std::fs::read_to_string(view_out.join("report.html")).unwrap();
    assert!(view_html.contains(&section_id("front-radar")));
    assert!(view_html.contains("data-kind=\"radar\""));

    // --no-report: the tables, no page.
    let tables_only = dir.path().join("tables-only");
    run_cli(&[
        "run",
        "--fmu-dir",
        fmus,
        "--out",
        tables_only.to_str().unwrap(),
        "--max-frames",
        "5",
        "--sensors",
        "radar",
        "--no-report",
        "--quiet",
    ])
    .unwrap();
    assert!(!tables_only.join("report.html").exists());
    assert!(tables_only.join("objects.csv").is_file() && tables_only.join("frames.csv").is_file());
    assert!(summary_of(&tables_only)["report"].is_null());

    // Without ground truth: no object rows, and the report says so.
    let bare = dir.path().join("view-bare");
    run_cli(&[
        "view",
        sd.to_str().unwrap(),
        "--out",
        bare.to_str().unwrap(),
    ])
    .unwrap();
    assert_eq!(
        std::fs::read_to_string(bare.join("objects.csv"))
            .unwrap()
            .lines()
            .count(),
        1
    );
    assert!(
        std::fs::read_to_string(bare.join("report.html"))
            .unwrap()
            .contains("No ground truth")
    );

    // The .mcap: one section per SensorData channel, ground truth from the SensorView channels.
    let view_mcap = dir.path().join("view-mcap");
    run_cli(&[
        "view",
        mcap_trace(&out).to_str().unwrap(),
        "--out",
        view_mcap.to_str().unwrap(),
    ])
    .unwrap();
    let html = std::fs::read_to_string(view_mcap.join("report.html")).unwrap();
    for name in ["front_camera", "front_radar", "front_lidar"] {
        assert!(html.contains(&section_id(name)), "{name}");
    }
    let mut mcap_rows = csv_rows_without_sensor(&view_mcap.join("objects.csv"));
    let mut run_rows = csv_rows_without_sensor(&out.join("objects.csv"));
    mcap_rows.sort();
    run_rows.sort();
    assert_eq!(mcap_rows, run_rows);

    // Errors name the file (and the message), exit status 2.
    let missing = dir.path().join("missing.osi");
    let e = run_cli(&[
        "view",
        missing.to_str().unwrap(),
        "--out",
        bare.to_str().unwrap(),
    ])
    .unwrap_err();
    assert!(format!("{e:#}").contains("missing.osi"), "{e:#}");
    assert_eq!(osiris::cli::exit_code(&e), 2);
    let e = run_cli(&[
        "view",
        sv.to_str().unwrap(),
        "--out",
        bare.to_str().unwrap(),
    ])
    .unwrap_err();
    assert!(
        format!("{e:#}").contains(&sv.display().to_string())
            && format!("{e:#}").contains("SensorData"),
        "{e:#}"
    );
    // A trace cut in its second message.
    let bytes = std::fs::read(&sd).unwrap();
    let first = u32::from_le_bytes(bytes[..4].try_into().unwrap()) as usize;
    let broken = dir.path().join("broken.osi");
    std::fs::write(&broken, &bytes[..4 + first + 10]).unwrap();
    let e = run_cli(&[
        "view",
        broken.to_str().unwrap(),
        "--out",
        bare.to_str().unwrap(),
    ])
    .unwrap_err();
    let msg = format!("{e:#}");
    assert!(
        msg.contains("broken.osi") && msg.contains("message 1"),
        "{msg}"
    );
}

#[test]
fn view_reports_a_foreign_sensor_trace() {
    let dummy = osmp_dummy("OSMPDummySensor.fmu");
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    let run = osiris_process(&[
        "run",
        "--fmu",
        &format!("dummy={}", dummy.display()),
        "--max-frames",
        "20",
        "--format",
        "both",
        "--out",
        out.to_str().unwrap(),
        "--quiet",
    ]);
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    let html = std::fs::read_to_string(out.join("report.html")).unwrap();
    assert!(html.contains(&format!(
        "{} class=\"sensor\" data-kind=\"other\"",
        section_id("dummy")
    )));
    // The dummy reports the car 40 m ahead (id 100): its objects.csv rows say so.
    let objects = std::fs::read_to_string(out.join("objects.csv")).unwrap();
    assert!(
        objects.lines().any(|l| l.starts_with("dummy,")
            && l.split(',').nth(3) == Some("100")
            && l.split(',').nth(8) == Some("1")),
        "{objects}"
    );
    let view_out = dir.path().join("view");
    let view = osiris_process(&[
        "view",
        mcap_trace(&out).to_str().unwrap(),
        "--out",
        view_out.to_str().unwrap(),
    ]);
    assert!(
        view.status.success(),
        "{}",
        String::from_utf8_lossy(&view.stderr)
    );
    let html = std::fs::read_to_string(view_out.join("report.html")).unwrap();
    assert!(
        html.contains(&section_id("dummy")),
        "sections of the foreign trace"
    );
    assert!(html.contains("<svg"));
}
