//! The world a physical sensor model sees in one step: the SensorView turned into a ray-traceable
//! [`Space`], the sensor's pose and motion in that space's frame, and the weather.
//!
//! [`SensorWorld`] is kept by a physical model across steps. Each step, [`SensorWorld::update`]
//!
//! 1. resolves the host vehicle (`SensorView.host_vehicle_id`, else `GroundTruth.host_vehicle_id`)
//!    and the mounting (`SensorView.mounting_position`, else the configured one), as the ideal model
//!    does ([`crate::frames::SensorFrame`]);
//! 2. builds the [`Scene`] from the ground truth on the first step and updates it afterwards (object
//!    poses and velocities; the static world is rebuilt only when the road network changes or the
//!    scene origin is moved);
//! 3. builds the [`Space`] (two-level BVH) on the first step and after a static rebuild, otherwise
//!    only refreshes its top level ([`Space::sync_scene`]);
//! 4. expresses the sensor frame in the **scene frame** (the space's frame: global minus
//!    [`Scene::origin`]) with its linear and angular velocity;
//! 5. takes the weather from the configuration (`"weather"` key: exact values) or else from the
//!    ground truth's OSI categories ([`weather_from_osi`]: a representative value per class).
//!
//! The world applies the sensor's environment and space-design switches in one place
//! ([`WorldEffects`], from the sensor's effect set): `env.wet_road` decides whether the road is wet
//! (configured weather, else the ground truth), `env.wet_surfaces` whether the road and marking
//! materials follow it with their wet variants, and `space.*` ([`SpaceEffects`]) reach the
//! [`Space`] every query of the sensor goes through.
//!
//! # True and nominal pose (`<sensor>.extrinsic_error`, `<sensor>.time_offset`)
//!
//! A real sensor is not exactly where its mounting says, and its clock is not the ground truth's
//! ([`crate::frames::Calibration`], the configuration's `calibration` block). The world resolves two poses:
//!
//! * the **true** one ([`WorldFrame::sensor_pose`], [`WorldFrame::frame`], the sensor velocities):
//!   the mounting composed with the extrinsic error (`M_true = M_nom ∘ E`,
//!   [`crate::frames::Calibration::true_mounting`]; `<sensor>.extrinsic_error`) on the host vehicle as it is at
//!   the sensor's measurement time `t + Δt` (`<sensor>.time_offset`: every moving object of the
//!   ground truth, the host included, is moved along its OSI velocity and acceleration by `Δt`,
//!   [`ground_truth_after`]). Every ray is traced from it, so the physics measures from where the
//!   sensor really is, when it really measures;
//! * the **nominal** one ([`WorldFrame::nominal_pose`], [`WorldFrame::nominal_frame`]): the
//!   configured (or SensorView) mounting on the host at the stamped time `t`. It is what the sensor
//!   believes: the recognition's ego state ([`crate::physical::ego_state`]: ego-motion
//!   compensation, tracking in the scene frame), the camera's levelling and height, and the output
//!   headers (`mounting_position`, timestamp) use it.
//!
//! A sensor-frame measurement (a LiDAR point, a radar detection's range and angles, a pixel) is
//! therefore taken in the true frame and reported as it is, in the frame the header calls nominal:
//! a miscalibrated sensor does not know its error. With both effects off, or a zero calibration,
//! the two poses are the same.
//!
//! The resulting [`WorldFrame`] is all a physical model needs to trace rays: everything in it is
//! in the scene frame except `frame` and `nominal_frame` (global).

use glam::DVec3;
use osiris_proto::{osi3, timestamp_from_seconds};

use crate::effects::EffectInfo;
use crate::effects::Effects;
use crate::environment::material::{MaterialDb, WET_SURFACES};
use crate::environment::scene::{Scene, SceneBuilder, SceneOptions};
use crate::environment::weather::{RoadWetness, WET_ROAD, Weather};
use crate::frames::{Pose, SensorFrame};
use crate::sensor::{CommonConfig, ModelError, SensorKind};
use crate::space::{Space, SpaceBuilder, SpaceEffects};

/// `lidar.extrinsic_error`: the LiDAR measures from its true pose (see the module documentation).
pub const LIDAR_EXTRINSIC_ERROR: EffectInfo = extrinsic_error("lidar.extrinsic_error");
/// `radar.extrinsic_error`: the radar measures from its true pose.
pub const RADAR_EXTRINSIC_ERROR: EffectInfo = extrinsic_error("radar.extrinsic_error");
/// `camera.extrinsic_error`: the camera measures from its true pose.
pub const CAMERA_EXTRINSIC_ERROR: EffectInfo = extrinsic_error("camera.extrinsic_error");
/// `lidar.time_offset`: the LiDAR measures at its own clock's time.
pub const LIDAR_TIME_OFFSET: EffectInfo = time_offset("lidar.time_offset");
/// `radar.time_offset`: the radar measures at its own clock's time.
pub const RADAR_TIME_OFFSET: EffectInfo = time_offset("radar.time_offset");
/// `camera.time_offset`: the camera measures at its own clock's time.
pub const CAMERA_TIME_OFFSET: EffectInfo = time_offset("camera.time_offset");

const fn extrinsic_error(name: &'static str) -> EffectInfo {
    EffectInfo {
        name,
        default_on: true,
        summary: "the sensor measures from its true pose M_nom ∘ E (the `calibration` block's roll, \
                  pitch, yaw in deg and x, y, z in m, nominal sensor axes) and reports in the nominal \
                  frame: a yaw error δ moves a target at azimuth θ to θ − δ, a translation t moves \
                  it by −t; acts only with a non-zero calibration",
        source: "rigid-body frame composition (physics.md §7.1); radar misalignment and its \
                 effects: Burza, Sensors 24(15):4913, 2024; LiDAR/camera extrinsic drift: \
                 Levinson & Thrun, RSS 2013",
        requires: None,
    }
}

const fn time_offset(name: &'static str) -> EffectInfo {
    EffectInfo {
        name,
        default_on: true,
        summary: "the sensor measures the world at t + Δt, Δt = time_offset_s + \
                  time_drift_ppm·10⁻⁶·t, and stamps it t: moving objects (host included) are \
                  extrapolated along their OSI velocity and acceleration, a target moving at v_rel \
                  is reported v_rel·Δt off; acts only with a non-zero offset or drift",
        source: "constant-acceleration kinematics p + v·Δt + ½a·Δt² (physics.md §7.2)",
        requires: None,
    }
}

/// The mounting and timing effects of every sensor (the world applies them; `registry::catalogue`
/// lists them).
pub const MOUNTING_EFFECTS: &[EffectInfo] = &[
    LIDAR_EXTRINSIC_ERROR,
    RADAR_EXTRINSIC_ERROR,
    CAMERA_EXTRINSIC_ERROR,
    LIDAR_TIME_OFFSET,
    RADAR_TIME_OFFSET,
    CAMERA_TIME_OFFSET,
];

/// The extrinsic-error and time-offset effects of a sensor kind.
pub fn mounting_effects(kind: SensorKind) -> (&'static EffectInfo, &'static EffectInfo) {
    match kind {
        SensorKind::Lidar => (&LIDAR_EXTRINSIC_ERROR, &LIDAR_TIME_OFFSET),
        SensorKind::Radar => (&RADAR_EXTRINSIC_ERROR, &RADAR_TIME_OFFSET),
        SensorKind::Camera => (&CAMERA_EXTRINSIC_ERROR, &CAMERA_TIME_OFFSET),
    }
}

/// The switches a [`SensorWorld`] applies to the scene and the space (see the module
/// documentation).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct WorldEffects {
    /// `space.multipath`, `space.diffuse_bounces`, `space.transmission`: set on the [`Space`].
    pub space: SpaceEffects,
    /// `env.wet_road`: the road may be wet (off: dry whatever the weather).
    pub wet_road: bool,
    /// `env.wet_surfaces`: a wet road uses the wet variants of its materials.
    pub wet_surfaces: bool,
    /// `<sensor>.extrinsic_error`: trace from the true pose (the calibration's extrinsic error).
    pub extrinsic_error: bool,
    /// `<sensor>.time_offset`: measure at the sensor clock's time (the calibration's offset, drift).
    pub time_offset: bool,
}

impl Default for WorldEffects {
    fn default() -> Self {
        WorldEffects {
            space: SpaceEffects::default(),
            wet_road: WET_ROAD.default_on,
            wet_surfaces: WET_SURFACES.default_on,
            extrinsic_error: RADAR_EXTRINSIC_ERROR.default_on,
            time_offset: RADAR_TIME_OFFSET.default_on,
        }
    }
}

impl WorldEffects {
    /// The switches of a `kind` sensor from an effect set that declares the `env.*`, `space.*` and
    /// mounting effects ([`effects`]; panics if it does not).
    pub fn from_effects(effects: &Effects, kind: SensorKind) -> WorldEffects {
        let (extrinsic, timing) = mounting_effects(kind);
        WorldEffects {
            space: SpaceEffects::from_effects(effects),
            wet_road: effects.is_on(&WET_ROAD),
            wet_surfaces: effects.is_on(&WET_SURFACES),
            extrinsic_error: effects.is_on(extrinsic),
            time_offset: effects.is_on(timing),
        }
    }

    /// The road state the scene is to use, given the configured weather (`None`: the ground truth
    /// decides): dry with `env.wet_road` off.
    fn road_wet(&self, configured: Option<&Weather>) -> Option<bool> {
        if !self.wet_road {
            Some(false)
        } else {
            configured.map(|w| w.road.is_wet())
        }
    }
}

/// One step's view of the world (see the module documentation).
pub struct WorldFrame<'a> {
    /// The scene (meshes, materials, instances), scene frame.
    pub scene: &'a Scene,
    /// The ray-traceable space of the scene, scene frame.
    pub space: &'a Space,
    /// The **true** sensor frame → scene frame (`p_scene = sensor_pose.transform_point(p_sensor)`):
    /// where the sensor really is when it really measures (module documentation). Rays start here.
    pub sensor_pose: Pose,
    /// Velocity of the true sensor origin, scene frame axes, m/s.
    pub sensor_velocity_m_s: DVec3,
    /// Angular velocity of the sensor frame, scene frame axes, rad/s.
    pub sensor_angular_velocity_rad_s: DVec3,
    /// The true sensor frame in global coordinates (with its motion).
    pub frame: SensorFrame,
    /// The **nominal** sensor frame → scene frame: the mounting in effect on the host at the
    /// stamped time, what the sensor believes its pose is (recognition, reporting).
    pub nominal_pose: Pose,
    /// The nominal sensor frame in global coordinates (with its motion).
    pub nominal_frame: SensorFrame,
    /// The sensor clock's offset this step (`<sensor>.time_offset`): the world is the ground truth
    /// this much later than `time_s`, s (0 with the effect off or no offset configured).
    pub time_offset_s: f64,
    /// Weather in effect this step.
    pub weather: Weather,
    /// Measurement time of this step (SensorView timestamp, else ground truth's, else the
    /// communication point), s.
    pub time_s: f64,
    /// The same as an OSI timestamp.
    pub timestamp: osi3::Timestamp,
    /// Host vehicle id, if any.
    pub host_id: Option<u64>,
    /// The mounting in effect, nominal (the sensor frame the output reports in, relative to the
    /// host vehicle frame).
    pub mounting: osi3::MountingPosition,
    /// The host vehicle's `base` (for `SensorData.host_vehicle_location`).
    pub host_base: Option<osi3::BaseMoving>,
    /// Sensor id of this step (SensorView's, else the configured one).
    pub sensor_id: Option<osi3::Identifier>,
}

impl WorldFrame<'_> {
    /// Sensor position in the scene frame, m.
    pub fn sensor_origin(&self) -> DVec3 {
        self.sensor_pose.position
    }

    /// Velocity of a point `p_scene` rigidly attached to the sensor (scene frame), m/s:
    /// `v_s + ω × (p − s)`.
    pub fn sensor_point_velocity(&self, p_scene: DVec3) -> DVec3 {
        self.sensor_velocity_m_s
            + self
                .sensor_angular_velocity_rad_s
                .cross(p_scene - self.sensor_pose.position)
    }

    /// The sensor pose `dt_s` seconds after the measurement time, assuming constant linear and
    /// angular velocity over the interval (first order in `ω·dt`, exact for translation).
    pub fn sensor_pose_at(&self, dt_s: f64) -> Pose {
        let w = self.sensor_angular_velocity_rad_s;
        let angle = w.length() * dt_s;
        let rotation = if angle.abs() > 0.0 {
            glam::DMat3::from_axis_angle(w.normalize(), angle) * self.sensor_pose.rotation
        } else {
            self.sensor_pose.rotation
        };
        Pose::new(
            self.sensor_pose.position + self.sensor_velocity_m_s * dt_s,
            rotation,
        )
    }
}

/// What every model (ideal or physical) reads from a SensorView before anything else: the ground
/// truth, the host vehicle (`SensorView.host_vehicle_id`, else `GroundTruth.host_vehicle_id`; an id
/// missing from the ground truth is an input error), the mounting (`SensorView.mounting_position`,
/// else the configured one), the sensor frame, and the measurement time (SensorView timestamp, else
/// the ground truth's, else the communication point).
pub struct ViewFrame<'v> {
    pub gt: &'v osi3::GroundTruth,
    pub host_id: Option<u64>,
    pub host: Option<&'v osi3::MovingObject>,
    pub mounting: osi3::MountingPosition,
    pub frame: SensorFrame,
    pub timestamp: osi3::Timestamp,
}

impl<'v> ViewFrame<'v> {
    /// Resolve `view`; `fallback_mounting` is used when the view carries no mounting position and
    /// `time_s` (the communication point) when it carries no timestamp.
    pub fn resolve(
        view: &'v osi3::SensorView,
        fallback_mounting: &crate::frames::Mounting,
        time_s: f64,
    ) -> Result<ViewFrame<'v>, ModelError> {
        let gt = view
            .global_ground_truth
            .as_ref()
            .ok_or_else(|| ModelError::Input("the SensorView has no global_ground_truth".into()))?;
        let host_id = view
            .host_vehicle_id
            .and_then(|i| i.value)
            .or(gt.host_vehicle_id.and_then(|i| i.value));
        let host = match host_id {
            Some(hid) => Some(
                gt.moving_object
                    .iter()
                    .find(|o| o.id.and_then(|i| i.value) == Some(hid))
                    .ok_or_else(|| {
                        ModelError::Input(format!(
                            "host vehicle id {hid} is not among the ground truth's moving objects"
                        ))
                    })?,
            ),
            None => None,
        };
        let mounting = view
            .mounting_position
            .unwrap_or_else(|| fallback_mounting.to_osi());
        let frame = SensorFrame::new(host, &mounting);
        let timestamp = view
            .timestamp
            .or(gt.timestamp)
            .unwrap_or_else(|| timestamp_from_seconds(time_s));
        Ok(ViewFrame {
            gt,
            host_id,
            host,
            mounting,
            frame,
            timestamp,
        })
    }

    /// The sensor id of this step: the SensorView's, else `granted` (the handshake's).
    pub fn sensor_id(
        &self,
        view: &osi3::SensorView,
        granted: Option<u64>,
    ) -> Option<osi3::Identifier> {
        view.sensor_id
            .filter(|i| i.value.is_some())
            .or(granted.map(osiris_proto::id))
    }
}

/// Scene and space kept across the steps of one physical model instance.
pub struct SensorWorld {
    materials: MaterialDb,
    options: SceneOptions,
    effects: WorldEffects,
    scene: Option<Scene>,
    space: Option<Space>,
    /// The ground truth at the sensor's measurement time when its clock is off (`None`: the
    /// SensorView's own is used).
    shifted: Option<osi3::GroundTruth>,
    /// Scene builds + static rebuilds so far (diagnostics).
    pub static_builds: u64,
    /// Warnings of the last scene update (unusable model references etc.).
    pub warnings: Vec<String>,
}

impl SensorWorld {
    /// A world with the built-in materials database, default scene options and every effect at its
    /// default.
    pub fn new() -> SensorWorld {
        SensorWorld::with(MaterialDb::builtin(), SceneOptions::default())
    }

    /// A world with the built-in materials database and default scene options that applies the
    /// switches of a `kind` sensor's effect set ([`WorldEffects::from_effects`]): how every
    /// physical sensor builds its world.
    pub fn for_effects(effects: &Effects, kind: SensorKind) -> SensorWorld {
        SensorWorld::new().with_effects(WorldEffects::from_effects(effects, kind))
    }

    /// A world with a given materials database and scene options, every effect at its default
    /// (`options.use_wet_materials` and `options.road_wet` are set from the effects at the first
    /// update).
    pub fn with(materials: MaterialDb, options: SceneOptions) -> SensorWorld {
        SensorWorld {
            materials,
            options,
            effects: WorldEffects::default(),
            scene: None,
            space: None,
            shifted: None,
            static_builds: 0,
            warnings: Vec::new(),
        }
    }

    /// The same world applying `effects` (forgets the scene and space).
    pub fn with_effects(mut self, effects: WorldEffects) -> SensorWorld {
        self.effects = effects;
        self.reset();
        self
    }

    /// The switches this world applies.
    pub fn effects(&self) -> &WorldEffects {
        &self.effects
    }

    /// Forget the scene and space (next update rebuilds them).
    pub fn reset(&mut self) {
        self.scene = None;
        self.space = None;
    }

    /// The scene of the last update.
    pub fn scene(&self) -> Option<&Scene> {
        self.scene.as_ref()
    }

    /// Bring the world to `view` and return this step's frame. `time_s` is the communication point
    /// (used when the view carries no timestamp); `config` gives the fallback mounting and the
    /// weather override; `sensor_id` the configured id (used when the view carries none).
    pub fn update<'w>(
        &'w mut self,
        view: &osi3::SensorView,
        config: &CommonConfig,
        time_s: f64,
        sensor_id: Option<u64>,
    ) -> Result<WorldFrame<'w>, ModelError> {
        let resolved = ViewFrame::resolve(view, &config.mounting, time_s)?;
        let sensor_id = resolved.sensor_id(view, sensor_id);
        let ViewFrame {
            gt,
            host_id,
            host,
            mounting,
            frame: nominal_frame,
            timestamp,
        } = resolved;

        // The sensor's clock: the world as it is `dt` after the stamped time.
        let t_stamp_s = osiris_proto::timestamp_to_seconds(&timestamp);
        let dt = if self.effects.time_offset {
            config.calibration.time_offset_at(t_stamp_s)
        } else {
            0.0
        };
        let dt = if dt.is_finite() { dt } else { 0.0 };
        self.shifted = (dt != 0.0).then(|| ground_truth_after(gt, dt));
        let gt_true: &osi3::GroundTruth = self.shifted.as_ref().unwrap_or(gt);
        // The true pose: the extrinsic error on the host at the measurement time.
        let extrinsic = self.effects.extrinsic_error && config.calibration.has_extrinsic_error();
        let frame = if extrinsic || dt != 0.0 {
            let true_mounting = if extrinsic {
                config.calibration.true_mounting(&mounting)
            } else {
                mounting
            };
            let host_true = host_id.and_then(|h| {
                gt_true
                    .moving_object
                    .iter()
                    .find(|o| o.id.and_then(|i| i.value) == Some(h))
            });
            SensorFrame::new(host_true, &true_mounting)
        } else {
            nominal_frame
        };

        // Scene: build once, update afterwards.
        let scene_err = |e: crate::environment::scene::SceneError| {
            ModelError::Input(format!("scene from the ground truth: {e}"))
        };
        let mut rebuild_space = self.space.is_none();
        match self.scene.as_mut() {
            Some(scene) => {
                let report = scene.update(gt_true).map_err(scene_err)?;
                if report.static_rebuilt || report.rebased {
                    rebuild_space = true;
                    self.static_builds += 1;
                }
            }
            None => {
                let options = SceneOptions {
                    use_wet_materials: self.effects.wet_surfaces,
                    road_wet: self.effects.road_wet(config.weather.as_ref()),
                    ..self.options.clone()
                };
                let scene = SceneBuilder::new(self.materials.clone())
                    .host_id(host_id)
                    .options(options)
                    .build(gt_true)
                    .map_err(scene_err)?;
                self.scene = Some(scene);
                self.static_builds += 1;
                rebuild_space = true;
            }
        }
        let scene = self.scene.as_ref().expect("scene built above");
        self.warnings.clone_from(&scene.warnings);
        let space_err = |e: crate::space::SpaceError| ModelError::Input(format!("space: {e}"));
        // The BVH builder asserts on degenerate input that slipped through the checks: contain it,
        // forget scene and space (rebuilt next step) and skip the frame.
        let built = std::panic::catch_unwind(std::panic::AssertUnwindSafe(
            || -> Result<Option<Space>, ModelError> {
                if !rebuild_space {
                    let space = self.space.as_mut().expect("space exists");
                    if space.sync_scene(scene).map_err(space_err)? {
                        return Ok(None);
                    }
                }
                Ok(Some(
                    SpaceBuilder::new().build_scene(scene).map_err(space_err)?,
                ))
            },
        ));
        match built {
            Ok(Ok(Some(mut space))) => {
                space.effects = self.effects.space;
                self.space = Some(space);
            }
            Ok(Ok(None)) => {}
            Ok(Err(e)) => return Err(e),
            Err(_) => {
                self.scene = None;
                self.space = None;
                return Err(ModelError::Input(
                    "the ray-tracing structure could not be built from this ground truth \
                     (degenerate geometry); frame skipped"
                        .into(),
                ));
            }
        }
        let scene = self.scene.as_ref().expect("scene built above");
        let space = self.space.as_ref().expect("space built above");

        let sensor_pose = Pose::new(scene.to_local(frame.pose.position), frame.pose.rotation);
        let nominal_pose = Pose::new(
            scene.to_local(nominal_frame.pose.position),
            nominal_frame.pose.rotation,
        );
        // The road state is the scene's (configured weather or ground truth, `env.wet_road`).
        let weather = match &config.weather {
            Some(w) => Weather {
                road: if scene.wet { w.road } else { RoadWetness::Dry },
                ..*w
            },
            None => weather_from_osi(gt.environmental_conditions.as_ref(), scene.wet),
        };
        Ok(WorldFrame {
            scene,
            space,
            sensor_pose,
            sensor_velocity_m_s: frame.velocity,
            sensor_angular_velocity_rad_s: frame.angular_velocity,
            frame,
            nominal_pose,
            nominal_frame,
            time_offset_s: dt,
            weather,
            time_s: t_stamp_s,
            timestamp,
            host_id,
            mounting,
            host_base: host.and_then(|h| h.base.clone()),
            sensor_id,
        })
    }
}

/// Every effect the world applies (the environment's and the space's): with a model's own
/// effects, all that model's [`Effects`] set is asked about (every effect's `requires` parent is one
/// of these).
pub fn effects() -> Vec<crate::effects::EffectInfo> {
    [
        &crate::environment::effects()[..],
        crate::space::EFFECTS,
        MOUNTING_EFFECTS,
    ]
    .concat()
}

/// The ground truth `dt_s` later, as a sensor whose clock is `dt_s` ahead sees it: every moving
/// object (the host included) moved along its OSI motion at constant acceleration,
/// `p + v·dt + ½·a·dt²`, `v + a·dt`, and its orientation along its `orientation_rate`
/// (`(φ, θ, ψ) + (φ̇, θ̇, ψ̇)·dt`, first order). Stationary objects, the road and the timestamp
/// stay as they are.
pub fn ground_truth_after(gt: &osi3::GroundTruth, dt_s: f64) -> osi3::GroundTruth {
    use crate::frames::{rpy_from_osi, rpy_to_osi, vec3_from_osi, vec3_to_osi};
    let mut out = gt.clone();
    for o in &mut out.moving_object {
        let Some(base) = o.base.as_mut() else {
            continue;
        };
        let v = vec3_from_osi(base.velocity.as_ref());
        let a = vec3_from_osi(base.acceleration.as_ref());
        if let Some(p) = base.position.as_ref() {
            let p = vec3_from_osi(Some(p)) + v * dt_s + 0.5 * a * dt_s * dt_s;
            base.position = Some(vec3_to_osi(p));
        }
        if base.acceleration.is_some() {
            base.velocity = Some(vec3_to_osi(v + a * dt_s));
        }
        if let (Some(o), Some(rate)) = (base.orientation.as_ref(), base.orientation_rate.as_ref()) {
            let (rpy, w) = (rpy_from_osi(Some(o)), rpy_from_osi(Some(rate)));
            base.orientation = Some(rpy_to_osi([
                rpy[0] + w[0] * dt_s,
                rpy[1] + w[1] * dt_s,
                rpy[2] + w[2] * dt_s,
            ]));
        }
    }
    out
}

impl Default for SensorWorld {
    fn default() -> Self {
        SensorWorld::new()
    }
}

/// Representative weather for OSI's categorical `EnvironmentalConditions` (OSI carries rain and
/// fog only as classes): the geometric mean of each class's limits (OSI 3.8.0
/// `osi_environment.proto` class limits, see
/// [`crate::environment::weather::osi_precipitation_category`] and
/// [`crate::environment::weather::osi_fog_category`]); temperature (K) and relative humidity (%)
/// when given. `wet` (the scene's road state) selects a wet road. Use the sensor configuration's
/// `"weather"` key for exact values.
pub fn weather_from_osi(env: Option<&osi3::EnvironmentalConditions>, wet: bool) -> Weather {
    use osi3::environmental_conditions::{Fog as F, Precipitation as P};
    let mut w = Weather::CLEAR;
    if wet {
        w.road = RoadWetness::Wet;
    }
    let Some(env) = env else { return w };
    w.rain_mm_h = match env.precipitation.and_then(|p| P::try_from(p).ok()) {
        Some(P::VeryLight) => (0.1f64 * 0.5).sqrt(),
        Some(P::Light) => (0.5f64 * 1.9).sqrt(),
        Some(P::Moderate) => (1.9f64 * 8.1).sqrt(),
        Some(P::Heavy) => (8.1f64 * 34.0).sqrt(),
        Some(P::VeryHeavy) => (34.0f64 * 149.0).sqrt(),
        Some(P::Extreme) => 200.0,
        _ => 0.0,
    };
    w.fog_visibility_m = match env.fog.and_then(|f| F::try_from(f).ok()) {
        Some(F::GoodVisibility) => (10_000.0f64 * 40_000.0).sqrt(),
        Some(F::ModerateVisibility) => (4_000.0f64 * 10_000.0).sqrt(),
        Some(F::PoorVisibility) => (2_000.0f64 * 4_000.0).sqrt(),
        Some(F::Mist) => (1_000.0f64 * 2_000.0).sqrt(),
        Some(F::Light) => (200.0f64 * 1_000.0).sqrt(),
        Some(F::Thick) => (50.0f64 * 200.0).sqrt(),
        Some(F::Dense) => 30.0,
        _ => f64::INFINITY,
    };
    if let Some(t_k) = env
        .temperature
        .filter(|t| t.is_finite() && *t > 200.0 && *t < 340.0)
    {
        w.temperature_c = t_k - 273.15;
    }
    if let Some(rh) = env
        .relative_humidity
        .filter(|h| h.is_finite() && (0.0..=100.0).contains(h))
    {
        w.relative_humidity = rh / 100.0;
    }
    w
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::environment::weather::{osi_fog_category, osi_precipitation_category};

    #[test]
    fn representative_weather_falls_in_its_osi_class() {
        for rain in [0.3, 1.0, 5.0, 20.0, 80.0, 300.0] {
            let env = osi3::EnvironmentalConditions {
                precipitation: Some(osi_precipitation_category(rain) as i32),
                ..Default::default()
            };
            let w = weather_from_osi(Some(&env), false);
            assert_eq!(
                osi_precipitation_category(w.rain_mm_h),
                osi_precipitation_category(rain)
            );
        }
        for vis in [20.0, 100.0, 500.0, 1500.0, 3000.0, 6000.0, 20_000.0] {
            let env = osi3::EnvironmentalConditions {
                fog: Some(osi_fog_category(vis) as i32),
                ..Default::default()
            };
            let w = weather_from_osi(Some(&env), false);
            assert_eq!(osi_fog_category(w.fog_visibility_m), osi_fog_category(vis));
        }
        assert_eq!(weather_from_osi(None, false), Weather::CLEAR);
    }
}
