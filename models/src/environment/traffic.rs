//! Traffic signs, traffic lights and road markings from OSI: their static-world geometry, materials
//! and the per-element records the sensors read ([`super::scene::Scene::traffic_signs`],
//! [`super::scene::Scene::signal_bulbs`], [`super::scene::Scene::road_markings`]).
//!
//! # Traffic signs (`GroundTruth.traffic_sign`)
//!
//! * One **plate** per main sign and per supplementary sign, each placed by its own `base`
//!   (position = box centre, `orientation` x-axis = the view normal, pointing to where the sign is
//!   read from; z-axis = the plate's "up", as OSI defines them). Size: `base.dimension` width × height
//!   (missing or 0: [`DEFAULT_SIGN_SIZE_M`]); thickness: `dimension.length` clamped to 1–50 mm
//!   (missing or 0: [`DEFAULT_PLATE_THICKNESS_M`]). Outline by the main sign's
//!   `classification.type` ([`sign_shape`]); supplementary signs are rectangles.
//! * **Face** material: retroreflective sheeting of the class [`SheetingClass`]
//!   (`SceneOptions::sign_sheeting`, default RA2) in the colour of the sign's background
//!   ([`sign_colour`]; supplementary signs white): `sign_sheeting_<ra1|ra2>_<white|red|blue|yellow>`,
//!   with the EN 12899-1 coefficients of retroreflection (physics.md §3.6). Back and rim: aluminium
//!   (a conductor at mm-wave: a strong, specular radar target).
//! * A **post** (`SceneOptions::sign_posts`): a vertical steel tube of diameter
//!   `SceneOptions::sign_post_diameter_m` (60.3 mm, the common 2" steel tube of sign posts:
//!   **guessed** from practice, not from a standard), behind the main plate (touching its back), from
//!   the road surface below it (the nearest road vertex's height, else the fallback plane) up to the
//!   highest plate centre. Skipped when that is less than 0.1 m.
//!
//! # Traffic lights (`GroundTruth.traffic_light`, one message per bulb)
//!
//! * Each bulb is a **lens**: a flat disc of diameter `min(dimension.width, dimension.height)`
//!   (missing: [`DEFAULT_LENS_DIAMETER_M`]; EN 12368 roundels are 200 or 300 mm) centred at
//!   `base.position`, facing the `base.orientation` x-axis (the optical axis).
//! * A **housing** (`plastic_black`) behind the lenses: bulbs whose centres lie within
//!   [`HOUSING_MERGE_DISTANCE_M`] of each other (transitively) and whose axes differ by less than
//!   30° share one box, in the frame of the group's first bulb: from
//!   `SceneOptions::signal_housing_depth_m` (0.25 m, **guessed**) behind the rearmost lens to 2 mm
//!   behind it, [`HOUSING_MARGIN_M`] (5 cm, **guessed**) beyond the lenses' edges. No visors.
//! * Unlit lenses are `signal_lens_off` (dark); which are lit is decided per frame by the camera
//!   (`camera::light`), from each bulb's `classification.mode` and `color`.
//!
//! # Road markings (`GroundTruth.road_marking`)
//!
//! The painted area is a flat polygon raised by `max(thickness/2, SceneOptions::marking_height_m)`
//! above the box centre along the marking's normal. Frames (see [`marking_frame`]):
//!
//! * OSI's road-marking convention (`orientation` x-axis = view normal, "normally to the sky";
//!   z-axis = the image's bottom → top, in the road plane): normal = x-axis (turned up if it points
//!   down), forward = z-axis, left = normal × forward; extent forward = `dimension.height`, left =
//!   `dimension.width`, thickness = `dimension.length`.
//! * A horizontal x-axis (a producer that gives a plain yaw): normal = z-axis, forward = x-axis, left
//!   = y-axis; extents `length` × `width`, thickness `height`.
//!
//! The outline is `base.base_polygon` with each vertex `(x, y)` read as (forward, left) in that
//! frame, origin at the box centre (OSI's "x forward, y left" footprint convention applied in the
//! painted plane; at least three vertices), else the rectangle of the two extents. It is
//! ear-clipped (simple polygons). Material by `classification.monochrome_color`: yellow (and
//! orange) → `lane_paint_yellow`, others → `lane_paint_white` (both with glass-bead retroreflection,
//! EN 1436 R_L, physics.md §3.6; `_wet` variants on a wet road as for lane markings). Painted
//! traffic signs (colour images) are white paint.

use glam::{DMat3, DVec2, DVec3};
use osiris_proto::{INVALID_ID, osi3};

use super::assets::geometry::{ear_clip, polygon_area};
use super::assets::signals::{SignShape, sign_plate, sign_post, signal_housing, signal_lens};
use super::mesh::Mesh;
use super::scene::StaticElement;
use crate::frames::Pose;

/// Plate width and height where OSI gives none, m (**guessed**: the 600 mm size class of German
/// round and triangular signs, VwV-StVO).
pub const DEFAULT_SIGN_SIZE_M: f64 = 0.6;
/// Plate thickness where OSI gives none, m (**guessed**: 2 mm aluminium sheet).
pub const DEFAULT_PLATE_THICKNESS_M: f64 = 0.002;
/// Lens diameter where OSI gives none, m (the smaller EN 12368 roundel).
pub const DEFAULT_LENS_DIAMETER_M: f64 = 0.2;
/// Bulbs closer than this share a housing, m.
pub const HOUSING_MERGE_DISTANCE_M: f64 = 0.5;
/// Housing margin around the lenses, m (**guessed**).
pub const HOUSING_MARGIN_M: f64 = 0.05;
/// Gap between a lens and the housing face behind it, m.
pub const LENS_GAP_M: f64 = 0.002;

/// Retroreflective sheeting class of sign faces (EN 12899-1).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub enum SheetingClass {
    /// Class RA1 (engineering grade, about ASTM D4956 Type I).
    Ra1,
    /// Class RA2 (high intensity, about ASTM D4956 Type III).
    #[default]
    Ra2,
}

/// Background colour of a sign face.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum SignColour {
    White,
    Red,
    Blue,
    Yellow,
}

impl SignColour {
    fn word(self) -> &'static str {
        match self {
            SignColour::White => "white",
            SignColour::Red => "red",
            SignColour::Blue => "blue",
            SignColour::Yellow => "yellow",
        }
    }
}

/// The material of a sign face: `sign_sheeting_<class>_<colour>`.
pub fn sheeting_material(class: SheetingClass, colour: SignColour) -> String {
    let c = match class {
        SheetingClass::Ra1 => "ra1",
        SheetingClass::Ra2 => "ra2",
    };
    format!("sign_sheeting_{c}_{}", colour.word())
}

type SignType = osi3::traffic_sign::main_sign::classification::Type;

fn sign_type(ty: Option<i32>) -> Option<SignType> {
    ty.and_then(|t| SignType::try_from(t).ok())
}

/// Mandatory signs (Vienna Convention class D): prescribed directions, roundabout, pass left or
/// right, and the paths reserved to bicycles, horse riders or pedestrians. Round and blue, so
/// [`sign_shape`] and [`sign_colour`] both take them from here.
fn is_mandatory(t: SignType) -> bool {
    use SignType as T;
    matches!(
        t,
        T::PrescribedLeftTurn
            | T::PrescribedRightTurn
            | T::PrescribedStraight
            | T::PrescribedRightWay
            | T::PrescribedLeftWay
            | T::PrescribedRightTurnAndStraight
            | T::PrescribedLeftTurnAndStraight
            | T::PrescribedLeftTurnAndRightTurn
            | T::PrescribedLeftTurnRightTurnAndStraight
            | T::Roundabout
            | T::PassLeft
            | T::PassRight
            | T::BicyclesOnly
            | T::HorseRidersOnly
            | T::PedestriansOnly
            | T::BicyclesPedestriansSharedOnly
            | T::BicyclesPedestriansSeparatedLeftOnly
            | T::BicyclesPedestriansSeparatedRightOnly
            | T::PrescribedUTurnLeft
            | T::PrescribedUTurnRight
    )
}

/// Plate outline of a main sign by its OSI type (Vienna Convention shapes, cheap classes): warning
/// signs and "right of way at the next intersection" triangles; give way an inverted triangle; stop
/// an octagon; priority road a diamond; prohibitions, restrictions, mandatory directions, speed
/// limits (begin and end) circles; everything else (information, direction, zones) rectangles.
pub fn sign_shape(ty: Option<i32>) -> SignShape {
    use SignType as T;
    let Some(t) = sign_type(ty) else {
        return SignShape::Rectangle;
    };
    match t {
        T::DangerSpot
        | T::ZebraCrossing
        | T::Flight
        | T::Cattle
        | T::HorseRiders
        | T::Amphibians
        | T::FallingRocks
        | T::SnowOrIce
        | T::LooseGravel
        | T::Waterside
        | T::Clearance
        | T::MovableBridge
        | T::RightBeforeLeftNextIntersection
        | T::TurnLeft
        | T::TurnRight
        | T::DoubleTurnLeft
        | T::DoubleTurnRight
        | T::HillDownwards
        | T::HillUpwards
        | T::UnevenRoad
        | T::RoadSlipperyWetOrDirty
        | T::SideWinds
        | T::RoadNarrowing
        | T::RoadNarrowingRight
        | T::RoadNarrowingLeft
        | T::RoadWorks
        | T::TrafficQueues
        | T::TwoWayTraffic
        | T::AttentionTrafficLight
        | T::Pedestrians
        | T::ChildrenCrossing
        | T::CycleRoute
        | T::DeerCrossing
        | T::UngatedLevelCrossing
        | T::RightOfWayNextIntersection => SignShape::Triangle,
        T::GiveWay => SignShape::InvertedTriangle,
        T::Stop => SignShape::Octagon,
        T::RightOfWayBegin | T::RightOfWayEnd => SignShape::Diamond,
        T::PriorityToOppositeDirection
        | T::PriorityToOppositeDirectionUpsideDown
        | T::AllProhibited
        | T::MotorizedMultitrackProhibited
        | T::TrucksProhibited
        | T::BicyclesProhibited
        | T::MotorcyclesProhibited
        | T::MopedsProhibited
        | T::HorseRidersProhibited
        | T::HorseCarriagesProhibited
        | T::CattleProhibited
        | T::BusesProhibited
        | T::CarsProhibited
        | T::CarsTrailersProhibited
        | T::TrucksTrailersProhibited
        | T::TractorsProhibited
        | T::PedestriansProhibited
        | T::MotorVehiclesProhibited
        | T::HazardousGoodsVehiclesProhibited
        | T::OverWeightVehiclesProhibited
        | T::VehiclesAxleOverWeightProhibited
        | T::VehiclesExcessWidthProhibited
        | T::VehiclesExcessHeightProhibited
        | T::VehiclesExcessLengthProhibited
        | T::DoNotEnter
        | T::SnowChainsRequired
        | T::WaterPollutantVehiclesProhibited
        | T::NoUTurnLeft
        | T::NoUTurnRight
        | T::MinimumDistanceForTrucks
        | T::SpeedLimitBegin
        | T::MinimumSpeedBegin
        | T::OvertakingBanBegin
        | T::OvertakingBanForTrucksBegin
        | T::SpeedLimitEnd
        | T::MinimumSpeedEnd
        | T::OvertakingBanEnd
        | T::OvertakingBanForTrucksEnd
        | T::AllRestrictionsEnd
        | T::NoStopping
        | T::NoParking
        | T::AdvisorySpeedLimitBegin
        | T::AdvisorySpeedLimitEnd => SignShape::Circle,
        t if is_mandatory(t) => SignShape::Circle,
        _ => SignShape::Rectangle,
    }
}

/// Background colour of a main sign by its OSI type (German practice, VwV-StVO; cheap classes):
/// stop and no entry red; mandatory directions, minimum speeds, parking, bus lanes, motorway and
/// expressway signs blue; priority road, town and advance direction signs yellow; everything else
/// (warnings, prohibitions, speed limits, information) white. The coloured borders and symbols are
/// not modelled.
pub fn sign_colour(ty: Option<i32>) -> SignColour {
    use SignType as T;
    let Some(t) = sign_type(ty) else {
        return SignColour::White;
    };
    match t {
        T::Stop | T::DoNotEnter => SignColour::Red,
        t if is_mandatory(t) => SignColour::Blue,
        T::MinimumSpeedBegin
        | T::MinimumSpeedEnd
        | T::BusLane
        | T::BusLaneBegin
        | T::BusLaneEnd
        | T::CarParking
        | T::CarParkingZoneBegin
        | T::CarParkingZoneEnd
        | T::HighwayBegin
        | T::HighwayEnd
        | T::ExpresswayBegin
        | T::ExpresswayEnd
        | T::HighwayExit
        | T::ExpresswayExit
        | T::OnewayLeft
        | T::OnewayRight
        | T::OnewayStreet
        | T::ZebraCrossing
        | T::BusStop
        | T::TaxiStand
        | T::LivingStreetBegin
        | T::LivingStreetEnd
        | T::Tunnel
        | T::Deadend => SignColour::Blue,
        T::RightOfWayBegin
        | T::RightOfWayEnd
        | T::TownBegin
        | T::TownEnd
        | T::DirectionPreannouncement
        | T::DirectionPreannouncementLaneConfig
        | T::OtherRoadAnnouncement => SignColour::Yellow,
        _ => SignColour::White,
    }
}

/// Colour of a signal bulb (OSI `TrafficLight.Classification.Color`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum SignalColour {
    Red,
    Yellow,
    Green,
    Blue,
    White,
    /// Unknown or other: drawn as white.
    Other,
}

impl SignalColour {
    pub fn from_osi(color: Option<i32>) -> SignalColour {
        use osi3::traffic_light::classification::Color as C;
        match color.and_then(|c| C::try_from(c).ok()) {
            Some(C::Red) => SignalColour::Red,
            Some(C::Yellow) => SignalColour::Yellow,
            Some(C::Green) => SignalColour::Green,
            Some(C::Blue) => SignalColour::Blue,
            Some(C::White) => SignalColour::White,
            _ => SignalColour::Other,
        }
    }
}

/// One plate of a traffic sign.
#[derive(Debug, Clone, PartialEq)]
pub struct SceneSignPlate {
    /// `None`: the main sign; `Some(k)`: `supplementary_sign[k]`.
    pub supplementary: Option<usize>,
    /// Plate frame (origin = OSI box centre, x = view normal, z = plate up) → scene frame.
    pub pose: Pose,
    pub width_m: f64,
    pub height_m: f64,
    pub thickness_m: f64,
    pub shape: SignShape,
    /// Face material (sheeting) name.
    pub face_material: String,
}

/// A traffic sign in the scene (its static-world triangles are owned by
/// [`StaticElement::TrafficSign`] (plates) and [`StaticElement::SignPost`] (post)).
#[derive(Debug, Clone, PartialEq)]
pub struct SceneTrafficSign {
    /// OSI id (`INVALID_ID` when it has none).
    pub id: u64,
    pub plates: Vec<SceneSignPlate>,
    /// Post (bottom, top) centres in the scene frame and its diameter, m.
    pub post: Option<(DVec3, DVec3, f64)>,
}

/// A traffic-light bulb in the scene (its lens is owned by [`StaticElement::TrafficLight`]).
#[derive(Debug, Clone, PartialEq)]
pub struct SceneSignalBulb {
    /// OSI id of the `TrafficLight` message (`INVALID_ID` when it has none).
    pub id: u64,
    /// Lens centre (the OSI box centre), scene frame, m.
    pub centre: DVec3,
    /// Bulb frame (x = optical axis, y = left, z = up) → scene axes.
    pub rotation: DMat3,
    pub diameter_m: f64,
    pub colour: SignalColour,
    /// Index of the housing this bulb sits in (bulbs with the same index share one).
    pub housing: usize,
}

impl SceneSignalBulb {
    /// Lens area π d²/4, m².
    pub fn lens_area_m2(&self) -> f64 {
        0.25 * std::f64::consts::PI * self.diameter_m * self.diameter_m
    }
}

/// A road marking in the scene (owned by [`StaticElement::RoadMarking`]).
#[derive(Debug, Clone, PartialEq)]
pub struct SceneRoadMarking {
    /// OSI id (`INVALID_ID` when it has none).
    pub id: u64,
    /// Painted outline (scene frame, counter-clockwise seen along −normal).
    pub outline: Vec<DVec3>,
    /// Unit normal of the painted surface (up).
    pub normal: DVec3,
    /// Painted area, m².
    pub area_m2: f64,
    pub material: String,
}

/// Settings of the traffic geometry (from `SceneOptions`).
pub(crate) struct TrafficSettings<'a> {
    pub origin: DVec3,
    pub sheeting: SheetingClass,
    pub sign_posts: bool,
    pub post_diameter_m: f64,
    pub housing_depth_m: f64,
    pub marking_height_m: f64,
    /// Road height below a global point.
    pub ground_z: &'a dyn Fn(DVec3) -> f64,
    /// The material in effect for a paint name (wet variant on a wet road).
    pub paint: &'a dyn Fn(&str) -> String,
}

/// A mesh to place in the static world: object frame → global by `pose`.
pub(crate) struct TrafficPiece {
    pub mesh: Mesh,
    pub pose: Pose,
    pub element: StaticElement,
}

/// Everything the traffic elements add to the static world.
#[derive(Default)]
pub(crate) struct TrafficBuild {
    pub pieces: Vec<TrafficPiece>,
    pub signs: Vec<SceneTrafficSign>,
    pub bulbs: Vec<SceneSignalBulb>,
    pub markings: Vec<SceneRoadMarking>,
    pub warnings: Vec<String>,
}

fn object_id(id: Option<&osi3::Identifier>) -> u64 {
    id.and_then(|i| i.value).unwrap_or(INVALID_ID)
}

fn positive(v: Option<f64>) -> Option<f64> {
    v.filter(|x| x.is_finite() && *x > 0.0)
}

fn base_pose(b: &osi3::BaseStationary) -> Option<Pose> {
    let p = b.position.as_ref()?;
    let pose = Pose::from_osi(Some(p), b.orientation.as_ref());
    (pose.position.is_finite() && pose.rotation.is_finite()).then_some(pose)
}

/// One plate from a `BaseStationary`.
fn plate(
    base: &osi3::BaseStationary,
    shape: SignShape,
    face_material: String,
    supplementary: Option<usize>,
) -> Option<SceneSignPlate> {
    let pose = base_pose(base)?;
    let d = base.dimension.as_ref();
    let width_m = positive(d.and_then(|d| d.width)).unwrap_or(DEFAULT_SIGN_SIZE_M);
    let height_m = positive(d.and_then(|d| d.height)).unwrap_or(DEFAULT_SIGN_SIZE_M);
    let thickness_m = positive(d.and_then(|d| d.length))
        .map_or(DEFAULT_PLATE_THICKNESS_M, |t| t.clamp(0.001, 0.05));
    Some(SceneSignPlate {
        supplementary,
        pose,
        width_m,
        height_m,
        thickness_m,
        shape,
        face_material,
    })
}

/// The (normal, forward, left) frame and the (forward, left, thickness) extents of a road marking
/// (see the module docs), from its OSI rotation and dimension (length, width, height).
pub fn marking_frame(rotation: &DMat3, dims: DVec3) -> (DMat3, DVec3) {
    let (x, y, z) = (rotation.x_axis, rotation.y_axis, rotation.z_axis);
    let (n, fwd, ext) = if x.z.abs() >= std::f64::consts::FRAC_1_SQRT_2 {
        (x * x.z.signum(), z, DVec3::new(dims.z, dims.y, dims.x))
    } else {
        (
            z * if z.z < 0.0 { -1.0 } else { 1.0 },
            x,
            DVec3::new(dims.x, dims.y, dims.z),
        )
    };
    let n = n.normalize();
    let mut f = (fwd - n * n.dot(fwd)).normalize_or_zero();
    if f == DVec3::ZERO {
        f = y.cross(n).normalize();
    }
    let fwd = f;
    let left = n.cross(fwd);
    // Columns: forward, left, normal (a right-handed frame: forward × left = normal).
    (DMat3::from_cols(fwd, left, n), ext)
}

/// Build the geometry and records of `gt`'s traffic signs, traffic lights and road markings.
pub(crate) fn build(gt: &osi3::GroundTruth, s: &TrafficSettings<'_>) -> TrafficBuild {
    let mut out = TrafficBuild::default();
    signs(gt, s, &mut out);
    lights(gt, s, &mut out);
    markings(gt, s, &mut out);
    out
}

fn signs(gt: &osi3::GroundTruth, s: &TrafficSettings<'_>, out: &mut TrafficBuild) {
    for sign in &gt.traffic_sign {
        let id = object_id(sign.id.as_ref());
        let Some(main) = sign.main_sign.as_ref() else {
            out.warnings
                .push(format!("traffic sign {id}: no main_sign; skipped"));
            continue;
        };
        let ty = main.classification.as_ref().and_then(|c| c.r#type);
        let Some(main_plate) = main.base.as_ref().and_then(|b| {
            plate(
                b,
                sign_shape(ty),
                sheeting_material(s.sheeting, sign_colour(ty)),
                None,
            )
        }) else {
            out.warnings.push(format!(
                "traffic sign {id}: main_sign without base.position; skipped"
            ));
            continue;
        };
        let mut plates = vec![main_plate];
        for (k, sup) in sign.supplementary_sign.iter().enumerate() {
            match sup.base.as_ref().and_then(|b| {
                plate(
                    b,
                    SignShape::Rectangle,
                    sheeting_material(s.sheeting, SignColour::White),
                    Some(k),
                )
            }) {
                Some(p) => plates.push(p),
                None => out.warnings.push(format!(
                    "traffic sign {id}: supplementary_sign[{k}] without base.position; skipped"
                )),
            }
        }
        for p in &plates {
            out.pieces.push(TrafficPiece {
                mesh: sign_plate(
                    p.shape,
                    p.width_m,
                    p.height_m,
                    p.thickness_m,
                    &p.face_material,
                ),
                pose: p.pose,
                element: StaticElement::TrafficSign(id),
            });
        }
        let mut post = None;
        if s.sign_posts {
            let m = &plates[0];
            let r = 0.5 * s.post_diameter_m;
            let axis = m
                .pose
                .transform_point(DVec3::new(-0.5 * m.thickness_m - r, 0.0, 0.0));
            let top = plates
                .iter()
                .map(|p| p.pose.position.z)
                .fold(f64::NEG_INFINITY, f64::max);
            let bottom = (s.ground_z)(axis);
            if top - bottom >= 0.1 {
                let base = DVec3::new(axis.x, axis.y, bottom);
                out.pieces.push(TrafficPiece {
                    mesh: sign_post(
                        DVec3::ZERO,
                        DVec3::new(0.0, 0.0, top - bottom),
                        s.post_diameter_m,
                    ),
                    pose: Pose::new(base, DMat3::IDENTITY),
                    element: StaticElement::SignPost(id),
                });
                post = Some((
                    base - s.origin,
                    DVec3::new(axis.x, axis.y, top) - s.origin,
                    s.post_diameter_m,
                ));
            }
        }
        out.signs.push(SceneTrafficSign {
            id,
            plates: plates
                .into_iter()
                .map(|mut p| {
                    p.pose.position -= s.origin;
                    p
                })
                .collect(),
            post,
        });
    }
}

fn lights(gt: &osi3::GroundTruth, s: &TrafficSettings<'_>, out: &mut TrafficBuild) {
    // (id, global pose, diameter, colour)
    let mut bulbs: Vec<(u64, Pose, f64, SignalColour)> = Vec::new();
    for tl in &gt.traffic_light {
        let id = object_id(tl.id.as_ref());
        let Some(base) = tl.base.as_ref() else {
            out.warnings
                .push(format!("traffic light {id}: no base; skipped"));
            continue;
        };
        let Some(pose) = base_pose(base) else {
            out.warnings
                .push(format!("traffic light {id}: no base.position; skipped"));
            continue;
        };
        let d = base.dimension.as_ref();
        let diameter = match (
            positive(d.and_then(|d| d.width)),
            positive(d.and_then(|d| d.height)),
        ) {
            (Some(w), Some(h)) => w.min(h),
            (Some(x), None) | (None, Some(x)) => x,
            (None, None) => DEFAULT_LENS_DIAMETER_M,
        };
        let colour = SignalColour::from_osi(tl.classification.as_ref().and_then(|c| c.color));
        bulbs.push((id, pose, diameter, colour));
    }
    // Housing groups: union-find over close, similarly aimed bulbs.
    let n = bulbs.len();
    let mut parent: Vec<usize> = (0..n).collect();
    fn find(p: &mut [usize], mut i: usize) -> usize {
        while p[i] != i {
            p[i] = p[p[i]];
            i = p[i];
        }
        i
    }
    let cos30 = 30f64.to_radians().cos();
    for i in 0..n {
        for j in i + 1..n {
            let (a, b) = (&bulbs[i].1, &bulbs[j].1);
            if a.position.distance(b.position) < HOUSING_MERGE_DISTANCE_M
                && a.rotation.x_axis.dot(b.rotation.x_axis) > cos30
            {
                let (ri, rj) = (find(&mut parent, i), find(&mut parent, j));
                if ri != rj {
                    parent[rj.max(ri)] = ri.min(rj);
                }
            }
        }
    }
    let mut group_of = vec![usize::MAX; n];
    let mut groups: Vec<Vec<usize>> = Vec::new();
    for i in 0..n {
        let r = find(&mut parent, i);
        if group_of[r] == usize::MAX {
            group_of[r] = groups.len();
            groups.push(Vec::new());
        }
        groups[group_of[r]].push(i);
    }
    for (g, members) in groups.iter().enumerate() {
        let frame = bulbs[members[0]].1;
        let first_id = bulbs[members[0]].0;
        let mut lo = DVec3::splat(f64::INFINITY);
        let mut hi = DVec3::splat(f64::NEG_INFINITY);
        for &i in members {
            let (_, pose, d, _) = &bulbs[i];
            let c = frame.inverse_transform_point(pose.position);
            let r = 0.5 * d + HOUSING_MARGIN_M;
            lo = lo.min(c - DVec3::new(0.0, r, r));
            hi = hi.max(c + DVec3::new(0.0, r, r));
        }
        let front = lo.x - LENS_GAP_M;
        out.pieces.push(TrafficPiece {
            mesh: signal_housing(
                DVec3::new(front - s.housing_depth_m, lo.y, lo.z),
                DVec3::new(front, hi.y, hi.z),
            ),
            pose: frame,
            element: StaticElement::SignalHousing(first_id),
        });
        for &i in members {
            let (id, pose, d, colour) = bulbs[i];
            out.pieces.push(TrafficPiece {
                mesh: signal_lens(d),
                pose,
                element: StaticElement::TrafficLight(id),
            });
            out.bulbs.push(SceneSignalBulb {
                id,
                centre: pose.position - s.origin,
                rotation: pose.rotation,
                diameter_m: d,
                colour,
                housing: g,
            });
        }
    }
}

fn markings(gt: &osi3::GroundTruth, s: &TrafficSettings<'_>, out: &mut TrafficBuild) {
    use osi3::road_marking::classification::Color as C;
    for rm in &gt.road_marking {
        let id = object_id(rm.id.as_ref());
        let Some(base) = rm.base.as_ref() else {
            out.warnings
                .push(format!("road marking {id}: no base; skipped"));
            continue;
        };
        let Some(pose) = base_pose(base) else {
            out.warnings
                .push(format!("road marking {id}: no base.position; skipped"));
            continue;
        };
        let d = base.dimension.as_ref();
        let dims = DVec3::new(
            positive(d.and_then(|d| d.length)).unwrap_or(0.0),
            positive(d.and_then(|d| d.width)).unwrap_or(0.0),
            positive(d.and_then(|d| d.height)).unwrap_or(0.0),
        );
        let (frame, ext) = marking_frame(&pose.rotation, dims);
        let mut poly: Vec<DVec2> = base
            .base_polygon
            .iter()
            .filter_map(|v| Some(DVec2::new(v.x?, v.y?)))
            .filter(|v| v.is_finite())
            .collect();
        poly.dedup_by(|a, b| a.distance(*b) < 1e-6);
        if poly.len() < 3 || polygon_area(&poly).abs() < 1e-8 {
            let (a, b) = (0.5 * ext.x, 0.5 * ext.y);
            poly = vec![
                DVec2::new(-a, -b),
                DVec2::new(a, -b),
                DVec2::new(a, b),
                DVec2::new(-a, b),
            ];
        }
        let area = polygon_area(&poly);
        if area.abs() < 1e-8 {
            out.warnings.push(format!(
                "road marking {id}: no base_polygon and no width / length; skipped"
            ));
            continue;
        }
        if area < 0.0 {
            poly.reverse();
        }
        let colour = rm
            .classification
            .as_ref()
            .and_then(|c| c.monochrome_color)
            .and_then(|c| C::try_from(c).ok());
        let paint = match colour {
            Some(C::Yellow | C::Orange) => "lane_paint_yellow",
            _ => "lane_paint_white",
        };
        let material = (s.paint)(paint);
        let lift = (0.5 * ext.z).max(s.marking_height_m);
        let mut m = Mesh::default();
        let part = m.part("road_marking", &material);
        let v: Vec<DVec3> = poly.iter().map(|q| DVec3::new(q.x, q.y, lift)).collect();
        for [i, j, k] in ear_clip(&poly) {
            m.push_triangle(v[i].as_vec3(), v[j].as_vec3(), v[k].as_vec3(), part);
        }
        let mpose = Pose::new(pose.position, frame);
        out.markings.push(SceneRoadMarking {
            id,
            outline: v
                .iter()
                .map(|&p| mpose.transform_point(p) - s.origin)
                .collect(),
            normal: frame.z_axis,
            area_m2: area.abs(),
            material: material.clone(),
        });
        out.pieces.push(TrafficPiece {
            mesh: m,
            pose: mpose,
            element: StaticElement::RoadMarking(id),
        });
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::frames::rotation_from_rpy;

    #[test]
    fn marking_frames() {
        // OSI convention: x up, z forward (yaw 30° in the road plane).
        let yaw = 30f64.to_radians();
        let fwd = DVec3::new(yaw.cos(), yaw.sin(), 0.0);
        let up = DVec3::Z;
        let r = DMat3::from_cols(up, fwd.cross(up), fwd);
        let (f, ext) = marking_frame(&r, DVec3::new(0.002, 0.5, 3.0));
        assert!(f.z_axis.distance(up) < 1e-12);
        assert!(f.x_axis.distance(fwd) < 1e-12);
        assert!(f.y_axis.distance(up.cross(fwd)) < 1e-12);
        assert_eq!(ext, DVec3::new(3.0, 0.5, 0.002));
        // A plain yaw: x forward, z up.
        let r = rotation_from_rpy(0.0, 0.0, yaw);
        let (f, ext) = marking_frame(&r, DVec3::new(3.0, 0.5, 0.002));
        assert!(f.z_axis.distance(up) < 1e-12);
        assert!(f.x_axis.distance(fwd) < 1e-12);
        assert_eq!(ext, DVec3::new(3.0, 0.5, 0.002));
    }

    #[test]
    fn shapes_and_colours_by_type() {
        use SignType as T;
        let t = |x: T| Some(x as i32);
        assert_eq!(sign_shape(t(T::SpeedLimitBegin)), SignShape::Circle);
        assert_eq!(sign_shape(t(T::DangerSpot)), SignShape::Triangle);
        assert_eq!(sign_shape(t(T::GiveWay)), SignShape::InvertedTriangle);
        assert_eq!(sign_shape(t(T::Stop)), SignShape::Octagon);
        assert_eq!(sign_shape(t(T::RightOfWayBegin)), SignShape::Diamond);
        assert_eq!(sign_shape(t(T::TownBegin)), SignShape::Rectangle);
        assert_eq!(sign_shape(None), SignShape::Rectangle);
        assert_eq!(sign_colour(t(T::Stop)), SignColour::Red);
        assert_eq!(sign_colour(t(T::PrescribedStraight)), SignColour::Blue);
        assert_eq!(sign_colour(t(T::SpeedLimitBegin)), SignColour::White);
        assert_eq!(
            sheeting_material(SheetingClass::Ra1, SignColour::Yellow),
            "sign_sheeting_ra1_yellow"
        );
    }
}
