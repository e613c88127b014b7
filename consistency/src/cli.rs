//! `osiris consistency --meta <campaign>/consistency.toml --out <dir> [--simulated <sd.osi>]
//! [--model <config.json>] [--enable <effect-id>]... [--disable <effect-id>]... [--history <dir>]`.

use std::collections::BTreeMap;
use std::path::PathBuf;

use anyhow::{Context, Result, bail};
use osiris_models::SensorConfig;
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

/// The verdict "the model is inconsistent with the measurement": a tolerance fails and the status
/// is not EXPLAINED. `osiris consistency` exits with 1 on it (the outputs are written), and with
/// 2 on a usage or input error (`osiris::cli::exit_code`).
#[derive(Debug, Clone, thiserror::Error)]
#[error("consistency: status {status} with failing metrics: {} (see {report})", failing.join(", "))]
pub struct VerdictFailed {
    /// The run's status (`UNEXPLAINED`, `PARTIALLY_EXPLAINED`, or `CONSISTENT` never).
    pub status: String,
    /// The failing metric ids.
    pub failing: Vec<String>,
    /// The report path.
    pub report: String,
}

/// Runs the workflow, writes `summary.json` and `report.html`; fails (after writing them) with
/// [`VerdictFailed`] when a tolerance fails and the status is not EXPLAINED (the CI contract,
/// validation.md §6).
pub fn run(args: ConsistencyArgs) -> Result<()> {
    let summary = run_with(&args, None)?;
    let failing: Vec<String> = summary
        .metrics
        .iter()
        .filter(|m| !m.pass)
        .map(|m| m.id.clone())
        .collect();
    if !failing.is_empty() && summary.status != Status::Explained.name() {
        return Err(VerdictFailed {
            status: summary.status.clone(),
            failing,
            report: args.out.join("report.html").display().to_string(),
        }
        .into());
    }
    Ok(())
}

pub(crate) fn switches(args: &ConsistencyArgs) -> Result<osiris_models::effects::EffectSwitches> {
    let known = osiris_models::registry::catalogue();
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

/// The workflow with the built-in catalogue of the campaign's sensor; `simulator` replaces the
/// real model when given. Returns the summary it wrote.
pub fn run_with(args: &ConsistencyArgs, simulator: Option<&mut Simulator<'_>>) -> Result<Summary> {
    run_with_catalogue(args, None, simulator)
}

/// The workflow with `catalogue` (e.g. the built-in one plus registered effects,
/// [`Catalogue::register`]) in place of the built-in catalogue; its sensor must be the campaign's.
pub fn run_with_catalogue(
    args: &ConsistencyArgs,
    catalogue: Option<&Catalogue>,
    simulator: Option<&mut Simulator<'_>>,
) -> Result<Summary> {
    let campaign = Campaign::load(&args.meta)?;
    for w in &campaign.warnings {
        eprintln!("warning: {w}");
    }
    let catalogue = match catalogue {
        Some(c) if c.sensor != campaign.sensor.kind.name() => bail!(
            "the {} catalogue cannot attribute a {} campaign (`{}`)",
            c.sensor,
            campaign.sensor.kind.name(),
            args.meta.display()
        ),
        Some(c) => c.clone(),
        None => Catalogue::builtin(campaign.sensor.kind)?,
    }
    .for_campaign(&campaign);
    if campaign.sensor.kind == CampaignSensor::Camera && !campaign.camera_detections {
        return super::camera::run_with(args, &campaign, &catalogue);
    }
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("cannot create `{}`", args.out.display()))?;
    let sw = switches(args)?;
    let mut warnings = campaign.warnings.clone();
    eprintln!("consistency: reading {}", campaign.sensor_view.display());
    let views: Vec<osi3::SensorView> = read_trace(&campaign.sensor_view, "SensorView")?;
    let meas: Vec<osi3::SensorData> = read_trace(&campaign.sensor_data, "measured SensorData")?;
    let (sim, sim_truth, model_info) = match &args.simulated {
        Some(path) => {
            if !sw.is_empty() || args.model.is_some() {
                warnings.push(
                    "--enable/--disable/--model do not apply to a --simulated trace; ignored"
                        .into(),
                );
            }
            (
                read_trace::<osi3::SensorData>(path, "simulated SensorData")?,
                None,
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
                Some(f) => f(&cfg, &views).map(|frames| simulate::Simulation {
                    frames,
                    truth: Vec::new(),
                }),
                None => simulate::simulate(cfg.clone(), &views, &mut progress),
            };
            let simulate::Simulation { frames: sim, truth } = match sim {
                Ok(s) => s,
                Err(SimulateError::Other(e)) => {
                    return Err(e.context(
                        "re-simulation failed (to attribute a trace made elsewhere, pass --simulated <sd.osi>)",
                    ));
                }
            };
            let path = args.out.join("simulated_sensor_data.osi");
            let mut w = osiris_proto::trace::OsiTraceWriter::create(&path)?;
            for sd in &sim {
                w.write_message(sd)?;
            }
            w.finish()?;
            (
                sim,
                (!truth.is_empty()).then_some(truth),
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
    let summary = analyse(
        &campaign,
        &catalogue,
        &views,
        &meas,
        (&sim, sim_truth.as_deref()),
        model_info,
        args,
        warnings,
    )?;
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

/// A word for the shell: quoted when it holds anything but plain path characters.
fn shell_word(s: &str) -> String {
    if !s.is_empty()
        && s.chars()
            .all(|c| c.is_ascii_alphanumeric() || "-_./=:+@%".contains(c))
    {
        s.to_owned()
    } else {
        format!("'{}'", s.replace('\'', r"'\''"))
    }
}

/// The command that re-runs this campaign with `effect` switched on: the same arguments, the
/// effect moved from `--disable` to `--enable`, a sibling output folder, a re-simulation (a
/// `--simulated` trace cannot be switched).
fn rerun_command(args: &ConsistencyArgs, effect: &str) -> String {
    let mut w: Vec<String> = vec![
        "osiris".into(),
        "consistency".into(),
        "--meta".into(),
        shell_word(&args.meta.display().to_string()),
        "--out".into(),
    ];
    let out = args.out.display().to_string();
    let out = out.trim_end_matches('/');
    w.push(shell_word(&format!("{out}_{}", effect.replace('.', "_"))));
    if let Some(m) = &args.model {
        w.push("--model".into());
        w.push(shell_word(&m.display().to_string()));
    }
    for e in args.enable.iter().filter(|e| *e != effect) {
        w.push("--enable".into());
        w.push(shell_word(e));
    }
    w.push("--enable".into());
    w.push(shell_word(effect));
    for e in args.disable.iter().filter(|e| *e != effect) {
        w.push("--disable".into());
        w.push(shell_word(e));
    }
    if let Some(h) = &args.history {
        w.push("--history".into());
        w.push(shell_word(&h.display().to_string()));
    }
    w.join(" ")
}

/// Per accepted effect (in order of acceptance): its switch, the command to re-run with it, and
/// the headline error predicted once it is in the model (the residual rows minus its fitted
/// signature, the calibration offset refitted on the training split).
fn actions(
    catalogue: &Catalogue,
    attribution: &[attribution::QuantityAttribution],
    rows: &[super::Row],
    holdout: &super::split::Holdout,
    args: &ConsistencyArgs,
) -> Vec<report::Action> {
    use super::catalogue::EffectKind;
    let mut out: Vec<report::Action> = Vec::new();
    for qa in attribution {
        for id in &qa.accepted {
            let (Some(e), Some(res)) = (
                catalogue.get_for(id, &qa.quantity),
                qa.effects.iter().find(|r| &r.id == id),
            ) else {
                continue;
            };
            // The entry's parameters by name: fitted here, or (a joint signature) fixed by the
            // same effect's fit on another quantity.
            let p: Vec<f64> = e
                .params()
                .iter()
                .map(|par| {
                    res.params
                        .iter()
                        .chain(
                            attribution
                                .iter()
                                .flat_map(|a| a.effects.iter())
                                .filter(|r| &r.id == id)
                                .flat_map(|r| r.params.iter()),
                        )
                        .find(|f| f.name == par.name)
                        .map_or(par.nominal, |f| f.value)
                })
                .collect();
            let q = qa.quantity.as_str();
            // RMS of the rows of `q` after subtracting `s` and an offset fitted on the training
            // split: the same figure with and without the effect.
            let rms_after = |with: bool| -> Option<f64> {
                let v: Vec<(bool, f64)> = rows
                    .iter()
                    .filter(|r| r.quantity == q)
                    .map(|r| {
                        let s = if with { e.eval(&r.x, &p) } else { 0.0 };
                        (holdout.contains(r), r.resid() - s)
                    })
                    .collect();
                let train: Vec<f64> = v.iter().filter(|(h, _)| !h).map(|(_, x)| *x).collect();
                let offset = if attribution::has_offset(q) && !train.is_empty() {
                    train.iter().sum::<f64>() / train.len() as f64
                } else {
                    0.0
                };
                (!v.is_empty()).then(|| {
                    (v.iter().map(|(_, x)| (x - offset).powi(2)).sum::<f64>() / v.len() as f64)
                        .sqrt()
                })
            };
            let (kind, params) = (
                e.kind(),
                res.params
                    .iter()
                    .map(|p| (p.name.clone(), p.value))
                    .collect::<Vec<_>>(),
            );
            let a = match out.iter_mut().find(|a| a.effect == *id) {
                Some(a) => a,
                None => {
                    let (switch, command, advice) = match kind {
                        EffectKind::Model => (
                            Some(id.clone()),
                            Some(rerun_command(args, id)),
                            format!(
                                "switch `{id}` on in the model and re-run (the error should fall to the predicted value)"
                            ),
                        ),
                        EffectKind::MissingPhysics => (
                            None,
                            None,
                            format!(
                                "add this effect: the model has no `{id}` (see the catalogue entry's physics)"
                            ),
                        ),
                        EffectKind::Measurement => (
                            None,
                            None,
                            format!(
                                "a property of the measurement (`{id}`): correct or calibrate the measurement, not the model"
                            ),
                        ),
                    };
                    out.push(report::Action {
                        effect: id.clone(),
                        quantities: Vec::new(),
                        kind,
                        switch,
                        command,
                        advice,
                        params: Vec::new(),
                        error_now: BTreeMap::new(),
                        predicted_error: BTreeMap::new(),
                    });
                    out.last_mut().expect("just pushed")
                }
            };
            a.quantities.push(q.to_owned());
            a.params.extend(params);
            if let (Some(now), Some(then)) = (rms_after(false), rms_after(true)) {
                a.error_now.insert(q.to_owned(), now);
                a.predicted_error.insert(q.to_owned(), then);
            }
        }
    }
    out
}

/// Pairs, measures, attributes and writes the outputs.
#[allow(clippy::too_many_arguments)]
fn analyse(
    campaign: &Campaign,
    catalogue: &Catalogue,
    views: &[osi3::SensorView],
    meas: &[osi3::SensorData],
    (sim, sim_truth): (&[osi3::SensorData], Option<&[Vec<u64>]>),
    model: ModelInfo,
    args: &ConsistencyArgs,
    warnings: Vec<String>,
) -> Result<Summary> {
    let paired = pairing::pair(campaign, views, meas, sim, sim_truth)?;
    analyse_paired(campaign, catalogue, paired, model, args, warnings)
}

/// Metrics, attribution and outputs of paired rows (also the camera branch, `camera.rs`).
pub(crate) fn analyse_paired(
    campaign: &Campaign,
    catalogue: &Catalogue,
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
    // Held-out split (the closed-loop comparison): whole targets, or stations where the targets
    // are too few or too distinct to hold one out ([`Holdout`]).
    let holdout = super::split::holdout(campaign, &paired.rows);
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
    eprintln!(
        "consistency: attribution over {} catalogue effects",
        catalogue.effects.len()
    );
    // Attribution fits the training split only; the held-out targets judge the closed loop.
    let train: Vec<super::Row> = paired
        .rows
        .iter()
        .filter(|r| !holdout.contains(r))
        .copied()
        .collect();
    let attribution = attribution::attribute(campaign, catalogue, &train);
    // The calibration offsets fitted on the training split are a nuisance (reported in
    // `attribution[].calibration_offset`, not an error to chase): the verdict and the headline
    // errors judge the residuals after removing them; the raw RMS is reported beside.
    let calibration = metrics::Calibration::new(
        attribution
            .iter()
            .filter_map(|a| a.calibration_offset.map(|c| (a.quantity.to_string(), c[0]))),
    );
    let (metric_list, stats) =
        metrics::verdict_metrics(campaign, &paired.rows, &paired.counts, &calibration);
    let error_raw: BTreeMap<String, f64> = stats.iter().map(|(q, s)| (q.clone(), s.rms)).collect();
    for m in &metric_list {
        // A tolerance met only once the calibration is removed: say so.
        if let (Some(c), Some(raw)) = (m.calibration, m.raw_value)
            && raw > m.tolerance
            && m.pass
        {
            let q = m.id.strip_suffix(".rms").unwrap_or(&m.id);
            let unit = if q == super::quantity::INTENSITY_PCT {
                "dB of gain"
            } else {
                m.unit
            };
            warnings.push(format!(
                "{q}: the measurement's calibration differs from the model's by {c:.3} {unit} (a \
                 fitted nuisance, removed before the verdict): raw RMS {raw:.3} {u} against the \
                 tolerance {t} {u}, {v:.3} {u} after removing it; check the sensor's calibration",
                u = m.unit,
                t = m.tolerance,
                v = m.value,
            ));
        }
    }
    let rms_of = |q: &str, held_out: bool| -> Option<f64> {
        let r: Vec<f64> = paired
            .rows
            .iter()
            .filter(|r| r.quantity == q && (!held_out || holdout.contains(r)))
            .map(|r| calibration.residual(r))
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
    let actions = actions(catalogue, &attribution, &paired.rows, &holdout, args);
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
        actions,
        metrics: metric_list,
        error,
        error_raw,
        holdout_targets: holdout.targets.clone(),
        holdout,
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
