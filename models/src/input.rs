//! Screening of a SensorView at the model boundary: every value a model would use is checked once,
//! before any model sees it, so bad input is reported by name instead of being silently dropped,
//! silently used, or turned into an endless step.
//!
//! [`screen_view`] checks the global ground truth's moving and stationary objects, the host
//! vehicle and the sensor's mounting:
//!
//! | what | rule | consequence |
//! |---|---|---|
//! | object id | present, unique over moving and stationary objects | later duplicates / id-less objects skipped |
//! | position | finite, every coordinate within ±[`MAX_COORDINATE_M`] | object skipped |
//! | orientation | finite | object skipped |
//! | dimension | finite, each extent in [0, [`MAX_DIMENSION_M`]], at most one extent 0 | object skipped |
//! | velocity | finite, speed ≤ [`MAX_SPEED_M_S`] | object skipped |
//! | acceleration | finite, magnitude ≤ [`MAX_ACCELERATION_M_S2`] | object skipped |
//! | orientation rate | finite, each rate ≤ [`MAX_ORIENTATION_RATE_RAD_S`] | object skipped |
//! | orientation acceleration, base polygon, `bbcenter_to_rear` | finite | object skipped |
//! | the host vehicle failing any rule above | — | frame skipped (the sensor cannot be placed) |
//! | `SensorView.mounting_position` | finite, offset ≤ [`MAX_MOUNTING_OFFSET_M`] | frame skipped |
//! | `SensorView.timestamp`, `GroundTruth.timestamp` | OSI's rules: seconds ≥ 0 (and ≤ [`MAX_TIMESTAMP_S`]), nanos ≤ 999,999,999 | timestamp ignored (the next in line — the ground truth's, then the communication point — stands in) |
//!
//! The bounds are plausibility gates, not physics: a 1 km object, a 1,000 m/s road user or a
//! sensor mounted 100 m from its vehicle's reference point is a broken input, not a scenario. OSI
//! allows extents of 0 (`Dimension3d` fields are "≥ 0"), so one zero extent (a flat plate, a
//! painted marking) is accepted; two or three (a line or a point) have no surface a sensor could
//! see. Orientations outside [−π, π] are off OSI's convention but unambiguous, so only non-finite
//! angles are refused.
//!
//! Each finding is one [`InputIssue`] naming the object (its id, or its index when it has none)
//! and the field; the FMU shell logs them as fmi2Warning and steps the rest of the frame.

use std::collections::HashSet;
use std::fmt;

use osiris_proto::osi3;

/// Largest plausible object extent, m (each of length, width, height).
pub const MAX_DIMENSION_M: f64 = 1_000.0;
/// Largest plausible absolute global coordinate, m: about 15 Earth radii, beyond any projected
/// (UTM-like) coordinate a scenario uses.
pub const MAX_COORDINATE_M: f64 = 1.0e8;
/// Largest plausible speed of an object, m/s (about 3× the speed of sound).
pub const MAX_SPEED_M_S: f64 = 1_000.0;
/// Largest plausible acceleration magnitude of an object, m/s² (≈ 100 g).
pub const MAX_ACCELERATION_M_S2: f64 = 1_000.0;
/// Largest plausible body rotation rate about any axis, rad/s (≈ 16 revolutions per second).
pub const MAX_ORIENTATION_RATE_RAD_S: f64 = 100.0;
/// Largest plausible distance of the sensor from its vehicle's reference point, m.
pub const MAX_MOUNTING_OFFSET_M: f64 = 100.0;

/// Largest timestamp accepted, s: nanoseconds since the epoch must fit an `i64` (year 2262).
pub const MAX_TIMESTAMP_S: i64 = i64::MAX / 1_000_000_000 - 1;

/// Which ground-truth list an object came from.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ObjectList {
    Moving,
    Stationary,
}

impl ObjectList {
    fn field(self) -> &'static str {
        match self {
            ObjectList::Moving => "moving_object",
            ObjectList::Stationary => "stationary_object",
        }
    }
}

/// One finding of [`screen_view`].
#[derive(Debug, Clone, PartialEq)]
pub struct InputIssue {
    /// The object, e.g. `moving_object id 42` or `stationary_object[3] (no id)`, or
    /// `SensorView.mounting_position`.
    pub subject: String,
    /// The field and what is wrong with it, e.g. `base.dimension.length = inf (must be finite)`.
    pub problem: String,
    /// What was done: `object skipped` or `frame skipped`.
    pub action: &'static str,
}

impl fmt::Display for InputIssue {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}: {}; {}", self.subject, self.problem, self.action)
    }
}

/// What [`screen_view`] found.
#[derive(Debug, Default, Clone)]
pub struct Screening {
    /// Every finding, objects skipped and frame-level ones, in input order.
    pub issues: Vec<InputIssue>,
    /// Set when the frame cannot be simulated at all (bad mounting, bad host vehicle): the
    /// reason. The view is then left as it was.
    pub frame_skipped: bool,
}

impl Screening {
    /// No finding at all.
    pub fn is_clean(&self) -> bool {
        self.issues.is_empty()
    }
}

/// Check `view` against the rules of the module documentation; objects that break one are removed
/// from `view.global_ground_truth`, and the findings are returned. When
/// [`Screening::frame_skipped`] is set the frame must not be simulated.
pub fn screen_view(view: &mut osi3::SensorView) -> Screening {
    let mut s = Screening::default();
    if let Some(m) = &view.mounting_position
        && let Some(problem) = mounting_problem(m)
    {
        s.issues.push(InputIssue {
            subject: "SensorView.mounting_position".into(),
            problem,
            action: "frame skipped",
        });
        s.frame_skipped = true;
    }
    if let Some(problem) = view.timestamp.as_ref().and_then(timestamp_problem) {
        s.issues.push(InputIssue {
            subject: "SensorView.timestamp".into(),
            problem,
            action: "timestamp ignored",
        });
        view.timestamp = None;
    }
    let Some(gt) = view.global_ground_truth.as_mut() else {
        return s;
    };
    if let Some(problem) = gt.timestamp.as_ref().and_then(timestamp_problem) {
        s.issues.push(InputIssue {
            subject: "GroundTruth.timestamp".into(),
            problem,
            action: "timestamp ignored",
        });
        gt.timestamp = None;
    }
    let host_id = view
        .host_vehicle_id
        .and_then(|i| i.value)
        .or(gt.host_vehicle_id.and_then(|i| i.value));

    // Decide first (the host may be anywhere in the list), remove afterwards.
    let mut seen: HashSet<u64> =
        HashSet::with_capacity(gt.moving_object.len() + gt.stationary_object.len());
    let mut keep_moving = Vec::with_capacity(gt.moving_object.len());
    let mut host_issue = None;
    for (k, o) in gt.moving_object.iter().enumerate() {
        let id = o.id.and_then(|i| i.value);
        let problem = id_problem(id, &mut seen).or_else(|| moving_problem(o));
        if let Some(problem) = problem {
            let subject = subject(ObjectList::Moving, k, id);
            if id.is_some() && id == host_id && !problem.starts_with("duplicate") {
                host_issue = Some(InputIssue {
                    subject: format!("host vehicle ({subject})"),
                    problem,
                    action: "frame skipped",
                });
            } else {
                s.issues.push(InputIssue {
                    subject,
                    problem,
                    action: "object skipped",
                });
            }
            keep_moving.push(false);
        } else {
            keep_moving.push(true);
        }
    }
    let mut keep_stationary = Vec::with_capacity(gt.stationary_object.len());
    for (k, o) in gt.stationary_object.iter().enumerate() {
        let id = o.id.and_then(|i| i.value);
        let problem = id_problem(id, &mut seen).or_else(|| stationary_problem(o));
        keep_stationary.push(problem.is_none());
        if let Some(problem) = problem {
            s.issues.push(InputIssue {
                subject: subject(ObjectList::Stationary, k, id),
                problem,
                action: "object skipped",
            });
        }
    }
    if let Some(issue) = host_issue {
        s.issues.push(issue);
        s.frame_skipped = true;
    }
    if s.frame_skipped {
        return s;
    }
    let mut it = keep_moving.into_iter();
    gt.moving_object.retain(|_| it.next().unwrap_or(true));
    let mut it = keep_stationary.into_iter();
    gt.stationary_object.retain(|_| it.next().unwrap_or(true));
    s
}

fn subject(list: ObjectList, index: usize, id: Option<u64>) -> String {
    match id {
        Some(id) => format!("{} id {id}", list.field()),
        None => format!("{}[{index}] (no id)", list.field()),
    }
}

fn id_problem(id: Option<u64>, seen: &mut HashSet<u64>) -> Option<String> {
    match id {
        None => Some("id is not set (OSI requires a unique id)".into()),
        Some(v) if !seen.insert(v) => Some(format!(
            "duplicate id {v} (ids must be unique over moving and stationary objects; the first \
             object with this id is kept)"
        )),
        Some(_) => None,
    }
}

fn timestamp_problem(ts: &osi3::Timestamp) -> Option<String> {
    let sec = ts.seconds.unwrap_or(0);
    let nanos = ts.nanos.unwrap_or(0);
    if !(0..=MAX_TIMESTAMP_S).contains(&sec) {
        Some(format!(
            "seconds = {sec} (must be in [0, {MAX_TIMESTAMP_S}])"
        ))
    } else if nanos > 999_999_999 {
        Some(format!("nanos = {nanos} (must be ≤ 999999999)"))
    } else {
        None
    }
}

fn mounting_problem(m: &osi3::MountingPosition) -> Option<String> {
    if let Some(p) = &m.position {
        if let Some(e) = vector_problem("position", p, "m", f64::INFINITY) {
            return Some(e);
        }
        let r = norm(p);
        if r > MAX_MOUNTING_OFFSET_M {
            return Some(format!(
                "position is {r:.3e} m from the vehicle's reference point (plausible: ≤ \
                 {MAX_MOUNTING_OFFSET_M} m)"
            ));
        }
    }
    m.orientation
        .as_ref()
        .and_then(|o| orientation_problem("orientation", o, f64::INFINITY, "rad"))
}

fn moving_problem(o: &osi3::MovingObject) -> Option<String> {
    if let Some(b) = &o.base {
        let checks = [
            b.position
                .as_ref()
                .and_then(|p| vector_problem("base.position", p, "m", MAX_COORDINATE_M)),
            b.orientation
                .as_ref()
                .and_then(|r| orientation_problem("base.orientation", r, f64::INFINITY, "rad")),
            b.dimension
                .as_ref()
                .and_then(|d| dimension_problem("base.dimension", d)),
            b.velocity
                .as_ref()
                .and_then(|v| magnitude_problem("base.velocity", v, "m/s", MAX_SPEED_M_S)),
            b.acceleration.as_ref().and_then(|a| {
                magnitude_problem("base.acceleration", a, "m/s²", MAX_ACCELERATION_M_S2)
            }),
            b.orientation_rate.as_ref().and_then(|r| {
                orientation_problem(
                    "base.orientation_rate",
                    r,
                    MAX_ORIENTATION_RATE_RAD_S,
                    "rad/s",
                )
            }),
            b.orientation_acceleration.as_ref().and_then(|r| {
                orientation_problem("base.orientation_acceleration", r, f64::INFINITY, "rad/s²")
            }),
            polygon_problem("base.base_polygon", &b.base_polygon),
        ];
        if let Some(e) = checks.into_iter().flatten().next() {
            return Some(e);
        }
    }
    o.vehicle_attributes
        .as_ref()
        .and_then(|va| va.bbcenter_to_rear.as_ref())
        .and_then(|v| {
            vector_problem(
                "vehicle_attributes.bbcenter_to_rear",
                v,
                "m",
                MAX_DIMENSION_M,
            )
        })
}

fn stationary_problem(o: &osi3::StationaryObject) -> Option<String> {
    let b = o.base.as_ref()?;
    [
        b.position
            .as_ref()
            .and_then(|p| vector_problem("base.position", p, "m", MAX_COORDINATE_M)),
        b.orientation
            .as_ref()
            .and_then(|r| orientation_problem("base.orientation", r, f64::INFINITY, "rad")),
        b.dimension
            .as_ref()
            .and_then(|d| dimension_problem("base.dimension", d)),
        polygon_problem("base.base_polygon", &b.base_polygon),
    ]
    .into_iter()
    .flatten()
    .next()
}

fn norm(v: &osi3::Vector3d) -> f64 {
    let c = |x: Option<f64>| x.unwrap_or(0.0);
    (c(v.x).powi(2) + c(v.y).powi(2) + c(v.z).powi(2)).sqrt()
}

/// Each named component finite and within ±`bound` (the one check behind vectors, angles and
/// rates).
fn axes_problem(
    field: &str,
    axes: [(&str, Option<f64>); 3],
    unit: &str,
    bound: f64,
) -> Option<String> {
    axes.into_iter().find_map(|(axis, c)| {
        let c = c?;
        if !c.is_finite() {
            Some(format!("{field}.{axis} = {c} (must be finite)"))
        } else if c.abs() > bound {
            Some(format!(
                "{field}.{axis} = {c:e} {unit} (plausible: within ±{bound:e} {unit})"
            ))
        } else {
            None
        }
    })
}

/// Each component finite and within ±`bound`.
fn vector_problem(field: &str, v: &osi3::Vector3d, unit: &str, bound: f64) -> Option<String> {
    axes_problem(field, [("x", v.x), ("y", v.y), ("z", v.z)], unit, bound)
}

/// Each component finite, magnitude ≤ `bound`.
fn magnitude_problem(field: &str, v: &osi3::Vector3d, unit: &str, bound: f64) -> Option<String> {
    if let Some(e) = vector_problem(field, v, unit, f64::INFINITY) {
        return Some(e);
    }
    let m = norm(v);
    (m > bound).then(|| format!("{field} magnitude {m:e} {unit} (plausible: ≤ {bound} {unit})"))
}

/// Each angle (or rate) finite and within ±`bound`.
fn orientation_problem(
    field: &str,
    o: &osi3::Orientation3d,
    bound: f64,
    unit: &str,
) -> Option<String> {
    axes_problem(
        field,
        [("roll", o.roll), ("pitch", o.pitch), ("yaw", o.yaw)],
        unit,
        bound,
    )
}

fn dimension_problem(field: &str, d: &osi3::Dimension3d) -> Option<String> {
    let mut zeros = 0;
    for (axis, v) in [
        ("length", d.length),
        ("width", d.width),
        ("height", d.height),
    ] {
        let Some(v) = v else { continue };
        if !v.is_finite() {
            return Some(format!("{field}.{axis} = {v} (must be finite)"));
        }
        if v < 0.0 {
            return Some(format!("{field}.{axis} = {v} m (must be ≥ 0)"));
        }
        if v > MAX_DIMENSION_M {
            return Some(format!(
                "{field}.{axis} = {v:e} m (plausible: ≤ {MAX_DIMENSION_M} m)"
            ));
        }
        if v == 0.0 {
            zeros += 1;
        }
    }
    (zeros >= 2).then(|| {
        format!("{field} has {zeros} zero extents (a line or a point: no surface a sensor sees)")
    })
}

fn polygon_problem(field: &str, poly: &[osi3::Vector2d]) -> Option<String> {
    poly.iter().enumerate().find_map(|(k, p)| {
        [("x", p.x), ("y", p.y)].into_iter().find_map(|(axis, c)| {
            c.filter(|c| !c.is_finite() || c.abs() > MAX_DIMENSION_M)
                .map(|c| {
                    format!(
                        "{field}[{k}].{axis} = {c} (must be finite, within ±{MAX_DIMENSION_M} m)"
                    )
                })
        })
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use osiris_proto::id;

    fn v3(x: f64, y: f64, z: f64) -> osi3::Vector3d {
        osi3::Vector3d {
            x: Some(x),
            y: Some(y),
            z: Some(z),
        }
    }

    fn car(i: u64, x: f64) -> osi3::MovingObject {
        osi3::MovingObject {
            id: Some(id(i)),
            base: Some(osi3::BaseMoving {
                dimension: Some(osi3::Dimension3d {
                    length: Some(4.5),
                    width: Some(1.8),
                    height: Some(1.5),
                }),
                position: Some(v3(x, 0.0, 0.75)),
                orientation: Some(osi3::Orientation3d::default()),
                velocity: Some(v3(10.0, 0.0, 0.0)),
                ..Default::default()
            }),
            ..Default::default()
        }
    }

    fn cone(i: u64, x: f64) -> osi3::StationaryObject {
        osi3::StationaryObject {
            id: Some(id(i)),
            base: Some(osi3::BaseStationary {
                dimension: Some(osi3::Dimension3d {
                    length: Some(0.3),
                    width: Some(0.3),
                    height: Some(0.7),
                }),
                position: Some(v3(x, 2.0, 0.35)),
                ..Default::default()
            }),
            ..Default::default()
        }
    }

    fn view() -> osi3::SensorView {
        osi3::SensorView {
            host_vehicle_id: Some(id(1)),
            mounting_position: Some(osi3::MountingPosition {
                position: Some(v3(1.5, 0.0, 0.5)),
                orientation: Some(osi3::Orientation3d::default()),
            }),
            global_ground_truth: Some(osi3::GroundTruth {
                moving_object: vec![car(1, 0.0), car(2, 20.0), car(3, 40.0)],
                stationary_object: vec![cone(10, 15.0), cone(11, 25.0)],
                ..Default::default()
            }),
            ..Default::default()
        }
    }

    fn ids(v: &osi3::SensorView) -> (Vec<u64>, Vec<u64>) {
        let gt = v.global_ground_truth.as_ref().unwrap();
        (
            gt.moving_object
                .iter()
                .map(|o| o.id.unwrap().value.unwrap())
                .collect(),
            gt.stationary_object
                .iter()
                .map(|o| o.id.unwrap().value.unwrap())
                .collect(),
        )
    }

    #[test]
    fn a_valid_view_is_untouched() {
        let mut v = view();
        let before = v.clone();
        let s = screen_view(&mut v);
        assert!(s.is_clean(), "{:?}", s.issues);
        assert!(!s.frame_skipped);
        assert_eq!(v, before);
    }

    /// Each bad value removes exactly its object and names the id and the field.
    #[test]
    fn bad_objects_are_named_and_skipped() {
        type Edit = fn(&mut osi3::MovingObject);
        let cases: [(Edit, &str); 9] = [
            (
                |o| {
                    o.base.as_mut().unwrap().dimension.as_mut().unwrap().length =
                        Some(f64::INFINITY)
                },
                "base.dimension.length",
            ),
            (
                |o| o.base.as_mut().unwrap().dimension.as_mut().unwrap().width = Some(1e7),
                "base.dimension.width",
            ),
            (
                |o| o.base.as_mut().unwrap().dimension.as_mut().unwrap().height = Some(-1.0),
                "base.dimension.height",
            ),
            (
                |o| o.base.as_mut().unwrap().position.as_mut().unwrap().y = Some(f64::NAN),
                "base.position.y",
            ),
            (
                |o| o.base.as_mut().unwrap().position.as_mut().unwrap().x = Some(1e9),
                "base.position.x",
            ),
            (
                |o| o.base.as_mut().unwrap().orientation.as_mut().unwrap().yaw = Some(f64::NAN),
                "base.orientation.yaw",
            ),
            (
                |o| o.base.as_mut().unwrap().velocity.as_mut().unwrap().x = Some(f64::NEG_INFINITY),
                "base.velocity.x",
            ),
            (
                |o| o.base.as_mut().unwrap().velocity = Some(v3(3000.0, 0.0, 0.0)),
                "base.velocity magnitude",
            ),
            (
                |o| {
                    o.base.as_mut().unwrap().dimension = Some(osi3::Dimension3d {
                        length: Some(1.0),
                        width: Some(0.0),
                        height: Some(0.0),
                    })
                },
                "base.dimension has 2 zero extents",
            ),
        ];
        for (edit, field) in cases {
            let mut v = view();
            edit(&mut v.global_ground_truth.as_mut().unwrap().moving_object[1]);
            let s = screen_view(&mut v);
            assert!(!s.frame_skipped, "{field}");
            assert_eq!(s.issues.len(), 1, "{field}: {:?}", s.issues);
            let text = s.issues[0].to_string();
            assert!(text.starts_with("moving_object id 2: "), "{text}");
            assert!(text.contains(field), "{field} not in `{text}`");
            assert!(text.ends_with("object skipped"), "{text}");
            assert_eq!(ids(&v), (vec![1, 3], vec![10, 11]), "{field}");
        }
    }

    #[test]
    fn one_zero_extent_is_a_valid_flat_object() {
        let mut v = view();
        v.global_ground_truth.as_mut().unwrap().stationary_object[0]
            .base
            .as_mut()
            .unwrap()
            .dimension
            .as_mut()
            .unwrap()
            .height = Some(0.0);
        assert!(screen_view(&mut v).is_clean());
    }

    #[test]
    fn duplicate_and_missing_ids_keep_the_first_object() {
        let mut v = view();
        let gt = v.global_ground_truth.as_mut().unwrap();
        gt.stationary_object[1].id = Some(id(2)); // same id as a moving object
        gt.moving_object.push(car(3, 60.0)); // duplicate of moving id 3
        gt.stationary_object.push(cone(0, 5.0));
        gt.stationary_object[2].id = None;
        let s = screen_view(&mut v);
        let texts: Vec<String> = s.issues.iter().map(|i| i.to_string()).collect();
        assert_eq!(texts.len(), 3, "{texts:?}");
        assert!(
            texts[0].starts_with("moving_object id 3: duplicate id 3"),
            "{texts:?}"
        );
        assert!(
            texts[1].starts_with("stationary_object id 2: duplicate id 2"),
            "{texts:?}"
        );
        assert!(
            texts[2].starts_with("stationary_object[2] (no id): id is not set"),
            "{texts:?}"
        );
        let (m, st) = ids(&v);
        assert_eq!(m, vec![1, 2, 3]);
        assert_eq!(st, vec![10]);
        // The kept object 3 is the first one (x = 40 m), not the duplicate at 60 m.
        let x = v.global_ground_truth.as_ref().unwrap().moving_object[2]
            .base
            .as_ref()
            .unwrap()
            .position
            .unwrap()
            .x
            .unwrap();
        assert_eq!(x, 40.0);
    }

    #[test]
    fn a_bad_mounting_or_host_skips_the_frame_and_leaves_the_view() {
        let mut v = view();
        v.mounting_position
            .as_mut()
            .unwrap()
            .orientation
            .as_mut()
            .unwrap()
            .pitch = Some(f64::NAN);
        let before = v.clone();
        let s = screen_view(&mut v);
        assert!(s.frame_skipped);
        assert_eq!(s.issues.len(), 1);
        assert_eq!(
            s.issues[0].to_string(),
            "SensorView.mounting_position: orientation.pitch = NaN (must be finite); frame skipped"
        );
        assert_eq!(format!("{v:?}"), format!("{before:?}"));

        let mut v = view();
        v.mounting_position.as_mut().unwrap().position = Some(v3(0.0, 500.0, 0.0));
        assert!(screen_view(&mut v).frame_skipped);

        let mut v = view();
        v.global_ground_truth.as_mut().unwrap().moving_object[0]
            .base
            .as_mut()
            .unwrap()
            .position = Some(v3(f64::NAN, 0.0, 0.0));
        let s = screen_view(&mut v);
        assert!(s.frame_skipped);
        let text = s.issues.last().unwrap().to_string();
        assert!(
            text.starts_with("host vehicle (moving_object id 1): base.position.x = NaN"),
            "{text}"
        );
        assert!(text.ends_with("frame skipped"), "{text}");
    }

    #[test]
    fn out_of_range_timestamps_are_ignored_by_name() {
        let mut v = view();
        v.timestamp = Some(osi3::Timestamp {
            seconds: Some(-3),
            nanos: Some(0),
        });
        v.global_ground_truth.as_mut().unwrap().timestamp = Some(osi3::Timestamp {
            seconds: Some(1),
            nanos: Some(1_000_000_000),
        });
        let s = screen_view(&mut v);
        assert!(!s.frame_skipped);
        let texts: Vec<String> = s.issues.iter().map(|i| i.to_string()).collect();
        assert_eq!(texts.len(), 2);
        assert!(
            texts[0].starts_with("SensorView.timestamp: seconds = -3"),
            "{texts:?}"
        );
        assert!(
            texts[1].starts_with("GroundTruth.timestamp: nanos = 1000000000"),
            "{texts:?}"
        );
        assert!(v.timestamp.is_none());
        assert!(v.global_ground_truth.unwrap().timestamp.is_none());
    }

    #[test]
    fn a_view_without_ground_truth_is_left_to_the_model() {
        let mut v = osi3::SensorView::default();
        assert!(screen_view(&mut v).is_clean());
    }
}
