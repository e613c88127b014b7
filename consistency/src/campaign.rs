//! The campaign folder contract: `consistency.toml` (schema `osiris.consistency/1`).
//!
//! Loading is tolerant of unknown keys (each gives a warning naming it) and strict about required
//! keys (a missing one is an error naming `table.key`). Required: `schema`, `run.id`, `sensor.kind`,
//! `traces.sensor_view`, `traces.sensor_data`; everything else has a documented default.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use anyhow::{Context, Result, anyhow, bail};

/// The schema string campaigns and summaries carry.
pub const SCHEMA: &str = "osiris.consistency/1";

/// A TOML value reduced to what the schema needs (keeps `inf`, which JSON cannot).
#[derive(Debug, Clone, PartialEq)]
pub enum TVal {
    Str(String),
    Num(f64),
    Bool(bool),
    Arr(Vec<TVal>),
    Table(Vec<(String, TVal)>),
}

impl TVal {
    fn from_value(v: &toml_edit::Value) -> TVal {
        use toml_edit::Value as V;
        match v {
            V::String(s) => TVal::Str(s.value().clone()),
            V::Integer(i) => TVal::Num(*i.value() as f64),
            V::Float(f) => TVal::Num(*f.value()),
            V::Boolean(b) => TVal::Bool(*b.value()),
            V::Datetime(d) => TVal::Str(d.value().to_string()),
            V::Array(a) => TVal::Arr(a.iter().map(TVal::from_value).collect()),
            V::InlineTable(t) => TVal::Table(
                t.iter()
                    .map(|(k, v)| (k.to_owned(), TVal::from_value(v)))
                    .collect(),
            ),
        }
    }

    fn from_item(item: &toml_edit::Item) -> Option<TVal> {
        use toml_edit::Item;
        match item {
            Item::None => None,
            Item::Value(v) => Some(TVal::from_value(v)),
            Item::Table(t) => Some(TVal::Table(
                t.iter()
                    .filter_map(|(k, v)| TVal::from_item(v).map(|v| (k.to_owned(), v)))
                    .collect(),
            )),
            Item::ArrayOfTables(a) => Some(TVal::Arr(
                a.iter()
                    .map(|t| {
                        TVal::Table(
                            t.iter()
                                .filter_map(|(k, v)| TVal::from_item(v).map(|v| (k.to_owned(), v)))
                                .collect(),
                        )
                    })
                    .collect(),
            )),
        }
    }

    fn type_name(&self) -> &'static str {
        match self {
            TVal::Str(_) => "a string",
            TVal::Num(_) => "a number",
            TVal::Bool(_) => "a boolean",
            TVal::Arr(_) => "an array",
            TVal::Table(_) => "a table",
        }
    }
}

/// Parses TOML text into its root table entries.
pub(crate) fn parse_toml(text: &str, what: &str) -> Result<Vec<(String, TVal)>> {
    let doc: toml_edit::DocumentMut = text
        .parse()
        .map_err(|e| anyhow!("{what} is not valid TOML: {e}"))?;
    Ok(doc
        .as_table()
        .iter()
        .filter_map(|(k, v)| TVal::from_item(v).map(|v| (k.to_owned(), v)))
        .collect())
}

/// Reads keys of one table, remembering which were used so the rest can be warned about.
struct Tab<'a> {
    path: String,
    entries: &'a [(String, TVal)],
    used: std::cell::RefCell<Vec<&'a str>>,
}

impl<'a> Tab<'a> {
    fn new(path: impl Into<String>, entries: &'a [(String, TVal)]) -> Self {
        Tab {
            path: path.into(),
            entries,
            used: Default::default(),
        }
    }

    fn key(&self, k: &str) -> String {
        if self.path.is_empty() {
            k.to_owned()
        } else {
            format!("{}.{k}", self.path)
        }
    }

    fn get(&self, k: &'a str) -> Option<&'a TVal> {
        self.used.borrow_mut().push(k);
        self.entries.iter().find(|(n, _)| n == k).map(|(_, v)| v)
    }

    fn wrong(&self, k: &str, want: &str, v: &TVal) -> anyhow::Error {
        anyhow!(
            "consistency.toml: `{}` must be {want}, got {}",
            self.key(k),
            v.type_name()
        )
    }

    fn f64_opt(&self, k: &'a str) -> Result<Option<f64>> {
        match self.get(k) {
            None => Ok(None),
            Some(TVal::Num(x)) => Ok(Some(*x)),
            Some(TVal::Str(s)) if s.eq_ignore_ascii_case("inf") => Ok(Some(f64::INFINITY)),
            Some(v) => Err(self.wrong(k, "a number", v)),
        }
    }

    fn f64_or(&self, k: &'a str, default: f64) -> Result<f64> {
        Ok(self.f64_opt(k)?.unwrap_or(default))
    }

    fn str_opt(&self, k: &'a str) -> Result<Option<String>> {
        match self.get(k) {
            None => Ok(None),
            Some(TVal::Str(s)) => Ok(Some(s.clone())),
            Some(TVal::Num(x)) => Ok(Some(format!("{x}"))),
            Some(v) => Err(self.wrong(k, "a string", v)),
        }
    }

    fn str_req(&self, k: &'a str) -> Result<String> {
        self.str_opt(k)?
            .ok_or_else(|| anyhow!("consistency.toml: missing required key `{}`", self.key(k)))
    }

    fn nums_opt(&self, k: &'a str) -> Result<Option<Vec<f64>>> {
        match self.get(k) {
            None => Ok(None),
            Some(TVal::Arr(a)) => a
                .iter()
                .map(|v| match v {
                    TVal::Num(x) => Ok(*x),
                    TVal::Str(s) if s.eq_ignore_ascii_case("inf") => Ok(f64::INFINITY),
                    other => Err(self.wrong(k, "an array of numbers", other)),
                })
                .collect::<Result<Vec<_>>>()
                .map(Some),
            Some(v) => Err(self.wrong(k, "an array of numbers", v)),
        }
    }

    fn vec3_or(&self, k: &'a str, default: [f64; 3]) -> Result<[f64; 3]> {
        match self.nums_opt(k)? {
            None => Ok(default),
            Some(v) if v.len() == 3 => Ok([v[0], v[1], v[2]]),
            Some(v) => bail!(
                "consistency.toml: `{}` must have 3 numbers, got {}",
                self.key(k),
                v.len()
            ),
        }
    }

    fn strs_opt(&self, k: &'a str) -> Result<Option<Vec<String>>> {
        match self.get(k) {
            None => Ok(None),
            Some(TVal::Arr(a)) => a
                .iter()
                .map(|v| match v {
                    TVal::Str(s) => Ok(s.clone()),
                    other => Err(self.wrong(k, "an array of strings", other)),
                })
                .collect::<Result<Vec<_>>>()
                .map(Some),
            Some(TVal::Str(s)) => Ok(Some(vec![s.clone()])),
            Some(v) => Err(self.wrong(k, "an array of strings", v)),
        }
    }

    fn table_opt(&self, k: &'a str) -> Result<Option<Tab<'a>>> {
        match self.get(k) {
            None => Ok(None),
            Some(TVal::Table(t)) => Ok(Some(Tab::new(self.key(k), t))),
            Some(v) => Err(self.wrong(k, "a table", v)),
        }
    }

    /// Warnings for keys never asked for.
    fn finish(&self, warnings: &mut Vec<String>) {
        let used = self.used.borrow();
        for (k, _) in self.entries {
            if !used.contains(&k.as_str()) {
                warnings.push(format!(
                    "consistency.toml: unknown key `{}` ignored",
                    self.key(k)
                ));
            }
        }
    }
}

/// Sensor kind of a campaign.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum CampaignSensor {
    Radar,
    Lidar,
    Camera,
}

impl CampaignSensor {
    pub fn name(self) -> &'static str {
        match self {
            CampaignSensor::Radar => "radar",
            CampaignSensor::Lidar => "lidar",
            CampaignSensor::Camera => "camera",
        }
    }
}

/// `[run]`.
#[derive(Debug, Clone, Default, serde::Serialize)]
pub struct RunMeta {
    pub id: String,
    pub description: String,
    pub provenance: String,
    pub licence: String,
}

/// `[sensor]`.
#[derive(Debug, Clone, serde::Serialize)]
pub struct SensorMeta {
    pub kind: CampaignSensor,
    pub osi_sensor_id: Option<u64>,
    pub mounting_position_m: [f64; 3],
    pub mounting_orientation_rad: [f64; 3],
    // radar
    pub frequency_hz: Option<f64>,
    pub bandwidth_hz: Option<f64>,
    pub mounting_height_m: Option<f64>,
    pub polarisation: Option<String>,
    pub antenna_beamwidth_az_deg: Option<f64>,
    pub antenna_beamwidth_el_deg: Option<f64>,
    pub detection_threshold_db: Option<f64>,
    // lidar
    pub wavelength_nm: Option<f64>,
    pub beam_divergence_mrad: Option<f64>,
    pub range_accuracy_m: Option<f64>,
    /// LiDAR model preset (`osiris_models::lidar` `preset`, e.g. `"fmcw"`): the re-simulation runs
    /// it, and an `"fmcw"` campaign gets the FMCW quantities (radial velocity, per-target spreads)
    /// and the FMCW catalogue entries.
    pub lidar_preset: Option<String>,
    /// What the real sensor logged, per quantity (`rcs`, `snr`, `intensity`, ...).
    pub quantity_semantics: BTreeMap<String, String>,
    /// Model configuration JSON (absolute, resolved against the TOML's folder).
    pub model: Option<PathBuf>,
}

impl SensorMeta {
    /// The sensor's wavelength, m: c / `frequency_hz` for a radar (77 GHz when absent),
    /// `wavelength_nm` for a LiDAR (905 nm when absent), 550 nm for a camera.
    pub fn wavelength_m(&self) -> f64 {
        match self.kind {
            CampaignSensor::Radar => {
                osiris_models::constants::SPEED_OF_LIGHT_M_S / self.frequency_hz.unwrap_or(77e9)
            }
            CampaignSensor::Lidar => self.wavelength_nm.unwrap_or(905.0) * 1e-9,
            CampaignSensor::Camera => 550e-9,
        }
    }

    /// Whether the campaign is of an FMCW (coherent) LiDAR: `lidar_preset = "fmcw"`.
    pub fn is_fmcw(&self) -> bool {
        self.kind == CampaignSensor::Lidar && self.lidar_preset.as_deref() == Some("fmcw")
    }
}

impl Campaign {
    /// Whether the campaign has a property a catalogue entry `requires`: `"fmcw"` (an FMCW LiDAR,
    /// `sensor.lidar_preset = "fmcw"`), `"fog"` (a finite `environment.fog_visibility_m`), `"rcs"`
    /// (a radar whose power quantity is an RCS estimate in dBsm: `quantity_semantics` names `rcs`,
    /// or not `snr`, as the pairing reads it).
    pub fn has(&self, property: &str) -> bool {
        match property {
            "fmcw" => self.sensor.is_fmcw(),
            "rcs" => {
                let sem = &self.sensor.quantity_semantics;
                self.sensor.kind == CampaignSensor::Radar
                    && (sem.contains_key("rcs") || !sem.contains_key("snr"))
            }
            "fog" => self.environment.fog_visibility_m.is_finite(),
            _ => false,
        }
    }
}

/// `[environment]`.
#[derive(Debug, Clone, serde::Serialize)]
pub struct EnvironmentMeta {
    pub rain_mm_h: f64,
    /// Meteorological visibility, m; `inf` = clear (serialised as a string then).
    #[serde(serialize_with = "ser_inf")]
    pub fog_visibility_m: f64,
    pub temperature_c: f64,
    pub ground: Option<String>,
    pub sun_elevation_deg: Option<f64>,
    pub sun_azimuth_deg: Option<f64>,
}

fn ser_inf<S: serde::Serializer>(v: &f64, s: S) -> std::result::Result<S::Ok, S::Error> {
    if v.is_finite() {
        s.serialize_f64(*v)
    } else {
        s.serialize_str("inf")
    }
}

impl Default for EnvironmentMeta {
    fn default() -> Self {
        EnvironmentMeta {
            rain_mm_h: 0.0,
            fog_visibility_m: f64::INFINITY,
            temperature_c: 15.0,
            ground: None,
            sun_elevation_deg: None,
            sun_azimuth_deg: None,
        }
    }
}

/// `[[target]]`.
#[derive(Debug, Clone, serde::Serialize)]
pub struct TargetMeta {
    /// Ground-truth object id.
    pub id: u64,
    pub kind: String,
    /// Trihedral edge, m.
    pub edge_m: Option<f64>,
    /// Diffuse reflectivity, %.
    pub reflectivity_pct: Option<f64>,
    /// Board size [w, h], m.
    pub size_m: Option<[f64; 2]>,
    pub material: Option<String>,
    pub orientation: Option<String>,
}

impl TargetMeta {
    /// Face area, m²: trihedral a² (one face), board w·h.
    pub fn area_m2(&self) -> Option<f64> {
        if let Some(a) = self.edge_m {
            return Some(a * a);
        }
        self.size_m.map(|s| s[0] * s[1])
    }
}

/// `[uncertainty]`.
#[derive(Debug, Clone, Copy, serde::Serialize)]
pub struct UncertaintyMeta {
    pub gt_position_sigma_m: f64,
    pub gt_height_sigma_m: f64,
    pub gt_orientation_sigma_deg: f64,
}

/// Association method.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum AssociationMethod {
    ObjectId,
    Gating,
}

/// `[association]`.
#[derive(Debug, Clone, serde::Serialize)]
pub struct AssociationMeta {
    pub method: AssociationMethod,
    /// LiDAR point pairing (`beam_id`).
    pub pairing: String,
}

/// `[tolerance]`: per-quantity tolerances in natural units. Keys: `range_m`, `radial_velocity_kmh`,
/// `azimuth_deg`, `power_db` (DIVP), and for LiDAR `intensity_pct`, `intensity_db`,
/// `points_on_target_pct`, `gap_points`, for radar `clutter_count` (osiris defaults, guessed: see
/// [`Tolerances::default`]).
#[derive(Debug, Clone, Copy, serde::Serialize)]
pub struct Tolerances {
    pub range_m: f64,
    pub radial_velocity_kmh: f64,
    pub azimuth_deg: f64,
    /// Elevation, deg (camera detection campaigns; default: the azimuth's 1°, guessed).
    pub elevation_deg: f64,
    pub power_db: f64,
    pub intensity_pct: f64,
    pub intensity_db: f64,
    pub points_on_target_pct: f64,
    pub gap_points: f64,
    /// Radar clutter detections per 2 m range band and frame (osiris default 1, guessed).
    pub clutter_count: f64,
    /// Camera ROI mean, % of the simulated signal above black (osiris default 5 %, guessed).
    pub roi_mean_pct: f64,
    /// Camera ROI variance, % of the simulated variance (osiris default 20 %, guessed).
    pub roi_variance_pct: f64,
    /// Camera ROI mean in DN (attribution); absent (`inf`): `roi_mean_pct` × the median simulated
    /// signal of the lit ROIs, set by `camera.rs`.
    pub roi_mean_dn: f64,
    /// Camera detections: screen width and height of the boxes, % of the simulated (osiris
    /// default 10 %, guessed: ≈ 1 px on a 10 px box).
    pub screen_size_pct: f64,
    /// Camera detections: the recognition distance, % of the simulated (osiris default 5 %,
    /// guessed; DIVP's Prius ahead differed by 1.3 %: 22.94 m real, 23.25 m simulated).
    pub recognition_distance_pct: f64,
}

impl Default for Tolerances {
    /// DIVP FY2019 radar tolerances (validation.md §2); LiDAR values are osiris guesses: intensity
    /// ±10 % / ±3 dB, points on target ±20 % (Haider et al. 2022 reached 8.5 % MAPE), 1 gap point
    /// per frame; radar clutter 1 detection per 2 m range band and frame.
    fn default() -> Self {
        Tolerances {
            range_m: 0.30,
            radial_velocity_kmh: 0.3,
            azimuth_deg: 1.0,
            elevation_deg: 1.0,
            power_db: 5.0,
            intensity_pct: 10.0,
            intensity_db: 3.0,
            points_on_target_pct: 20.0,
            gap_points: 1.0,
            clutter_count: 1.0,
            roi_mean_pct: 5.0,
            roi_variance_pct: 20.0,
            roi_mean_dn: f64::INFINITY,
            screen_size_pct: 10.0,
            recognition_distance_pct: 5.0,
        }
    }
}

/// `[bins]`: bin edges of the explanatory variables.
#[derive(Debug, Clone, serde::Serialize)]
pub struct BinsMeta {
    pub range_m: Vec<f64>,
    pub azimuth_deg: Vec<f64>,
    pub incidence_deg: Vec<f64>,
    pub reflectivity_pct: Vec<f64>,
    pub explanatory: Vec<String>,
}

impl Default for BinsMeta {
    fn default() -> Self {
        BinsMeta {
            range_m: vec![0.0, 5.0, 10.0, 20.0, 40.0, 80.0, 160.0, 320.0],
            azimuth_deg: vec![-60.0, -20.0, -10.0, -3.0, 3.0, 10.0, 20.0, 60.0],
            incidence_deg: vec![0.0, 15.0, 30.0, 45.0, 60.0, 90.0],
            reflectivity_pct: vec![0.0, 20.0, 60.0, 100.0, 255.0],
            explanatory: vec!["range".into(), "azimuth".into()],
        }
    }
}

/// `[split]`.
#[derive(Debug, Clone, serde::Serialize)]
pub struct SplitMeta {
    /// CV groups: `target`, `station`, `frame`.
    pub cv_group_by: Vec<String>,
    pub holdout_fraction: f64,
    pub seed: u64,
}

/// A loaded campaign.
#[derive(Debug, Clone, serde::Serialize)]
pub struct Campaign {
    /// Folder of the TOML (trace paths are relative to it).
    pub dir: PathBuf,
    pub run: RunMeta,
    pub sensor: SensorMeta,
    pub environment: EnvironmentMeta,
    pub targets: Vec<TargetMeta>,
    pub uncertainty: UncertaintyMeta,
    pub association: AssociationMeta,
    pub tolerance: Tolerances,
    pub bins: BinsMeta,
    pub split: SplitMeta,
    pub sensor_view: PathBuf,
    pub sensor_data: PathBuf,
    /// A camera campaign of detections (a `traces.sensor_data` trace of camera detections and no
    /// RAW `[[frame]]`s): the directions of the detected objects' image boxes pair with the
    /// ground truth like a radar's detections (`pairing.rs`), for the mounting and timing effects.
    /// A camera campaign with RAW frames is radiometric (`camera.rs`).
    pub camera_detections: bool,
    /// Unknown keys and other non-fatal remarks.
    pub warnings: Vec<String>,
}

impl Campaign {
    /// Loads `consistency.toml` from a file.
    pub fn load(path: &Path) -> Result<Campaign> {
        let text = std::fs::read_to_string(path)
            .with_context(|| format!("cannot read campaign `{}`", path.display()))?;
        let dir = path
            .parent()
            .map(Path::to_path_buf)
            .unwrap_or_else(|| PathBuf::from("."));
        Campaign::parse(&text, &dir).with_context(|| format!("campaign `{}`", path.display()))
    }

    /// The target with a ground-truth id.
    pub fn target(&self, id: u64) -> Option<&TargetMeta> {
        self.targets.iter().find(|t| t.id == id)
    }

    /// Parses the TOML text; relative paths resolve against `dir`.
    pub fn parse(text: &str, dir: &Path) -> Result<Campaign> {
        let root_entries = parse_toml(text, "consistency.toml")?;
        let root = Tab::new("", &root_entries);
        let mut warnings = Vec::new();
        let schema = root.str_req("schema")?;
        if schema != SCHEMA {
            bail!("consistency.toml: `schema` is `{schema}`, this osiris reads `{SCHEMA}`");
        }
        let empty: Vec<(String, TVal)> = Vec::new();
        let req_table = |k: &'static str| -> Result<Tab<'_>> {
            root.table_opt(k)?
                .ok_or_else(|| anyhow!("consistency.toml: missing required table `[{k}]`"))
        };
        let opt_table = |k: &'static str| -> Result<Tab<'_>> {
            Ok(root.table_opt(k)?.unwrap_or_else(|| Tab::new(k, &empty)))
        };

        // [run]
        let t = req_table("run")?;
        let run = RunMeta {
            id: t.str_req("id")?,
            description: t.str_opt("description")?.unwrap_or_default(),
            provenance: t.str_opt("provenance")?.unwrap_or_default(),
            licence: t.str_opt("licence")?.unwrap_or_default(),
        };
        t.finish(&mut warnings);

        // [sensor]
        let t = req_table("sensor")?;
        let kind = match t.str_req("kind")?.as_str() {
            "radar" => CampaignSensor::Radar,
            "lidar" => CampaignSensor::Lidar,
            "camera" => CampaignSensor::Camera,
            other => bail!(
                "consistency.toml: `sensor.kind` must be \"radar\", \"lidar\" or \"camera\", got `{other}`"
            ),
        };
        let osi_sensor_id = match t.f64_opt("osi_sensor_id")? {
            Some(v) if v >= 0.0 && v.fract() == 0.0 => Some(v as u64),
            Some(v) => bail!(
                "consistency.toml: `sensor.osi_sensor_id` must be a non-negative integer, got {v}"
            ),
            None => None,
        };
        let mut quantity_semantics = BTreeMap::new();
        if let Some(q) = t.table_opt("quantity_semantics")? {
            for (k, v) in q.entries {
                match v {
                    TVal::Str(s) => {
                        quantity_semantics.insert(k.clone(), s.clone());
                    }
                    other => bail!(
                        "consistency.toml: `sensor.quantity_semantics.{k}` must be a string, got {}",
                        other.type_name()
                    ),
                }
            }
        }
        let sensor = SensorMeta {
            kind,
            osi_sensor_id,
            mounting_position_m: t.vec3_or("mounting_position_m", [0.0; 3])?,
            mounting_orientation_rad: t.vec3_or("mounting_orientation_rad", [0.0; 3])?,
            frequency_hz: t.f64_opt("frequency_hz")?,
            bandwidth_hz: t.f64_opt("bandwidth_hz")?,
            mounting_height_m: t.f64_opt("mounting_height_m")?,
            polarisation: t.str_opt("polarisation")?,
            antenna_beamwidth_az_deg: t.f64_opt("antenna_beamwidth_az_deg")?,
            antenna_beamwidth_el_deg: t.f64_opt("antenna_beamwidth_el_deg")?,
            detection_threshold_db: t.f64_opt("detection_threshold_db")?,
            wavelength_nm: t.f64_opt("wavelength_nm")?,
            beam_divergence_mrad: t.f64_opt("beam_divergence_mrad")?,
            range_accuracy_m: t.f64_opt("range_accuracy_m")?,
            lidar_preset: t.str_opt("lidar_preset")?,
            quantity_semantics,
            model: t.str_opt("model")?.map(|p| dir.join(p)),
        };
        if let Some(p) = sensor.lidar_preset.as_deref() {
            const PRESETS: [&str; 3] = ["vls128", "vlp16", "fmcw"];
            if kind != CampaignSensor::Lidar || !PRESETS.contains(&p) {
                bail!(
                    "consistency.toml: `sensor.lidar_preset` = `{p}`: a LiDAR campaign's preset, one of {PRESETS:?}"
                );
            }
        }
        if kind == CampaignSensor::Camera {
            // Read (and checked) by `camera::CameraCampaign`.
            super::camera::SENSOR_KEYS.iter().for_each(|k| _ = t.get(k));
            super::camera::ROOT_KEYS
                .iter()
                .for_each(|k| _ = root.get(k));
        }
        t.finish(&mut warnings);

        // [environment]
        let t = opt_table("environment")?;
        let d = EnvironmentMeta::default();
        let (mut sun_el, mut sun_az) = (None, None);
        if let Some(sun) = t.table_opt("sun")? {
            sun_el = sun.f64_opt("elevation_deg")?;
            sun_az = sun.f64_opt("azimuth_deg")?;
            sun.finish(&mut warnings);
        }
        let environment = EnvironmentMeta {
            rain_mm_h: t.f64_or("rain_mm_h", d.rain_mm_h)?,
            fog_visibility_m: t.f64_or("fog_visibility_m", d.fog_visibility_m)?,
            temperature_c: t.f64_or("temperature_c", d.temperature_c)?,
            ground: t.str_opt("ground")?,
            sun_elevation_deg: sun_el,
            sun_azimuth_deg: sun_az,
        };
        t.finish(&mut warnings);
        if !(environment.rain_mm_h >= 0.0 && environment.rain_mm_h.is_finite()) {
            bail!("consistency.toml: `environment.rain_mm_h` must be a finite number >= 0");
        }
        if environment.fog_visibility_m.is_nan() || environment.fog_visibility_m <= 0.0 {
            bail!("consistency.toml: `environment.fog_visibility_m` must be > 0 (or inf)");
        }

        // [[target]]
        let mut targets = Vec::new();
        match root.get("target") {
            None => {}
            Some(TVal::Arr(list)) => {
                for (i, item) in list.iter().enumerate() {
                    let TVal::Table(entries) = item else {
                        bail!("consistency.toml: `target[{i}]` must be a table");
                    };
                    let t = Tab::new(format!("target[{i}]"), entries);
                    let id = t.f64_opt("id")?.ok_or_else(|| {
                        anyhow!("consistency.toml: missing required key `target[{i}].id`")
                    })?;
                    if !(id >= 0.0 && id.fract() == 0.0) {
                        bail!("consistency.toml: `target[{i}].id` must be a non-negative integer");
                    }
                    let size_m = match t.nums_opt("size_m")? {
                        None => None,
                        Some(v) if v.len() == 2 => Some([v[0], v[1]]),
                        Some(_) => {
                            bail!("consistency.toml: `target[{i}].size_m` must be [w, h]")
                        }
                    };
                    targets.push(TargetMeta {
                        id: id as u64,
                        kind: t.str_req("kind")?,
                        edge_m: t.f64_opt("edge_m")?,
                        reflectivity_pct: t.f64_opt("reflectivity_pct")?,
                        size_m,
                        material: t.str_opt("material")?,
                        orientation: t.str_opt("orientation")?,
                    });
                    t.finish(&mut warnings);
                }
            }
            Some(v) => bail!(
                "consistency.toml: `target` must be an array of tables ([[target]]), got {}",
                v.type_name()
            ),
        }

        // [uncertainty]
        let t = opt_table("uncertainty")?;
        let uncertainty = UncertaintyMeta {
            gt_position_sigma_m: t.f64_or("gt_position_sigma_m", 0.0)?,
            gt_height_sigma_m: t.f64_or("gt_height_sigma_m", 0.0)?,
            gt_orientation_sigma_deg: t.f64_or("gt_orientation_sigma_deg", 0.0)?,
        };
        t.finish(&mut warnings);

        // [association]
        let t = opt_table("association")?;
        let method = match t.str_opt("method")?.as_deref() {
            None | Some("object_id") => AssociationMethod::ObjectId,
            Some("gating") => AssociationMethod::Gating,
            Some(other) => bail!(
                "consistency.toml: `association.method` must be \"object_id\" or \"gating\", got `{other}`"
            ),
        };
        let association = AssociationMeta {
            method,
            pairing: t.str_opt("pairing")?.unwrap_or_else(|| "beam_id".into()),
        };
        t.finish(&mut warnings);

        // [tolerance]
        let t = opt_table("tolerance")?;
        let d = Tolerances::default();
        let tolerance = Tolerances {
            range_m: t.f64_or("range_m", d.range_m)?,
            radial_velocity_kmh: t.f64_or("radial_velocity_kmh", d.radial_velocity_kmh)?,
            azimuth_deg: t.f64_or("azimuth_deg", d.azimuth_deg)?,
            elevation_deg: t.f64_or("elevation_deg", d.elevation_deg)?,
            power_db: t.f64_or("power_db", d.power_db)?,
            intensity_pct: t.f64_or("intensity_pct", d.intensity_pct)?,
            intensity_db: t.f64_or("intensity_db", d.intensity_db)?,
            points_on_target_pct: t.f64_or("points_on_target_pct", d.points_on_target_pct)?,
            gap_points: t.f64_or("gap_points", d.gap_points)?,
            clutter_count: t.f64_or("clutter_count", d.clutter_count)?,
            roi_mean_pct: t.f64_or("roi_mean_pct", d.roi_mean_pct)?,
            roi_variance_pct: t.f64_or("roi_variance_pct", d.roi_variance_pct)?,
            roi_mean_dn: t.f64_or("roi_mean_dn", d.roi_mean_dn)?,
            screen_size_pct: t.f64_or("screen_size_pct", d.screen_size_pct)?,
            recognition_distance_pct: t
                .f64_or("recognition_distance_pct", d.recognition_distance_pct)?,
        };
        t.finish(&mut warnings);
        for (k, v) in [
            ("range_m", tolerance.range_m),
            ("radial_velocity_kmh", tolerance.radial_velocity_kmh),
            ("azimuth_deg", tolerance.azimuth_deg),
            ("elevation_deg", tolerance.elevation_deg),
            ("power_db", tolerance.power_db),
            ("intensity_pct", tolerance.intensity_pct),
            ("intensity_db", tolerance.intensity_db),
            ("points_on_target_pct", tolerance.points_on_target_pct),
            ("gap_points", tolerance.gap_points),
            ("clutter_count", tolerance.clutter_count),
            ("roi_mean_pct", tolerance.roi_mean_pct),
            ("roi_variance_pct", tolerance.roi_variance_pct),
            ("screen_size_pct", tolerance.screen_size_pct),
            (
                "recognition_distance_pct",
                tolerance.recognition_distance_pct,
            ),
        ] {
            if !(v > 0.0 && v.is_finite()) {
                bail!("consistency.toml: `tolerance.{k}` must be a finite number > 0, got {v}");
            }
        }

        // [bins]
        let t = opt_table("bins")?;
        let d = BinsMeta::default();
        let edges = |k: &'static str, d: Vec<f64>| -> Result<Vec<f64>> {
            let v = t.nums_opt(k)?.unwrap_or(d);
            if v.len() < 2
                || v.windows(2)
                    .any(|w| w[1].partial_cmp(&w[0]) != Some(std::cmp::Ordering::Greater))
            {
                bail!("consistency.toml: `bins.{k}` must be at least 2 increasing bin edges");
            }
            Ok(v)
        };
        let bins = BinsMeta {
            range_m: edges("range_m", d.range_m)?,
            azimuth_deg: edges("azimuth_deg", d.azimuth_deg)?,
            incidence_deg: edges("incidence_deg", d.incidence_deg)?,
            reflectivity_pct: edges("reflectivity_pct", d.reflectivity_pct)?,
            explanatory: t.strs_opt("explanatory")?.unwrap_or(d.explanatory),
        };
        t.finish(&mut warnings);

        // [split]
        let t = opt_table("split")?;
        let split = SplitMeta {
            cv_group_by: t
                .strs_opt("cv_group_by")?
                .unwrap_or_else(|| vec!["target".into()]),
            holdout_fraction: t.f64_or("holdout_fraction", 0.3)?,
            seed: t.f64_or("seed", 1.0)?.max(0.0) as u64,
        };
        t.finish(&mut warnings);
        if !(0.0..1.0).contains(&split.holdout_fraction) {
            bail!("consistency.toml: `split.holdout_fraction` must be in [0, 1)");
        }
        for g in &split.cv_group_by {
            if !["target", "station", "frame"].contains(&g.as_str()) {
                bail!(
                    "consistency.toml: `split.cv_group_by` entries must be \"target\", \"station\" or \"frame\", got `{g}`"
                );
            }
        }

        // [traces]
        let t = req_table("traces")?;
        let sensor_view = dir.join(t.str_req("sensor_view")?);
        // Camera campaigns carry RAW frames (`[[frame]]`) or a SensorData trace of detections.
        let mut camera_detections = false;
        let sensor_data = match kind {
            CampaignSensor::Camera => {
                let trace = t.str_opt("sensor_data")?;
                camera_detections = trace.is_some() && root.get("frame").is_none();
                dir.join(trace.unwrap_or_default())
            }
            _ => dir.join(t.str_req("sensor_data")?),
        };
        t.finish(&mut warnings);

        root.finish(&mut warnings);
        Ok(Campaign {
            dir: dir.to_path_buf(),
            run,
            sensor,
            environment,
            targets,
            uncertainty,
            association,
            tolerance,
            bins,
            split,
            sensor_view,
            sensor_data,
            camera_detections,
            warnings,
        })
    }
}
