//! `osiris bench consistency`: the attribution (station aggregation, noise model, nuisance
//! baseline, tie check, forward selection with bounded multi-start fits, the four gates, profile
//! CIs, leave-one-group-out CV) over synthetic radar power residuals, timed on a rayon pool.
//!
//! Design ([`BENCH_ROWS`] rows, [`BENCH_FRAMES_PER_STATION`] frames per station): 3–150 m,
//! ±40° azimuth, five trihedral sizes; the residual carries a calibration offset, the DIVP R⁻²
//! bug and a two-way antenna pattern, plus 1 dB of per-frame scatter. The candidates are the
//! built-in `power_db` entries of the radar catalogue plus generated variants (polynomials, ripples,
//! knees, exponentials) up to [`BENCH_EFFECTS`]: all on one quantity, the worst case of the
//! forward selection. Target (GitHub issue 7): under 2 s on 2 cores.

use std::path::Path;
use std::time::Instant;

use serde_json::{Value, json};

use super::attribution::attribute_quantity;
use super::campaign::{Campaign, CampaignSensor};
use super::catalogue::{Catalogue, Effect, Param};
use super::metrics::SplitMix;
use super::{NVARS, Row, V_PRX, V_SIM, quantity};

/// Residual rows of the benchmark.
pub const BENCH_ROWS: usize = 10_000;
/// Catalogue effects on the benchmark's quantity.
pub const BENCH_EFFECTS: usize = 30;
/// Replicate frames per station.
pub const BENCH_FRAMES_PER_STATION: usize = 5;
/// Target wall time, s.
pub const BENCH_TARGET_S: f64 = 2.0;

const CAMPAIGN: &str = r#"schema = "osiris.consistency/1"
[run]
id = "bench-consistency"
[sensor]
kind = "radar"
[tolerance]
power_db = 5.0
[split]
cv_group_by = ["target"]
[traces]
sensor_view = "sv.osi"
sensor_data = "sd.osi"
"#;

/// The benchmark campaign (tolerances, CV groups by target).
pub fn bench_campaign() -> Campaign {
    Campaign::parse(CAMPAIGN, Path::new(".")).expect("the benchmark campaign parses")
}

/// `n` synthetic radar `power_db` rows, `frames` per station (deterministic for a seed).
pub fn synthetic_rows(n: usize, frames: usize, seed: u64) -> Vec<Row> {
    let frames = frames.max(1);
    let stations = n.div_ceil(frames);
    let mut rng = SplitMix(seed ^ 0x5EED_BE7C);
    let edges: [f64; 5] = [0.05, 0.08, 0.10, 0.12, 0.15];
    let lambda_m = 0.003_893;
    let mut rows = Vec::with_capacity(n);
    for s in 0..stations {
        // Targets: 40 per size, each seen at several ranges (CV groups by target).
        let target = (s % 200) as u64 + 1;
        let a = edges[(target as usize) % edges.len()];
        let range = 3.0 + 147.0 * rng.unit();
        let az = -40.0 + 80.0 * rng.unit();
        // Trihedral peak RCS 4πa⁴/(3λ²) (Knott), dBsm.
        let rcs =
            10.0 * (4.0 * std::f64::consts::PI * a.powi(4) / (3.0 * lambda_m * lambda_m)).log10();
        let mut x = [0.0; NVARS];
        x[0] = range;
        x[1] = az;
        x[2] = 0.0;
        x[3] = 0.0;
        x[4] = a * a;
        x[5] = a;
        x[7] = a;
        x[8] = a;
        x[V_SIM] = rcs;
        x[11] = 1e9;
        x[V_PRX] = rcs - 40.0 * range.log10();
        x[13] = 0.5;
        // Hidden: calibration offset, R⁻² bug (+20 log10(R/10)), antenna pattern θ3 = 25°.
        let truth = 1.0 + 20.0 * (range / 10.0).log10() - 24.0 * (az / 25.0).powi(2);
        for f in 0..frames {
            if rows.len() == n {
                break;
            }
            rows.push(Row {
                quantity: quantity::POWER_DB,
                frame: s * frames + f,
                time_s: (s * frames + f) as f64 * 0.05,
                target,
                station: s as u64,
                meas: rcs + truth + rng.normal(),
                sim: rcs,
                x,
            });
        }
    }
    rows
}

/// The radar catalogue's `power_db` effects plus generated variants, `n` in all.
pub fn bench_catalogue(n: usize) -> Catalogue {
    let mut c = Catalogue::builtin(CampaignSensor::Radar).expect("built-in radar catalogue");
    c.effects.retain(|e| e.quantity() == quantity::POWER_DB);
    c.effects.truncate(n);
    let templates = [
        "p0*((range - c)/100)^3",
        "p0*sin(2*pi*range/p1 + c)",
        "p0*(azimuth + c)/30",
        "p0*log10(max(area, 1e-4)/0.01)*log10(range/c)",
        "p0*exp(-range/p1)*(1 + 0*c)",
        "p0*max(range - p1, 0)/100 + 0*c",
        "p0*abs(azimuth - c)/30",
    ];
    let mut i = 0usize;
    while c.effects.len() < n {
        let sig = templates[i % templates.len()];
        let cval = 10.0 + 7.0 * (i / templates.len()) as f64;
        let mut params = vec![Param::new("p0", [-10.0, 10.0], 1.0)];
        if sig.contains("p1") {
            params.push(Param::new("p1", [2.0, 150.0], 30.0));
        }
        let e = Effect::from_signature(
            &format!("bench.variant_{i}"),
            quantity::POWER_DB,
            sig,
            &[("c".to_owned(), cval)],
            params,
        )
        .expect("benchmark variant signature");
        c.register(Box::new(e)).expect("new benchmark id");
        i += 1;
    }
    c
}

/// `osiris bench consistency` with the issue's sizes.
pub fn bench_consistency(threads: Option<usize>) -> Value {
    bench_consistency_with(BENCH_ROWS, BENCH_EFFECTS, threads)
}

/// The benchmark with other sizes (tests use small ones). `threads`: rayon pool size (default 2).
pub fn bench_consistency_with(rows: usize, effects: usize, threads: Option<usize>) -> Value {
    let threads = threads.unwrap_or(2).max(1);
    let campaign = bench_campaign();
    let data = synthetic_rows(rows, BENCH_FRAMES_PER_STATION, 7);
    let catalogue = bench_catalogue(effects);
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .expect("rayon pool");
    let start = Instant::now();
    let result =
        pool.install(|| attribute_quantity(&campaign, &catalogue, &data, quantity::POWER_DB));
    let attribution_s = start.elapsed().as_secs_f64();
    let (status, accepted, stations) = match &result {
        Some(a) => (a.status.name(), a.accepted.clone(), a.stations),
        None => ("NONE", Vec::new(), 0),
    };
    json!({
        "bench": "consistency",
        "attribution_s": (attribution_s * 1e3).round() / 1e3,
        "rows": data.len(),
        "stations": stations,
        "effects": catalogue.for_quantity(quantity::POWER_DB).count(),
        "threads": threads,
        "target_s": BENCH_TARGET_S,
        "status": status,
        "accepted": accepted,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bench_json_has_the_keys_and_finds_the_planted_effects() {
        let v = bench_consistency_with(600, 12, Some(2));
        for k in [
            "attribution_s",
            "rows",
            "effects",
            "threads",
            "target_s",
            "stations",
        ] {
            assert!(!v[k].is_null(), "bench JSON lacks {k}: {v}");
        }
        assert_eq!(v["rows"], 600);
        assert_eq!(v["effects"], 12);
        assert_eq!(v["stations"], 120);
        // The planted R⁻² bug and antenna pattern are what the attribution accepts.
        let acc: Vec<&str> = v["accepted"]
            .as_array()
            .unwrap()
            .iter()
            .map(|a| a.as_str().unwrap())
            .collect();
        assert!(acc.contains(&"radar.two_way_spreading"), "{v}");
        assert!(acc.contains(&"radar.antenna_pattern"), "{v}");
    }
}
