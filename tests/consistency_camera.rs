//! The camera part of the consistency workflow (issue 7) against the independent camera truth
//! generator (`osiris::consistency::truth_camera`, EMVA 1288 written out again): RAW PNG campaigns
//! with hidden effects, attribution through the same entry point as `osiris consistency`.

use std::path::Path;

use osiris::consistency::camera::{CameraCampaign, RawFrame, read_raw_png, write_raw_png};
use osiris::consistency::report::Summary;
use osiris::consistency::truth_camera::{CameraFiles, CameraHidden, CameraTruth, write_camera};
use osiris::consistency::{ConsistencyArgs, cli};

fn args(files: &CameraFiles, out: &Path, simulated: bool) -> ConsistencyArgs {
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

fn run(dir: &Path, spec: &CameraTruth) -> Summary {
    let files = write_camera(&dir.join("campaign"), spec).unwrap();
    cli::run_with(&args(&files, &dir.join("out"), true), None).expect("consistency run")
}

fn describe(s: &Summary) -> String {
    let mut out = format!("status {}\n", s.status);
    for a in &s.attribution {
        out += &format!(
            "  {} {} chi2/dof {:.2} -> {:.2} (thr {:.2}) tol {:.2} offset {:?} accepted {:?}\n",
            a.quantity,
            a.status.name(),
            a.baseline_chi2 / a.baseline_dof.max(1) as f64,
            a.final_chi2_per_dof,
            a.consistent_threshold,
            a.tolerance,
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
                e.params.iter().map(|p| p.value).collect::<Vec<_>>(),
                e.tie_group
            );
        }
    }
    for t in &s.tie_groups {
        out += &format!("  tie {} {:?} {}\n", t.id, t.members, t.reason);
    }
    for m in &s.metrics {
        out += &format!(
            "  metric {} {:.3} tol {} pass {}\n",
            m.id, m.value, m.tolerance, m.pass
        );
    }
    out
}

/// Whether accepting `got` is right when `want` is hidden: the effect itself, or its signature in
/// the other quantity (saturation collapses the variance; a missing dark current also lacks its
/// dark shot noise, a temporal variance offset that the catalogue names read noise, EMVA 1288's
/// σ_d²). A clip level just below the brightest ROIs clips only part of the pixels: the ROI mean
/// bends softly, like a companding knee (its look-alike); the variance collapse names the switch.
fn companion(want: &str, got: &str) -> bool {
    got == want
        || (want == "camera.saturation"
            && (got == "camera.saturation" || got == "camera.hdr_companding"))
        || (want == "camera.dark_current" && got == "camera.read_noise")
}

/// Physical catalogue effects (everything but the nuisance gain).
fn physical(s: &Summary) -> Vec<String> {
    s.accepted()
        .into_iter()
        .filter(|e| e != "camera.gain_offset")
        .collect()
}

#[test]
fn camera_toml_schema_errors_name_the_key() {
    let dir = tempfile::tempdir().unwrap();
    let spec = CameraTruth::default();
    let good = osiris::consistency::truth_camera::campaign_toml(&spec, "x");
    let cc = CameraCampaign::parse(&good, dir.path(), 15.0).unwrap();
    assert_eq!(cc.frames.len(), 6 * 2 + 2 * 2 * 2);
    assert_eq!(cc.rois.len(), 9);
    assert!(cc.warnings.is_empty(), "{:?}", cc.warnings);
    let err = |text: &str| {
        CameraCampaign::parse(text, dir.path(), 15.0)
            .unwrap_err()
            .to_string()
    };
    let e = err(&good.replacen("exposure_s = 0.001\n", "", 1));
    assert!(e.contains("frame[0].exposure_s"), "{e}");
    let e = err(&good.replacen("width_px = 128", "width_px = 128.5", 1));
    assert!(e.contains("sensor.width_px"), "{e}");
    let first = good
        .lines()
        .find(|l| l.starts_with("rect_px"))
        .unwrap()
        .to_string();
    let e = err(&good.replacen(&first, "rect_px = [120, 0, 32, 24]", 1));
    assert!(e.contains("roi[0].rect_px"), "{e}");
    let e = err(&good.replacen("cfa = \"rggb\"", "cfa = \"xyz\"", 1));
    assert!(e.contains("sensor.cfa"), "{e}");
    let cc = CameraCampaign::parse(
        &good.replacen("dark = false", "dark = false\nflash = true", 1),
        dir.path(),
        15.0,
    )
    .unwrap();
    assert!(
        cc.warnings.iter().any(|w| w.contains("frame[0].flash")),
        "{:?}",
        cc.warnings
    );
    // The common loader accepts the camera keys without warnings.
    let c = osiris::consistency::campaign::Campaign::parse(&good, dir.path()).unwrap();
    assert!(c.warnings.is_empty(), "{:?}", c.warnings);
}

#[test]
fn raw_png_round_trip_keeps_dn_and_black_level() {
    let dir = tempfile::tempdir().unwrap();
    let f = RawFrame {
        width: 6,
        height: 4,
        data: (0..24).map(|i| (i * 2731) as u16).collect(),
        black_level_dn: Some(64.0),
    };
    let p = dir.path().join("a/f.png");
    write_raw_png(&p, &f).unwrap();
    assert_eq!(read_raw_png(&p).unwrap(), f);
}

#[test]
fn null_campaign_is_consistent() {
    let dir = tempfile::tempdir().unwrap();
    let s = run(dir.path(), &CameraTruth::default());
    eprintln!("{}", describe(&s));
    assert_eq!(s.status, "CONSISTENT", "{}", describe(&s));
    assert!(s.accepted().is_empty());
    // The unknown black-level offset (2.5 DN) is the fitted, reported nuisance.
    let mean = s
        .attribution
        .iter()
        .find(|a| a.quantity == "roi_mean_dn")
        .unwrap();
    let off = mean.calibration_offset.unwrap();
    assert!((off[0] - 2.5).abs() < 0.5, "offset {off:?}");
    assert!(s.distributions.contains_key("roi_pixel_dn"));
    // Frame 3 is missing from the measurement: counted, not an error.
    assert_eq!(s.pairing.missing_meas_frames, 1);
}

fn found(h: CameraHidden, magnitude: f64, seed: u64) -> (bool, Summary) {
    let dir = tempfile::tempdir().unwrap();
    let spec = CameraTruth {
        seed,
        hidden: Some(h),
        magnitude,
        ..CameraTruth::default()
    };
    let s = run(dir.path(), &spec);
    let want = h.expected().unwrap();
    let named = |a: &String| a == want || (want == "camera.saturation" && a == "camera.saturation");
    let ok = s.accepted().iter().any(named) && physical(&s).iter().all(|a| companion(want, a));
    (ok, s)
}

#[test]
fn each_hidden_effect_alone_is_found_at_1x_and_3x_tolerance() {
    let mut missed = Vec::new();
    for h in CameraHidden::ALL_IN_CATALOGUE {
        for m in [1.0, 3.0] {
            let (ok, s) = found(h, m, 11);
            eprintln!("RESULT {h:?} at {m}×: {ok} {}", s.status);
            eprintln!("{}", describe(&s));
            // Shot noise at 1× lives in the brightest temporal pairs only: its χ² gain is real
            // (ΔBIC ≫ 10) but the baseline χ²/dof stays below 1, so gate 3 (share of the excess
            // χ²) cannot pass; ½× and 1× may legitimately stay CONSISTENT (hit rates: docs/consistency.md).
            let required = m >= 3.0 || h != CameraHidden::ShotNoise;
            if required && (!ok || s.status == "CONSISTENT") {
                missed.push(format!("{h:?} at {m}×"));
            }
        }
    }
    assert!(missed.is_empty(), "not found: {missed:?}");
}

#[test]
fn two_hidden_effects_together_are_both_found() {
    // A mean effect (vignetting) and a variance effect (PRNU), each at 3× its tolerance.
    let mut failures = Vec::new();
    for seed in [21, 22, 23] {
        let dir = tempfile::tempdir().unwrap();
        let spec = CameraTruth {
            seed,
            hidden: Some(CameraHidden::Vignetting),
            hidden2: Some(CameraHidden::Prnu),
            magnitude: 3.0,
            ..CameraTruth::default()
        };
        let s = run(dir.path(), &spec);
        eprintln!("seed {seed}\n{}", describe(&s));
        let acc = s.accepted();
        let both = ["camera.vignetting", "camera.prnu"]
            .iter()
            .all(|w| acc.iter().any(|a| a == w));
        let wrong: Vec<String> = physical(&s)
            .into_iter()
            .filter(|a| a != "camera.vignetting" && a != "camera.prnu")
            .collect();
        if !both || !wrong.is_empty() {
            failures.push(format!("seed {seed}: accepted {acc:?}"));
        }
    }
    assert!(failures.is_empty(), "{failures:?}");
}

/// A dashboard veil (issue 20 §4: the contrast loss of the dashboard's reflection in the
/// windshield) on a grey-chart design, at 1× and 3× its tolerance: named
/// `camera.dashboard_reflection`, not a gain error (which would scale each patch) nor dark current
/// (which the capped frames would show).
#[test]
fn dashboard_veil_on_a_grey_chart_is_found() {
    let mut missed = Vec::new();
    for seed in [11, 12, 13] {
        for m in [1.0, 3.0] {
            let dir = tempfile::tempdir().unwrap();
            let spec = CameraTruth {
                seed,
                hidden: Some(CameraHidden::DashboardVeil),
                magnitude: m,
                ..CameraTruth::default().with_chart()
            };
            let s = run(dir.path(), &spec);
            eprintln!("veil seed {seed} at {m}×: {}\n{}", s.status, describe(&s));
            let acc = s.accepted();
            let ok = acc.iter().any(|a| a == "camera.dashboard_reflection")
                && physical(&s)
                    .iter()
                    .all(|a| companion("camera.dashboard_reflection", a));
            // The fitted veil against the generator's.
            let hidden = osiris::consistency::truth_camera::hidden_veil_fraction(&spec);
            let fitted = s
                .attribution
                .iter()
                .flat_map(|a| a.effects.iter())
                .find(|e| e.id == "camera.dashboard_reflection" && e.accepted)
                .map_or(f64::NAN, |e| e.params[0].value);
            eprintln!("veil fitted {fitted:.5}, hidden {hidden:.5}");
            // The signature averages r before the slab sum: within 10 % of the generator's.
            if !ok || s.status == "CONSISTENT" || (fitted - hidden).abs() > 0.1 * hidden {
                missed.push(format!(
                    "seed {seed} at {m}×: {} {acc:?}, veil {fitted} vs {hidden}",
                    s.status
                ));
            }
        }
    }
    assert!(missed.is_empty(), "not found: {missed:?}");
}

/// The grey chart alone hides nothing: CONSISTENT (the patches' reflectances reach both sides).
#[test]
fn null_grey_chart_is_consistent() {
    let dir = tempfile::tempdir().unwrap();
    let s = run(dir.path(), &CameraTruth::default().with_chart());
    assert_eq!(s.status, "CONSISTENT", "{}", describe(&s));
}

#[test]
fn look_alikes_on_a_single_exposure_design_tie() {
    // Read noise vs DSNU: no temporal pairs on single frames.
    let dir = tempfile::tempdir().unwrap();
    let spec = CameraTruth {
        hidden: Some(CameraHidden::Dsnu),
        magnitude: 3.0,
        ..CameraTruth::default().single_exposure()
    };
    let s = run(dir.path(), &spec);
    eprintln!("{}", describe(&s));
    let tie = s
        .tie_groups
        .iter()
        .find(|t| t.members.iter().any(|m| m == "camera.dsnu"))
        .unwrap_or_else(|| panic!("no tie group with camera.dsnu\n{}", describe(&s)));
    assert!(
        tie.members.iter().any(|m| m == "camera.read_noise"),
        "{}",
        describe(&s)
    );
    assert!(tie.discriminating_experiment.contains("temporal"));
    // Never a confident wrong answer.
    for a in physical(&s) {
        assert!(
            a == "camera.dsnu" || tie.members.contains(&a),
            "{a} accepted\n{}",
            describe(&s)
        );
    }
}

#[test]
fn out_of_catalogue_banding_is_not_explained_by_a_wrong_effect() {
    let dir = tempfile::tempdir().unwrap();
    let spec = CameraTruth {
        hidden: Some(CameraHidden::FlickerBanding),
        magnitude: 3.0,
        ..CameraTruth::default()
    };
    let s = run(dir.path(), &spec);
    eprintln!("{}", describe(&s));
    assert!(
        s.status == "UNEXPLAINED" || s.status == "PARTIALLY_EXPLAINED",
        "{}",
        describe(&s)
    );
    assert!(physical(&s).is_empty(), "{}", describe(&s));
}

#[test]
fn cli_binary_runs_a_camera_campaign() {
    let dir = tempfile::tempdir().unwrap();
    let files = write_camera(&dir.path().join("campaign"), &CameraTruth::default()).unwrap();
    let out = dir.path().join("out");
    let st = std::process::Command::new(env!("CARGO_BIN_EXE_osiris"))
        .arg("consistency")
        .arg("--meta")
        .arg(&files.toml)
        .arg("--out")
        .arg(&out)
        .arg("--simulated")
        .arg(&files.simulated)
        .output()
        .unwrap();
    assert!(
        st.status.success(),
        "{}",
        String::from_utf8_lossy(&st.stderr)
    );
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    assert_eq!(json["sensor"], "camera");
    assert_eq!(json["status"], "CONSISTENT");
    assert!(out.join("report.html").exists());
}

/// Close the loop with our own model: "measured" = the physical camera with every effect on,
/// "simulated" = the same model with `camera.prnu` off; the tool must name PRNU; enabling it and
/// re-simulating makes the held-out error fall (below tolerance) and nothing that passed fails.
///
/// The exposures (0.1–1.5 ms) keep the sunlit flat field of the campaign below saturation in the
/// model (with the truth generator's default 1–10 ms sweep every frame from 4 ms on clips at full
/// well, two signal levels remain, and PRNU cannot be told from DSNU or the variance scale there).
/// The scenario cannot cap the lens, so the design has no dark frames.
#[test]
fn closed_loop_with_the_osiris_camera_model() {
    let dir = tempfile::tempdir().unwrap();
    let design = CameraTruth {
        exposures_s: vec![0.0001, 0.00025, 0.0005, 0.00075, 0.001, 0.0015],
        dark_exposures_s: vec![],
        temperatures_c: vec![40.0],
        ..CameraTruth::default()
    };
    let (files, cc, meas) = measured_by_the_model(dir.path(), &design, None);
    // The lit frames must carry light (a renderer that lost the scene fails here, not silently).
    let lit = cc
        .frames
        .iter()
        .zip(&meas)
        .filter(|(f, _)| !f.dark)
        .map(|(_, m)| {
            let bl = m.black_level_dn.unwrap_or(0.0);
            m.data.iter().map(|&v| f64::from(v) - bl).sum::<f64>() / m.data.len() as f64
        })
        .fold(0.0, f64::max);
    assert!(
        lit >= 50.0,
        "the simulated lit frames carry no light ({lit:.1} DN above black)"
    );
    let run_with = |enable: &[&str], disable: &[&str], out: &str| {
        resimulate(&files, dir.path().join(out), None, enable, disable)
    };
    let before = run_with(&[], &["camera.prnu"], "before");
    eprintln!("before\n{}", describe(&before));
    assert!(
        before.accepted().iter().any(|a| a == "camera.prnu"),
        "{}",
        describe(&before)
    );
    let after = run_with(&["camera.prnu"], &[], "after");
    eprintln!("after\n{}", describe(&after));
    let q = "roi_variance_per_roi_pct";
    let (b, a) = (before.holdout_error[q], after.holdout_error[q]);
    eprintln!("held-out {q}: {b:.2} -> {a:.2} %");
    assert!(a < b, "held-out variance error {b} -> {a}");
    assert!(a <= 20.0, "held-out variance error {a} % above tolerance");
    assert_eq!(after.status, "CONSISTENT", "{}", describe(&after));
    // Nothing that passed before fails now.
    for m in &before.metrics {
        if m.pass {
            let now = after.metrics.iter().find(|x| x.id == m.id).unwrap();
            assert!(now.pass, "{} passed before, fails after", m.id);
        }
    }
}

/// The protocol (validation.md §8): ≥ 10 seeds per case; prints the hit rates.
/// `cargo test --release --test consistency_camera -- --ignored --nocapture`
#[test]
#[ignore]
fn protocol_hit_rates_over_ten_seeds() {
    let seeds: Vec<u64> = (100..110).collect();
    let mut lines = Vec::new();
    let mut null_ok = 0;
    for &seed in &seeds {
        let dir = tempfile::tempdir().unwrap();
        let s = run(
            dir.path(),
            &CameraTruth {
                seed,
                ..CameraTruth::default()
            },
        );
        null_ok += usize::from(s.status == "CONSISTENT");
    }
    lines.push(format!("null: CONSISTENT {null_ok}/{}", seeds.len()));
    for h in CameraHidden::ALL_IN_CATALOGUE {
        for m in [0.5, 1.0, 3.0] {
            let mut hits = 0;
            let mut wrong = 0;
            for &seed in &seeds {
                let (ok, s) = found(h, m, seed);
                hits += usize::from(ok);
                let want = h.expected().unwrap();
                wrong += usize::from(physical(&s).iter().any(|a| !companion(want, a)));
            }
            lines.push(format!(
                "{h:?} at {m}× tol: found {hits}/{}, a wrong effect accepted {wrong}/{}",
                seeds.len(),
                seeds.len()
            ));
        }
    }
    let (mut tie_ok, mut oc_ok) = (0, 0);
    for &seed in &seeds {
        let dir = tempfile::tempdir().unwrap();
        let s = run(
            dir.path(),
            &CameraTruth {
                seed,
                hidden: Some(CameraHidden::Dsnu),
                magnitude: 3.0,
                ..CameraTruth::default().single_exposure()
            },
        );
        tie_ok += usize::from(s.tie_groups.iter().any(|t| {
            t.members.iter().any(|m| m == "camera.dsnu")
                && t.members.iter().any(|m| m == "camera.read_noise")
        }));
        let dir = tempfile::tempdir().unwrap();
        let s = run(
            dir.path(),
            &CameraTruth {
                seed,
                hidden: Some(CameraHidden::FlickerBanding),
                magnitude: 3.0,
                ..CameraTruth::default()
            },
        );
        oc_ok += usize::from(
            (s.status == "UNEXPLAINED" || s.status == "PARTIALLY_EXPLAINED")
                && physical(&s).is_empty(),
        );
    }
    lines.push(format!(
        "look-alike DSNU vs read noise (single exposure): tie reported {tie_ok}/{}",
        seeds.len()
    ));
    lines.push(format!(
        "out-of-catalogue flicker banding: UNEXPLAINED/PARTIALLY with no wrong effect {oc_ok}/{}",
        seeds.len()
    ));
    println!("{}", lines.join("\n"));
}

#[test]
fn camera_catalogue_parses_with_known_switches_and_exact_signatures() {
    use osiris::consistency::campaign::CampaignSensor;
    use osiris::consistency::catalogue::Catalogue;
    let c = Catalogue::builtin(CampaignSensor::Camera).unwrap();
    let known: Vec<&str> = osiris_models::registry::catalogue()
        .iter()
        .map(|e| e.name)
        .collect();
    let ids: Vec<String> = c.effects.iter().map(|e| e.id().to_string()).collect();
    assert!(ids.len() >= 10, "{ids:?}");
    for e in &c.effects {
        if let Some(s) = e.model_switch() {
            assert!(known.contains(&s), "{}: unknown model switch {s}", e.id());
        }
        for o in e.confusable_with() {
            assert!(ids.contains(o), "{}: {o}", e.id());
        }
    }
    let get = |id: &str| c.effects.iter().find(|e| e.id() == id).unwrap().clone();
    let mut x = [0.0; osiris::consistency::NVARS];
    // sim = 3000 DN above black, v_sim = 1000 DN², spatial row, field angle 30°.
    x[9] = 3000.0;
    x[13] = 1000.0;
    x[7] = 1.0;
    x[0] = 30.0;
    // Clip at 2000 DN: the mean loses 1000 DN.
    let sat = get("camera.saturation").eval(&x, &[2000f64.log10()]);
    assert!((sat + 1000.0).abs() < 1e-6, "{sat}");
    // Missing shot noise with K = 0.3: v_meas = 1000 + 900 → 100·ln(1.9) log-%.
    let shot = get("camera.shot_noise").eval(&x, &[0.3]);
    assert!((shot - 100.0 * 1.9f64.ln()).abs() < 1e-9, "{shot}");
    // PRNU 1 %: (30 DN)² = 900 DN² more spatial variance.
    let prnu = get("camera.prnu").eval(&x, &[1.0]);
    assert!((prnu - 100.0 * 1.9f64.ln()).abs() < 1e-9, "{prnu}");
    // Natural vignetting cos⁴θ missing: the mean scales by cos⁴ 30° = 0.5625.
    let vig = get("camera.vignetting").eval(&x, &[4.0]);
    assert!((vig - 3000.0 * (0.5625 - 1.0)).abs() < 1e-6, "{vig}");
    // Dark current doubling every p1 K: 2× at 25 + p1 °C.
    x[5] = 0.01;
    x[3] = 32.0;
    let dc = get("camera.dark_current").eval(&x, &[1000.0, 7.0]);
    assert!((dc - 20.0).abs() < 1e-9, "{dc}");
    // A dashboard of 2 % of a white's luminance mirrored in the glass, on a 30 % patch giving
    // 3000 DN (a white there gives 10 000 DN), at field angle 30° on the horizontal (position
    // angle 0): incidence cos θ = cos 30°·sin 28°; the lossless slab's 2r/(1 + r) of the
    // unpolarised interface r. Nothing on a dark frame or an ROI of unknown reflectance.
    let veil = get("camera.dashboard_reflection");
    x[6] = 30.0;
    x[10] = 1.0;
    x[1] = 0.0;
    let c = 30f64.to_radians().cos() * 28f64.to_radians().sin();
    let ct = (1.0 - (1.0 - c * c) / (1.52f64 * 1.52)).sqrt();
    let r = 0.5
        * (((c - 1.52 * ct) / (c + 1.52 * ct)).powi(2)
            + ((1.52 * c - ct) / (1.52 * c + ct)).powi(2));
    let want = 0.02 * 10_000.0 * 2.0 * r / (1.0 + r);
    let v = veil.eval(&x, &[0.02]);
    // (sin 28° and cos 28° to 7 digits in the signature)
    assert!((v - want).abs() < 1e-6 * want, "{v} vs {want}");
    // Towards the bottom of the image (position angle −90°) the glass is seen more obliquely.
    x[1] = -90.0;
    assert!(veil.eval(&x, &[0.02]) > 1.5 * v);
    x[1] = 0.0;
    x[10] = 0.0;
    assert_eq!(veil.eval(&x, &[0.02]), 0.0);
    x[10] = 1.0;
    x[6] = 0.0;
    assert_eq!(veil.eval(&x, &[0.02]), 0.0);

    // The windshield's elevation signature against a two-face Snell chain written here in angles
    // (rake 28°, n = 1.52, 4.96 mm; the ray in the vertical plane at elevation e; the outer face
    // turned by the wedge w towards the bottom of the glass): reported lower by the deviation, and
    // by the slab's offset Δ over the range.
    let ws = get("camera.windshield_refraction");
    let (n, t_m, w) = (1.52f64, 4.96e-3, 1.5e-3);
    for (e_deg, range) in [(0.0f64, 20.0f64), (-3.0, 10.0), (2.0, 40.0)] {
        let psi_n = 62f64.to_radians();
        let e = e_deg.to_radians();
        let th1 = psi_n - e;
        let tht = (th1.sin() / n).asin();
        let th2 = (psi_n - w) - (psi_n - tht);
        let th3 = (n * th2.sin()).asin();
        let deviation = (psi_n - w - th3) - e;
        let slab = t_m * (th1 - tht).sin() / tht.cos();
        let want = -(deviation + slab / range).to_degrees();
        let mut x = [0.0; osiris::consistency::NVARS];
        x[0] = range;
        x[2] = e_deg;
        let got = ws.eval(&x, &[1e3 * w]);
        // First order in w: within 1 % of the exact chain.
        assert!(
            (got - want).abs() < 0.01 * want.abs(),
            "e {e_deg}°: {got} vs {want}"
        );
    }
}

/// The closed loop for the dashboard's reflection with osiris's own camera model: "measured" is
/// the physical camera behind the default windshield with a light dashboard (reflectance 0.5)
/// looking at the grey chart (`CameraTruth::with_chart`, the patches in the SensorViews), at
/// another seed, every effect on; re-simulated with `camera.dashboard_reflection` off the workflow
/// names it from the ROI means (the same added luminance on every patch) with the veil in
/// fractions of a white; re-simulated with it on, the held-out mean error falls and it is no
/// longer accepted. The chart itself is checked first: the 90 % patch gives 4.5× the 20 % one.
#[test]
fn closed_loop_dashboard_reflection_with_the_osiris_camera_model() {
    let dir = tempfile::tempdir().unwrap();
    let design = CameraTruth {
        exposures_s: vec![0.0001, 0.00025, 0.0005, 0.00075, 0.001],
        dark_exposures_s: vec![],
        temperatures_c: vec![40.0],
        ..CameraTruth::default().with_chart()
    };
    let model = dir.path().join("model.json");
    std::fs::write(
        &model,
        r#"{"kind": "camera", "mode": "physical", "range_m": 150, "update_cycle_s": 0.1,
            "fov_horizontal_rad": 1.0471976, "fov_vertical_rad": 0.8,
            "mounting": {"position_m": [1.9, 0.0, 1.3]},
            "camera": {"windshield": {"dashboard_reflectance": 0.5}}}"#,
    )
    .unwrap();
    let (files, cc, meas) = measured_by_the_model(dir.path(), &design, Some(&model));
    // The chart: mean above black of the 90 % and the 20 % patch in the longest exposure.
    let last = meas.last().unwrap();
    let roi_mean = |k: usize| {
        let r = cc.rois[k].rect_px;
        let bl = last.black_level_dn.unwrap_or(0.0);
        let mut s = 0.0;
        for y in r[1]..r[1] + r[3] {
            for x in r[0]..r[0] + r[2] {
                s += f64::from(last.data[y * last.width + x]) - bl;
            }
        }
        s / (r[2] * r[3]) as f64
    };
    let refl = |k: usize| cc.rois[k].reflectance_pct.unwrap();
    let (k90, k20) = (
        (0..cc.rois.len()).find(|&k| refl(k) == 90.0).unwrap(),
        (0..cc.rois.len()).find(|&k| refl(k) == 20.0).unwrap(),
    );
    let ratio = roi_mean(k90) / roi_mean(k20);
    eprintln!(
        "chart: 90 % patch {:.1} DN, 20 % patch {:.1} DN, ratio {ratio:.2}",
        roi_mean(k90),
        roi_mean(k20)
    );
    assert!(ratio > 2.5 && ratio < 4.6, "chart ratio {ratio}");
    let run_with = |enable: &[&str], disable: &[&str], out: &str| {
        resimulate(&files, dir.path().join(out), Some(&model), enable, disable)
    };
    let veil = "camera.dashboard_reflection";
    let before = run_with(&[], &[veil], "before");
    eprintln!("before\n{}", describe(&before));
    assert!(
        before.accepted().iter().any(|a| a == veil),
        "{}",
        describe(&before)
    );
    let after = run_with(&[veil], &[], "after");
    eprintln!("after\n{}", describe(&after));
    let q = "roi_mean_pct";
    let (b, a) = (before.holdout_error[q], after.holdout_error[q]);
    eprintln!("held-out {q}: {b:.2} -> {a:.2} %");
    assert!(a < 0.6 * b, "held-out mean error {b} -> {a}");
    assert!(
        !after.accepted().iter().any(|x| x == veil),
        "{}",
        describe(&after)
    );
}

/// Writes the campaign of `design` into `dir/campaign` with its "measured" frames replaced by
/// osiris's physical camera (the model configuration `model`, else the campaign's default) at
/// seed 9001 with every effect on: another camera of the type. Returns the files, the loaded
/// campaign and those frames.
fn measured_by_the_model(
    dir: &Path,
    design: &CameraTruth,
    model: Option<&Path>,
) -> (CameraFiles, CameraCampaign, Vec<RawFrame>) {
    use osiris::consistency::camera::simulate_frames;
    use osiris::consistency::campaign::Campaign;
    use osiris::consistency::simulate::model_config;
    let files = write_camera(&dir.join("campaign"), design).unwrap();
    let campaign = Campaign::load(&files.toml).unwrap();
    let cc = CameraCampaign::load(&campaign, &files.toml).unwrap();
    let views: Vec<osiris_proto::osi3::SensorView> =
        osiris::consistency::pairing::read_trace(&files.sensor_view, "SensorView").unwrap();
    let cfg = model_config(&campaign, model, &Default::default(), 9_001).unwrap();
    let mut w = Vec::new();
    let meas: Vec<RawFrame> = simulate_frames(&cfg, &cc, &views, &mut w)
        .unwrap_or_else(|e| panic!("{e:#}"))
        .into_iter()
        .map(|m| m.expect("every frame simulated"))
        .collect();
    for (f, m) in cc.frames.iter().zip(&meas) {
        write_raw_png(
            &f.file,
            &RawFrame {
                black_level_dn: None,
                ..m.clone()
            },
        )
        .unwrap();
    }
    (files, cc, meas)
}

/// The workflow on `files`' campaign, re-simulating with osiris's camera (`model`, else the
/// campaign's default) and the given switches, into `out`.
fn resimulate(
    files: &CameraFiles,
    out: std::path::PathBuf,
    model: Option<&Path>,
    enable: &[&str],
    disable: &[&str],
) -> Summary {
    let names = |l: &[&str]| l.iter().map(|s| s.to_string()).collect();
    cli::run_with(
        &ConsistencyArgs {
            meta: files.toml.clone(),
            out,
            simulated: None,
            model: model.map(Path::to_path_buf),
            enable: names(enable),
            disable: names(disable),
            history: None,
        },
        None,
    )
    .unwrap()
}
