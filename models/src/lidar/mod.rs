//! Physics-based pulsed time-of-flight LiDAR (DIVP decomposition): scan model → signal propagation
//! → detection & ranging → point cloud → recognition.
//!
//! * [`scan`]: scan patterns (Velodyne VLS-128 / VLP-16 presets, generic spinning / MEMS / flash),
//!   per-firing timestamps.
//! * [`beam`]: beam footprint sampled by weighted sub-rays.
//! * [`signal`]: received power from the LiDAR equation, overlap function, solar background.
//! * [`detection`]: received waveform, APD/TIA noise, threshold detection, multi-echo, range walk,
//!   intensity mapping, saturation.
//! * [`export`]: PCD / PLY files of a frame.
//! * [`bench`]: `osiris bench lidar`.
//!
//! # One step
//!
//! [`LidarSensor`] simulates the firings of one sensor cycle (`update_cycle_s`) starting at the
//! measurement time. Per pulse: the sub-rays of the beam are traced from the sensor pose at the
//! firing time (`lidar.scan_motion`), each hit gives a [`detection::Return`] (LiDAR equation,
//! [`signal`]), the solar background of the surface is added, and the [`detection::Detector`] turns
//! the returns into echoes — all sub-rays in one waveform (`lidar.mixed_pixels` on) or per surface.
//! A sub-ray that meets glass (`space.transmission`, a material with a slab transmittance τ at the
//! LiDAR band) goes on behind it: the pane returns its own reflection, every surface behind it
//! returns with τ² (two-way), up to [`MAX_PANES`] panes.
//! Each echo is a point `range × beam direction` in the sensor frame of its firing time, moved
//! into the sensor frame of the measurement time (ego motion during the sweep compensated, as
//! drivers de-skew with the per-point timestamps; moving objects keep their rolling distortion),
//! written to
//! `PerceptionData.lidar` and `SensorData.feature_data.lidar_sensor[0]`, then clustered into
//! objects by [`crate::recognition::lidar::LidarRecognition`].
//!
//! Work is split into chunks of [`CHUNK_PULSES`] pulses traced with `Space::trace_batch` on the
//! rayon pool; buffers are reused across steps; every pulse has its own random stream
//! (`seed ^ splitmix(cycle, pulse)`), so the output does not depend on the thread schedule.
//! Spinning patterns are traced column by column (per firing sequence: by azimuth offset, then
//! elevation) so that neighbouring rays form SIMD packets.
//!
//! # Performance (`osiris bench lidar`, [`bench::bench_lidar`])
//!
//! VLS-128 full frame (240 128 pulses at 600 RPM, ≈ 222 k points), ≈1.37 M-triangle street
//! (500 moving objects), 2 threads, release build, on the shared 2-vCPU machine while other builds
//! ran (load average 4–5): 1 sub-ray 2.9–6.1 frames/s wall (0.17–0.23 CPU-s per frame), 7 sub-rays
//! 0.9–2.0 frames/s wall (0.49–0.71 CPU-s per frame). The CPU time per frame implies ≈ 9–12 and
//! ≈ 3–4 frames/s with both cores free, around the targets of 10 and 3; not measured on an idle
//! machine. Time goes to closest-hit tracing (≈ 45 %), the solar-background shadow rays (≈ 10 %),
//! the detector (≈ 13 %) and the per-hit BRDF and LiDAR equation (≈ 15 %).

pub mod beam;
pub mod bench;
pub mod detection;
pub mod export;
pub mod fmcw;
pub mod scan;
pub mod signal;

use crate::rng::splitmix64;
use std::sync::Mutex;

use glam::{DMat3, DVec3};
use osiris_proto::{id, osi3, perception};
use prost::Message as _;
use rand::SeedableRng;
use rand::rngs::SmallRng;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crate::constants::SPEED_OF_LIGHT_M_S;
use crate::effects::{EffectInfo, Effects};
use crate::environment::material::{self, MaterialDb, MaterialEffects};
use crate::environment::scene::{Scene, StaticElement};
use crate::environment::sky_distribution::{
    CieSkyType, DEFAULT_CIE_SKY_TYPE, SKY_DISTRIBUTION, SkyDistributionCache,
};
use crate::environment::sun;
use crate::frames::{Pose, Spherical};
use crate::physical::{Cycle, PhysicalSensor, Physics, ego_state};
use crate::recognition::LidarPoint;
use crate::recognition::lidar::LidarRecognition;
use crate::sensor::{CommonConfig, ModelError, SensorKind, StepOutput};
use crate::space::{Hit, Ray, Space};
use crate::world::WorldFrame;
use detection::{Detector, Echo, IntensityCalibration, Return};
use scan::{Firing, Preset, ScanPattern};
use signal::{SignalConfig, SignalPlan, SolarPlan};

/// Most glass panes a sub-ray passes through (`space.transmission`).
pub const MAX_PANES: u32 = 4;

/// Pulses per parallel work item (their sub-rays are traced as one batch).
pub const CHUNK_PULSES: usize = 256;

/// LiDAR-specific configuration (`"lidar"` key of the sensor configuration JSON).
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LidarConfig {
    /// Receiver / detector parameters.
    #[serde(default)]
    pub detector: detection::DetectorConfig,
    /// Recognition (clustering, boxes, tracking) parameters.
    #[serde(default)]
    pub recognition: crate::recognition::lidar::LidarRecognitionConfig,
    /// Built-in sensor (`vls128` default, `vlp16`, `fmcw`): scan pattern, detection chain (pulsed
    /// time of flight; `fmcw`: coherent FMCW with per-point Doppler) and the defaults below.
    #[serde(default)]
    pub preset: Preset,
    /// FMCW chain parameters (`preset: fmcw` only; absent: the defaults of `fmcw::FmcwConfig`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub fmcw: Option<fmcw::FmcwConfig>,
    /// Scan pattern replacing the preset's (`{"spinning": {...}}`, `{"mems": {...}}`,
    /// `{"flash": {...}}`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub scan: Option<ScanPattern>,
    /// Rotation rate of the preset, RPM (default 600).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rpm: Option<f64>,
    /// Laser wavelength, nm (preset: 903).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub wavelength_nm: Option<f64>,
    /// Beam divergence, exit diameter and sub-rays per pulse.
    #[serde(default)]
    pub beam: beam::BeamConfig,
    /// Transmitter / receiver optics of the LiDAR equation.
    #[serde(default)]
    pub signal: SignalConfig,
}

/// Every effect of the LiDAR model.
pub fn effects() -> Vec<EffectInfo> {
    [
        signal::EFFECTS,
        detection::EFFECTS,
        scan::EFFECTS,
        beam::EFFECTS,
        fmcw::EFFECTS,
    ]
    .concat()
}

/// Values in effect after the preset defaults and the overrides.
#[derive(Debug, Clone, PartialEq)]
pub struct Resolved {
    pub pattern: ScanPattern,
    pub wavelength_nm: f64,
    pub divergence_h_rad: f64,
    pub divergence_v_rad: f64,
    pub exit_diameter_m: f64,
    pub sub_rays: usize,
    /// The FMCW chain's parameters (`preset: fmcw`; its wavelength is `wavelength_nm`), or `None`
    /// for the pulsed chain.
    pub fmcw: Option<fmcw::FmcwConfig>,
}

impl LidarConfig {
    /// Apply the preset defaults and check every value; errors name the key.
    pub fn resolve(&self) -> Result<Resolved, ModelError> {
        let spec = self.preset.spec();
        let pos = |key: &str, v: f64| {
            if v.is_finite() && v > 0.0 {
                Ok(v)
            } else {
                Err(ModelError::Config(format!(
                    "`lidar.{key}` must be a finite number > 0, got {v}"
                )))
            }
        };
        let non_neg = |key: &str, v: f64| {
            if v.is_finite() && v >= 0.0 {
                Ok(v)
            } else {
                Err(ModelError::Config(format!(
                    "`lidar.{key}` must be a finite number ≥ 0, got {v}"
                )))
            }
        };
        let rpm = pos("rpm", self.rpm.unwrap_or(spec.rpm))?;
        let pattern = match &self.scan {
            Some(p) => p.clone(),
            None => ScanPattern::Spinning(self.preset.pattern(rpm)),
        };
        pattern.validate()?;
        let wavelength_nm = pos(
            "wavelength_nm",
            self.wavelength_nm.unwrap_or(spec.wavelength_nm),
        )?;
        if !(780.0..=2000.0).contains(&wavelength_nm) {
            return Err(ModelError::Config(format!(
                "`lidar.wavelength_nm` must be a near-infrared wavelength (780–2000 nm), got {wavelength_nm}"
            )));
        }
        self.signal.validate()?;
        let sub_rays = self.beam.sub_rays.unwrap_or(1);
        beam::rings_for(sub_rays)?;
        let fmcw = match (self.preset, &self.fmcw) {
            (Preset::Fmcw, given) => {
                let mut f = given.clone().unwrap_or_default();
                if given.is_some() && f.wavelength_nm != fmcw::FmcwConfig::default().wavelength_nm {
                    return Err(ModelError::Config(
                        "`lidar.fmcw.wavelength_nm`: set the wavelength with `lidar.wavelength_nm`"
                            .into(),
                    ));
                }
                f.wavelength_nm = wavelength_nm;
                f.validate()?;
                Some(f)
            }
            (_, Some(_)) => {
                return Err(ModelError::Config(format!(
                    "`lidar.fmcw` parameters given for the pulsed preset `{}`; set `\"preset\": \"fmcw\"`",
                    serde_json::to_value(self.preset)
                        .ok()
                        .and_then(|v| v.as_str().map(str::to_string))
                        .unwrap_or_default()
                )));
            }
            (_, None) => None,
        };
        Ok(Resolved {
            fmcw,
            pattern,
            wavelength_nm,
            divergence_h_rad: non_neg(
                "beam.divergence_h_rad",
                self.beam.divergence_h_rad.unwrap_or(spec.divergence_h_rad),
            )?,
            divergence_v_rad: non_neg(
                "beam.divergence_v_rad",
                self.beam.divergence_v_rad.unwrap_or(spec.divergence_v_rad),
            )?,
            exit_diameter_m: non_neg(
                "beam.exit_diameter_m",
                self.beam
                    .exit_diameter_m
                    .unwrap_or(beam::DEFAULT_EXIT_DIAMETER_M),
            )?,
            sub_rays,
        })
    }
}

/// One output point of a frame (before it is written to the messages).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PointRecord {
    /// Position in the sensor frame of the measurement time (ego motion during the sweep
    /// compensated), m.
    pub position_m: DVec3,
    /// Measured range (along the beam, at the firing time), m.
    pub range_m: f64,
    /// Beam azimuth / elevation in the sensor frame of the firing time, rad.
    pub azimuth_rad: f64,
    pub elevation_rad: f64,
    /// Intensity on the output scale.
    pub intensity: f32,
    /// Firing time after the measurement time, ns.
    pub t_ns: i64,
    pub channel: u32,
    /// Echo index within the pulse.
    pub echo: u32,
    /// Ground-truth object (`INVALID_ID` = none).
    pub object_id: u64,
    /// Echo pulse width, s (FMCW: the beat peak's −3 dB width in range, as 2·width/c).
    pub pulse_width_s: f32,
    /// Measured range rate (FMCW: from the Doppler of the beat peaks), m/s, positive receding;
    /// `None` for the pulsed chain.
    pub range_rate_m_s: Option<f32>,
}

/// What the engine needs of the world for one frame (the scene frame throughout).
pub struct FrameInput<'a> {
    pub space: &'a Space,
    pub materials: &'a MaterialDb,
    /// The scene, for static-element ids (None: the static world has no ids).
    pub scene: Option<&'a Scene>,
    /// Sensor → scene pose at the measurement time.
    pub sensor_pose: Pose,
    /// Sensor velocity and angular velocity, scene frame, m/s and rad/s.
    pub velocity_m_s: DVec3,
    pub angular_velocity_rad_s: DVec3,
    pub signal: SignalPlan,
    pub solar: Option<SolarPlan>,
    /// Step counter (random streams).
    pub cycle: u64,
}

#[derive(Default)]
struct Scratch {
    rays: Vec<Ray>,
    hits: Vec<Option<Hit>>,
    tagged: Vec<(u64, Return)>,
    returns: Vec<Return>,
    echoes: Vec<Echo>,
    /// FMCW chain: the range rate of each `tagged` return, m/s.
    rates: Vec<f64>,
    /// FMCW chain: the returns, echoes, range rates and the detector's buffers of one beam.
    fmcw_returns: Vec<fmcw::FmcwReturn>,
    fmcw_echoes: Vec<fmcw::FmcwEcho>,
    echo_rates: Vec<f32>,
    fmcw: Option<fmcw::FmcwScratch>,
}

/// The beat spectra of one beam selected by `lidar.fmcw.emit_beat_spectra`, refilled every frame.
#[derive(Debug, Clone, Default)]
pub struct BeamSpectrum {
    /// Index of the firing in the cycle's plan ([`LidarEngine::firings`]).
    pub firing: usize,
    /// Its two ramps' spectra and peaks.
    pub spectra: fmcw::BeatSpectra,
}

/// The per-frame pulse engine: the scan plan, the beam sampling and the detector, planned once;
/// buffers reused across frames.
pub struct LidarEngine {
    firings: Vec<Firing>,
    /// Beam axis and azimuth / elevation unit vectors of each firing (sensor frame).
    frames: Vec<[DVec3; 3]>,
    sub_rays: Vec<beam::SubRay>,
    detector: Detector,
    /// The FMCW chain's detector (`preset: fmcw`); `None`: the pulsed `detector`.
    fmcw: Option<fmcw::FmcwDetector>,
    band: material::Band,
    material_effects: MaterialEffects,
    incidence: bool,
    scan_motion: bool,
    mixed_pixels: bool,
    solar_background: bool,
    /// `lidar.fmcw_ego_doppler`: range rates relative to the moving sensor.
    ego_doppler: bool,
    t_max_m: f64,
    seed: u64,
    scratch: Mutex<Vec<Scratch>>,
    chunks: Vec<Vec<PointRecord>>,
    /// Per chunk: the beams whose beat spectra are emitted (`lidar.fmcw.emit_beat_spectra`; all
    /// empty without the request), planned once, refilled every frame.
    spectra: Vec<Vec<BeamSpectrum>>,
}

/// Pose after `dt_s` for constant linear and angular velocity (as `WorldFrame::sensor_pose_at`).
fn pose_at(p: &Pose, v: DVec3, w: DVec3, dt_s: f64) -> Pose {
    let angle = w.length() * dt_s;
    let rotation = if angle != 0.0 {
        DMat3::from_axis_angle(w.normalize(), angle) * p.rotation
    } else {
        p.rotation
    };
    Pose::new(p.position + v * dt_s, rotation)
}

/// The beam axis of a firing and the unit vectors of increasing azimuth and elevation (sensor
/// frame).
#[inline]
fn beam_frame(f: &Firing) -> [DVec3; 3] {
    let (sa, ca) = f.azimuth_rad.sin_cos();
    let (se, ce) = f.elevation_rad.sin_cos();
    [
        DVec3::new(ce * ca, ce * sa, se),
        DVec3::new(-sa, ca, 0.0),
        DVec3::new(-se * ca, -se * sa, ce),
    ]
}

/// Unit direction of (azimuth, elevation) in the sensor frame.
#[inline]
pub fn direction(azimuth_rad: f64, elevation_rad: f64) -> DVec3 {
    let (sa, ca) = azimuth_rad.sin_cos();
    let (se, ce) = elevation_rad.sin_cos();
    DVec3::new(ce * ca, ce * sa, se)
}

impl LidarEngine {
    /// Plan the engine. `range_m` bounds the rays; `fov_*` restrict the firings.
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        lidar: &LidarConfig,
        resolved: &Resolved,
        effects: &Effects,
        cycle_s: f64,
        fov_h_rad: f64,
        fov_v_rad: f64,
        range_m: f64,
        seed: u64,
    ) -> Result<LidarEngine, ModelError> {
        let firings = resolved.pattern.plan(cycle_s, fov_h_rad, fov_v_rad);
        let beta_v = if effects.is_on(&beam::VERTICAL_DIVERGENCE) {
            resolved.divergence_v_rad
        } else {
            0.0
        };
        let sub_rays = beam::sub_rays(
            beam::rings_for(resolved.sub_rays)?,
            resolved.divergence_h_rad,
            beta_v,
        );
        // Intensity calibration: 100 % Lambertian, normal incidence, clear air (log grid).
        let signal_config = chain_signal(lidar, resolved);
        let clear = SignalPlan::new(
            &signal_config,
            effects,
            &crate::environment::weather::Weather::CLEAR,
            resolved.wavelength_nm,
        );
        let mut calibration = IntensityCalibration::default();
        let (r0, r1) = (0.1f64, range_m.max(1.0) * 1.5);
        let n = 200;
        for k in 0..=n {
            let r = r0 * (r1 / r0).powf(k as f64 / n as f64);
            calibration.range_m.push(r);
            calibration
                .reference_power_w
                .push(clear.reference_power_w(r));
        }
        let detector = Detector::new(&lidar.detector, effects, calibration)?;
        let fmcw = match &resolved.fmcw {
            Some(f) => Some(fmcw::FmcwDetector::new(f, effects)?),
            None => None,
        };
        let mut spectra = vec![Vec::new(); firings.len().div_ceil(CHUNK_PULSES)];
        if let Some(req) = resolved
            .fmcw
            .as_ref()
            .and_then(|f| f.emit_beat_spectra.as_ref())
        {
            for (i, _) in firings
                .iter()
                .enumerate()
                .filter(|(_, f)| req.selects(f.channel, f.azimuth_rad))
                .take(req.max_beams)
            {
                spectra[i / CHUNK_PULSES].push(BeamSpectrum {
                    firing: i,
                    spectra: fmcw::BeatSpectra::default(),
                });
            }
        }
        Ok(LidarEngine {
            spectra,
            fmcw,
            frames: firings.iter().map(beam_frame).collect(),
            firings,
            sub_rays,
            detector,
            band: material::Band::for_wavelength_nm(resolved.wavelength_nm),
            material_effects: MaterialEffects::from_effects(effects),
            incidence: effects.is_on(&signal::INCIDENCE_ANGLE),
            scan_motion: effects.is_on(&scan::SCAN_MOTION),
            mixed_pixels: effects.is_on(&beam::MIXED_PIXELS),
            solar_background: effects.is_on(&signal::SOLAR_BACKGROUND),
            ego_doppler: effects.is_on(&fmcw::EGO_DOPPLER),
            t_max_m: range_m,
            seed,
            scratch: Mutex::new(Vec::new()),
            chunks: Vec::new(),
        })
    }

    /// The firings of one cycle.
    pub fn firings(&self) -> &[Firing] {
        &self.firings
    }

    /// The sub-rays of a pulse.
    pub fn sub_rays(&self) -> &[beam::SubRay] {
        &self.sub_rays
    }

    /// The beat spectra of the beams selected by `lidar.fmcw.emit_beat_spectra` in the last frame,
    /// in firing order (none without the request).
    pub fn beat_spectra(&self) -> impl Iterator<Item = &BeamSpectrum> {
        self.spectra.iter().flatten()
    }

    /// The FMCW chain's detector (`preset: fmcw`).
    pub fn fmcw_detector(&self) -> Option<&fmcw::FmcwDetector> {
        self.fmcw.as_ref()
    }

    /// The points of the last frame, per chunk of [`CHUNK_PULSES`] firings, in plan order.
    pub fn points(&self) -> &[Vec<PointRecord>] {
        &self.chunks
    }

    /// Simulate one frame; the points come back per chunk of [`CHUNK_PULSES`] firings, in plan
    /// order (each point carries its firing time).
    pub fn run(&mut self, input: &FrameInput<'_>) -> &[Vec<PointRecord>] {
        let n_chunks = self.firings.len().div_ceil(CHUNK_PULSES);
        self.chunks.resize_with(n_chunks, Vec::new);
        let mut chunks = std::mem::take(&mut self.chunks);
        let mut spectra = std::mem::take(&mut self.spectra);
        let this = &*self;
        chunks
            .par_iter_mut()
            .zip(spectra.par_iter_mut())
            .enumerate()
            .for_each(|(ci, (out, spec))| {
                out.clear();
                let mut s = this
                    .scratch
                    .lock()
                    .map(|mut v| v.pop())
                    .ok()
                    .flatten()
                    .unwrap_or_default();
                let lo = ci * CHUNK_PULSES;
                let hi = (lo + CHUNK_PULSES).min(this.firings.len());
                this.run_chunk(input, lo, hi, &mut s, out, spec);
                if let Ok(mut v) = this.scratch.lock() {
                    v.push(s);
                }
            });
        self.chunks = chunks;
        self.spectra = spectra;
        &self.chunks
    }

    fn run_chunk(
        &self,
        input: &FrameInput<'_>,
        lo: usize,
        hi: usize,
        s: &mut Scratch,
        out: &mut Vec<PointRecord>,
        spectra: &mut [BeamSpectrum],
    ) {
        let m = self.sub_rays.len();
        s.rays.clear();
        for (f, frame) in self.firings[lo..hi].iter().zip(&self.frames[lo..hi]) {
            let dt = if self.scan_motion {
                f.t_ns as f64 * 1e-9
            } else {
                0.0
            };
            let pose = if dt != 0.0 {
                pose_at(
                    &input.sensor_pose,
                    input.velocity_m_s,
                    input.angular_velocity_rad_s,
                    dt,
                )
            } else {
                input.sensor_pose
            };
            let [d, e_az, e_el] = *frame;
            for sr in &self.sub_rays {
                let ds = (d + sr.dh_rad * e_az + sr.dv_rad * e_el).normalize();
                s.rays.push(Ray {
                    origin: pose.position,
                    direction: pose.rotation * ds,
                    t_min: 0.0,
                    t_max: self.t_max_m,
                    time_s: 0.0,
                });
            }
        }
        s.hits.clear();
        s.hits.resize(s.rays.len(), None);
        input.space.trace_batch(&s.rays, &mut s.hits);

        for (k, f) in self.firings[lo..hi].iter().enumerate() {
            let pulse = (lo + k) as u64;
            let dt = if self.scan_motion {
                f.t_ns as f64 * 1e-9
            } else {
                0.0
            };
            s.tagged.clear();
            s.rates.clear();
            let mut background_w = 0.0;
            let mut shadow_tested: Option<bool> = None;
            for j in 0..m {
                let Some(first) = s.hits[k * m + j] else {
                    // Nothing within range: the sky's radiance in the sub-ray's direction.
                    if self.solar_background
                        && let Some(sun) = &input.solar
                    {
                        background_w +=
                            self.sub_rays[j].weight * sun.sky_power_w(s.rays[k * m + j].direction);
                    }
                    continue;
                };
                let ray = s.rays[k * m + j];
                let d = ray.direction;
                // `space.transmission`: a pane (glass) returns its own reflection and passes the
                // rest on; each surface behind it returns with the two-way transmittance τ² of the
                // panes in front (up to `MAX_PANES`).
                let mut next = Some(first);
                let mut pane_t = 1.0;
                let mut crossed = 0;
                while let Some(hit) = next.take() {
                    let mut range = hit.distance_m;
                    if dt != 0.0 && hit.object_id.is_some() && hit.velocity_m_s != DVec3::ZERO {
                        // First-order re-intersection with the tangent plane moved by v·dt.
                        let n = hit.geometric_normal;
                        let dn = d.dot(n);
                        if dn.abs() > 1e-3 {
                            range += (hit.velocity_m_s * dt).dot(n) / dn;
                        }
                        if !(range > 0.0 && range <= self.t_max_m) {
                            continue;
                        }
                    }
                    let mat = input.materials.get(hit.material);
                    let n = hit.facing_normal();
                    let (brdf, cos) = if self.incidence {
                        (
                            mat.eval_brdf_with(self.band, -d, -d, n, &self.material_effects),
                            hit.cos_incidence(d),
                        )
                    } else {
                        (
                            mat.eval_brdf_with(self.band, n, n, n, &self.material_effects),
                            1.0,
                        )
                    };
                    let power = input
                        .signal
                        .power_w(self.sub_rays[j].weight, brdf, cos, range)
                        * pane_t
                        * pane_t;
                    let (key, object_id) = surface_key(&hit, input.scene);
                    if self.fmcw.is_some() {
                        // Doppler: the range rate of the hit point seen from the moving sensor
                        // (the ray leaves the sensor origin, so its velocity is the sensor's;
                        // `lidar.fmcw_ego_doppler` off: as if the sensor stood still).
                        let v_s = if self.ego_doppler {
                            input.velocity_m_s
                        } else {
                            DVec3::ZERO
                        };
                        s.rates.push(d.dot(hit.velocity_m_s - v_s));
                    }
                    s.tagged.push((
                        key,
                        Return {
                            range_m: range,
                            power_w: power,
                            object_id,
                        },
                    ));
                    if self.solar_background
                        && let Some(sun) = &input.solar
                    {
                        // Shadow ray only where the sun can light the surface (cos θ_s > 0).
                        let sunlit = n.dot(sun.sun_dir) > 0.0
                            && *shadow_tested.get_or_insert_with(|| {
                                let p = ray.origin + d * hit.distance_m + n * 1e-3;
                                !input
                                    .space
                                    .any_hit(&Ray::new(p, sun.sun_dir).with_t_max(1e4))
                            });
                        background_w += self.sub_rays[j].weight
                            * pane_t
                            * sun.power_w(mat.diffuse_albedo(self.band), n, sunlit);
                    }
                    if input.space.effects.transmission && crossed < MAX_PANES {
                        let tau = mat.transmittance(self.band, hit.cos_incidence(d));
                        if tau > 0.0 {
                            pane_t *= tau;
                            crossed += 1;
                            let eps = crate::space::surface_epsilon(hit.point, hit.distance_m);
                            next = input
                                .space
                                .closest_hit(&ray.with_t_min(hit.distance_m + eps));
                        }
                    }
                }
            }
            // An empty beam has no echo, except the FMCW chain's false alarms (noise peaks that
            // pass the threshold in both ramps, drawn in closed form by its detector).
            if s.tagged.is_empty() && self.fmcw.is_none() {
                continue;
            }
            let mut rng =
                SmallRng::seed_from_u64(self.seed ^ splitmix64(splitmix64(input.cycle) ^ pulse));
            s.echoes.clear();
            s.echo_rates.clear();
            if let Some(det) = &self.fmcw {
                // FMCW: every surface in the footprint is its own beat tone of one coherent
                // measurement (physics.md §2.10); sunlight only adds shot noise.
                s.fmcw_returns.clear();
                s.fmcw_returns
                    .extend(
                        s.tagged
                            .iter()
                            .zip(&s.rates)
                            .map(|(t, &rate)| fmcw::FmcwReturn {
                                range_m: t.1.range_m,
                                range_rate_m_s: rate,
                                power_w: t.1.power_w,
                                object_id: t.1.object_id,
                            }),
                    );
                let scratch = s.fmcw.get_or_insert_with(|| det.scratch());
                s.fmcw_echoes.clear();
                match spectra.iter_mut().find(|b| b.firing == lo + k) {
                    Some(b) => det.detect_with_spectra(
                        scratch,
                        &s.fmcw_returns,
                        background_w,
                        &mut rng,
                        &mut s.fmcw_echoes,
                        &mut b.spectra,
                    ),
                    None => det.detect(
                        scratch,
                        &s.fmcw_returns,
                        background_w,
                        &mut rng,
                        &mut s.fmcw_echoes,
                    ),
                }
                s.fmcw_echoes
                    .sort_by(|x, y| x.range_m.total_cmp(&y.range_m));
                for e in &s.fmcw_echoes {
                    // The calibration is the chain's (`chain_signal`: the FMCW CW power).
                    let reference = self.detector.reference_power_w(e.range_m).max(1e-30);
                    s.echoes.push(Echo {
                        range_m: e.range_m,
                        peak_power_w: e.power_w,
                        // Reflectivity, %: the echo power over a 100 % Lambertian target's at the
                        // same range (speckle makes it fluctuate, as on a real coherent sensor).
                        intensity: (100.0 * e.power_w / reference) as f32,
                        snr: 10f64.powf(e.snr_db / 20.0) as f32,
                        saturated: false,
                        pulse_width_s: (2.0 * e.peak_width_m / SPEED_OF_LIGHT_M_S) as f32,
                        object_id: e.object_id,
                    });
                    s.echo_rates.push(e.range_rate_m_s as f32);
                }
            } else if self.mixed_pixels {
                s.returns.clear();
                s.returns.extend(s.tagged.iter().map(|t| t.1));
                self.detect(&mut s.returns, background_w, &mut rng, &mut s.echoes);
            } else {
                s.tagged.sort_by_key(|t| t.0);
                let mut a = 0;
                while a < s.tagged.len() {
                    let key = s.tagged[a].0;
                    let mut b = a;
                    s.returns.clear();
                    while b < s.tagged.len() && s.tagged[b].0 == key {
                        s.returns.push(s.tagged[b].1);
                        b += 1;
                    }
                    self.detect(&mut s.returns, background_w, &mut rng, &mut s.echoes);
                    a = b;
                }
                s.echoes.sort_by(|x, y| x.range_m.total_cmp(&y.range_m));
            }
            let d_s = self.frames[lo + k][0];
            // Ego-motion compensation into the sensor frame of the measurement time: the point
            // measured at t_k in the sensor frame of t_k, moved through the scene frame.
            let moving_sensor = dt != 0.0
                && (input.velocity_m_s != DVec3::ZERO
                    || input.angular_velocity_rad_s != DVec3::ZERO);
            let pose_k = moving_sensor.then(|| {
                pose_at(
                    &input.sensor_pose,
                    input.velocity_m_s,
                    input.angular_velocity_rad_s,
                    dt,
                )
            });
            for (e_idx, e) in s.echoes.iter().enumerate() {
                let p_k = d_s * e.range_m;
                let position_m = match &pose_k {
                    Some(pk) => input
                        .sensor_pose
                        .inverse_transform_point(pk.transform_point(p_k)),
                    None => p_k,
                };
                out.push(PointRecord {
                    position_m,
                    range_m: e.range_m,
                    azimuth_rad: f.azimuth_rad,
                    elevation_rad: f.elevation_rad,
                    intensity: e.intensity,
                    t_ns: f.t_ns,
                    channel: f.channel,
                    echo: e_idx as u32,
                    object_id: e.object_id,
                    pulse_width_s: e.pulse_width_s,
                    range_rate_m_s: s.echo_rates.get(e_idx).copied(),
                });
            }
        }
    }

    #[inline]
    fn detect(
        &self,
        returns: &mut [Return],
        background_w: f64,
        rng: &mut SmallRng,
        out: &mut Vec<Echo>,
    ) {
        self.detector.detect(returns, background_w, rng, out);
    }
}

/// The transmitter / receiver optics of the chain in use: the configured ones, with the FMCW
/// chain's CW power `lidar.fmcw.tx_power_w` as the transmitted power.
fn chain_signal(lidar: &LidarConfig, resolved: &Resolved) -> SignalConfig {
    let mut signal = lidar.signal;
    if let Some(f) = &resolved.fmcw {
        signal.peak_power_w = f.tx_power_w;
    }
    signal
}

/// A key identifying the surface a hit belongs to (object + part, or static element) and the
/// ground-truth id of the hit.
fn surface_key(hit: &Hit, scene: Option<&Scene>) -> (u64, u64) {
    match hit.object_id {
        Some(oid) => (splitmix64(oid) ^ u64::from(hit.part), oid),
        None => match scene.and_then(|s| s.static_element(hit.triangle)) {
            Some(StaticElement::Lane(i)) => (splitmix64(i ^ 0x1111), osiris_proto::INVALID_ID),
            Some(StaticElement::RoadPlane) => (2, osiris_proto::INVALID_ID),
            Some(StaticElement::Marking(i)) => (splitmix64(i ^ 0x3333), osiris_proto::INVALID_ID),
            Some(StaticElement::Object(i)) => (splitmix64(i ^ 0x4444) ^ u64::from(hit.part), i),
            Some(e @ (StaticElement::TrafficSign(i) | StaticElement::TrafficLight(i))) => (
                splitmix64(i ^ 0x5555) ^ u64::from(hit.part),
                e.ground_truth_id().unwrap_or(osiris_proto::INVALID_ID),
            ),
            Some(StaticElement::SignPost(i)) => (splitmix64(i ^ 0x6666), osiris_proto::INVALID_ID),
            Some(StaticElement::SignalHousing(i)) => {
                (splitmix64(i ^ 0x7777), osiris_proto::INVALID_ID)
            }
            Some(StaticElement::RoadMarking(i)) => (
                splitmix64(i ^ 0x8888),
                StaticElement::RoadMarking(i)
                    .ground_truth_id()
                    .unwrap_or(osiris_proto::INVALID_ID),
            ),
            None => (1, osiris_proto::INVALID_ID),
        },
    }
}

/// The physical LiDAR sensor model: the shared loop of [`PhysicalSensor`] around the LiDAR's
/// physics ([`LidarPhysics`]).
pub type LidarSensor = PhysicalSensor<LidarPhysics>;

/// The LiDAR's physics: scan → beams → propagation → detection → point cloud → recognition.
pub struct LidarPhysics {
    lidar: LidarConfig,
    resolved: Resolved,
    effects: Effects,
    engine: LidarEngine,
    recognition: LidarRecognition,
    /// The cycle's points as recognition input, in output order.
    points: Vec<LidarPoint>,
    /// The recognised moving objects of the cycle (swapped into the output by `emit`).
    moving: Vec<osi3::DetectedMovingObject>,
    /// The sky radiance distribution of the last sun direction.
    sky: SkyDistributionCache,
}

impl LidarPhysics {
    fn engine(
        config: &CommonConfig,
        lidar: &LidarConfig,
        resolved: &Resolved,
        effects: &Effects,
    ) -> Result<LidarEngine, ModelError> {
        LidarEngine::new(
            lidar,
            resolved,
            effects,
            config.update_cycle_s,
            config.fov_horizontal_rad,
            config.fov_vertical_rad,
            config.range_m,
            config.seed.unwrap_or(0),
        )
    }
}

impl Physics for LidarPhysics {
    const KIND: SensorKind = SensorKind::Lidar;
    type Params = LidarConfig;

    fn plan(
        config: &CommonConfig,
        lidar: LidarConfig,
        effects: Effects,
    ) -> Result<LidarPhysics, ModelError> {
        let resolved = lidar.resolve()?;
        let engine = Self::engine(config, &lidar, &resolved, &effects)?;
        let recognition = LidarRecognition::new(&lidar.recognition)?;
        Ok(LidarPhysics {
            lidar,
            resolved,
            effects,
            engine,
            recognition,
            points: Vec::new(),
            moving: Vec::new(),
            sky: SkyDistributionCache::new(),
        })
    }

    /// The scan plan and the ray length follow the field of view and range.
    fn replan(&mut self, config: &CommonConfig) -> Result<(), ModelError> {
        self.engine = Self::engine(config, &self.lidar, &self.resolved, &self.effects)?;
        Ok(())
    }

    fn perceive(&mut self, cycle: &Cycle<'_>, frame: &WorldFrame<'_>) -> Result<(), ModelError> {
        let gt_env = cycle
            .view
            .global_ground_truth
            .as_ref()
            .and_then(|g| g.environmental_conditions.as_ref());
        let signal = SignalPlan::new(
            &chain_signal(&self.lidar, &self.resolved),
            &self.effects,
            &frame.weather,
            self.resolved.wavelength_nm,
        );
        let solar = if self.effects.is_on(&signal::SOLAR_BACKGROUND) {
            let sun_dir = sun::sun_direction(gt_env);
            // `env.sky_distribution`: the CIE standard clear sky for this sun (planned once per
            // sun position), else the isotropic sky.
            let ty = self
                .effects
                .is_on(&SKY_DISTRIBUTION)
                .then(|| CieSkyType::standard(DEFAULT_CIE_SKY_TYPE).expect("CIE type 12"));
            let sky = self.sky.plan(sun_dir, ty).clone();
            SolarPlan::new(
                &self.lidar.signal,
                sun_dir,
                self.resolved.wavelength_nm,
                sky,
            )
        } else {
            None
        };
        let fi = FrameInput {
            space: frame.space,
            materials: &frame.scene.materials,
            scene: Some(frame.scene),
            sensor_pose: frame.sensor_pose,
            velocity_m_s: frame.sensor_velocity_m_s,
            angular_velocity_rad_s: frame.sensor_angular_velocity_rad_s,
            signal,
            solar,
            cycle: cycle.index,
        };
        let chunks = self.engine.run(&fi);
        self.points.clear();
        self.points
            .extend(chunks.iter().flatten().map(|p| LidarPoint {
                position_m: p.position_m,
                intensity: p.intensity,
                range_rate_m_s: p.range_rate_m_s,
                object_id: p.object_id,
            }));
        self.moving.clear();
        self.recognition
            .step(&ego_state(frame), &self.points, &mut self.moving);
        Ok(())
    }

    /// The point cloud (`PerceptionData.lidar`), one OSI LiDAR detection per point under the
    /// detected object it belongs to (from recognition; the ground truth stays in the cloud's
    /// `object_id`), and the recognised moving objects. The lists of the previous cycle are reused.
    fn emit(&mut self, _cycle: &Cycle<'_>, frame: &WorldFrame<'_>, out: &mut StepOutput) {
        let mut cloud = out.perception.lidar.take().unwrap_or_default();
        let mut dets = out
            .sensor_data
            .feature_data
            .as_mut()
            .and_then(|fd| fd.lidar_sensor.first_mut())
            .map(|x| std::mem::take(&mut x.detection))
            .unwrap_or_default();
        // The recognised objects go out; the previous output's list comes back for the next cycle.
        let mut moving = std::mem::take(&mut out.sensor_data.moving_object);
        std::mem::swap(&mut moving, &mut self.moving);
        out.sensor_data.clear();
        out.perception.clear();
        cloud.x_m.clear();
        cloud.y_m.clear();
        cloud.z_m.clear();
        cloud.intensity.clear();
        cloud.timestamp_ns.clear();
        cloud.channel.clear();
        cloud.echo.clear();
        cloud.object_id.clear();
        cloud.range_rate_m_s.clear();
        dets.clear();

        let t0 = osiris_proto::timestamp_to_nanos(&frame.timestamp);
        // The FMCW chain reports reflectivity in % (`LidarEngine`); the pulsed one its detector's scale.
        let u8_scale = self.resolved.fmcw.is_none()
            && self.lidar.detector.intensity_scale == detection::IntensityScale::U8;
        // OSI intensity is in %: the u8 byte's diffuse part 0–100 is already %; its retro-reflector
        // codes 101–255 are reported as 100 %.
        let pct = |v: f32| {
            if u8_scale {
                f64::from(v.min(100.0))
            } else {
                f64::from(v)
            }
        };
        let objects = self.recognition.detection_objects();
        for (i, p) in self.engine.points().iter().flatten().enumerate() {
            cloud.x_m.push(p.position_m.x as f32);
            cloud.y_m.push(p.position_m.y as f32);
            cloud.z_m.push(p.position_m.z as f32);
            cloud.intensity.push(p.intensity);
            cloud.timestamp_ns.push(t0.saturating_add(p.t_ns));
            cloud.channel.push(p.channel);
            cloud.echo.push(p.echo);
            cloud.object_id.push(p.object_id);
            if let Some(rate) = p.range_rate_m_s {
                cloud.range_rate_m_s.push(rate);
            }
            dets.push(osi3::LidarDetection {
                existence_probability: Some(1.0),
                object_id: objects.get(i).copied().flatten().map(id),
                position: Some(Spherical::from_cartesian(p.position_m).to_osi()),
                intensity: Some(pct(p.intensity)),
                // OSI `echo_pulse_width` is a length (m): c·τ/2 of the echo's width in time.
                echo_pulse_width: Some(f64::from(p.pulse_width_s) * SPEED_OF_LIGHT_M_S / 2.0),
                beam_id: Some(id(u64::from(p.channel))),
                // OSI: positive towards the sensor (as the radar's).
                radial_velocity: p.range_rate_m_s.map(|v| -f64::from(v)),
                ..Default::default()
            });
        }
        cloud.intensity_scale = Some(if u8_scale {
            perception::lidar_perception::IntensityScale::U8
        } else {
            perception::lidar_perception::IntensityScale::Percent
        } as i32);
        cloud.wavelength_nm = Some(self.resolved.wavelength_nm);
        cloud.pulses_fired = Some(self.engine.firings().len() as u64);
        self.emit_beat_spectra(t0, &mut cloud);

        let sd = &mut out.sensor_data;
        sd.feature_data = Some(osi3::FeatureData {
            lidar_sensor: vec![osi3::LidarDetectionData {
                header: None,
                detection: dets,
            }],
            ..Default::default()
        });
        sd.moving_object = moving;
        out.perception.lidar = Some(cloud);
    }

    fn last_truth_of(&self, tracking_id: u64) -> Option<u64> {
        crate::recognition::last_truth_of(self.recognition.reported_ground_truth(), tracking_id)
    }

    fn reset(&mut self) {
        self.recognition.reset();
        self.points.clear();
        self.moving.clear();
    }
}

impl LidarPhysics {
    /// `cloud.beat_spectrum` from the engine's [`BeamSpectrum`]s (`lidar.fmcw.emit_beat_spectra`):
    /// dB re the mean noise per bin, ascending frequency from −f_s/2; the messages and their
    /// arrays of the previous cycle are reused. `t0_ns`: the frame's time.
    fn emit_beat_spectra(&self, t0_ns: i64, cloud: &mut perception::LidarPerception) {
        let mut used = 0;
        if let Some(det) = self.engine.fmcw_detector() {
            let noise = det.noise_per_bin();
            let db = |p: f32| (10.0 * (f64::from(p) / noise).max(1e-30).log10()) as f32;
            for b in self.engine.beat_spectra() {
                if cloud.beat_spectrum.len() == used {
                    cloud.beat_spectrum.push(Default::default());
                }
                let m = &mut cloud.beat_spectrum[used];
                used += 1;
                let f = &self.engine.firings()[b.firing];
                m.channel = Some(f.channel);
                m.firing_index = Some(b.firing as u32);
                m.azimuth_rad = Some(f.azimuth_rad);
                m.elevation_rad = Some(f.elevation_rad);
                m.timestamp_ns = Some(t0_ns.saturating_add(f.t_ns));
                m.bin_hz = Some(det.plan().bin_hz());
                m.threshold_db = Some(db(det.threshold() as f32));
                // FFT order → ascending frequency: bins N/2 … N − 1 (negative), then 0 … N/2 − 1.
                for (dst, src) in [
                    (&mut m.up_power_db, &b.spectra.power[0]),
                    (&mut m.down_power_db, &b.spectra.power[1]),
                ] {
                    let half = src.len() / 2;
                    dst.clear();
                    dst.extend(src[half..].iter().chain(&src[..half]).map(|&p| db(p)));
                }
                m.up_peak_hz.clear();
                m.up_peak_hz.extend_from_slice(&b.spectra.peaks_hz[0]);
                m.down_peak_hz.clear();
                m.down_peak_hz.extend_from_slice(&b.spectra.peaks_hz[1]);
            }
        }
        cloud.beat_spectrum.truncate(used);
    }
}

impl LidarSensor {
    /// The values in effect (preset defaults and overrides).
    pub fn resolved(&self) -> &Resolved {
        &self.physics().resolved
    }

    /// The firings of one cycle.
    pub fn firings(&self) -> &[Firing] {
        self.physics().engine.firings()
    }

    /// The LiDAR configuration in effect.
    pub fn lidar_config(&self) -> &LidarConfig {
        &self.physics().lidar
    }
}
