//! `osiris consistency --meta <campaign>/consistency.toml --out <dir> [--simulated <sd.osi>]
//! [--model <config.json>] [--enable <effect-id>]... [--disable <effect-id>]... [--history <dir>]`.

use std::collections::BTreeMap;
use std::path::PathBuf;

use anyhow::{Context, Result, anyhow, bail};
use osiris_models::sensor::SensorConfig;
use osiris_proto::osi3;

use super::attribution::{self, Status};
use super::campaign::{Campaign, CampaignSensor};
use super::catalogue::Catalogue;
use super::history::{self, HistoryEntry};
use super::metrics;
use super::pairing::{self, read_trace};
use super::report::{self, ModelInfo, PairingInfo, Summary};
use super::simulate::{self, SimulateError};
use super::{quantity, tolerance_of};

/// Arguments of `osiris consistency`.
#[derive(Debug, Clone, clap::Args)]
pub struct ConsistencyArgs {
    /// The campaign's `consistency.toml`.
    #[arg(long)]
    pub meta: PathBuf,
    /// Output folder (`summary.json`, `report.html`).
    #[arg(long)]
    pub out: PathBuf,
    /// A simulated SensorData trace made elsewhere (attribution without re-simulation).
    #[arg(long)]
    pub simulated: Option<PathBuf>,
    /// Model configuration JSON for the re-simulation (overrides the campaign's `sensor.model`).
    #[arg(long)]
    pub model: Option<PathBuf>,
    /// Switch an effect on for the re-simulation (repeatable; `osiris effects` lists them).
    #[arg(long = "enable", value_name = "EFFECT-ID")]
    pub enable: Vec<String>,
    /// Switch an effect off for the re-simulation (repeatable).
    #[arg(long = "disable", value_name = "EFFECT-ID")]
    pub disable: Vec<String>,
    /// Run registry folder: previous runs' headline errors go into the summary, this run is appended.
    #[arg(long)]
    pub history: Option<PathBuf>,
}

/// A simulator injected in place of `osiris_models::build_sensor` (tests).
pub type Simulator<'a> = dyn FnMut(&SensorConfig, &[osi3::SensorView]) -> Result<Vec<osi3::SensorData>, SimulateError>
    + 'a;

/// Runs the workflow, writes `summary.json` and `report.html`; fails (after writing them) when a
/// tolerance fails and the status is not EXPLAINED (the CI contract, validation.md §6).
pub fn run(args: ConsistencyArgs) -> Result<()> {
    let summary = run_with(&args, None)?;
    let failing: Vec<&str> = summary
        .metrics
        .iter()
        .filter(|m| !m.pass)
        .map(|m| m.id.as_str())
        .collect();
    if !failing.is_empty() && summary.status != Status::Explained.name() {
        bail!(
            "consistency: status {} with failing metrics: {} (see {})",
            summary.status,
            failing.join(", "),
            args.out.join("report.html").display()
        );
    }
    Ok(())
}

pub(crate) fn switches(args: &ConsistencyArgs) -> Result<osiris_models::effects::EffectSwitches> {
    let known = osiris_models::effects::catalogue();
    let mut sw = BTreeMap::new();
    for (list, on) in [(&args.enable, true), (&args.disable, false)] {
        for name in list {
            if !known.iter().any(|e| e.name == name) {
                bail!(
                    "unknown effect `{name}` in --{} (known: {})",
                    if on { "enable" } else { "disable" },
                    known.iter().map(|e| e.name).collect::<Vec<_>>().join(", ")
                );
            }
            if sw.insert(name.clone(), on).is_some_and(|prev| prev != on) {
                bail!("effect `{name}` is both enabled and disabled");
            }
        }
    }
    Ok(sw)
}

/// The workflow; `simulator` replaces the real model when given. Returns the summary it wrote.
pub fn run_with(args: &ConsistencyArgs, simulator: Option<&mut Simulator<'_>>) -> Result<Summary> {
    let campaign = Campaign::load(&args.meta)?;
    for w in &campaign.warnings {
        eprintln!("warning: {w}");
    }
    if campaign.sensor.kind == CampaignSensor::Camera {
        return super::camera::run_with(args, &campaign);
    }
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("cannot create `{}`", args.out.display()))?;
    let sw = switches(args)?;
    let mut warnings = campaign.warnings.clone();
    eprintln!("consistency: reading {}", campaign.sensor_view.display());
    let views: Vec<osi3::SensorView> = read_trace(&campaign.sensor_view, "SensorView")?;
    let meas: Vec<osi3::SensorData> = read_trace(&campaign.sensor_data, "measured SensorData")?;
    let (sim, model_info) = match &args.simulated {
        Some(path) => {
            if !sw.is_empty() || args.model.is_some() {
                warnings.push(
                    "--enable/--disable/--model do not apply to a --simulated trace; ignored"
                        .into(),
                );
            }
            (
                read_trace::<osi3::SensorData>(path, "simulated SensorData")?,
                ModelInfo {
                    source: "simulated-trace".into(),
                    detail: path.display().to_string(),
                    enabled: vec![],
                    disabled: vec![],
                    osiris_version: env!("CARGO_PKG_VERSION").into(),
                },
            )
        }
        None => {
            let cfg =
                simulate::model_config(&campaign, args.model.as_deref(), &sw, campaign.split.seed)?;
            eprintln!(
                "consistency: re-simulating {} frames with the physical {} model",
                views.len(),
                cfg.kind.name()
            );
            let mut progress = |i: usize, n: usize| {
                if i == n || i.is_multiple_of(50) {
                    eprintln!("consistency: simulated {i}/{n}");
                }
            };
            let sim = match simulator {
                Some(f) => f(&cfg, &views),
                None => simulate::simulate(cfg.clone(), &views, &mut progress),
            };
            let sim = match sim {
                Ok(s) => s,
                Err(SimulateError::NotAvailable(why)) => {
                    return Err(anyhow!(SimulateError::NotAvailable(why)))
                        .context("re-simulation impossible; pass --simulated <sd.osi> to attribute a trace made elsewhere");
                }
                Err(SimulateError::Other(e)) => return Err(e.context("re-simulation failed")),
            };
            let path = args.out.join("simulated_sensor_data.osi");
            let mut w = crate::trace::OsiTraceWriter::create(&path)?;
            for sd in &sim {
                w.write_message(sd)?;
            }
            w.finish()?;
            (
                sim,
                ModelInfo {
                    source: "re-simulated".into(),
                    detail: format!(
                        "mode physical, seed {}, trace {}",
                        campaign.split.seed,
                        path.display()
                    ),
                    enabled: args.enable.clone(),
                    disabled: args.disable.clone(),
                    osiris_version: env!("CARGO_PKG_VERSION").into(),
                },
            )
        }
    };
    let summary = analyse(&campaign, &views, &meas, &sim, model_info, args, warnings)?;
    eprintln!(
        "consistency: {} — {}",
        summary.status,
        summary
            .error
            .iter()
            .map(|(k, v)| format!("{k} RMS {v:.3}"))
            .collect::<Vec<_>>()
            .join(", ")
    );
    Ok(summary)
}

/// The held-out targets: each target is held out when a seeded hash of its id falls below
/// `split.holdout_fraction` (at least one target when the fraction is > 0).
pub fn holdout_targets(campaign: &Campaign, rows: &[super::Row]) -> Vec<u64> {
    let mut targets: Vec<u64> = rows.iter().map(|r| r.target).filter(|t| *t != 0).collect();
    targets.sort_unstable();
    targets.dedup();
    let frac = campaign.split.holdout_fraction;
    let key = |t: u64| {
        metrics::SplitMix(t ^ campaign.split.seed.wrapping_mul(0x9E37_79B9_7F4A_7C15)).next_u64()
    };
    let mut ranked: Vec<(u64, u64)> = targets.iter().map(|&t| (key(t), t)).collect();
    ranked.sort_unstable();
    let n = ((frac * targets.len() as f64).round() as usize)
        .max(usize::from(frac > 0.0))
        .min(targets.len());
    let mut out: Vec<u64> = ranked.into_iter().take(n).map(|(_, t)| t).collect();
    out.sort_unstable();
    out
}

/// Pairs, measures, attributes and writes the outputs.
fn analyse(
    campaign: &Campaign,
    views: &[osi3::SensorView],
    meas: &[osi3::SensorData],
    sim: &[osi3::SensorData],
    model: ModelInfo,
    args: &ConsistencyArgs,
    warnings: Vec<String>,
) -> Result<Summary> {
    let paired = pairing::pair(campaign, views, meas, sim)?;
    analyse_paired(campaign, paired, model, args, warnings)
}

/// Metrics, attribution and outputs of paired rows (also the camera branch, `camera.rs`).
pub(crate) fn analyse_paired(
    campaign: &Campaign,
    paired: pairing::Paired,
    model: ModelInfo,
    args: &ConsistencyArgs,
    mut warnings: Vec<String>,
) -> Result<Summary> {
    warnings.extend(paired.warnings.iter().cloned());
    if paired.missing_meas_frames > 0 {
        warnings.push(format!(
            "{} SensorView frame(s) have no measured frame (missing frames are skipped)",
            paired.missing_meas_frames
        ));
    }
    eprintln!(
        "consistency: {} frames paired, {} residual rows",
        paired.paired_frames,
        paired.rows.len()
    );
    let (metric_list, stats) = metrics::verdict_metrics(campaign, &paired.rows, &paired.counts);
    let error_raw: BTreeMap<String, f64> = stats.iter().map(|(q, s)| (q.clone(), s.rms)).collect();
    // Held-out split: a seeded `holdout_fraction` of the targets (the closed-loop comparison).
    let holdout_targets = holdout_targets(campaign, &paired.rows);
    let mut distributions = BTreeMap::new();
    for (q, m) in &paired.meas_values {
        if let Some(s) = paired.sim_values.get(q)
            && let Some(d) = metrics::distribution_metrics(m, s)
        {
            distributions.insert(q.to_string(), d);
        }
    }
    let b = &campaign.bins;
    let mut binned = Vec::new();
    let (main_q, y) = match campaign.sensor.kind {
        CampaignSensor::Lidar => (
            quantity::INTENSITY_PCT,
            ("incidence", super::V_ASPECT, b.incidence_deg.as_slice()),
        ),
        _ => (
            quantity::POWER_DB,
            ("azimuth", super::V_AZIMUTH, b.azimuth_deg.as_slice()),
        ),
    };
    for q in [main_q, quantity::RANGE_M] {
        if paired.rows.iter().any(|r| r.quantity == q) {
            binned.push(metrics::binned(
                &paired.rows,
                q,
                tolerance_of(q, &campaign.tolerance),
                ("range", super::V_RANGE, &b.range_m),
                y,
            ));
        }
    }
    if campaign.sensor.kind == CampaignSensor::Lidar
        && paired.rows.iter().any(|r| r.quantity == main_q)
    {
        binned.push(metrics::binned(
            &paired.rows,
            main_q,
            tolerance_of(main_q, &campaign.tolerance),
            ("range", super::V_RANGE, &b.range_m),
            ("reflectivity", super::V_REFLECTIVITY, &b.reflectivity_pct),
        ));
    }
    let catalogue = Catalogue::builtin(campaign.sensor.kind)?;
    eprintln!(
        "consistency: attribution over {} catalogue effects",
        catalogue.effects.len()
    );
    // Attribution fits the training split only; the held-out targets judge the closed loop.
    let train: Vec<super::Row> = paired
        .rows
        .iter()
        .filter(|r| !holdout_targets.contains(&r.target))
        .copied()
        .collect();
    let attribution = attribution::attribute(campaign, &catalogue, &train);
    // Headline errors: RMS after removing the calibration offset fitted on the training split (the
    // offset is a nuisance, reported in `attribution[].calibration_offset`, not an error to chase).
    let offset_of = |q: &str| -> f64 {
        attribution
            .iter()
            .find(|a| a.quantity == q)
            .and_then(|a| a.calibration_offset)
            .map(|c| c[0])
            .unwrap_or(0.0)
    };
    let rms_of = |q: &str, held_out: bool| -> Option<f64> {
        let off = offset_of(q);
        let r: Vec<f64> = paired
            .rows
            .iter()
            .filter(|r| r.quantity == q && (!held_out || holdout_targets.contains(&r.target)))
            .map(|r| r.resid() - off)
            .collect();
        (!r.is_empty()).then(|| (r.iter().map(|v| v * v).sum::<f64>() / r.len() as f64).sqrt())
    };
    let mut error = BTreeMap::new();
    let mut holdout_error = BTreeMap::new();
    for q in super::metric_quantities(campaign.sensor.kind) {
        if let Some(v) = rms_of(q, false) {
            error.insert(q.to_string(), v);
        }
        if let Some(v) = rms_of(q, true) {
            holdout_error.insert(q.to_string(), v);
        }
    }
    let statuses: Vec<Status> = attribution.iter().map(|a| a.status).collect();
    let mut status = if statuses.is_empty() {
        if metric_list.iter().all(|m| m.pass) {
            Status::Consistent
        } else {
            Status::Unexplained
        }
    } else {
        attribution::combine(&statuses)
    };
    // A failing verdict metric without an attributed quantity cannot be CONSISTENT.
    if status == Status::Consistent && metric_list.iter().any(|m| !m.pass) {
        status = Status::Unexplained;
    }
    let mut effects: Vec<_> = attribution
        .iter()
        .flat_map(|a| a.effects.iter().cloned())
        .collect();
    effects.sort_by(|a, b| {
        b.accepted
            .cmp(&a.accepted)
            .then(b.delta_bic.total_cmp(&a.delta_bic))
    });
    let tie_groups = attribution
        .iter()
        .flat_map(|a| a.tie_groups.iter().cloned())
        .collect();
    let history = match &args.history {
        Some(dir) => history::load(dir, &mut warnings)?,
        None => Vec::new(),
    };
    let summary = Summary {
        schema: super::campaign::SCHEMA,
        run: campaign.run.clone(),
        sensor: campaign.sensor.kind.name().into(),
        quantity_semantics: campaign.sensor.quantity_semantics.clone(),
        model,
        status: status.name().into(),
        metrics: metric_list,
        error,
        error_raw,
        holdout_targets,
        holdout_error,
        residual_stats: stats.into_iter().collect(),
        distributions,
        effects,
        tie_groups,
        attribution,
        binned,
        pairing: PairingInfo {
            views: paired.views,
            paired_frames: paired.paired_frames,
            missing_meas_frames: paired.missing_meas_frames,
            missing_sim_frames: paired.missing_sim_frames,
            rows: paired.rows.len(),
            counts: paired.counts,
        },
        tolerance: campaign.tolerance,
        history,
        warnings,
        catalogue_version: format!("{} v{}", catalogue.sensor, catalogue.version),
    };
    let json = serde_json::to_string_pretty(&summary)?;
    std::fs::write(args.out.join("summary.json"), json).context("cannot write summary.json")?;
    let html = report::html(
        &summary,
        campaign,
        &paired.rows,
        &paired.meas_values,
        &paired.sim_values,
    );
    std::fs::write(args.out.join("report.html"), html).context("cannot write report.html")?;
    if let Some(dir) = &args.history {
        let unix_time_s = std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map(|d| d.as_secs_f64())
            .unwrap_or(0.0);
        history::append(
            dir,
            &HistoryEntry {
                run_id: summary.run.id.clone(),
                unix_time_s,
                status: summary.status.clone(),
                error: summary.error.clone(),
                enabled: args.enable.clone(),
                disabled: args.disable.clone(),
                accepted: summary.accepted(),
            },
        )?;
    }
    Ok(summary)
}
