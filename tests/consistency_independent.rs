//! Hidden-effect protocol (validation.md §8) on campaigns from a second, independent truth
//! generator (`tests/support/independent_truth.rs`, GitHub issue 15): per case and seed, the
//! workflow must name the hidden effect (alone, or within its tie group), call the null case
//! CONSISTENT and the out-of-catalogue case UNEXPLAINED / PARTIALLY_EXPLAINED.
//!
//! Seeds: `OSIRIS_INDEPENDENT_SEEDS="1,2,3"` overrides the CI default. Each run prints one table
//! row per case and seed (`cargo test --test consistency_independent -- --nocapture`).

#[path = "support/independent_truth.rs"]
mod independent_truth;

use independent_truth::{
    BoardCase, CalibrationCase, CameraCase, ClutterCase, FmcwCase, LidarCase, RadarCase, Written,
};
use osiris::consistency::ConsistencyArgs;
use osiris::consistency::attribution::{EffectResult, QuantityAttribution};
use osiris::consistency::cli::run_with;
use osiris::consistency::report::{Action, Summary};

const DEFAULT_SEEDS: [u64; 3] = [1501, 1502, 1503];

fn seeds() -> Vec<u64> {
    std::env::var("OSIRIS_INDEPENDENT_SEEDS")
        .ok()
        .map(|s| {
            s.split(',')
                .filter_map(|x| x.trim().parse().ok())
                .collect::<Vec<u64>>()
        })
        .filter(|v| !v.is_empty())
        .unwrap_or_else(|| DEFAULT_SEEDS.to_vec())
}

/// What came out of one run.
struct Outcome {
    status: String,
    accepted: Vec<String>,
    /// Tie groups (member ids).
    ties: Vec<Vec<String>>,
}

impl Outcome {
    fn from(s: &Summary) -> Outcome {
        Outcome {
            status: s.status.clone(),
            accepted: s.accepted(),
            ties: s.tie_groups.iter().map(|t| t.members.clone()).collect(),
        }
    }

    /// The effects tied with `id` (including itself).
    fn tied_with(&self, id: &str) -> Vec<String> {
        let mut out = vec![id.to_string()];
        for g in &self.ties {
            if g.iter().any(|m| m == id) {
                out.extend(g.iter().cloned());
            }
        }
        out
    }

    /// The hidden effect is named: it is accepted or tied with an accepted effect, and every
    /// accepted effect is it or tied with it.
    fn names(&self, expected: &str) -> bool {
        let group = self.tied_with(expected);
        !self.accepted.is_empty()
            && self.accepted.iter().any(|a| group.contains(a))
            && self.accepted.iter().all(|a| group.contains(a))
    }
}

/// Where a run writes: `$OSIRIS_INDEPENDENT_KEEP/<name>` when that is set (the campaigns and
/// reports are kept there), else the temporary folder `tmp`.
fn work_dir(tmp: &tempfile::TempDir, name: &str) -> std::path::PathBuf {
    match std::env::var_os("OSIRIS_INDEPENDENT_KEEP") {
        Some(k) => std::path::PathBuf::from(k).join(name),
        None => tmp.path().to_path_buf(),
    }
}

/// The workflow's arguments for `w`'s campaign writing into `out`: no model, no switches, no
/// history (callers fill in what they need).
fn args_for(w: &Written, out: std::path::PathBuf) -> ConsistencyArgs {
    ConsistencyArgs {
        meta: w.meta.clone(),
        out,
        simulated: None,
        model: None,
        enable: vec![],
        disable: vec![],
        history: None,
    }
}

/// Writes a model configuration `json` as `name` into `w`'s campaign folder.
fn write_model(w: &Written, name: &str, json: String) -> std::path::PathBuf {
    let path = w.meta.with_file_name(name);
    std::fs::write(&path, json).unwrap();
    path
}

/// The physical camera of the independent camera campaigns as model configuration `name`: 60°,
/// `width_px` × `height_px`, detections only (no images), rolling shutter and motion blur off (the
/// generator's camera has a global shutter); `camera_extra` goes into the `camera` object, `extra`
/// into the configuration (each a `, "key": value` list or empty).
fn physical_camera_model(
    w: &Written,
    name: &str,
    (width_px, height_px): (u32, u32),
    camera_extra: &str,
    extra: &str,
) -> std::path::PathBuf {
    let (mx, mz) = independent_truth::camera_mounting();
    write_model(
        w,
        name,
        format!(
            r#"{{"kind": "camera", "mode": "physical", "range_m": 120, "update_cycle_s": 0.1,
            "fov_horizontal_rad": 1.0472, "fov_vertical_rad": 0.8,
            "mounting": {{"position_m": [{mx}, 0.0, {mz}]}},
            "effects": {{"camera.rolling_shutter": false, "camera.motion_blur": false}},
            "camera": {{"width_px": {width_px}, "height_px": {height_px}{camera_extra},
                        "emit": {{"raw_exposures": false, "raw_hdr_linear": false, "raw_companded": false, "isp": false}}}}{extra}}}"#
        ),
    )
}

/// [`args_for`] re-simulating with the model configuration `model` and the effect switches.
fn model_args(
    w: &Written,
    out: std::path::PathBuf,
    model: std::path::PathBuf,
    enable: &[&str],
    disable: &[&str],
) -> ConsistencyArgs {
    ConsistencyArgs {
        model: Some(model),
        enable: ids(enable),
        disable: ids(disable),
        ..args_for(w, out)
    }
}

fn ids(list: &[&str]) -> Vec<String> {
    list.iter().map(|s| s.to_string()).collect()
}

fn run(w: &Written, out: &std::path::Path) -> Summary {
    let args = ConsistencyArgs {
        simulated: Some(w.model_trace.clone()),
        ..args_for(w, out.to_path_buf())
    };
    run_with(&args, None).expect("the workflow runs")
}

/// The attribution of `quantity` in the summary `s`.
fn attribution<'a>(s: &'a Summary, quantity: &str) -> &'a QuantityAttribution {
    s.attribution
        .iter()
        .find(|a| a.quantity == quantity)
        .unwrap_or_else(|| panic!("no {quantity} rows"))
}

/// The fit of effect `id` in the attribution `q`.
fn fit<'a>(q: &'a QuantityAttribution, id: &str) -> &'a EffectResult {
    q.effects
        .iter()
        .find(|e| e.id == id)
        .unwrap_or_else(|| panic!("no fit of {id}"))
}

/// The summary's action for the effect `id`.
fn action_for<'a>(s: &'a Summary, id: &str) -> &'a Action {
    s.actions
        .iter()
        .find(|a| a.effect == id)
        .expect("an action for the named effect")
}

enum Expect {
    Effect(&'static str),
    /// Several hidden effects: each accepted (or tied with an accepted one), nothing else.
    Effects(&'static [&'static str]),
    Consistent,
    NotConfident,
}

impl Expect {
    fn text(&self) -> String {
        match self {
            Expect::Effect(e) => format!("{e} (alone or in its tie group)"),
            Expect::Effects(list) => format!("{} (each, nothing else)", list.join(" + ")),
            Expect::Consistent => "CONSISTENT".into(),
            Expect::NotConfident => "UNEXPLAINED / PARTIALLY_EXPLAINED".into(),
        }
    }

    fn holds(&self, o: &Outcome) -> bool {
        match self {
            Expect::Effect(e) => {
                o.names(e) && ["EXPLAINED", "PARTIALLY_EXPLAINED"].contains(&o.status.as_str())
            }
            Expect::Effects(list) => {
                let groups: Vec<Vec<String>> = list.iter().map(|e| o.tied_with(e)).collect();
                groups
                    .iter()
                    .all(|g| o.accepted.iter().any(|a| g.contains(a)))
                    && o.accepted
                        .iter()
                        .all(|a| groups.iter().any(|g| g.contains(a)))
                    && ["EXPLAINED", "PARTIALLY_EXPLAINED"].contains(&o.status.as_str())
            }
            Expect::Consistent => o.status == "CONSISTENT" && o.accepted.is_empty(),
            Expect::NotConfident => {
                ["UNEXPLAINED", "PARTIALLY_EXPLAINED"].contains(&o.status.as_str())
            }
        }
    }
}

/// Runs one case over the seeds, prints the table rows, and fails listing every miss.
fn protocol(
    sensor: &str,
    case: &str,
    expect: Expect,
    generate: impl Fn(u64, &std::path::Path) -> anyhow::Result<Written>,
) {
    let mut misses = Vec::new();
    for seed in seeds() {
        let tmp = tempfile::tempdir().unwrap();
        let root = work_dir(&tmp, &format!("{sensor}-{case}-{seed}"));
        let t0 = std::time::Instant::now();
        let w = generate(seed, &root.join("campaign")).expect("campaign written");
        let summary = run(&w, &root.join("out"));
        let o = Outcome::from(&summary);
        let ok = expect.holds(&o);
        let fitted: Vec<String> = match &expect {
            Expect::Effect(e) => vec![*e],
            Expect::Effects(list) => list.to_vec(),
            _ => vec![],
        }
        .iter()
        .flat_map(|id| {
            summary
                .attribution
                .iter()
                .flat_map(|q| q.effects.iter())
                .filter(move |r| r.id == *id && r.accepted)
                .map(|r| {
                    let p: Vec<String> =
                        r.params.iter().map(|p| format!("{:.3}", p.value)).collect();
                    format!("{}@{} [{}]", r.id, r.quantity, p.join(", "))
                })
        })
        .collect();
        if !fitted.is_empty() {
            println!(
                "  fitted {} (hidden {:?})",
                fitted.join("; "),
                w.hidden_value
            );
        }
        let row = format!(
            "| {sensor} | {case} | {seed} | {} | {} | {} | {} | {:.1} s |",
            o.status,
            if o.accepted.is_empty() {
                "-".to_string()
            } else {
                o.accepted.join(", ")
            },
            expect.text(),
            if ok { "ok" } else { "MISS" },
            t0.elapsed().as_secs_f64()
        );
        println!("{row}");
        if !ok {
            let ties: Vec<String> = o.ties.iter().map(|g| g.join("~")).collect();
            misses.push(format!(
                "{row} ties [{}]; frames {} (dropped {}); warnings {:?}",
                ties.join("; "),
                w.frames,
                w.dropped_frames,
                summary.warnings
            ));
        }
    }
    assert!(misses.is_empty(), "{}", misses.join("\n"));
}

fn radar(case: RadarCase, expect: Expect) {
    protocol("radar", case.name(), expect, |seed, dir| {
        independent_truth::radar_campaign(case, seed, dir)
    });
}

fn lidar(case: LidarCase, expect: Expect) {
    protocol("lidar", case.name(), expect, |seed, dir| {
        independent_truth::lidar_campaign(case, seed, dir)
    });
}

#[test]
fn radar_ground_multipath() {
    radar(
        RadarCase::GroundMultipath,
        Expect::Effect("radar.ground_multipath"),
    );
}

#[test]
fn radar_two_way_spreading() {
    radar(
        RadarCase::TwoWaySpreading,
        Expect::Effect("radar.two_way_spreading"),
    );
}

#[test]
fn radar_rcs_area_scaling() {
    radar(
        RadarCase::RcsAreaScaling,
        Expect::Effect("radar.rcs_area_scaling"),
    );
}

#[test]
fn radar_antenna_pattern() {
    radar(
        RadarCase::AntennaPattern,
        Expect::Effect("radar.antenna_pattern"),
    );
}

#[test]
fn radar_rain() {
    radar(RadarCase::Rain, Expect::Effect("radar.rain_attenuation"));
}

#[test]
fn radar_null() {
    radar(RadarCase::Null, Expect::Consistent);
}

#[test]
fn radar_out_of_catalogue() {
    radar(RadarCase::OutOfCatalogue, Expect::NotConfident);
}

/// A radar turned 0.5–1° from its nominal mounting (issue 19): a constant azimuth offset over five
/// azimuths and 8–60 m, named `radar.extrinsic_error` with its yaw.
#[test]
fn radar_yaw_misalignment() {
    radar(
        RadarCase::YawMisalignment,
        Expect::Effect("radar.extrinsic_error"),
    );
}

/// A radar clock 40–80 ms off (issue 19) with approaching, receding and crossing targets: range
/// residuals ṙ·Δt and azimuth residuals (dθ/dt)·Δt, named `radar.time_offset`.
#[test]
fn radar_time_offset() {
    radar(RadarCase::TimeOffset, Expect::Effect("radar.time_offset"));
}

fn calibration(case: CalibrationCase, expect: Expect) {
    protocol("radar", case.name(), expect, |seed, dir| {
        independent_truth::radar_calibration_campaign(case, seed, dir)
    });
}

/// A radar turned 0.5–1° that calibrates its azimuth online from the Doppler of stationary targets
/// once the host drives (issue 19), re-simulated with the surveyed yaw and no online calibration:
/// the azimuth residual steps from 0 (standing) to the yaw (driving), named
/// `radar.mounting_misalignment` with the yaw.
#[test]
fn radar_online_calibration() {
    calibration(
        CalibrationCase::SelfCalibrating,
        Expect::Effect("radar.mounting_misalignment"),
    );
}

/// The same radar re-simulated with the nominal mounting: −yaw while standing, 0 once the
/// calibration runs; named as both `radar.extrinsic_error` and `radar.mounting_misalignment`.
#[test]
fn radar_yaw_and_online_calibration() {
    calibration(
        CalibrationCase::YawAndSelfCalibrating,
        Expect::Effects(&["radar.extrinsic_error", "radar.mounting_misalignment"]),
    );
}

/// A yawed radar without online calibration on the same standing-then-driving design: the offset
/// stays when the host drives, named `radar.extrinsic_error` alone (the separating experiment of
/// the two look-alikes).
#[test]
fn radar_yaw_standing_and_driving() {
    calibration(
        CalibrationCase::YawOnly,
        Expect::Effect("radar.extrinsic_error"),
    );
}

/// A self-calibrating radar without misalignment: consistent.
#[test]
fn radar_online_calibration_null() {
    calibration(CalibrationCase::Null, Expect::Consistent);
}

fn clutter(case: ClutterCase, expect: Expect) {
    protocol("radar", case.name(), expect, |seed, dir| {
        independent_truth::radar_clutter_campaign(case, seed, dir)
    });
}

/// A parked radar over asphalt whose measurement has the road's constant-γ backscatter and whose
/// model trace has none (issue 19): clutter detections per 2 m band, named `radar.road_clutter`.
#[test]
fn radar_road_clutter() {
    clutter(
        ClutterCase::RoadClutter,
        Expect::Effect("radar.road_clutter"),
    );
}

#[test]
fn radar_clutter_null() {
    clutter(ClutterCase::Null, Expect::Consistent);
}

/// False alarms spread evenly over range (interference-like): not road clutter but the flat
/// `radar.false_alarms` (its decoy, kind measurement).
#[test]
fn radar_uniform_false_alarms() {
    clutter(
        ClutterCase::FalseAlarms,
        Expect::Effect("radar.false_alarms"),
    );
}

fn boards(case: BoardCase, expect: Expect) {
    protocol("radar", case.name(), expect, |seed, dir| {
        independent_truth::radar_board_campaign(case, seed, dir)
    });
}

/// Rough metal boards turned 4–48° off the line of sight (issue 19): the measurement has the
/// incoherent Lambertian term, the model trace only the coherent one; named
/// `radar.diffuse_scattering` on the power.
#[test]
fn radar_diffuse_scattering() {
    boards(
        BoardCase::DiffuseScattering,
        Expect::Effect("radar.diffuse_scattering"),
    );
}

#[test]
fn radar_boards_null() {
    boards(BoardCase::Null, Expect::Consistent);
}

fn camera(case: CameraCase, expect: Expect) {
    protocol("camera", case.name(), expect, |seed, dir| {
        independent_truth::camera_campaign(case, seed, dir)
    });
}

/// Camera detections of standing and crossing cars with nothing hidden: consistent.
#[test]
fn camera_detections_null() {
    camera(CameraCase::Null, Expect::Consistent);
}

/// A camera turned 0.5–1° in yaw (issue 19): a constant offset of the detections' azimuths, named
/// `camera.extrinsic_error`.
#[test]
fn camera_yaw_misalignment() {
    camera(
        CameraCase::YawMisalignment,
        Expect::Effect("camera.extrinsic_error"),
    );
}

/// A camera pitched 0.3–0.8° (issue 19: a camera's pitch changes with load): an elevation offset,
/// named `camera.extrinsic_error`.
#[test]
fn camera_pitch_misalignment() {
    camera(
        CameraCase::PitchMisalignment,
        Expect::Effect("camera.extrinsic_error"),
    );
}

/// A camera clock 40–80 ms off with crossing cars (issue 19): azimuth residuals (dθ/dt)·Δt,
/// named `camera.time_offset`; the standing cars tell it from a yaw.
#[test]
fn camera_time_offset() {
    camera(CameraCase::TimeOffset, Expect::Effect("camera.time_offset"));
}

/// A windshield the model lacks (issue 20 §4): the measuring camera looks through a raked glass
/// with a 1–2 mrad wedge (the generator's own two-face Snell trace), every car reported ≈ 0.1–0.2°
/// low, more where its ray meets the glass more obliquely; named `camera.windshield_refraction`
/// (or in its tie group with `camera.extrinsic_error`: on cars alone a pitch and a height error
/// can mimic it, the catalogue names the separating experiment).
#[test]
fn camera_windshield_refraction() {
    camera(
        CameraCase::Windshield,
        Expect::Effect("camera.windshield_refraction"),
    );
}

fn fmcw(case: FmcwCase, expect: Expect) {
    protocol("lidar", case.name(), expect, |seed, dir| {
        independent_truth::fmcw_lidar_campaign(case, seed, dir)
    });
}

#[test]
fn fmcw_lidar_speckle() {
    fmcw(FmcwCase::Speckle, Expect::Effect("lidar.fmcw_speckle"));
}

#[test]
fn fmcw_lidar_phase_noise() {
    fmcw(
        FmcwCase::PhaseNoise,
        Expect::Effect("lidar.fmcw_phase_noise"),
    );
}

#[test]
fn fmcw_lidar_chirp_nonlinearity() {
    fmcw(
        FmcwCase::ChirpNonlinearity,
        Expect::Effect("lidar.fmcw_chirp_nonlinearity"),
    );
}

#[test]
fn fmcw_lidar_null() {
    fmcw(FmcwCase::Null, Expect::Consistent);
}

#[test]
fn lidar_overlap() {
    lidar(LidarCase::Overlap, Expect::Effect("lidar.overlap_function"));
}

#[test]
fn lidar_fog() {
    lidar(LidarCase::Fog, Expect::Effect("lidar.fog_extinction"));
}

#[test]
fn lidar_vertical_divergence() {
    lidar(
        LidarCase::VerticalDivergence,
        Expect::Effect("lidar.vertical_divergence"),
    );
}

#[test]
fn lidar_detector_saturation() {
    lidar(
        LidarCase::Saturation,
        Expect::Effect("lidar.detector_saturation"),
    );
}

/// A LiDAR turned 0.5–1° from its nominal mounting (issue 19): every board's point centroid moves
/// by the same azimuth over 5–52 m and ±17°, named `lidar.extrinsic_error` with its yaw.
#[test]
fn lidar_yaw_misalignment() {
    lidar(
        LidarCase::YawMisalignment,
        Expect::Effect("lidar.extrinsic_error"),
    );
}

#[test]
fn lidar_null() {
    lidar(LidarCase::Null, Expect::Consistent);
}

#[test]
fn lidar_out_of_catalogue() {
    lidar(LidarCase::OutOfCatalogue, Expect::NotConfident);
}

/// Closed-form checks of the generator itself against the reference values of physics.md and
/// validation.md §9.
#[test]
fn generator_physics_reference_values() {
    use independent_truth::*;
    // Trihedral RCS at 77 GHz: 10 cm → 27.6 m² (14.4 dBsm), 15 cm → 139.9 m².
    assert!((trihedral_rcs(0.10) - 27.6).abs() < 0.2);
    assert!((trihedral_rcs(0.15) - 139.9).abs() < 1.0);
    // ITU-R P.838-3 at 77 GHz, H: 10 mm/h → 5.91 dB/km, 50 → 18.8, 100 → 30.8.
    assert!((rain_db_per_km(10.0) - 5.91).abs() < 0.02);
    assert!((rain_db_per_km(50.0) - 18.8).abs() < 0.1);
    assert!((rain_db_per_km(100.0) - 30.8).abs() < 0.1);
    // Fresnel H for ε = 4 − 0.2j, h = 0.5 m both ends: |Γ_H| = 0.89 / 0.94 / 0.98 at 10 / 20 / 50 m.
    for (d, want) in [(10.0, 0.89), (20.0, 0.94), (50.0, 0.98)] {
        let psi = (1.0f64 / d).atan();
        let g = fresnel_h(psi, C64::new(4.0, -0.2)).abs();
        assert!((g - want).abs() < 0.011, "|Γ_H| at {d} m = {g}");
    }
    // Two-ray: at grazing incidence Γ_H → −1, so |F| → 2|sin(kΔR/2)| (the flat-earth lobing of
    // Skolnik §2.11) with ΔR the exact path difference; 2 km, both ends at 0.5 m: kΔR ≈ 0.40 rad.
    let (s, t) = (
        glam::DVec3::new(0.0, 0.0, 0.5),
        glam::DVec3::new(2000.0, 0.0, 0.5),
    );
    let dr = (2000.0f64.hypot(1.0) - 2000.0) * 2.0 * std::f64::consts::PI / (299_792_458.0 / 77e9);
    let f = two_ray_factor(s, t, EPS_ASPHALT).abs();
    assert!(
        (f - 2.0 * (dr / 2.0).sin()).abs() < 0.01,
        "|F| at 2 km = {f}"
    );
    // Overlap (physics.md §2.3 example): 0 below 1.5 m, ≈ 0.2 at 2 m, ≈ 0.7 at 3 m, ≈ 0.97 at 4 m,
    // 1 beyond 5 m.
    assert_eq!(overlap(1.4), 0.0);
    assert!((overlap(2.0) - 0.2).abs() < 0.06, "O(2) = {}", overlap(2.0));
    assert!((overlap(3.0) - 0.7).abs() < 0.06, "O(3) = {}", overlap(3.0));
    assert!(
        (overlap(4.0) - 0.97).abs() < 0.03,
        "O(4) = {}",
        overlap(4.0)
    );
    assert!((overlap(6.0) - 1.0).abs() < 1e-9);
    // Fog: V = 50 m → 340 dB/km one-way (validation.md §9b); V = 200 m → 85 dB/km.
    let db_km = |v: f64| 10.0 * std::f64::consts::E.log10() * fog_extinction_per_m(v) * 1000.0;
    assert!((db_km(50.0) - 340.0).abs() < 1.0);
    assert!((db_km(200.0) - 85.0).abs() < 0.5);
    // FMCW coherence: at R = c/(4πΔν) the coherent fraction is 1/e (τ = 2R/c = τ_c/2, τ_c =
    // 1/(πΔν)); 300 kHz → R = 79.5 m; 0 Hz → 1.
    let r_e = 299_792_458.0 / (4.0 * std::f64::consts::PI * 300e3);
    assert!((r_e - 79.52).abs() < 0.01);
    assert!((coherent_fraction(r_e, 300e3) - (-1.0f64).exp()).abs() < 1e-12);
    assert_eq!(coherent_fraction(50.0, 0.0), 1.0);
}

/// The closed loop on an independent ground-multipath campaign with the physical radar model
/// (`osiris_models::build_sensor`, the FMU's code path): re-simulated with
/// `--disable radar.ground_multipath` the workflow names `radar.ground_multipath` and its action is
/// `--enable radar.ground_multipath`; re-simulated with it, the headline power RMS falls by ≥ 25 %.
/// `OSIRIS_LOOP_GT=σ,h` sets the ground truth's jitter σ and height error bound h, m.
#[test]
fn closed_loop_ground_multipath_with_the_physical_radar_model() {
    let tmp = tempfile::tempdir().unwrap();
    let root = work_dir(&tmp, "closed-loop-ground-multipath");
    let (sigma, height_error) = std::env::var("OSIRIS_LOOP_GT")
        .ok()
        .and_then(|s| {
            let v: Vec<f64> = s.split(',').filter_map(|x| x.parse().ok()).collect();
            (v.len() == 2).then(|| (v[0], v[1]))
        })
        // The issue's independent campaigns: 1 cm ground-truth jitter; heights off by ≤ 1 cm. With
        // 2 cm (1.6 rad of two-way phase per cm at 10 m) the lobing cannot be reproduced
        // station by station: the effect is still named, the error falls by ≈ 9 % only.
        .unwrap_or((0.01, 0.01));
    let w = independent_truth::radar_campaign_surveyed(
        RadarCase::GroundMultipath,
        seeds()[0],
        &root.join("campaign"),
        sigma,
        height_error,
    )
    .unwrap();
    let args = |out: &str, enable: &[&str], disable: &[&str]| ConsistencyArgs {
        enable: ids(enable),
        disable: ids(disable),
        history: Some(root.join("history")),
        ..args_for(&w, root.join(out))
    };
    let before = run_with(&args("without", &[], &["radar.ground_multipath"]), None).unwrap();
    let o = Outcome::from(&before);
    println!(
        "without: {} accepted {:?} power RMS {:.2} dB",
        before.status, o.accepted, before.error["power_db"]
    );
    assert!(o.names("radar.ground_multipath"), "{:?}", o.accepted);
    let action = action_for(&before, "radar.ground_multipath");
    let cmd = action.command.as_deref().unwrap();
    assert!(
        cmd.contains("--enable radar.ground_multipath")
            && !cmd.contains("--disable radar.ground_multipath"),
        "{cmd}"
    );
    let after = run_with(&args("with", &["radar.ground_multipath"], &[]), None).unwrap();
    let (b, a) = (before.error["power_db"], after.error["power_db"]);
    println!(
        "with: {} accepted {:?} power RMS {a:.2} dB (was {b:.2}; predicted {:.2})",
        after.status,
        after.accepted(),
        action.predicted_error["power_db"]
    );
    assert!(a <= 0.75 * b, "power RMS {b:.2} -> {a:.2} dB");
    assert!(
        !after
            .accepted()
            .contains(&"radar.ground_multipath".to_string())
    );
    assert_eq!(after.history.len(), 1, "the history shows the first run");
}

/// The closed loop on an independent yaw-misalignment campaign with the physical radar model
/// (issue 19): re-simulated with the nominal mounting (`--disable radar.extrinsic_error`), the
/// workflow names `radar.extrinsic_error` with the fitted yaw p0 (deg) and lateral offset p1 (m);
/// re-simulated with `"calibration": {"yaw_deg": p0, "y_m": p1}` and the effect on, the azimuth RMS
/// falls by ≥ 50 % and the effect is no longer accepted.
#[test]
fn closed_loop_yaw_misalignment_with_the_physical_radar_model() {
    let tmp = tempfile::tempdir().unwrap();
    let root = work_dir(&tmp, "closed-loop-yaw");
    let w = independent_truth::radar_campaign_surveyed(
        RadarCase::YawMisalignment,
        seeds()[0],
        &root.join("campaign"),
        0.01,
        0.01,
    )
    .unwrap();
    let (mx, mz) = independent_truth::radar_mounting();
    let model = |name: &str, calibration: &str| {
        write_model(
            &w,
            name,
            format!(
                r#"{{"kind": "radar", "mode": "physical", "range_m": 100, "update_cycle_s": 0.05,
                "fov_horizontal_rad": 1.5708, "fov_vertical_rad": 0.1745,
                "mounting": {{"position_m": [{mx}, 0.0, {mz}]}}{calibration}}}"#
            ),
        )
    };
    let args = |out: &str, model: std::path::PathBuf, enable: &[&str], disable: &[&str]| {
        model_args(&w, root.join(out), model, enable, disable)
    };
    let t0 = std::time::Instant::now();
    let before = run_with(
        &args(
            "without",
            model("nominal.json", ""),
            &[],
            &["radar.extrinsic_error"],
        ),
        None,
    )
    .unwrap();
    let o = Outcome::from(&before);
    println!(
        "without: {} accepted {:?} azimuth RMS {:.3}° ({:.1} s)",
        before.status,
        o.accepted,
        before.error["azimuth_deg"],
        t0.elapsed().as_secs_f64()
    );
    let fitted = attribution(&before, "azimuth_deg");
    assert!(
        fitted
            .accepted
            .contains(&"radar.extrinsic_error".to_string()),
        "{:?}",
        fitted.accepted
    );
    let e = fit(fitted, "radar.extrinsic_error");
    let (yaw, y) = (e.params[0].value, e.params[1].value);
    let hidden = w.hidden_value.expect("the hidden yaw, deg");
    println!("fitted yaw {yaw:.3}° (hidden {hidden:.3}°), lateral offset {y:.3} m (hidden 0)");
    assert!(
        (yaw - hidden).abs() <= 0.1,
        "fitted yaw {yaw:.3}°, hidden {hidden:.3}°"
    );
    assert!(y.abs() <= 0.05, "fitted lateral offset {y:.3} m, hidden 0");
    let action = action_for(&before, "radar.extrinsic_error");
    assert!(
        action
            .command
            .as_deref()
            .unwrap()
            .contains("--enable radar.extrinsic_error")
    );
    let calibrated = model(
        "calibrated.json",
        &format!(r#", "calibration": {{"yaw_deg": {yaw}, "y_m": {y}}}"#),
    );
    let after = run_with(
        &args("with", calibrated, &["radar.extrinsic_error"], &[]),
        None,
    )
    .unwrap();
    let (b, a) = (before.error["azimuth_deg"], after.error["azimuth_deg"]);
    println!(
        "with: {} accepted {:?} azimuth RMS {a:.3}° (was {b:.3}°) ({:.1} s)",
        after.status,
        after.accepted(),
        t0.elapsed().as_secs_f64()
    );
    assert!(a <= 0.5 * b, "azimuth RMS {b:.3} -> {a:.3} deg");
    assert!(
        !after
            .accepted()
            .contains(&"radar.extrinsic_error".to_string())
    );
}

/// The closed loop on an independent online-calibration campaign (seed 1501, issue 19) with the
/// physical radar model: the measuring radar is turned by the hidden yaw and calibrates itself
/// from the Doppler of the stationary trihedrals once the host drives; the re-simulation has the
/// surveyed yaw (`"calibration": {"yaw_deg": …}`). With the online calibration off the workflow
/// names `radar.mounting_misalignment` on the azimuth and fits the yaw within 0.15°; re-simulated
/// with `--enable radar.mounting_misalignment` (the model's own estimator, physics.md §7.3) the
/// azimuth RMS falls by ≥ 50 % and the effect is no longer accepted.
#[test]
fn closed_loop_online_calibration_with_the_physical_radar_model() {
    let tmp = tempfile::tempdir().unwrap();
    let root = work_dir(&tmp, "closed-loop-online-calibration");
    let w = independent_truth::radar_calibration_campaign(
        CalibrationCase::SelfCalibrating,
        seeds()[0],
        &root.join("campaign"),
    )
    .unwrap();
    let hidden = w.hidden_value.expect("the hidden yaw, deg");
    let (mx, mz) = independent_truth::radar_mounting();
    let model = write_model(
        &w,
        "surveyed.json",
        format!(
            r#"{{"kind": "radar", "mode": "physical", "range_m": 100, "update_cycle_s": 0.05,
            "fov_horizontal_rad": 1.5708, "fov_vertical_rad": 0.1745,
            "mounting": {{"position_m": [{mx}, 0.0, {mz}]}},
            "calibration": {{"yaw_deg": {hidden}}}}}"#
        ),
    );
    let id = "radar.mounting_misalignment";
    let az = |s| attribution(s, "azimuth_deg");
    let t0 = std::time::Instant::now();
    // The campaign's ground is absorber mats: no road clutter in the model either (its stationary
    // clutter detections would feed the model's calibration too).
    let clutter = "radar.road_clutter";
    let before = run_with(
        &model_args(&w, root.join("without"), model.clone(), &[], &[id, clutter]),
        None,
    )
    .unwrap();
    let fitted = az(&before);
    println!(
        "without: {} accepted on azimuth {:?}, azimuth RMS {:.3}° ({:.1} s)",
        before.status,
        fitted.accepted,
        before.error["azimuth_deg"],
        t0.elapsed().as_secs_f64()
    );
    assert!(
        fitted.accepted.contains(&id.to_string()),
        "{:?}",
        fitted.accepted
    );
    let e = fit(fitted, id);
    let (yaw, w0) = (e.params[0].value, e.params[1].value);
    println!("fitted yaw {yaw:.3}° (hidden {hidden:.3}°), prior weight {w0:.1} (m/s)²/rad²");
    assert!(
        (yaw - hidden).abs() <= 0.15,
        "fitted yaw {yaw:.3}°, hidden {hidden:.3}°"
    );
    let action = action_for(&before, id);
    let cmd = action.command.as_deref().unwrap();
    assert!(cmd.contains(&format!("--enable {id}")), "{cmd}");
    let after = run_with(
        &model_args(&w, root.join("with"), model, &[id], &[clutter]),
        None,
    )
    .unwrap();
    let (b, a) = (before.error["azimuth_deg"], after.error["azimuth_deg"]);
    println!(
        "with: {} accepted on azimuth {:?}, azimuth RMS {a:.3}° (was {b:.3}°; predicted {:.3}°) ({:.1} s)",
        after.status,
        az(&after).accepted,
        action.predicted_error["azimuth_deg"],
        t0.elapsed().as_secs_f64()
    );
    let left = az(&after)
        .effects
        .iter()
        .find(|e| e.id == id)
        .map(|e| (e.params[0].value, e.accepted));
    println!("left over: {left:?} (yaw the model's calibration missed, deg; accepted)");
    assert!(a <= 0.5 * b, "azimuth RMS {b:.3} -> {a:.3} deg");
    assert!(!az(&after).accepted.contains(&id.to_string()));
}

/// The closed loop on an independent clock-offset campaign (seed 1501, 1 cm survey jitter: the
/// measuring radar stamps its detections Δt = 40–80 ms off the ground truth's clock while targets
/// approach, recede and cross) with the physical radar model: re-simulated with the nominal clock
/// the workflow names `radar.time_offset` on the range (ΔR = ṙ·Δt) and fits Δt; re-simulated with
/// `"calibration": {"time_offset_s": Δt}` the range RMS falls by ≥ 50 % and the effect is no
/// longer accepted on the range.
#[test]
fn closed_loop_time_offset_with_the_physical_radar_model() {
    let tmp = tempfile::tempdir().unwrap();
    let root = work_dir(&tmp, "closed-loop-time-offset");
    let w = independent_truth::radar_campaign_surveyed(
        RadarCase::TimeOffset,
        seeds()[0],
        &root.join("campaign"),
        0.01,
        0.01,
    )
    .unwrap();
    let hidden_ms = w.hidden_value.expect("the hidden clock offset, ms");
    let (mx, mz) = independent_truth::radar_mounting();
    let model = |name: &str, calibration: &str| {
        write_model(
            &w,
            name,
            format!(
                r#"{{"kind": "radar", "mode": "physical", "range_m": 120, "update_cycle_s": 0.05,
                "fov_horizontal_rad": 1.5708, "fov_vertical_rad": 0.1745,
                "mounting": {{"position_m": [{mx}, 0.0, {mz}]}}{calibration}}}"#
            ),
        )
    };
    let args = |out: &str, model: std::path::PathBuf, enable: &[&str], disable: &[&str]| {
        model_args(&w, root.join(out), model, enable, disable)
    };
    let t0 = std::time::Instant::now();
    let before = run_with(
        &args(
            "without",
            model("nominal.json", ""),
            &[],
            &["radar.time_offset"],
        ),
        None,
    )
    .unwrap();
    let range_rows = |s| attribution(s, "range_m");
    let fitted = range_rows(&before);
    println!(
        "without: {} accepted on range {:?}, range RMS {:.3} m ({:.1} s)",
        before.status,
        fitted.accepted,
        before.error["range_m"],
        t0.elapsed().as_secs_f64()
    );
    assert!(
        fitted.accepted.contains(&"radar.time_offset".to_string()),
        "{:?}",
        fitted.accepted
    );
    let dt_ms = fit(fitted, "radar.time_offset").params[0].value;
    println!("fitted clock offset {dt_ms:.1} ms (hidden {hidden_ms:.1} ms)");
    assert!(
        (dt_ms - hidden_ms).abs() <= 0.25 * hidden_ms.abs(),
        "fitted {dt_ms:.1} ms, hidden {hidden_ms:.1} ms"
    );
    let calibrated = model(
        "calibrated.json",
        &format!(r#", "calibration": {{"time_offset_s": {}}}"#, dt_ms / 1e3),
    );
    let after = run_with(&args("with", calibrated, &["radar.time_offset"], &[]), None).unwrap();
    let (b, a) = (before.error["range_m"], after.error["range_m"]);
    println!(
        "with: {} accepted on range {:?}, range RMS {a:.3} m (was {b:.3} m) ({:.1} s)",
        after.status,
        range_rows(&after).accepted,
        t0.elapsed().as_secs_f64()
    );
    assert!(a <= 0.5 * b, "range RMS {b:.3} -> {a:.3} m");
    assert!(
        !range_rows(&after)
            .accepted
            .contains(&"radar.time_offset".to_string())
    );
}

/// The closed loop on an independent camera yaw-misalignment campaign (seed 1501) with the
/// physical camera model (320 × 240, 60°; its recognition reports the image boxes of the rendered
/// cars; rolling shutter and motion blur off, as the generator's camera has a global shutter): re-
/// simulated with the nominal mounting the workflow names `camera.extrinsic_error` on the azimuth
/// and fits the yaw within 0.1°; re-simulated with `"calibration": {"yaw_deg": …}` the azimuth RMS
/// falls by ≥ 50 % and the effect is no longer accepted. (With the rolling shutter on, the crossing
/// cars' row-time skew is named as `camera.time_offset` beside the yaw: the generator has none.)
#[test]
fn closed_loop_camera_yaw_misalignment_with_the_physical_camera_model() {
    let tmp = tempfile::tempdir().unwrap();
    let root = work_dir(&tmp, "closed-loop-camera-yaw");
    let w = independent_truth::camera_campaign(
        CameraCase::YawMisalignment,
        seeds()[0],
        &root.join("campaign"),
    )
    .unwrap();
    let hidden = w.hidden_value.expect("the hidden yaw, deg");
    let model = |name: &str, calibration: &str| {
        physical_camera_model(&w, name, (320, 240), "", calibration)
    };
    let args = |out: &str, model: std::path::PathBuf, enable: &[&str], disable: &[&str]| {
        model_args(&w, root.join(out), model, enable, disable)
    };
    let t0 = std::time::Instant::now();
    let before = run_with(&args("without", model("nominal.json", ""), &[], &[]), None).unwrap();
    let az = |s| attribution(s, "azimuth_deg");
    let fitted = az(&before);
    println!(
        "without: {} accepted on azimuth {:?}, azimuth RMS {:.3}°, pairing {:?} ({:.1} s)",
        before.status,
        fitted.accepted,
        before.error["azimuth_deg"],
        before.pairing,
        t0.elapsed().as_secs_f64()
    );
    assert!(
        fitted
            .accepted
            .contains(&"camera.extrinsic_error".to_string()),
        "{:?}",
        fitted.accepted
    );
    let yaw = fit(fitted, "camera.extrinsic_error").params[0].value;
    println!("fitted yaw {yaw:.3}° (hidden {hidden:.3}°)");
    assert!(
        (yaw - hidden).abs() <= 0.1,
        "fitted yaw {yaw:.3}°, hidden {hidden:.3}°"
    );
    let calibrated = model(
        "calibrated.json",
        &format!(r#", "calibration": {{"yaw_deg": {yaw}}}"#),
    );
    let after = run_with(&args("with", calibrated, &[], &[]), None).unwrap();
    let (b, a) = (before.error["azimuth_deg"], after.error["azimuth_deg"]);
    println!(
        "with: {} accepted on azimuth {:?}, azimuth RMS {a:.3}° (was {b:.3}°) ({:.1} s)",
        after.status,
        az(&after).accepted,
        t0.elapsed().as_secs_f64()
    );
    assert!(a <= 0.5 * b, "azimuth RMS {b:.3} -> {a:.3} deg");
    assert!(
        !az(&after)
            .accepted
            .contains(&"camera.extrinsic_error".to_string())
    );
}

/// The closed loop on an independent windshield campaign (seed 1501) with the physical camera
/// model (as in the yaw loop above): re-simulated without a windshield the workflow names
/// `camera.windshield_refraction` on the elevation with the wedge of the generator's glass; re-
/// simulated with the default windshield carrying the fitted `wedge_mrad`, the elevation RMS falls
/// by at least 40 % and the effect is no longer accepted.
#[test]
fn closed_loop_camera_windshield_with_the_physical_camera_model() {
    let tmp = tempfile::tempdir().unwrap();
    let root = work_dir(&tmp, "closed-loop-camera-windshield");
    let w = independent_truth::camera_campaign(
        CameraCase::Windshield,
        seeds()[0],
        &root.join("campaign"),
    )
    .unwrap();
    let hidden = w.hidden_value.expect("the hidden wedge, mrad");
    let model =
        |name: &str, windshield: &str| physical_camera_model(&w, name, (640, 480), windshield, "");
    let args =
        |out: &str, model: std::path::PathBuf| model_args(&w, root.join(out), model, &[], &[]);
    let t0 = std::time::Instant::now();
    let before = run_with(&args("without", model("nominal.json", "")), None).unwrap();
    let el = |s| attribution(s, "elevation_deg");
    let fitted = el(&before);
    println!(
        "without: {} accepted on elevation {:?}, elevation RMS {:.3}°, pairing {:?} ({:.1} s)",
        before.status,
        fitted.accepted,
        before.error["elevation_deg"],
        before.pairing,
        t0.elapsed().as_secs_f64()
    );
    assert!(
        fitted
            .accepted
            .contains(&"camera.windshield_refraction".to_string()),
        "{:?}",
        fitted.accepted
    );
    let wedge = fit(fitted, "camera.windshield_refraction").params[0].value;
    println!("fitted wedge {wedge:.3} mrad (hidden {hidden:.3} mrad)");
    assert!(
        (wedge - hidden).abs() <= 0.3 * hidden,
        "fitted wedge {wedge:.3} mrad, hidden {hidden:.3} mrad"
    );
    let glazed = model(
        "glazed.json",
        &format!(r#", "windshield": {{"wedge_mrad": {wedge}}}"#),
    );
    let after = run_with(&args("with", glazed), None).unwrap();
    let (b, a) = (before.error["elevation_deg"], after.error["elevation_deg"]);
    println!(
        "with: {} accepted on elevation {:?}, elevation RMS {a:.3}° (was {b:.3}°) ({:.1} s)",
        after.status,
        el(&after).accepted,
        t0.elapsed().as_secs_f64()
    );
    assert!(a <= 0.6 * b, "elevation RMS {b:.3} -> {a:.3} deg");
    assert!(
        !el(&after)
            .accepted
            .contains(&"camera.windshield_refraction".to_string())
    );
}

/// The closed loop on an independent FMCW speckle campaign with the physical LiDAR model's FMCW
/// chain (`sensor.lidar_preset = "fmcw"`, `osiris_models::build_sensor`): re-simulated with
/// `--disable lidar.fmcw_speckle` the workflow names `lidar.fmcw_speckle` from the intensity
/// spread (p0 ≈ 5.57 dB, one look) and its action is `--enable lidar.fmcw_speckle`; re-simulated
/// with it, the RMS of the intensity-spread residual falls by ≥ 40 % and the spread still missing
/// shrinks. The other FMCW effects stay off on both runs (the generator's truth has none).
#[test]
fn closed_loop_fmcw_speckle_with_the_physical_lidar_model() {
    let tmp = tempfile::tempdir().unwrap();
    let root = work_dir(&tmp, "closed-loop-fmcw-speckle");
    let w = independent_truth::fmcw_lidar_campaign(
        FmcwCase::Speckle,
        seeds()[0],
        &root.join("campaign"),
    )
    .unwrap();
    let others = ["lidar.fmcw_phase_noise", "lidar.fmcw_chirp_nonlinearity"];
    // The FMCW preset with its firings cut to the boards' ±20° (the boards stand within ±17°) and
    // 60 m: a full 360° scan costs ≈ 3 s per frame in the dev profile.
    let (mx, mz) = independent_truth::lidar_mounting();
    let model = root.join("campaign").join("model.json");
    std::fs::write(
        &model,
        format!(
            r#"{{"kind": "lidar", "mode": "physical", "range_m": 60, "update_cycle_s": 0.1, "fov_horizontal_rad": 0.7,
                "fov_vertical_rad": 0.7, "mounting": {{"position_m": [{mx}, 0.0, {mz}]}},
                "lidar": {{"preset": "fmcw"}}}}"#
        ),
    )
    .unwrap();
    let args = |out: &str, enable: &[&str], disable: &[&str]| ConsistencyArgs {
        model: Some(model.clone()),
        enable: ids(enable),
        disable: ids(&[disable, &others[..]].concat()),
        ..args_for(&w, root.join(out))
    };
    let spread_rms = |s: &Summary| s.residual_stats["intensity_sd_db"].rms;
    let t0 = std::time::Instant::now();
    let before = run_with(&args("without", &[], &["lidar.fmcw_speckle"]), None).unwrap();
    let o = Outcome::from(&before);
    println!(
        "without: {} accepted {:?} intensity-spread RMS {:.2} dB ({:.1} s)",
        before.status,
        o.accepted,
        spread_rms(&before),
        t0.elapsed().as_secs_f64()
    );
    // The speckle is named on the intensity spread. (The points on target are not compared here:
    // the generator's scan, 0.2° rings × 0.4° columns, is not the model's VLS-128 layout, so
    // `lidar.dropped_rays` may take up the count ratio.)
    let spread = attribution(&before, "intensity_sd_db");
    assert_eq!(spread.accepted, ["lidar.fmcw_speckle"], "{:?}", o.accepted);
    let action = action_for(&before, "lidar.fmcw_speckle");
    let cmd = action.command.as_deref().unwrap();
    assert!(cmd.contains("--enable lidar.fmcw_speckle"), "{cmd}");
    let after = run_with(&args("with", &["lidar.fmcw_speckle"], &[]), None).unwrap();
    let (b, a) = (spread_rms(&before), spread_rms(&after));
    println!(
        "with: {} accepted {:?} intensity-spread RMS {a:.2} dB (was {b:.2}) ({:.1} s)",
        after.status,
        after.accepted(),
        t0.elapsed().as_secs_f64()
    );
    assert!(a <= 0.6 * b, "intensity-spread RMS {b:.2} -> {a:.2} dB");
    // The spread the model still misses, as the speckle entry's p0 (dB; one look = 5.57 dB): the
    // model's speckle averages independent draws per point (sub-rays, ramps), so a smaller excess
    // may remain, never a larger one.
    let p0 = |s: &Summary| {
        s.attribution
            .iter()
            .find(|q| q.quantity == "intensity_sd_db")
            .and_then(|q| q.effects.iter().find(|e| e.id == "lidar.fmcw_speckle"))
            .map(|e| e.params[0].value)
            .unwrap_or(f64::NAN)
    };
    let (p_b, p_a) = (p0(&before), p0(&after));
    println!("speckle p0 {p_b:.2} dB without, {p_a:.2} dB with the model's speckle");
    assert!((4.5..6.5).contains(&p_b), "p0 without = {p_b:.2} dB");
    assert!(p_a < p_b, "p0 {p_b:.2} -> {p_a:.2} dB");
}
