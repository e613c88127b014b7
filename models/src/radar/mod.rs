//! Physics-based 76–81 GHz FMCW radar (DIVP decomposition): ray-traced paths → baseband signal
//! generation → range/velocity FFTs → threshold processing → direction estimation → peaks →
//! recognition.
//!
//! * [`propagation`]: paths from the space-design layer → [`PathReturn`]s (radar equation,
//!   physical-optics scattering, Fresnel reflection, ground multipath, attenuation).
//! * [`antenna`]: Tx/Rx antenna gain patterns (table or parametric).
//! * [`waveform`]: chirp sequence and MIMO array (virtual array) parameters and derived quantities.
//! * [`baseband`]: IF cube synthesis (samples × chirps × virtual channels) with noise and
//!   impairments, windowed range / Doppler FFTs, the range-Doppler map.
//! * [`processing`]: processing parameters and thresholds; CFAR, peak interpolation, velocity
//!   disambiguation and angle estimation (further `impl` blocks of the baseband's chain).
//! * [`calibration`]: the radar's online azimuth calibration from stationary targets
//!   (`radar.mounting_misalignment`).
//! * `export`: the cycle's content of SensorData (detections, moving objects) and of the
//!   PerceptionData radar block; the shared loop is `crate::physical`.

pub mod antenna;
pub mod baseband;
pub mod bench;
pub mod calibration;
mod export;
pub mod preset;
pub mod processing;
pub mod propagation;
pub mod waveform;

use crate::constants::SPEED_OF_LIGHT_M_S;
use num_complex::Complex64;
use osiris_proto::osi3;
use serde::{Deserialize, Serialize};

use crate::effects::{EffectInfo, Effects};
use crate::physical::{Cycle, PhysicalSensor, Physics, ego_state};
use crate::recognition::RadarDetection;
use crate::recognition::radar::RadarRecognition;
use crate::sensor::{CommonConfig, ModelError, SensorKind, StepInput, StepOutput};
use crate::world::WorldFrame;

use antenna::Antennas;
use baseband::{ChainDetection, RadarChain};
use propagation::Propagator;

/// One propagation path as the baseband sees it: what reaches the receiver from one scattering
/// contribution, for the whole frame (stop-and-hop: range and direction are those at the frame's
/// reference time; the range rate gives the phase progression).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PathReturn {
    /// Half the total path length Tx → … → Rx (the range the radar measures), m.
    pub range_m: f64,
    /// Rate of `range_m`, m/s, positive when the path gets longer (target receding).
    pub range_rate_m_s: f64,
    /// Direction of departure at the Tx array, sensor frame: azimuth (about +z from +x), rad.
    pub tx_azimuth_rad: f64,
    /// Direction of departure at the Tx array: elevation (positive up), rad.
    pub tx_elevation_rad: f64,
    /// Direction of arrival at the Rx array: azimuth, rad.
    pub rx_azimuth_rad: f64,
    /// Direction of arrival at the Rx array: elevation, rad.
    pub rx_elevation_rad: f64,
    /// Complex amplitude at the receiver input, √W (|a|² = received power incl. antenna gains,
    /// spreading, scattering, reflection coefficients, attenuation; arg a = propagation phase
    /// beyond the 4πR/λ the baseband adds itself, e.g. the reflection coefficients' phases).
    pub amplitude: Complex64,
    /// Ground-truth object the path scattered off last (`osiris_proto::INVALID_ID` = static world).
    pub object_id: u64,
}

/// Distinguishes the propagation's random stream (diffuse amplitudes, road clutter) from the
/// baseband's noise, both derived from the cycle seed.
const PROPAGATION_STREAM: u64 = 0x7072_6F70_6167_6174;

/// Radar-specific configuration (`"radar"` key of the sensor configuration JSON).
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RadarConfig {
    /// The preset these values start from (`"awr1843"`, `"imaging"`; [`preset`]). In a JSON
    /// configuration the preset supplies every key not given; in Rust, start from
    /// [`preset::RadarPreset::config`].
    #[serde(default)]
    pub preset: preset::RadarPreset,
    /// Chirp sequence.
    #[serde(default)]
    pub waveform: waveform::WaveformConfig,
    /// Tx / Rx antenna layout (MIMO).
    #[serde(default)]
    pub array: waveform::ArrayConfig,
    /// Transmit power, antenna patterns, noise figure.
    #[serde(default)]
    pub front_end: antenna::FrontEndConfig,
    /// FFT windows, CFAR, angle estimation.
    #[serde(default)]
    pub processing: processing::ProcessingConfig,
    /// Recognition (clustering, ghost rejection, tracking) parameters.
    #[serde(default)]
    pub recognition: crate::recognition::radar::RadarRecognitionConfig,
    /// Ray-tube launching and scattering-centre grouping.
    #[serde(default)]
    pub propagation: propagation::PropagationConfig,
    /// Put the range-Doppler map of every frame into the perception output (large).
    #[serde(default)]
    pub emit_range_doppler_map: bool,
}

/// Every effect of the radar model.
pub fn effects() -> Vec<EffectInfo> {
    [
        propagation::EFFECTS,
        antenna::EFFECTS,
        baseband::EFFECTS,
        calibration::EFFECTS,
    ]
    .concat()
}

/// The physical radar sensor model: the shared loop of [`PhysicalSensor`] around the radar's
/// physics ([`RadarPhysics`]).
pub type RadarSensor = PhysicalSensor<RadarPhysics>;

/// The radar's physics: world → propagation paths → baseband chain → detections → recognition.
pub struct RadarPhysics {
    radar: RadarConfig,
    effects: Effects,
    propagator: Propagator,
    antennas: Antennas,
    chain: RadarChain,
    recognition: RadarRecognition,
    paths: Vec<PathReturn>,
    chain_out: Vec<ChainDetection>,
    /// The chain's detections as recognition input (with their RCS), in chain order.
    detections: Vec<RadarDetection>,
    /// The recognised moving objects of the cycle (swapped into the output by `emit`).
    moving: Vec<osi3::DetectedMovingObject>,
    /// `radar.mounting_misalignment`: the online azimuth calibration runs.
    online_calibration: bool,
    /// Its running estimate.
    misalignment: calibration::MisalignmentEstimator,
}

impl Physics for RadarPhysics {
    const KIND: SensorKind = SensorKind::Radar;
    type Params = RadarConfig;

    fn plan(
        _config: &CommonConfig,
        radar: RadarConfig,
        effects: Effects,
    ) -> Result<RadarPhysics, ModelError> {
        radar.front_end.validate()?;
        let propagator = Propagator::new(
            &radar.propagation,
            &radar.front_end,
            radar.waveform.carrier_frequency_hz,
            &effects,
        )?;
        let chain = RadarChain::new(
            &radar.waveform,
            &radar.array,
            &radar.front_end,
            &radar.processing,
            &effects,
        )?;
        let recognition = RadarRecognition::new(&radar.recognition)?;
        Ok(RadarPhysics {
            antennas: Antennas::new(&radar.front_end, &effects),
            online_calibration: effects.is_on(&calibration::MOUNTING_MISALIGNMENT),
            radar,
            effects,
            propagator,
            chain,
            recognition,
            paths: Vec::new(),
            chain_out: Vec::new(),
            detections: Vec::new(),
            moving: Vec::new(),
            misalignment: calibration::MisalignmentEstimator::default(),
        })
    }

    /// The field of view and range are applied per cycle (propagation and the chain's angle
    /// gate read them from the configuration in force): nothing to re-plan.
    fn replan(&mut self, _config: &CommonConfig) -> Result<(), ModelError> {
        Ok(())
    }

    fn perceive(&mut self, cycle: &Cycle<'_>, frame: &WorldFrame<'_>) -> Result<(), ModelError> {
        let cfg = cycle.config;
        let seed = crate::rng::splitmix64(cycle.seed ^ crate::rng::splitmix64(cycle.index));
        // Propagation paths → baseband chain → detections (the propagation's random draws from
        // a stream of their own).
        self.propagator.compute(
            frame,
            (cfg.fov_horizontal_rad, cfg.fov_vertical_rad),
            cfg.range_m,
            crate::rng::fmix64(seed ^ PROPAGATION_STREAM),
            &mut self.paths,
        );
        self.chain_out.clear();
        self.chain
            .set_field_of_view(cfg.fov_horizontal_rad, cfg.fov_vertical_rad);
        self.chain.run(&self.paths, seed, &mut self.chain_out);
        self.detections.clear();
        self.detections
            .extend(self.chain_out.iter().map(|d| RadarDetection {
                range_m: d.range_m,
                azimuth_rad: d.azimuth_rad,
                elevation_rad: d.elevation_rad,
                range_rate_m_s: d.range_rate_m_s,
                snr_db: d.snr_db,
                rcs_dbsm: rcs_estimate_dbsm(&self.radar, &self.antennas, d),
                object_id: d.object_id,
            }));
        let ego = ego_state(frame);
        // The online azimuth calibration: estimate from the raw azimuths, then correct them.
        if self.online_calibration {
            let v_s = ego
                .sensor_pose
                .inverse_transform_vector(ego.sensor_velocity_m_s);
            self.misalignment.update(v_s, &self.detections);
            let delta = self.misalignment.estimate_rad();
            for d in &mut self.detections {
                d.azimuth_rad = crate::frames::wrap_angle(d.azimuth_rad + delta);
            }
        }
        // Recognise: detections → moving objects.
        self.moving.clear();
        self.recognition
            .set_field_of_view(cfg.fov_horizontal_rad, cfg.range_m);
        self.recognition
            .step(&ego, &self.detections, &mut self.moving);
        Ok(())
    }

    fn emit(&mut self, _cycle: &Cycle<'_>, _frame: &WorldFrame<'_>, out: &mut StepOutput) {
        export::emit(self, out);
    }

    fn last_truth_of(&self, tracking_id: u64) -> Option<u64> {
        crate::recognition::last_truth_of(self.recognition.reported_ground_truth(), tracking_id)
    }

    fn reset(&mut self) {
        self.recognition.reset();
        self.misalignment.reset();
        self.paths.clear();
        self.chain_out.clear();
        self.detections.clear();
        self.moving.clear();
    }
}

impl RadarSensor {
    /// The radar configuration in effect.
    pub fn radar_config(&self) -> &RadarConfig {
        &self.physics().radar
    }

    /// The effect switches in effect.
    pub fn effects(&self) -> &Effects {
        &self.physics().effects
    }

    /// The propagation paths of the last step (sensor frame angles).
    pub fn last_paths(&self) -> &[PathReturn] {
        &self.physics().paths
    }

    /// The chain detections of the last step.
    pub fn last_chain_detections(&self) -> &[ChainDetection] {
        &self.physics().chain_out
    }

    /// The online azimuth calibration's running estimate (`radar.mounting_misalignment`).
    pub fn misalignment(&self) -> &calibration::MisalignmentEstimator {
        &self.physics().misalignment
    }

    /// Ray tubes launched in the last step.
    pub fn last_tube_count(&self) -> usize {
        self.physics().propagator.last_tube_count
    }

    /// Only the propagation of one step: the paths of `view` (no baseband, no outputs).
    pub fn propagate(&mut self, input: &StepInput<'_>) -> Result<&[PathReturn], ModelError> {
        let (frame, config, physics) = self.world_frame(input)?;
        let seed = crate::rng::splitmix64(config.seed.unwrap_or(0));
        physics.propagator.compute(
            &frame,
            (config.fov_horizontal_rad, config.fov_vertical_rad),
            config.range_m,
            crate::rng::fmix64(seed ^ PROPAGATION_STREAM),
            &mut physics.paths,
        );
        Ok(&physics.paths)
    }

    /// RCS estimate of a detection, dBsm: the radar equation inverted at the detected range with
    /// the antenna gains at the detected angle,
    /// `σ = P_r (4π)³ R⁴ L_sys / (P_t G_t G_r λ²)` (physics.md §1.1). The chain reports only
    /// detections inside its angle gate (field of view ∩ two-way main lobe,
    /// `processing::ProcessingConfig::field_of_view_gate`), so the gain compensated is the main
    /// lobe's.
    pub fn rcs_estimate_dbsm(&self, d: &ChainDetection) -> f64 {
        let p = self.physics();
        rcs_estimate_dbsm(&p.radar, &p.antennas, d)
    }
}

/// See [`RadarSensor::rcs_estimate_dbsm`].
fn rcs_estimate_dbsm(radar: &RadarConfig, antennas: &Antennas, d: &ChainDetection) -> f64 {
    let fe = &radar.front_end;
    let lambda = SPEED_OF_LIGHT_M_S / radar.waveform.carrier_frequency_hz;
    let g = antennas.tx_gain_dbi(d.azimuth_rad, d.elevation_rad)
        + antennas.rx_gain_dbi(d.azimuth_rad, d.elevation_rad);
    d.power_dbm - fe.tx_power_dbm - g - 20.0 * lambda.log10()
        + 30.0 * (4.0 * std::f64::consts::PI).log10()
        + 40.0 * d.range_m.max(1e-3).log10()
        + fe.system_losses_db
}
