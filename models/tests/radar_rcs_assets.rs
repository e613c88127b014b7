//! The built-in assets look to the radar like the objects they stand for (GitHub issue #19): curved
//! surfaces return finite specular flashes σ = π·a₁·a₂ that do not grow with range, and a car, a
//! pedestrian and a cyclist have RCS levels of the published 77 GHz measurements.
//!
//! Every number is the RCS estimate of the physical radar's reported detections (OSI
//! `RadarDetection.rcs`, dBm²: the radar equation inverted at the detection's range and angle), the
//! default radar 0.5 m above an empty world (no road, so no ground multipath; the effect is off
//! too), the target's centre at the radar's height unless said otherwise.
//!
//! Closed forms and references (physics.md §1.2, §1.8):
//! * Doubly curved convex surface with principal radii a₁, a₂ at the specular point (geometrical
//!   optics; Knott, Shaeffer & Tuley, *Radar Cross Section*, 2nd ed. 2004, ch. 5; Ruck et al.,
//!   *Radar Cross Section Handbook*, 1970): σ = π·a₁·a₂ in the far field; at range R the reflected
//!   tube's divergence gives the apparent σ(R) = π·a₁·a₂·R² / ((R + a₁)(R + a₂)). A sphere of
//!   radius a: σ = πa²; an ellipsoid of semi-axes (a, b, c) seen along a: a₁ = b²/a, a₂ = c²/a.
//! * Pedestrian at 77 GHz: ≈ −8 dBm² from the front, side and back (Fortuny-Guasch & Chareau, JRC
//!   report EUR 25762 EN, 2013; Yamada et al., Toyota CRDL R&D Review 2004).
//! * Passenger car: 360° means around 10 dBm² at 77 GHz (e.g. Matsunami, Nakamura & Kajiwara,
//!   ICSPCS 2012; Lee et al., PIMRC 2016: 0 … 20 dBm² with aspect); the band is 5–20 dBm².
//! * Bicycle with rider: see [`cyclist_sector_means_are_those_of_a_bicycle_with_rider`].

mod common;
use common::{db, moving_object, radar_detections, step_at};

use std::f64::consts::PI;
use std::io::Write;

use osiris_models::radar::RadarSensor;
use osiris_models::sensor::{ModelMode, Mounting};
use osiris_models::{SensorConfig, SensorKind};
use osiris_proto::osi3;

/// Sensor height, m.
const H: f64 = 0.5;

fn radar() -> RadarSensor {
    let mut c = SensorConfig::default_for(SensorKind::Radar);
    c.mode = ModelMode::Physical;
    c.mounting = Mounting {
        position_m: [0.0, 0.0, H],
        orientation_rad: [0.0; 3],
    };
    c.seed = Some(1);
    c.effects.insert("radar.ground_multipath".into(), false);
    RadarSensor::new(c).expect("radar")
}

use common::view_of as view;

/// Reported detections (rcs dBm², distance m) of one frame.
fn detections(sensor: &mut RadarSensor, v: &osi3::SensorView) -> Vec<(f64, f64)> {
    radar_detections(&step_at(sensor, v, 0.0, 0.05))
        .iter()
        .map(|d| {
            (
                d.rcs.unwrap(),
                d.position.as_ref().and_then(|p| p.distance).unwrap(),
            )
        })
        .collect()
}

/// RCS of the strongest detection within `window_m` of range `r`, dBm² (−∞ when none).
fn strongest(d: &[(f64, f64)], r: f64, window_m: f64) -> f64 {
    d.iter()
        .filter(|(_, dist)| (dist - r).abs() < window_m)
        .map(|x| x.0)
        .fold(f64::NEG_INFINITY, f64::max)
}

/// An object `reference` at range `r` straight ahead, its box centre at height `zc`, rotated so the
/// radar sees it at aspect `aspect` (0: its front, +x, faces the radar; π/2: its left side).
fn at_aspect(reference: &str, r: f64, zc: f64, aspect: f64, dims: [f64; 3]) -> osi3::MovingObject {
    moving_object(reference, 7, [r, 0.0, zc], PI + aspect, dims, [0.0; 3])
}

/// Linear mean of dB values, in dB.
fn linear_mean_db(v: &[f64]) -> f64 {
    db(v.iter().map(|x| 10f64.powf(x / 10.0)).sum::<f64>() / v.len() as f64)
}

/// Apparent RCS of a doubly curved convex specular point at range `r` (module doc), dBm².
fn curved_specular_dbsm(a1: f64, a2: f64, r: f64) -> f64 {
    db(PI * a1 * a2 * r * r / ((r + a1) * (r + a2)))
}

/// Write a closed UV ellipsoid of semi-axes `s` (x, y, z) as a Wavefront OBJ with shared vertices:
/// `n` segments around z, `m` (odd) rings, the vertices half a segment off the x axis so that a
/// quad's centre (a flat facet ≈ 2πs/n wide) faces −x.
fn ellipsoid_obj(name: &str, s: [f64; 3], n: usize, m: usize) -> String {
    let path = std::env::temp_dir().join(format!("osiris_rcs_{}_{name}.obj", std::process::id()));
    let mut f = std::fs::File::create(&path).unwrap();
    writeln!(f, "v 0 0 {}", -s[2]).unwrap();
    for j in 1..m {
        let phi = PI * j as f64 / m as f64;
        for k in 0..n {
            let t = 2.0 * PI * (k as f64 + 0.5) / n as f64;
            writeln!(
                f,
                "v {} {} {}",
                s[0] * phi.sin() * t.cos(),
                s[1] * phi.sin() * t.sin(),
                -s[2] * phi.cos()
            )
            .unwrap();
        }
    }
    writeln!(f, "v 0 0 {}", s[2]).unwrap();
    // OBJ indices are 1-based; vertex 1 the bottom pole, rows from 2.
    let row = |j: usize, k: usize| 2 + (j - 1) * n + (k % n);
    let top = 2 + (m - 1) * n;
    for k in 0..n {
        writeln!(f, "f 1 {} {}", row(1, k + 1), row(1, k)).unwrap();
        for j in 1..m - 1 {
            writeln!(
                f,
                "f {} {} {} {}",
                row(j, k),
                row(j, k + 1),
                row(j + 1, k + 1),
                row(j + 1, k)
            )
            .unwrap();
        }
        writeln!(f, "f {} {} {top}", row(m - 1, k), row(m - 1, k + 1)).unwrap();
    }
    format!("osiris:mesh?path={}&material=steel", path.to_str().unwrap())
}

/// Geometrical optics: a steel sphere of radius 0.5 m (σ = πa² = −1.0 dBm²) and a steel ellipsoid of
/// semi-axes 0.3 × 0.6 × 0.45 m seen along its short axis (a₁ = 1.2 m, a₂ = 0.675 m: σ = 4.1 dBm²),
/// tessellated into 48 × 25 facets (about 6.5 cm: flat facets would return a plate's
/// 4πA²/λ² ≈ +11 dBm² each, the facet facing the radar), at 10, 20 and 40 m: the strongest
/// detection is within 1.5 dB of σ(R) at every range.
#[test]
fn curved_test_bodies_match_geometrical_optics() {
    let sphere = ellipsoid_obj("sphere", [0.5, 0.5, 0.5], 48, 25);
    let ellipsoid = ellipsoid_obj("ellipsoid", [0.3, 0.6, 0.45], 48, 25);
    let cases = [
        (&sphere, [0.5, 0.5, 0.5], 0.5, 0.5),
        (
            &ellipsoid,
            [0.3, 0.6, 0.45],
            0.6 * 0.6 / 0.3,
            0.45 * 0.45 / 0.3,
        ),
    ];
    for (reference, s, a1, a2) in cases {
        for r in [10.0, 20.0, 40.0] {
            let mut sensor = radar();
            let obj = at_aspect(
                reference,
                r + s[0],
                H,
                0.0,
                [2.0 * s[0], 2.0 * s[1], 2.0 * s[2]],
            );
            let d = detections(&mut sensor, &view(vec![obj]));
            let got = strongest(&d, r, 0.5);
            let expected = curved_specular_dbsm(a1, a2, r);
            println!(
                "{reference}: {r} m: strongest {got:.2} dBm², π·a₁·a₂ (at range) {expected:.2} dBm², \
                 {} detections",
                d.len()
            );
            assert!(
                (got - expected).abs() < 1.5,
                "semi-axes {s:?} at {r} m: {got:.2} vs {expected:.2} dBm²"
            );
        }
    }
}

const CAR: [f64; 3] = [4.5, 1.8, 1.5];

/// A car seen broadside (its left side towards the radar) at 10, 20, 40 and 60 m: the strongest
/// detection's RCS changes by at most 3 dB between 20 m and 60 m (a flat side, a mirror, grew with
/// R²: 31.6 → 43.1 dBm² before), and lies within 5 dB of the flank's closed form
/// π·a₁·a₂ (a₁ = 10 m plan radius, a₂ = 1.5 m vertical radius: 16.7 dBm², at range) at 20–60 m
/// (wheels, mirrors and the greenhouse add to the flank's flash in the same range cell).
#[test]
fn car_broadside_does_not_grow_with_range() {
    let mut at = Vec::new();
    for r in [10.0, 20.0, 40.0, 60.0] {
        let mut sensor = radar();
        let obj = at_aspect("osiris:car", r + 0.5 * CAR[1], 0.5 * CAR[2], 0.5 * PI, CAR);
        let d = detections(&mut sensor, &view(vec![obj]));
        let got = strongest(&d, r, 1.0);
        let flank = curved_specular_dbsm(10.0, 1.5, r);
        println!(
            "car broadside at {r} m: strongest {got:.2} dBm² (flank π·a₁·a₂ at range {flank:.2}), {} \
             detections",
            d.len()
        );
        at.push((r, got, flank));
    }
    let (r20, r60) = (at[1].1, at[3].1);
    assert!(
        (r60 - r20).abs() <= 3.0,
        "broadside 20 m {r20:.2} vs 60 m {r60:.2} dBm²"
    );
    for &(r, got, flank) in &at[1..] {
        assert!(
            (got - flank).abs() < 5.0,
            "{r} m: {got:.2} vs flank {flank:.2} dBm²"
        );
    }
}

/// Strongest-detection RCS (dBm²) of `reference` at range `r` for aspects `k · step_deg + offset`
/// (k = 0 … 360/step − 1), degrees; 0: front to the radar.
fn aspect_sweep(
    reference: &str,
    dims: [f64; 3],
    r: f64,
    step_deg: f64,
    offset_deg: f64,
) -> Vec<(f64, f64)> {
    let n = (360.0 / step_deg).round() as usize;
    let mut sensor = radar();
    (0..n)
        .map(|k| {
            let a = k as f64 * step_deg + offset_deg;
            let obj = at_aspect(reference, r, 0.5 * dims[2], a.to_radians(), dims);
            let d = detections(&mut sensor, &view(vec![obj]));
            (a, strongest(&d, r, 0.5 * dims[0].max(dims[1]) + 1.0))
        })
        .collect()
}

/// Linear mean (dB) over the aspects within `half_deg` of `centre_deg` (either sense).
fn sector_mean(sweep: &[(f64, f64)], centre_deg: f64, half_deg: f64) -> f64 {
    let v: Vec<f64> = sweep
        .iter()
        .filter(|(a, _)| {
            [centre_deg, -centre_deg].iter().any(|c| {
                let d = (a - c).rem_euclid(360.0);
                d.min(360.0 - d) <= half_deg
            })
        })
        .map(|x| x.1.max(-60.0))
        .collect();
    linear_mean_db(&v)
}

/// A car at 40 m seen from every aspect (1° steps, half a degree off the axes so the plates' and
/// lamps' sub-degree flashes are sampled like any other aspect): the linear mean of the strongest
/// detection's RCS lies in 5–20 dBm².
#[test]
fn car_360_mean_is_that_of_a_passenger_car() {
    let sweep = aspect_sweep("osiris:car", CAR, 40.0, 1.0, 0.5);
    let mean = linear_mean_db(&sweep.iter().map(|x| x.1.max(-60.0)).collect::<Vec<_>>());
    let (front, side, rear) = (
        sector_mean(&sweep, 0.0, 30.0),
        sector_mean(&sweep, 90.0, 30.0),
        sector_mean(&sweep, 180.0, 30.0),
    );
    println!(
        "car at 40 m: 360° mean {mean:.2} dBm²; sector means front {front:.2}, side {side:.2}, rear \
         {rear:.2} dBm²; min {:.2}, max {:.2}",
        sweep.iter().map(|x| x.1).fold(f64::INFINITY, f64::min),
        sweep.iter().map(|x| x.1).fold(f64::NEG_INFINITY, f64::max)
    );
    assert!((5.0..=20.0).contains(&mean), "360° mean {mean:.2} dBm²");
}

/// Pedestrian (walking, 1.8 m) at 20 m: the linear means over ±30° around the front, the side and
/// the back are each within 5 dB of −8 dBm² (module doc).
#[test]
fn pedestrian_sector_means_are_those_of_a_person() {
    let sweep = aspect_sweep("osiris:pedestrian", [0.5, 0.6, 1.8], 20.0, 3.0, 1.5);
    for (name, c) in [("front", 0.0), ("side", 90.0), ("back", 180.0)] {
        let m = sector_mean(&sweep, c, 30.0);
        println!("pedestrian at 20 m, {name}: {m:.2} dBm² (published ≈ −8)");
        assert!((m + 8.0).abs() <= 5.0, "{name}: {m:.2} dBm²");
    }
}

/// Bicycle with rider at 20 m, sector means over ±30° around the front, the side and the back.
///
/// Reference values: Belgiovane & Chen, "Bicycles and human riders backscattering at 77 GHz for
/// automotive radar", EuCAP 2016, measured a bicycle with rider over 360° at 77 GHz; the paper
/// could not be consulted for this test, so the expectations are the rounded levels osiris already
/// uses for a bicycle with rider (`ideal::default_rcs_moving_dbsm`: 0 dBm², from the 77 GHz
/// measurements cited there) for the side, and the pedestrian's −8 dBm² plus the bicycle's small
/// frontal area (tyre, fork, handlebar: a few dB) for the front and the back: −5 dBm². Each sector
/// mean must be within 5 dB. (UNVERIFIED against the paper's polar plots.)
#[test]
fn cyclist_sector_means_are_those_of_a_bicycle_with_rider() {
    let sweep = aspect_sweep("osiris:cyclist", [1.8, 0.6, 1.75], 20.0, 3.0, 1.5);
    for (name, c, expected) in [
        ("front", 0.0, -5.0),
        ("side", 90.0, 0.0),
        ("back", 180.0, -5.0),
    ] {
        let m = sector_mean(&sweep, c, 30.0);
        println!("cyclist at 20 m, {name}: {m:.2} dBm² (reference {expected})");
        assert!((m - expected).abs() <= 5.0, "{name}: {m:.2} dBm²");
    }
}
