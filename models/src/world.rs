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
//! The resulting [`WorldFrame`] is all a physical model needs to trace rays: everything in it is
//! in the scene frame except `frame` (global).

use glam::DVec3;
use osiris_proto::{osi3, timestamp_from_seconds};

use crate::effects::Effects;
use crate::environment::material::{MaterialDb, WET_SURFACES};
use crate::environment::scene::{Scene, SceneBuilder, SceneOptions};
use crate::environment::weather::{RoadWetness, WET_ROAD, Weather};
use crate::frames::{Pose, SensorFrame};
use crate::sensor::{CommonConfig, ModelError};
use crate::space::{Space, SpaceBuilder, SpaceEffects};

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
}

impl Default for WorldEffects {
    fn default() -> Self {
        WorldEffects {
            space: SpaceEffects::default(),
            wet_road: WET_ROAD.default_on,
            wet_surfaces: WET_SURFACES.default_on,
        }
    }
}

impl WorldEffects {
    /// The switches from an effect set that declares the `env.*` and `space.*` effects (panics if
    /// it does not).
    pub fn from_effects(effects: &Effects) -> WorldEffects {
        WorldEffects {
            space: SpaceEffects::from_effects(effects),
            wet_road: effects.is_on(&WET_ROAD),
            wet_surfaces: effects.is_on(&WET_SURFACES),
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
    /// Sensor frame → scene frame (`p_scene = sensor_pose.transform_point(p_sensor)`).
    pub sensor_pose: Pose,
    /// Velocity of the sensor origin, scene frame axes, m/s.
    pub sensor_velocity_m_s: DVec3,
    /// Angular velocity of the sensor frame, scene frame axes, rad/s.
    pub sensor_angular_velocity_rad_s: DVec3,
    /// The sensor frame in global coordinates (with its motion).
    pub frame: SensorFrame,
    /// Weather in effect this step.
    pub weather: Weather,
    /// Measurement time of this step (SensorView timestamp, else ground truth's, else the
    /// communication point), s.
    pub time_s: f64,
    /// The same as an OSI timestamp.
    pub timestamp: osi3::Timestamp,
    /// Host vehicle id, if any.
    pub host_id: Option<u64>,
    /// The mounting in effect (physical sensor frame relative to the host vehicle frame).
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
    /// switches of a sensor's effect set ([`WorldEffects::from_effects`]): how every physical sensor
    /// builds its world.
    pub fn for_effects(effects: &Effects) -> SensorWorld {
        SensorWorld::new().with_effects(WorldEffects::from_effects(effects))
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
            frame,
            timestamp,
        } = resolved;

        // Scene: build once, update afterwards.
        let scene_err = |e: crate::environment::scene::SceneError| {
            ModelError::Input(format!("scene from the ground truth: {e}"))
        };
        let mut rebuild_space = self.space.is_none();
        match self.scene.as_mut() {
            Some(scene) => {
                let report = scene.update(gt).map_err(scene_err)?;
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
                    .build(gt)
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
            weather,
            time_s: osiris_proto::timestamp_to_seconds(&timestamp),
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
    [&crate::environment::effects()[..], crate::space::EFFECTS].concat()
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
