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
//! * `export`: the step's outputs (OSI SensorData, the PerceptionData radar block).

pub mod antenna;
pub mod baseband;
pub mod bench;
mod export;
pub mod processing;
pub mod propagation;
pub mod waveform;

use crate::constants::SPEED_OF_LIGHT_M_S;
use num_complex::Complex64;
use osiris_proto::osi3;
use serde::{Deserialize, Serialize};

use crate::effects::{EffectInfo, Effects};
use crate::ideal::Handshake;
use crate::recognition::radar::RadarRecognition;
use crate::recognition::{EgoState, RadarDetection};
use crate::sensor::{
    CommonConfig, ModelError, ModelMode, SensorKind, SensorModel, SensorSetup, StepInput,
    StepOutput,
};
use crate::world::SensorWorld;

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

/// Radar-specific configuration (`"radar"` key of the sensor configuration JSON).
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RadarConfig {
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
    [propagation::EFFECTS, antenna::EFFECTS, baseband::EFFECTS].concat()
}

/// The physical radar sensor model: world → propagation paths → baseband chain → detections →
/// recognition.
pub struct RadarSensor {
    radar: RadarConfig,
    effects: Effects,
    handshake: Handshake,
    world: SensorWorld,
    propagator: Propagator,
    antennas: Antennas,
    chain: RadarChain,
    recognition: RadarRecognition,
    cycle: u64,
    seed: u64,
    paths: Vec<PathReturn>,
    chain_out: Vec<ChainDetection>,
    detections: Vec<RadarDetection>,
}

impl RadarSensor {
    /// Build from a configuration (`kind: radar`: a `SensorConfig`, checked and resolved by the
    /// registry, or a [`SensorSetup`]); errors name the bad key.
    pub fn new(
        config: impl TryInto<SensorSetup<RadarConfig>, Error = ModelError>,
    ) -> Result<RadarSensor, ModelError> {
        Self::from_setup(config.try_into()?)
    }

    /// Build from a setup (`kind: radar`); errors name the bad key.
    pub fn from_setup(setup: SensorSetup<RadarConfig>) -> Result<RadarSensor, ModelError> {
        let SensorSetup {
            common: config,
            params: radar,
            effects,
        } = setup;
        if config.kind != SensorKind::Radar {
            return Err(ModelError::Config(format!(
                "`kind` must be `radar` for the radar model, got `{}`",
                config.kind.name()
            )));
        }
        // Environment and space-design switches (wet road, multipath, transmission, ...) reach the
        // scene and the space through the world.
        let world = SensorWorld::for_effects(&effects);
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
        Ok(RadarSensor {
            handshake: Handshake::new(&config),
            antennas: Antennas::new(&radar.front_end, &effects),
            seed: config.seed.unwrap_or(0),
            radar,
            effects,
            world,
            propagator,
            chain,
            recognition,
            cycle: 0,
            paths: Vec::new(),
            chain_out: Vec::new(),
            detections: Vec::new(),
        })
    }

    /// The radar configuration in effect.
    pub fn radar_config(&self) -> &RadarConfig {
        &self.radar
    }

    /// The effect switches in effect.
    pub fn effects(&self) -> &Effects {
        &self.effects
    }

    /// The propagation paths of the last step (sensor frame angles).
    pub fn last_paths(&self) -> &[PathReturn] {
        &self.paths
    }

    /// The chain detections of the last step.
    pub fn last_chain_detections(&self) -> &[ChainDetection] {
        &self.chain_out
    }

    /// Ray tubes launched in the last step.
    pub fn last_tube_count(&self) -> usize {
        self.propagator.last_tube_count
    }

    /// Only the propagation of one step: the paths of `view` (no baseband, no outputs).
    pub fn propagate(&mut self, input: &StepInput<'_>) -> Result<&[PathReturn], ModelError> {
        let frame = self.world.update(
            input.view,
            self.handshake.config(),
            input.time_s,
            self.handshake.sensor_id(),
        )?;
        self.propagator.compute(
            &frame,
            (
                self.handshake.config().fov_horizontal_rad,
                self.handshake.config().fov_vertical_rad,
            ),
            self.handshake.config().range_m,
            &mut self.paths,
        );
        Ok(&self.paths)
    }

    /// RCS estimate of a detection, dBsm: the radar equation inverted at the detected range with
    /// the antenna gains at the detected angle,
    /// `σ = P_r (4π)³ R⁴ L_sys / (P_t G_t G_r λ²)` (physics.md §1.1). The chain reports only
    /// detections inside its angle gate (field of view ∩ two-way main lobe,
    /// `processing::ProcessingConfig::field_of_view_gate`), so the gain compensated is the main
    /// lobe's.
    pub fn rcs_estimate_dbsm(&self, d: &ChainDetection) -> f64 {
        rcs_estimate_dbsm(&self.radar, &self.antennas, d)
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

impl SensorModel for RadarSensor {
    fn kind(&self) -> SensorKind {
        SensorKind::Radar
    }

    fn mode(&self) -> ModelMode {
        ModelMode::Physical
    }

    fn config(&self) -> &CommonConfig {
        self.handshake.config()
    }

    fn view_configuration_request(&self) -> osi3::SensorViewConfiguration {
        self.handshake.request()
    }

    fn apply_view_configuration(
        &mut self,
        granted: &osi3::SensorViewConfiguration,
    ) -> Result<Vec<String>, ModelError> {
        let (notes, _) = self.handshake.apply(granted)?;
        Ok(notes)
    }

    fn step(&mut self, input: &StepInput<'_>, out: &mut StepOutput) -> Result<(), ModelError> {
        let mut bufs = export::Buffers::take(out);

        // Plan: the world of this step.
        let cycle = self.cycle;
        self.cycle += 1;
        let frame = self.world.update(
            input.view,
            self.handshake.config(),
            input.time_s,
            self.handshake.sensor_id(),
        )?;
        // Perceive: propagation paths → baseband chain → detections.
        self.propagator.compute(
            &frame,
            (
                self.handshake.config().fov_horizontal_rad,
                self.handshake.config().fov_vertical_rad,
            ),
            self.handshake.config().range_m,
            &mut self.paths,
        );
        self.chain_out.clear();
        let seed = crate::rng::splitmix64(self.seed ^ crate::rng::splitmix64(cycle));
        let cfg = self.handshake.config();
        self.chain
            .set_field_of_view(cfg.fov_horizontal_rad, cfg.fov_vertical_rad);
        self.chain.run(&self.paths, seed, &mut self.chain_out);
        export::detections(
            &self.radar,
            &self.antennas,
            &self.chain_out,
            &mut bufs,
            &mut self.detections,
        );

        // Recognise: detections → moving objects.
        let ego = EgoState {
            time_s: frame.time_s,
            sensor_pose: frame.sensor_pose,
            sensor_velocity_m_s: frame.sensor_velocity_m_s,
            sensor_angular_velocity_rad_s: frame.sensor_angular_velocity_rad_s,
        };
        self.recognition
            .step(&ego, &self.detections, &mut bufs.moving);
        export::detected_objects(&mut bufs.detections, self.recognition.detection_objects());

        // Export: SensorData and PerceptionData.
        export::sensor_data(
            &mut out.sensor_data,
            &frame,
            cycle,
            bufs.detections,
            bufs.moving,
            input.view.global_ground_truth.as_ref(),
            self.recognition.reported_ground_truth(),
        );
        export::perception(
            &mut out.perception,
            &frame,
            cycle,
            bufs.peaks,
            &self.radar,
            &self.chain,
        );
        Ok(())
    }

    fn reset(&mut self) {
        self.world.reset();
        self.recognition.reset();
        self.cycle = 0;
        self.paths.clear();
        self.chain_out.clear();
        self.detections.clear();
    }
}
