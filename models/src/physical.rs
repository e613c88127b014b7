//! The physical-sensor skeleton: the loop every physical model shares, written once (pbrt's
//! integrator loop: the shared part here, the physics in each sensor).
//!
//! One cycle of a [`PhysicalSensor`]:
//!
//! 1. **World**: bring the scene and the ray-traceable space to the SensorView
//!    (`crate::world::SensorWorld::update`: ground truth, host vehicle, mounting, sensor pose,
//!    measurement time and weather, resolved once).
//! 2. **Perceive** ([`Physics::perceive`]): the sensor's physics, from the world to its raw output
//!    and recognised objects.
//! 3. **Emit** ([`Physics::emit`]): the sensor's content of SensorData and PerceptionData.
//! 4. **Finish** (`crate::output::finish`): the headers (measurement time, sensor id, mounting,
//!    cycle counter, model mode), the OSI semantics against the ground truth, the optional copy of
//!    the SensorView.
//!
//! The skeleton also owns what every model keeps across cycles: the OSMP view-configuration
//! handshake (`crate::handshake`; a grant that narrows the field of view or range re-plans the
//! physics, [`Physics::replan`]), the cycle counter and the configured noise seed. A new physical
//! sensor implements [`Physics`] in its own folder and adds its line to the registry.

use crate::effects::Effects;
use crate::error::ModelError;
use crate::handshake::Handshake;
use crate::output::{FrameHeader, finish};
use crate::semantics::PoseFrames;
use crate::sensor::{
    CommonConfig, ModelMode, SensorKind, SensorModel, SensorSetup, StepInput, StepOutput,
};
use crate::world::{SensorWorld, WorldFrame};
use osiris_proto::osi3;

/// What one cycle gives the physics besides the world.
pub struct Cycle<'a> {
    /// Cycles completed before this one (the output's `cycle_counter`).
    pub index: u64,
    /// The configured seed of the random noise (`seed`, 0 when absent): same seed, same input,
    /// same output.
    pub seed: u64,
    /// The configuration in force (after the handshake).
    pub config: &'a CommonConfig,
    /// The SensorView of this cycle (decoded and screened).
    pub view: &'a osi3::SensorView,
    /// Communication step size, s.
    pub step_s: f64,
}

/// A sensor's physics: what a physical model fills into the shared loop of [`PhysicalSensor`].
pub trait Physics: Sized + Send {
    /// The sensor technology.
    const KIND: SensorKind;
    /// The model's own parameters (its configuration key: `lidar`, `radar`, `camera`).
    type Params;

    /// Plan the model once: check the parameters, precompute what every cycle reuses.
    fn plan(
        config: &CommonConfig,
        params: Self::Params,
        effects: Effects,
    ) -> Result<Self, ModelError>;

    /// Re-plan for a configuration the handshake narrowed (field of view or range).
    fn replan(&mut self, config: &CommonConfig) -> Result<(), ModelError>;

    /// One cycle's physics, from the world to the raw output and recognised objects (kept in the
    /// physics until [`Self::emit`]).
    fn perceive(&mut self, cycle: &Cycle<'_>, frame: &WorldFrame<'_>) -> Result<(), ModelError>;

    /// Write the cycle's content into `out`: everything in `out` from the previous cycle is to be
    /// replaced (lists may be taken out of it to reuse their allocations); the headers, the OSI
    /// semantics and the SensorView copy are the skeleton's.
    fn emit(&mut self, cycle: &Cycle<'_>, frame: &WorldFrame<'_>, out: &mut StepOutput);

    /// The ground truth a reported track had at its last update, for a track whose header
    /// carries none this cycle (a coasting track; `None`: unknown, or the model has no tracker).
    fn last_truth_of(&self, _tracking_id: u64) -> Option<u64> {
        None
    }

    /// Forget the state accumulated over cycles (trackers, auto exposure, ...).
    fn reset(&mut self);
}

/// A physical sensor model: the shared loop around a sensor's [`Physics`].
pub struct PhysicalSensor<P> {
    handshake: Handshake,
    world: SensorWorld,
    cycle: u64,
    physics: P,
}

impl<P: Physics> PhysicalSensor<P> {
    /// Build from a configuration (a checked `SensorConfig` of the registry, or a
    /// [`SensorSetup`]); errors name the bad key.
    pub fn new(
        config: impl TryInto<SensorSetup<P::Params>, Error = ModelError>,
    ) -> Result<Self, ModelError> {
        Self::from_setup(config.try_into()?)
    }

    /// Build from a setup; errors name the bad key.
    pub fn from_setup(setup: SensorSetup<P::Params>) -> Result<Self, ModelError> {
        let SensorSetup {
            common,
            params,
            effects,
        } = setup;
        if common.kind != P::KIND {
            return Err(ModelError::Config(format!(
                "`kind` must be `{}` for the {} model, got `{}`",
                P::KIND.name(),
                P::KIND.name(),
                common.kind.name()
            )));
        }
        // Environment and space-design switches (wet road, multipath, transmission, ...) reach
        // the scene and the space through the world.
        let world = SensorWorld::for_effects(&effects, P::KIND);
        let physics = P::plan(&common, params, effects)?;
        Ok(PhysicalSensor {
            handshake: Handshake::new(common),
            world,
            cycle: 0,
            physics,
        })
    }

    /// The sensor's physics.
    pub fn physics(&self) -> &P {
        &self.physics
    }

    /// The world kept across cycles (scene, space, warnings of the last update).
    pub fn world(&self) -> &SensorWorld {
        &self.world
    }

    /// Bring the world to `input` without a cycle of the physics: the frame, the configuration in
    /// force and the physics (for tools that run one stage alone, e.g. the radar's propagation).
    pub fn world_frame(
        &mut self,
        input: &StepInput<'_>,
    ) -> Result<(WorldFrame<'_>, &CommonConfig, &mut P), ModelError> {
        let config = self.handshake.config();
        let frame =
            self.world
                .update(input.view, config, input.time_s, self.handshake.sensor_id())?;
        Ok((frame, config, &mut self.physics))
    }
}

impl<P: Physics> SensorModel for PhysicalSensor<P> {
    fn kind(&self) -> SensorKind {
        P::KIND
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
        let granted = self.handshake.apply(granted)?;
        if granted.narrowed {
            self.physics.replan(self.handshake.config())?;
        }
        Ok(granted.notes)
    }

    fn step(&mut self, input: &StepInput<'_>, out: &mut StepOutput) -> Result<(), ModelError> {
        let index = self.cycle;
        let (frame, config, physics) = self.world_frame(input)?;
        let cycle = Cycle {
            index,
            seed: config.seed.unwrap_or(0),
            config,
            view: input.view,
            step_s: input.step_s,
        };
        physics.perceive(&cycle, &frame)?;
        physics.emit(&cycle, &frame, out);
        let physics = &*physics;
        finish(
            out,
            &FrameHeader::of_world(&frame, index),
            input.view,
            config,
            &PoseFrames::new(&frame.nominal_frame, &frame.mounting),
            &|t| physics.last_truth_of(t),
        );
        self.cycle += 1;
        Ok(())
    }

    fn reset(&mut self) {
        self.world.reset();
        self.physics.reset();
        self.cycle = 0;
    }
}

/// The sensor's motion at the measurement time as recognition takes it (ego-motion compensation,
/// tracking in the scene frame): the **nominal** pose and motion (the mounting on the host at the
/// stamped time, `WorldFrame::nominal_pose`), what the sensor believes; a miscalibrated sensor
/// compensates and tracks with it.
pub fn ego_state(frame: &WorldFrame<'_>) -> crate::recognition::EgoState {
    crate::recognition::EgoState {
        time_s: frame.time_s,
        sensor_pose: frame.nominal_pose,
        sensor_velocity_m_s: frame.nominal_frame.velocity,
        sensor_angular_velocity_rad_s: frame.nominal_frame.angular_velocity,
    }
}
