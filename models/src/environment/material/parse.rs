//! JSON loading of the materials database (`"schema": "osiris-materials/1"`, the schema is in the
//! [`material`](super) module doc): deserialisation with unknown keys rejected, range and energy
//! checks, wet variants derived from a water film, and errors that name the file, line and column,
//! the material and the key.

use std::collections::HashMap;
use std::fmt;

use serde::Deserialize;
use serde::de::{self, MapAccess, Visitor};

use super::*;

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawFile {
    schema: String,
    #[serde(default)]
    #[allow(dead_code)]
    description: Option<String>,
    materials: RawMaterials,
}

/// The `materials` object, in file order, duplicates rejected.
struct RawMaterials(Vec<(String, RawMaterial)>);

impl<'de> Deserialize<'de> for RawMaterials {
    fn deserialize<D: de::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V;
        impl<'de> Visitor<'de> for V {
            type Value = RawMaterials;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                f.write_str("an object of materials by name")
            }
            fn visit_map<A: MapAccess<'de>>(self, mut map: A) -> Result<RawMaterials, A::Error> {
                let mut out: Vec<(String, RawMaterial)> = Vec::new();
                while let Some(name) = map.next_key::<String>()? {
                    if out.iter().any(|(n, _)| *n == name) {
                        return Err(de::Error::custom(format!("duplicate material `{name}`")));
                    }
                    let m = map.next_value::<RawMaterial>()?;
                    out.push((name, m));
                }
                Ok(RawMaterials(out))
            }
        }
        d.deserialize_map(V)
    }
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawMaterial {
    #[serde(default)]
    description: String,
    visible: Option<RawVisible>,
    nir: Option<RawNir>,
    mmwave: Option<RawMmWave>,
    transmission: Option<RawTransmission>,
    wet_of: Option<String>,
    water_film: Option<RawWaterFilm>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawVisible {
    reflectance: Vec<f64>,
    specular: Option<RawSpecular>,
    retro: Option<RawRetro>,
    source: String,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawNir {
    #[serde(rename = "905")]
    nm905: RawBand,
    #[serde(rename = "1550")]
    nm1550: RawBand,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawBand {
    diffuse: f64,
    specular: Option<RawSpecular>,
    retro: Option<RawRetro>,
    source: String,
}

fn one() -> f64 {
    1.0
}

fn fifteen() -> f64 {
    15.0
}

#[derive(Deserialize, Clone, Copy)]
#[serde(deny_unknown_fields)]
struct RawSpecular {
    n: f64,
    #[serde(default)]
    k: f64,
    roughness: f64,
    #[serde(default = "one")]
    weight: f64,
}

#[derive(Deserialize, Clone, Copy)]
#[serde(deny_unknown_fields)]
struct RawRetro {
    peak_sr: f64,
    width_rad: f64,
    #[serde(default)]
    entrance_exponent: f64,
}

#[derive(Deserialize, Clone, Copy, PartialEq, Eq)]
#[serde(rename_all = "lowercase")]
enum RawBacking {
    Air,
    Pec,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawMmWave {
    eps_r: Option<Permittivity>,
    #[serde(default)]
    conductor: bool,
    sigma_s_per_m: Option<f64>,
    thickness_m: Option<f64>,
    backing: Option<RawBacking>,
    #[serde(default)]
    layers: Vec<RawLayer>,
    #[serde(default)]
    roughness_m: f64,
    source: String,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawLayer {
    name: String,
    eps_r: Permittivity,
    thickness_m: f64,
    source: Option<String>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawTransmission {
    thickness_m: f64,
    k_visible: Vec<f64>,
    k_905: f64,
    k_1550: f64,
    source: String,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawWaterFilm {
    thickness_m: f64,
    roughness: f64,
    mmwave_roughness_m: Option<f64>,
    #[serde(default = "one")]
    retro_factor: f64,
    #[serde(default = "fifteen")]
    temperature_c: f64,
    source: String,
}

impl<'de> Deserialize<'de> for Permittivity {
    fn deserialize<D: de::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let v = serde_json::Value::deserialize(d)?;
        permittivity_from_value(&v).map_err(de::Error::custom)
    }
}

const PERMITTIVITY_FORMS: &str = "expected [eps', eps''], {\"itu_p2040\": [a, b, c, d]}, {\"water\": \
        {\"temperature_c\": T}}, {\"cole_cole\": {\"eps_inf\", \"sigma_s_per_m\", \"terms\": [[d_eps, tau_s, \
        alpha], ...]}} or {\"table\": [[f_ghz, eps', eps''], ...]}";

fn numbers(v: &serde_json::Value, len: Option<usize>) -> Option<Vec<f64>> {
    let a = v.as_array()?;
    if len.is_some_and(|n| a.len() != n) {
        return None;
    }
    a.iter().map(|x| x.as_f64()).collect()
}

fn permittivity_from_value(v: &serde_json::Value) -> Result<Permittivity, String> {
    let bad = |what: &str| format!("invalid permittivity ({what}): {PERMITTIVITY_FORMS}");
    if v.is_array() {
        let x = numbers(v, Some(2)).ok_or_else(|| bad("not two numbers"))?;
        return Ok(Permittivity::Constant {
            re: x[0],
            loss: x[1],
        });
    }
    let obj = v
        .as_object()
        .ok_or_else(|| bad("neither an array nor an object"))?;
    if obj.len() != 1 {
        return Err(bad("an object must have exactly one key"));
    }
    let (key, val) = obj.iter().next().expect("one key");
    match key.as_str() {
        "itu_p2040" => {
            let x = numbers(val, Some(4)).ok_or_else(|| bad("itu_p2040 needs 4 numbers"))?;
            Ok(Permittivity::ItuP2040 {
                a: x[0],
                b: x[1],
                c: x[2],
                d: x[3],
            })
        }
        "water" => {
            let o = val
                .as_object()
                .ok_or_else(|| bad("water needs an object"))?;
            if o.keys().any(|k| k != "temperature_c") {
                return Err(bad("water takes only temperature_c"));
            }
            let t = match o.get("temperature_c") {
                None => 15.0,
                Some(t) => t
                    .as_f64()
                    .ok_or_else(|| bad("temperature_c must be a number"))?,
            };
            Ok(Permittivity::Water { temperature_c: t })
        }
        "cole_cole" => {
            let o = val
                .as_object()
                .ok_or_else(|| bad("cole_cole needs an object"))?;
            if o.keys()
                .any(|k| !matches!(k.as_str(), "eps_inf" | "sigma_s_per_m" | "terms"))
            {
                return Err(bad("cole_cole takes eps_inf, sigma_s_per_m and terms"));
            }
            let eps_inf = o
                .get("eps_inf")
                .and_then(|x| x.as_f64())
                .ok_or_else(|| bad("cole_cole.eps_inf missing"))?;
            let sigma = o
                .get("sigma_s_per_m")
                .map_or(Some(0.0), |x| x.as_f64())
                .ok_or_else(|| bad("sigma"))?;
            let terms = o
                .get("terms")
                .and_then(|t| t.as_array())
                .ok_or_else(|| bad("cole_cole.terms missing"))?
                .iter()
                .map(|t| {
                    numbers(t, Some(3)).map(|x| ColeColeTerm {
                        delta_eps: x[0],
                        tau_s: x[1],
                        alpha: x[2],
                    })
                })
                .collect::<Option<Vec<_>>>()
                .ok_or_else(|| bad("each term is [d_eps, tau_s, alpha]"))?;
            Ok(Permittivity::ColeCole {
                eps_inf,
                sigma_s_per_m: sigma,
                terms,
            })
        }
        "table" => {
            let rows = val
                .as_array()
                .ok_or_else(|| bad("table needs an array"))?
                .iter()
                .map(|r| numbers(r, Some(3)).map(|x| (x[0], x[1], x[2])))
                .collect::<Option<Vec<_>>>()
                .ok_or_else(|| bad("each row is [f_ghz, eps', eps'']"))?;
            if rows.is_empty() {
                return Err(bad("empty table"));
            }
            if rows.windows(2).any(|w| w[1].0 <= w[0].0) {
                return Err(bad("table frequencies must increase"));
            }
            Ok(Permittivity::Table(rows))
        }
        other => Err(bad(&format!("unknown form `{other}`"))),
    }
}

/// 1-based (line, column) of byte offset `at`.
fn line_col(text: &str, at: usize) -> (usize, usize) {
    let before = &text[..at.min(text.len())];
    let line = before.matches('\n').count() + 1;
    let column = before
        .rfind('\n')
        .map_or(before.chars().count(), |p| before[p + 1..].chars().count())
        + 1;
    (line, column)
}

/// Offset of `"key"` followed by `:` at or after `from`.
fn find_key(text: &str, key: &str, from: usize) -> Option<usize> {
    let pat = format!("\"{key}\"");
    let mut start = from;
    while let Some(p) = text.get(start..)?.find(&pat) {
        let at = start + p;
        let rest = text[at + pat.len()..].trim_start();
        if rest.starts_with(':') {
            return Some(at);
        }
        start = at + pat.len();
    }
    None
}

/// Best-effort position of `key` (dotted) inside material `material`.
fn locate(text: &str, material: &str, key: Option<&str>) -> (usize, usize) {
    let base = find_key(text, "materials", 0).unwrap_or(0);
    let Some(mut at) = find_key(text, material, base) else {
        return line_col(text, base);
    };
    if let Some(key) = key {
        for seg in key.split('.') {
            let seg = seg.split('[').next().unwrap_or(seg);
            if seg.is_empty() {
                continue;
            }
            match find_key(text, seg, at) {
                Some(p) => at = p,
                None => break,
            }
        }
    }
    line_col(text, at)
}

/// Context of one load, for errors.
struct Ctx<'a> {
    text: &'a str,
    file: &'a str,
}

impl Ctx<'_> {
    fn err(&self, material: &str, key: Option<&str>, message: impl Into<String>) -> MaterialError {
        let (line, column) = locate(self.text, material, key);
        MaterialError::Parse {
            file: self.file.to_owned(),
            line,
            column,
            material: Some(material.to_owned()),
            key: key.map(str::to_owned),
            message: message.into(),
        }
    }
}

fn check_range(
    ctx: &Ctx,
    m: &str,
    key: &str,
    v: f64,
    lo: f64,
    hi: f64,
) -> Result<f64, MaterialError> {
    if v.is_finite() && v >= lo && v <= hi {
        Ok(v)
    } else {
        Err(ctx.err(m, Some(key), format!("{v} is outside [{lo}, {hi}]")))
    }
}

fn check_source(ctx: &Ctx, m: &str, key: &str, s: &str) -> Result<String, MaterialError> {
    if s.trim().is_empty() {
        Err(ctx.err(
            m,
            Some(key),
            "empty source: every value needs its source (or `estimate: ...`)",
        ))
    } else {
        Ok(s.to_owned())
    }
}

fn lobe(ctx: &Ctx, m: &str, key: &str, s: &RawSpecular) -> Result<SpecularLobe, MaterialError> {
    check_range(ctx, m, &format!("{key}.n"), s.n, 1e-3, 100.0)?;
    check_range(ctx, m, &format!("{key}.k"), s.k, 0.0, 100.0)?;
    check_range(ctx, m, &format!("{key}.roughness"), s.roughness, 1e-4, 1.0)?;
    check_range(ctx, m, &format!("{key}.weight"), s.weight, 0.0, 1.0)?;
    Ok(SpecularLobe::new(s.n, s.k, s.roughness, s.weight))
}

fn retro(ctx: &Ctx, m: &str, key: &str, r: &RawRetro) -> Result<RetroLobe, MaterialError> {
    check_range(ctx, m, &format!("{key}.peak_sr"), r.peak_sr, 0.0, 1e7)?;
    check_range(
        ctx,
        m,
        &format!("{key}.width_rad"),
        r.width_rad,
        1e-5,
        PI / 2.0,
    )?;
    check_range(
        ctx,
        m,
        &format!("{key}.entrance_exponent"),
        r.entrance_exponent,
        0.0,
        100.0,
    )?;
    Ok(RetroLobe {
        peak_sr: r.peak_sr,
        width_rad: r.width_rad,
        entrance_exponent: r.entrance_exponent,
    })
}

fn energy(
    ctx: &Ctx,
    m: &str,
    key: &str,
    diffuse: f64,
    s: Option<&SpecularLobe>,
) -> Result<(), MaterialError> {
    if let Some(s) = s
        && diffuse > 1.0 - s.weight * s.f0 + 1e-9
    {
        return Err(ctx.err(
            m,
            Some(key),
            format!(
                "diffuse {diffuse} + specular weight × F0 {:.4} exceeds 1 (energy conservation)",
                s.weight * s.f0
            ),
        ));
    }
    Ok(())
}

fn band(ctx: &Ctx, m: &str, key: &str, b: &RawBand) -> Result<BandOptics, MaterialError> {
    let diffuse = check_range(ctx, m, &format!("{key}.diffuse"), b.diffuse, 0.0, 1.0)?;
    let specular = b
        .specular
        .as_ref()
        .map(|s| lobe(ctx, m, &format!("{key}.specular"), s))
        .transpose()?;
    energy(
        ctx,
        m,
        &format!("{key}.diffuse"),
        diffuse,
        specular.as_ref(),
    )?;
    Ok(BandOptics {
        diffuse,
        specular,
        retro: b
            .retro
            .as_ref()
            .map(|r| retro(ctx, m, &format!("{key}.retro"), r))
            .transpose()?,
        source: check_source(ctx, m, &format!("{key}.source"), &b.source)?,
    })
}

fn samples(
    ctx: &Ctx,
    m: &str,
    key: &str,
    v: &[f64],
    hi: f64,
) -> Result<[f64; VISIBLE_SAMPLES], MaterialError> {
    if v.len() != VISIBLE_SAMPLES {
        return Err(ctx.err(
            m,
            Some(key),
            format!(
                "expected {VISIBLE_SAMPLES} samples (380..=780 nm in 10 nm steps), got {}",
                v.len()
            ),
        ));
    }
    let mut out = [0.0; VISIBLE_SAMPLES];
    for (i, (o, &x)) in out.iter_mut().zip(v).enumerate() {
        *o = check_range(ctx, m, &format!("{key}[{i}]"), x, 0.0, hi)?;
    }
    Ok(out)
}

fn visible(ctx: &Ctx, m: &str, v: &RawVisible) -> Result<VisibleOptics, MaterialError> {
    let reflectance = samples(ctx, m, "visible.reflectance", &v.reflectance, 1.0)?;
    let specular = v
        .specular
        .as_ref()
        .map(|s| lobe(ctx, m, "visible.specular", s))
        .transpose()?;
    let max = reflectance.iter().copied().fold(0.0, f64::max);
    energy(ctx, m, "visible.reflectance", max, specular.as_ref())?;
    Ok(VisibleOptics {
        reflectance,
        specular,
        retro: v
            .retro
            .as_ref()
            .map(|r| retro(ctx, m, "visible.retro", r))
            .transpose()?,
        source: check_source(ctx, m, "visible.source", &v.source)?,
    })
}

fn permittivity(ctx: &Ctx, m: &str, key: &str, p: &Permittivity) -> Result<(), MaterialError> {
    let ok = match p {
        Permittivity::Constant { re, loss } => {
            re.is_finite() && *re > 0.0 && loss.is_finite() && *loss >= 0.0
        }
        Permittivity::ItuP2040 { a, b, c, d } => {
            *a > 0.0 && *c >= 0.0 && b.is_finite() && d.is_finite()
        }
        Permittivity::Water { temperature_c } => (-10.0..=60.0).contains(temperature_c),
        Permittivity::ColeCole {
            eps_inf,
            sigma_s_per_m,
            terms,
        } => {
            *eps_inf > 0.0
                && *sigma_s_per_m >= 0.0
                && terms
                    .iter()
                    .all(|t| t.delta_eps >= 0.0 && t.tau_s > 0.0 && (0.0..1.0).contains(&t.alpha))
        }
        Permittivity::Table(rows) => rows.iter().all(|r| r.0 > 0.0 && r.1 > 0.0 && r.2 >= 0.0),
        Permittivity::Conductor { sigma_s_per_m } => *sigma_s_per_m > 0.0,
    };
    if ok {
        Ok(())
    } else {
        Err(ctx.err(
            m,
            Some(key),
            format!("non-physical permittivity {p:?} (need ε' > 0, ε'' ≥ 0)"),
        ))
    }
}

fn mmwave(ctx: &Ctx, m: &str, w: &RawMmWave) -> Result<MmWave, MaterialError> {
    let eps_r = match (&w.eps_r, w.conductor) {
        (Some(_), true) => {
            return Err(ctx.err(
                m,
                Some("mmwave.eps_r"),
                "a conductor takes sigma_s_per_m, not eps_r",
            ));
        }
        (None, false) => {
            return Err(ctx.err(m, Some("mmwave"), "missing `eps_r` (or `conductor: true`)"));
        }
        (Some(e), false) => {
            permittivity(ctx, m, "mmwave.eps_r", e)?;
            Some(e.clone())
        }
        (None, true) => match w.sigma_s_per_m {
            Some(s) => {
                check_range(ctx, m, "mmwave.sigma_s_per_m", s, 1.0, 1e10)?;
                Some(Permittivity::Conductor { sigma_s_per_m: s })
            }
            None => None,
        },
    };
    if w.sigma_s_per_m.is_some() && !w.conductor {
        return Err(ctx.err(
            m,
            Some("mmwave.sigma_s_per_m"),
            "sigma_s_per_m needs `conductor: true`",
        ));
    }
    if let Some(t) = w.thickness_m {
        check_range(ctx, m, "mmwave.thickness_m", t, 1e-9, 10.0)?;
    }
    if w.backing.is_some() && w.thickness_m.is_none() {
        return Err(ctx.err(
            m,
            Some("mmwave.backing"),
            "backing needs thickness_m (a slab)",
        ));
    }
    let roughness_m = check_range(ctx, m, "mmwave.roughness_m", w.roughness_m, 0.0, 0.1)?;
    let mut layers = Vec::with_capacity(w.layers.len());
    for (i, l) in w.layers.iter().enumerate() {
        let key = format!("mmwave.layers[{i}]");
        permittivity(ctx, m, &format!("{key}.eps_r"), &l.eps_r)?;
        check_range(
            ctx,
            m,
            &format!("{key}.thickness_m"),
            l.thickness_m,
            1e-9,
            10.0,
        )?;
        layers.push(Layer {
            name: l.name.clone(),
            eps_r: l.eps_r.clone(),
            thickness_m: l.thickness_m,
            source: l.source.clone(),
        });
    }
    Ok(MmWave {
        eps_r,
        conductor: w.conductor,
        thickness_m: w.thickness_m,
        backing: match w.backing {
            Some(RawBacking::Pec) => Backing::Pec,
            _ => Backing::Air,
        },
        layers,
        roughness_m,
        source: check_source(ctx, m, "mmwave.source", &w.source)?,
    })
}

fn transmission(
    ctx: &Ctx,
    m: &str,
    t: &RawTransmission,
    bands: [&Option<SpecularLobe>; 3],
) -> Result<Transmission, MaterialError> {
    if bands.iter().any(|b| b.is_none()) {
        return Err(ctx.err(
                m,
                Some("transmission"),
                "a transmissive material needs a specular lobe in every band (its n is the slab's index)",
            ));
    }
    Ok(Transmission {
        thickness_m: check_range(
            ctx,
            m,
            "transmission.thickness_m",
            t.thickness_m,
            1e-9,
            10.0,
        )?,
        k_visible: samples(ctx, m, "transmission.k_visible", &t.k_visible, 10.0)?,
        k_905: check_range(ctx, m, "transmission.k_905", t.k_905, 0.0, 10.0)?,
        k_1550: check_range(ctx, m, "transmission.k_1550", t.k_1550, 0.0, 10.0)?,
        source: check_source(ctx, m, "transmission.source", &t.source)?,
    })
}

fn water_film(ctx: &Ctx, m: &str, f: &RawWaterFilm) -> Result<WaterFilm, MaterialError> {
    Ok(WaterFilm {
        thickness_m: check_range(ctx, m, "water_film.thickness_m", f.thickness_m, 0.0, 0.1)?,
        roughness: check_range(ctx, m, "water_film.roughness", f.roughness, 1e-4, 1.0)?,
        mmwave_roughness_m: f
            .mmwave_roughness_m
            .map(|r| check_range(ctx, m, "water_film.mmwave_roughness_m", r, 0.0, 0.1))
            .transpose()?,
        retro_factor: check_range(ctx, m, "water_film.retro_factor", f.retro_factor, 0.0, 1.0)?,
        temperature_c: check_range(
            ctx,
            m,
            "water_film.temperature_c",
            f.temperature_c,
            -10.0,
            60.0,
        )?,
        source: check_source(ctx, m, "water_film.source", &f.source)?,
    })
}

fn valid_name(name: &str) -> bool {
    !name.is_empty()
        && name
            .chars()
            .all(|c| c.is_ascii_lowercase() || c.is_ascii_digit() || c == '_')
}

/// Parse `text` and insert its materials into `db`.
pub(super) fn load(
    db: &mut MaterialDb,
    text: &str,
    file: &str,
) -> Result<Vec<MaterialId>, MaterialError> {
    let ctx = Ctx { text, file };
    let de = &mut serde_json::Deserializer::from_str(text);
    let raw: RawFile = serde_path_to_error::deserialize(de).map_err(|e| {
        let mut material = None;
        let mut key: Vec<String> = Vec::new();
        let mut in_materials = false;
        for seg in e.path().iter() {
            use serde_path_to_error::Segment;
            match seg {
                Segment::Map { key: k } if material.is_none() && in_materials => {
                    material = Some(k.clone())
                }
                Segment::Map { key: k }
                    if k == "materials" && !in_materials && material.is_none() =>
                {
                    in_materials = true
                }
                Segment::Map { key: k } if material.is_some() => key.push(k.clone()),
                Segment::Seq { index } if material.is_some() => {
                    if let Some(last) = key.last_mut() {
                        last.push_str(&format!("[{index}]"));
                    }
                }
                _ => {}
            }
        }
        let inner = e.inner();
        let mut message = inner.to_string();
        // serde_json appends " at line L column C"; the error carries them separately.
        if let Some(p) = message.rfind(" at line ") {
            message.truncate(p);
        }
        MaterialError::Parse {
            file: file.to_owned(),
            line: inner.line(),
            column: inner.column(),
            material,
            key: (!key.is_empty()).then(|| key.join(".")),
            message,
        }
    })?;
    if raw.schema != SCHEMA {
        let (line, column) = find_key(text, "schema", 0).map_or((1, 1), |p| line_col(text, p));
        return Err(MaterialError::Parse {
            file: file.to_owned(),
            line,
            column,
            material: None,
            key: Some("schema".to_owned()),
            message: format!("unsupported schema `{}` (expected `{SCHEMA}`)", raw.schema),
        });
    }

    // Pass 1: explicit materials. Pass 2: materials derived from a water film.
    let mut ids = Vec::new();
    let mut replaced: Vec<String> = Vec::new();
    let mut derived: Vec<(String, String, WaterFilm, String)> = Vec::new();
    for (name, m) in &raw.materials.0 {
        if !valid_name(name) {
            return Err(ctx.err(name, None, "material names use a-z, 0-9 and `_`"));
        }
        if parse_lambertian(name).is_some() || name.starts_with("lambertian_") {
            return Err(ctx.err(
                name,
                None,
                "`lambertian_<NN>` names are reserved for parametric materials",
            ));
        }
        if let Some(dry) = &m.wet_of
            && (dry == name || !valid_name(dry))
        {
            return Err(ctx.err(
                name,
                Some("wet_of"),
                format!("invalid dry material `{dry}`"),
            ));
        }
        if let Some(film) = &m.water_film {
            let Some(dry) = &m.wet_of else {
                return Err(ctx.err(
                    name,
                    Some("water_film"),
                    "water_film needs `wet_of` (the dry material)",
                ));
            };
            for (k, present) in [
                ("visible", m.visible.is_some()),
                ("nir", m.nir.is_some()),
                ("mmwave", m.mmwave.is_some()),
                ("transmission", m.transmission.is_some()),
            ] {
                if present {
                    return Err(ctx.err(name, Some(k), "derived from water_film: remove this key"));
                }
            }
            derived.push((
                name.clone(),
                dry.clone(),
                water_film(&ctx, name, film)?,
                m.description.clone(),
            ));
            continue;
        }
        let visible = match &m.visible {
            Some(v) => visible(&ctx, name, v)?,
            None => return Err(ctx.err(name, None, "missing key `visible`")),
        };
        let (nir905, nir1550) = match &m.nir {
            Some(n) => (
                band(&ctx, name, "nir.905", &n.nm905)?,
                band(&ctx, name, "nir.1550", &n.nm1550)?,
            ),
            None => return Err(ctx.err(name, None, "missing key `nir`")),
        };
        let mmwave = match &m.mmwave {
            Some(w) => mmwave(&ctx, name, w)?,
            None => return Err(ctx.err(name, None, "missing key `mmwave`")),
        };
        let transmission = m
            .transmission
            .as_ref()
            .map(|t| {
                transmission(
                    &ctx,
                    name,
                    t,
                    [&visible.specular, &nir905.specular, &nir1550.specular],
                )
            })
            .transpose()?;
        if db.id(name).is_some() {
            replaced.push(name.clone());
        }
        ids.push(db.insert(Material {
            name: name.clone(),
            description: m.description.clone(),
            visible,
            nir905,
            nir1550,
            mmwave,
            transmission,
            wet_of: m.wet_of.clone(),
            water_film: None,
        }));
    }
    for (name, dry, film, description) in &derived {
        let Some(dry_m) = db.by_name(dry) else {
            return Err(ctx.err(
                name,
                Some("wet_of"),
                format!("unknown dry material `{dry}`"),
            ));
        };
        if dry_m.wet_of.is_some() {
            return Err(ctx.err(
                name,
                Some("wet_of"),
                format!("`{dry}` is itself a wet variant"),
            ));
        }
        let mut wet = dry_m.with_water_film(name, film);
        if !description.is_empty() {
            wet.description = description.clone();
        }
        ids.push(db.insert(wet));
    }
    // Re-derive film-derived wet variants (from earlier loads) of replaced dry materials.
    let stale: Vec<(String, String, WaterFilm, String)> = db
        .materials
        .iter()
        .filter_map(|m| {
            let dry = m.wet_of.as_ref()?;
            let film = m.water_film.as_ref()?;
            (replaced.contains(dry) && !derived.iter().any(|d| d.0 == m.name)).then(|| {
                (
                    m.name.clone(),
                    dry.clone(),
                    film.clone(),
                    m.description.clone(),
                )
            })
        })
        .collect();
    for (name, dry, film, description) in stale {
        let mut wet = db
            .by_name(&dry)
            .expect("replaced dry material")
            .with_water_film(&name, &film);
        wet.description = description;
        db.insert(wet);
    }
    // Every wet_of must name a known dry material, with at most one wet variant each.
    let mut seen: HashMap<String, String> = HashMap::new();
    for m in &db.materials {
        if let Some(dry) = &m.wet_of {
            if db.id(dry).is_none() {
                return Err(ctx.err(
                    &m.name,
                    Some("wet_of"),
                    format!("unknown dry material `{dry}`"),
                ));
            }
            if let Some(other) = seen.insert(dry.clone(), m.name.clone()) {
                return Err(ctx.err(
                    &m.name,
                    Some("wet_of"),
                    format!("`{dry}` already has the wet variant `{other}`"),
                ));
            }
        }
    }
    Ok(ids)
}
