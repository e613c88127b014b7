//! Built-in scenario generator: OSI SensorViews of a straight multi-lane road over time.
//!
//! A [`ScenarioConfig`] (JSON, unknown keys rejected) describes an ego (host) vehicle and other road
//! users driving at constant velocity, a guardrail, static targets and the sensors mounted on the ego.
//! [`ScenarioConfig::sensor_view`] produces the `osi3::SensorView` of one sensor at one step.
//! `ScenarioConfig::default()` is the reference scenario; `serde_json` turns it into a file users can
//! start from ([`ScenarioConfig::to_json_pretty`]).
//!
//! # Geometry and conventions
//!
//! * Global frame: ISO 8855 axes (x forward along the road, y left, z up), m, rad, s. The road is flat
//!   (`z = 0`) and runs along +x from `x = 0` to `x = road.length_m`.
//! * Lanes: index `0` is the rightmost driving lane, `lanes − 1` the leftmost; lane `i` is centred at
//!   `y_i = (i − (lanes − 1)/2) · lane_width_m` (the road is centred on `y = 0`). Index `−1` is the
//!   right shoulder (centred in the shoulder strip of `shoulder_width_m`), index `lanes` the left verge
//!   (as far left of the leftmost lane's left edge as the shoulder is right of the rightmost one).
//! * Road users: `x_m` is the initial x of the bounding-box centre, the centre sits at half its height
//!   above the road, `heading_rad` is the yaw relative to +x (0: driving direction). Constant velocity:
//!   `p(t) = p₀ + speed·t·(cos h, sin h, 0)`, with `t = step · step_s` (the scenario's own time;
//!   timestamps add `start_time_s`). `base.velocity` is set accordingly; acceleration and orientation
//!   rate are zero.
//! * Vehicles carry `vehicle_attributes` (`bbcenter_to_rear`/`bbcenter_to_front` in the object frame,
//!   from typical overhangs, wheelbases and wheel radii) and `vehicle_classification`; pedestrians do
//!   not. Cyclists are OSI vehicles of class `BICYCLE` (rider included in the box).
//! * Pedestrians carry `pedestrian_attributes` ([`pedestrian_attributes`]): an upright adult skeleton
//!   of all 20 OSI bones scaled to the box height, arms hanging, head turned 20° to the left (a
//!   pedestrian glancing at the traffic beside them); a still pose (no gait cycle).
//! * Ground-truth ids are stable over time: ego `1` (or `ego.id`), road users `100 + i`, static objects
//!   `500 + i`, guardrail `900`, lanes `1000 + i` (`i = 0..lanes`, then the shoulder), lane boundaries
//!   `2000 + j` (`j = 0..=lanes` from right to left, then the road edge). Explicit `id`s override the
//!   object ids; all ids must be unique.
//! * Steps: `step_count() = round(duration_s / step_s)`, step `k` at `t = k · step_s` (the
//!   communication points of a co-simulation over `[0, duration_s)`).
//!
//! [`player`] turns a scenario (one sensor's view of it) or a recorded SensorView trace into one
//! stream of SensorViews over time: what `scenario.fmu` publishes.

pub mod player;
pub mod traffic_control;

pub use player::{Player, PlayerError};
pub use traffic_control::{
    MarkingKind, RoadMarkingConfig, SignKind, SignalHeadConfig, SignalPhase, SignalState,
    TrafficSignConfig,
};

use std::path::{Path, PathBuf};

use osiris_models::{Mounting, SensorConfig, SensorKind};
use osiris_proto::{id, interface_version, osi3, timestamp_from_seconds};
use serde::{Deserialize, Serialize};

/// Errors of reading or validating a scenario.
#[derive(Debug, thiserror::Error)]
pub enum ScenarioError {
    #[error("cannot read scenario file {}: {source}", path.display())]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    /// Syntax or schema error; `origin` is the file name (or "scenario JSON" for a string).
    #[error("{origin}: line {line}, column {column}: {message}")]
    Json {
        origin: String,
        line: usize,
        column: usize,
        message: String,
    },
    #[error("invalid scenario: {0}")]
    Invalid(String),
}

fn default_name() -> String {
    "osiris-default".into()
}
fn default_lanes() -> u32 {
    3
}
fn default_lane_width() -> f64 {
    3.5
}
fn default_road_length() -> f64 {
    400.0
}
fn default_shoulder_width() -> f64 {
    2.5
}
fn default_marking_width() -> f64 {
    0.15
}
fn default_dash_length() -> f64 {
    6.0
}
fn default_dash_gap() -> f64 {
    12.0
}
fn default_point_spacing() -> f64 {
    10.0
}

/// The straight road.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RoadConfig {
    /// Number of driving lanes (≥ 1).
    #[serde(default = "default_lanes")]
    pub lanes: u32,
    /// m
    #[serde(default = "default_lane_width")]
    pub lane_width_m: f64,
    /// Road length along +x, m.
    #[serde(default = "default_road_length")]
    pub length_m: f64,
    /// Paved shoulder right of the rightmost lane, m (0: none; no shoulder lane and no road-edge line).
    #[serde(default = "default_shoulder_width")]
    pub shoulder_width_m: f64,
    /// Width of the painted lines, m.
    #[serde(default = "default_marking_width")]
    pub marking_width_m: f64,
    /// Dashes of the lines between lanes: dash and gap length, m.
    #[serde(default = "default_dash_length")]
    pub dash_length_m: f64,
    #[serde(default = "default_dash_gap")]
    pub dash_gap_m: f64,
    /// Spacing of centreline and solid-line points, m.
    #[serde(default = "default_point_spacing")]
    pub point_spacing_m: f64,
}

impl Default for RoadConfig {
    fn default() -> Self {
        RoadConfig {
            lanes: default_lanes(),
            lane_width_m: default_lane_width(),
            length_m: default_road_length(),
            shoulder_width_m: default_shoulder_width(),
            marking_width_m: default_marking_width(),
            dash_length_m: default_dash_length(),
            dash_gap_m: default_dash_gap(),
            point_spacing_m: default_point_spacing(),
        }
    }
}

impl RoadConfig {
    /// Lateral position (y, m) of the centre of lane `lane` (see the module documentation).
    pub fn lane_center_y(&self, lane: i32) -> f64 {
        let n = f64::from(self.lanes);
        let w = self.lane_width_m;
        if lane < 0 {
            -0.5 * n * w - 0.5 * self.shoulder_width_m
        } else if lane >= self.lanes as i32 {
            0.5 * n * w + 0.5 * self.shoulder_width_m
        } else {
            (f64::from(lane) - 0.5 * (n - 1.0)) * w
        }
    }

    /// y of lane boundary `j` (0 = right edge of lane 0, `lanes` = left edge of the leftmost lane).
    pub fn boundary_y(&self, j: u32) -> f64 {
        (f64::from(j) - 0.5 * f64::from(self.lanes)) * self.lane_width_m
    }

    /// y of the outer edge of the right shoulder.
    pub fn road_edge_right_y(&self) -> f64 {
        self.boundary_y(0) - self.shoulder_width_m
    }

    /// The driving lane (0..lanes) or shoulder (−1) containing lateral position `y`, if any.
    pub fn lane_at(&self, y: f64) -> Option<i32> {
        let j = ((y - self.boundary_y(0)) / self.lane_width_m).floor();
        if j >= 0.0 && j < f64::from(self.lanes) {
            Some(j as i32)
        } else if self.shoulder_width_m > 0.0
            && y < self.boundary_y(0)
            && y >= self.road_edge_right_y()
        {
            Some(-1)
        } else {
            None
        }
    }
}

/// Kinds of road users (moving objects).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum RoadUserKind {
    Car,
    Van,
    Truck,
    Bus,
    Motorcycle,
    Cyclist,
    Pedestrian,
}

/// Typical geometry of a road-user kind.
struct RoadUserGeometry {
    /// length, width, height, m
    dim: [f64; 3],
    /// Rear overhang (rear of the box to the rear axle), wheelbase and wheel radius, m (vehicles).
    axles: Option<(f64, f64, f64)>,
    wheels: u32,
}

impl RoadUserKind {
    fn name(self) -> &'static str {
        match self {
            RoadUserKind::Car => "car",
            RoadUserKind::Van => "van",
            RoadUserKind::Truck => "truck",
            RoadUserKind::Bus => "bus",
            RoadUserKind::Motorcycle => "motorcycle",
            RoadUserKind::Cyclist => "cyclist",
            RoadUserKind::Pedestrian => "pedestrian",
        }
    }

    fn geometry(self) -> RoadUserGeometry {
        let g = |dim, axles, wheels| RoadUserGeometry { dim, axles, wheels };
        match self {
            RoadUserKind::Car => g([4.5, 1.8, 1.5], Some((0.9, 2.7, 0.32)), 4),
            RoadUserKind::Van => g([5.4, 2.0, 2.3], Some((1.0, 3.4, 0.35)), 4),
            RoadUserKind::Truck => g([10.0, 2.55, 3.6], Some((2.5, 5.0, 0.5)), 6),
            RoadUserKind::Bus => g([12.0, 2.55, 3.2], Some((3.0, 6.0, 0.5)), 6),
            RoadUserKind::Motorcycle => g([2.2, 0.8, 1.4], Some((0.35, 1.5, 0.3)), 2),
            RoadUserKind::Cyclist => g([1.8, 0.6, 1.75], Some((0.35, 1.1, 0.35)), 2),
            RoadUserKind::Pedestrian => g([0.5, 0.6, 1.8], None, 0),
        }
    }

    fn osi_type(self) -> osi3::moving_object::Type {
        match self {
            RoadUserKind::Pedestrian => osi3::moving_object::Type::Pedestrian,
            _ => osi3::moving_object::Type::Vehicle,
        }
    }

    fn vehicle_class(self) -> Option<osi3::moving_object::vehicle_classification::Type> {
        use osi3::moving_object::vehicle_classification::Type as V;
        match self {
            RoadUserKind::Car => Some(V::Car),
            RoadUserKind::Van => Some(V::DeliveryVan),
            RoadUserKind::Truck => Some(V::HeavyTruck),
            RoadUserKind::Bus => Some(V::Bus),
            RoadUserKind::Motorcycle => Some(V::Motorbike),
            RoadUserKind::Cyclist => Some(V::Bicycle),
            RoadUserKind::Pedestrian => None,
        }
    }
}

/// A road user (also the ego): kind, lane, initial position and constant speed.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RoadUserConfig {
    pub kind: RoadUserKind,
    /// Ground-truth id (default: see the module documentation).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub id: Option<u64>,
    /// Lane index (−1 right shoulder, `lanes` left verge).
    pub lane: i32,
    /// Lateral offset from the lane centre, m (positive to the left).
    #[serde(default)]
    pub lateral_offset_m: f64,
    /// Initial x of the box centre, m.
    pub x_m: f64,
    /// Constant speed along the heading, m/s.
    pub speed_m_s: f64,
    /// Heading (yaw) relative to the road direction, rad.
    #[serde(default)]
    pub heading_rad: f64,
    /// OSI `model_reference` (default `osiris:<kind>`, e.g. `osiris:car?paint=black`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub model_reference: Option<String>,
    /// Box length, width, height, m (default: typical for the kind).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub dimension_m: Option<[f64; 3]>,
}

impl RoadUserConfig {
    fn new(kind: RoadUserKind, lane: i32, x_m: f64, speed_m_s: f64) -> RoadUserConfig {
        RoadUserConfig {
            kind,
            id: None,
            lane,
            lateral_offset_m: 0.0,
            x_m,
            speed_m_s,
            heading_rad: 0.0,
            model_reference: None,
            dimension_m: None,
        }
    }
}

/// Kinds of static targets.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum StaticKind {
    /// Trihedral corner reflector (0.1 m inner edge) on a 1 m pole; `osiris:trihedral?edge_m=0.1`.
    CornerReflector,
    /// 1 m × 1 m Lambertian (50 %) board on legs, its face towards −x (oncoming ego traffic);
    /// `osiris:board?width_m=1&height_m=1&material=lambertian_50`.
    Board,
    /// Traffic cone, 0.5 m; `osiris:cone`.
    Cone,
    /// Metal pole, 3 m; `osiris:pole`.
    Pole,
}

impl StaticKind {
    /// Default (dimension, bottom height above the road, model reference, type, material, colour).
    #[allow(clippy::type_complexity)]
    fn defaults(
        self,
    ) -> (
        [f64; 3],
        f64,
        &'static str,
        osi3::stationary_object::classification::Type,
        osi3::stationary_object::classification::Material,
        osi3::stationary_object::classification::Color,
    ) {
        use osi3::stationary_object::classification::{Color as C, Material as M, Type as T};
        match self {
            StaticKind::CornerReflector => (
                [0.15, 0.15, 1.15],
                0.0,
                "osiris:trihedral?edge_m=0.1",
                T::ReflectiveStructure,
                M::Metal,
                C::Gray,
            ),
            StaticKind::Board => (
                [0.05, 1.0, 1.0],
                0.5,
                "osiris:board?width_m=1&height_m=1&material=lambertian_50",
                T::RectangularStructure,
                M::Other,
                C::Gray,
            ),
            StaticKind::Cone => (
                [0.3, 0.3, 0.5],
                0.0,
                "osiris:cone",
                T::Pylon,
                M::Plastic,
                C::Orange,
            ),
            StaticKind::Pole => (
                [0.1, 0.1, 3.0],
                0.0,
                "osiris:pole",
                T::Pole,
                M::Metal,
                C::Gray,
            ),
        }
    }
}

/// A static target.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StaticObjectConfig {
    pub kind: StaticKind,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub id: Option<u64>,
    /// Lane index (−1 right shoulder, `lanes` left verge).
    pub lane: i32,
    #[serde(default)]
    pub lateral_offset_m: f64,
    /// x of the box centre, m.
    pub x_m: f64,
    /// Height of the box bottom above the road, m (default: per kind).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub z_m: Option<f64>,
    #[serde(default)]
    pub yaw_rad: f64,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub model_reference: Option<String>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub dimension_m: Option<[f64; 3]>,
}

/// Which side of the road.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Side {
    Left,
    Right,
}

fn default_guardrail_offset() -> f64 {
    0.5
}
fn default_guardrail_height() -> f64 {
    0.75
}
fn default_guardrail_width() -> f64 {
    0.3
}

/// A guardrail along the road: one stationary object (type `BARRIER`, `osiris:guardrail`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GuardrailConfig {
    pub side: Side,
    /// Gap between the road edge (outer shoulder edge on the right, leftmost lane edge on the left) and
    /// the guardrail's road-side face, m.
    #[serde(default = "default_guardrail_offset")]
    pub offset_m: f64,
    /// Height of the top above the road, m (the box spans 0..height).
    #[serde(default = "default_guardrail_height")]
    pub height_m: f64,
    /// Thickness, m.
    #[serde(default = "default_guardrail_width")]
    pub width_m: f64,
    /// Start x and length, m (default: the whole road).
    #[serde(default)]
    pub x_start_m: f64,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub length_m: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub id: Option<u64>,
}

fn default_time_of_day() -> f64 {
    12.0 * 3600.0
}
fn default_illumination() -> u8 {
    9
}
fn default_temperature() -> f64 {
    293.15
}
fn default_pressure() -> f64 {
    101_325.0
}
fn default_humidity() -> f64 {
    50.0
}

/// Environmental conditions written into every ground truth.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct EnvironmentConfig {
    /// Time of day at scenario time 0, s since midnight.
    #[serde(default = "default_time_of_day")]
    pub time_of_day_s: f64,
    /// OSI ambient illumination level 1 (darkest, < 0.01 lx) … 9 (daylight, > 10 000 lx).
    #[serde(default = "default_illumination")]
    pub ambient_illumination_level: u8,
    /// K
    #[serde(default = "default_temperature")]
    pub temperature_k: f64,
    /// Pa
    #[serde(default = "default_pressure")]
    pub atmospheric_pressure_pa: f64,
    /// %
    #[serde(default = "default_humidity")]
    pub relative_humidity_percent: f64,
    /// Rain rate, mm/h. OSI carries only a category (`precipitation`, derived from this); sensor
    /// models take the rate from [`ScenarioConfig::weather`].
    #[serde(default)]
    pub rain_mm_h: f64,
    /// Fog visibility, m (absent = clear). OSI carries only a category (`fog`, derived from this).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub fog_visibility_m: Option<f64>,
}

impl Default for EnvironmentConfig {
    fn default() -> Self {
        EnvironmentConfig {
            time_of_day_s: default_time_of_day(),
            ambient_illumination_level: default_illumination(),
            temperature_k: default_temperature(),
            atmospheric_pressure_pa: default_pressure(),
            relative_humidity_percent: default_humidity(),
            rain_mm_h: 0.0,
            fog_visibility_m: None,
        }
    }
}

/// A sensor on the ego vehicle.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SensorMount {
    /// Unique name (e.g. the FMU instance name).
    pub name: String,
    pub kind: SensorKind,
    /// OSI sensor id written into the SensorView.
    pub sensor_id: u64,
    /// Mounting in the host vehicle frame (default: `SensorConfig::default_for(kind).mounting`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub mounting: Option<Mounting>,
}

impl SensorMount {
    /// A sensor with the default mounting of its kind.
    pub fn new(name: &str, kind: SensorKind, sensor_id: u64) -> SensorMount {
        SensorMount {
            name: name.into(),
            kind,
            sensor_id,
            mounting: None,
        }
    }

    /// The mounting in effect.
    pub fn mounting(&self) -> Mounting {
        self.mounting
            .unwrap_or_else(|| SensorConfig::default_for(self.kind).mounting)
    }
}

/// A scenario (see the module documentation).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ScenarioConfig {
    #[serde(default = "default_name")]
    pub name: String,
    /// Scenario duration, s.
    pub duration_s: f64,
    /// Step (communication step) size, s.
    pub step_s: f64,
    /// Timestamp of step 0, s.
    #[serde(default)]
    pub start_time_s: f64,
    #[serde(default)]
    pub road: RoadConfig,
    #[serde(default)]
    pub environment: EnvironmentConfig,
    /// The host vehicle.
    pub ego: RoadUserConfig,
    #[serde(default)]
    pub road_users: Vec<RoadUserConfig>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub guardrail: Option<GuardrailConfig>,
    #[serde(default)]
    pub static_objects: Vec<StaticObjectConfig>,
    /// Traffic signs on posts ([`traffic_control`]).
    #[serde(default)]
    pub traffic_signs: Vec<TrafficSignConfig>,
    /// Three-bulb signal heads with their cycles ([`traffic_control`]).
    #[serde(default)]
    pub signal_heads: Vec<SignalHeadConfig>,
    /// Stop lines and lane arrows ([`traffic_control`]).
    #[serde(default)]
    pub road_markings: Vec<RoadMarkingConfig>,
    #[serde(default)]
    pub sensors: Vec<SensorMount>,
}

impl Default for ScenarioConfig {
    /// 3-lane straight road, 400 m; ego at 25 m/s in the middle lane; a slower car 40 m ahead in the
    /// same lane, a truck in the left lane, a car behind the ego, a cyclist and a pedestrian on the
    /// right shoulder ahead, a guardrail on the right, a corner reflector, a board and a cone ahead;
    /// a signalised stop line 135 m ahead (300 mm signal heads on both sides, EN 12368's size for
    /// fast approaches, turning from green to yellow
    /// at t = 1 s, a stop line across the three lanes, right/straight/left arrows before it), a
    /// 70 km/h speed-limit sign and a "traffic signals ahead" warning sign on the right;
    /// camera, radar and LiDAR with their default mountings; 2 s at 0.02 s.
    fn default() -> Self {
        use RoadUserKind::*;
        let ego_x = 50.0;
        let mut pedestrian = RoadUserConfig::new(Pedestrian, -1, ego_x + 110.0, 1.4);
        pedestrian.lateral_offset_m = -0.5;
        let static_at = |kind, x_m, lateral_offset_m| StaticObjectConfig {
            kind,
            id: None,
            lane: -1,
            lateral_offset_m,
            x_m,
            z_m: None,
            yaw_rad: 0.0,
            model_reference: None,
            dimension_m: None,
        };
        ScenarioConfig {
            name: default_name(),
            duration_s: 2.0,
            step_s: 0.01,
            start_time_s: 0.0,
            road: RoadConfig::default(),
            environment: EnvironmentConfig::default(),
            ego: RoadUserConfig {
                model_reference: Some("osiris:car?paint=white".into()),
                ..RoadUserConfig::new(Car, 1, ego_x, 25.0)
            },
            road_users: vec![
                RoadUserConfig {
                    model_reference: Some("osiris:car?paint=black".into()),
                    ..RoadUserConfig::new(Car, 1, ego_x + 40.0, 20.0)
                },
                RoadUserConfig::new(Truck, 2, ego_x + 25.0, 22.0),
                RoadUserConfig::new(Car, 1, ego_x - 25.0, 25.0),
                RoadUserConfig::new(Cyclist, -1, ego_x + 80.0, 5.0),
                pedestrian,
            ],
            guardrail: Some(GuardrailConfig {
                side: Side::Right,
                offset_m: default_guardrail_offset(),
                height_m: default_guardrail_height(),
                width_m: default_guardrail_width(),
                x_start_m: 0.0,
                length_m: None,
                id: None,
            }),
            static_objects: vec![
                static_at(StaticKind::CornerReflector, ego_x + 100.0, 0.5),
                static_at(StaticKind::Board, ego_x + 130.0, 0.0),
                static_at(StaticKind::Cone, ego_x + 70.0, 0.8),
            ],
            traffic_signs: vec![
                TrafficSignConfig {
                    sign: SignKind::SpeedLimit,
                    value: Some(70.0),
                    x_m: ego_x + 50.0,
                    lane: -1,
                    lateral_offset_m: -0.5,
                    size_m: 0.6,
                    height_m: 2.0,
                    id: None,
                },
                TrafficSignConfig {
                    sign: SignKind::TrafficSignalsAhead,
                    value: None,
                    x_m: ego_x + 75.0,
                    lane: -1,
                    lateral_offset_m: -0.5,
                    size_m: 0.9,
                    height_m: 2.0,
                    id: None,
                },
            ],
            signal_heads: {
                let cycle = vec![
                    SignalPhase {
                        state: SignalState::Green,
                        duration_s: 1.0,
                    },
                    SignalPhase {
                        state: SignalState::Yellow,
                        duration_s: 3.0,
                    },
                    SignalPhase {
                        state: SignalState::Red,
                        duration_s: 20.0,
                    },
                    SignalPhase {
                        state: SignalState::RedYellow,
                        duration_s: 1.0,
                    },
                ];
                let head = |lane, lateral_offset_m| SignalHeadConfig {
                    x_m: ego_x + 135.0,
                    lane,
                    lateral_offset_m,
                    z_m: 2.5,
                    lens_diameter_m: 0.3,
                    cycle: cycle.clone(),
                    offset_s: 0.0,
                    id: None,
                };
                vec![head(-1, -0.5), head(3, 0.5)]
            },
            road_markings: {
                let m = |kind, x_m, lane| RoadMarkingConfig {
                    kind,
                    x_m,
                    lane,
                    id: None,
                };
                let stop_x = ego_x + 131.0;
                let arrow_x = ego_x + 115.0;
                vec![
                    m(MarkingKind::StopLine, stop_x, 0),
                    m(MarkingKind::StopLine, stop_x, 1),
                    m(MarkingKind::StopLine, stop_x, 2),
                    m(MarkingKind::ArrowRight, arrow_x, 0),
                    m(MarkingKind::ArrowStraight, arrow_x, 1),
                    m(MarkingKind::ArrowLeft, arrow_x, 2),
                ]
            },
            sensors: SensorKind::ALL
                .iter()
                .enumerate()
                .map(|(i, &k)| {
                    SensorMount::new(&format!("front_{}", k.name()), k, 10 * (i as u64 + 1))
                })
                .collect(),
        }
    }
}

/// Turn a serde_json error into [`ScenarioError::Json`] (without serde's own position suffix).
fn json_error(origin: &str, e: &serde_json::Error) -> ScenarioError {
    let text = e.to_string();
    let suffix = format!(" at line {} column {}", e.line(), e.column());
    let message = text.strip_suffix(&suffix).unwrap_or(&text).to_string();
    ScenarioError::Json {
        origin: origin.to_string(),
        line: e.line(),
        column: e.column(),
        message,
    }
}

impl ScenarioConfig {
    /// Parse and validate a JSON scenario; errors name the line, column and the offending key.
    pub fn from_json_str(text: &str) -> Result<ScenarioConfig, ScenarioError> {
        Self::parse(text, "scenario JSON")
    }

    /// Read, parse and validate a JSON scenario file; errors name the file, line and column.
    pub fn from_json_file(path: impl AsRef<Path>) -> Result<ScenarioConfig, ScenarioError> {
        let path = path.as_ref();
        let text = std::fs::read_to_string(path).map_err(|source| ScenarioError::Io {
            path: path.to_path_buf(),
            source,
        })?;
        Self::parse(&text, &path.display().to_string())
    }

    fn parse(text: &str, origin: &str) -> Result<ScenarioConfig, ScenarioError> {
        let cfg: ScenarioConfig = serde_json::from_str(text).map_err(|e| json_error(origin, &e))?;
        cfg.validate().map_err(|e| match e {
            ScenarioError::Invalid(m) => ScenarioError::Invalid(format!("{origin}: {m}")),
            other => other,
        })?;
        Ok(cfg)
    }

    /// Pretty-printed JSON of this scenario (reads back with [`ScenarioConfig::from_json_str`]).
    pub fn to_json_pretty(&self) -> String {
        serde_json::to_string_pretty(self).expect("a scenario always serializes")
    }

    /// Check value ranges and id uniqueness.
    pub fn validate(&self) -> Result<(), ScenarioError> {
        let bad = |m: String| Err(ScenarioError::Invalid(m));
        let positive = |name: &str, v: f64| {
            if v.is_finite() && v > 0.0 {
                Ok(())
            } else {
                bad(format!("`{name}` must be a finite number > 0, got {v}"))
            }
        };
        let non_negative = |name: &str, v: f64| {
            if v.is_finite() && v >= 0.0 {
                Ok(())
            } else {
                bad(format!("`{name}` must be a finite number ≥ 0, got {v}"))
            }
        };
        let finite = |name: &str, v: f64| {
            if v.is_finite() {
                Ok(())
            } else {
                bad(format!("`{name}` must be finite, got {v}"))
            }
        };
        positive("step_s", self.step_s)?;
        non_negative("duration_s", self.duration_s)?;
        traffic_control::validate(&self.traffic_signs, &self.signal_heads, &self.road_markings)?;
        non_negative("environment.rain_mm_h", self.environment.rain_mm_h)?;
        if let Some(v) = self.environment.fog_visibility_m {
            positive("environment.fog_visibility_m", v)?;
        }
        finite("start_time_s", self.start_time_s)?;
        let r = &self.road;
        if r.lanes == 0 || r.lanes > 64 {
            return bad(format!("`road.lanes` must be in 1..=64, got {}", r.lanes));
        }
        positive("road.lane_width_m", r.lane_width_m)?;
        positive("road.length_m", r.length_m)?;
        non_negative("road.shoulder_width_m", r.shoulder_width_m)?;
        non_negative("road.marking_width_m", r.marking_width_m)?;
        positive("road.dash_length_m", r.dash_length_m)?;
        positive("road.dash_gap_m", r.dash_gap_m)?;
        positive("road.point_spacing_m", r.point_spacing_m)?;
        let e = &self.environment;
        if !(1..=9).contains(&e.ambient_illumination_level) {
            return bad(format!(
                "`environment.ambient_illumination_level` must be in 1..=9, got {}",
                e.ambient_illumination_level
            ));
        }
        finite("environment.time_of_day_s", e.time_of_day_s)?;
        positive("environment.temperature_k", e.temperature_k)?;
        positive(
            "environment.atmospheric_pressure_pa",
            e.atmospheric_pressure_pa,
        )?;
        if !(0.0..=100.0).contains(&e.relative_humidity_percent) {
            return bad(format!(
                "`environment.relative_humidity_percent` must be in 0..=100, got {}",
                e.relative_humidity_percent
            ));
        }
        let lane_ok = |name: &str, lane: i32| {
            if lane >= -1 && lane <= r.lanes as i32 {
                Ok(())
            } else {
                bad(format!(
                    "`{name}.lane` must be in -1..={}, got {lane}",
                    r.lanes
                ))
            }
        };
        let dims_ok = |name: &str, d: Option<[f64; 3]>| match d {
            Some(d) if !d.iter().all(|v| v.is_finite() && *v > 0.0) => bad(format!(
                "`{name}.dimension_m` must be three finite numbers > 0, got {d:?}"
            )),
            _ => Ok(()),
        };
        for (i, u) in std::iter::once(&self.ego)
            .chain(&self.road_users)
            .enumerate()
        {
            let name = if i == 0 {
                "ego".to_string()
            } else {
                format!("road_users[{}]", i - 1)
            };
            lane_ok(&name, u.lane)?;
            dims_ok(&name, u.dimension_m)?;
            finite(&format!("{name}.x_m"), u.x_m)?;
            finite(&format!("{name}.speed_m_s"), u.speed_m_s)?;
            finite(&format!("{name}.heading_rad"), u.heading_rad)?;
            finite(&format!("{name}.lateral_offset_m"), u.lateral_offset_m)?;
        }
        for (i, s) in self.static_objects.iter().enumerate() {
            let name = format!("static_objects[{i}]");
            lane_ok(&name, s.lane)?;
            dims_ok(&name, s.dimension_m)?;
            finite(&format!("{name}.x_m"), s.x_m)?;
            finite(&format!("{name}.yaw_rad"), s.yaw_rad)?;
            finite(&format!("{name}.lateral_offset_m"), s.lateral_offset_m)?;
            finite(&format!("{name}.z_m"), s.z_m.unwrap_or(0.0))?;
        }
        if let Some(g) = &self.guardrail {
            non_negative("guardrail.offset_m", g.offset_m)?;
            positive("guardrail.height_m", g.height_m)?;
            positive("guardrail.width_m", g.width_m)?;
            finite("guardrail.x_start_m", g.x_start_m)?;
            if let Some(l) = g.length_m {
                positive("guardrail.length_m", l)?;
            }
        }
        // Unique ground-truth ids.
        let mut ids: Vec<(u64, String)> = self.object_ids();
        for i in 0..self.lane_count() {
            ids.push((1000 + i as u64, format!("lane {i}")));
        }
        for j in 0..self.boundary_count() {
            ids.push((2000 + j as u64, format!("lane boundary {j}")));
        }
        ids.sort();
        for w in ids.windows(2) {
            if w[0].0 == w[1].0 {
                return bad(format!(
                    "id {} is used by both {} and {}",
                    w[0].0, w[0].1, w[1].1
                ));
            }
        }
        if ids.iter().any(|(i, _)| *i == osiris_proto::INVALID_ID) {
            return bad("id 2^64-1 is reserved (invalid)".into());
        }
        // Unique sensor names and ids; valid mountings.
        for (i, s) in self.sensors.iter().enumerate() {
            for t in &self.sensors[..i] {
                if t.name == s.name {
                    return bad(format!("two sensors are named `{}`", s.name));
                }
                if t.sensor_id == s.sensor_id {
                    return bad(format!(
                        "sensors `{}` and `{}` share sensor_id {}",
                        t.name, s.name, s.sensor_id
                    ));
                }
            }
            let m = s.mounting();
            if m.position_m
                .iter()
                .chain(&m.orientation_rad)
                .any(|v| !v.is_finite())
            {
                return bad(format!(
                    "sensor `{}`: mounting values must be finite",
                    s.name
                ));
            }
        }
        Ok(())
    }

    /// (id, description) of every object: ego, road users, static objects, guardrail.
    fn object_ids(&self) -> Vec<(u64, String)> {
        let mut ids = vec![(self.ego_id(), "the ego".to_string())];
        for (i, u) in self.road_users.iter().enumerate() {
            ids.push((u.id.unwrap_or(100 + i as u64), format!("road_users[{i}]")));
        }
        for (i, s) in self.static_objects.iter().enumerate() {
            ids.push((
                s.id.unwrap_or(500 + i as u64),
                format!("static_objects[{i}]"),
            ));
        }
        if let Some(g) = &self.guardrail {
            ids.push((g.id.unwrap_or(900), "the guardrail".to_string()));
        }
        ids.extend(traffic_control::ids(
            &self.traffic_signs,
            &self.signal_heads,
            &self.road_markings,
        ));
        ids
    }

    /// Ground-truth id of the host vehicle.
    pub fn ego_id(&self) -> u64 {
        self.ego.id.unwrap_or(1)
    }

    /// Number of steps: `round(duration_s / step_s)`.
    pub fn step_count(&self) -> usize {
        (self.duration_s / self.step_s).round() as usize
    }

    /// Scenario time of a step, s (`step · step_s`; timestamps add `start_time_s`).
    pub fn time_s(&self, step: usize) -> f64 {
        step as f64 * self.step_s
    }

    /// The sensor named `name`.
    pub fn sensor(&self, name: &str) -> Option<&SensorMount> {
        self.sensors.iter().find(|s| s.name == name)
    }

    fn has_shoulder(&self) -> bool {
        self.road.shoulder_width_m > 0.0
    }

    fn lane_count(&self) -> usize {
        self.road.lanes as usize + usize::from(self.has_shoulder())
    }

    fn boundary_count(&self) -> usize {
        self.road.lanes as usize + 1 + usize::from(self.has_shoulder())
    }

    /// The ground-truth id of lane index `lane` (−1 = shoulder), if that lane exists in the ground truth.
    fn lane_id(&self, lane: i32) -> Option<u64> {
        if lane >= 0 && lane < self.road.lanes as i32 {
            Some(1000 + lane as u64)
        } else if lane == -1 && self.has_shoulder() {
            Some(1000 + u64::from(self.road.lanes))
        } else {
            None
        }
    }

    /// The moving object of a road user at scenario time `t`.
    fn moving_object(&self, u: &RoadUserConfig, oid: u64, t: f64) -> osi3::MovingObject {
        use osi3::moving_object::{
            MovingObjectClassification, VehicleAttributes, VehicleClassification,
        };
        let geo = u.kind.geometry();
        let dim = u.dimension_m.unwrap_or(geo.dim);
        let (sh, ch) = u.heading_rad.sin_cos();
        let x = u.x_m + u.speed_m_s * t * ch;
        let y = self.road.lane_center_y(u.lane) + u.lateral_offset_m + u.speed_m_s * t * sh;
        let z = 0.5 * dim[2];
        let lane_id = self.road.lane_at(y).and_then(|l| self.lane_id(l));
        let vehicle_attributes = geo.axles.map(|(overhang, wheelbase, radius)| {
            // Scale the typical axle positions with the box length if the dimension was overridden.
            let k = dim[0] / geo.dim[0];
            let rear = [-0.5 * dim[0] + overhang * k, 0.0, radius - 0.5 * dim[2]];
            VehicleAttributes {
                radius_wheel: Some(radius),
                number_wheels: Some(geo.wheels),
                bbcenter_to_rear: Some(vec3(rear)),
                bbcenter_to_front: Some(vec3([rear[0] + wheelbase * k, 0.0, rear[2]])),
                ground_clearance: Some(
                    if u.kind == RoadUserKind::Truck || u.kind == RoadUserKind::Bus {
                        0.3
                    } else {
                        0.15
                    },
                ),
                ..Default::default()
            }
        });
        osi3::MovingObject {
            id: Some(id(oid)),
            base: Some(osi3::BaseMoving {
                dimension: Some(osi3::Dimension3d {
                    length: Some(dim[0]),
                    width: Some(dim[1]),
                    height: Some(dim[2]),
                }),
                position: Some(vec3([x, y, z])),
                orientation: Some(osi3::Orientation3d {
                    roll: Some(0.0),
                    pitch: Some(0.0),
                    yaw: Some(u.heading_rad),
                }),
                velocity: Some(vec3([u.speed_m_s * ch, u.speed_m_s * sh, 0.0])),
                acceleration: Some(vec3([0.0; 3])),
                orientation_rate: Some(osi3::Orientation3d {
                    roll: Some(0.0),
                    pitch: Some(0.0),
                    yaw: Some(0.0),
                }),
                ..Default::default()
            }),
            r#type: Some(u.kind.osi_type() as i32),
            assigned_lane_id: lane_id.map(id).into_iter().collect(),
            vehicle_attributes,
            vehicle_classification: u.kind.vehicle_class().map(|c| VehicleClassification {
                r#type: Some(c as i32),
                has_trailer: Some(false),
                role: Some(osi3::moving_object::vehicle_classification::Role::Civil as i32),
                ..Default::default()
            }),
            model_reference: Some(
                u.model_reference
                    .clone()
                    .unwrap_or_else(|| format!("osiris:{}", u.kind.name())),
            ),
            moving_object_classification: lane_id.map(|l| MovingObjectClassification {
                assigned_lane_id: vec![id(l)],
                assigned_lane_percentage: vec![100.0],
                ..Default::default()
            }),
            pedestrian_attributes: (u.kind == RoadUserKind::Pedestrian)
                .then(|| pedestrian_attributes(dim[2])),
            ..Default::default()
        }
    }

    fn stationary_objects(&self) -> Vec<osi3::StationaryObject> {
        use osi3::stationary_object::Classification;
        use osi3::stationary_object::classification::{Color as C, Material as M, Type as T};
        let mut out = Vec::with_capacity(self.static_objects.len() + 1);
        let lane_ids = |y: f64| -> Vec<osi3::Identifier> {
            self.road
                .lane_at(y)
                .and_then(|l| self.lane_id(l))
                .map(id)
                .into_iter()
                .collect()
        };
        for (i, s) in self.static_objects.iter().enumerate() {
            let (dim0, z0, reference, ty, material, color) = s.kind.defaults();
            let dim = s.dimension_m.unwrap_or(dim0);
            let y = self.road.lane_center_y(s.lane) + s.lateral_offset_m;
            let z = s.z_m.unwrap_or(z0) + 0.5 * dim[2];
            out.push(osi3::StationaryObject {
                id: Some(id(s.id.unwrap_or(500 + i as u64))),
                base: Some(osi3::BaseStationary {
                    dimension: Some(osi3::Dimension3d {
                        length: Some(dim[0]),
                        width: Some(dim[1]),
                        height: Some(dim[2]),
                    }),
                    position: Some(vec3([s.x_m, y, z])),
                    orientation: Some(osi3::Orientation3d {
                        roll: Some(0.0),
                        pitch: Some(0.0),
                        yaw: Some(s.yaw_rad),
                    }),
                    ..Default::default()
                }),
                classification: Some(Classification {
                    r#type: Some(ty as i32),
                    material: Some(material as i32),
                    density: Some(osi3::stationary_object::classification::Density::Solid as i32),
                    color: Some(color as i32),
                    assigned_lane_id: lane_ids(y),
                    ..Default::default()
                }),
                model_reference: Some(
                    s.model_reference
                        .clone()
                        .unwrap_or_else(|| reference.to_string()),
                ),
                ..Default::default()
            });
        }
        if let Some(g) = &self.guardrail {
            let length = g.length_m.unwrap_or(self.road.length_m);
            let y = match g.side {
                Side::Right => self.road.road_edge_right_y() - g.offset_m - 0.5 * g.width_m,
                Side::Left => self.road.boundary_y(self.road.lanes) + g.offset_m + 0.5 * g.width_m,
            };
            out.push(osi3::StationaryObject {
                id: Some(id(g.id.unwrap_or(900))),
                base: Some(osi3::BaseStationary {
                    dimension: Some(osi3::Dimension3d {
                        length: Some(length),
                        width: Some(g.width_m),
                        height: Some(g.height_m),
                    }),
                    position: Some(vec3([g.x_start_m + 0.5 * length, y, 0.5 * g.height_m])),
                    orientation: Some(osi3::Orientation3d {
                        roll: Some(0.0),
                        pitch: Some(0.0),
                        yaw: Some(0.0),
                    }),
                    ..Default::default()
                }),
                classification: Some(Classification {
                    r#type: Some(T::Barrier as i32),
                    material: Some(M::Metal as i32),
                    density: Some(osi3::stationary_object::classification::Density::Solid as i32),
                    color: Some(C::Gray as i32),
                    ..Default::default()
                }),
                // The W-beam faces the road: +y (the asset default) for a rail on the right of
                // the road, -y for one on the left.
                model_reference: Some(
                    match g.side {
                        Side::Right => "osiris:guardrail",
                        Side::Left => "osiris:guardrail?face=right",
                    }
                    .into(),
                ),
                ..Default::default()
            });
        }
        out
    }

    /// Lanes (driving lanes right to left, then the shoulder) and lane boundaries (right to left,
    /// then the road edge). `host_lane` marks `is_host_vehicle_lane`.
    fn lanes(&self, host_lane: Option<i32>) -> (Vec<osi3::Lane>, Vec<osi3::LaneBoundary>) {
        use osi3::lane::Classification;
        use osi3::lane::classification::{Subtype, Type as LaneType};
        use osi3::lane_boundary::boundary_point::Dash;
        use osi3::lane_boundary::classification::{Color as BColor, Type as BType};
        let r = &self.road;
        let n = r.lanes;
        let xs: Vec<f64> = {
            let k = (r.length_m / r.point_spacing_m).ceil().max(1.0) as usize;
            (0..=k)
                .map(|i| (i as f64 * r.point_spacing_m).min(r.length_m))
                .collect()
        };
        let line =
            |y: f64| -> Vec<osi3::Vector3d> { xs.iter().map(|&x| vec3([x, y, 0.0])).collect() };
        let lane_id = |i: u32| id(1000 + u64::from(i));
        let boundary_id = |j: u32| id(2000 + u64::from(j));
        let shoulder_lane = n; // index in the 1000+ range
        let edge_boundary = n + 1; // index in the 2000+ range

        let mut lanes = Vec::with_capacity(self.lane_count());
        for i in 0..n {
            let mut right_adjacent = Vec::new();
            if i > 0 {
                right_adjacent.push(lane_id(i - 1));
            } else if self.has_shoulder() {
                right_adjacent.push(lane_id(shoulder_lane));
            }
            lanes.push(osi3::Lane {
                id: Some(lane_id(i)),
                classification: Some(Classification {
                    r#type: Some(LaneType::Driving as i32),
                    subtype: Some(Subtype::Normal as i32),
                    is_host_vehicle_lane: Some(host_lane == Some(i as i32)),
                    centerline: line(r.lane_center_y(i as i32)),
                    centerline_is_driving_direction: Some(true),
                    left_adjacent_lane_id: if i + 1 < n {
                        vec![lane_id(i + 1)]
                    } else {
                        vec![]
                    },
                    right_adjacent_lane_id: right_adjacent,
                    right_lane_boundary_id: vec![boundary_id(i)],
                    left_lane_boundary_id: vec![boundary_id(i + 1)],
                    ..Default::default()
                }),
                ..Default::default()
            });
        }
        if self.has_shoulder() {
            lanes.push(osi3::Lane {
                id: Some(lane_id(shoulder_lane)),
                classification: Some(Classification {
                    r#type: Some(LaneType::Nondriving as i32),
                    subtype: Some(Subtype::Shoulder as i32),
                    is_host_vehicle_lane: Some(host_lane == Some(-1)),
                    centerline: line(r.lane_center_y(-1)),
                    centerline_is_driving_direction: Some(true),
                    left_adjacent_lane_id: vec![lane_id(0)],
                    right_lane_boundary_id: vec![boundary_id(edge_boundary)],
                    left_lane_boundary_id: vec![boundary_id(0)],
                    ..Default::default()
                }),
                ..Default::default()
            });
        }

        let solid = |y: f64, width: f64| -> Vec<osi3::lane_boundary::BoundaryPoint> {
            xs.iter()
                .map(|&x| osi3::lane_boundary::BoundaryPoint {
                    position: Some(vec3([x, y, 0.0])),
                    width: Some(width),
                    height: Some(0.0),
                    dash: None,
                })
                .collect()
        };
        let dashed = |y: f64| -> Vec<osi3::lane_boundary::BoundaryPoint> {
            let mut pts = Vec::new();
            let mut x = 0.0;
            while x < r.length_m {
                let end = (x + r.dash_length_m).min(r.length_m);
                for (px, dash) in [(x, Dash::Start), (end, Dash::End)] {
                    pts.push(osi3::lane_boundary::BoundaryPoint {
                        position: Some(vec3([px, y, 0.0])),
                        width: Some(r.marking_width_m),
                        height: Some(0.0),
                        dash: Some(dash as i32),
                    });
                }
                x += r.dash_length_m + r.dash_gap_m;
            }
            pts
        };
        let boundary = |j: u32, ty: BType, color: BColor, points| osi3::LaneBoundary {
            id: Some(boundary_id(j)),
            boundary_line: points,
            classification: Some(osi3::lane_boundary::Classification {
                r#type: Some(ty as i32),
                color: Some(color as i32),
                ..Default::default()
            }),
            ..Default::default()
        };
        let mut boundaries = Vec::with_capacity(self.boundary_count());
        for j in 0..=n {
            let y = r.boundary_y(j);
            boundaries.push(if j == 0 || j == n {
                boundary(
                    j,
                    BType::SolidLine,
                    BColor::White,
                    solid(y, r.marking_width_m),
                )
            } else {
                boundary(j, BType::DashedLine, BColor::White, dashed(y))
            });
        }
        if self.has_shoulder() {
            boundaries.push(boundary(
                edge_boundary,
                BType::RoadEdge,
                BColor::None,
                solid(r.road_edge_right_y(), 0.0),
            ));
        }
        (lanes, boundaries)
    }

    fn environment(&self, t: f64) -> osi3::EnvironmentalConditions {
        use osi3::environmental_conditions::{AmbientIllumination, TimeOfDay};
        use osiris_models::environment::weather;
        let e = &self.environment;
        let seconds = (e.time_of_day_s + self.start_time_s + t)
            .rem_euclid(86_400.0)
            .floor() as u32;
        // LEVEL1 = 2 … LEVEL9 = 10.
        let level =
            AmbientIllumination::Level1 as i32 + i32::from(e.ambient_illumination_level) - 1;
        osi3::EnvironmentalConditions {
            ambient_illumination: Some(level),
            time_of_day: Some(TimeOfDay {
                seconds_since_midnight: Some(seconds),
            }),
            atmospheric_pressure: Some(e.atmospheric_pressure_pa),
            temperature: Some(e.temperature_k),
            relative_humidity: Some(e.relative_humidity_percent),
            precipitation: Some(weather::osi_precipitation_category(e.rain_mm_h) as i32),
            fog: Some(
                weather::osi_fog_category(e.fog_visibility_m.unwrap_or(f64::INFINITY)) as i32,
            ),
            ..Default::default()
        }
    }

    /// The scenario's weather for the sensor models (the quantities OSI carries only as categories):
    /// rain rate, fog visibility, temperature, humidity; the road is wet while it rains.
    pub fn weather(&self) -> osiris_models::environment::weather::Weather {
        use osiris_models::environment::weather::{RoadWetness, Weather};
        let e = &self.environment;
        Weather {
            rain_mm_h: e.rain_mm_h,
            fog_visibility_m: e.fog_visibility_m.unwrap_or(f64::INFINITY),
            temperature_c: e.temperature_k - 273.15,
            relative_humidity: e.relative_humidity_percent / 100.0,
            road: if e.rain_mm_h > 0.0 {
                RoadWetness::Wet
            } else {
                RoadWetness::Dry
            },
        }
    }

    /// The global ground truth at a step: every moving object (the host first), stationary objects,
    /// lanes, lane boundaries and environmental conditions.
    pub fn ground_truth(&self, step: usize) -> osi3::GroundTruth {
        self.ground_truth_at(self.time_s(step))
    }

    /// The global ground truth at scenario time `t` s (any time, not only a step's; step `k` is
    /// `t = k · step_s`, see [`ScenarioConfig::ground_truth`]).
    pub fn ground_truth_at(&self, t: f64) -> osi3::GroundTruth {
        let ts = timestamp_from_seconds(self.start_time_s + t);
        let host_id = self.ego_id();
        let mut moving = Vec::with_capacity(1 + self.road_users.len());
        let host = self.moving_object(&self.ego, host_id, t);
        let host_y = host
            .base
            .as_ref()
            .and_then(|b| b.position)
            .and_then(|p| p.y)
            .unwrap_or(0.0);
        moving.push(host);
        for (i, u) in self.road_users.iter().enumerate() {
            moving.push(self.moving_object(u, u.id.unwrap_or(100 + i as u64), t));
        }
        let (lane, lane_boundary) = self.lanes(self.road.lane_at(host_y));
        let lane_ids = |y: f64| -> Vec<osi3::Identifier> {
            self.road
                .lane_at(y)
                .and_then(|l| self.lane_id(l))
                .map(id)
                .into_iter()
                .collect()
        };
        osi3::GroundTruth {
            traffic_sign: traffic_control::traffic_signs(
                &self.road,
                &self.traffic_signs,
                &(0..self.road.lanes as i32)
                    .filter_map(|l| self.lane_id(l).map(id))
                    .collect::<Vec<_>>(),
            ),
            traffic_light: traffic_control::traffic_lights(&self.road, &self.signal_heads, t),
            road_marking: traffic_control::road_markings(
                &self.road,
                &self.road_markings,
                &lane_ids,
            ),
            version: Some(interface_version()),
            timestamp: Some(ts),
            host_vehicle_id: Some(id(host_id)),
            stationary_object: self.stationary_objects(),
            moving_object: moving,
            lane_boundary,
            lane,
            environmental_conditions: Some(self.environment(t)),
            map_reference: Some(format!(
                "osiris:straight_road?lanes={}&length_m={}",
                self.road.lanes, self.road.length_m
            )),
            ..Default::default()
        }
    }

    /// The SensorView of `sensor` at `step`: version, timestamp, sensor id, mounting (host vehicle
    /// frame), host id, the global ground truth, and one technology view of the sensor's kind whose
    /// `view_configuration` repeats the sensor id, mounting and the default FoVs of that kind
    /// (`SensorConfig::default_for`).
    pub fn sensor_view(&self, step: usize, sensor: &SensorMount) -> osi3::SensorView {
        let gt = self.ground_truth(step);
        self.sensor_view_with(gt, sensor)
    }

    /// The SensorView of `sensor` at scenario time `t` s ([`ScenarioConfig::sensor_view`] between
    /// steps).
    pub fn sensor_view_at(&self, t: f64, sensor: &SensorMount) -> osi3::SensorView {
        self.sensor_view_with(self.ground_truth_at(t), sensor)
    }

    /// The SensorViews of all configured sensors at `step`, in configuration order (the ground truth
    /// is built once).
    pub fn sensor_views(&self, step: usize) -> Vec<osi3::SensorView> {
        let gt = self.ground_truth(step);
        self.sensors
            .iter()
            .map(|s| self.sensor_view_with(gt.clone(), s))
            .collect()
    }

    fn sensor_view_with(&self, gt: osi3::GroundTruth, sensor: &SensorMount) -> osi3::SensorView {
        let sensor_id = Some(id(sensor.sensor_id));
        let mounting = Some(sensor.mounting().to_osi());
        let defaults = SensorConfig::default_for(sensor.kind);
        let (fov_h, fov_v) = (
            Some(defaults.fov_horizontal_rad),
            Some(defaults.fov_vertical_rad),
        );
        let mut sv = osi3::SensorView {
            version: Some(interface_version()),
            timestamp: gt.timestamp,
            sensor_id,
            mounting_position: mounting,
            host_vehicle_id: gt.host_vehicle_id,
            global_ground_truth: Some(gt),
            ..Default::default()
        };
        match sensor.kind {
            SensorKind::Radar => sv.radar_sensor_view.push(osi3::RadarSensorView {
                view_configuration: Some(osi3::RadarSensorViewConfiguration {
                    sensor_id,
                    mounting_position: mounting,
                    field_of_view_horizontal: fov_h,
                    field_of_view_vertical: fov_v,
                    ..Default::default()
                }),
                reflection: Vec::new(),
            }),
            SensorKind::Lidar => sv.lidar_sensor_view.push(osi3::LidarSensorView {
                view_configuration: Some(osi3::LidarSensorViewConfiguration {
                    sensor_id,
                    mounting_position: mounting,
                    field_of_view_horizontal: fov_h,
                    field_of_view_vertical: fov_v,
                    ..Default::default()
                }),
                reflection: Vec::new(),
            }),
            SensorKind::Camera => sv.camera_sensor_view.push(osi3::CameraSensorView {
                view_configuration: Some(osi3::CameraSensorViewConfiguration {
                    sensor_id,
                    mounting_position: mounting,
                    field_of_view_horizontal: fov_h,
                    field_of_view_vertical: fov_v,
                    ..Default::default()
                }),
                image_data: None,
            }),
        }
        sv
    }

    /// The default scenario with its road users replaced by `n_objects` vehicles ahead of the ego
    /// (benchmarks): round-robin over the lanes, 12 m apart within a lane and staggered by 4 m between
    /// lanes, starting 15 m ahead of the ego; every fifth a truck, the others cars; one speed per lane
    /// (22, 25, 28, … m/s from right to left) so they never overlap. The road is lengthened to hold them.
    pub fn with_traffic(n_objects: usize) -> ScenarioConfig {
        let mut c = ScenarioConfig {
            name: format!("traffic-{n_objects}"),
            ..ScenarioConfig::default()
        };
        let lanes = c.road.lanes as usize;
        let x0 = c.ego.x_m + 15.0;
        c.road_users = (0..n_objects)
            .map(|k| {
                let lane = k % lanes;
                let row = k / lanes;
                let kind = if k % 5 == 4 {
                    RoadUserKind::Truck
                } else {
                    RoadUserKind::Car
                };
                let x = x0
                    + 12.0 * row as f64
                    + 4.0 * lane as f64
                    + if kind == RoadUserKind::Truck {
                        3.0
                    } else {
                        0.0
                    };
                RoadUserConfig::new(kind, lane as i32, x, 22.0 + 3.0 * lane as f64)
            })
            .collect();
        let needed = x0 + 12.0 * (n_objects / lanes.max(1)) as f64 + 100.0 + 30.0 * c.duration_s;
        c.road.length_m = c.road.length_m.max(needed.ceil());
        c
    }
}

/// A SensorView with `n_objects` moving objects ahead of the ego (plus the ego and the default static
/// objects), for the default radar at step 0 of [`ScenarioConfig::with_traffic`].
pub fn benchmark_view(n_objects: usize) -> osi3::SensorView {
    let c = ScenarioConfig::with_traffic(n_objects);
    let radar = c
        .sensors
        .iter()
        .find(|s| s.kind == SensorKind::Radar)
        .cloned()
        .expect("the default has a radar");
    c.sensor_view(0, &radar)
}

/// Yaw of the scenario pedestrians' head relative to their body, rad (20° to the left).
pub const PEDESTRIAN_HEAD_YAW_RAD: f64 = 0.349_065_850_398_865_9;

/// The OSI skeleton of an upright adult of height `height_m` (the box height).
///
/// * Joint heights as fractions of the body height H from Winter's anthropometric table (D. A.
///   Winter, "Biomechanics and Motor Control of Human Movement", 4th ed., Wiley 2009, Fig. 4.1):
///   hip joint 0.530 H, shoulder 0.818 H, chin 0.870 H, elbow 0.630 H, wrist 0.485 H, knee
///   0.285 H, ankle 0.039 H; shoulder width 0.259 H (biacromial), foot length 0.152 H, hand length
///   0.108 H. Hip joints ±0.05 H from the mid-line, spine split at 0.60 H and 0.70 H (guessed).
/// * The **root** is the pelvis centre (between the hip joints): `bbcenter_to_root` = (0, 0,
///   0.530 H − H/2) in the object frame. Bone positions are relative to it, object axes (x forward,
///   y left, z up). OSI: "a bone's position and orientation is defined by the end-point closer to
///   the root", so a bone's position is its proximal joint and its `length` the distance to the next.
/// * Orientations (root frame) as osiris reads them (`osiris_models::semantics`, rule 3): an
///   anatomical frame with x anterior and z along the bone towards its far end. Upward bones
///   (hip, spine, neck) are the identity; the head is yawed by [`PEDESTRIAN_HEAD_YAW_RAD`];
///   hanging arms and legs are rolled by π (z down, x still anterior); shoulders point sideways
///   (roll ∓π/2); feet point forward (pitch π/2).
pub fn pedestrian_attributes(height_m: f64) -> osi3::moving_object::PedestrianAttributes {
    use osi3::moving_object::PedestrianAttributes;
    use osi3::moving_object::pedestrian_attributes::Bone;
    use osi3::moving_object::pedestrian_attributes::bone::Type as B;
    use std::f64::consts::{FRAC_PI_2, PI};
    let h = height_m;
    let hip = 0.530 * h;
    // Heights above the root.
    let z = |frac: f64| frac * h - hip;
    let (shoulder_y, hip_y) = (0.5 * 0.259 * h, 0.05 * h);
    let bone = |t: B, p: [f64; 3], rpy: [f64; 3], length: f64| Bone {
        r#type: Some(t as i32),
        position: Some(vec3(p)),
        orientation: Some(osi3::Orientation3d {
            roll: Some(rpy[0]),
            pitch: Some(rpy[1]),
            yaw: Some(rpy[2]),
        }),
        length: Some(length as f32),
        missing: Some(false),
        ..Default::default()
    };
    let up = [0.0; 3];
    let down = [PI, 0.0, 0.0];
    let mut bones = vec![
        bone(B::Root, [0.0; 3], up, 0.0),
        bone(B::Hip, [0.0; 3], up, z(0.60)),
        bone(B::LowerSpine, [0.0, 0.0, z(0.60)], up, 0.10 * h),
        bone(B::UpperSpine, [0.0, 0.0, z(0.70)], up, z(0.818) - z(0.70)),
        bone(B::Neck, [0.0, 0.0, z(0.818)], up, z(0.870) - z(0.818)),
        bone(
            B::Head,
            [0.0, 0.0, z(0.870)],
            [0.0, 0.0, PEDESTRIAN_HEAD_YAW_RAD],
            h - 0.870 * h,
        ),
    ];
    for (side, sy) in [(0usize, 1.0f64), (1, -1.0)] {
        let pick = |l: B, r: B| if side == 0 { l } else { r };
        bones.extend([
            bone(
                pick(B::ShoulderL, B::ShoulderR),
                [0.0, 0.0, z(0.818)],
                [-sy * FRAC_PI_2, 0.0, 0.0],
                shoulder_y,
            ),
            bone(
                pick(B::UpperArmL, B::UpperArmR),
                [0.0, sy * shoulder_y, z(0.818)],
                down,
                (0.818 - 0.630) * h,
            ),
            bone(
                pick(B::LowerArmL, B::LowerArmR),
                [0.0, sy * shoulder_y, z(0.630)],
                down,
                (0.630 - 0.485) * h,
            ),
            bone(
                pick(B::FullHandL, B::FullHandR),
                [0.0, sy * shoulder_y, z(0.485)],
                down,
                0.108 * h,
            ),
            bone(
                pick(B::UpperLegL, B::UpperLegR),
                [0.0, sy * hip_y, 0.0],
                down,
                (0.530 - 0.285) * h,
            ),
            bone(
                pick(B::LowerLegL, B::LowerLegR),
                [0.0, sy * hip_y, z(0.285)],
                down,
                (0.285 - 0.039) * h,
            ),
            bone(
                pick(B::FullFootL, B::FullFootR),
                [0.0, sy * hip_y, z(0.039)],
                [0.0, FRAC_PI_2, 0.0],
                0.152 * h,
            ),
        ]);
    }
    PedestrianAttributes {
        bbcenter_to_root: Some(vec3([0.0, 0.0, hip - 0.5 * h])),
        skeleton_bone: bones,
    }
}

fn vec3(a: [f64; 3]) -> osi3::Vector3d {
    osi3::Vector3d {
        x: Some(a[0]),
        y: Some(a[1]),
        z: Some(a[2]),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn position(o: &osi3::MovingObject) -> [f64; 3] {
        let p = o.base.as_ref().unwrap().position.unwrap();
        [p.x.unwrap(), p.y.unwrap(), p.z.unwrap()]
    }

    #[test]
    fn default_is_valid_and_matches_the_description() {
        let c = ScenarioConfig::default();
        c.validate().unwrap();
        assert_eq!(c.step_count(), 200);
        assert_eq!(c.road.lanes, 3);
        assert_eq!(c.ego.speed_m_s, 25.0);
        assert_eq!(c.sensors.len(), 3);
        let gt = c.ground_truth(0);
        assert_eq!(gt.host_vehicle_id, Some(id(1)));
        assert_eq!(gt.moving_object.len(), 6);
        assert_eq!(gt.stationary_object.len(), 4);
        assert_eq!(gt.lane.len(), 4); // 3 driving lanes + shoulder
        assert_eq!(gt.lane_boundary.len(), 5); // 4 lines + road edge
        let host = &gt.moving_object[0];
        assert_eq!(position(host), [50.0, 0.0, 0.75]);
        // The car ahead is in the same lane 40 m ahead, slower.
        let ahead = &gt.moving_object[1];
        assert_eq!(position(ahead)[1], 0.0);
        assert_eq!(position(ahead)[0] - position(host)[0], 40.0);
        assert!(ahead.base.as_ref().unwrap().velocity.unwrap().x.unwrap() < 25.0);
        assert_eq!(
            ahead.model_reference.as_deref(),
            Some("osiris:car?paint=black")
        );
        // The truck is in the left lane.
        let truck = &gt.moving_object[2];
        assert_eq!(position(truck)[1], 3.5);
        assert_eq!(truck.model_reference.as_deref(), Some("osiris:truck"));
        // Guardrail on the right, right of the shoulder.
        let rail = gt
            .stationary_object
            .iter()
            .find(|s| {
                s.model_reference
                    .as_deref()
                    .is_some_and(|r| r.starts_with("osiris:guardrail"))
            })
            .unwrap();
        let rail_y = rail.base.as_ref().unwrap().position.unwrap().y.unwrap();
        assert!(rail_y < c.road.road_edge_right_y());
        assert_eq!(
            rail.classification.as_ref().unwrap().r#type,
            Some(osi3::stationary_object::classification::Type::Barrier as i32)
        );
        assert!(
            gt.stationary_object
                .iter()
                .any(|s| s.model_reference.as_deref() == Some("osiris:trihedral?edge_m=0.1"))
        );
        assert!(
            gt.stationary_object
                .iter()
                .any(|s| s.model_reference.as_deref()
                    == Some("osiris:board?width_m=1&height_m=1&material=lambertian_50"))
        );
        // Host lane marked.
        let host_lane: Vec<_> = gt
            .lane
            .iter()
            .filter(|l| l.classification.as_ref().unwrap().is_host_vehicle_lane == Some(true))
            .collect();
        assert_eq!(host_lane.len(), 1);
        assert_eq!(host_lane[0].id, Some(id(1001)));
        // Vehicles carry bbcenter_to_rear; pedestrians carry no vehicle attributes.
        let rear = host
            .vehicle_attributes
            .as_ref()
            .unwrap()
            .bbcenter_to_rear
            .unwrap();
        assert!((rear.x.unwrap() + 1.35).abs() < 1e-12 && (rear.z.unwrap() + 0.43).abs() < 1e-12);
        let ped = gt
            .moving_object
            .iter()
            .find(|o| o.r#type == Some(osi3::moving_object::Type::Pedestrian as i32))
            .unwrap();
        assert!(ped.vehicle_attributes.is_none() && ped.vehicle_classification.is_none());
        // The skeleton: all 20 OSI bones once, the root at the pelvis inside the box, the head
        // above the shoulders and below the top of the box, the feet at the ground.
        let pa = ped.pedestrian_attributes.as_ref().unwrap();
        let h = ped
            .base
            .as_ref()
            .unwrap()
            .dimension
            .unwrap()
            .height
            .unwrap();
        let mut types: Vec<i32> = pa.skeleton_bone.iter().map(|b| b.r#type.unwrap()).collect();
        types.sort();
        assert_eq!(types, (0..20).collect::<Vec<_>>());
        let root_z = pa.bbcenter_to_root.unwrap().z.unwrap();
        assert!((root_z + 0.5 * h - 0.530 * h).abs() < 1e-12, "{root_z}");
        let bone = |t: osi3::moving_object::pedestrian_attributes::bone::Type| {
            pa.skeleton_bone
                .iter()
                .find(|b| b.r#type == Some(t as i32))
                .unwrap()
        };
        use osi3::moving_object::pedestrian_attributes::bone::Type as B;
        let above_ground = |b: &osi3::moving_object::pedestrian_attributes::Bone| {
            b.position.unwrap().z.unwrap() + root_z + 0.5 * h
        };
        let head = bone(B::Head);
        let top = above_ground(head) + f64::from(head.length.unwrap());
        assert!((top - h).abs() < 1e-6, "head top {top} vs height {h}");
        assert!(above_ground(head) > above_ground(bone(B::UpperArmL)));
        let foot = above_ground(bone(B::FullFootR));
        assert!((0.0..0.1).contains(&foot), "{foot}");
        assert!(
            (head.orientation.unwrap().yaw.unwrap() - PEDESTRIAN_HEAD_YAW_RAD).abs() < 1e-12
                && (PEDESTRIAN_HEAD_YAW_RAD.to_degrees() - 20.0).abs() < 1e-9
        );
        // Shoulder joints 0.259 H apart (Winter's biacromial breadth).
        let (l, r) = (bone(B::UpperArmL), bone(B::UpperArmR));
        let w = l.position.unwrap().y.unwrap() - r.position.unwrap().y.unwrap();
        assert!((w - 0.259 * h).abs() < 1e-12, "{w}");
        let env = gt.environmental_conditions.as_ref().unwrap();
        assert_eq!(
            env.time_of_day.unwrap().seconds_since_midnight,
            Some(43_200)
        );
    }

    #[test]
    fn ids_are_stable_and_unique_across_steps() {
        let c = ScenarioConfig::default();
        let ids = |step| {
            let gt = c.ground_truth(step);
            let mut v: Vec<u64> = gt
                .moving_object
                .iter()
                .map(|o| o.id.unwrap().value.unwrap())
                .collect();
            v.extend(
                gt.stationary_object
                    .iter()
                    .map(|o| o.id.unwrap().value.unwrap()),
            );
            v.extend(gt.lane.iter().map(|o| o.id.unwrap().value.unwrap()));
            v.extend(
                gt.lane_boundary
                    .iter()
                    .map(|o| o.id.unwrap().value.unwrap()),
            );
            v
        };
        let first = ids(0);
        let mut sorted = first.clone();
        sorted.sort();
        sorted.dedup();
        assert_eq!(sorted.len(), first.len());
        for step in [1, 37, c.step_count() - 1] {
            assert_eq!(ids(step), first);
        }
    }

    #[test]
    fn constant_velocity_kinematics() {
        let c = ScenarioConfig::default();
        let gt0 = c.ground_truth(0);
        for step in [1, 10, 99] {
            let t = c.time_s(step);
            let gt = c.ground_truth(step);
            assert_eq!(gt.timestamp, Some(timestamp_from_seconds(t)));
            for (o0, o) in gt0.moving_object.iter().zip(&gt.moving_object) {
                let v = o.base.as_ref().unwrap().velocity.unwrap();
                let (p0, p) = (position(o0), position(o));
                assert!((p[0] - (p0[0] + v.x.unwrap() * t)).abs() < 1e-9);
                assert!((p[1] - (p0[1] + v.y.unwrap() * t)).abs() < 1e-9);
                assert_eq!(p[2], p0[2]);
            }
        }
        // A crossing pedestrian moves laterally.
        let mut c = ScenarioConfig::default();
        c.road_users[4].heading_rad = std::f64::consts::FRAC_PI_2;
        let p0 = position(&c.ground_truth(0).moving_object[5]);
        let p = position(&c.ground_truth(100).moving_object[5]);
        assert!((p[1] - p0[1] - 1.4 * 1.0).abs() < 1e-9 && (p[0] - p0[0]).abs() < 1e-9);
    }

    #[test]
    fn sensor_view_carries_mounting_ids_and_technology_view() {
        let c = ScenarioConfig::default();
        for s in &c.sensors {
            let sv = c.sensor_view(3, s);
            assert_eq!(sv.version, Some(interface_version()));
            assert_eq!(sv.sensor_id, Some(id(s.sensor_id)));
            assert_eq!(sv.host_vehicle_id, Some(id(1)));
            assert_eq!(sv.timestamp, Some(timestamp_from_seconds(0.03)));
            assert_eq!(
                sv.mounting_position,
                Some(SensorConfig::default_for(s.kind).mounting.to_osi())
            );
            let gt = sv.global_ground_truth.as_ref().unwrap();
            assert!(gt.moving_object.iter().any(|o| o.id == Some(id(1))));
            let n = (
                sv.radar_sensor_view.len(),
                sv.lidar_sensor_view.len(),
                sv.camera_sensor_view.len(),
            );
            let expect = match s.kind {
                SensorKind::Radar => (1, 0, 0),
                SensorKind::Lidar => (0, 1, 0),
                SensorKind::Camera => (0, 0, 1),
            };
            assert_eq!(n, expect);
        }
        assert_eq!(c.sensor_views(0).len(), 3);
    }

    #[test]
    fn lane_markings() {
        let c = ScenarioConfig::default();
        let gt = c.ground_truth(0);
        use osi3::lane_boundary::classification::Type as B;
        let types: Vec<_> = gt
            .lane_boundary
            .iter()
            .map(|b| b.classification.as_ref().unwrap().r#type.unwrap())
            .collect();
        assert_eq!(
            types,
            vec![
                B::SolidLine as i32,
                B::DashedLine as i32,
                B::DashedLine as i32,
                B::SolidLine as i32,
                B::RoadEdge as i32
            ]
        );
        let dashed = &gt.lane_boundary[1];
        assert_eq!(
            dashed.boundary_line[0].dash,
            Some(osi3::lane_boundary::boundary_point::Dash::Start as i32)
        );
        assert_eq!(dashed.boundary_line[1].position.unwrap().x, Some(6.0));
        assert_eq!(dashed.boundary_line[1].position.unwrap().y, Some(-1.75));
        let solid = &gt.lane_boundary[0];
        assert_eq!(solid.boundary_line.len(), 41);
        assert_eq!(
            solid.boundary_line.last().unwrap().position.unwrap().x,
            Some(400.0)
        );
        assert_eq!(solid.boundary_line[0].position.unwrap().y, Some(-5.25));
        let lane0 = gt.lane[0].classification.as_ref().unwrap();
        assert_eq!(lane0.right_lane_boundary_id, vec![id(2000)]);
        assert_eq!(lane0.left_lane_boundary_id, vec![id(2001)]);
        assert_eq!(lane0.right_adjacent_lane_id, vec![id(1003)]); // the shoulder
        assert_eq!(lane0.centerline[0].y, Some(-3.5));
    }

    #[test]
    fn json_round_trip_of_the_default() {
        let c = ScenarioConfig::default();
        let text = c.to_json_pretty();
        let back = ScenarioConfig::from_json_str(&text).unwrap();
        assert_eq!(back, c);
        assert_eq!(back.to_json_pretty(), text);
        // A minimal file relies on the defaults.
        let minimal = r#"{"duration_s": 1, "step_s": 0.1, "ego": {"kind": "car", "lane": 0, "x_m": 0, "speed_m_s": 10}}"#;
        let m = ScenarioConfig::from_json_str(minimal).unwrap();
        assert_eq!(m.road, RoadConfig::default());
        assert!(m.road_users.is_empty() && m.sensors.is_empty() && m.guardrail.is_none());
        assert_eq!(m.step_count(), 10);
    }

    #[test]
    fn bad_key_error_names_key_line_and_file() {
        let text = "{\n  \"duration_s\": 2,\n  \"step_s\": 0.02,\n  \"road\": {\n    \"lanez\": 3\n  },\n  \"ego\": {\"kind\": \"car\", \"lane\": 0, \"x_m\": 0, \"speed_m_s\": 1}\n}";
        let e = ScenarioConfig::from_json_str(text).unwrap_err();
        let msg = e.to_string();
        assert!(msg.contains("lanez") && msg.contains("line 5"), "{msg}");
        match e {
            ScenarioError::Json { line, .. } => assert_eq!(line, 5),
            other => panic!("{other:?}"),
        }
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("bad.json");
        std::fs::write(&path, text).unwrap();
        let msg = ScenarioConfig::from_json_file(&path)
            .unwrap_err()
            .to_string();
        assert!(
            msg.contains("bad.json") && msg.contains("lanez") && msg.contains("line 5"),
            "{msg}"
        );
        let msg = ScenarioConfig::from_json_file(dir.path().join("missing.json"))
            .unwrap_err()
            .to_string();
        assert!(msg.contains("missing.json"), "{msg}");
        // A wrong kind is reported with its position too.
        let msg = ScenarioConfig::from_json_str(
            &text
                .replace("\"lanez\": 3", "\"lanes\": 3")
                .replace("\"car\"", "\"tank\""),
        )
        .unwrap_err()
        .to_string();
        assert!(msg.contains("tank") && msg.contains("line 7"), "{msg}");
        // Semantic errors name the key.
        let msg = ScenarioConfig::from_json_str(&text.replace("\"lanez\": 3", "\"lanes\": 0"))
            .unwrap_err()
            .to_string();
        assert!(msg.contains("road.lanes"), "{msg}");
        let mut c = ScenarioConfig::default();
        c.road_users[0].id = Some(1);
        assert!(c.validate().unwrap_err().to_string().contains("id 1"));
    }

    #[test]
    fn traffic_for_benchmarks() {
        let sv = benchmark_view(100);
        let gt = sv.global_ground_truth.as_ref().unwrap();
        assert_eq!(gt.moving_object.len(), 101);
        let host_x = position(&gt.moving_object[0])[0];
        assert!(
            gt.moving_object[1..]
                .iter()
                .all(|o| position(o)[0] > host_x)
        );
        let c = ScenarioConfig::with_traffic(100);
        c.validate().unwrap();
        // No two vehicles in one lane overlap, at the start or the end.
        for step in [0, c.step_count()] {
            let gt = c.ground_truth(step);
            let objs = &gt.moving_object[1..];
            for (i, a) in objs.iter().enumerate() {
                for b in &objs[i + 1..] {
                    let (pa, pb) = (position(a), position(b));
                    if pa[1] == pb[1] {
                        let la = a.base.as_ref().unwrap().dimension.unwrap().length.unwrap();
                        let lb = b.base.as_ref().unwrap().dimension.unwrap().length.unwrap();
                        assert!((pa[0] - pb[0]).abs() > 0.5 * (la + lb), "{pa:?} {pb:?}");
                    }
                }
            }
        }
    }

    /// The physical radar and LiDAR on the default scenario: feature detections on the car ahead
    /// (id 100, 40 m ahead in the ego lane), the LiDAR also on the car behind (102), and the car
    /// ahead recognised and tracked by the radar within a few cycles.
    #[test]
    fn physical_sensors_see_the_default_scenario() {
        use osiris_models::{ModelMode, StepInput, StepOutput, build_sensor};
        let c = ScenarioConfig::default();
        // Ground truth of every feature detection: the perception extension's (a detection's
        // OSI `object_id` names the detected object it belongs to, not the ground truth).
        let feature_ids = |out: &StepOutput| -> Vec<u64> {
            let fd = out.sensor_data.feature_data.as_ref().expect("feature data");
            let n = fd
                .radar_sensor
                .iter()
                .map(|r| r.detection.len())
                .sum::<usize>()
                + fd.lidar_sensor
                    .iter()
                    .map(|l| l.detection.len())
                    .sum::<usize>();
            let p = &out.perception;
            let ids: Vec<u64> = p
                .radar
                .iter()
                .flat_map(|r| {
                    r.peak.iter().map(|k| {
                        k.object_id
                            .and_then(|i| i.value)
                            .unwrap_or(osiris_proto::INVALID_ID)
                    })
                })
                .chain(p.lidar.iter().flat_map(|l| l.object_id.iter().copied()))
                .collect();
            assert_eq!(ids.len(), n, "one ground-truth id per detection");
            let violations = osiris_models::semantics::violations(&out.sensor_data, None);
            assert!(violations.is_empty(), "{violations:?}");
            ids
        };
        // Radar: 6 cycles, every 10th scenario step (0.1 s apart).
        let mount = c
            .sensors
            .iter()
            .find(|s| s.kind == SensorKind::Radar)
            .unwrap();
        let config = SensorConfig::default_for(SensorKind::Radar);
        assert_eq!(config.mode, ModelMode::Physical);
        let mut radar = build_sensor(config).unwrap();
        let mut out = StepOutput::default();
        let mut tracked = false;
        for k in 0..6 {
            let step = (k * 10).min(c.step_count() - 1);
            let sv = c.sensor_view(step, mount);
            radar
                .step(
                    &StepInput {
                        view: &sv,
                        time_s: c.time_s(step),
                        step_s: 0.1,
                    },
                    &mut out,
                )
                .unwrap();
            let ids = feature_ids(&out);
            assert!(ids.contains(&100), "cycle {k}: radar detections {ids:?}");
            assert!(
                !ids.contains(&102),
                "the car behind is behind the front radar"
            );
            tracked |= out.sensor_data.moving_object.iter().any(|o| {
                o.header
                    .as_ref()
                    .is_some_and(|h| h.ground_truth_id.iter().any(|g| g.value == Some(100)))
            });
        }
        assert!(
            tracked,
            "the radar never reported the car ahead as an object"
        );
        // LiDAR: one VLP-16 revolution (a full VLS-128 frame is slow in the dev profile).
        let mount = c
            .sensors
            .iter()
            .find(|s| s.kind == SensorKind::Lidar)
            .unwrap();
        let mut config = SensorConfig::default_for(SensorKind::Lidar);
        config.lidar =
            Some(serde_json::from_str(r#"{"preset": "vlp16"}"#).expect("valid LiDAR config"));
        let mut lidar = build_sensor(config).unwrap();
        let sv = c.sensor_view(10, mount);
        lidar
            .step(
                &StepInput {
                    view: &sv,
                    time_s: c.time_s(10),
                    step_s: 0.1,
                },
                &mut out,
            )
            .unwrap();
        let ids = feature_ids(&out);
        let on = |id: u64| ids.iter().filter(|&&i| i == id).count();
        // VLP-16 (2° between channels): a car at 30–40 m spans 2–3 channels.
        assert!(
            on(100) >= 5 && on(102) >= 5,
            "points on 100: {}, on 102: {}",
            on(100),
            on(102)
        );
        assert_eq!(on(1), 0, "no points on the host");
        let cloud = out.perception.lidar.as_ref().expect("point cloud");
        let detections: usize = out
            .sensor_data
            .feature_data
            .as_ref()
            .unwrap()
            .lidar_sensor
            .iter()
            .map(|l| l.detection.len())
            .sum();
        assert_eq!(cloud.x_m.len(), detections);
    }

    #[test]
    fn ideal_sensors_see_the_default_scenario() {
        use osiris_models::{StepInput, StepOutput, build_sensor};
        let c = ScenarioConfig::default();
        let seen = |kind: SensorKind, step: usize| -> (Vec<u64>, Vec<u64>) {
            let mount = c.sensors.iter().find(|s| s.kind == kind).unwrap();
            let mut config = SensorConfig::default_for(kind);
            config.mode = osiris_models::ModelMode::Ideal;
            let mut model = build_sensor(config).unwrap();
            let sv = c.sensor_view(step, mount);
            let mut out = StepOutput::default();
            model
                .step(
                    &StepInput {
                        view: &sv,
                        time_s: c.time_s(step),
                        step_s: c.step_s,
                    },
                    &mut out,
                )
                .unwrap();
            let ids = |hs: Vec<&osi3::DetectedItemHeader>| -> Vec<u64> {
                hs.iter()
                    .map(|h| h.tracking_id.unwrap().value.unwrap())
                    .collect()
            };
            (
                ids(out
                    .sensor_data
                    .moving_object
                    .iter()
                    .map(|o| o.header.as_ref().unwrap())
                    .collect()),
                ids(out
                    .sensor_data
                    .stationary_object
                    .iter()
                    .map(|o| o.header.as_ref().unwrap())
                    .collect()),
            )
        };
        // Front radar: the car ahead, the truck; not the host (1) nor the car behind (102).
        let (moving, stationary) = seen(SensorKind::Radar, 0);
        assert!(moving.contains(&100) && moving.contains(&101), "{moving:?}");
        assert!(!moving.contains(&1) && !moving.contains(&102), "{moving:?}");
        assert!(stationary.contains(&900), "{stationary:?}"); // the guardrail
        // Roof LiDAR (360°): also the car behind.
        let (moving, _) = seen(SensorKind::Lidar, 50);
        assert!(
            moving.contains(&102) && moving.contains(&100) && !moving.contains(&1),
            "{moving:?}"
        );
        // Camera: the car ahead.
        let (moving, _) = seen(SensorKind::Camera, 99);
        assert!(
            moving.contains(&100) && !moving.contains(&102),
            "{moving:?}"
        );
    }

    #[test]
    fn ideal_lidar_on_the_benchmark_view() {
        use osiris_models::{StepInput, StepOutput, build_sensor};
        let mut sv = benchmark_view(100);
        sv.mounting_position = Some(
            SensorConfig::default_for(SensorKind::Lidar)
                .mounting
                .to_osi(),
        );
        let mut model = build_sensor(SensorConfig::default_for(SensorKind::Lidar)).unwrap();
        let mut out = StepOutput::default();
        let t0 = std::time::Instant::now();
        let n = 5;
        for _ in 0..n {
            model
                .step(
                    &StepInput {
                        view: &sv,
                        time_s: 0.0,
                        step_s: 0.1,
                    },
                    &mut out,
                )
                .unwrap();
        }
        let per_step = t0.elapsed().as_secs_f64() / n as f64;
        let seen = out.sensor_data.moving_object.len();
        eprintln!(
            "ideal lidar, 100 objects: {seen} seen, {:.3} ms/step",
            per_step * 1e3
        );
        assert!(seen > 0 && seen <= 100);
    }

    #[test]
    fn weather_maps_to_osi_categories_and_back_to_the_models() {
        use osi3::environmental_conditions::{Fog, Precipitation};
        let mut c = ScenarioConfig::default();
        c.environment.rain_mm_h = 25.0;
        c.environment.fog_visibility_m = Some(150.0);
        c.validate().unwrap();
        let env = c.ground_truth(0).environmental_conditions.unwrap();
        assert_eq!(env.precipitation, Some(Precipitation::Heavy as i32));
        assert_eq!(env.fog, Some(Fog::Thick as i32));
        let w = c.weather();
        assert_eq!((w.rain_mm_h, w.fog_visibility_m), (25.0, 150.0));
        assert!(w.road.is_wet());
        assert!((w.temperature_c - (c.environment.temperature_k - 273.15)).abs() < 1e-12);
        let clear = ScenarioConfig::default();
        assert_eq!(clear.weather().fog_visibility_m, f64::INFINITY);
        let env = clear.ground_truth(0).environmental_conditions.unwrap();
        assert_eq!(env.precipitation, Some(Precipitation::None as i32));
        assert_eq!(env.fog, Some(Fog::ExcellentVisibility as i32));
        c.environment.fog_visibility_m = Some(-1.0);
        assert!(
            c.validate()
                .unwrap_err()
                .to_string()
                .contains("fog_visibility_m")
        );
    }
}
