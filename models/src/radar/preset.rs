//! Radar presets (`"radar": {"preset": "..."}`): a preset is a complete set of defaults for the
//! waveform, the MIMO array, the front end and the processing; every key given beside it overrides
//! the preset's value (objects merge key by key, lists and numbers replace).
//!
//! * `awr1843` (the default): the TI AWR1843BOOST-like corner / mid-range radar of
//!   [`super::waveform`], [`super::antenna`] and [`super::processing`] (3 Tx × 4 Rx, 12 virtual
//!   channels, weak elevation).
//! * `imaging`: a 4D imaging radar of the ARS548 / cascaded-MMIC class (docs/models/radar.md): 12 Tx ×
//!   16 Rx on a 2-D grid, 192 virtual channels, a 128-element horizontal aperture and 5 elevation
//!   rows, ≥ 200 m instrumented range.

use serde::{Deserialize, Deserializer, Serialize};
use serde_json::Value;

use super::RadarConfig;
use super::antenna::{AntennaPattern, BeamShape, FrontEndConfig};
use super::processing::ProcessingConfig;
use super::waveform::{ArrayConfig, WaveformConfig};

/// The radar presets.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum RadarPreset {
    /// TI AWR1843BOOST-like: 3 Tx × 4 Rx, 256 samples × 128 chirps (the defaults).
    #[default]
    Awr1843,
    /// 4D imaging radar: 12 Tx × 16 Rx on a 2-D grid, long-range waveform.
    Imaging,
}

impl RadarPreset {
    /// The preset's name in the configuration.
    pub fn name(self) -> &'static str {
        match self {
            RadarPreset::Awr1843 => "awr1843",
            RadarPreset::Imaging => "imaging",
        }
    }

    /// The complete configuration of the preset.
    pub fn config(self) -> RadarConfig {
        match self {
            RadarPreset::Awr1843 => RadarConfig::default(),
            RadarPreset::Imaging => RadarConfig {
                preset: self,
                waveform: imaging_waveform(),
                array: imaging_array(),
                front_end: imaging_front_end(),
                processing: imaging_processing(),
                ..RadarConfig::default()
            },
        }
    }
}

/// Long-range waveform (values guessed, within what 77 GHz imaging radars publish: ≥ 200 m,
/// < 0.5 m range resolution): slope 20 MHz/µs, 512 complex samples at 30 MHz (T_adc = 17.1 µs,
/// B_eff = 341 MHz, ΔR = c/(2B_eff) = 0.44 m, R_max = f_s c/(2S) = 225 m); 64 chirps of
/// T_c = 23 µs with all Tx transmitting at once in orthogonal codes (DDMA / CDM, idealised:
/// `tdm_mimo: false`), so v_max = λ/(4T_c) = 42.6 m/s and Δv = λ/(2·64·T_c) = 1.33 m/s.
fn imaging_waveform() -> WaveformConfig {
    WaveformConfig {
        carrier_frequency_hz: 76.5e9,
        slope_hz_per_s: 20e12,
        ramp_time_s: 20e-6,
        idle_time_s: 3e-6,
        adc_start_time_s: 2e-6,
        sample_rate_hz: 30e6,
        samples_per_chirp: 512,
        chirps_per_frame: 64,
        tdm_mimo: false,
        ..WaveformConfig::default()
    }
}

/// 12 Tx × 16 Rx (the channel count of a four-chip cascade such as TI's MMWCAS-RF-EVM, TIDEP-01012;
/// the layout here is osiris's, guessed): 16 Rx at 0…15 (λ/2); 8 Tx at 0, 16, …, 112 in the same
/// row, so the horizontal virtual aperture is a filled 128-element λ/2 line (azimuth resolution
/// ≈ 2/128 in sine, 0.9° at boresight); 4 Tx at heights 1, 2, 4, 6 (λ/2) above column 0, so five
/// rows of 16 elements span 3λ vertically (elevation resolution ≈ 2/7 in sine, ≈ 16°; a single
/// target's elevation is measured far finer than that at high SNR).
fn imaging_array() -> ArrayConfig {
    let mut tx: Vec<[i32; 2]> = (0..8).map(|i| [16 * i, 0]).collect();
    tx.extend([[0, 1], [0, 2], [0, 4], [0, 6]]);
    ArrayConfig {
        tx,
        rx: (0..16).map(|i| [i, 0]).collect(),
    }
}

/// Wider azimuth and elevation beams than the corner radar's (an imaging radar covers ±60° ×
/// ±15°; guessed: Gaussian, 14 dBi, 100° × 30°); the rest as the default front end.
fn imaging_front_end() -> FrontEndConfig {
    FrontEndConfig {
        tx_pattern: imaging_pattern(),
        rx_pattern: imaging_pattern(),
        ..FrontEndConfig::default()
    }
}

fn imaging_pattern() -> AntennaPattern {
    AntennaPattern::Parametric {
        shape: BeamShape::Gaussian,
        peak_gain_dbi: 14.0,
        azimuth_beamwidth_deg: 100.0,
        elevation_beamwidth_deg: 30.0,
    }
}

/// Zero-padded azimuth FFT of 256 over the 128-element line (it resolves 2/128 in sine, so a car
/// of 4.5 m spans about 6 resolution cells at 50 m), up to 4 angle peaks per range-Doppler cell.
/// The per-direction range grouping (`peak_grouping_per_angle`) and 8 peaks per cell were tried:
/// they gave a car at 50 m no more detections (4 / 4 either way) and cost the estimation 3.5×
/// (`osiris bench radar`), so they stay off. The rest as the default processing.
fn imaging_processing() -> ProcessingConfig {
    ProcessingConfig {
        angle_fft_azimuth: 256,
        angle_fft_elevation: 32,
        angle_peak_dynamic_range_db: 25.0,
        peak_grouping_per_angle: false,
        max_angle_peaks_per_cell: 4,
        ..ProcessingConfig::default()
    }
}

/// `value` merged into `base`: objects key by key (recursively), anything else replaces.
fn merge(base: &mut Value, value: Value) {
    match (base, value) {
        (Value::Object(b), Value::Object(v)) => {
            for (k, x) in v {
                match b.get_mut(&k) {
                    Some(slot) => merge(slot, x),
                    None => {
                        b.insert(k, x);
                    }
                }
            }
        }
        (slot, x) => *slot = x,
    }
}

fn strip_nulls(v: &mut Value) {
    if let Value::Object(m) = v {
        m.retain(|_, x| !x.is_null());
        m.values_mut().for_each(strip_nulls);
    }
}

/// The `radar` key of a sensor configuration: its `preset` (default `awr1843`) with the given keys
/// over it.
pub fn resolve(value: Value) -> Result<RadarConfig, String> {
    let preset = match value.get("preset") {
        None => RadarPreset::default(),
        Some(p) => serde_json::from_value(p.clone())
            .map_err(|_| format!("`radar.preset` must be \"awr1843\" or \"imaging\" (got {p})"))?,
    };
    let mut base = serde_json::to_value(preset.config()).map_err(|e| e.to_string())?;
    // JSON has no infinities: a non-finite default (`processing.min_snr_db` = −∞) serialises as
    // null; dropped, the key takes its struct's default again.
    strip_nulls(&mut base);
    merge(&mut base, value);
    serde_json::from_value(base).map_err(|e| format!("radar: {e}"))
}

/// Serde adapter for an optional `radar` key ([`resolve`]).
pub fn deserialize_optional<'de, D: Deserializer<'de>>(
    d: D,
) -> Result<Option<RadarConfig>, D::Error> {
    match Option::<Value>::deserialize(d)? {
        None | Some(Value::Null) => Ok(None),
        Some(v) => resolve(v).map(Some).map_err(serde::de::Error::custom),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_preset_is_defaults_and_the_given_keys_override_it() {
        let c = resolve(serde_json::json!({"preset": "imaging"})).unwrap();
        assert_eq!(c, RadarPreset::Imaging.config());
        assert_eq!(c.array.n_virtual(), 192);
        let c = resolve(serde_json::json!({
            "preset": "imaging",
            "waveform": {"chirps_per_frame": 128},
        }))
        .unwrap();
        assert_eq!(c.waveform.chirps_per_frame, 128);
        assert_eq!(
            c.waveform.samples_per_chirp, 512,
            "the rest stays the preset's"
        );
        assert_eq!(c.array, imaging_array());
        let c = resolve(serde_json::json!({"waveform": {"chirps_per_frame": 32}})).unwrap();
        assert_eq!(c.preset, RadarPreset::Awr1843);
        assert_eq!(c.array, ArrayConfig::default());
        let e = resolve(serde_json::json!({"preset": "lrr"})).unwrap_err();
        assert!(e.contains("radar.preset"), "{e}");
        let e = resolve(serde_json::json!({"preset": "imaging", "waveform": {"chirps": 3}}))
            .unwrap_err();
        assert!(e.contains("chirps"), "{e}");
    }

    #[test]
    fn the_imaging_waveform_and_array_give_the_documented_figures() {
        let c = RadarPreset::Imaging.config();
        let w = &c.waveform;
        let c0 = crate::constants::SPEED_OF_LIGHT_M_S;
        let t_adc = w.samples_per_chirp as f64 / w.sample_rate_hz;
        assert!(w.adc_start_time_s + t_adc <= w.ramp_time_s);
        let range_res = c0 / (2.0 * w.slope_hz_per_s * t_adc);
        let r_max = w.sample_rate_hz * c0 / (2.0 * w.slope_hz_per_s);
        let lambda = c0 / w.carrier_frequency_hz;
        let t_c = w.ramp_time_s + w.idle_time_s;
        assert!((range_res - 0.44).abs() < 0.01, "ΔR {range_res}");
        assert!(r_max >= 200.0, "R_max {r_max}");
        assert!((lambda / (4.0 * t_c) - 42.6).abs() < 0.1);
        // A filled 128-element horizontal line and five rows.
        let v = c.array.virtual_positions();
        let row0: std::collections::BTreeSet<i32> =
            v.iter().filter(|p| p[1] == 0).map(|p| p[0]).collect();
        assert_eq!(row0, (0..128).collect());
        let rows: std::collections::BTreeSet<i32> = v.iter().map(|p| p[1]).collect();
        assert_eq!(rows, [0, 1, 2, 4, 6].into_iter().collect());
    }
}
