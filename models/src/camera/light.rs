//! Vehicle lamps as light sources and as emitting surfaces for the camera renderer.
//!
//! * Which lamps are lit comes from each vehicle's OSI `vehicle_classification.light_state`:
//!   `head_light` ON → low beams plus rear position (tail) lamps, `high_beam` ON → high beams,
//!   `tail_light` ON → tail lamps, `brake_light_state` NORMAL/STRONG → the tail-lamp lenses emit
//!   the stop-lamp distribution. The host vehicle (excluded from the scene) gets low beams from its
//!   own light state, or by [`HostLamps`] (`auto`: when the sun is below the horizon).
//! * Lamp positions: the outer face of each vehicle asset's `head_lamps` / `tail_lamps` part (one
//!   per side, split by the sign of y in the mesh frame); the lamp's optical axis is the face normal
//!   (+x for head lamps, −x for tail lamps). The host's lamps are placed on its bounding box
//!   (guessed layout, see [`host_lamp_faces`]).
//! * Light distributions `I(h, v)` and spectra from [`crate::environment::lamps`]; irradiance by the
//!   inverse-square law `E = I(θ) cos θ_s / d²` (point source, far field).
//! * Radiance of a lit lens seen directly: `L_v = I(θ) / (A cos θ)` with `A` the face area and `θ`
//!   the angle between the lamp axis and the viewing direction (a uniformly bright emitting face of
//!   the given intensity; Ryer, *Light Measurement Handbook*, 1997, ch. 7: luminance = intensity /
//!   projected area).
//!
//! # Traffic signals
//!
//! Each bulb of the scene ([`Scene::signal_bulbs`], one per OSI `TrafficLight`) is lit when its
//! current `classification.mode` is `CONSTANT` or `COUNTING` (counting signals are steady lights with
//! a counter), or `FLASHING` during the on-phase of a [`LampConfig::flash_hz`] /
//! [`LampConfig::flash_duty`] cycle (1 Hz, 50 %: inside the US MUTCD range of 50–60 flashes per
//! minute lit for ½ to ⅔ of the cycle, physics.md §3.7; the phase is 0 at simulation time 0, and
//! the on/off state is decided once per frame at the frame's start time); not when `OFF`, unknown or
//! `is_out_of_service`. A lit bulb is a [`LampSource`] ([`LampRole::Signal`]) at the lens centre
//! with the bulb's axis, the EN 12368-like distribution of its roundel size
//! ([`SIGNAL_200`]: lenses < 250 mm, else [`SIGNAL_300`]), the LED line of its colour, the lens
//! area `π d²/4`, and a PWM drive of [`LampConfig::signal_pwm_hz`] / [`LampConfig::signal_duty`]
//! (phase 0: mains-synchronous; duty 1 = steady). Its lens pixels emit `L = I/(A cos θ)` and go
//! through the `camera.led_flicker` path like vehicle lamps. Signal lamps light the scene only with
//! [`LampConfig::signal_illumination`] (off by default: a shadow ray per pixel and lit bulb).

use glam::{DMat3, DVec3};
use osiris_proto::osi3;
use serde::{Deserialize, Serialize};

use std::collections::HashMap;

use crate::environment::lamps::{LightDistribution, SIGNAL_200MM_CD, SIGNAL_300MM_CD, Spectrum};
use crate::environment::mesh::Mesh;
use crate::environment::scene::Scene;
use crate::environment::traffic::SignalColour;
use crate::error::ModelError;
use crate::frames::Pose;

use super::PwmSource;

/// Whether the host vehicle's own head lamps are on.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum HostLamps {
    /// From the host's OSI light state; without one, on when the sun is below the horizon
    /// (automatic headlamps; guessed rule).
    #[default]
    Auto,
    On,
    Off,
}

/// Head-lamp light source technology.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum HeadLampKind {
    /// Phosphor-converted white LED (PWM-driven, may flicker).
    #[default]
    Led,
    /// Tungsten halogen (black body 3200 K, steady).
    Halogen,
}

/// Lamp defaults (`"render": {"lamps": {...}}`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct LampConfig {
    /// Head-lamp technology of every vehicle.
    pub head_lamp: HeadLampKind,
    /// Host vehicle head lamps.
    pub host: HostLamps,
    /// PWM frequency of LED head lamps, Hz (**guessed**: automotive LED drivers run ≈ 100–500 Hz).
    pub head_pwm_hz: f64,
    /// PWM duty cycle of LED head lamps, 0…1 (**guessed**).
    pub head_duty: f64,
    /// PWM frequency of LED tail lamps, Hz (**guessed**).
    pub tail_pwm_hz: f64,
    /// PWM duty cycle of LED tail (rear position) lamps, 0…1 (**guessed**: a tail lamp is the stop
    /// lamp's LEDs dimmed by PWM).
    pub tail_duty: f64,
    /// PWM duty cycle of LED stop lamps, 0…1 (**guessed**).
    pub brake_duty: f64,
    /// Stop-lamp intensity as a multiple of the rear position lamp's (**guessed** from the ECE R7
    /// on-axis minima, 60 cd stop vs 4–8 cd position, UNVERIFIED).
    pub brake_factor: f64,
    /// Irradiance below which a lamp's contribution at a point is skipped (no shadow ray), lx.
    pub min_illuminance_lux: f64,
    /// PWM frequency of LED traffic signals, Hz (**guessed**: 100 Hz, the ripple of a drive from
    /// full-wave rectified 50 Hz mains).
    pub signal_pwm_hz: f64,
    /// PWM duty cycle of LED traffic signals, 0…1 (**guessed**; 1 = steady, a DC-driven signal).
    pub signal_duty: f64,
    /// Flash rate of `FLASHING` signals, Hz (1 Hz: 60 flashes per minute, US MUTCD range 50–60).
    pub flash_hz: f64,
    /// Lit fraction of a flash cycle, 0…1 (0.5: the MUTCD minimum of ½).
    pub flash_duty: f64,
    /// Lit signal lamps also light the scene (point sources with their distribution).
    pub signal_illumination: bool,
}

impl Default for LampConfig {
    fn default() -> Self {
        LampConfig {
            head_lamp: HeadLampKind::Led,
            host: HostLamps::Auto,
            head_pwm_hz: 400.0,
            head_duty: 0.8,
            tail_pwm_hz: 200.0,
            tail_duty: 0.25,
            brake_duty: 1.0,
            brake_factor: 8.0,
            min_illuminance_lux: 1e-3,
            signal_pwm_hz: 100.0,
            signal_duty: 0.5,
            flash_hz: 1.0,
            flash_duty: 0.5,
            signal_illumination: false,
        }
    }
}

impl LampConfig {
    pub fn validate(&self) -> Result<(), ModelError> {
        let bad = |k: &str, v: f64, what: &str| {
            Err(ModelError::Config(format!(
                "`camera.render.lamps.{k}` must be {what}, got {v}"
            )))
        };
        for (k, v) in [
            ("head_pwm_hz", self.head_pwm_hz),
            ("tail_pwm_hz", self.tail_pwm_hz),
            ("signal_pwm_hz", self.signal_pwm_hz),
            ("flash_hz", self.flash_hz),
        ] {
            if !(v.is_finite() && v > 0.0 && v <= 1e6) {
                return bad(k, v, "in (0, 1e6] Hz");
            }
        }
        for (k, v) in [
            ("head_duty", self.head_duty),
            ("tail_duty", self.tail_duty),
            ("brake_duty", self.brake_duty),
            ("signal_duty", self.signal_duty),
            ("flash_duty", self.flash_duty),
        ] {
            if !(v.is_finite() && v > 0.0 && v <= 1.0) {
                return bad(k, v, "in (0, 1]");
            }
        }
        if !(self.brake_factor.is_finite()
            && self.brake_factor >= 1.0
            && self.brake_factor <= 100.0)
        {
            return bad("brake_factor", self.brake_factor, "in [1, 100]");
        }
        if !(self.min_illuminance_lux.is_finite() && self.min_illuminance_lux >= 0.0) {
            return bad("min_illuminance_lux", self.min_illuminance_lux, "≥ 0 lx");
        }
        Ok(())
    }
}

/// Head or tail lamp lens, or a traffic-signal bulb.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LampRole {
    Head,
    Tail,
    Signal,
}

/// The outer face of one lamp lens in the mesh (object) frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LampFace {
    pub role: LampRole,
    /// 0 = right (y < 0), 1 = left.
    pub side: usize,
    pub centre: DVec3,
    /// Optical axis (unit, outward).
    pub axis: DVec3,
    pub area_m2: f64,
}

/// Lamp faces of a mesh from its `head_lamps` / `tail_lamps` parts.
pub fn mesh_lamp_faces(mesh: &Mesh) -> Vec<LampFace> {
    let mut out = Vec::new();
    for (role, name) in [
        (LampRole::Head, "head_lamps"),
        (LampRole::Tail, "tail_lamps"),
    ] {
        let Some(part) = mesh.parts.iter().position(|p| p.name == name) else {
            continue;
        };
        for side in 0..2 {
            let mut lo = DVec3::splat(f64::INFINITY);
            let mut hi = DVec3::splat(f64::NEG_INFINITY);
            for (t, tri) in mesh.triangles.iter().enumerate() {
                if mesh.triangle_part[t] as usize != part {
                    continue;
                }
                let c = tri
                    .iter()
                    .map(|&i| mesh.positions[i as usize].as_dvec3())
                    .fold(DVec3::ZERO, |a, b| a + b)
                    / 3.0;
                if (c.y >= 0.0) != (side == 1) {
                    continue;
                }
                for &i in tri {
                    let p = mesh.positions[i as usize].as_dvec3();
                    lo = lo.min(p);
                    hi = hi.max(p);
                }
            }
            if !lo.x.is_finite() {
                continue;
            }
            let (x, axis) = match role {
                LampRole::Tail => (lo.x, DVec3::NEG_X),
                _ => (hi.x, DVec3::X),
            };
            out.push(LampFace {
                role,
                side,
                centre: DVec3::new(x, 0.5 * (lo.y + hi.y), 0.5 * (lo.z + hi.z)),
                axis,
                area_m2: ((hi.y - lo.y) * (hi.z - lo.z)).max(1e-4),
            });
        }
    }
    out
}

/// Head-lamp faces of a vehicle box of dimension `d` (length, width, height) centred at the origin
/// (**guessed** layout: lenses 0.25 × 0.12 m at ±0.36 w, 0.65 m above the ground).
pub fn host_lamp_faces(d: DVec3) -> Vec<LampFace> {
    (0..2)
        .map(|side| LampFace {
            role: LampRole::Head,
            side,
            centre: DVec3::new(
                0.5 * d.x,
                if side == 1 { 0.36 } else { -0.36 } * d.y,
                -0.5 * d.z + 0.65f64.min(0.8 * d.z),
            ),
            axis: DVec3::X,
            area_m2: 0.25 * 0.12,
        })
        .collect()
}

/// Index of a light distribution in [`LampLibrary::distributions`].
pub const LOW_BEAM: usize = 0;
pub const HIGH_BEAM: usize = 1;
pub const TAIL: usize = 2;
pub const BRAKE: usize = 3;
/// Traffic-signal roundel of 200 mm ([`LightDistribution::en12368_signal`], [`SIGNAL_200MM_CD`]).
pub const SIGNAL_200: usize = 4;
/// Traffic-signal roundel of 300 mm ([`SIGNAL_300MM_CD`]).
pub const SIGNAL_300: usize = 5;
/// Index of a spectrum in [`LampLibrary::spectra`].
pub const SPECTRUM_HEAD: usize = 0;
pub const SPECTRUM_RED: usize = 1;
pub const SPECTRUM_SIGNAL_RED: usize = 2;
pub const SPECTRUM_SIGNAL_YELLOW: usize = 3;
pub const SPECTRUM_SIGNAL_GREEN: usize = 4;
pub const SPECTRUM_SIGNAL_BLUE: usize = 5;
pub const SPECTRUM_SIGNAL_WHITE: usize = 6;

/// The spectrum index of a signal colour (unknown colours: white).
pub fn signal_spectrum(colour: SignalColour) -> usize {
    match colour {
        SignalColour::Red => SPECTRUM_SIGNAL_RED,
        SignalColour::Yellow => SPECTRUM_SIGNAL_YELLOW,
        SignalColour::Green => SPECTRUM_SIGNAL_GREEN,
        SignalColour::Blue => SPECTRUM_SIGNAL_BLUE,
        SignalColour::White | SignalColour::Other => SPECTRUM_SIGNAL_WHITE,
    }
}

/// The distribution index of a signal lens of diameter `d` (m): 300 mm class from 250 mm on.
pub fn signal_distribution(diameter_m: f64) -> usize {
    if diameter_m >= 0.25 {
        SIGNAL_300
    } else {
        SIGNAL_200
    }
}

/// Distributions and spectra, built once.
#[derive(Debug, Clone)]
pub struct LampLibrary {
    pub distributions: [LightDistribution; 6],
    pub spectra: [Spectrum; 7],
    pub head_is_led: bool,
}

impl LampLibrary {
    pub fn new(config: &LampConfig) -> LampLibrary {
        let tail = LightDistribution::ece_tail_lamp();
        LampLibrary {
            distributions: [
                LightDistribution::ece_low_beam(),
                LightDistribution::ece_high_beam(),
                tail.clone(),
                tail.scaled(config.brake_factor),
                LightDistribution::en12368_signal(SIGNAL_200MM_CD),
                LightDistribution::en12368_signal(SIGNAL_300MM_CD),
            ],
            spectra: [
                match config.head_lamp {
                    HeadLampKind::Led => Spectrum::white_led(),
                    HeadLampKind::Halogen => Spectrum::halogen(),
                },
                Spectrum::red_led(),
                Spectrum::signal_red(),
                Spectrum::signal_yellow(),
                Spectrum::signal_green(),
                Spectrum::signal_blue(),
                Spectrum::white_led(),
            ],
            head_is_led: config.head_lamp == HeadLampKind::Led,
        }
    }
}

/// One lit lamp in the scene frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LampSource {
    pub position: DVec3,
    /// Lamp frame (x = optical axis, y = left, z = up) → scene frame.
    pub rotation: DMat3,
    /// Index into [`LampLibrary::distributions`].
    pub distribution: usize,
    /// Index into [`LampLibrary::spectra`].
    pub spectrum: usize,
    /// Emitting face area, m².
    pub area_m2: f64,
    /// PWM drive (LED lamps), `None` for steady sources.
    pub pwm: Option<PwmSource>,
    /// Scene instance the lamp belongs to (`None`: the host, or a traffic signal).
    pub instance: Option<u32>,
    pub role: LampRole,
    pub side: usize,
    /// Ground-truth id of the lamp's vehicle (the host's for host lamps) or signal bulb.
    pub object_id: u64,
    /// Whether the lamp lights the scene (vehicle lamps always; signals with
    /// [`LampConfig::signal_illumination`]).
    pub illuminates: bool,
}

impl LampSource {
    /// Lamp-frame direction of a scene-frame direction.
    pub fn to_lamp(&self, dir_scene: DVec3) -> DVec3 {
        self.rotation.transpose() * dir_scene
    }
}

/// The lamps of one frame and, per scene instance, its lit lenses.
#[derive(Debug, Clone, Default)]
pub struct LampPlan {
    pub lamps: Vec<LampSource>,
    /// Per scene instance: lamp index of [head right, head left, tail right, tail left], or
    /// `u32::MAX`.
    pub instance_lamps: Vec<[u32; 4]>,
    /// Lit traffic-signal bulbs: OSI id → lamp index.
    pub signal_lamps: HashMap<u64, u32>,
}

fn on(v: Option<i32>) -> bool {
    use osi3::moving_object::vehicle_classification::light_state::GenericLightState as G;
    v == Some(G::On as i32)
}

/// Which lamp groups a light state lights: (low beam, high beam, tail, brake).
fn lit(ls: &osi3::moving_object::vehicle_classification::LightState) -> (bool, bool, bool, bool) {
    use osi3::moving_object::vehicle_classification::light_state::BrakeLightState as B;
    let head = on(ls.head_light);
    let high = on(ls.high_beam);
    let tail = on(ls.tail_light) || head || high;
    let brake =
        matches!(ls.brake_light_state, Some(v) if v == B::Normal as i32 || v == B::Strong as i32);
    (head, high, tail, brake)
}

/// Deterministic PWM phase of a lamp, s: a hash of the object id and lamp slot spread over the
/// period (vehicles are not synchronised).
fn phase_s(object_id: u64, slot: u64, period_s: f64) -> f64 {
    let mut x = object_id ^ slot.wrapping_mul(0x9E37_79B9_7F4A_7C15);
    x ^= x >> 33;
    x = x.wrapping_mul(0xff51_afd7_ed55_8ccd);
    x ^= x >> 33;
    (x >> 11) as f64 / (1u64 << 53) as f64 * period_s
}

#[allow(clippy::too_many_arguments)]
fn push_lamp(
    plan: &mut LampPlan,
    config: &LampConfig,
    lib: &LampLibrary,
    pose: &Pose,
    face: &LampFace,
    distribution: usize,
    instance: Option<u32>,
    object_id: u64,
) -> u32 {
    let axis = pose.rotation * face.axis;
    let up = pose.rotation * DVec3::Z;
    let left = up.cross(axis).normalize_or_zero();
    let up = axis.cross(left);
    let (spectrum, pwm) = match face.role {
        LampRole::Signal => unreachable!("signal lamps are planned by `plan_signals`"),
        LampRole::Head => (
            SPECTRUM_HEAD,
            lib.head_is_led
                .then_some((config.head_pwm_hz, config.head_duty)),
        ),
        LampRole::Tail => (
            SPECTRUM_RED,
            Some((
                config.tail_pwm_hz,
                if distribution == BRAKE {
                    config.brake_duty
                } else {
                    config.tail_duty
                },
            )),
        ),
    };
    let slot = face.side as u64 + 2 * (face.role == LampRole::Tail) as u64;
    plan.lamps.push(LampSource {
        position: pose.transform_point(face.centre),
        rotation: DMat3::from_cols(axis, left, up),
        distribution,
        spectrum,
        area_m2: face.area_m2,
        pwm: pwm.map(|(f, duty)| PwmSource {
            frequency_hz: f,
            duty,
            phase_s: phase_s(object_id, slot, 1.0 / f),
        }),
        instance,
        role: face.role,
        side: face.side,
        object_id,
        illuminates: true,
    });
    (plan.lamps.len() - 1) as u32
}

/// Whether a signal bulb is lit at `time_s` (see the module docs).
pub fn signal_lit(tl: &osi3::TrafficLight, config: &LampConfig, time_s: f64) -> bool {
    use osi3::traffic_light::classification::Mode as M;
    let Some(c) = tl.classification.as_ref() else {
        return false;
    };
    if c.is_out_of_service == Some(true) {
        return false;
    }
    match c.mode.and_then(|m| M::try_from(m).ok()) {
        Some(M::Constant | M::Counting) => true,
        Some(M::Flashing) => {
            PwmSource {
                frequency_hz: config.flash_hz,
                duty: config.flash_duty,
                phase_s: 0.0,
            }
            .on_fraction(time_s, 0.0)
                >= 1.0
        }
        _ => false,
    }
}

/// The lit traffic-signal bulbs of the frame at `time_s` (see the module docs).
fn plan_signals(
    plan: &mut LampPlan,
    config: &LampConfig,
    scene: &Scene,
    gt: &osi3::GroundTruth,
    time_s: f64,
) {
    if scene.signal_bulbs.is_empty() {
        return;
    }
    let lights: HashMap<u64, &osi3::TrafficLight> = gt
        .traffic_light
        .iter()
        .filter_map(|t| Some((t.id.as_ref()?.value?, t)))
        .collect();
    for bulb in &scene.signal_bulbs {
        let Some(tl) = lights.get(&bulb.id) else {
            continue;
        };
        if !signal_lit(tl, config, time_s) {
            continue;
        }
        let colour = SignalColour::from_osi(tl.classification.as_ref().and_then(|c| c.color));
        // Orthonormal lamp frame from the bulb's axes (x = optical axis).
        let axis = bulb.rotation.x_axis.normalize();
        let left = bulb
            .rotation
            .z_axis
            .cross(axis)
            .try_normalize()
            .unwrap_or_else(|| axis.any_orthonormal_vector());
        let up = axis.cross(left);
        plan.lamps.push(LampSource {
            position: bulb.centre,
            rotation: DMat3::from_cols(axis, left, up),
            distribution: signal_distribution(bulb.diameter_m),
            spectrum: signal_spectrum(colour),
            area_m2: bulb.lens_area_m2(),
            pwm: (config.signal_duty < 1.0).then_some(PwmSource {
                frequency_hz: config.signal_pwm_hz,
                duty: config.signal_duty,
                phase_s: 0.0,
            }),
            instance: None,
            role: LampRole::Signal,
            side: 0,
            object_id: bulb.id,
            illuminates: config.signal_illumination,
        });
        plan.signal_lamps
            .insert(bulb.id, (plan.lamps.len() - 1) as u32);
    }
}

/// The lamps lit in this frame. `sun_up`: whether the sun is above the horizon (host `auto`);
/// `time_s`: simulation time of the frame's start (flashing signals).
#[allow(clippy::too_many_arguments)]
pub fn plan_lamps(
    plan: &mut LampPlan,
    config: &LampConfig,
    lib: &LampLibrary,
    scene: &Scene,
    gt: &osi3::GroundTruth,
    host_id: Option<u64>,
    sun_up: bool,
    time_s: f64,
) {
    plan.lamps.clear();
    plan.signal_lamps.clear();
    plan.instance_lamps.clear();
    plan.instance_lamps
        .resize(scene.instances.len(), [u32::MAX; 4]);
    let mut mesh_faces: Vec<Option<Vec<LampFace>>> = vec![None; scene.meshes.len()];
    for obj in &gt.moving_object {
        let Some(oid) = obj.id.and_then(|i| i.value) else {
            continue;
        };
        if Some(oid) == host_id {
            continue;
        }
        let Some(ls) = obj
            .vehicle_classification
            .as_ref()
            .and_then(|c| c.light_state.as_ref())
        else {
            continue;
        };
        let (head, high, tail, brake) = lit(ls);
        if !(head || high || tail || brake) {
            continue;
        }
        let Some(idx) = scene.instances.iter().position(|i| i.object_id == oid) else {
            continue;
        };
        let inst = &scene.instances[idx];
        let faces = mesh_faces[inst.mesh]
            .get_or_insert_with(|| mesh_lamp_faces(&scene.meshes[inst.mesh].mesh))
            .clone();
        for face in &faces {
            let distribution = match face.role {
                LampRole::Head if high => HIGH_BEAM,
                LampRole::Head if head => LOW_BEAM,
                LampRole::Tail if brake => BRAKE,
                LampRole::Tail if tail => TAIL,
                _ => continue,
            };
            let k = push_lamp(
                plan,
                config,
                lib,
                &inst.pose_local,
                face,
                distribution,
                Some(idx as u32),
                oid,
            );
            let slot = face.side + 2 * (face.role == LampRole::Tail) as usize;
            plan.instance_lamps[idx][slot] = k;
        }
    }
    // Host head lamps.
    let host = host_id.and_then(|h| {
        gt.moving_object
            .iter()
            .find(|o| o.id.and_then(|i| i.value) == Some(h))
    });
    if let Some(host) = host {
        let state = host
            .vehicle_classification
            .as_ref()
            .and_then(|c| c.light_state.as_ref())
            .map(lit);
        let (low, high) = match config.host {
            HostLamps::On => (true, false),
            HostLamps::Off => (false, false),
            HostLamps::Auto => match state {
                Some((h, hb, _, _)) => (h, hb),
                None => (!sun_up, false),
            },
        };
        if low || high {
            let global = crate::frames::moving_object_pose(host);
            let pose = Pose::new(scene.to_local(global.position), global.rotation);
            let d = crate::frames::vec3_from_osi(
                host.base
                    .as_ref()
                    .and_then(|b| b.dimension.as_ref())
                    .map(|d| osi3::Vector3d {
                        x: d.length,
                        y: d.width,
                        z: d.height,
                    })
                    .as_ref(),
            );
            let d = if d.min_element() > 0.0 {
                d
            } else {
                DVec3::new(4.5, 1.8, 1.5)
            };
            let oid = host_id.unwrap_or(0);
            for face in host_lamp_faces(d) {
                push_lamp(
                    plan,
                    config,
                    lib,
                    &pose,
                    &face,
                    if high { HIGH_BEAM } else { LOW_BEAM },
                    None,
                    oid,
                );
            }
        }
    }
    plan_signals(plan, config, scene, gt, time_s);
}
