//! Traffic control of the built-in scenario: traffic signs, signal heads and road markings, written
//! into the ground truth as OSI `TrafficSign`, `TrafficLight` (one per bulb) and `RoadMarking`.
//!
//! # Conventions
//!
//! * Positions as for static objects: `x_m` along the road, `lane` (−1 right shoulder, `lanes` left
//!   verge) plus `lateral_offset_m`. Signs and signal heads face −x (the oncoming ego traffic): their
//!   OSI yaw is π, so the object's +x (the sign face normal, the bulb's optical axis) points back
//!   along the road.
//! * Sign plate: `base.position` is the plate centre, `dimension` = (0.02 m, size, size): the
//!   standard sizes of the German VzKat are 420/600/750 mm for round signs (600 mm the normal size
//!   outside motorways). `height_m` is the plate's lower edge above the road (2.0 m: the usual
//!   clearance beside a footway, RiLSA/StVO-VwV guidance; a guess for other countries).
//! * Signal head: three bulbs (red top, yellow, green bottom) of `lens_diameter_m` (200 mm or
//!   300 mm lenses, EN 12368), centres `1.5 · lens_diameter_m` apart, `z_m` the centre of the green
//!   (lowest) bulb. Each bulb is one OSI `TrafficLight` with `dimension` = (0.05 m, d, d),
//!   colour, icon `NONE` and a mode from the head's signal cycle at time t.
//! * Signal cycle: `cycle` is a list of (state, duration) phases repeated from `t = −offset_s`.
//!   States: `red`, `red_yellow`, `yellow`, `green`, `off`, `flashing_yellow` (the yellow bulb's
//!   mode is `FLASHING`). The German sequence is green → yellow (3 s at 50 km/h, RiLSA) → red →
//!   red+yellow (1 s) → green.
//! * Road markings: a stop line (`stop_line`: 0.50 m deep across the lane, the German "Haltlinie"
//!   width, RMS) and lane arrows (`arrow_straight`, `arrow_left`, `arrow_right`: 5 m long, 0.15 m
//!   shaft, 0.6 m head; shapes simplified from the German RMS arrow drawings). Each is one OSI
//!   `RoadMarking` with its outline in `base.base_polygon` (the marking's local frame, x along the
//!   road, counter-clockwise), the box centre on the road (`z = 0`, height 0).
//! * Signs apply to every driving lane (`assigned_lane_id`); markings to the lane they lie in.
//! * Country `DE`, revision `2017` (the German traffic-sign catalogue VzKat 2017) and its codes
//!   (274 speed limit, 131 signals ahead, 206 stop, 205 give way, 294 stop line, 297 arrows; the
//!   arrow sub-codes are osiris' own numbering).
//! * Ids: signs `3000 + i`, bulbs `4000 + 10 i + b` (b = 0 red, 1 yellow, 2 green), markings
//!   `5000 + i`, unless given.

use osiris_proto::{id, osi3};
use serde::{Deserialize, Serialize};

use super::{RoadConfig, ScenarioError, vec3};

/// What a sign shows.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum SignKind {
    /// Speed limit (`value` km/h), round.
    SpeedLimit,
    /// "Traffic signals ahead" warning, triangular.
    TrafficSignalsAhead,
    /// Stop, octagonal.
    Stop,
    /// Give way, inverted triangle.
    GiveWay,
}

fn default_sign_size() -> f64 {
    0.6
}
fn default_sign_height() -> f64 {
    2.0
}
fn default_shoulder() -> i32 {
    -1
}

/// A traffic sign on its post.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TrafficSignConfig {
    pub sign: SignKind,
    /// Sign value (speed limit in km/h).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub value: Option<f64>,
    pub x_m: f64,
    #[serde(default = "default_shoulder")]
    pub lane: i32,
    #[serde(default)]
    pub lateral_offset_m: f64,
    /// Plate size (diameter or side), m.
    #[serde(default = "default_sign_size")]
    pub size_m: f64,
    /// Lower edge of the plate above the road, m.
    #[serde(default = "default_sign_height")]
    pub height_m: f64,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub id: Option<u64>,
}

/// One phase state of a signal head.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum SignalState {
    Red,
    RedYellow,
    Yellow,
    Green,
    Off,
    FlashingYellow,
}

/// One phase of a signal cycle.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SignalPhase {
    pub state: SignalState,
    pub duration_s: f64,
}

fn default_lens() -> f64 {
    0.2
}
fn default_signal_z() -> f64 {
    2.5
}

/// A three-bulb signal head.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SignalHeadConfig {
    pub x_m: f64,
    #[serde(default = "default_shoulder")]
    pub lane: i32,
    #[serde(default)]
    pub lateral_offset_m: f64,
    /// Height of the lowest (green) bulb's centre above the road, m.
    #[serde(default = "default_signal_z")]
    pub z_m: f64,
    /// Lens diameter, m (0.2 or 0.3).
    #[serde(default = "default_lens")]
    pub lens_diameter_m: f64,
    /// The signal cycle, repeated.
    pub cycle: Vec<SignalPhase>,
    /// Scenario time at which the cycle's first phase began, s before t = 0.
    #[serde(default)]
    pub offset_s: f64,
    /// Id of the red bulb (yellow +1, green +2).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub id: Option<u64>,
}

/// What a road marking is.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum MarkingKind {
    StopLine,
    ArrowStraight,
    ArrowLeft,
    ArrowRight,
}

/// A road marking in a lane.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RoadMarkingConfig {
    pub kind: MarkingKind,
    /// x of the marking's centre, m.
    pub x_m: f64,
    pub lane: i32,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub id: Option<u64>,
}

impl SignalHeadConfig {
    /// Which bulbs (red, yellow, green) are lit and whether the lit ones flash, at time `t`.
    pub fn state_at(&self, t: f64) -> SignalState {
        let period: f64 = self.cycle.iter().map(|p| p.duration_s).sum();
        if self.cycle.is_empty() || period.is_nan() || period <= 0.0 {
            return SignalState::Off;
        }
        let mut tau = (t + self.offset_s).rem_euclid(period);
        for p in &self.cycle {
            if tau < p.duration_s {
                return p.state;
            }
            tau -= p.duration_s;
        }
        self.cycle
            .last()
            .map(|p| p.state)
            .unwrap_or(SignalState::Off)
    }
}

/// Validation of the traffic-control lists (errors name the entry and key).
pub(crate) fn validate(
    signs: &[TrafficSignConfig],
    heads: &[SignalHeadConfig],
    markings: &[RoadMarkingConfig],
) -> Result<(), ScenarioError> {
    let bad = |m: String| Err(ScenarioError::Invalid(m));
    for (i, s) in signs.iter().enumerate() {
        for (k, v) in [
            ("x_m", s.x_m),
            ("lateral_offset_m", s.lateral_offset_m),
            ("height_m", s.height_m),
        ] {
            if !v.is_finite() {
                return bad(format!("`traffic_signs[{i}].{k}` must be finite, got {v}"));
            }
        }
        if !(s.size_m.is_finite() && s.size_m > 0.05 && s.size_m <= 5.0) {
            return bad(format!(
                "`traffic_signs[{i}].size_m` must be in (0.05, 5] m, got {}",
                s.size_m
            ));
        }
        if let Some(v) = s.value
            && !(v.is_finite() && v >= 0.0)
        {
            return bad(format!(
                "`traffic_signs[{i}].value` must be finite and ≥ 0, got {v}"
            ));
        }
        if s.sign == SignKind::SpeedLimit && s.value.is_none() {
            return bad(format!(
                "`traffic_signs[{i}]`: a speed_limit sign needs a `value` (km/h)"
            ));
        }
    }
    for (i, h) in heads.iter().enumerate() {
        for (k, v) in [
            ("x_m", h.x_m),
            ("lateral_offset_m", h.lateral_offset_m),
            ("z_m", h.z_m),
            ("offset_s", h.offset_s),
        ] {
            if !v.is_finite() {
                return bad(format!("`signal_heads[{i}].{k}` must be finite, got {v}"));
            }
        }
        if !(h.lens_diameter_m.is_finite() && h.lens_diameter_m > 0.05 && h.lens_diameter_m <= 1.0)
        {
            return bad(format!(
                "`signal_heads[{i}].lens_diameter_m` must be in (0.05, 1] m, got {}",
                h.lens_diameter_m
            ));
        }
        if h.cycle.is_empty() {
            return bad(format!("`signal_heads[{i}].cycle` is empty"));
        }
        for (j, p) in h.cycle.iter().enumerate() {
            if !(p.duration_s.is_finite() && p.duration_s > 0.0) {
                return bad(format!(
                    "`signal_heads[{i}].cycle[{j}].duration_s` must be a finite number > 0, got {}",
                    p.duration_s
                ));
            }
        }
    }
    for (i, m) in markings.iter().enumerate() {
        if !m.x_m.is_finite() {
            return bad(format!(
                "`road_markings[{i}].x_m` must be finite, got {}",
                m.x_m
            ));
        }
    }
    Ok(())
}

/// (id, description) of every traffic-control entity (for the scenario's unique-id check).
pub(crate) fn ids(
    signs: &[TrafficSignConfig],
    heads: &[SignalHeadConfig],
    markings: &[RoadMarkingConfig],
) -> Vec<(u64, String)> {
    let mut out = Vec::new();
    for (i, s) in signs.iter().enumerate() {
        out.push((
            s.id.unwrap_or(3000 + i as u64),
            format!("traffic_signs[{i}]"),
        ));
    }
    for (i, h) in heads.iter().enumerate() {
        let first = h.id.unwrap_or(4000 + 10 * i as u64);
        for b in 0..3 {
            out.push((first + b, format!("signal_heads[{i}] bulb {b}")));
        }
    }
    for (i, m) in markings.iter().enumerate() {
        out.push((
            m.id.unwrap_or(5000 + i as u64),
            format!("road_markings[{i}]"),
        ));
    }
    out
}

fn base(position: [f64; 3], dim: [f64; 3], yaw: f64) -> osi3::BaseStationary {
    osi3::BaseStationary {
        dimension: Some(osi3::Dimension3d {
            length: Some(dim[0]),
            width: Some(dim[1]),
            height: Some(dim[2]),
        }),
        position: Some(vec3(position)),
        orientation: Some(osi3::Orientation3d {
            roll: Some(0.0),
            pitch: Some(0.0),
            yaw: Some(yaw),
        }),
        ..Default::default()
    }
}

/// The OSI traffic signs.
pub(crate) fn traffic_signs(
    road: &RoadConfig,
    signs: &[TrafficSignConfig],
    driving_lanes: &[osi3::Identifier],
) -> Vec<osi3::TrafficSign> {
    use osi3::traffic_sign::main_sign::Classification;
    use osi3::traffic_sign::main_sign::classification::{DirectionScope, Type};
    use osi3::traffic_sign::{MainSign, Variability};
    signs
        .iter()
        .enumerate()
        .map(|(i, s)| {
            let y = road.lane_center_y(s.lane) + s.lateral_offset_m;
            let z = s.height_m + 0.5 * s.size_m;
            // A triangle's box is its side wide and √3/2 side high.
            let h = match s.sign {
                SignKind::TrafficSignalsAhead | SignKind::GiveWay => 0.5 * 3f64.sqrt() * s.size_m,
                _ => s.size_m,
            };
            let (ty, code, value) = match s.sign {
                SignKind::SpeedLimit => (
                    Type::SpeedLimitBegin,
                    "274",
                    s.value.map(|v| osi3::TrafficSignValue {
                        value: Some(v),
                        value_unit: Some(osi3::traffic_sign_value::Unit::KilometerPerHour as i32),
                        text: None,
                    }),
                ),
                SignKind::TrafficSignalsAhead => (Type::AttentionTrafficLight, "131", None),
                SignKind::Stop => (Type::Stop, "206", None),
                SignKind::GiveWay => (Type::GiveWay, "205", None),
            };
            osi3::TrafficSign {
                id: Some(id(s.id.unwrap_or(3000 + i as u64))),
                main_sign: Some(MainSign {
                    base: Some(base(
                        [s.x_m, y, z],
                        [0.02, s.size_m, h],
                        std::f64::consts::PI,
                    )),
                    classification: Some(Classification {
                        variability: Some(Variability::Fixed as i32),
                        r#type: Some(ty as i32),
                        value,
                        direction_scope: Some(DirectionScope::NoDirection as i32),
                        assigned_lane_id: driving_lanes.to_vec(),
                        vertically_mirrored: Some(false),
                        is_out_of_service: Some(false),
                        country: Some("DE".into()),
                        country_revision: Some("2017".into()),
                        code: Some(code.into()),
                        sub_code: Some(s.value.map(|v| format!("{v}")).unwrap_or_default()),
                        ..Default::default()
                    }),
                    model_reference: None,
                }),
                ..Default::default()
            }
        })
        .collect()
}

/// The OSI traffic lights (three bulbs per head) at time `t`.
pub(crate) fn traffic_lights(
    road: &RoadConfig,
    heads: &[SignalHeadConfig],
    t: f64,
) -> Vec<osi3::TrafficLight> {
    use osi3::traffic_light::Classification;
    use osi3::traffic_light::classification::{Color, Icon, Mode};
    let mut out = Vec::with_capacity(3 * heads.len());
    for (i, h) in heads.iter().enumerate() {
        let y = road.lane_center_y(h.lane) + h.lateral_offset_m;
        let state = h.state_at(t);
        let lit = |bulb: usize| -> Mode {
            use SignalState::*;
            match (state, bulb) {
                (Red | RedYellow, 0) | (RedYellow | Yellow, 1) | (Green, 2) => Mode::Constant,
                (FlashingYellow, 1) => Mode::Flashing,
                _ => Mode::Off,
            }
        };
        let first = h.id.unwrap_or(4000 + 10 * i as u64);
        let d = h.lens_diameter_m;
        for (bulb, color) in [Color::Red, Color::Yellow, Color::Green]
            .into_iter()
            .enumerate()
        {
            let z = h.z_m + 1.5 * d * (2 - bulb) as f64;
            out.push(osi3::TrafficLight {
                id: Some(id(first + bulb as u64)),
                base: Some(base([h.x_m, y, z], [0.05, d, d], std::f64::consts::PI)),
                classification: Some(Classification {
                    color: Some(color as i32),
                    icon: Some(Icon::None as i32),
                    mode: Some(lit(bulb) as i32),
                    is_out_of_service: Some(false),
                    ..Default::default()
                }),
                ..Default::default()
            });
        }
    }
    out
}

/// A marking's outline in its local frame (x along the road, y left), counter-clockwise.
fn outline(kind: MarkingKind, lane_width_m: f64) -> (Vec<[f64; 2]>, [f64; 2]) {
    // Straight arrow: 3.5 m shaft 0.15 m wide, 1.5 m head 0.6 m wide; 5 m overall.
    let (sw, hw) = (0.075, 0.3);
    match kind {
        MarkingKind::StopLine => {
            let (l, w) = (0.25, 0.5 * lane_width_m);
            (
                vec![[-l, -w], [l, -w], [l, w], [-l, w]],
                [0.5, lane_width_m],
            )
        }
        MarkingKind::ArrowStraight => (
            vec![
                [-2.5, -sw],
                [1.0, -sw],
                [1.0, -hw],
                [2.5, 0.0],
                [1.0, hw],
                [1.0, sw],
                [-2.5, sw],
            ],
            [5.0, 2.0 * hw],
        ),
        MarkingKind::ArrowLeft | MarkingKind::ArrowRight => {
            // Shaft up to 1.0 m, then a head pointing to the side (left: +y).
            let left = vec![
                [-2.5, -sw],
                [1.0, -sw],
                [1.0, 0.5],
                [1.5, 0.5],
                [0.8, 1.1],
                [0.1, 0.5],
                [0.6, 0.5],
                [0.6, sw],
                [-2.5, sw],
            ];
            let pts = if kind == MarkingKind::ArrowLeft {
                left
            } else {
                // Mirror y and reverse the order to stay counter-clockwise.
                left.iter().rev().map(|p| [p[0], -p[1]]).collect()
            };
            (pts, [5.0, 2.2])
        }
    }
}

/// The OSI road markings.
pub(crate) fn road_markings(
    road: &RoadConfig,
    markings: &[RoadMarkingConfig],
    lane_ids: &dyn Fn(f64) -> Vec<osi3::Identifier>,
) -> Vec<osi3::RoadMarking> {
    use osi3::road_marking::Classification;
    use osi3::road_marking::classification::{Color, Type};
    use osi3::traffic_sign::main_sign::classification::Type as SignType;
    markings
        .iter()
        .enumerate()
        .map(|(i, m)| {
            let y = road.lane_center_y(m.lane);
            let (poly, size) = outline(m.kind, road.lane_width_m);
            // German catalogue codes (VzKat): Zeichen 294 stop line, 297 lane arrows.
            let (ty, sign, code, sub_code) = match m.kind {
                MarkingKind::StopLine => (Type::GenericLine, SignType::Other, "294", ""),
                MarkingKind::ArrowStraight => (
                    Type::SymbolicTrafficSign,
                    SignType::PrescribedStraight,
                    "297",
                    "10",
                ),
                MarkingKind::ArrowLeft => (
                    Type::SymbolicTrafficSign,
                    SignType::PrescribedLeftTurn,
                    "297",
                    "11",
                ),
                MarkingKind::ArrowRight => (
                    Type::SymbolicTrafficSign,
                    SignType::PrescribedRightTurn,
                    "297",
                    "12",
                ),
            };
            let mut b = base([m.x_m, y, 0.0], [size[0], size[1], 0.0], 0.0);
            b.base_polygon = poly
                .iter()
                .map(|p| osi3::Vector2d {
                    x: Some(p[0]),
                    y: Some(p[1]),
                })
                .collect();
            osi3::RoadMarking {
                id: Some(id(m.id.unwrap_or(5000 + i as u64))),
                base: Some(b),
                classification: Some(Classification {
                    r#type: Some(ty as i32),
                    traffic_main_sign_type: Some(sign as i32),
                    monochrome_color: Some(Color::White as i32),
                    assigned_lane_id: lane_ids(y),
                    is_out_of_service: Some(false),
                    country: Some("DE".into()),
                    country_revision: Some("2017".into()),
                    code: Some(code.into()),
                    sub_code: Some(sub_code.into()),
                    ..Default::default()
                }),
                ..Default::default()
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn shoelace(p: &[[f64; 2]]) -> f64 {
        (0..p.len())
            .map(|i| {
                let (a, b) = (p[i], p[(i + 1) % p.len()]);
                a[0] * b[1] - b[0] * a[1]
            })
            .sum::<f64>()
            / 2.0
    }

    #[test]
    fn outlines_are_counter_clockwise_with_their_areas() {
        // Stop line: 0.5 m × lane width.
        let (p, _) = outline(MarkingKind::StopLine, 3.5);
        assert!((shoelace(&p) - 0.5 * 3.5).abs() < 1e-12);
        // Straight arrow: shaft 3.5 × 0.15 plus head ½ · 1.5 · 0.6.
        let (p, _) = outline(MarkingKind::ArrowStraight, 3.5);
        assert!((shoelace(&p) - (3.5 * 0.15 + 0.5 * 1.5 * 0.6)).abs() < 1e-12);
        for k in [MarkingKind::ArrowLeft, MarkingKind::ArrowRight] {
            let (p, _) = outline(k, 3.5);
            assert!(shoelace(&p) > 0.0, "{k:?}");
        }
        let (l, _) = outline(MarkingKind::ArrowLeft, 3.5);
        let (r, _) = outline(MarkingKind::ArrowRight, 3.5);
        assert!((shoelace(&l) - shoelace(&r)).abs() < 1e-12);
    }

    #[test]
    fn signal_cycle_states() {
        let h = SignalHeadConfig {
            x_m: 0.0,
            lane: -1,
            lateral_offset_m: 0.0,
            z_m: 2.5,
            lens_diameter_m: 0.2,
            cycle: vec![
                SignalPhase {
                    state: SignalState::Green,
                    duration_s: 10.0,
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
            ],
            offset_s: 9.0,
            id: None,
        };
        assert_eq!(h.state_at(0.0), SignalState::Green);
        assert_eq!(h.state_at(1.0), SignalState::Yellow);
        assert_eq!(h.state_at(4.5), SignalState::Red);
        assert_eq!(h.state_at(24.5), SignalState::RedYellow);
        assert_eq!(h.state_at(25.0), SignalState::Green);
        assert_eq!(h.state_at(-9.5), SignalState::RedYellow);
        let road = RoadConfig::default();
        let lights = traffic_lights(&road, std::slice::from_ref(&h), 4.5);
        use osi3::traffic_light::classification::Mode;
        let modes: Vec<_> = lights
            .iter()
            .map(|l| l.classification.as_ref().unwrap().mode.unwrap())
            .collect();
        assert_eq!(
            modes,
            vec![Mode::Constant as i32, Mode::Off as i32, Mode::Off as i32]
        );
        // Red on top: 2 · 1.5 · 0.2 m above the green bulb.
        let z = |k: usize| {
            lights[k]
                .base
                .as_ref()
                .unwrap()
                .position
                .unwrap()
                .z
                .unwrap()
        };
        assert!((z(0) - 3.1).abs() < 1e-12 && (z(2) - 2.5).abs() < 1e-12);
    }
}
