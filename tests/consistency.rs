//! The consistency workflow (issue 7) against the independent truth generator
//! (`osiris::consistency::truth`, validation.md §8): campaigns with hidden effects and nuisances,
//! attribution through the same entry point as `osiris consistency`.

use std::path::Path;

use osiris::consistency::campaign::Campaign;
use osiris::consistency::report::Summary;
use osiris::consistency::truth::{
    CampaignFiles, LidarHidden, LidarTruth, RadarHidden, RadarTruth, write_lidar, write_radar,
};
use osiris::consistency::{ConsistencyArgs, cli, protocol};

fn args(files: &CampaignFiles, out: &Path, simulated: bool) -> ConsistencyArgs {
    ConsistencyArgs {
        meta: files.toml.clone(),
        out: out.to_path_buf(),
        simulated: simulated.then(|| files.simulated.clone()),
        model: None,
        enable: vec![],
        disable: vec![],
        history: None,
    }
}

fn attribute(files: &CampaignFiles, out: &Path) -> Summary {
    cli::run_with(&args(files, out, true), None).expect("consistency run")
}

fn radar(dir: &Path, spec: RadarTruth) -> Summary {
    let files = write_radar(&dir.join("campaign"), &spec).unwrap();
    let s = attribute(&files, &dir.join("out"));
    eprintln!("{}", describe(&s));
    s
}

fn lidar(dir: &Path, spec: LidarTruth) -> Summary {
    let files = write_lidar(&dir.join("campaign"), &spec).unwrap();
    let s = attribute(&files, &dir.join("out"));
    eprintln!("{}", describe(&s));
    s
}

fn describe(s: &Summary) -> String {
    let mut out = format!("status {}\n", s.status);
    for a in &s.attribution {
        out += &format!(
            "  {} {} chi2/dof {:.2} -> {:.2} (thr {:.2}) offset {:?} accepted {:?}\n",
            a.quantity,
            a.status.name(),
            a.baseline_chi2 / a.baseline_dof.max(1) as f64,
            a.final_chi2_per_dof,
            a.consistent_threshold,
            a.calibration_offset,
            a.accepted
        );
        for e in a.effects.iter().take(4) {
            out += &format!(
                "    {} dBIC {:.1} expl {:.2} maxc {:.3} {:?} params {:?} tie {:?}\n",
                e.id,
                e.delta_bic,
                e.explained_share,
                e.max_contribution,
                e.gates,
                e.params
                    .iter()
                    .map(|p| (p.value, p.sigma))
                    .collect::<Vec<_>>(),
                e.tie_group
            );
        }
    }
    for t in &s.tie_groups {
        out += &format!("  tie {} {:?} {}\n", t.id, t.members, t.reason);
    }
    out
}

fn param(s: &Summary, effect: &str) -> f64 {
    s.effect(effect)
        .unwrap_or_else(|| panic!("{effect} missing\n{}", describe(s)))
        .params[0]
        .value
}

#[test]
fn radar_null_is_consistent_and_writes_the_outputs() {
    let dir = tempfile::tempdir().unwrap();
    let s = radar(dir.path(), RadarTruth::default());
    assert_eq!(s.status, "CONSISTENT", "{}", describe(&s));
    assert!(s.accepted().is_empty());
    // The calibration offset (1.3 dB) is fitted and reported, not absorbed by an effect.
    let power = s
        .attribution
        .iter()
        .find(|a| a.quantity == "power_db")
        .unwrap();
    let off = power.calibration_offset.unwrap();
    assert!((off[0] - 1.3).abs() < 0.4, "offset {off:?}");
    for m in &s.metrics {
        assert!(m.pass, "{m:?}");
    }
    let json: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(dir.path().join("out/summary.json")).unwrap(),
    )
    .unwrap();
    assert_eq!(json["schema"], "osiris.consistency/1");
    assert_eq!(json["sensor"], "radar");
    for k in ["status", "metrics", "effects", "error"] {
        assert!(!json[k].is_null(), "summary.json lacks {k}");
    }
    let m = &json["metrics"][0];
    for k in ["id", "value", "tolerance", "pass"] {
        assert!(!m[k].is_null(), "metric lacks {k}");
    }
    let html = std::fs::read_to_string(dir.path().join("out/report.html")).unwrap();
    assert!(html.contains("<svg") && !html.contains("<script"));
}

#[test]
fn divp_radar_r2_bug_is_found_as_the_spreading_exponent() {
    let dir = tempfile::tempdir().unwrap();
    // Ranges beyond the STC knee separate spreading from the STC decoy.
    let spec = RadarTruth {
        distances_m: (0..18).map(|i| 3.0 + 14.0 * f64::from(i)).collect(),
        hidden: vec![RadarHidden::ModelSpreadingR2],
        ..RadarTruth::default()
    };
    let s = radar(dir.path(), spec);
    assert_eq!(s.status, "EXPLAINED", "{}", describe(&s));
    assert_eq!(
        s.accepted(),
        vec!["radar.two_way_spreading".to_string()],
        "{}",
        describe(&s)
    );
    let p0 = param(&s, "radar.two_way_spreading");
    assert!((p0 - 2.0).abs() < 0.1, "exponent {p0}\n{}", describe(&s));
    assert!(
        s.effect("radar.two_way_spreading")
            .unwrap()
            .tie_group
            .is_none(),
        "{}",
        describe(&s)
    );
}

#[test]
fn divp_radar_area_bug_is_found_as_rcs_area_scaling() {
    let dir = tempfile::tempdir().unwrap();
    let spec = RadarTruth {
        hidden: vec![RadarHidden::ModelAreaLinear],
        seed: 3,
        ..RadarTruth::default()
    };
    let s = radar(dir.path(), spec);
    assert_eq!(s.status, "EXPLAINED", "{}", describe(&s));
    assert_eq!(
        s.accepted(),
        vec!["radar.rcs_area_scaling".to_string()],
        "{}",
        describe(&s)
    );
    let p0 = param(&s, "radar.rcs_area_scaling");
    assert!(
        (p0 - 1.0).abs() < 0.1,
        "area exponent {p0}\n{}",
        describe(&s)
    );
}

#[test]
fn stc_inside_its_knee_ties_with_spreading_until_the_design_reaches_beyond_it() {
    let dir = tempfile::tempdir().unwrap();
    // Measured processing with STC (near returns attenuated as (R/60 m)²); all ranges below the
    // knee: a spreading exponent of −2 has the same signature.
    let decoy = RadarTruth {
        distances_m: (0..14).map(|i| 3.0 + 4.0 * f64::from(i)).collect(),
        hidden: vec![RadarHidden::Stc {
            knee_m: 60.0,
            exponent: 2.0,
        }],
        seed: 5,
        ..RadarTruth::default()
    };
    let s = radar(&dir.path().join("decoy"), decoy.clone());
    let acc = s.accepted();
    assert_eq!(acc.len(), 1, "{}", describe(&s));
    let e = s.effect(&acc[0]).unwrap();
    let tie = s
        .tie_groups
        .iter()
        .find(|t| Some(&t.id) == e.tie_group.as_ref())
        .unwrap_or_else(|| panic!("the accepted effect has no tie group\n{}", describe(&s)));
    for m in ["radar.two_way_spreading", "radar.stc_range_gain"] {
        assert!(tie.members.iter().any(|x| x == m), "{}", describe(&s));
    }
    assert!(tie.discriminating_experiment.contains("STC knee"));
    // The discriminating design (ranges to 241 m, beyond the knee) gives the single right answer.
    let s = radar(
        &dir.path().join("separated"),
        RadarTruth {
            distances_m: (0..18).map(|i| 3.0 + 14.0 * f64::from(i)).collect(),
            ..decoy
        },
    );
    assert_eq!(
        s.accepted(),
        vec!["radar.stc_range_gain".to_string()],
        "{}",
        describe(&s)
    );
    assert!(
        s.effect("radar.stc_range_gain")
            .unwrap()
            .tie_group
            .is_none(),
        "{}",
        describe(&s)
    );
}

#[test]
fn divp_spreading_bug_inside_the_stc_knee_is_not_a_tie_when_stc_cannot_fit_its_sign() {
    let dir = tempfile::tempdir().unwrap();
    // The DIVP R⁻² model bug makes the residual fall with range; STC (bounded p0 ≥ 0) can only
    // make it rise, so the identical shapes are separated by the sign.
    let spec = RadarTruth {
        distances_m: (0..14).map(|i| 3.0 + 4.0 * f64::from(i)).collect(),
        hidden: vec![RadarHidden::ModelSpreadingR2],
        seed: 5,
        ..RadarTruth::default()
    };
    let s = radar(dir.path(), spec);
    assert_eq!(
        s.accepted(),
        vec!["radar.two_way_spreading".to_string()],
        "{}",
        describe(&s)
    );
    assert!((param(&s, "radar.two_way_spreading") - 2.0).abs() < 0.15);
    assert!(
        s.effect("radar.two_way_spreading")
            .unwrap()
            .tie_group
            .is_none(),
        "{}",
        describe(&s)
    );
}

#[test]
fn out_of_catalogue_scalloping_is_not_explained() {
    let dir = tempfile::tempdir().unwrap();
    let spec = RadarTruth {
        distances_m: (0..40).map(|i| 3.0 + 1.93 * f64::from(i)).collect(),
        hidden: vec![RadarHidden::Scalloping {
            bandwidth_hz: 1.0e9,
        }],
        frames_per_station: 4,
        seed: 7,
        ..RadarTruth::default()
    };
    let s = radar(dir.path(), spec);
    assert!(
        s.status == "UNEXPLAINED" || s.status == "PARTIALLY_EXPLAINED",
        "{}",
        describe(&s)
    );
    let power = s
        .attribution
        .iter()
        .find(|a| a.quantity == "power_db")
        .unwrap();
    assert!(power.diagnostics.is_some(), "{}", describe(&s));
}

#[test]
fn lidar_null_is_consistent() {
    let dir = tempfile::tempdir().unwrap();
    let s = lidar(dir.path(), LidarTruth::default());
    assert_eq!(s.status, "CONSISTENT", "{}", describe(&s));
}

#[test]
fn divp_lidar_missing_overlap_function_is_found() {
    let dir = tempfile::tempdir().unwrap();
    let spec = LidarTruth {
        hidden: vec![LidarHidden::Overlap {
            r_on_m: 1.5,
            full_ratio: 3.0,
        }],
        seed: 2,
        ..LidarTruth::default()
    };
    let s = lidar(dir.path(), spec);
    assert!(
        s.accepted().contains(&"lidar.overlap_function".to_string()),
        "{}",
        describe(&s)
    );
    let r_on = param(&s, "lidar.overlap_function");
    assert!((r_on - 1.5).abs() < 0.3, "R_on {r_on}\n{}", describe(&s));
}

#[test]
fn divp_lidar_missing_vertical_divergence_is_found() {
    let dir = tempfile::tempdir().unwrap();
    let spec = LidarTruth {
        hidden: vec![LidarHidden::VerticalDivergence { mrad: 6.0 }],
        seed: 4,
        ..LidarTruth::default()
    };
    let s = lidar(dir.path(), spec);
    assert!(
        s.accepted()
            .contains(&"lidar.vertical_divergence".to_string()),
        "{}",
        describe(&s)
    );
}

#[test]
fn divp_lidar_missing_mixed_pixels_is_found() {
    let dir = tempfile::tempdir().unwrap();
    let spec = LidarTruth {
        hidden: vec![LidarHidden::MixedPixels {
            footprint_mrad: 4.0,
        }],
        back_board_gap_m: Some(2.0),
        seed: 6,
        ..LidarTruth::default()
    };
    let s = lidar(dir.path(), spec);
    assert!(
        s.accepted().contains(&"lidar.mixed_pixels".to_string()),
        "{}",
        describe(&s)
    );
}

#[test]
fn campaign_schema_errors_name_the_key_and_unknown_keys_warn() {
    let dir = tempfile::tempdir().unwrap();
    let ok = r#"schema = "osiris.consistency/1"
surprise = 1
[run]
id = "r1"
[sensor]
kind = "radar"
quantity_semantics = { rcs = "dBsm" }
colour = "blue"
[environment]
fog_visibility_m = inf
[traces]
sensor_view = "sv.osi"
sensor_data = "sd.osi"
"#;
    let c = Campaign::parse(ok, dir.path()).unwrap();
    assert!(c.environment.fog_visibility_m.is_infinite());
    assert_eq!(c.tolerance.range_m, 0.30);
    assert!(
        c.warnings.iter().any(|w| w.contains("`surprise`")),
        "{:?}",
        c.warnings
    );
    assert!(
        c.warnings.iter().any(|w| w.contains("`sensor.colour`")),
        "{:?}",
        c.warnings
    );
    assert_eq!(c.sensor_view, dir.path().join("sv.osi"));
    let missing = ok.replace("sensor_data = \"sd.osi\"\n", "");
    let e = Campaign::parse(&missing, dir.path())
        .unwrap_err()
        .to_string();
    assert!(e.contains("traces.sensor_data"), "{e}");
    let missing = ok.replace("id = \"r1\"\n", "");
    let e = Campaign::parse(&missing, dir.path())
        .unwrap_err()
        .to_string();
    assert!(e.contains("run.id"), "{e}");
    let bad = ok.replace("kind = \"radar\"", "kind = 3");
    let e = Campaign::parse(&bad, dir.path()).unwrap_err().to_string();
    assert!(e.contains("sensor.kind"), "{e}");
}

/// ITU-R P.838-3 at 77 GHz (validation.md §9c), one-way dB/km: the stand-in simulator's rain.
fn itu_77ghz_db_per_km(rain_mm_h: f64) -> f64 {
    1.132 * rain_mm_h.powf(0.718)
}

/// A stand-in for the physical radar model: replays the campaign's model trace and, when the
/// configuration switches `radar.rain_attenuation` on, applies the two-way rain loss to its RCS.
fn stand_in(
    model_trace: &Path,
) -> impl FnMut(
    &osiris_models::SensorConfig,
    &[osiris_proto::osi3::SensorView],
) -> Result<
    Vec<osiris_proto::osi3::SensorData>,
    osiris::consistency::simulate::SimulateError,
> {
    let trace: Vec<osiris_proto::osi3::SensorData> =
        osiris::trace::read_messages(model_trace).unwrap();
    move |cfg, views| {
        assert_eq!(cfg.mode, osiris_models::sensor::ModelMode::Physical);
        assert_eq!(views.len(), trace.len());
        let rain = cfg.weather.as_ref().map(|w| w.rain_mm_h).unwrap_or(0.0);
        let on = cfg
            .effects
            .get("radar.rain_attenuation")
            .copied()
            .unwrap_or(true);
        let mut out = trace.clone();
        if on {
            for sd in &mut out {
                for d in &mut sd.feature_data.as_mut().unwrap().radar_sensor[0].detection {
                    let r = d.position.unwrap().distance.unwrap();
                    *d.rcs.as_mut().unwrap() -= 2.0 * itu_77ghz_db_per_km(rain) * r / 1000.0;
                }
            }
        }
        Ok(out)
    }
}

#[test]
fn closed_loop_enabling_the_identified_effect_makes_the_error_fall() {
    let dir = tempfile::tempdir().unwrap();
    let spec = RadarTruth {
        // Bright reflectors and ≤ 143 m keep the far stations clear of the detection threshold
        // (threshold censoring is not in the catalogue).
        distances_m: (0..11).map(|i| 3.0 + 14.0 * f64::from(i)).collect(),
        edges_m: vec![0.1, 0.15, 0.2],
        hidden: vec![RadarHidden::Rain { rain_mm_h: 25.0 }],
        seed: 11,
        ..RadarTruth::default()
    };
    let files = write_radar(&dir.path().join("campaign"), &spec).unwrap();
    let history = dir.path().join("history");
    let mut sim = stand_in(&files.simulated);
    // Iteration 1: the model without rain extinction.
    let mut a = args(&files, &dir.path().join("run1"), false);
    a.disable = vec!["radar.rain_attenuation".into()];
    a.history = Some(history.clone());
    let before = cli::run_with(&a, Some(&mut sim)).unwrap();
    eprintln!("{}", describe(&before));
    let rain = before.effect("radar.rain_attenuation").unwrap();
    assert!(rain.accepted, "{}", describe(&before));
    // The verdict says what to do: the switch, the exact re-run command, the predicted error.
    let act = &before.actions[0];
    assert_eq!(act.effect, "radar.rain_attenuation");
    assert_eq!(act.switch.as_deref(), Some("radar.rain_attenuation"));
    let cmd = act.command.as_deref().unwrap();
    assert!(
        cmd.starts_with("osiris consistency --meta ")
            && cmd.contains("--enable radar.rain_attenuation")
            && !cmd.contains("--disable radar.rain_attenuation")
            && cmd.contains("--history "),
        "{cmd}"
    );
    let (now, predicted) = (act.error_now["power_db"], act.predicted_error["power_db"]);
    assert!(predicted < 0.8 * now, "predicted {predicted} vs now {now}");
    assert_eq!(rain.model_switch.as_deref(), Some("radar.rain_attenuation"));
    // ITU-R P.838-3: 11.4 dB/km one-way at 25 mm/h.
    let g = rain.params[0].value;
    assert!((g - itu_77ghz_db_per_km(25.0)).abs() < 2.0, "γ {g}");
    assert!(before.history.is_empty());
    // Iteration 2: enable the switch the catalogue names; the held-out error falls.
    let mut a2 = args(&files, &dir.path().join("run2"), false);
    a2.enable = vec!["radar.rain_attenuation".into()];
    a2.history = Some(history.clone());
    let after = cli::run_with(&a2, Some(&mut sim)).unwrap();
    eprintln!("{}", describe(&after));
    assert_eq!(after.status, "CONSISTENT", "{}", describe(&after));
    let (b, c) = (
        before.holdout_error["power_db"],
        after.holdout_error["power_db"],
    );
    assert!(!before.holdout_targets.is_empty());
    // Per-detection scatter (fluctuation, thermal noise, 0.5 dB quantisation) of ≈ 1 dB stays.
    assert!(c < 0.8 * b, "held-out power RMS {b} -> {c}");
    // The prediction of the first run is what the second run measured (same offset convention).
    let rerun = after.error["power_db"];
    assert!(
        (rerun - predicted).abs() < 0.25 * predicted.max(0.5),
        "predicted {predicted}, re-run {rerun}"
    );
    assert!(after.actions.is_empty(), "{:?}", after.actions);
    // No earlier metric regresses.
    for m in &after.metrics {
        let prev = before.metrics.iter().find(|p| p.id == m.id).unwrap();
        assert!(m.pass || !prev.pass, "{} regressed", m.id);
    }
    // The registry carries the first run into the second summary.
    assert_eq!(after.history.len(), 1);
    assert_eq!(
        after.history[0].disabled,
        vec!["radar.rain_attenuation".to_string()]
    );
    assert!(
        after.history[0]
            .accepted
            .contains(&"radar.rain_attenuation".to_string())
    );
    let lines = std::fs::read_to_string(history.join("runs.jsonl")).unwrap();
    assert_eq!(lines.lines().count(), 2);
    assert!(dir.path().join("run2/simulated_sensor_data.osi").exists());
    if let Ok(keep) = std::env::var("OSIRIS_CONSISTENCY_KEEP") {
        // Inspection aid: keep the reports of both iterations.
        for run in ["run1", "run2"] {
            for f in ["report.html", "summary.json"] {
                let to = Path::new(&keep).join(format!("{run}_{f}"));
                std::fs::copy(dir.path().join(run).join(f), to).unwrap();
            }
        }
    }
    let html = std::fs::read_to_string(dir.path().join("run2/report.html")).unwrap();
    assert!(html.contains("Trend") && html.contains("radar.rain_attenuation"));
}

#[test]
fn unknown_effect_names_are_rejected() {
    let dir = tempfile::tempdir().unwrap();
    let files = write_radar(
        &dir.path().join("campaign"),
        &RadarTruth {
            distances_m: vec![5.0, 10.0],
            ..RadarTruth::default()
        },
    )
    .unwrap();
    let mut a = args(&files, &dir.path().join("out"), false);
    a.enable = vec!["radar.no_such_effect".into()];
    let e = cli::run_with(&a, None).unwrap_err().to_string();
    assert!(e.contains("radar.no_such_effect"), "{e}");
}

#[test]
fn gating_association_without_object_ids() {
    let dir = tempfile::tempdir().unwrap();
    let spec = RadarTruth {
        object_ids: false,
        hidden: vec![RadarHidden::ModelAreaLinear],
        seed: 9,
        ..RadarTruth::default()
    };
    let s = radar(dir.path(), spec);
    assert!(s.pairing.rows > 1000);
    assert_eq!(
        s.accepted(),
        vec!["radar.rcs_area_scaling".to_string()],
        "{}",
        describe(&s)
    );
}

/// End-to-end re-simulation through `osiris_models::build_sensor` (the FMU's code path).
#[test]
fn resimulation_with_the_physical_radar_model() {
    let dir = tempfile::tempdir().unwrap();
    let spec = RadarTruth {
        distances_m: vec![20.0, 60.0],
        // Reflector columns 6 m apart: resolvable by a small MIMO array at these ranges.
        lateral_m: vec![-6.0, 0.0, 6.0],
        frames_per_station: 1,
        hidden: vec![RadarHidden::Rain { rain_mm_h: 50.0 }],
        missing_fraction: 0.0,
        seed: 13,
        ..RadarTruth::default()
    };
    let files = write_radar(&dir.path().join("campaign"), &spec).unwrap();
    let mut off = args(&files, &dir.path().join("off"), false);
    off.disable = vec!["radar.rain_attenuation".into()];
    let before =
        cli::run_with(&off, None).unwrap_or_else(|e| panic!("re-simulation failed: {e:#}"));
    let mut on = args(&files, &dir.path().join("on"), false);
    on.enable = vec!["radar.rain_attenuation".into()];
    let after = cli::run_with(&on, None).unwrap();
    assert!(before.pairing.rows > 0 && after.pairing.rows > 0);
    let (b, c) = (before.error["power_db"], after.error["power_db"]);
    assert!(
        c <= b + 0.1,
        "power RMS with rain extinction {c} vs without {b}"
    );
}

#[test]
fn antenna_pattern_vs_reflector_aspect_is_a_tie_until_the_reflectors_face_the_sensor() {
    let dir = tempfile::tempdir().unwrap();
    // Reflectors facing along −x: their aspect equals their azimuth, so the antenna pattern and
    // the aspect pattern have the same signature.
    let decoy = RadarTruth {
        distances_m: (0..12).map(|i| 10.0 + 6.0 * f64::from(i)).collect(),
        lateral_m: vec![-2.0, -1.0, 0.0, 1.0, 2.0],
        edges_m: vec![0.1, 0.15],
        face_sensor: false,
        hidden: vec![RadarHidden::AntennaPattern {
            beamwidth_deg: 12.0,
        }],
        seed: 17,
        ..RadarTruth::default()
    };
    let s = radar(&dir.path().join("decoy"), decoy.clone());
    let acc = s.accepted();
    assert!(!acc.is_empty(), "{}", describe(&s));
    let e = s.effect(&acc[0]).unwrap();
    let group = s
        .tie_groups
        .iter()
        .find(|t| Some(&t.id) == e.tie_group.as_ref())
        .unwrap_or_else(|| panic!("no tie group on {}\n{}", acc[0], describe(&s)));
    assert!(group.members.contains(&"radar.antenna_pattern".to_string()));
    assert!(group.members.contains(&"radar.target_aspect".to_string()));
    // The discriminating design: reflectors turned to face the sensor (aspect ≈ 0).
    let s = radar(
        &dir.path().join("separated"),
        RadarTruth {
            face_sensor: true,
            ..decoy
        },
    );
    assert_eq!(
        s.accepted(),
        vec!["radar.antenna_pattern".to_string()],
        "{}",
        describe(&s)
    );
    let bw = param(&s, "radar.antenna_pattern");
    assert!((bw - 12.0).abs() < 1.0, "beamwidth {bw}");
    assert!(
        s.effect("radar.antenna_pattern")
            .unwrap()
            .tie_group
            .is_none(),
        "{}",
        describe(&s)
    );
}

/// The hidden-effect protocol (validation.md §8) over [`protocol::FAST_SEEDS`] seeds per case: every
/// case is named in every seed and nothing is wrongly accepted. A case with a documented known gap
/// (`Case::known_gap`, said in the bench JSON and the docs) is held to the weaker criterion: its
/// effect on top in all seeds but one; its misses and wrong acceptances are printed.
/// `osiris bench consistency-protocol` runs the same cases over 10 seeds.
#[test]
fn hidden_effect_protocol_names_every_case() {
    let dir = tempfile::tempdir().unwrap();
    let mut failures = Vec::new();
    for case in protocol::cases() {
        let outcomes = protocol::run_case(&case, protocol::FAST_SEEDS, dir.path()).unwrap();
        let hits = outcomes.iter().filter(|o| o.hit).count();
        eprintln!("PROTOCOL {}: {hits}/{}", case.name, outcomes.len());
        if let Some(gap) = case.known_gap {
            let top = outcomes.iter().filter(|o| o.top_hit).count();
            eprintln!("  known gap: {gap}; effect on top {top}/{}", outcomes.len());
            for o in outcomes.iter().filter(|o| !o.hit) {
                eprintln!("  miss {o:?}");
            }
            if top + 1 < outcomes.len() {
                failures.push(format!(
                    "{}: top {top}/{} {outcomes:?}",
                    case.name,
                    outcomes.len()
                ));
            }
            continue;
        }
        if hits < outcomes.len() {
            failures.push(format!(
                "{}: {hits}/{} {outcomes:?}",
                case.name,
                outcomes.len()
            ));
        }
        for o in outcomes.iter().filter(|o| !o.wrong.is_empty()) {
            failures.push(format!("{} wrong acceptance {o:?}", case.name));
        }
    }
    assert!(failures.is_empty(), "{failures:#?}");
}

/// End-to-end LiDAR re-simulation through `osiris_models::build_sensor`.
#[test]
fn resimulation_with_the_physical_lidar_model() {
    let dir = tempfile::tempdir().unwrap();
    let spec = LidarTruth {
        distances_m: vec![6.0, 12.0],
        frames_per_station: 1,
        missing_fraction: 0.0,
        seed: 21,
        ..LidarTruth::default()
    };
    let files = write_lidar(&dir.path().join("campaign"), &spec).unwrap();
    let s = cli::run_with(&args(&files, &dir.path().join("out"), false), None)
        .unwrap_or_else(|e| panic!("re-simulation failed: {e:#}"));
    eprintln!("{}", describe(&s));
    assert_eq!(s.pairing.paired_frames, 2);
    assert!(s.pairing.counts.sim_detected > 0, "{:?}", s.pairing.counts);
}

#[test]
fn one_target_keeps_a_training_split_and_names_the_effect() {
    // One reflector: holding out the target would leave nothing to fit; stations are held out.
    let dir = tempfile::tempdir().unwrap();
    let s = radar(
        dir.path(),
        RadarTruth {
            edges_m: vec![0.15],
            lateral_m: vec![0.0],
            hidden: vec![RadarHidden::ModelSpreadingR2],
            seed: 21,
            ..RadarTruth::default()
        },
    );
    assert_eq!(s.holdout.by, "station");
    assert!(s.holdout_targets.is_empty() && !s.holdout.stations.is_empty());
    let a = s
        .attribution
        .iter()
        .find(|a| a.quantity == "power_db")
        .unwrap();
    assert!(
        a.stations > s.holdout.stations.len(),
        "training split empty"
    );
    assert_eq!(
        s.accepted(),
        vec!["radar.two_way_spreading".to_string()],
        "{}",
        describe(&s)
    );
    assert!(!s.holdout_error.is_empty());
}

#[test]
fn three_sizes_of_one_reflector_each_identify_the_area_law() {
    // Three reflectors of 0.05, 0.1 and 0.2 m: no target can be held out without taking a size
    // away, and leave-one-target-out folds would train a size law on one size.
    let dir = tempfile::tempdir().unwrap();
    let s = radar(
        dir.path(),
        RadarTruth {
            edges_m: vec![0.05, 0.1, 0.2],
            lateral_m: vec![0.0],
            hidden: vec![RadarHidden::ModelAreaLinear],
            seed: 22,
            ..RadarTruth::default()
        },
    );
    assert_eq!(s.holdout.by, "station");
    assert_eq!(
        s.accepted(),
        vec!["radar.rcs_area_scaling".to_string()],
        "{}",
        describe(&s)
    );
    let p0 = param(&s, "radar.rcs_area_scaling");
    assert!((p0 - 1.0).abs() < 0.15, "area exponent {p0}");
}

#[test]
fn exit_status_separates_verdicts_from_errors() {
    let bin = env!("CARGO_BIN_EXE_osiris");
    let dir = tempfile::tempdir().unwrap();
    let run = |meta: &Path, simulated: &Path, out: &str| {
        std::process::Command::new(bin)
            .args(["consistency", "--meta"])
            .arg(meta)
            .arg("--simulated")
            .arg(simulated)
            .arg("--out")
            .arg(dir.path().join(out))
            .output()
            .unwrap()
    };
    // CONSISTENT → 0.
    let null = write_radar(&dir.path().join("null"), &RadarTruth::default()).unwrap();
    let o = run(&null.toml, &null.simulated, "o_null");
    assert_eq!(
        o.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&o.stderr)
    );
    // A failing tolerance that the catalogue does not explain → 1, outputs written.
    let bad = write_radar(
        &dir.path().join("bad"),
        &RadarTruth {
            hidden: vec![RadarHidden::Scalloping { bandwidth_hz: 1e9 }],
            ..RadarTruth::default()
        },
    )
    .unwrap();
    let text = std::fs::read_to_string(&bad.toml).unwrap();
    // A strict power tolerance, so the scalloping fails it.
    let text = text.replace("power_db = 5.0", "power_db = 0.3");
    std::fs::write(&bad.toml, text).unwrap();
    let o = run(&bad.toml, &bad.simulated, "o_bad");
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(err.contains("failing metrics"), "{err}");
    assert!(dir.path().join("o_bad/summary.json").exists());
    // An input error → 2, naming the file.
    let missing = dir.path().join("nope/consistency.toml");
    let o = run(&missing, &null.simulated, "o_missing");
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(err.contains("nope/consistency.toml"), "{err}");
    // A usage error of the command line → 2 (clap).
    let o = std::process::Command::new(bin)
        .args(["consistency", "--bogus"])
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(2));
}

/// `sensor.lidar_preset = "fmcw"`: the re-simulation runs the FMCW preset, the catalogue offers the
/// FMCW effects (and fog extinction only where the campaign has a finite visibility); a pulsed
/// campaign gets no FMCW entry; a radar campaign cannot name a LiDAR preset.
#[test]
fn fmcw_campaign_selects_the_preset_and_the_fmcw_entries() {
    use osiris::consistency::campaign::CampaignSensor;
    use osiris::consistency::catalogue::Catalogue;
    let dir = tempfile::tempdir().unwrap();
    let text = |preset: &str, fog: &str| {
        format!(
            "schema = \"osiris.consistency/1\"\n[run]\nid = \"f\"\n[sensor]\nkind = \"lidar\"\n{preset}\n\
             [environment]\nfog_visibility_m = {fog}\n[traces]\nsensor_view = \"sv.osi\"\nsensor_data = \"sd.osi\"\n"
        )
    };
    let ids = |c: &Campaign| -> Vec<String> {
        Catalogue::builtin(CampaignSensor::Lidar)
            .unwrap()
            .for_campaign(c)
            .effects
            .iter()
            .map(|e| e.id().to_string())
            .collect()
    };
    let fmcw = Campaign::parse(&text("lidar_preset = \"fmcw\"", "inf"), dir.path()).unwrap();
    assert!(fmcw.sensor.is_fmcw());
    let got = ids(&fmcw);
    for id in [
        "lidar.fmcw_speckle",
        "lidar.fmcw_phase_noise",
        "lidar.fmcw_chirp_nonlinearity",
    ] {
        assert!(got.iter().any(|g| g == id), "{id} missing from {got:?}");
    }
    assert!(!got.iter().any(|g| g == "lidar.fog_extinction"), "{got:?}");
    let pulsed = Campaign::parse(&text("", "200"), dir.path()).unwrap();
    let got = ids(&pulsed);
    assert!(!got.iter().any(|g| g.starts_with("lidar.fmcw_")), "{got:?}");
    assert!(got.iter().any(|g| g == "lidar.fog_extinction"), "{got:?}");
    let cfg =
        osiris::consistency::simulate::model_config(&fmcw, None, &Default::default(), 1).unwrap();
    assert_eq!(
        cfg.lidar.unwrap().preset,
        osiris_models::lidar::scan::Preset::Fmcw
    );
    let cfg =
        osiris::consistency::simulate::model_config(&pulsed, None, &Default::default(), 1).unwrap();
    assert!(
        cfg.lidar
            .is_none_or(|l| l.preset != osiris_models::lidar::scan::Preset::Fmcw)
    );
    let e = Campaign::parse(
        &text("lidar_preset = \"fmcw\"", "inf").replace("kind = \"lidar\"", "kind = \"radar\""),
        dir.path(),
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("sensor.lidar_preset"), "{e}");
}
