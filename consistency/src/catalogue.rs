//! Effect catalogues (validation.md §4): one versioned TOML per sensor
//! (`consistency/catalogue/{radar,lidar,camera}.toml`), each entry a residual signature with 0–2
//! bounded parameters, its explanatory variables, its [`EffectKind`] (an osiris model effect of the
//! same name, physics the model lacks, or a property of the measurement), the effects it can be
//! confused with and the experiment that separates them.
//!
//! # One name per effect
//! A catalogue id of kind [`EffectKind::Model`] *is* the model's switch: `osiris consistency
//! --enable <id>` and `osiris effects` use the same string ([`validate`] rejects a model-kind id the
//! models do not declare). One effect that changes several quantities has one entry per quantity
//! under the same id.
//!
//! # Adding an effect
//! Every entry implements [`EffectSignature`]: the TOML entries are one implementation
//! ([`Effect`], a parsed signature expression); a user writes another in Rust and adds it with
//! [`Catalogue::register`]. The attribution ([`super::attribution`]) only sees the trait.
//! `examples/custom_effect.rs` writes a radome loss from scratch, finds it on a campaign and then
//! enables it.

use std::sync::Arc;

use anyhow::{Context, Result, anyhow, bail};
use serde::Serialize;

use super::VAR_NAMES;
use super::campaign::{CampaignSensor, TVal, parse_toml};
use super::expr::{Expr, Program};

/// The built-in radar catalogue.
pub const RADAR_TOML: &str = include_str!("../catalogue/radar.toml");
/// The built-in LiDAR catalogue.
pub const LIDAR_TOML: &str = include_str!("../catalogue/lidar.toml");
/// The built-in camera catalogue (ROI mean and variance; variable mapping in `camera.rs`).
pub const CAMERA_TOML: &str = include_str!("../catalogue/camera.toml");

/// Most parameters an effect may have (validation.md §4: 0–2 bounded parameters keep the
/// forward selection identifiable and fast).
pub const MAX_PARAMS: usize = 2;

/// What a catalogue id stands for.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum EffectKind {
    /// An osiris model effect of the same name: switch it with `--enable <id>` / `--disable <id>`.
    Model,
    /// Physics the model lacks: the report says "add this effect".
    MissingPhysics,
    /// A property of the measurement or its processing (not sensor physics to add to the model).
    Measurement,
}

impl EffectKind {
    /// The TOML spelling.
    pub fn name(self) -> &'static str {
        match self {
            EffectKind::Model => "model",
            EffectKind::MissingPhysics => "missing_physics",
            EffectKind::Measurement => "measurement",
        }
    }

    /// Parses the TOML spelling.
    pub fn parse(s: &str) -> Option<EffectKind> {
        [
            EffectKind::Model,
            EffectKind::MissingPhysics,
            EffectKind::Measurement,
        ]
        .into_iter()
        .find(|k| k.name() == s)
    }
}

/// Whether `id` is an osiris model effect (`osiris effects`).
pub fn is_model_effect(id: &str) -> bool {
    osiris_models::registry::catalogue()
        .iter()
        .any(|e| e.name == id)
}

/// A bounded parameter.
#[derive(Debug, Clone, Serialize)]
pub struct Param {
    pub name: String,
    pub bounds: [f64; 2],
    /// Value for the identifiability check.
    pub nominal: f64,
}

impl Param {
    /// A parameter with bounds `[lo, hi]` and the value the identifiability check uses.
    pub fn new(name: &str, bounds: [f64; 2], nominal: f64) -> Param {
        Param {
            name: name.to_owned(),
            bounds,
            nominal,
        }
    }
}

/// One effect of the catalogue: a residual signature s(x; θ) in the natural unit of its quantity
/// (meas − sim), with 0–2 bounded parameters, and its documentation (validation.md §4).
///
/// Implement it and add the effect with [`Catalogue::register`]; the attribution fits `eval` over
/// the station-aggregated residuals (a calibration offset is always fitted beside it, so a constant
/// part of the signature is irrelevant).
pub trait EffectSignature: Send + Sync {
    /// Unique id, `<sensor>.<effect>` (e.g. `radar.radome_loss`).
    fn id(&self) -> &str;
    /// The residual quantity it acts on ([`super::quantity`], e.g. `power_db`).
    fn quantity(&self) -> &str;
    /// The bounded parameters θ (at most [`MAX_PARAMS`]).
    fn params(&self) -> &[Param];
    /// The signature s(x; θ) at the explanatory variables `x` (indexed as [`VAR_NAMES`]) and
    /// parameters `p` (same order as [`EffectSignature::params`]). Must not allocate (it runs
    /// inside the fits); a non-finite value counts as 0.
    fn eval(&self, x: &[f64], p: &[f64]) -> f64;
    /// Explanatory variables the signature reads ([`VAR_NAMES`]).
    fn explanatory(&self) -> &[String] {
        &[]
    }
    /// Interface layers where the effect shows (`raw`, `detections`, `points`, ...).
    fn layer(&self) -> &[String] {
        &[]
    }
    /// Human-readable formula of the signature.
    fn signature(&self) -> &str {
        ""
    }
    /// What the id stands for; a user's effect is physics the model lacks unless it says otherwise.
    fn kind(&self) -> EffectKind {
        EffectKind::MissingPhysics
    }
    /// The osiris model switch of this effect: its own id when it is a model effect, else None.
    fn model_switch(&self) -> Option<&str> {
        (self.kind() == EffectKind::Model).then(|| self.id())
    }
    /// Campaign properties the effect needs to be a candidate (`"fmcw"`: an FMCW LiDAR campaign,
    /// `sensor.lidar_preset = "fmcw"`; `"fog"`: a finite fog visibility; `"rcs"`: a radar campaign
    /// whose power quantity is an RCS estimate); empty: every campaign of the sensor.
    fn requires(&self) -> &[String] {
        &[]
    }
    /// Effects with a similar signature on typical designs.
    fn confusable_with(&self) -> &[String] {
        &[]
    }
    /// The experiment that separates it from the confusable effects.
    fn discriminating_experiment(&self) -> &str {
        ""
    }
    /// Physics and its source.
    fn physics(&self) -> &str {
        ""
    }
    /// Nominal parameter values (identifiability check, fit start).
    fn nominal(&self) -> Vec<f64> {
        self.params().iter().map(|p| p.nominal).collect()
    }
}

/// Checks an effect's declaration; errors name the effect and the field.
pub fn validate(e: &dyn EffectSignature) -> Result<()> {
    let id = e.id();
    if id.trim().is_empty() {
        bail!("catalogue: an effect has an empty id");
    }
    if e.quantity().trim().is_empty() {
        bail!("catalogue effect `{id}`: `quantity` is empty");
    }
    if e.params().len() > MAX_PARAMS {
        bail!("catalogue effect `{id}`: at most {MAX_PARAMS} parameters");
    }
    if let Some(r) = e
        .requires()
        .iter()
        .find(|r| !["fmcw", "fog", "rcs"].contains(&r.as_str()))
    {
        bail!(
            "catalogue effect `{id}`: `requires` = `{r}`: the campaign properties are [\"fmcw\", \"fog\", \"rcs\"]"
        );
    }
    for p in e.params() {
        let [lo, hi] = p.bounds;
        if !(lo.is_finite() && hi.is_finite() && lo < hi) {
            bail!(
                "catalogue effect `{id}`: param `{}` bounds must be finite [lo, hi] with lo < hi",
                p.name
            );
        }
        if !(lo..=hi).contains(&p.nominal) {
            bail!(
                "catalogue effect `{id}`: param `{}` nominal {} outside its bounds",
                p.name,
                p.nominal
            );
        }
    }
    if e.kind() == EffectKind::Model && !is_model_effect(id) {
        bail!(
            "catalogue effect `{id}`: kind = \"model\" but the models declare no effect `{id}` \
             (`osiris effects` lists them); use kind = \"missing_physics\" for physics the model lacks"
        );
    }
    for v in e.explanatory() {
        if !VAR_NAMES.contains(&v.as_str()) {
            bail!(
                "catalogue effect `{id}`: unknown explanatory variable `{v}` (known: {})",
                VAR_NAMES.join(", ")
            );
        }
    }
    Ok(())
}

/// One TOML catalogue entry: the signature is an [`Expr`] over [`VAR_NAMES`].
#[derive(Debug, Clone, Serialize)]
pub struct Effect {
    pub id: String,
    pub layer: Vec<String>,
    pub quantity: String,
    pub explanatory: Vec<String>,
    pub signature: String,
    #[serde(skip)]
    pub expr: Expr,
    /// `expr` compiled (what [`Effect::eval`] runs).
    #[serde(skip)]
    pub program: Program,
    pub params: Vec<Param>,
    /// What the id stands for (a model effect of that name, missing physics, the measurement).
    pub kind: EffectKind,
    /// Campaign properties the effect needs ([`EffectSignature::requires`]).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub requires: Vec<String>,
    pub confusable_with: Vec<String>,
    pub discriminating_experiment: String,
    pub physics: String,
}

impl Effect {
    /// An expression effect built in code: `signature` over [`VAR_NAMES`], the constants `consts`
    /// and the parameters (`p0`, `p1` or their names).
    pub fn from_signature(
        id: &str,
        quantity: &str,
        signature: &str,
        consts: &[(String, f64)],
        params: Vec<Param>,
    ) -> Result<Effect> {
        let names: Vec<String> = params.iter().map(|p| p.name.clone()).collect();
        let expr = Expr::parse(signature, &VAR_NAMES, consts, &names)
            .with_context(|| format!("catalogue effect `{id}`"))?;
        let explanatory = VAR_NAMES
            .iter()
            .enumerate()
            .filter(|(i, _)| expr.uses_var(*i))
            .map(|(_, v)| (*v).to_owned())
            .collect();
        let e = Effect {
            id: id.to_owned(),
            layer: Vec::new(),
            quantity: quantity.to_owned(),
            explanatory,
            signature: signature.to_owned(),
            program: Program::compile(&expr),
            expr,
            params,
            kind: EffectKind::MissingPhysics,
            requires: Vec::new(),
            confusable_with: Vec::new(),
            discriminating_experiment: String::new(),
            physics: String::new(),
        };
        validate(&e)?;
        Ok(e)
    }

    /// Signature value at variables `x` and parameters `p` (0 where not finite).
    pub fn eval(&self, x: &[f64], p: &[f64]) -> f64 {
        let v = self.program.eval(x, p);
        if v.is_finite() { v } else { 0.0 }
    }

    pub fn nominal(&self) -> Vec<f64> {
        self.params.iter().map(|p| p.nominal).collect()
    }
}

impl EffectSignature for Effect {
    fn id(&self) -> &str {
        &self.id
    }
    fn quantity(&self) -> &str {
        &self.quantity
    }
    fn params(&self) -> &[Param] {
        &self.params
    }
    fn eval(&self, x: &[f64], p: &[f64]) -> f64 {
        Effect::eval(self, x, p)
    }
    fn explanatory(&self) -> &[String] {
        &self.explanatory
    }
    fn layer(&self) -> &[String] {
        &self.layer
    }
    fn signature(&self) -> &str {
        &self.signature
    }
    fn kind(&self) -> EffectKind {
        self.kind
    }
    fn requires(&self) -> &[String] {
        &self.requires
    }
    fn confusable_with(&self) -> &[String] {
        &self.confusable_with
    }
    fn discriminating_experiment(&self) -> &str {
        &self.discriminating_experiment
    }
    fn physics(&self) -> &str {
        &self.physics
    }
}

/// The documentation of one effect (what `summary.json` / `osiris effects`-like listings show).
#[derive(Debug, Clone, Serialize)]
pub struct EffectDoc {
    pub id: String,
    pub quantity: String,
    pub layer: Vec<String>,
    pub explanatory: Vec<String>,
    pub signature: String,
    pub params: Vec<Param>,
    pub kind: EffectKind,
    /// The model switch (the id itself) when `kind` is `model`.
    pub model_switch: Option<String>,
    pub confusable_with: Vec<String>,
    pub discriminating_experiment: String,
    pub physics: String,
}

impl EffectDoc {
    /// The documentation of any effect.
    pub fn of(e: &dyn EffectSignature) -> EffectDoc {
        EffectDoc {
            id: e.id().to_owned(),
            quantity: e.quantity().to_owned(),
            layer: e.layer().to_vec(),
            explanatory: e.explanatory().to_vec(),
            signature: e.signature().to_owned(),
            params: e.params().to_vec(),
            kind: e.kind(),
            model_switch: e.model_switch().map(str::to_owned),
            confusable_with: e.confusable_with().to_vec(),
            discriminating_experiment: e.discriminating_experiment().to_owned(),
            physics: e.physics().to_owned(),
        }
    }
}

/// A versioned catalogue of one sensor: the built-in TOML entries plus registered effects.
#[derive(Clone)]
pub struct Catalogue {
    pub sensor: String,
    pub version: String,
    pub effects: Vec<Arc<dyn EffectSignature>>,
}

impl std::fmt::Debug for Catalogue {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Catalogue")
            .field("sensor", &self.sensor)
            .field("version", &self.version)
            .field(
                "effects",
                &self.effects.iter().map(|e| e.id()).collect::<Vec<_>>(),
            )
            .finish()
    }
}

impl Serialize for Catalogue {
    fn serialize<S: serde::Serializer>(&self, s: S) -> std::result::Result<S::Ok, S::Error> {
        #[derive(Serialize)]
        struct View<'a> {
            sensor: &'a str,
            version: &'a str,
            effects: Vec<EffectDoc>,
        }
        View {
            sensor: &self.sensor,
            version: &self.version,
            effects: self.docs(),
        }
        .serialize(s)
    }
}

impl Catalogue {
    /// The built-in catalogue of a sensor kind. A catalogue with registered effects is passed to
    /// the workflow as a value ([`super::cli::run_with_catalogue`]).
    pub fn builtin(kind: CampaignSensor) -> Result<Catalogue> {
        match kind {
            CampaignSensor::Radar => Catalogue::parse(RADAR_TOML),
            CampaignSensor::Lidar => Catalogue::parse(LIDAR_TOML),
            CampaignSensor::Camera => Catalogue::parse(CAMERA_TOML),
        }
    }

    /// Adds a user effect (validated; its id must be new). A registered effect takes part in the
    /// attribution of its quantity like a built-in one.
    pub fn register(&mut self, effect: Box<dyn EffectSignature>) -> Result<()> {
        validate(effect.as_ref())?;
        if self.get_for(effect.id(), effect.quantity()).is_some() {
            bail!(
                "catalogue: effect `{}` on `{}` is already in the {} catalogue",
                effect.id(),
                effect.quantity(),
                self.sensor
            );
        }
        self.effects.push(Arc::from(effect));
        Ok(())
    }

    /// The entry of an id on one quantity.
    pub fn get_for(&self, id: &str, quantity: &str) -> Option<&dyn EffectSignature> {
        self.effects
            .iter()
            .find(|e| e.id() == id && e.quantity() == quantity)
            .map(|e| e.as_ref())
    }

    /// The (first) entry of an id.
    pub fn get(&self, id: &str) -> Option<&dyn EffectSignature> {
        self.effects
            .iter()
            .find(|e| e.id() == id)
            .map(|e| e.as_ref())
    }

    /// Effects acting on one quantity.
    pub fn for_quantity<'a>(
        &'a self,
        q: &'a str,
    ) -> impl Iterator<Item = &'a dyn EffectSignature> + 'a {
        self.effects
            .iter()
            .filter(move |e| e.quantity() == q)
            .map(|e| e.as_ref())
    }

    /// The catalogue a campaign is attributed with: the effects whose `requires` the campaign has.
    pub fn for_campaign(&self, campaign: &super::campaign::Campaign) -> Catalogue {
        let mut c = self.clone();
        c.effects
            .retain(|e| e.requires().iter().all(|r| campaign.has(r)));
        c
    }

    /// The documentation of every effect.
    pub fn docs(&self) -> Vec<EffectDoc> {
        self.effects
            .iter()
            .map(|e| EffectDoc::of(e.as_ref()))
            .collect()
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
        let mut effects: Vec<Arc<dyn EffectSignature>> = Vec::new();
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
            let signature = s(get(&t, "signature"), "signature")?;
            let names: Vec<String> = params.iter().map(|p| p.name.clone()).collect();
            let expr = Expr::parse(&signature, &VAR_NAMES, &consts, &names).with_context(ctx)?;
            if get(&t, "model_switch").is_some() {
                bail!(
                    "{}: `model_switch` is gone: the id is the model's switch name; say `kind = \"model\"`, \
                     `\"missing_physics\"` or `\"measurement\"`",
                    ctx()
                );
            }
            let kind_s = s(get(&t, "kind"), "kind")?;
            let kind = EffectKind::parse(&kind_s).ok_or_else(|| {
                anyhow!(
                    "{}: `kind` = `{kind_s}`: expected \"model\", \"missing_physics\" or \"measurement\"",
                    ctx()
                )
            })?;
            let effect = Effect {
                layer: strs(get(&t, "layer"), "layer")?,
                quantity: s(get(&t, "quantity"), "quantity")?,
                explanatory: strs(get(&t, "explanatory"), "explanatory")?,
                signature,
                program: Program::compile(&expr),
                expr,
                params,
                kind,
                requires: strs(get(&t, "requires"), "requires")?,
                confusable_with: strs(get(&t, "confusable_with"), "confusable_with")?,
                discriminating_experiment: s(
                    get(&t, "discriminating_experiment"),
                    "discriminating_experiment",
                )?,
                physics: s(get(&t, "physics"), "physics")?,
                id,
            };
            validate(&effect)?;
            if effects
                .iter()
                .any(|e| e.id() == effect.id && e.quantity() == effect.quantity)
            {
                bail!(
                    "catalogue: effect `{}` on `{}` is declared twice",
                    effect.id,
                    effect.quantity
                );
            }
            effects.push(Arc::new(effect));
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
    fn catalogue_ids_are_the_model_effect_names() {
        // The two lists held together: a catalogue id names a model effect exactly when it says
        // kind = "model"; anything else is marked as missing physics or a measurement property.
        let known: Vec<&str> = osiris_models::registry::catalogue()
            .iter()
            .map(|e| e.name)
            .collect();
        let mut linked = 0;
        for kind in [
            CampaignSensor::Radar,
            CampaignSensor::Lidar,
            CampaignSensor::Camera,
        ] {
            let c = Catalogue::builtin(kind).unwrap();
            assert!(c.effects.len() >= 7);
            for e in &c.effects {
                let in_model = known.contains(&e.id());
                match e.kind() {
                    EffectKind::Model => {
                        assert!(in_model, "{}: kind model, but no such model effect", e.id());
                        assert_eq!(e.model_switch(), Some(e.id()));
                        linked += 1;
                    }
                    k => {
                        assert!(
                            !in_model,
                            "{}: the model has this effect, but the catalogue marks it {}",
                            e.id(),
                            k.name()
                        );
                        assert_eq!(e.model_switch(), None);
                    }
                }
                for other in e.confusable_with() {
                    assert!(c.get(other).is_some(), "{}: {other}", e.id());
                }
            }
        }
        assert!(linked >= 20, "{linked} linked entries");
        // The names the issue found unlinked are linked now.
        let radar = Catalogue::builtin(CampaignSensor::Radar).unwrap();
        let lidar = Catalogue::builtin(CampaignSensor::Lidar).unwrap();
        for id in [
            "radar.two_way_spreading",
            "radar.ground_multipath",
            "radar.rcs_area_scaling",
            "radar.receiver_compression",
            "radar.rain_attenuation",
        ] {
            assert_eq!(radar.get(id).unwrap().kind(), EffectKind::Model, "{id}");
        }
        for id in [
            "lidar.detector_saturation",
            "lidar.dropped_rays",
            "lidar.range_walk",
            "lidar.overlap_function",
            "lidar.vertical_divergence",
            "lidar.mixed_pixels",
            "lidar.fog_extinction",
        ] {
            assert_eq!(lidar.get(id).unwrap().kind(), EffectKind::Model, "{id}");
        }
    }

    #[test]
    fn a_model_kind_needs_a_model_effect_and_model_switch_is_refused() {
        let entry = |id: &str, kind: &str| {
            format!(
                "sensor = \"radar\"\nversion = \"1\"\n[[effect]]\nid = \"{id}\"\nquantity = \"power_db\"\n\
                 signature = \"p0\"\nparams = [{{ name = \"p0\", bounds = [0.0, 1.0] }}]\nkind = \"{kind}\"\n"
            )
        };
        let err = Catalogue::parse(&entry("radar.spreading_exponent", "model")).unwrap_err();
        assert!(
            format!("{err:#}").contains("no effect `radar.spreading_exponent`"),
            "{err:#}"
        );
        assert!(Catalogue::parse(&entry("radar.radome_loss", "missing_physics")).is_ok());
        let err = Catalogue::parse(&entry("radar.radome_loss", "maybe")).unwrap_err();
        assert!(format!("{err:#}").contains("`kind`"), "{err:#}");
        let old = entry("radar.radome_loss", "missing_physics") + "model_switch = \"\"\n";
        let err = Catalogue::parse(&old).unwrap_err();
        assert!(format!("{err:#}").contains("model_switch"), "{err:#}");
    }

    #[test]
    fn ground_multipath_signature_is_the_two_way_two_ray_factor() {
        // Independent: the phasor sum of the direct and the road-image paths between a sensor at
        // height hs and a point at height ht, horizontal distance d, with Γ = −ρ and a Gaussian
        // elevation beam (one-way voltage gain exp(−2 ln2 θ²/θ₃²)), squared twice (both ways).
        let c = Catalogue::builtin(CampaignSensor::Radar).unwrap();
        let e = c.get("radar.ground_multipath").unwrap();
        let lambda = 299_792_458.0 / 77e9;
        let (hs, rho, bw) = (0.5, 0.6, 12.0);
        for (d, ht) in [(10.0, 0.45), (23.7, 0.85), (61.2, 0.65), (7.3, 1.1)] {
            let direct = f64::hypot(d, ht - hs);
            let image = f64::hypot(d, ht + hs);
            let gain = |theta_deg: f64| (-2.0 * 2f64.ln() * (theta_deg / bw).powi(2)).exp();
            let th_dir = ((ht - hs) / d).atan().to_degrees();
            let th_img = (-(ht + hs) / d).atan().to_degrees();
            let a = rho * gain(th_img) / gain(th_dir);
            let phase = 2.0 * std::f64::consts::PI * (image - direct) / lambda;
            // F = 1 − a·e^{−jφ}
            let (re, im) = (1.0 - a * phase.cos(), a * phase.sin());
            let want_db = 40.0 * (re * re + im * im).sqrt().log10();
            let mut x = [0.0; super::super::NVARS];
            x[super::super::V_RANGE] = direct;
            x[super::super::V_MOUNT_H] = hs;
            x[super::super::V_PC_H] = ht;
            x[super::super::V_WAVELENGTH] = lambda;
            let (dr, el_dir, el_img) = super::super::two_ray_geometry(direct, hs, ht);
            x[super::super::V_GROUND_DR] = dr;
            x[super::super::V_ELEV_DIR] = el_dir;
            x[super::super::V_ELEV_IMG] = el_img;
            let got = e.eval(&x, &[rho, bw]);
            assert!(
                (got - want_db).abs() < 1e-6,
                "d {d} ht {ht}: {got} vs {want_db}"
            );
        }
    }

    /// Standard normal pairs from SplitMix64 (Box–Muller), for the Monte-Carlo checks below.
    fn normals(seed: u64, n: usize) -> Vec<(f64, f64)> {
        let mut state = seed;
        let mut uniform = || {
            state = state.wrapping_add(0x9E37_79B9_7F4A_7C15);
            let mut z = state;
            z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
            z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
            ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
        };
        (0..n)
            .map(|_| {
                let (u, v) = (uniform().max(1e-300), uniform());
                let r = (-2.0 * u.ln()).sqrt();
                let a = 2.0 * std::f64::consts::PI * v;
                (r * a.cos(), r * a.sin())
            })
            .collect()
    }

    #[test]
    fn diffuse_scattering_signature_is_the_mean_log_of_a_rician_power() {
        // Independent: the mean over many frames of 10·log10|√σ_c + √σ_d·z|², z circular complex
        // Gaussian of unit power, less 10·log10 σ_c, for a flat metal face (|Γ|² = 1) of area A at
        // incidence θ with σ_d = 4(1 − e^{−(2kσ_h cos θ)²})·A·cos²θ.
        let c = Catalogue::builtin(CampaignSensor::Radar).unwrap();
        let e = c.get_for("radar.diffuse_scattering", "power_db").unwrap();
        assert_eq!(e.requires(), ["rcs"]);
        let lambda = 299_792_458.0 / 77e9;
        let k = 2.0 * std::f64::consts::PI / lambda;
        let (area, sigma_h_mm) = (0.16, 0.3);
        let z = normals(19, 200_000);
        for (aspect, sigma_c_dbsm) in [(0.0, 20.0), (10.0, -3.0), (30.0, -14.0), (50.0, -30.0)] {
            let th = f64::to_radians(aspect);
            let rho = 1.0 - (-(2.0 * k * sigma_h_mm * 1e-3 * th.cos()).powi(2)).exp();
            let sigma_d = 4.0 * rho * area * th.cos().powi(2);
            let sigma_c = 10f64.powf(sigma_c_dbsm / 10.0);
            let mean_db = z
                .iter()
                .map(|(x, y)| {
                    let re = sigma_c.sqrt() + (sigma_d / 2.0).sqrt() * x;
                    let im = (sigma_d / 2.0).sqrt() * y;
                    10.0 * (re * re + im * im).log10()
                })
                .sum::<f64>()
                / z.len() as f64;
            let want = mean_db - sigma_c_dbsm;
            let mut x = [0.0; super::super::NVARS];
            x[super::super::V_SIM] = sigma_c_dbsm;
            x[super::super::V_AREA] = area;
            x[super::super::V_ASPECT] = aspect;
            x[super::super::V_WAVELENGTH] = lambda;
            let got = e.eval(&x, &[1.0, sigma_h_mm]);
            // The Monte-Carlo mean's standard error is ≤ 5.6 dB/√(2·10⁵) = 0.013 dB.
            assert!(
                (got - want).abs() < 0.05,
                "aspect {aspect}°: signature {got:.3} dB, Monte Carlo {want:.3} dB"
            );
        }
    }

    #[test]
    fn road_clutter_signature_is_the_exceedance_count_of_constant_gamma_cells() {
        // Independent: n Rayleigh cells (exponential power of mean S̄) of a band exceed the threshold
        // T with probability exp(−T/S̄), S̄(R) = K·γ·sin ψ·(R·ΔR·Δφ)·G²/R⁴, sin ψ = h/R, G² the
        // two-way Gaussian elevation pattern exp(−8 ln2·ψ²/θ²) at the road's depression ψ.
        let c = Catalogue::builtin(CampaignSensor::Radar).unwrap();
        let e = c.get_for("radar.road_clutter", "clutter_count").unwrap();
        let (h, bw_deg, t, n) = (0.5, 12.0, 20.0, 40.0);
        let k_gamma = 3.0e4; // K·γ·ΔR·Δφ, arbitrary units
        let mean = |r: f64| {
            let psi = (h / r).asin();
            let g2 = (-8.0 * 2f64.ln() * (psi.to_degrees() / bw_deg).powi(2)).exp();
            k_gamma * (h / r) * r * g2 / r.powi(4)
        };
        let p1 = 10.0 * (t / mean(10.0)).log10();
        for r in [3.0, 5.0, 9.0, 13.0, 21.0] {
            let want = n * (-t / mean(r)).exp();
            let mut x = [0.0; super::super::NVARS];
            x[super::super::V_RANGE] = r;
            x[super::super::V_CLUTTER_DB] = crate::pairing::clutter_db(r, h, Some(bw_deg));
            let got = e.eval(&x, &[n, p1]);
            assert!(
                (got - want).abs() < 1e-9 * n.max(1.0),
                "{r} m: {got} vs {want}"
            );
        }
    }

    #[test]
    fn mounting_misalignment_signature_is_the_calibrations_correction() {
        // Standing (no Doppler information): nothing; after the first usable cycle the full yaw
        // (p1 = 0, osiris's estimator); with a prior weight p1 half of it at W = p1.
        let c = Catalogue::builtin(CampaignSensor::Radar).unwrap();
        let e = c
            .get_for("radar.mounting_misalignment", "azimuth_deg")
            .unwrap();
        assert_eq!(e.confusable_with(), ["radar.extrinsic_error"]);
        let mut x = [0.0; super::super::NVARS];
        assert_eq!(e.eval(&x, &[0.8, 0.0]), 0.0);
        x[super::super::V_CAL_W] = 25.0;
        assert!((e.eval(&x, &[0.8, 0.0]) - 0.8).abs() < 1e-12);
        assert!((e.eval(&x, &[0.8, 25.0]) - 0.4).abs() < 1e-12);
    }

    #[test]
    fn two_way_spreading_signature() {
        // DIVP model bug: R⁻² instead of R⁻⁴ is −20 dB per decade with p0 = 2.
        let c = Catalogue::builtin(CampaignSensor::Radar).unwrap();
        let e = c.get("radar.two_way_spreading").unwrap();
        let mut x = [0.0; super::super::NVARS];
        x[0] = 100.0;
        assert!((e.eval(&x, &[2.0]) + 20.0).abs() < 1e-9);
    }
}
