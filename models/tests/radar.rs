//! Closed-form tests of the physical radar's propagation (`osiris_models::radar`): radar equation
//! laws, canonical RCS (physics.md §1.2), P.838 rain, two-ray ground lobing (physics.md §1.3),
//! Doppler, and the end-to-end detections of a corner reflector.

mod common;
use common::{coherent_power_w, db, moving_object, v3};

/// A moving object with `reference` and id [`TARGET`] at `pos`, yaw, box `dim`, velocity.
fn target(
    reference: &str,
    pos: [f64; 3],
    yaw: f64,
    dim: [f64; 3],
    vel: [f64; 3],
) -> osi3::MovingObject {
    moving_object(reference, TARGET, pos, yaw, dim, vel)
}

use std::f64::consts::PI;

use num_complex::Complex64;
use osiris_models::environment::material::MaterialDb;
use osiris_models::environment::weather::Weather;
use osiris_models::radar::{PathReturn, RadarConfig, RadarSensor};
use osiris_models::sensor::{ModelMode, Mounting};
use osiris_models::{SensorConfig, SensorKind, SensorModel, StepInput, StepOutput};
use osiris_proto::{id, osi3};

const C0: f64 = 299_792_458.0;
const TARGET: u64 = 7;

/// Trihedral of edge `a` at range `r`, azimuth `az`, height `h`, facing the sensor at the origin.
fn trihedral(a: f64, r: f64, az: f64, h: f64, vel: [f64; 3]) -> osi3::MovingObject {
    target(
        &format!("osiris:trihedral?edge_m={a}"),
        [r * az.cos(), r * az.sin(), h],
        az + PI,
        [a * 0.9, a * 1.5, a * 1.5],
        vel,
    )
}

use common::view_of as view;

/// Sensor at height `h` looking along +x; `effects` switched as given. Road clutter is off (these
/// tests look at the paths of their targets; it has its own tests in `radar_clutter.rs`).
fn config(h: f64, effects: &[(&str, bool)]) -> SensorConfig {
    let mut c = SensorConfig::default_for(SensorKind::Radar);
    c.effects.insert("radar.road_clutter".into(), false);
    c.mode = ModelMode::Physical;
    c.mounting = Mounting {
        position_m: [0.0, 0.0, h],
        orientation_rad: [0.0; 3],
    };
    c.fov_horizontal_rad = 120f64.to_radians();
    c.fov_vertical_rad = 30f64.to_radians();
    c.seed = Some(1);
    for (k, v) in effects {
        c.effects.insert((*k).to_string(), *v);
    }
    c
}

/// Free space, isotropic-shaped antennas (peak gain everywhere), no gases.
const FREE: &[(&str, bool)] = &[
    ("radar.ground_multipath", false),
    ("radar.antenna_pattern", false),
    ("radar.atmospheric_absorption", false),
];

fn paths(cfg: SensorConfig, objects: Vec<osi3::MovingObject>) -> Vec<PathReturn> {
    paths_with(cfg, view(objects))
}

fn paths_with(cfg: SensorConfig, v: osi3::SensorView) -> Vec<PathReturn> {
    let mut s = RadarSensor::new(cfg).expect("radar");
    s.propagate(&StepInput {
        view: &v,
        time_s: 0.0,
        step_s: 0.05,
    })
    .expect("propagate")
    .to_vec()
}

/// Radar equation inverted: σ = P_r (4π)³ R⁴ L / (P_t G_t G_r λ²) with the default front end.
fn rcs_from_power(p_w: f64, r: f64, lambda: f64) -> f64 {
    let cfg = RadarConfig::default();
    let fe = &cfg.front_end;
    let pt = 1e-3 * 10f64.powf(fe.tx_power_dbm / 10.0);
    let g = 10f64.powf((fe.tx_pattern.peak_gain_dbi() + fe.rx_pattern.peak_gain_dbi()) / 10.0);
    let l = 10f64.powf(fe.system_losses_db / 10.0);
    p_w * (4.0 * PI).powi(3) * r.powi(4) * l / (pt * g * lambda * lambda)
}

fn lambda() -> f64 {
    C0 / RadarConfig::default().waveform.carrier_frequency_hz
}

#[test]
fn trihedral_rcs_matches_closed_form() {
    // Knott: σ = 4π a⁴ / (3 λ²) for a triangular trihedral at boresight (physics.md §1.2).
    let lam = lambda();
    for (a, r) in [(0.1, 10.0), (0.1, 20.0)] {
        let p = paths(config(1.0, FREE), vec![trihedral(a, r, 0.0, 1.0, [0.0; 3])]);
        assert!(!p.is_empty());
        assert!(p.iter().all(|q| q.object_id == TARGET));
        let sigma = rcs_from_power(coherent_power_w(&p, lam), r, lam);
        let expected = 4.0 * PI * a.powi(4) / (3.0 * lam * lam);
        let err = db(sigma) - db(expected);
        assert!(
            err.abs() < 1.5,
            "a = {a} at {r} m: {:.2} dBsm vs {:.2}",
            db(sigma),
            db(expected)
        );
        // The strongest path lies at the reflector (its phase centre is inside the aperture).
        let best = p
            .iter()
            .max_by(|x, y| x.amplitude.norm().total_cmp(&y.amplitude.norm()))
            .unwrap();
        assert!((best.range_m - r).abs() < 0.15, "range {}", best.range_m);
        assert!(best.rx_azimuth_rad.abs() < 0.5f64.to_radians());
    }
}

#[test]
fn power_falls_40_db_per_decade_of_range() {
    let lam = lambda();
    let p = |r: f64| {
        coherent_power_w(
            &paths(
                config(1.0, FREE),
                vec![trihedral(0.1, r, 0.0, 1.0, [0.0; 3])],
            ),
            lam,
        )
    };
    let (p5, p50) = (p(5.0), p(50.0));
    let slope = db(p50) - db(p5);
    assert!((slope + 40.0).abs() < 1.5, "slope {slope:.2} dB/decade");
    // Spreading off: the range law disappears (only the near-field aperture phase remains).
    let mut fx = FREE.to_vec();
    fx.push(("radar.two_way_spreading", false));
    let q = |r: f64| {
        coherent_power_w(
            &paths(
                config(1.0, &fx),
                vec![trihedral(0.1, r, 0.0, 1.0, [0.0; 3])],
            ),
            lam,
        )
    };
    let flat = db(q(50.0)) - db(q(5.0));
    assert!(flat.abs() < 1.5, "with spreading off: {flat:.2} dB");
}

#[test]
fn power_grows_40_db_per_decade_of_trihedral_edge() {
    // σ ∝ a⁴ (area²): +12.04 dB per doubling of the edge. Far field 2D²/λ < 30 m for a ≤ 0.2 m.
    let lam = lambda();
    let r = 40.0;
    let p = |a: f64, fx: &[(&str, bool)]| {
        coherent_power_w(
            &paths(config(1.0, fx), vec![trihedral(a, r, 0.0, 1.0, [0.0; 3])]),
            lam,
        )
    };
    let d1 = db(p(0.1, FREE)) - db(p(0.05, FREE));
    let d2 = db(p(0.2, FREE)) - db(p(0.1, FREE));
    let per_doubling = 40.0 * 2f64.log10();
    assert!((d1 - per_doubling).abs() < 1.5, "0.05 → 0.1: {d1:.2} dB");
    assert!((d2 - per_doubling).abs() < 1.5, "0.1 → 0.2: {d2:.2} dB");
    // Area scaling off: every object is a point scatterer of the same RCS.
    let mut fx = FREE.to_vec();
    fx.push(("radar.rcs_area_scaling", false));
    let d = db(p(0.2, &fx)) - db(p(0.05, &fx));
    assert!(d.abs() < 0.5, "area scaling off: {d:.2} dB");
}

#[test]
fn metal_plate_rcs_is_area_squared() {
    // σ = 4π A² / λ² at normal incidence (physics.md §1.2): 10×10 cm at 77 GHz ≈ 19 dBsm.
    let lam = lambda();
    let r = 15.0;
    let mut sig = Vec::new();
    for w in [0.1, 0.2] {
        let board = target(
            &format!(
                "osiris:board?width_m={w}&height_m={w}&thickness_m=0.005&material=aluminium&mount=none"
            ),
            [r, 0.0, 1.0],
            PI,
            [0.005, w, w],
            [0.0; 3],
        );
        let p = paths(config(1.0, FREE), vec![board]);
        let sigma = rcs_from_power(coherent_power_w(&p, lam), r, lam);
        let expected = 4.0 * PI * (w * w).powi(2) / (lam * lam);
        assert!(
            (db(sigma) - db(expected)).abs() < 1.5,
            "{w} m plate: {:.2} vs {:.2} dBsm",
            db(sigma),
            db(expected)
        );
        sig.push(sigma);
    }
    assert!((db(sig[1] / sig[0]) - 40.0 * 2f64.log10()).abs() < 1.0);
}

#[test]
fn rain_attenuation_matches_p838_over_100_m() {
    // P.838-3 at 76.5 GHz, horizontal (physics.md §1.4): k = 1.1253, α = 0.7188.
    let lam = lambda();
    let rain = 25.0;
    let gamma_db_km = 1.1253 * f64::powf(rain, 0.7188);
    let r = 100.0;
    let p = |wet: bool| {
        let mut c = config(1.0, FREE);
        let mut w = Weather::CLEAR;
        if wet {
            w.rain_mm_h = rain;
        }
        c.weather = Some(w);
        coherent_power_w(&paths(c, vec![trihedral(0.1, r, 0.0, 1.0, [0.0; 3])]), lam)
    };
    let loss = db(p(false)) - db(p(true));
    let expected = 2.0 * gamma_db_km * r / 1000.0;
    assert!(
        (loss - expected).abs() < 0.05,
        "loss {loss:.3} dB vs {expected:.3} dB"
    );
    // Switched off: no loss.
    let mut c = config(1.0, FREE);
    c.effects.insert("radar.rain_attenuation".into(), false);
    let mut w = Weather::CLEAR;
    w.rain_mm_h = rain;
    c.weather = Some(w);
    let off = coherent_power_w(&paths(c, vec![trihedral(0.1, r, 0.0, 1.0, [0.0; 3])]), lam);
    assert!((db(p(false)) - db(off)).abs() < 0.01);
}

#[test]
fn radial_velocity_of_a_moving_reflector() {
    // Receding at 10 m/s straight ahead: range rate +10 m/s (within 0.3 km/h).
    let v = 10.0;
    let p = paths(
        config(1.0, FREE),
        vec![trihedral(0.1, 20.0, 0.0, 1.0, [v, 0.0, 0.0])],
    );
    let best = p
        .iter()
        .max_by(|x, y| x.amplitude.norm().total_cmp(&y.amplitude.norm()))
        .unwrap();
    assert!(
        (best.range_rate_m_s - v).abs() < 0.3 / 3.6,
        "{}",
        best.range_rate_m_s
    );
    // At 30° azimuth moving along x: range rate = v cos 30°.
    let az = 30f64.to_radians();
    let p = paths(
        config(1.0, FREE),
        vec![trihedral(0.1, 20.0, az, 1.0, [-v, 0.0, 0.0])],
    );
    let best = p
        .iter()
        .max_by(|x, y| x.amplitude.norm().total_cmp(&y.amplitude.norm()))
        .unwrap();
    assert!(
        (best.range_rate_m_s + v * az.cos()).abs() < 0.3 / 3.6,
        "{}",
        best.range_rate_m_s
    );
    assert!((best.rx_azimuth_rad - az).abs() < 1f64.to_radians());
}

#[test]
fn ground_two_ray_lobing_follows_the_two_path_formula() {
    // Point-like target (trihedral) over the fallback road plane (asphalt_dry), radar at 0.5 m.
    // With/without the effect the power ratio is |F|⁴, F = 1 + Γ(ψ)(R_d/R_g)e^{−jkΔR}
    // (physics.md §1.3), Γ_H from the road permittivity by the Fresnel formula.
    let lam = lambda();
    let k = 2.0 * PI / lam;
    let f = C0 / lam;
    let db_mat = MaterialDb::builtin();
    let eps = db_mat
        .by_name("asphalt_dry")
        .unwrap()
        .eps_r_mmwave(f)
        .expect("asphalt permittivity");
    let gamma_h = |psi: f64| {
        let s = Complex64::new(psi.sin(), 0.0);
        let w = (eps - psi.cos().powi(2)).sqrt();
        (s - w) / (s + w)
    };
    // Area scaling off: the reflector is one point scatterer (one scattering centre).
    let base: Vec<(&str, bool)> = vec![
        ("radar.rcs_area_scaling", false),
        ("radar.antenna_pattern", false),
        ("radar.atmospheric_absorption", false),
        ("space.mmwave_roughness", false),
    ];
    let mut off = base.clone();
    off.push(("radar.ground_multipath", false));
    let hs = 0.5;
    let mut checked = 0;
    let mut max_err: f64 = 0.0;
    let mut min_ratio = f64::INFINITY;
    for i in 0..40 {
        let r = 10.0 + 0.25 * f64::from(i);
        let obj = || vec![trihedral(0.1, r, 0.0, hs, [0.0; 3])];
        let with = paths(config(hs, &base), obj());
        let without = paths(config(hs, &off), obj());
        assert!(with.len() > without.len(), "image paths added at {r} m");
        let ratio = coherent_power_w(&with, lam) / coherent_power_w(&without, lam);
        // Geometry of the reflector's phase centre, its apex: (a − t)/(2√3) behind and
        // (a − t)/(2√6) below the box centre (plate thickness t = 2 mm; models/ASSETS.md).
        let (a, t) = (0.1, 0.002);
        let d = r + (a - t) / (2.0 * 3f64.sqrt());
        let ht = hs - (a - t) / (2.0 * 6f64.sqrt());
        let r_d = (d * d + (ht - hs).powi(2)).sqrt();
        let r_g = (d * d + (ht + hs).powi(2)).sqrt();
        let psi = ((ht + hs) / r_g).asin();
        let big_f = Complex64::new(1.0, 0.0)
            + gamma_h(psi) * (r_d / r_g) * Complex64::from_polar(1.0, -k * (r_g - r_d));
        let expected = big_f.norm_sqr().powi(2);
        min_ratio = min_ratio.min(ratio);
        if expected > 0.1 {
            let e = db(ratio) - db(expected);
            max_err = max_err.max(e.abs());
            checked += 1;
        }
    }
    assert!(checked > 20);
    assert!(max_err < 0.5, "max |error| {max_err:.2} dB");
    // Lobing: deep nulls and up to +12 dB peaks.
    assert!(min_ratio < 0.1, "deepest null {:.1} dB", db(min_ratio));
}

#[test]
fn antenna_pattern_weights_off_boresight_targets() {
    // Default Gaussian beams, 60° azimuth beamwidth: G(θ) = G₀ − 12.04 (θ/60°)² dB each way, so a
    // reflector at 20° is 2 × 1.34 dB weaker than with the pattern off.
    let lam = lambda();
    let az = 20f64.to_radians();
    let p = |pattern: bool| {
        let fx = [
            ("radar.ground_multipath", false),
            ("radar.antenna_pattern", pattern),
            ("radar.atmospheric_absorption", false),
        ];
        coherent_power_w(
            &paths(
                config(1.0, &fx),
                vec![trihedral(0.1, 15.0, az, 1.0, [0.0; 3])],
            ),
            lam,
        )
    };
    let drop = db(p(false)) - db(p(true));
    let expected = 2.0 * 40.0 * 2f64.ln() / 10f64.ln() * (20.0f64 / 60.0).powi(2);
    assert!(
        (drop - expected).abs() < 0.1,
        "drop {drop:.3} dB vs {expected:.3} dB"
    );
}

#[test]
fn wheels_spread_the_doppler_of_a_car() {
    // A car receding at 10 m/s, 15 m ahead: rigid body → every path has range rate ≈ 10 m/s; with
    // spinning wheels (ω = v/r) the wheel points move between 0 (contact) and 2v (top).
    let v = 10.0;
    let car = || {
        vec![target(
            "osiris:car",
            [15.0, 0.0, 0.75],
            0.0,
            [4.5, 1.8, 1.5],
            [v, 0.0, 0.0],
        )]
    };
    let spread = |on: bool| {
        let fx = [
            ("radar.micro_doppler", on),
            ("radar.ground_multipath", false),
        ];
        let p = paths(config(0.5, &fx), car());
        let rates: Vec<f64> = p.iter().map(|q| q.range_rate_m_s).collect();
        assert!(!rates.is_empty());
        let lo = rates.iter().copied().fold(f64::INFINITY, f64::min);
        let hi = rates.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        (lo, hi)
    };
    let (lo, hi) = spread(false);
    // Rigid: v·cos(angle off the line of sight) ≥ v·cos(5°).
    assert!(lo > 0.99 * v && hi < v + 1e-6, "rigid: {lo} … {hi}");
    let (lo, hi) = spread(true);
    assert!(
        hi - lo > 0.5 && lo >= -0.05 && hi <= 2.0 * v + 0.05,
        "wheels: {lo} … {hi}"
    );
}

#[test]
fn dihedral_of_two_objects_needs_multipath() {
    // Two square aluminium plates (w × w, different objects) forming a vertical 90° corner that opens
    // towards the radar: the double bounce A → B gives σ = 8π w⁴/λ² (Knott; physics.md §1.2:
    // 10 × 10 cm → 22.2 dBsm). With `radar.multipath` off the tubes stop when they leave the first
    // plate, and only the weak single-bounce returns of the 45°-tilted plates remain.
    let lam = lambda();
    let (w, t, r, h) = (0.1, 0.004, 20.0, 1.0);
    let corner = [r, 0.0, h];
    let plate = |oid: u64, dir: [f64; 2], normal: [f64; 2]| {
        let s2 = std::f64::consts::FRAC_1_SQRT_2;
        let (dx, dy) = (dir[0] * s2, dir[1] * s2);
        let (nx, ny) = (normal[0] * s2, normal[1] * s2);
        let mut o = target(
            &format!(
                "osiris:board?width_m={w}&height_m={w}&thickness_m={t}&material=aluminium&mount=none"
            ),
            [
                corner[0] + dx * w / 2.0 - nx * t / 2.0,
                corner[1] + dy * w / 2.0 - ny * t / 2.0,
                h,
            ],
            ny.atan2(nx),
            [t, w, w],
            [0.0; 3],
        );
        o.id = Some(id(oid));
        o
    };
    let objects = || {
        vec![
            plate(11, [-1.0, 1.0], [-1.0, -1.0]),
            plate(12, [-1.0, -1.0], [-1.0, 1.0]),
        ]
    };
    let sigma = |multipath: bool| {
        let mut fx = FREE.to_vec();
        fx.push(("radar.multipath", multipath));
        rcs_from_power(
            coherent_power_w(&paths(config(h, &fx), objects()), lam),
            r,
            lam,
        )
    };
    let expected = 8.0 * PI * w.powi(4) / (lam * lam);
    let on = sigma(true);
    assert!(
        (db(on) - db(expected)).abs() < 1.5,
        "dihedral {:.2} dBsm vs {:.2}",
        db(on),
        db(expected)
    );
    let off = sigma(false);
    assert!(
        db(on) - db(off) > 10.0,
        "multipath off: {:.2} dBsm",
        db(off)
    );
}

#[test]
fn propagation_is_deterministic() {
    let objects = || {
        vec![
            target(
                "osiris:car",
                [12.0, 1.0, 0.75],
                0.3,
                [4.5, 1.8, 1.5],
                [3.0, 1.0, 0.0],
            ),
            trihedral(0.1, 20.0, -0.2, 0.5, [0.0; 3]),
        ]
    };
    let a = paths(config(0.5, &[]), objects());
    let b = paths(config(0.5, &[]), objects());
    assert!(a.len() > 10);
    assert_eq!(a, b);
}

#[test]
fn reflector_behind_glass_loses_the_two_way_slab_transmission() {
    // A single glass sheet (open board, no thickness in the mesh: the materials database gives the
    // slab) 4 m in front of a reflector at 15 m. At normal incidence the slab (ε, thickness d)
    // transmits T = (1 − Γ²)e^{−jδ} / (1 − Γ² e^{−2jδ}), Γ = (1 − √ε)/(1 + √ε), δ = k√ε d
    // (Orfanidis, Electromagnetic Waves and Antennas, ch. 5); the reflector's return falls by |T|⁴.
    let lam = lambda();
    let f = C0 / lam;
    let db_mat = MaterialDb::builtin();
    let glass = db_mat.by_name("glass").unwrap();
    let (Some(eps), Some(d)) = (glass.eps_r_mmwave(f), glass.mmwave.thickness_m) else {
        panic!("glass is a slab with a permittivity at mm-wave");
    };
    assert!(glass.mmwave.layers.is_empty());
    let n = eps.sqrt();
    let one = Complex64::new(1.0, 0.0);
    let g = (one - n) / (one + n);
    let delta = n * (2.0 * PI / lam) * d;
    let j = Complex64::new(0.0, 1.0);
    let t = (one - g * g) * (-j * delta).exp() / (one - g * g * (-2.0 * j * delta).exp());
    let expected = -40.0 * t.norm().log10();
    let r = 15.0;
    let pane = || {
        let mut o = target(
            "osiris:board?width_m=0.6&height_m=0.6&thickness_m=0&material=glass&mount=none",
            [11.0, 0.0, 1.0],
            PI,
            [0.01, 0.6, 0.6],
            [0.0; 3],
        );
        o.id = Some(id(21));
        o
    };
    let beyond = |p: Vec<PathReturn>| -> Vec<PathReturn> {
        p.into_iter().filter(|q| q.object_id == TARGET).collect()
    };
    let free = beyond(paths(
        config(1.0, FREE),
        vec![trihedral(0.1, r, 0.0, 1.0, [0.0; 3])],
    ));
    let behind = paths(
        config(1.0, FREE),
        vec![trihedral(0.1, r, 0.0, 1.0, [0.0; 3]), pane()],
    );
    // The pane reflects too (its own paths at 11 m).
    assert!(
        behind
            .iter()
            .any(|q| q.object_id == 21 && (q.range_m - 11.0).abs() < 0.1)
    );
    let behind = beyond(behind);
    let loss = db(coherent_power_w(&free, lam)) - db(coherent_power_w(&behind, lam));
    assert!(expected > 0.1, "glass transmits |T| = {}", t.norm());
    assert!(
        (loss - expected).abs() < 0.3,
        "loss {loss:.2} dB vs {expected:.2} dB"
    );
}

#[test]
fn guardrail_multipath_makes_a_ghost_behind_the_guardrail() {
    // Steel guardrail right of the road (beam face at y ≈ −2.85 m, facing the road), a car at
    // (25, −1). A path car → guardrail → radar arrives from a guardrail point but with the longer
    // range of the whole path, so its apparent position (range along the arrival direction) lies
    // behind the guardrail (y < −3.5 m), which no single-bounce path can produce. Off: none.
    // (Measured: one such ghost at y ≈ −9.4 m, −28.6 dB below the strongest path.)
    let scene = || {
        let mut v = view(vec![target(
            "osiris:car",
            [25.0, -1.0, 0.75],
            0.0,
            [4.5, 1.8, 1.5],
            [0.0; 3],
        )]);
        let gt = v.global_ground_truth.as_mut().unwrap();
        gt.stationary_object.push(osi3::StationaryObject {
            id: Some(id(31)),
            base: Some(osi3::BaseStationary {
                dimension: Some(osi3::Dimension3d {
                    length: Some(60.0),
                    width: Some(0.3),
                    height: Some(0.75),
                }),
                position: Some(v3([20.0, -3.0, 0.375])),
                orientation: Some(osi3::Orientation3d {
                    roll: Some(0.0),
                    pitch: Some(0.0),
                    yaw: Some(0.0),
                }),
                ..Default::default()
            }),
            model_reference: Some("osiris:guardrail?face=left".into()),
            ..Default::default()
        });
        v
    };
    let ghosts = |multipath: bool| {
        let fx = [
            ("radar.multipath", multipath),
            ("radar.ground_multipath", false),
        ];
        let p = paths_with(config(0.5, &fx), scene());
        let strongest = p.iter().map(|q| q.amplitude.norm_sqr()).fold(0.0, f64::max);
        p.iter()
            .filter(|q| {
                let y = q.range_m * q.rx_azimuth_rad.sin();
                y < -3.5 && q.amplitude.norm_sqr() > 1e-4 * strongest
            })
            .count()
    };
    assert!(ghosts(true) > 0, "no ghost behind the guardrail");
    assert_eq!(ghosts(false), 0);
}

#[test]
fn bad_config_is_a_config_error() {
    let mut c = config(1.0, &[]);
    let mut r = RadarConfig::default();
    r.propagation.tube_spacing_m = -1.0;
    c.radar = Some(r);
    let e = RadarSensor::new(c).err().expect("error").to_string();
    assert!(e.contains("tube_spacing_m"), "{e}");
    let mut c = config(1.0, &[]);
    let mut r = RadarConfig::default();
    r.front_end.noise_temperature_k = 0.0;
    c.radar = Some(r);
    let e = RadarSensor::new(c).err().expect("error").to_string();
    assert!(e.contains("noise_temperature_k"), "{e}");
    let mut c = config(1.0, &[]);
    c.effects.insert("radar.no_such_effect".into(), true);
    assert!(RadarSensor::new(c).is_err());
}

fn step(sensor: &mut RadarSensor, v: &osi3::SensorView) -> StepOutput {
    common::step_at(sensor, v, 0.0, 0.05)
}

#[test]
fn outputs_follow_osi_conventions() {
    // Whatever the chain detects is reported twice, with OSI's opposite radial-velocity sign.
    let mut s = RadarSensor::new(config(1.0, &[])).unwrap();
    let v = view(vec![trihedral(0.1, 15.0, 0.0, 1.0, [5.0, 0.0, 0.0])]);
    let out = step(&mut s, &v);
    let fd = out.sensor_data.feature_data.as_ref().unwrap();
    let dets = &fd.radar_sensor[0].detection;
    let peaks = &out.perception.radar.as_ref().unwrap().peak;
    assert_eq!(dets.len(), peaks.len());
    assert_eq!(
        fd.radar_sensor[0]
            .header
            .as_ref()
            .unwrap()
            .number_of_valid_detections,
        Some(dets.len() as u32)
    );
    for (d, p) in dets.iter().zip(peaks) {
        assert_eq!(d.radial_velocity, p.range_rate_m_s.map(|x| -x));
        assert_eq!(d.snr, p.snr_db);
    }
    assert_eq!(out.perception.model_mode.as_deref(), Some("physical"));
    let radar = out.perception.radar.as_ref().unwrap();
    assert!(radar.range_doppler_map.is_none());
    let wf = radar.waveform.as_ref().unwrap();
    assert_eq!(
        wf.carrier_frequency_hz,
        Some(RadarConfig::default().waveform.carrier_frequency_hz)
    );
    // The range-Doppler map on request: one dBm value per cell.
    let mut c = config(1.0, &[]);
    c.radar = Some(RadarConfig {
        emit_range_doppler_map: true,
        ..Default::default()
    });
    let mut s2 = RadarSensor::new(c).unwrap();
    let out2 = step(&mut s2, &v);
    let map = out2
        .perception
        .radar
        .as_ref()
        .unwrap()
        .range_doppler_map
        .as_ref()
        .expect("map");
    let cells = map.range_bins.unwrap() as usize * map.doppler_bins.unwrap() as usize;
    assert!(cells > 0);
    assert_eq!(map.power_dbm.len(), cells);
    assert_eq!(s.kind(), SensorKind::Radar);
}

/// End-to-end: corner reflector at 10 m and 20 m, at 0° and 45° azimuth, detected within 0.30 m in
/// range and 1° in azimuth, through the baseband chain (FFTs, CFAR, angle estimation).
#[test]
fn corner_reflector_detected_end_to_end() {
    for az_deg in [0.0f64, 45.0] {
        for r in [10.0, 20.0] {
            let az = az_deg.to_radians();
            let mut s = RadarSensor::new(config(0.5, &[])).unwrap();
            let v = view(vec![trihedral(0.1, r, az, 0.5, [0.0; 3])]);
            let out = step(&mut s, &v);
            let peaks = &out.perception.radar.as_ref().unwrap().peak;
            let best = peaks
                .iter()
                .max_by(|a, b| a.snr_db.unwrap().total_cmp(&b.snr_db.unwrap()))
                .expect("a detection");
            assert!(
                (best.range_m.unwrap() - r).abs() < 0.30,
                "{az_deg}°, {r} m: range {:?}",
                best.range_m
            );
            assert!(
                (best.azimuth_rad.unwrap() - az).abs() < 1f64.to_radians(),
                "{az_deg}°, {r} m: azimuth {:?}",
                best.azimuth_rad.map(f64::to_degrees)
            );
        }
    }
}

/// End-to-end: a reflector receding at 5 m/s is measured within 0.3 km/h, reported with OSI's sign
/// (positive towards the sensor), and its RCS estimate (radar equation inverted at the detected
/// range and angle) is within 3 dB of 4πa⁴/(3λ²).
#[test]
fn moving_reflector_velocity_and_rcs_end_to_end() {
    let v = 5.0;
    let mut s = RadarSensor::new(config(1.0, &[("radar.ground_multipath", false)])).unwrap();
    let vw = view(vec![trihedral(0.1, 20.0, 0.0, 1.0, [v, 0.0, 0.0])]);
    let out = step(&mut s, &vw);
    let peaks = &out.perception.radar.as_ref().unwrap().peak;
    let (i, best) = peaks
        .iter()
        .enumerate()
        .max_by(|a, b| a.1.snr_db.unwrap().total_cmp(&b.1.snr_db.unwrap()))
        .expect("a detection");
    let rr = best.range_rate_m_s.unwrap();
    assert!((rr - v).abs() < 0.3 / 3.6, "range rate {rr} m/s");
    let det = &out.sensor_data.feature_data.as_ref().unwrap().radar_sensor[0].detection[i];
    assert_eq!(det.radial_velocity, Some(-rr));
    // OSI 3.8.0: `object_id` names a detected object; in the first cycle the track is tentative
    // (not reported), so the detection belongs to none. Its ground truth is the peak's.
    assert_eq!(det.object_id, None);
    assert!(out.sensor_data.moving_object.is_empty());
    assert_eq!(best.object_id.and_then(|x| x.value), Some(TARGET));
    let lam = lambda();
    let expected = db(4.0 * PI * 0.1f64.powi(4) / (3.0 * lam * lam));
    let rcs = best.rcs_dbsm.unwrap();
    assert!(
        (rcs - expected).abs() < 3.0,
        "rcs {rcs:.2} dBsm vs {expected:.2}"
    );
}
/// End-to-end: three trihedrals (edge 0.1 m) at 20 m range, −6 / 0 / +6 m lateral offset, facing
/// the sensor, sensor and reflectors at the same height: one range-Doppler cell, three targets
/// 0.30 apart in sin(azimuth) (the 8-element horizontal aperture resolves 2/8 = 0.25). Three
/// detections, each within 0.3 m in range, 1° in azimuth and 1.5° in elevation of its reflector,
/// with its object id, with and without the ground multipath (its image paths, 2.9° below, fall in
/// the same cell and pull the single vertical baseline's elevation by < 1°) and the antenna
/// pattern; a single reflector gives exactly one detection in its cell.
#[test]
fn three_corner_reflectors_in_one_cell_end_to_end() {
    let az = 0.3f64.asin();
    let h = 0.5;
    let obj = |i: u64, a: f64| {
        let mut o = trihedral(0.1, 20.0, a, h, [0.0; 3]);
        o.id = Some(id(100 + i));
        o
    };
    let cell = |effects: &[(&str, bool)], objects: Vec<osi3::MovingObject>| {
        let mut s = RadarSensor::new(config(h, effects)).unwrap();
        let out = step(&mut s, &view(objects));
        out.perception
            .radar
            .as_ref()
            .unwrap()
            .peak
            .iter()
            .filter(|p| {
                (p.range_m.unwrap() - 20.0).abs() < 0.5 && p.range_rate_m_s.unwrap().abs() < 0.5
            })
            .cloned()
            .collect::<Vec<_>>()
    };
    for effects in [
        &[("radar.antenna_pattern", false)][..],
        &[("radar.ground_multipath", false)][..],
        &[][..],
    ] {
        let peaks = cell(effects, vec![obj(0, -az), obj(1, 0.0), obj(2, az)]);
        for p in &peaks {
            println!(
                "{effects:?}: range {:.3} m, az {:.3}°, el {:.3}°, {:.1} dBm, id {:?}",
                p.range_m.unwrap(),
                p.azimuth_rad.unwrap().to_degrees(),
                p.elevation_rad.unwrap().to_degrees(),
                p.power_dbm.unwrap(),
                p.object_id.as_ref().and_then(|i| i.value)
            );
        }
        assert_eq!(peaks.len(), 3, "{effects:?}: {peaks:#?}");
        for (i, truth) in [-az, 0.0, az].into_iter().enumerate() {
            let p = peaks
                .iter()
                .min_by(|a, b| {
                    (a.azimuth_rad.unwrap() - truth)
                        .abs()
                        .total_cmp(&(b.azimuth_rad.unwrap() - truth).abs())
                })
                .unwrap();
            assert!((p.range_m.unwrap() - 20.0).abs() < 0.3, "{p:?}");
            assert!(
                (p.azimuth_rad.unwrap() - truth).abs() < 1f64.to_radians(),
                "{effects:?} {truth}: {p:?}"
            );
            assert!(
                p.elevation_rad.unwrap().abs() < 1.5f64.to_radians(),
                "{effects:?}: {p:?}"
            );
            assert_eq!(
                p.object_id.as_ref().and_then(|i| i.value),
                Some(100 + i as u64)
            );
        }
    }
    for a in [0.0, 45f64.to_radians()] {
        let peaks = cell(&[], vec![obj(0, a)]);
        assert_eq!(peaks.len(), 1, "{a}: {peaks:#?}");
    }
}
