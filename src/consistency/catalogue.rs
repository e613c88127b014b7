//! Effect catalogues (validation.md §4): one versioned TOML per sensor
//! (`models/resources/consistency/{radar,lidar}.toml`), each entry a residual signature with 0–2
//! bounded parameters, its explanatory variables, the osiris effect switch that adds the physics to
//! the model, the effects it can be confused with and the experiment that separates them.

use anyhow::{Context, Result, anyhow, bail};
use serde::Serialize;

use super::VAR_NAMES;
use super::campaign::{CampaignSensor, TVal, parse_toml};
use super::expr::Expr;

/// The built-in radar catalogue.
pub const RADAR_TOML: &str = include_str!("../../models/resources/consistency/radar.toml");
/// The built-in LiDAR catalogue.
pub const LIDAR_TOML: &str = include_str!("../../models/resources/consistency/lidar.toml");

/// A bounded parameter.
#[derive(Debug, Clone, Serialize)]
pub struct Param {
    pub name: String,
    pub bounds: [f64; 2],
    /// Value for the identifiability check.
    pub nominal: f64,
}

/// One catalogue entry.
#[derive(Debug, Clone, Serialize)]
pub struct Effect {
    pub id: String,
    pub layer: Vec<String>,
    pub quantity: String,
    pub explanatory: Vec<String>,
    pub signature: String,
    #[serde(skip)]
    pub expr: Expr,
    pub params: Vec<Param>,
    /// osiris effect switch that adds the physics to the model (None = not implemented yet).
    pub model_switch: Option<String>,
    pub confusable_with: Vec<String>,
    pub discriminating_experiment: String,
    pub physics: String,
}

impl Effect {
    /// Signature value at variables `x` and parameters `p`.
    pub fn eval(&self, x: &[f64], p: &[f64]) -> f64 {
        let v = self.expr.eval(x, p);
        if v.is_finite() { v } else { 0.0 }
    }

    pub fn nominal(&self) -> Vec<f64> {
        self.params.iter().map(|p| p.nominal).collect()
    }
}

/// A versioned catalogue of one sensor.
#[derive(Debug, Clone, Serialize)]
pub struct Catalogue {
    pub sensor: String,
    pub version: String,
    pub effects: Vec<Effect>,
}

impl Catalogue {
    /// The built-in catalogue of a sensor kind.
    pub fn builtin(kind: CampaignSensor) -> Result<Catalogue> {
        match kind {
            CampaignSensor::Radar => Catalogue::parse(RADAR_TOML),
            CampaignSensor::Lidar => Catalogue::parse(LIDAR_TOML),
            CampaignSensor::Camera => bail!("no camera catalogue yet"),
        }
    }

    /// Effects acting on one quantity.
    pub fn for_quantity<'a>(&'a self, q: &'a str) -> impl Iterator<Item = &'a Effect> + 'a {
        self.effects.iter().filter(move |e| e.quantity == q)
    }

    /// Parses a catalogue TOML.
    pub fn parse(text: &str) -> Result<Catalogue> {
        let root = parse_toml(text, "effect catalogue")?;
        let get = |entries: &[(String, TVal)], k: &str| {
            entries.iter().find(|(n, _)| n == k).map(|(_, v)| v.clone())
        };
        let s = |v: Option<TVal>, what: &str| -> Result<String> {
            match v {
                Some(TVal::Str(s)) => Ok(s),
                None => Ok(String::new()),
                Some(_) => bail!("catalogue: `{what}` must be a string"),
            }
        };
        let strs = |v: Option<TVal>, what: &str| -> Result<Vec<String>> {
            match v {
                None => Ok(Vec::new()),
                Some(TVal::Arr(a)) => a
                    .into_iter()
                    .map(|v| match v {
                        TVal::Str(s) => Ok(s),
                        _ => Err(anyhow!("catalogue: `{what}` must be an array of strings")),
                    })
                    .collect(),
                Some(_) => bail!("catalogue: `{what}` must be an array of strings"),
            }
        };
        let sensor = s(get(&root, "sensor"), "sensor")?;
        let version = s(get(&root, "version"), "version")?;
        let mut effects = Vec::new();
        let Some(TVal::Arr(list)) = get(&root, "effect") else {
            bail!("catalogue: no [[effect]] entries");
        };
        for (i, e) in list.into_iter().enumerate() {
            let TVal::Table(t) = e else {
                bail!("catalogue: effect[{i}] must be a table")
            };
            let id = s(get(&t, "id"), "effect.id")?;
            let ctx = || format!("catalogue effect `{id}`");
            if id.is_empty() {
                bail!("catalogue: effect[{i}] has no id");
            }
            let mut consts = Vec::new();
            if let Some(TVal::Table(c)) = get(&t, "consts") {
                for (k, v) in c {
                    match v {
                        TVal::Num(x) => consts.push((k, x)),
                        _ => bail!("{}: consts.{k} must be a number", ctx()),
                    }
                }
            }
            let mut params = Vec::new();
            if let Some(TVal::Arr(ps)) = get(&t, "params") {
                for p in ps {
                    let TVal::Table(p) = p else {
                        bail!("{}: params must be tables", ctx())
                    };
                    let name = s(get(&p, "name"), "params.name")?;
                    let bounds = match get(&p, "bounds") {
                        Some(TVal::Arr(b)) if b.len() == 2 => match (&b[0], &b[1]) {
                            (TVal::Num(lo), TVal::Num(hi)) if lo < hi => [*lo, *hi],
                            _ => bail!(
                                "{}: param `{name}` bounds must be [lo, hi] with lo < hi",
                                ctx()
                            ),
                        },
                        _ => bail!("{}: param `{name}` needs bounds = [lo, hi]", ctx()),
                    };
                    let nominal = match get(&p, "nominal") {
                        Some(TVal::Num(v)) => v.clamp(bounds[0], bounds[1]),
                        _ => 0.5 * (bounds[0] + bounds[1]),
                    };
                    params.push(Param {
                        name,
                        bounds,
                        nominal,
                    });
                }
            }
            if params.len() > 2 {
                bail!("{}: at most 2 parameters", ctx());
            }
            let signature = s(get(&t, "signature"), "signature")?;
            let names: Vec<String> = params.iter().map(|p| p.name.clone()).collect();
            let expr = Expr::parse(&signature, &VAR_NAMES, &consts, &names).with_context(ctx)?;
            let model_switch = s(get(&t, "model_switch"), "model_switch")?;
            effects.push(Effect {
                layer: strs(get(&t, "layer"), "layer")?,
                quantity: s(get(&t, "quantity"), "quantity")?,
                explanatory: strs(get(&t, "explanatory"), "explanatory")?,
                signature,
                expr,
                params,
                model_switch: (!model_switch.is_empty()).then_some(model_switch),
                confusable_with: strs(get(&t, "confusable_with"), "confusable_with")?,
                discriminating_experiment: s(
                    get(&t, "discriminating_experiment"),
                    "discriminating_experiment",
                )?,
                physics: s(get(&t, "physics"), "physics")?,
                id,
            });
        }
        Ok(Catalogue {
            sensor,
            version,
            effects,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn builtin_catalogues_parse_and_model_switches_exist() {
        let known: Vec<&str> = osiris_models::effects::catalogue()
            .iter()
            .map(|e| e.name)
            .collect();
        for kind in [CampaignSensor::Radar, CampaignSensor::Lidar] {
            let c = Catalogue::builtin(kind).unwrap();
            assert!(c.effects.len() >= 7);
            for e in &c.effects {
                if let Some(s) = &e.model_switch {
                    assert!(
                        known.contains(&s.as_str()),
                        "{}: unknown model switch {s}",
                        e.id
                    );
                }
                for other in &e.confusable_with {
                    assert!(
                        c.effects.iter().any(|o| &o.id == other),
                        "{}: {other}",
                        e.id
                    );
                }
            }
        }
        // DIVP signature: R⁻² instead of R⁻⁴ is −20 dB per decade with p0 = 2.
        let c = Catalogue::builtin(CampaignSensor::Radar).unwrap();
        let e = c
            .effects
            .iter()
            .find(|e| e.id == "radar.spreading_exponent")
            .unwrap();
        let mut x = [0.0; super::super::NVARS];
        x[0] = 100.0;
        assert!((e.eval(&x, &[2.0]) + 20.0).abs() < 1e-9);
    }
}
