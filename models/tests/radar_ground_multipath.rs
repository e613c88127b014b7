//! Ground multipath of the physical radar (`radar.ground_multipath`) against an independent two-ray
//! model: a trihedral corner reflector over the road, 5–80 m, every 0.25 m.
//!
//! The expectation is written here from first principles, not from the model's code:
//! * the reflector's phase centre is its apex; where the apex sits in the OSI box follows from the
//!   asset's geometry (`models/ASSETS.md`, "Phase centres and reference points");
//! * the road is the fallback plane at z = 0 (no lanes in the view), `asphalt_dry`; its reflection
//!   coefficient for the radar's horizontal polarisation (TE for the road) is the Fresnel formula for
//!   the road's complex permittivity times the Ament roughness factor;
//! * the antenna's one-way voltage pattern in elevation is that of the default Gaussian beam.
//!
//! Two-way pattern factor |F|⁴ with F = 1 + Γ_TE(ψ)·(g(θ_img)/g(θ_dir))·(R_d/R_g)·e^{−jkΔR}
//! (time dependence e^{jωt}, ε = ε' − jε''): the DD, DG, GD and GG paths summed coherently.

mod common;
use common::{coherent_power_w, db, v3};

use std::f64::consts::PI;

use num_complex::Complex64;
use osiris_models::environment::material::MaterialDb;
use osiris_models::radar::antenna::{AntennaPattern, BeamShape};
use osiris_models::radar::{RadarConfig, RadarSensor};
use osiris_models::sensor::{ModelMode, Mounting};
use osiris_models::{SensorConfig, SensorKind, StepInput};
use osiris_proto::{id, osi3, timestamp_from_seconds};

const C0: f64 = 299_792_458.0;
const TARGET: u64 = 7;
/// Trihedral inner edge and plate thickness, m.
const EDGE: f64 = 0.1;
const THICKNESS: f64 = 0.002;
/// Sensor height and the height of the reflector's OSI box centre, m.
const SENSOR_Z: f64 = 0.5;
const BOX_Z: f64 = 0.6;

/// The trihedral's box centred `r` m straight ahead at height `BOX_Z`, facing the sensor (yaw π), as
/// a moving object or a stationary one. The box (0.09 × 0.15 × 0.15 m) is not taller than the
/// reflector + 5 cm: no post, the reflector is centred in it.
fn view(r: f64, stationary: bool) -> osi3::SensorView {
    let dimension = Some(osi3::Dimension3d {
        length: Some(0.09),
        width: Some(0.15),
        height: Some(0.15),
    });
    let orientation = Some(osi3::Orientation3d {
        roll: Some(0.0),
        pitch: Some(0.0),
        yaw: Some(PI),
    });
    let reference = Some(format!(
        "osiris:trihedral?edge_m={EDGE}&thickness_m={THICKNESS}"
    ));
    let mut gt = osi3::GroundTruth {
        timestamp: Some(timestamp_from_seconds(0.0)),
        ..Default::default()
    };
    if stationary {
        gt.stationary_object.push(osi3::StationaryObject {
            id: Some(id(TARGET)),
            base: Some(osi3::BaseStationary {
                dimension,
                position: Some(v3([r, 0.0, BOX_Z])),
                orientation,
                ..Default::default()
            }),
            model_reference: reference,
            ..Default::default()
        });
    } else {
        gt.moving_object.push(osi3::MovingObject {
            id: Some(id(TARGET)),
            base: Some(osi3::BaseMoving {
                dimension,
                position: Some(v3([r, 0.0, BOX_Z])),
                orientation,
                velocity: Some(v3([0.0; 3])),
                orientation_rate: Some(osi3::Orientation3d {
                    roll: Some(0.0),
                    pitch: Some(0.0),
                    yaw: Some(0.0),
                }),
                ..Default::default()
            }),
            r#type: Some(osi3::moving_object::Type::Other as i32),
            model_reference: reference,
            ..Default::default()
        });
    }
    osi3::SensorView {
        version: Some(osiris_proto::interface_version()),
        timestamp: Some(timestamp_from_seconds(0.0)),
        global_ground_truth: Some(gt),
        ..Default::default()
    }
}

/// Physical radar at `SENSOR_Z` looking along +x; default effects except gaseous absorption and
/// road clutter (not part of the two-ray model) and `radar.ground_multipath` as given.
fn sensor(ground: bool) -> RadarSensor {
    let mut c = SensorConfig::default_for(SensorKind::Radar);
    c.mode = ModelMode::Physical;
    c.mounting = Mounting {
        position_m: [0.0, 0.0, SENSOR_Z],
        orientation_rad: [0.0; 3],
    };
    c.fov_horizontal_rad = 120f64.to_radians();
    c.fov_vertical_rad = 30f64.to_radians();
    c.seed = Some(1);
    c.effects
        .insert("radar.atmospheric_absorption".into(), false);
    c.effects.insert("radar.ground_multipath".into(), ground);
    // The road's own diffuse return is not part of the two-ray model.
    c.effects.insert("radar.road_clutter".into(), false);
    RadarSensor::new(c).expect("radar")
}

/// Received power vs range (`from` … `to` in 0.25 m steps), with and without the effect:
/// (range, P_on, P_off).
fn sweep(from: f64, to: f64, stationary: bool) -> Vec<(f64, f64, f64)> {
    let lam = lambda();
    let (mut on, mut off) = (sensor(true), sensor(false));
    let mut out = Vec::new();
    let n = ((to - from) / 0.25).round() as u32;
    for i in 0..=n {
        let r = from + 0.25 * f64::from(i);
        let v = view(r, stationary);
        let input = StepInput {
            view: &v,
            time_s: 0.05 * f64::from(i),
            step_s: 0.05,
        };
        let p_on = on.propagate(&input).expect("propagate");
        assert!(p_on.iter().all(|p| p.object_id == TARGET));
        let p_on = if p_on.is_empty() {
            0.0
        } else {
            coherent_power_w(p_on, lam)
        };
        let p_off = coherent_power_w(off.propagate(&input).expect("propagate"), lam);
        out.push((r, p_on, p_off));
    }
    out
}

fn lambda() -> f64 {
    C0 / RadarConfig::default().waveform.carrier_frequency_hz
}

/// The apex in the world for a box centred at (r, 0, BOX_Z) facing −x: in the object frame the apex
/// is (a − t)/(2√3) behind the box centre along the boresight and (a − t)/(2√6) = (a − t)·√(2/3)/4
/// below it (ASSETS.md: the reflecting faces span x ∈ [0, a/√3], z ∈ [−a/√6, 2a/√6] from the apex,
/// the plates' backs add t/√3 behind, (2a + t)/√6 above and (a + 2t)/√6 below). Yaw π turns "behind"
/// into +x.
fn apex(r: f64) -> [f64; 3] {
    let (a, t) = (EDGE, THICKNESS);
    [
        r + (a - t) / (2.0 * 3f64.sqrt()),
        0.0,
        BOX_Z - (a - t) / (2.0 * 6f64.sqrt()),
    ]
}

/// Independent two-ray model: the two-way pattern factor |F|⁴ of the apex over the road at z = 0.
struct TwoRay {
    k: f64,
    eps: Complex64,
    roughness_m: f64,
    /// Full elevation beamwidth of the (Gaussian) Tx and Rx beams, rad.
    el_beamwidth_rad: f64,
}

impl TwoRay {
    fn new() -> TwoRay {
        let lam = lambda();
        let road = MaterialDb::builtin();
        let road = road.by_name("asphalt_dry").expect("asphalt_dry");
        let cfg = RadarConfig::default();
        let el_bw = |p: &AntennaPattern| match p {
            AntennaPattern::Parametric {
                shape: BeamShape::Gaussian,
                elevation_beamwidth_deg,
                ..
            } => elevation_beamwidth_deg.to_radians(),
            other => panic!("the test assumes Gaussian default beams, got {other:?}"),
        };
        let bw = el_bw(&cfg.front_end.tx_pattern);
        assert_eq!(bw, el_bw(&cfg.front_end.rx_pattern));
        TwoRay {
            k: 2.0 * PI / lam,
            eps: road.eps_r_mmwave(C0 / lam).expect("asphalt permittivity"),
            roughness_m: road.mmwave.roughness_m,
            el_beamwidth_rad: bw,
        }
    }

    /// Fresnel TE (E parallel to the road) coefficient at grazing angle ψ for ε = ε' − jε'' (e^{jωt}),
    /// times the Ament factor exp(−2(kσ sin ψ)²) of the road's rms height σ.
    fn gamma_te(&self, psi: f64) -> Complex64 {
        let s = Complex64::new(psi.sin(), 0.0);
        // Normalised vertical wavenumber in the road, principal root (Re > 0, Im ≤ 0 for ε'' ≥ 0:
        // the wave entering the road decays).
        let w = (self.eps - psi.cos().powi(2)).sqrt();
        let ament = (-2.0 * (self.k * self.roughness_m * psi.sin()).powi(2)).exp();
        (s - w) / (s + w) * ament
    }

    /// One-way voltage pattern of the Gaussian beam in elevation:
    /// G = G₀ exp(−4 ln2 θ²/θ_bw²) → g = exp(−2 ln2 θ²/θ_bw²).
    fn g(&self, el: f64) -> f64 {
        (-2.0 * 2f64.ln() * (el / self.el_beamwidth_rad).powi(2)).exp()
    }

    /// |F|⁴ for the reflector box at range `r`.
    fn factor(&self, r: f64) -> f64 {
        let p = apex(r);
        let d = p[0].hypot(p[1]);
        let (z_d, z_g) = (p[2] - SENSOR_Z, -p[2] - SENSOR_Z);
        let r_d = d.hypot(z_d);
        let r_g = d.hypot(z_g);
        let psi = (-z_g / r_g).asin();
        let (el_d, el_g) = (z_d.atan2(d), z_g.atan2(d));
        let f = Complex64::new(1.0, 0.0)
            + self.gamma_te(psi)
                * (self.g(el_g) / self.g(el_d))
                * (r_d / r_g)
                * Complex64::from_polar(1.0, -self.k * (r_g - r_d));
        f.norm_sqr().powi(2)
    }
}

/// RMS of 10·log₁₀((P_on/P_off) / |F|⁴) in dB over the ranges with a return where the two-ray model
/// has no null deeper than −20 dB (there the dB error measures the depth of the null, not the
/// lobing), and how many ranges that is.
fn rms_db(model: &TwoRay, data: &[(f64, f64, f64)]) -> (f64, usize) {
    let (mut sum_sq, mut n) = (0.0, 0usize);
    let mut worst = (0.0f64, 0.0);
    for &(r, on, off) in data {
        assert!(off > 0.0, "no return with the effect off at {r} m");
        let expected = model.factor(r);
        if on <= 0.0 || expected < 0.01 {
            continue;
        }
        let e = db(on / off) - db(expected);
        if e.abs() > worst.0.abs() {
            worst = (e, r);
        }
        sum_sq += e * e;
        n += 1;
    }
    let rms = (sum_sq / n as f64).sqrt();
    println!(
        "two-ray model vs radar: RMS {rms:.2} dB over {n} of {} ranges (worst {:.2} dB at {} m)",
        data.len(),
        worst.0,
        worst.1
    );
    (rms, n)
}

#[test]
fn trihedral_over_the_road_follows_the_two_ray_model() {
    let model = TwoRay::new();
    let data = sweep(5.0, 80.0, false);
    // Free space (effect off): P ∝ R⁻⁴ (of the apex range) at constant RCS. The trihedral's RCS is
    // constant only beyond its near field (2D²/λ ≈ 10 m for D = √2·a); compare with the median of
    // P·R⁴ beyond 20 m.
    let r4 = |r: f64| {
        let p = apex(r);
        (p[0].powi(2) + (p[2] - SENSOR_Z).powi(2)).powi(2)
    };
    let mut far: Vec<f64> = data
        .iter()
        .filter(|(r, _, _)| *r >= 20.0)
        .map(|&(r, _, off)| db(off * r4(r)))
        .collect();
    far.sort_by(f64::total_cmp);
    let c_db = far[far.len() / 2];
    let worst_free = data
        .iter()
        .filter(|(r, _, _)| *r >= 20.0)
        .map(|&(r, _, off)| (db(off * r4(r)) - c_db).abs())
        .fold(0.0, f64::max);
    assert!(
        worst_free < 0.5,
        "effect off: P·R⁴ varies by {worst_free:.2} dB beyond 20 m"
    );
    // Effect on: P_on / P_off = |F|⁴ (`rms_db` says which ranges count).
    let (rms, n) = rms_db(&model, &data);
    assert!(n > 200, "only {n} ranges compared");
    assert!(rms <= 1.5, "RMS {rms:.2} dB");
    // The switch matters: the lobing changes the power by more than 1 dB at most ranges.
    let changed = data
        .iter()
        .filter(|(_, on, off)| (db(*on) - db(*off)).abs() > 1.0)
        .count();
    assert!(changed > data.len() / 2, "effect changed {changed} ranges");
}

#[test]
fn stationary_trihedral_is_imaged_from_its_apex_too() {
    // The same reflector as a stationary object (part of the static world): its phase centre comes
    // from the scene's stationary-object table instead of the instance's mesh.
    let model = TwoRay::new();
    let data = sweep(10.0, 20.0, true);
    let (rms, n) = rms_db(&model, &data);
    assert!(n > 30, "only {n} ranges compared");
    assert!(rms <= 1.5, "RMS {rms:.2} dB");
}
