//! Physics-based 76–81 GHz FMCW radar (DIVP decomposition): ray-traced paths → baseband signal
//! generation → range/velocity FFTs → threshold processing → direction estimation → peaks →
//! recognition.
//!
//! * [`propagation`]: paths from the space-design layer → [`PathReturn`]s (radar equation,
//!   physical-optics scattering, Fresnel reflection, ground multipath, attenuation).
//! * [`antenna`]: Tx/Rx antenna gain patterns (table or parametric).
//! * [`waveform`]: chirp sequence and MIMO array (virtual array) parameters and derived quantities.
//! * [`baseband`]: IF cube synthesis (samples × chirps × virtual channels) with noise and
//!   impairments.
//! * [`processing`]: windowed range / Doppler FFTs, CFAR, peak interpolation, angle estimation.

pub mod antenna;
pub mod baseband;
pub mod bench;
pub mod processing;
pub mod propagation;
pub mod waveform;

use crate::constants::SPEED_OF_LIGHT_M_S;
use num_complex::Complex64;
use osiris_proto::{id, interface_version, osi3, perception};
use prost::Message as _;
use serde::{Deserialize, Serialize};

use crate::effects::{EffectInfo, Effects};
use crate::frames::Spherical;
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

/// Existence probability of a detection from its SNR: a logistic ramp, 0.5 at 13 dB (the
/// CA-CFAR threshold at P_FA 1e-6, physics.md §1.7), 0.95 at 20 dB (guessed shape).
fn existence_from_snr(snr_db: f64) -> f64 {
    1.0 / (1.0 + (-(snr_db - 13.0) * 0.42).exp())
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
        let mut dets = out
            .sensor_data
            .feature_data
            .as_mut()
            .and_then(|fd| fd.radar_sensor.first_mut())
            .map(|x| std::mem::take(&mut x.detection))
            .unwrap_or_default();
        let mut peaks = out
            .perception
            .radar
            .as_mut()
            .map(|r| std::mem::take(&mut r.peak))
            .unwrap_or_default();
        let mut moving = std::mem::take(&mut out.sensor_data.moving_object);
        out.sensor_data.clear();
        out.perception.clear();
        dets.clear();
        peaks.clear();
        moving.clear();

        let cycle = self.cycle;
        self.cycle += 1;
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
        self.chain_out.clear();
        let seed = crate::rng::splitmix64(self.seed ^ crate::rng::splitmix64(cycle));
        let cfg = self.handshake.config();
        self.chain
            .set_field_of_view(cfg.fov_horizontal_rad, cfg.fov_vertical_rad);
        self.chain.run(&self.paths, seed, &mut self.chain_out);

        self.detections.clear();
        for d in &self.chain_out {
            let rcs = rcs_estimate_dbsm(&self.radar, &self.antennas, d);
            let oid = (d.object_id != osiris_proto::INVALID_ID).then(|| id(d.object_id));
            let sph = Spherical {
                distance: d.range_m,
                azimuth: d.azimuth_rad,
                elevation: d.elevation_rad,
            };
            dets.push(osi3::RadarDetection {
                existence_probability: Some(existence_from_snr(d.snr_db)),
                // The detected object it belongs to, set after recognition (OSI 3.8.0 semantics,
                // `crate::semantics`); the ground truth stays in the perception peak.
                object_id: None,
                position: Some(sph.to_osi()),
                // OSI: radial velocity positive towards the sensor (see ideal.rs).
                radial_velocity: Some(-d.range_rate_m_s),
                rcs: Some(rcs),
                snr: Some(d.snr_db),
                ..Default::default()
            });
            peaks.push(perception::RadarPeak {
                range_m: Some(d.range_m),
                range_rate_m_s: Some(d.range_rate_m_s),
                azimuth_rad: Some(d.azimuth_rad),
                elevation_rad: Some(d.elevation_rad),
                power_dbm: Some(d.power_dbm),
                snr_db: Some(d.snr_db),
                rcs_dbsm: Some(rcs),
                object_id: oid,
            });
            self.detections.push(RadarDetection {
                range_m: d.range_m,
                azimuth_rad: d.azimuth_rad,
                elevation_rad: d.elevation_rad,
                range_rate_m_s: d.range_rate_m_s,
                snr_db: d.snr_db,
                rcs_dbsm: rcs,
                object_id: d.object_id,
            });
        }
        let ego = EgoState {
            time_s: frame.time_s,
            sensor_pose: frame.sensor_pose,
            sensor_velocity_m_s: frame.sensor_velocity_m_s,
            sensor_angular_velocity_rad_s: frame.sensor_angular_velocity_rad_s,
        };
        self.recognition.step(&ego, &self.detections, &mut moving);
        for (d, o) in dets.iter_mut().zip(self.recognition.detection_objects()) {
            d.object_id = o.map(id);
        }

        let sd = &mut out.sensor_data;
        frame.fill_sensor_data_header(sd, cycle);
        let header = frame.detection_header(cycle, dets.len());
        sd.feature_data = Some(osi3::FeatureData {
            version: Some(interface_version()),
            radar_sensor: vec![osi3::RadarDetectionData {
                header: Some(header),
                detection: dets,
            }],
            ..Default::default()
        });
        sd.moving_object = moving;
        if let Some(gt) = input.view.global_ground_truth.as_ref() {
            let reported = self.recognition.reported_ground_truth();
            crate::semantics::complete(
                sd,
                gt,
                &crate::semantics::PoseFrames::new(&frame.frame, &frame.mounting),
                &|t| reported.iter().find(|r| r.0 == t).and_then(|r| r.1),
            );
        }
        let w = &self.radar.waveform;
        let rd_map = self.radar.emit_range_doppler_map.then(|| {
            let m = self.chain.range_doppler_map();
            perception::RangeDopplerMap {
                range_bins: Some(m.range_bins as u32),
                doppler_bins: Some(m.doppler_bins as u32),
                range_bin_m: Some(m.range_bin_m),
                range_rate_bin_m_s: Some(m.doppler_bin_m_s),
                power_dbm: m.power_dbm,
            }
        });
        let p = &mut out.perception;
        p.osi_version = Some(interface_version());
        p.extension_version = Some(osiris_proto::PERCEPTION_EXTENSION_VERSION.to_string());
        p.timestamp = Some(frame.timestamp);
        p.sensor_id = frame.sensor_id;
        p.mounting_position = Some(frame.mounting);
        p.model_mode = Some(ModelMode::Physical.name().to_string());
        p.cycle_counter = Some(cycle);
        p.radar = Some(perception::RadarPerception {
            peak: peaks,
            waveform: Some(perception::RadarWaveform {
                carrier_frequency_hz: Some(w.carrier_frequency_hz),
                bandwidth_hz: Some(w.sampled_bandwidth_hz()),
                chirp_duration_s: Some(w.chirp_interval_s()),
                samples_per_chirp: Some(w.samples_per_chirp as u32),
                chirps_per_frame: Some(w.chirps_per_frame as u32),
                virtual_channels: Some(self.radar.array.n_virtual() as u32),
            }),
            range_doppler_map: rd_map,
        });
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
