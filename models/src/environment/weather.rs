//! Weather: rain and fog extinction per sensor band, clear-air gaseous absorption at 76–81 GHz,
//! and the road wetness state.
//!
//! Every extinction coefficient here is a **power** extinction coefficient σ in m⁻¹ (or km⁻¹):
//! one-way transmittance `T = exp(−σ R)`, two-way `T² = exp(−2σR)`. Specific attenuation in dB/km
//! is `γ = 10·log₁₀(e)·σ[km⁻¹] ≈ 4.343 σ` ([`db_per_km_to_per_m`], [`per_m_to_db_per_km`]).
//!
//! | band | fog | rain | clear air |
//! |---|---|---|---|
//! | visible, 905 nm, 1550 nm | Kim (2001) wavelength scaling of Koschmieder 3.912/V ([`fog_extinction_per_km`]) | ITU-R P.1814 1.076 R^0.67 dB/km (**UNVERIFIED** coefficient, see [`rain_extinction_optical_db_per_km`]) | not modelled (molecular scattering ≪ 0.1 dB/km) |
//! | 76–81 GHz | ITU-R P.840 liquid-water model ([`fog_attenuation_mmwave_db_per_km`]) | ITU-R P.838-3 ([`rain_attenuation_mmwave_db_per_km`]) | ITU-R P.676 values at 77/79 GHz ([`gas_attenuation_mmwave_db_per_km`]) |
//!
//! Sources: physics.md §1.4 (P.838-3), §1.5 (P.676, P.840), §2.4 (fog: Koschmieder, Kruse, Kim),
//! §2.5 (rain at 905/1550 nm). Fog backscatter, rain clutter, drop echoes and spray are separate
//! effects, not handled here.

use serde::{Deserialize, Deserializer, Serialize, Serializer};

use crate::effects::{EffectInfo, Effects};

/// Fog extinction (Koschmieder 3.912/V scaled by Kim's wavelength law; P.840 at mm-wave).
pub const FOG_EXTINCTION: EffectInfo = EffectInfo {
    name: "env.fog_extinction",
    default_on: true,
    summary: "fog extinction: σ = (3.912/V)(λ/550 nm)^−q (Kim q(V)) optical; γ = K_l(f,T)·M(V) dB/km at mm-wave",
    source: "Kim et al., Proc. SPIE 4214:26 (2001); ITU-R P.1814; ITU-R P.840-7 (physics.md §2.4, §1.5)",
    requires: None,
};

/// Rain extinction (P.1814 optical, P.838-3 mm-wave).
pub const RAIN_EXTINCTION: EffectInfo = EffectInfo {
    name: "env.rain_extinction",
    default_on: true,
    summary: "rain extinction: γ = 1.076·R^0.67 dB/km optical/NIR; γ = k·R^α dB/km (P.838-3, horizontal pol.) at mm-wave",
    source: "ITU-R P.1814 (coefficient UNVERIFIED); ITU-R P.838-3 (physics.md §2.5, §1.4)",
    requires: None,
};

/// Clear-air gaseous absorption (O₂ + H₂O) at mm-wave.
pub const ATMOSPHERIC_ABSORPTION: EffectInfo = EffectInfo {
    name: "env.atmospheric_absorption",
    default_on: true,
    summary: "gaseous absorption at 76–81 GHz: γ = γ_O2 + γ_H2O·(ρ/7.5 g/m³), 0.098 + 0.251 dB/km at 77 GHz (std. atm.)",
    source: "ITU-R P.676-12 line-by-line values (physics.md §1.5)",
    requires: None,
};

/// Wet road: the road surface uses the wet material variants.
pub const WET_ROAD: EffectInfo = EffectInfo {
    name: "env.wet_road",
    default_on: true,
    summary: "wet road: road/marking materials switch to their wet variants (damp, wet, water film)",
    source: "materials database wet variants (Kerekes et al., Opt. Eng. 47(10):106201, 2008; physics.md §3.4)",
    requires: None,
};

/// The effects declared by this module.
pub const EFFECTS: &[EffectInfo] = &[
    FOG_EXTINCTION,
    RAIN_EXTINCTION,
    ATMOSPHERIC_ABSORPTION,
    WET_ROAD,
];

/// 10·log₁₀(e): dB per neper of power.
const DB_PER_NEPER: f64 = 4.342_944_819_032_518;

/// Specific attenuation in dB/km → power extinction coefficient in m⁻¹.
pub fn db_per_km_to_per_m(db_per_km: f64) -> f64 {
    db_per_km / DB_PER_NEPER / 1000.0
}

/// Power extinction coefficient in m⁻¹ → specific attenuation in dB/km.
pub fn per_m_to_db_per_km(per_m: f64) -> f64 {
    per_m * 1000.0 * DB_PER_NEPER
}

/// One-way power transmittance `exp(−σ R)` over `range_m` (σ in m⁻¹).
pub fn one_way_transmittance(extinction_per_m: f64, range_m: f64) -> f64 {
    (-extinction_per_m * range_m).exp()
}

/// Two-way (out and back) power transmittance `exp(−2 σ R)` over `range_m` (σ in m⁻¹).
pub fn two_way_transmittance(extinction_per_m: f64, range_m: f64) -> f64 {
    (-2.0 * extinction_per_m * range_m).exp()
}

// ---------------------------------------------------------------------------------------------
// Fog, optical
// ---------------------------------------------------------------------------------------------

/// Koschmieder constant for the 2 % contrast threshold: σ = 3.912/V (physics.md §2.4). The WMO
/// MOR definition (5 %) would give 2.996/V.
pub const KOSCHMIEDER_2PCT: f64 = 3.912;

/// Visible-band reference wavelength of the visibility definition, nm.
pub const VISIBILITY_REFERENCE_NM: f64 = 550.0;

/// Wavelength-scaling law of fog/haze extinction.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum FogModel {
    /// Kim, Mcarthur, Korevaar, Proc. SPIE 4214:26 (2001), adopted by ITU-R P.1814 (default).
    #[default]
    Kim,
    /// Kruse, McGlauchlin, McQuistan, *Elements of Infrared Technology* (1962).
    Kruse,
}

/// Size-distribution exponent q(V), V in km (physics.md §2.4).
///
/// * Kim: 1.6 (V > 50 km), 1.3 (6–50 km), 0.16V + 0.34 (1–6 km), V − 0.5 (0.5–1 km), 0 (< 0.5 km).
/// * Kruse: 1.6 (V > 50 km), 1.3 (6–50 km), 0.585·V^(1/3) (< 6 km).
pub fn fog_q(visibility_km: f64, model: FogModel) -> f64 {
    let v = visibility_km;
    match model {
        FogModel::Kim => {
            if v > 50.0 {
                1.6
            } else if v > 6.0 {
                1.3
            } else if v > 1.0 {
                0.16 * v + 0.34
            } else if v > 0.5 {
                v - 0.5
            } else {
                0.0
            }
        }
        FogModel::Kruse => {
            if v > 50.0 {
                1.6
            } else if v > 6.0 {
                1.3
            } else {
                0.585 * v.cbrt()
            }
        }
    }
}

/// Fog/haze extinction coefficient at `lambda_nm` for meteorological visibility `visibility_m`,
/// km⁻¹: `σ = (3.912/V[km]) (λ/550 nm)^−q(V)` (physics.md §2.4). Infinite visibility → 0.
pub fn fog_extinction_per_km(visibility_m: f64, lambda_nm: f64, model: FogModel) -> f64 {
    if !(visibility_m.is_finite() && visibility_m > 0.0) {
        return 0.0;
    }
    let v_km = visibility_m / 1000.0;
    KOSCHMIEDER_2PCT / v_km * (lambda_nm / VISIBILITY_REFERENCE_NM).powf(-fog_q(v_km, model))
}

// ---------------------------------------------------------------------------------------------
// Rain, optical
// ---------------------------------------------------------------------------------------------

/// Rain specific attenuation in the visible and near infrared, dB/km, for rain rate R in mm/h:
/// `γ = 1.076·R^0.67` (ITU-R P.1814, after Carbonneau 1998; physics.md §2.5). Raindrops are much
/// larger than the wavelength (Q_ext ≈ 2), so the same value is used from 380 nm to 1550 nm.
///
/// **UNVERIFIED**: physics.md marks the coefficient as recalled from P.1814, not checked against the
/// Recommendation. The Marshall–Palmer cross-check ([`rain_extinction_marshall_palmer_per_km`]) is
/// ≈ 35 % higher.
pub fn rain_extinction_optical_db_per_km(rain_mm_h: f64) -> f64 {
    if rain_mm_h <= 0.0 {
        return 0.0;
    }
    1.076 * rain_mm_h.powf(0.67)
}

/// Geometric-optics rain extinction from the Marshall–Palmer drop-size distribution, km⁻¹:
/// `N(D) = N₀ e^(−ΛD)`, N₀ = 8000 m⁻³ mm⁻¹, Λ = 4.1 R^−0.21 mm⁻¹ (J. Meteor. 5:165, 1948), Q_ext = 2:
/// `σ = 2·(π/4)·N₀·2/Λ³ = π N₀/Λ³ ≈ 0.365 R^0.63 km⁻¹` (physics.md §2.5). Cross-check only.
pub fn rain_extinction_marshall_palmer_per_km(rain_mm_h: f64) -> f64 {
    if rain_mm_h <= 0.0 {
        return 0.0;
    }
    let n0_per_m3_mm = 8000.0;
    let lambda_per_mm = 4.1 * rain_mm_h.powf(-0.21);
    // π N₀ / Λ³ in mm²·m⁻³ = 1e-6 m⁻¹ = 1e-3 km⁻¹.
    std::f64::consts::PI * n0_per_m3_mm / lambda_per_mm.powi(3) * 1e-3
}

// ---------------------------------------------------------------------------------------------
// Rain, mm-wave: ITU-R P.838-3
// ---------------------------------------------------------------------------------------------

/// P.838-3 Table 1 (k_H): a_j, b_j, c_j (j = 1…4), m_k, c_k. Transcribed from ITU-Rpy
/// `itur/models/itu838.py` (`_ITU838_3_`), which is the source of the physics.md §1.4 table; the
/// tests reproduce that table at 24/76.5/77/79/81 GHz to 4 decimals.
const P838_KH: ([f64; 4], [f64; 4], [f64; 4], f64, f64) = (
    [-5.33980, -0.35351, -0.23789, -0.94158],
    [-0.10008, 1.26970, 0.86036, 0.64552],
    [1.13098, 0.45400, 0.15354, 0.16817],
    -0.18961,
    0.71147,
);
/// P.838-3 Table 2 (k_V).
const P838_KV: ([f64; 4], [f64; 4], [f64; 4], f64, f64) = (
    [-3.80595, -3.44965, -0.39902, 0.50167],
    [0.56934, -0.22911, 0.73042, 1.07319],
    [0.81061, 0.51059, 0.11899, 0.27195],
    -0.16398,
    0.63297,
);
/// P.838-3 Table 3 (α_H): a_j, b_j, c_j (j = 1…5), m_α, c_α.
const P838_AH: ([f64; 5], [f64; 5], [f64; 5], f64, f64) = (
    [-0.14318, 0.29591, 0.32177, -5.37610, 16.1721],
    [1.82442, 0.77564, 0.63773, -0.96230, -3.29980],
    [-0.55187, 0.19822, 0.13164, 1.47828, 3.43990],
    0.67849,
    -1.95537,
);
/// P.838-3 Table 4 (α_V).
const P838_AV: ([f64; 5], [f64; 5], [f64; 5], f64, f64) = (
    [-0.07771, 0.56727, -0.20238, -48.2991, 48.5833],
    [2.33840, 0.95545, 1.14520, 0.791669, 0.791459],
    [-0.76284, 0.54039, 0.26809, 0.116226, 0.116479],
    -0.053739,
    0.83433,
);

fn p838_sum(a: &[f64], b: &[f64], c: &[f64], lf: f64) -> f64 {
    a.iter()
        .zip(b)
        .zip(c)
        .map(|((a, b), c)| a * (-((lf - b) / c).powi(2)).exp())
        .sum()
}

/// P.838-3 coefficients `(k_H, α_H, k_V, α_V)` at `f_ghz` (1–1000 GHz), from the Recommendation's
/// fitting equations: `log₁₀ k = Σ_j a_j exp(−((log₁₀ f − b_j)/c_j)²) + m_k log₁₀ f + c_k` and
/// `α = Σ_j a_j exp(−((log₁₀ f − b_j)/c_j)²) + m_α log₁₀ f + c_α`.
pub fn p838_coefficients(f_ghz: f64) -> (f64, f64, f64, f64) {
    let lf = f_ghz.log10();
    let k = |t: &([f64; 4], [f64; 4], [f64; 4], f64, f64)| {
        10f64.powf(p838_sum(&t.0, &t.1, &t.2, lf) + t.3 * lf + t.4)
    };
    let a = |t: &([f64; 5], [f64; 5], [f64; 5], f64, f64)| {
        p838_sum(&t.0, &t.1, &t.2, lf) + t.3 * lf + t.4
    };
    (k(&P838_KH), a(&P838_AH), k(&P838_KV), a(&P838_AV))
}

/// P.838-3 `(k, α)` for path elevation θ and polarisation tilt τ (0° = horizontal, 90° = vertical,
/// 45° = circular): `k = [k_H + k_V + (k_H − k_V) cos²θ cos 2τ]/2`,
/// `α = [k_Hα_H + k_Vα_V + (k_Hα_H − k_Vα_V) cos²θ cos 2τ]/(2k)`.
pub fn p838_k_alpha(f_ghz: f64, elevation_deg: f64, tilt_deg: f64) -> (f64, f64) {
    let (kh, ah, kv, av) = p838_coefficients(f_ghz);
    let c = elevation_deg.to_radians().cos().powi(2) * (2.0 * tilt_deg).to_radians().cos();
    let k = (kh + kv + (kh - kv) * c) / 2.0;
    let alpha = (kh * ah + kv * av + (kh * ah - kv * av) * c) / (2.0 * k);
    (k, alpha)
}

/// Rain specific attenuation at radio frequency `f_hz`, dB/km: `γ_R = k R^α` (P.838-3).
pub fn rain_attenuation_mmwave_db_per_km(
    rain_mm_h: f64,
    f_hz: f64,
    elevation_deg: f64,
    tilt_deg: f64,
) -> f64 {
    if rain_mm_h <= 0.0 {
        return 0.0;
    }
    let (k, alpha) = p838_k_alpha(f_hz / 1e9, elevation_deg, tilt_deg);
    k * rain_mm_h.powf(alpha)
}

// ---------------------------------------------------------------------------------------------
// Fog, mm-wave: ITU-R P.840
// ---------------------------------------------------------------------------------------------

/// Liquid-water specific attenuation coefficient K_l(f, T), (dB/km)/(g/m³), ITU-R P.840-6/-7
/// Rayleigh model with the double-Debye permittivity of water (eq. 2–11):
/// θ = 300/T[K]; ε₀ = 77.66 + 103.3(θ − 1); ε₁ = 0.0671 ε₀; ε₂ = 3.52;
/// f_p = 20.20 − 146(θ − 1) + 316(θ − 1)² GHz; f_s = 39.8 f_p;
/// ε″ = f(ε₀ − ε₁)/(f_p(1 + (f/f_p)²)) + f(ε₁ − ε₂)/(f_s(1 + (f/f_s)²));
/// ε′ = (ε₀ − ε₁)/(1 + (f/f_p)²) + (ε₁ − ε₂)/(1 + (f/f_s)²) + ε₂;
/// η = (2 + ε′)/ε″; K_l = 0.819 f/(ε″(1 + η²)). Transcribed from ITU-Rpy `itu840.py`
/// (`_ITU840_6_`); the tests reproduce physics.md §1.5 (3.54 / 3.15 / 2.71 at 77 GHz).
pub fn liquid_water_coefficient(f_ghz: f64, temperature_c: f64) -> f64 {
    let theta = 300.0 / (temperature_c + 273.15);
    let eps0 = 77.66 + 103.3 * (theta - 1.0);
    let eps1 = 0.0671 * eps0;
    let eps2 = 3.52;
    let fp = 20.20 - 146.0 * (theta - 1.0) + 316.0 * (theta - 1.0).powi(2);
    let fs = 39.8 * fp;
    let (rp, rs) = (1.0 + (f_ghz / fp).powi(2), 1.0 + (f_ghz / fs).powi(2));
    let eps_pp = f_ghz * (eps0 - eps1) / (fp * rp) + f_ghz * (eps1 - eps2) / (fs * rs);
    let eps_p = (eps0 - eps1) / rp + (eps1 - eps2) / rs + eps2;
    let eta = (2.0 + eps_p) / eps_pp;
    0.819 * f_ghz / (eps_pp * (1.0 + eta * eta))
}

/// Fog liquid-water content M (g/m³) for visibility `visibility_m`: the power law through the two
/// ITU-R P.840 anchor points (0.05 g/m³ at ~300 m "medium fog", 0.5 g/m³ at ~50 m "thick fog";
/// physics.md §1.5): `M = 0.5·(V/50 m)^(−ln 10/ln 6)`. **UNVERIFIED** as a V–M relation: P.840
/// gives only the two anchor values; outside 50–300 m it is an extrapolation. Infinite V → 0.
pub fn fog_liquid_water_g_m3(visibility_m: f64) -> f64 {
    if !(visibility_m.is_finite() && visibility_m > 0.0) {
        return 0.0;
    }
    let exponent = -(10f64.ln() / 6f64.ln()); // through (50 m, 0.5) and (300 m, 0.05)
    0.5 * (visibility_m / 50.0).powf(exponent)
}

/// Fog attenuation at radio frequency `f_hz`, dB/km: `γ_c = K_l(f, T)·M(V)` (ITU-R P.840).
pub fn fog_attenuation_mmwave_db_per_km(visibility_m: f64, f_hz: f64, temperature_c: f64) -> f64 {
    liquid_water_coefficient(f_hz / 1e9, temperature_c) * fog_liquid_water_g_m3(visibility_m)
}

// ---------------------------------------------------------------------------------------------
// Clear air, mm-wave: ITU-R P.676 values
// ---------------------------------------------------------------------------------------------

/// Water-vapour density of the P.676 reference atmosphere, g/m³ (physics.md §1.5).
pub const STANDARD_WATER_VAPOUR_G_M3: f64 = 7.5;

/// Saturation vapour pressure over water, hPa: Magnus form with the Alduchov & Eskridge
/// coefficients, `6.1094 exp(17.625 T/(T + 243.04))`, T in °C (J. Appl. Meteor. 35:601, 1996).
pub fn saturation_vapour_pressure_hpa(temperature_c: f64) -> f64 {
    6.1094 * (17.625 * temperature_c / (temperature_c + 243.04)).exp()
}

/// Water-vapour density ρ = RH·e_s(T)·M_w/(R T), g/m³ (ideal gas; M_w = 18.015 g/mol,
/// R = 8.314 462 J/(mol K)). `relative_humidity` is a fraction 0…1.
pub fn water_vapour_density_g_m3(temperature_c: f64, relative_humidity: f64) -> f64 {
    let e_pa = relative_humidity * saturation_vapour_pressure_hpa(temperature_c) * 100.0;
    e_pa * 18.015 / (8.314_462_618 * (temperature_c + 273.15))
}

/// Gaseous (O₂ + H₂O) specific attenuation at radio frequency `f_hz` in the 76–81 GHz radar band,
/// dB/km, from the ITU-R P.676-12 line-by-line values quoted in physics.md §1.5 (1013.25 hPa,
/// 15 °C, 7.5 g/m³): γ_O₂ = 0.098 and γ_H₂O = 0.251 dB/km at 77 GHz, total 0.34 dB/km at 79 GHz.
///
/// The water-vapour part is scaled linearly with the vapour density (physics.md's 20 g/m³ value,
/// 0.66 dB/km, is within 2 % of this scaling); the total is scaled in frequency by linear
/// interpolation between 77 and 79 GHz and held constant outside [77, 79] GHz. **UNVERIFIED**
/// outside 77–79 GHz and for the temperature dependence of γ_O₂ (physics.md: 0.08 dB/km at 35 °C,
/// not modelled). Not valid away from the 76–81 GHz band (e.g. 24 GHz: 0.17, 60 GHz: 14.8 dB/km).
pub fn gas_attenuation_mmwave_db_per_km(f_hz: f64, water_vapour_g_m3: f64) -> f64 {
    const O2_77: f64 = 0.098;
    const H2O_77: f64 = 0.251;
    const TOTAL_79: f64 = 0.34;
    let f_ghz = (f_hz / 1e9).clamp(77.0, 79.0);
    let scale = 1.0 + (TOTAL_79 / (O2_77 + H2O_77) - 1.0) * (f_ghz - 77.0) / 2.0;
    (O2_77 + H2O_77 * water_vapour_g_m3.max(0.0) / STANDARD_WATER_VAPOUR_G_M3) * scale
}

// ---------------------------------------------------------------------------------------------
// Weather state
// ---------------------------------------------------------------------------------------------

/// Road surface water state. JSON: `"dry"`, `"damp"`, `"wet"` or `{"water_film_mm": 0.5}`.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum RoadWetness {
    #[default]
    Dry,
    /// Moist surface, no continuous film.
    Damp,
    /// Wet surface with a thin continuous film.
    Wet,
    /// Standing water film of the given thickness, mm.
    WaterFilmMm(f64),
}

impl RoadWetness {
    /// Whether the road materials should use their wet variants.
    pub fn is_wet(&self) -> bool {
        !matches!(self, RoadWetness::Dry)
    }

    /// Water film thickness when given explicitly, mm.
    pub fn water_film_mm(&self) -> Option<f64> {
        match self {
            RoadWetness::WaterFilmMm(mm) => Some(*mm),
            _ => None,
        }
    }
}

/// Errors of weather configuration.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum WeatherError {
    #[error("weather: {0}")]
    Invalid(String),
}

/// The weather of a scene. JSON fields (all optional; defaults = clear, dry, 15 °C, the P.676
/// reference humidity):
/// `{"rain_mm_h": 0, "fog_visibility_m": "inf", "temperature_c": 15, "relative_humidity": 0.59,
/// "road": "dry"}`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Weather {
    /// Rain rate, mm/h (0 = no rain).
    pub rain_mm_h: f64,
    /// Meteorological visibility of fog/haze (2 % contrast), m. `f64::INFINITY` = clear; JSON
    /// accepts a number, `"inf"`/`"infinity"` or `null` (clear), and writes `"inf"`.
    #[serde(serialize_with = "ser_visibility", deserialize_with = "de_visibility")]
    pub fog_visibility_m: f64,
    /// Air temperature, °C.
    pub temperature_c: f64,
    /// Relative humidity, fraction 0…1.
    pub relative_humidity: f64,
    /// Road surface water state.
    pub road: RoadWetness,
}

impl Default for Weather {
    fn default() -> Self {
        Weather::CLEAR
    }
}

fn ser_visibility<S: Serializer>(v: &f64, s: S) -> Result<S::Ok, S::Error> {
    if v.is_infinite() {
        s.serialize_str("inf")
    } else {
        s.serialize_f64(*v)
    }
}

fn de_visibility<'de, D: Deserializer<'de>>(d: D) -> Result<f64, D::Error> {
    #[derive(Deserialize)]
    #[serde(untagged)]
    enum NumOrStr {
        Num(f64),
        Str(String),
    }
    let v = match Option::<NumOrStr>::deserialize(d)? {
        None => f64::INFINITY,
        Some(NumOrStr::Num(v)) => v,
        Some(NumOrStr::Str(s)) => match s.trim().to_ascii_lowercase().as_str() {
            "inf" | "+inf" | "infinity" | "+infinity" => f64::INFINITY,
            other => other.parse::<f64>().map_err(|_| {
                serde::de::Error::custom(format!(
                    "fog_visibility_m: expected metres or \"inf\", got {s:?}"
                ))
            })?,
        },
    };
    if v.is_nan() || v <= 0.0 {
        return Err(serde::de::Error::custom(format!(
            "fog_visibility_m must be > 0 m, got {v}"
        )));
    }
    Ok(v)
}

impl Weather {
    /// Clear, dry weather at 15 °C with the P.676 reference vapour density (7.5 g/m³).
    pub const CLEAR: Weather = Weather {
        rain_mm_h: 0.0,
        fog_visibility_m: f64::INFINITY,
        temperature_c: 15.0,
        // 7.5 g/m³ / ρ_sat(15 °C) with the Magnus/Alduchov–Eskridge formula (12.80 g/m³); the
        // test `standard_atmosphere_humidity` recomputes it.
        relative_humidity: 0.586,
        road: RoadWetness::Dry,
    };

    /// Check the ranges: rain ≥ 0, visibility > 0, −60 … 60 °C, humidity 0…1, film ≥ 0.
    pub fn validate(&self) -> Result<(), WeatherError> {
        let bad = |m: String| Err(WeatherError::Invalid(m));
        if !(self.rain_mm_h >= 0.0 && self.rain_mm_h.is_finite()) {
            return bad(format!("rain_mm_h must be ≥ 0, got {}", self.rain_mm_h));
        }
        if self.fog_visibility_m.is_nan() || self.fog_visibility_m <= 0.0 {
            return bad(format!(
                "fog_visibility_m must be > 0, got {}",
                self.fog_visibility_m
            ));
        }
        if !(-60.0..=60.0).contains(&self.temperature_c) {
            return bad(format!(
                "temperature_c must be in −60…60 °C, got {}",
                self.temperature_c
            ));
        }
        if !(0.0..=1.0).contains(&self.relative_humidity) {
            return bad(format!(
                "relative_humidity is a fraction 0…1, got {}",
                self.relative_humidity
            ));
        }
        if let RoadWetness::WaterFilmMm(mm) = self.road
            && !(mm >= 0.0 && mm.is_finite())
        {
            return bad(format!("water_film_mm must be ≥ 0, got {mm}"));
        }
        Ok(())
    }

    /// Water-vapour density of the air, g/m³.
    pub fn water_vapour_g_m3(&self) -> f64 {
        water_vapour_density_g_m3(self.temperature_c, self.relative_humidity)
    }

    /// Road state as the scene should use it: `Dry` when `env.wet_road` is off.
    pub fn road_surface(&self, effects: &Effects) -> RoadWetness {
        if effects.is_on(&WET_ROAD) {
            self.road
        } else {
            RoadWetness::Dry
        }
    }

    /// Total power extinction coefficient in `band`, m⁻¹, all effects on.
    pub fn extinction_per_m(&self, band: Band) -> f64 {
        extinction_per_m(self, band)
    }

    /// Two-way power transmittance over `range_m` in `band`, all effects on.
    pub fn two_way_transmittance(&self, band: Band, range_m: f64) -> f64 {
        two_way_transmittance(extinction_per_m(self, band), range_m)
    }
}

/// A sensor band.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Band {
    /// Visible light at a wavelength, nm (camera: evaluate per spectral sample).
    Visible { nm: f64 },
    /// 905 nm LiDAR.
    Nir905,
    /// 1550 nm LiDAR.
    Nir1550,
    /// Radar carrier frequency, Hz (76–81 GHz); rain uses horizontal polarisation on a horizontal
    /// path (use [`rain_attenuation_mmwave_db_per_km`] for other polarisations).
    MmWave { hz: f64 },
}

impl Band {
    /// Optical wavelength, nm (`None` for mm-wave).
    pub fn wavelength_nm(&self) -> Option<f64> {
        match *self {
            Band::Visible { nm } => Some(nm),
            Band::Nir905 => Some(905.0),
            Band::Nir1550 => Some(1550.0),
            Band::MmWave { .. } => None,
        }
    }
}

/// Per-mechanism extinction, m⁻¹ (for reports and attribution).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct ExtinctionBreakdown {
    pub fog_per_m: f64,
    pub rain_per_m: f64,
    pub gas_per_m: f64,
}

impl ExtinctionBreakdown {
    /// Sum of all mechanisms, m⁻¹.
    pub fn total_per_m(&self) -> f64 {
        self.fog_per_m + self.rain_per_m + self.gas_per_m
    }
}

/// Extinction per mechanism in `band` for `weather` (each one regardless of effect switches).
pub fn extinction_breakdown(weather: &Weather, band: Band) -> ExtinctionBreakdown {
    match band.wavelength_nm() {
        Some(nm) => ExtinctionBreakdown {
            fog_per_m: fog_extinction_per_km(weather.fog_visibility_m, nm, FogModel::Kim) / 1000.0,
            rain_per_m: db_per_km_to_per_m(rain_extinction_optical_db_per_km(weather.rain_mm_h)),
            gas_per_m: 0.0,
        },
        None => {
            let Band::MmWave { hz } = band else {
                unreachable!()
            };
            ExtinctionBreakdown {
                fog_per_m: db_per_km_to_per_m(fog_attenuation_mmwave_db_per_km(
                    weather.fog_visibility_m,
                    hz,
                    weather.temperature_c,
                )),
                rain_per_m: db_per_km_to_per_m(rain_attenuation_mmwave_db_per_km(
                    weather.rain_mm_h,
                    hz,
                    0.0,
                    0.0,
                )),
                gas_per_m: db_per_km_to_per_m(gas_attenuation_mmwave_db_per_km(
                    hz,
                    weather.water_vapour_g_m3(),
                )),
            }
        }
    }
}

/// Total power extinction coefficient in `band`, m⁻¹, with every effect on.
pub fn extinction_per_m(weather: &Weather, band: Band) -> f64 {
    extinction_breakdown(weather, band).total_per_m()
}

/// Total power extinction coefficient in `band`, m⁻¹, honouring the `env.fog_extinction`,
/// `env.rain_extinction` and `env.atmospheric_absorption` switches (`effects` must declare
/// [`EFFECTS`]).
pub fn extinction_per_m_with(weather: &Weather, band: Band, effects: &Effects) -> f64 {
    let b = extinction_breakdown(weather, band);
    let on = |e: &EffectInfo, v: f64| if effects.is_on(e) { v } else { 0.0 };
    on(&FOG_EXTINCTION, b.fog_per_m)
        + on(&RAIN_EXTINCTION, b.rain_per_m)
        + on(&ATMOSPHERIC_ABSORPTION, b.gas_per_m)
}

#[cfg(test)]
mod tests {
    use super::*;

    const F77: f64 = 77e9;

    fn rel(a: f64, b: f64) -> f64 {
        (a - b).abs() / b.abs()
    }

    #[test]
    fn fog_kim_and_kruse_check_values() {
        // physics.md §2.4, Kim (km⁻¹): V = 50 m: 78.2 / 78.2; 200 m: 19.6 / 19.6; 1 km: 3.05 / 2.33;
        // 5 km: 0.44 / 0.24 at 905 / 1550 nm. Kruse at 50 m: 70.3 / 62.6.
        let k = |v: f64, l: f64| fog_extinction_per_km(v, l, FogModel::Kim);
        for (v, a905, a1550, tol) in [
            (50.0, 78.2, 78.2, 0.05),
            (200.0, 19.6, 19.6, 0.05),
            (1000.0, 3.05, 2.33, 0.005),
            (5000.0, 0.44, 0.24, 0.005),
        ] {
            assert!(
                (k(v, 905.0) - a905).abs() <= tol,
                "V {v} 905: {}",
                k(v, 905.0)
            );
            assert!(
                (k(v, 1550.0) - a1550).abs() <= tol,
                "V {v} 1550: {}",
                k(v, 1550.0)
            );
        }
        let kr = |l: f64| fog_extinction_per_km(50.0, l, FogModel::Kruse);
        assert!((kr(905.0) - 70.3).abs() <= 0.05, "{}", kr(905.0));
        assert!((kr(1550.0) - 62.6).abs() <= 0.05, "{}", kr(1550.0));
        // 78.2 km⁻¹ ≈ 340 dB/km; 20 m of V = 50 m fog transmits 0.044 two-way (−13.5 dB).
        let w = Weather {
            fog_visibility_m: 50.0,
            ..Weather::CLEAR
        };
        let s = extinction_per_m(&w, Band::Nir905);
        assert!((per_m_to_db_per_km(s) - 340.0).abs() < 0.5);
        let t = w.two_way_transmittance(Band::Nir905, 20.0);
        assert!((t - 0.044).abs() < 0.0005, "{t}");
        assert!((-10.0 * t.log10() - 13.5).abs() < 0.1);
        // Kim is continuous at its range boundaries (1 km, 6 km).
        for v in [1.0, 6.0] {
            assert!((fog_q(v - 1e-9, FogModel::Kim) - fog_q(v + 1e-9, FogModel::Kim)).abs() < 1e-6);
        }
    }

    #[test]
    fn validation_md_fog_table() {
        // validation.md §9b: one-way dB/km 849 / 340 / 170 / 85 / 34 at V = 20 / 50 / 100 / 200 /
        // 500 m (λ-independent below 500 m with Kim), two-way at 10 m 17.0 / 6.8 / 3.4 / 1.7 / 0.7 dB.
        for (v, db_km, two_way_10) in [
            (20.0, 849.0, 17.0),
            (50.0, 340.0, 6.8),
            (100.0, 170.0, 3.4),
            (200.0, 85.0, 1.7),
            (500.0, 34.0, 0.7),
        ] {
            let w = Weather {
                fog_visibility_m: v,
                ..Weather::CLEAR
            };
            for band in [Band::Visible { nm: 550.0 }, Band::Nir905, Band::Nir1550] {
                let g = per_m_to_db_per_km(extinction_per_m(&w, band));
                assert!((g - db_km).abs() <= 0.5, "V {v}: {g}");
                let l = -10.0 * w.two_way_transmittance(band, 10.0).log10();
                assert!((l - two_way_10).abs() <= 0.05, "V {v}: {l}");
            }
        }
    }

    #[test]
    fn optical_rain_check_values() {
        // physics.md §2.5: 1.08 / 3.16 / 5.03 / 9.30 / 14.8 / 23.5 dB/km at 1 / 5 / 10 / 25 / 50 / 100 mm/h.
        for (r, g) in [
            (1.0, 1.08),
            (5.0, 3.16),
            (10.0, 5.03),
            (25.0, 9.30),
            (50.0, 14.8),
            (100.0, 23.5),
        ] {
            let w = Weather {
                rain_mm_h: r,
                ..Weather::CLEAR
            };
            for band in [Band::Visible { nm: 450.0 }, Band::Nir905, Band::Nir1550] {
                let got = per_m_to_db_per_km(extinction_per_m(&w, band));
                assert!((got - g).abs() <= 0.006 * g.max(1.0), "R {r}: {got}");
            }
        }
        // Marshall–Palmer cross-check σ = 0.365 R^0.63 km⁻¹, ≈ 35 % above P.1814.
        for r in [1.0, 10.0, 100.0] {
            let mp = rain_extinction_marshall_palmer_per_km(r);
            assert!(rel(mp, 0.365 * f64::powf(r, 0.63)) < 0.01, "{mp}");
            let ratio = mp * DB_PER_NEPER / rain_extinction_optical_db_per_km(r);
            assert!(ratio > 1.2 && ratio < 1.6, "{ratio}");
        }
    }

    #[test]
    fn p838_coefficient_table() {
        // physics.md §1.4 table (P.838-3 fitting formulae via ITU-Rpy): k_H α_H k_V α_V.
        let table = [
            (24.0, 0.1425, 1.0101, 0.1404, 0.9561),
            (76.5, 1.1253, 0.7188, 1.1208, 0.7082),
            (77.0, 1.1320, 0.7177, 1.1276, 0.7073),
            (79.0, 1.1579, 0.7135, 1.1541, 0.7038),
            (81.0, 1.1827, 0.7096, 1.1793, 0.7004),
        ];
        for (f, kh, ah, kv, av) in table {
            let (k_h, a_h, k_v, a_v) = p838_coefficients(f);
            for (got, want) in [(k_h, kh), (a_h, ah), (k_v, kv), (a_v, av)] {
                assert!((got - want).abs() <= 6e-5, "{f} GHz: {got} vs {want}");
            }
        }
        // Horizontal/vertical limits of the polarisation formula.
        let (kh, ah, kv, av) = p838_coefficients(77.0);
        let (k, a) = p838_k_alpha(77.0, 0.0, 0.0);
        assert!((k - kh).abs() < 1e-12 && (a - ah).abs() < 1e-12);
        let (k, a) = p838_k_alpha(77.0, 0.0, 90.0);
        assert!((k - kv).abs() < 1e-12 && (a - av).abs() < 1e-12);
    }

    #[test]
    fn mmwave_rain_check_values() {
        // physics.md §1.4 at 77 GHz, H / V dB/km: 1 → 1.13/1.13; 5 → 3.59/3.52; 10 → 5.91/5.75;
        // 25 → 11.4/11.0; 50 → 18.8/17.9; 100 → 30.8/29.3.
        let table = [
            (1.0, 1.13, 1.13),
            (5.0, 3.59, 3.52),
            (10.0, 5.91, 5.75),
            (25.0, 11.4, 11.0),
            (50.0, 18.8, 17.9),
            (100.0, 30.8, 29.3),
        ];
        for (r, h, v) in table {
            let gh = rain_attenuation_mmwave_db_per_km(r, F77, 0.0, 0.0);
            let gv = rain_attenuation_mmwave_db_per_km(r, F77, 0.0, 90.0);
            let tol = if h < 10.0 { 0.005 } else { 0.05 };
            assert!((gh - h).abs() <= tol, "R {r} H: {gh}");
            assert!((gv - v).abs() <= tol, "R {r} V: {gv}");
        }
        // Two-way over 100 m at 25 mm/h ≈ 2.3 dB (validation.md: 2.28 dB); Band::MmWave is H-pol.
        let w = Weather {
            rain_mm_h: 25.0,
            ..Weather::CLEAR
        };
        let mut e = Effects::new(EFFECTS);
        e.set("env.atmospheric_absorption", false).unwrap();
        let s = extinction_per_m_with(&w, Band::MmWave { hz: F77 }, &e);
        let loss = -10.0 * two_way_transmittance(s, 100.0).log10();
        assert!((loss - 2.28).abs() < 0.01, "{loss}");
    }

    #[test]
    fn mmwave_fog_and_gas() {
        // P.840 K_l at 77 GHz: 3.54 (0 °C), 3.15 (10 °C), 2.71 (20 °C) (dB/km)/(g/m³).
        for (t, kl) in [(0.0, 3.54), (10.0, 3.15), (20.0, 2.71)] {
            let got = liquid_water_coefficient(77.0, t);
            assert!((got - kl).abs() <= 0.005, "{t} °C: {got}");
        }
        // Anchors of the V → M law and the resulting 0.16–1.6 dB/km (physics.md §1.5).
        assert!(rel(fog_liquid_water_g_m3(50.0), 0.5) < 1e-12);
        assert!(rel(fog_liquid_water_g_m3(300.0), 0.05) < 1e-12);
        let thick = fog_attenuation_mmwave_db_per_km(50.0, F77, 10.0);
        let medium = fog_attenuation_mmwave_db_per_km(300.0, F77, 10.0);
        assert!(
            (thick - 1.6).abs() < 0.05 && (medium - 0.16).abs() < 0.005,
            "{thick} {medium}"
        );
        // Gases: 0.35 dB/km at 77 GHz and 0.34 at 79 GHz in the standard atmosphere; H₂O part at
        // 20 g/m³ ≈ 0.66 dB/km.
        assert!((gas_attenuation_mmwave_db_per_km(77e9, 7.5) - 0.349).abs() < 1e-9);
        assert!((gas_attenuation_mmwave_db_per_km(79e9, 7.5) - 0.34).abs() < 1e-9);
        let h2o_20 = gas_attenuation_mmwave_db_per_km(77e9, 20.0)
            - gas_attenuation_mmwave_db_per_km(77e9, 0.0);
        assert!(rel(h2o_20, 0.66) < 0.02, "{h2o_20}");
        // Clear default weather has the reference vapour density, hence 0.35 dB/km at 77 GHz.
        let g = per_m_to_db_per_km(extinction_per_m(&Weather::CLEAR, Band::MmWave { hz: F77 }));
        assert!((g - 0.349).abs() < 0.002, "{g}");
    }

    #[test]
    fn standard_atmosphere_humidity() {
        let rho = Weather::CLEAR.water_vapour_g_m3();
        assert!((rho - STANDARD_WATER_VAPOUR_G_M3).abs() < 0.01, "{rho}");
        // e_s(0 °C) = 6.1094 hPa by construction; e_s(20 °C) within 0.5 % of the IAPWS-95 value
        // 23.39 hPa (the Magnus form is meant for −40…50 °C).
        assert!((saturation_vapour_pressure_hpa(0.0) - 6.1094).abs() < 1e-12);
        assert!(rel(saturation_vapour_pressure_hpa(20.0), 23.39) < 0.005);
    }

    #[test]
    fn clear_weather_is_zero_and_switches_work() {
        for band in [
            Band::Visible { nm: 380.0 },
            Band::Visible { nm: 780.0 },
            Band::Nir905,
            Band::Nir1550,
        ] {
            assert_eq!(extinction_per_m(&Weather::CLEAR, band), 0.0);
            assert_eq!(Weather::CLEAR.two_way_transmittance(band, 200.0), 1.0);
        }
        // mm-wave: only gases in clear air; zero with the absorption switch off.
        let mut e = Effects::new(EFFECTS);
        e.set("env.atmospheric_absorption", false).unwrap();
        assert_eq!(
            extinction_per_m_with(&Weather::CLEAR, Band::MmWave { hz: F77 }, &e),
            0.0
        );
        // Fog and rain switches.
        let w = Weather {
            rain_mm_h: 10.0,
            fog_visibility_m: 100.0,
            ..Weather::CLEAR
        };
        let all = extinction_per_m_with(&w, Band::Nir905, &Effects::new(EFFECTS));
        assert_eq!(all, extinction_per_m(&w, Band::Nir905));
        let mut e = Effects::new(EFFECTS);
        e.set("env.fog_extinction", false).unwrap();
        let rain_only = extinction_per_m_with(&w, Band::Nir905, &e);
        e.set("env.rain_extinction", false).unwrap();
        assert_eq!(extinction_per_m_with(&w, Band::Nir905, &e), 0.0);
        assert!(rain_only > 0.0 && rain_only < all);
        // Wet road.
        let wet = Weather {
            road: RoadWetness::Wet,
            ..Weather::CLEAR
        };
        assert!(wet.road_surface(&Effects::new(EFFECTS)).is_wet());
        let mut e = Effects::new(EFFECTS);
        e.set("env.wet_road", false).unwrap();
        assert_eq!(wet.road_surface(&e), RoadWetness::Dry);
    }

    #[test]
    fn monotonic_in_rain_and_inverse_visibility() {
        let bands = [
            Band::Visible { nm: 550.0 },
            Band::Nir905,
            Band::Nir1550,
            Band::MmWave { hz: F77 },
        ];
        for band in bands {
            let mut last = -1.0;
            for r in [0.0, 0.1, 1.0, 5.0, 10.0, 25.0, 50.0, 100.0, 200.0] {
                let s = extinction_per_m(
                    &Weather {
                        rain_mm_h: r,
                        ..Weather::CLEAR
                    },
                    band,
                );
                assert!(s > last, "{band:?} R {r}");
                last = s;
            }
            let mut last = -1.0;
            for v in [
                f64::INFINITY,
                50_000.0,
                10_000.0,
                3000.0,
                1000.0,
                700.0,
                300.0,
                100.0,
                50.0,
                20.0,
            ] {
                let s = extinction_per_m(
                    &Weather {
                        fog_visibility_m: v,
                        ..Weather::CLEAR
                    },
                    band,
                );
                assert!(s > last, "{band:?} V {v}: {s} !> {last}");
                last = s;
            }
        }
        // Unit helpers are inverse to each other; 1 km⁻¹ = 4.343 dB/km.
        assert!((per_m_to_db_per_km(db_per_km_to_per_m(3.7)) - 3.7).abs() < 1e-12);
        assert!((per_m_to_db_per_km(1e-3) - 4.3429).abs() < 1e-4);
        assert!(
            (one_way_transmittance(0.01, 50.0).powi(2) - two_way_transmittance(0.01, 50.0)).abs()
                < 1e-15
        );
    }

    #[test]
    fn serde_round_trip_and_inf() {
        let w: Weather =
            serde_json::from_str(r#"{"rain_mm_h": 5, "fog_visibility_m": "inf", "road": "wet"}"#)
                .unwrap();
        assert_eq!(w.rain_mm_h, 5.0);
        assert!(w.fog_visibility_m.is_infinite());
        assert_eq!(w.road, RoadWetness::Wet);
        assert_eq!(w.temperature_c, 15.0);
        let json = serde_json::to_string(&w).unwrap();
        assert!(json.contains(r#""fog_visibility_m":"inf""#), "{json}");
        assert_eq!(serde_json::from_str::<Weather>(&json).unwrap(), w);

        let w: Weather = serde_json::from_str(
            r#"{"fog_visibility_m": 80, "road": {"water_film_mm": 1.5}, "relative_humidity": 0.9}"#,
        )
        .unwrap();
        assert_eq!(w.fog_visibility_m, 80.0);
        assert_eq!(w.road.water_film_mm(), Some(1.5));
        assert_eq!(
            serde_json::from_str::<Weather>(&serde_json::to_string(&w).unwrap()).unwrap(),
            w
        );
        assert!(w.validate().is_ok());

        let w: Weather = serde_json::from_str(r#"{"fog_visibility_m": null}"#).unwrap();
        assert!(w.fog_visibility_m.is_infinite());
        assert!(serde_json::from_str::<Weather>(r#"{"fog_visibility_m": 0}"#).is_err());
        assert!(serde_json::from_str::<Weather>(r#"{"fog_visibility_m": "fog"}"#).is_err());
        assert!(serde_json::from_str::<Weather>(r#"{"rain": 3}"#).is_err());
        assert!(
            Weather {
                relative_humidity: 58.0,
                ..Weather::CLEAR
            }
            .validate()
            .is_err()
        );
        assert!(
            Weather {
                rain_mm_h: -1.0,
                ..Weather::CLEAR
            }
            .validate()
            .is_err()
        );
        let b: Band = serde_json::from_str(r#"{"mm_wave": {"hz": 77e9}}"#).unwrap();
        assert_eq!(b, Band::MmWave { hz: 77e9 });
    }
}

/// OSI `EnvironmentalConditions.Precipitation` category of a rain rate (mm/h), with the class limits
/// of the OSI 3.8.0 documentation (`osi_environment.proto`): NONE < 0.1, VERY_LIGHT < 0.5,
/// LIGHT < 1.9, MODERATE < 8.1, HEAVY < 34, VERY_HEAVY < 149, EXTREME ≥ 149 mm/h.
pub fn osi_precipitation_category(
    rain_mm_h: f64,
) -> osiris_proto::osi3::environmental_conditions::Precipitation {
    use osiris_proto::osi3::environmental_conditions::Precipitation as P;
    match rain_mm_h {
        r if r.is_nan() => P::Unknown,
        r if r < 0.1 => P::None,
        r if r < 0.5 => P::VeryLight,
        r if r < 1.9 => P::Light,
        r if r < 8.1 => P::Moderate,
        r if r < 34.0 => P::Heavy,
        r if r < 149.0 => P::VeryHeavy,
        _ => P::Extreme,
    }
}

/// OSI `EnvironmentalConditions.Fog` category of a meteorological visibility (m), with the class
/// limits of the OSI 3.8.0 documentation: EXCELLENT > 40 km, GOOD 10–40 km, MODERATE 4–10 km,
/// POOR 2–4 km, MIST 1–2 km, LIGHT 200 m–1 km, THICK 50–200 m, DENSE < 50 m.
pub fn osi_fog_category(visibility_m: f64) -> osiris_proto::osi3::environmental_conditions::Fog {
    use osiris_proto::osi3::environmental_conditions::Fog as F;
    match visibility_m {
        v if v.is_nan() => F::Unknown,
        v if v > 40_000.0 => F::ExcellentVisibility,
        v if v >= 10_000.0 => F::GoodVisibility,
        v if v >= 4_000.0 => F::ModerateVisibility,
        v if v >= 2_000.0 => F::PoorVisibility,
        v if v >= 1_000.0 => F::Mist,
        v if v >= 200.0 => F::Light,
        v if v >= 50.0 => F::Thick,
        _ => F::Dense,
    }
}

#[cfg(test)]
mod osi_category_tests {
    use super::*;
    use osiris_proto::osi3::environmental_conditions::{Fog, Precipitation};

    #[test]
    fn categories_follow_the_osi_class_limits() {
        assert_eq!(osi_precipitation_category(0.0), Precipitation::None);
        assert_eq!(osi_precipitation_category(0.3), Precipitation::VeryLight);
        assert_eq!(osi_precipitation_category(1.0), Precipitation::Light);
        assert_eq!(osi_precipitation_category(5.0), Precipitation::Moderate);
        assert_eq!(osi_precipitation_category(25.0), Precipitation::Heavy);
        assert_eq!(osi_precipitation_category(100.0), Precipitation::VeryHeavy);
        assert_eq!(osi_precipitation_category(200.0), Precipitation::Extreme);
        assert_eq!(osi_fog_category(f64::INFINITY), Fog::ExcellentVisibility);
        assert_eq!(osi_fog_category(20_000.0), Fog::GoodVisibility);
        assert_eq!(osi_fog_category(5_000.0), Fog::ModerateVisibility);
        assert_eq!(osi_fog_category(3_000.0), Fog::PoorVisibility);
        assert_eq!(osi_fog_category(1_500.0), Fog::Mist);
        assert_eq!(osi_fog_category(500.0), Fog::Light);
        assert_eq!(osi_fog_category(100.0), Fog::Thick);
        assert_eq!(osi_fog_category(30.0), Fog::Dense);
    }
}
