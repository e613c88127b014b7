//! The scene from OSI: each `GroundTruth` becomes geometry the space-design layer traces.
//!
//! # What is built
//!
//! * **Static world** ([`Scene::static_world`], one [`SceneMesh`]): road surface, lane markings and
//!   every stationary object, already placed, in the local scene frame.
//!   * Road: for each lane, the strip between its left and right boundary polylines
//!     (`classification.left/right_lane_boundary_id`, the boundaries' `boundary_line[].position`,
//!     several ids are concatenated in order) is triangulated (both polylines resampled to at most
//!     [`SceneOptions::max_segment_m`], then zipped by normalised arc length; normals up). Lanes
//!     without both boundaries are skipped; when no lane yields a strip, a flat square road plane
//!     ([`SceneOptions::fallback_plane_half_size_m`]) at the host's wheel-contact height (else z = 0)
//!     is used instead. Material [`SceneOptions::road_material`] (`asphalt_dry`).
//!   * Lane markings: boundaries of type `SOLID_LINE` and `DASHED_LINE` (colour not `NONE`) get
//!     a flat strip centred on the boundary line, raised by [`SceneOptions::marking_height_m`] (1 mm),
//!     width `boundary_line[].width` (interpolated; absent or 0: [`SceneOptions::marking_width_m`],
//!     0.12 m = the German "Schmalstrich" on roads other than motorways, RMS-1). Dashed lines are
//!     painted from `DASH_START` to `DASH_END` points; without dash flags a pattern of
//!     [`SceneOptions::dash_length_m`] / [`SceneOptions::dash_gap_m`] (6 m / 12 m: the German motorway
//!     "Leitlinie", RMS-1; US MUTCD uses 10 ft / 30 ft) starting at the first point. Material
//!     [`SceneOptions::marking_material`] (`lane_paint_white`; yellow lines too).
//!     Road and markings are open surfaces (upward normals only).
//!   * Stationary objects: the mesh of their asset ([`super::assets`]; `model_reference`, else a
//!     default by classification type) sized to `base.dimension` and placed by `base.position` /
//!     `base.orientation`.
//!
//!   * Traffic signs, traffic lights and road markings (`GroundTruth.traffic_sign`, `traffic_light`,
//!     `road_marking`; [`super::traffic`]): a plate per main and supplementary sign (sheeting face,
//!     aluminium back) with a steel post, a lens disc per traffic-light bulb in a housing shared by
//!     neighbouring bulbs, a painted polygon per road marking. Their records are
//!     [`Scene::traffic_signs`], [`Scene::signal_bulbs`] and [`Scene::road_markings`].
//!
//!   [`Scene::static_owners`] says which triangles belong to which lane, boundary, object, sign,
//!   bulb or marking ([`Scene::static_element`] looks a triangle up).
//!
//! # Ground-truth ids of static triangles
//!
//! [`StaticElement::ground_truth_id`] is the id a sensor reports for a static triangle: the
//! stationary object's ([`StaticElement::Object`]), the OSI `TrafficSign`'s for its main and
//! supplementary plates ([`StaticElement::TrafficSign`]; supplementary signs have no id of their own),
//! the OSI `TrafficLight`'s (one bulb) for its lens ([`StaticElement::TrafficLight`]) and the
//! `RoadMarking`'s for its paint ([`StaticElement::RoadMarking`]). Road, lane markings, sign posts
//! ([`StaticElement::SignPost`]) and signal housings ([`StaticElement::SignalHousing`]) have none.
//! The camera's per-pixel object mask (`camera::RenderAux::object_ids` / `object_index`) and the
//! LiDAR's point ids use it, so a recognition finds a sign's, a bulb's or a marking's visible pixels
//! by its OSI id. The radar treats plates, posts, lenses and housings as stationary targets under the
//! sign's / (first) bulb's id and road markings as road.
//! * **Meshes** ([`Scene::meshes`]): one [`SceneMesh`] per distinct (asset reference, OSI dimension
//!   rounded to 1 mm) used by a moving object, in the object frame (origin = OSI box centre). 450
//!   identical cars share one mesh. Indices are stable for the scene's lifetime and new meshes are only
//!   appended ([`SceneUpdate::new_meshes`]), so a BLAS per mesh is built once.
//! * **Instances** ([`Scene::instances`]): one per moving object except the host (`host id`: the
//!   builder's, else `GroundTruth.host_vehicle_id`): object id, mesh index, pose (mesh frame → scene
//!   frame, f64) and the linear / angular velocity of the box centre ([`crate::frames::moving_object_twist`];
//!   a point `p` moves with `v + ω × (p − pose.position)`).
//!
//! # Scene frame
//!
//! All geometry is in a local frame with the global axes and its origin at [`Scene::origin`] (global
//! coordinates, m): `p_scene = p_global − origin`. The origin is chosen at build time
//! ([`SceneOptions::origin`], else the host position, else the first object or lane point, rounded to
//! [`SceneOptions::origin_grid_m`] = 100 m) so that f32 vertex coordinates stay precise (f32 has
//! 0.5 mm resolution at 4 km). When the host drives farther than [`SceneOptions::rebase_distance_m`]
//! from the origin, [`Scene::update`] moves the origin (and rebuilds the static world).
//!
//! # Materials
//!
//! Every mesh carries `part_material[part] = MaterialDb::resolve(part.material)`; the scene owns its
//! [`MaterialDb`] (parametric materials such as `lambertian_30` are created there on first use).
//! For triangle `t` of a mesh: `part_material[mesh.triangle_part[t]]` ([`SceneMesh::triangle_material`]).
//! Static-world parts are merged by (name, material), so two parts may share a name.
//!
//! # Updates
//!
//! [`Scene::update`] re-reads a new `GroundTruth`: instances (poses, velocities, added and removed
//! objects) every time; the static world only when lanes, lane boundaries, stationary objects,
//! traffic signs, traffic lights (id, base, colour: not their mode, so a light switching rebuilds
//! nothing), road markings or the wetness changed (a hash over them, [`Scene::static_revision`]
//! counts rebuilds) or the origin moved.
//!
//! # Model references
//!
//! A malformed `osiris:` reference is an error naming the object. A reference that is not an
//! `osiris:` one (e.g. a path from another tool) and cannot be used (unsupported format, missing file)
//! falls back to the default asset of the object's type with a warning ([`Scene::warnings`]), unless
//! [`SceneOptions::strict_references`].
//!
//! # Consuming the scene (space design)
//!
//! ```text
//! builder.add_static(&scene.static_world.mesh, &scene.static_world.part_material)
//! for m in &scene.meshes { handles.push(builder.add_mesh(&m.mesh, &m.part_material)) }
//! instances: InstanceDesc { object_id: i.object_id, mesh: handles[i.mesh], pose: i.pose_local,
//!                           linear_velocity: i.velocity_m_s, angular_velocity: i.angular_velocity_rad_s }
//! ```

use std::collections::{HashMap, HashSet};
use std::hash::{Hash, Hasher};
use std::ops::Range;
use std::path::PathBuf;
use std::sync::Arc;

use glam::DVec3;
use osiris_proto::{INVALID_ID, osi3};
use prost::Message as _;

use super::assets::{
    AssetContext, AssetError, AssetKind, AssetRef, build_asset_with, phase_centre,
};
use super::material::{MaterialDb, MaterialError, MaterialId};
use super::mesh::{Mesh, Part};
use super::traffic::{
    SceneRoadMarking, SceneSignalBulb, SceneTrafficSign, SheetingClass, TrafficSettings,
};
use crate::frames::{
    Pose, moving_object_pose, moving_object_twist, stationary_object_pose, vec3_from_osi,
};

/// Errors of scene construction.
#[derive(Debug, thiserror::Error)]
pub enum SceneError {
    #[error("{object}: model_reference `{reference}`: {source}")]
    Asset {
        object: String,
        reference: String,
        #[source]
        source: Box<AssetError>,
    },
    #[error("mesh `{mesh}`, part `{part}`: {source}")]
    Material {
        mesh: String,
        part: String,
        #[source]
        source: Box<MaterialError>,
    },
    #[error("scene option `{name}`: {message}")]
    Option { name: &'static str, message: String },
}

/// Options of scene construction.
#[derive(Debug, Clone, PartialEq)]
pub struct SceneOptions {
    /// Fixed scene origin (global, m); `None`: chosen from the ground truth (see the module docs).
    pub origin: Option<DVec3>,
    /// Grid the automatic origin is rounded to, m (0: not rounded).
    pub origin_grid_m: f64,
    /// Host distance from the origin above which [`Scene::update`] moves the origin, m.
    pub rebase_distance_m: f64,
    pub road_material: String,
    pub marking_material: String,
    /// On a wet road use the `_wet` variants of the road and marking materials
    /// (`asphalt_dry` → `asphalt_wet`, `x` → `x_wet`) where the database has them.
    pub use_wet_materials: bool,
    /// The road state when the ground truth is not to decide it (the sensor's configured weather,
    /// `env.wet_road` off): `Some(wet)`; `None`: wet as the ground truth says ([`Scene::wet`]).
    pub road_wet: Option<bool>,
    /// Marking width where the boundary points carry none, m.
    pub marking_width_m: f64,
    /// Height of markings above the road surface, m.
    pub marking_height_m: f64,
    /// Dash and gap length of dashed lines without dash flags, m.
    pub dash_length_m: f64,
    pub dash_gap_m: f64,
    /// Longest road / marking triangle edge along the road, m.
    pub max_segment_m: f64,
    /// Half size of the fallback road plane, m.
    pub fallback_plane_half_size_m: f64,
    /// Directory relative user-mesh paths are resolved against.
    pub asset_dir: Option<PathBuf>,
    /// Treat unusable non-`osiris:` model references as errors instead of falling back.
    pub strict_references: bool,
    /// Retroreflective sheeting class of traffic-sign faces (EN 12899-1; default RA2).
    pub sign_sheeting: SheetingClass,
    /// Give traffic signs a post from the road up to their plates.
    pub sign_posts: bool,
    /// Outer diameter of sign posts, m (**guessed**: the 60.3 mm steel tube common for sign posts).
    pub sign_post_diameter_m: f64,
    /// Depth of traffic-signal housings behind the lenses, m (**guessed**).
    pub signal_housing_depth_m: f64,
}

impl Default for SceneOptions {
    fn default() -> Self {
        SceneOptions {
            origin: None,
            origin_grid_m: 100.0,
            rebase_distance_m: 4000.0,
            road_material: "asphalt_dry".into(),
            marking_material: "lane_paint_white".into(),
            use_wet_materials: false,
            road_wet: None,
            marking_width_m: 0.12,
            marking_height_m: 0.001,
            dash_length_m: 6.0,
            dash_gap_m: 12.0,
            max_segment_m: 10.0,
            fallback_plane_half_size_m: 500.0,
            asset_dir: None,
            strict_references: false,
            sign_sheeting: SheetingClass::Ra2,
            sign_posts: true,
            sign_post_diameter_m: 0.0603,
            signal_housing_depth_m: 0.25,
        }
    }
}

/// A mesh with the material of each of its parts.
#[derive(Debug, Clone, PartialEq)]
pub struct SceneMesh {
    /// What it is: the canonical asset reference and OSI dimension, or "static world".
    pub key: String,
    pub mesh: Mesh,
    /// `part_material[p]` is the material of `mesh.parts[p]`.
    pub part_material: Vec<MaterialId>,
    /// The asset's phase centre in the mesh (object) frame, where it has a fixed one
    /// ([`super::assets::phase_centre`]: a trihedral's apex, a board's face centre).
    pub phase_centre: Option<DVec3>,
}

impl SceneMesh {
    /// Material of triangle `t`.
    pub fn triangle_material(&self, t: usize) -> MaterialId {
        self.part_material[self.mesh.triangle_part[t] as usize]
    }
}

/// A moving object placed in the scene.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SceneInstance {
    /// Ground-truth id (`INVALID_ID` = u64::MAX when the object has none).
    pub object_id: u64,
    /// Index into [`Scene::meshes`].
    pub mesh: usize,
    /// Mesh (object) frame → scene frame: `p_scene = position + rotation · p_mesh`.
    pub pose_local: Pose,
    /// Velocity of the box centre (`pose_local.position`), m/s, global = scene axes.
    pub velocity_m_s: DVec3,
    /// Angular velocity, rad/s, global = scene axes.
    pub angular_velocity_rad_s: DVec3,
}

/// What a range of static-world triangles is.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum StaticElement {
    /// Road surface of the lane with this id.
    Lane(u64),
    /// The fallback road plane.
    RoadPlane,
    /// Marking of the lane boundary with this id.
    Marking(u64),
    /// Stationary object with this id (`INVALID_ID` when it has none).
    Object(u64),
    /// A plate (face, back, rim) of the OSI `TrafficSign` with this id: its main sign or one of its
    /// supplementary signs (which have no id of their own).
    TrafficSign(u64),
    /// The post of the traffic sign with this id (not part of the sign's OSI box).
    SignPost(u64),
    /// The lens of the OSI `TrafficLight` (one bulb) with this id.
    TrafficLight(u64),
    /// A traffic-signal housing; the id is that of the first bulb it holds.
    SignalHousing(u64),
    /// The painted area of the OSI `RoadMarking` with this id.
    RoadMarking(u64),
}

impl StaticElement {
    /// The ground-truth id the sensors report for this element (the camera's object mask, LiDAR
    /// points): stationary objects, traffic-sign plates, traffic-light lenses and road markings;
    /// `None` for road, lane markings, sign posts, signal housings and elements without an id.
    pub fn ground_truth_id(self) -> Option<u64> {
        match self {
            StaticElement::Object(id)
            | StaticElement::TrafficSign(id)
            | StaticElement::TrafficLight(id)
            | StaticElement::RoadMarking(id)
                if id != INVALID_ID =>
            {
                Some(id)
            }
            _ => None,
        }
    }
}

/// Static-world triangles `first_triangle .. first_triangle + triangle_count` belong to `element`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct StaticOwner {
    pub first_triangle: u32,
    pub triangle_count: u32,
    pub element: StaticElement,
}

/// What [`Scene::update`] changed.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct SceneUpdate {
    /// The static world was rebuilt (lanes, boundaries, stationary objects or wetness changed, or the
    /// origin moved).
    pub static_rebuilt: bool,
    /// The origin moved (all instance poses and the static world changed).
    pub rebased: bool,
    /// Indices of meshes added to [`Scene::meshes`].
    pub new_meshes: Range<usize>,
    /// Object ids that got an instance / lost theirs.
    pub added: Vec<u64>,
    pub removed: Vec<u64>,
}

/// Builds a [`Scene`] from a ground truth.
#[derive(Debug, Clone)]
pub struct SceneBuilder {
    materials: MaterialDb,
    host_id: Option<u64>,
    options: SceneOptions,
}

impl SceneBuilder {
    /// A builder resolving materials in `materials` (usually [`MaterialDb::builtin`]).
    pub fn new(materials: MaterialDb) -> SceneBuilder {
        SceneBuilder {
            materials,
            host_id: None,
            options: SceneOptions::default(),
        }
    }

    /// The host vehicle's id (excluded from the instances); default: `GroundTruth.host_vehicle_id`.
    pub fn host_id(mut self, id: Option<u64>) -> SceneBuilder {
        self.host_id = id;
        self
    }

    pub fn options(mut self, options: SceneOptions) -> SceneBuilder {
        self.options = options;
        self
    }

    /// Build the scene of `gt`.
    pub fn build(self, gt: &osi3::GroundTruth) -> Result<Scene, SceneError> {
        check_options(&self.options)?;
        let host_id = self.host_id.or_else(|| gt_host_id(gt));
        let origin = match self.options.origin {
            Some(o) => o,
            None => round_to_grid(initial_origin(gt, host_id), self.options.origin_grid_m),
        };
        let mut scene = Scene {
            origin,
            static_world: SceneMesh {
                key: "static world".into(),
                mesh: Mesh::default(),
                part_material: Vec::new(),
                phase_centre: None,
            },
            static_owners: Vec::new(),
            static_phase_centres: Vec::new(),
            traffic_signs: Vec::new(),
            signal_bulbs: Vec::new(),
            road_markings: Vec::new(),
            meshes: Vec::new(),
            instances: Vec::new(),
            materials: self.materials,
            wet: road_wet(&self.options, gt),
            host_id,
            static_revision: 0,
            warnings: Vec::new(),
            options: self.options,
            host_override: self.host_id,
            mesh_index: HashMap::new(),
            cache: HashMap::new(),
            static_signature: 0,
        };
        scene.rebuild_static(gt)?;
        let mut report = SceneUpdate::default();
        scene.update_instances(gt, &mut report)?;
        Ok(scene)
    }
}

/// The scene of one ground truth (see the module documentation).
#[derive(Debug, Clone)]
pub struct Scene {
    /// Global position of the scene frame's origin, m.
    pub origin: DVec3,
    /// Road, markings and stationary objects, scene frame.
    pub static_world: SceneMesh,
    /// Which static-world triangles belong to which lane, boundary or object (sorted).
    pub static_owners: Vec<StaticOwner>,
    /// Phase centres (scene frame) of the stationary objects whose asset has one, by object id.
    pub static_phase_centres: Vec<(u64, DVec3)>,
    /// The traffic signs of the static world (plates, post), scene frame.
    pub traffic_signs: Vec<SceneTrafficSign>,
    /// The traffic-light bulbs of the static world (lens centre, axis, size, colour), scene frame.
    pub signal_bulbs: Vec<SceneSignalBulb>,
    /// The road markings of the static world (painted outline), scene frame.
    pub road_markings: Vec<SceneRoadMarking>,
    /// Meshes of the moving objects (object frame); instances refer to them by index.
    pub meshes: Vec<Arc<SceneMesh>>,
    /// Moving objects except the host.
    pub instances: Vec<SceneInstance>,
    /// The materials the part materials index.
    pub materials: MaterialDb,
    /// Whether the road is wet: [`SceneOptions::road_wet`] if set, else from the ground truth (a lane
    /// with `road_condition.surface_water_film > 0`, or precipitation: any
    /// `EnvironmentalConditions.precipitation` from `VERY_LIGHT` on).
    pub wet: bool,
    /// Host vehicle id in effect.
    pub host_id: Option<u64>,
    /// Number of static-world builds so far (1 after [`SceneBuilder::build`]).
    pub static_revision: u64,
    /// Problems of the last build / update that did not stop it (e.g. unusable foreign references).
    pub warnings: Vec<String>,
    options: SceneOptions,
    host_override: Option<u64>,
    /// Instance mesh key → index into `meshes`.
    mesh_index: HashMap<String, usize>,
    /// Every mesh built so far (moving and stationary), by key.
    cache: HashMap<String, Arc<SceneMesh>>,
    static_signature: u64,
}

fn check_options(o: &SceneOptions) -> Result<(), SceneError> {
    let bad = |name: &'static str, v: f64, what: &str| SceneError::Option {
        name,
        message: format!("must be {what}, got {v}"),
    };
    for (name, v) in [
        ("marking_width_m", o.marking_width_m),
        ("dash_length_m", o.dash_length_m),
        ("dash_gap_m", o.dash_gap_m),
        ("max_segment_m", o.max_segment_m),
        ("fallback_plane_half_size_m", o.fallback_plane_half_size_m),
        ("rebase_distance_m", o.rebase_distance_m),
        ("sign_post_diameter_m", o.sign_post_diameter_m),
        ("signal_housing_depth_m", o.signal_housing_depth_m),
    ] {
        if !(v.is_finite() && v > 0.0) {
            return Err(bad(name, v, "a finite number > 0"));
        }
    }
    for (name, v) in [
        ("marking_height_m", o.marking_height_m),
        ("origin_grid_m", o.origin_grid_m),
    ] {
        if !(v.is_finite() && v >= 0.0) {
            return Err(bad(name, v, "a finite number ≥ 0"));
        }
    }
    if o.origin.is_some_and(|p| !p.is_finite()) {
        return Err(SceneError::Option {
            name: "origin",
            message: "must be finite".into(),
        });
    }
    Ok(())
}

fn gt_host_id(gt: &osi3::GroundTruth) -> Option<u64> {
    gt.host_vehicle_id.as_ref().and_then(|i| i.value)
}

fn object_id(id: Option<&osi3::Identifier>) -> u64 {
    id.and_then(|i| i.value).unwrap_or(INVALID_ID)
}

fn host_object(gt: &osi3::GroundTruth, host: Option<u64>) -> Option<&osi3::MovingObject> {
    let h = host?;
    gt.moving_object
        .iter()
        .find(|o| object_id(o.id.as_ref()) == h)
}

/// Height (global z) of the fallback road plane of a ground truth without lane strips: the host's
/// wheel-contact height (its box centre less half its height), z = 0 without a host.
pub fn fallback_plane_z(host: Option<&osi3::MovingObject>) -> f64 {
    host.map_or(0.0, |h| {
        let height = h
            .base
            .as_ref()
            .and_then(|b| b.dimension.as_ref())
            .and_then(|d| d.height)
            .unwrap_or(0.0);
        moving_object_pose(h).position.z - 0.5 * height
    })
}

fn initial_origin(gt: &osi3::GroundTruth, host: Option<u64>) -> DVec3 {
    if let Some(h) = host_object(gt, host) {
        return moving_object_pose(h).position;
    }
    if let Some(o) = gt.moving_object.first() {
        return moving_object_pose(o).position;
    }
    if let Some(o) = gt.stationary_object.first() {
        return stationary_object_pose(o).position;
    }
    gt.lane_boundary
        .iter()
        .flat_map(|b| b.boundary_line.iter())
        .find_map(|p| p.position.as_ref())
        .map_or(DVec3::ZERO, |p| vec3_from_osi(Some(p)))
}

fn round_to_grid(p: DVec3, grid: f64) -> DVec3 {
    if grid > 0.0 {
        (p / grid).round() * grid
    } else {
        p
    }
}

/// The road state of `gt` under `options` (see [`Scene::wet`]).
fn road_wet(options: &SceneOptions, gt: &osi3::GroundTruth) -> bool {
    options.road_wet.unwrap_or_else(|| is_wet(gt))
}

fn is_wet(gt: &osi3::GroundTruth) -> bool {
    use osi3::environmental_conditions::Precipitation as P;
    let film = gt.lane.iter().any(|l| {
        l.classification
            .as_ref()
            .and_then(|c| c.road_condition.as_ref())
            .and_then(|r| r.surface_water_film)
            .is_some_and(|f| f > 0.0)
    });
    let rain = gt
        .environmental_conditions
        .as_ref()
        .and_then(|e| e.precipitation)
        .and_then(|p| P::try_from(p).ok())
        .is_some_and(|p| !matches!(p, P::Unknown | P::Other | P::None));
    film || rain
}

/// OSI dimension as a vector rounded to 1 mm (absent components 0 = asset default).
fn osi_dims(d: Option<&osi3::Dimension3d>) -> Option<DVec3> {
    let d = d?;
    let q = |v: Option<f64>| {
        v.filter(|x| x.is_finite())
            .map_or(0.0, |x| (x * 1000.0).round() / 1000.0)
    };
    Some(DVec3::new(q(d.length), q(d.width), q(d.height)))
}

/// Default asset of a moving object without a usable model reference.
pub fn default_moving_asset(obj: &osi3::MovingObject) -> AssetRef {
    use osi3::moving_object::Type;
    use osi3::moving_object::vehicle_classification::Type as V;
    let kind = match obj.r#type.and_then(|t| Type::try_from(t).ok()) {
        Some(Type::Pedestrian) => AssetKind::Pedestrian,
        Some(Type::Vehicle) => {
            match obj
                .vehicle_classification
                .as_ref()
                .and_then(|c| c.r#type)
                .and_then(|t| V::try_from(t).ok())
            {
                Some(V::Bicycle) => AssetKind::Cyclist,
                Some(V::Motorbike) => AssetKind::Motorcycle,
                Some(V::DeliveryVan) => AssetKind::Van,
                Some(V::Bus) => AssetKind::Bus,
                Some(
                    V::HeavyTruck | V::Semitractor | V::Semitrailer | V::Trailer | V::WorkMachine,
                ) => AssetKind::Truck,
                Some(
                    V::StandupScooter | V::MicromobilityDevice | V::Wheelchair | V::Train | V::Tram,
                ) => AssetKind::Box,
                _ => AssetKind::Car,
            }
        }
        _ => AssetKind::Box,
    };
    AssetRef::builtin(kind)
}

/// Default asset of a stationary object without a usable model reference: by classification type
/// (barrier → guardrail, pole/delineator → pole, pylon → cone), else a box of the classification's
/// material (metal → steel, concrete/stone → concrete, wood, glass, plastic → plastic_black, else
/// lambertian_50).
pub fn default_stationary_asset(obj: &osi3::StationaryObject) -> AssetRef {
    use osi3::stationary_object::classification::{Material as M, Type as T};
    let c = obj.classification.as_ref();
    match c.and_then(|c| c.r#type).and_then(|t| T::try_from(t).ok()) {
        Some(T::Barrier) => return AssetRef::builtin(AssetKind::Guardrail),
        Some(T::Pole | T::Delineator) => return AssetRef::builtin(AssetKind::Pole),
        Some(T::Pylon) => return AssetRef::builtin(AssetKind::Cone),
        _ => {}
    }
    let material = match c.and_then(|c| c.material).and_then(|m| M::try_from(m).ok()) {
        Some(M::Metal) => "steel",
        Some(M::Concrete | M::Stone) => "concrete",
        Some(M::Wood) => "wood",
        Some(M::Glass) => "glass",
        Some(M::Plastic) => "plastic_black",
        _ => "lambertian_50",
    };
    AssetRef::builtin(AssetKind::Box)
        .with("material", material)
        .unwrap_or_else(|_| AssetRef::builtin(AssetKind::Box))
}

/// Hash of everything the static world is built from.
fn static_signature(gt: &osi3::GroundTruth, wet_materials: bool) -> u64 {
    // `wet_materials`: the road uses its wet variants.
    let mut h = std::collections::hash_map::DefaultHasher::new();
    for l in &gt.lane {
        object_id(l.id.as_ref()).hash(&mut h);
        if let Some(c) = &l.classification {
            c.r#type.hash(&mut h);
            for ids in [&c.left_lane_boundary_id, &c.right_lane_boundary_id] {
                ids.len().hash(&mut h);
                for i in ids {
                    i.value.hash(&mut h);
                }
            }
        }
    }
    for b in &gt.lane_boundary {
        b.encode_to_vec().hash(&mut h);
    }
    for s in &gt.stationary_object {
        let key = osi3::StationaryObject {
            id: s.id,
            base: s.base.clone(),
            model_reference: s.model_reference.clone(),
            classification: s.classification.as_ref().map(|c| {
                osi3::stationary_object::Classification {
                    r#type: c.r#type,
                    material: c.material,
                    ..Default::default()
                }
            }),
            ..Default::default()
        };
        key.encode_to_vec().hash(&mut h);
    }
    // Traffic signs (all of the message: type and size decide the plates), traffic lights (not their
    // mode or counter: switching a light does not change the geometry), road markings.
    for s in &gt.traffic_sign {
        s.encode_to_vec().hash(&mut h);
    }
    for l in &gt.traffic_light {
        let key = osi3::TrafficLight {
            id: l.id,
            base: l.base.clone(),
            classification: l.classification.as_ref().map(|c| {
                osi3::traffic_light::Classification {
                    color: c.color,
                    ..Default::default()
                }
            }),
            ..Default::default()
        };
        key.encode_to_vec().hash(&mut h);
    }
    for m in &gt.road_marking {
        let key = osi3::RoadMarking {
            id: m.id,
            base: m.base.clone(),
            classification: m
                .classification
                .as_ref()
                .map(|c| osi3::road_marking::Classification {
                    r#type: c.r#type,
                    monochrome_color: c.monochrome_color,
                    ..Default::default()
                }),
            ..Default::default()
        };
        key.encode_to_vec().hash(&mut h);
    }
    wet_materials.hash(&mut h);
    h.finish()
}

// ---------------------------------------------------------------------------------------------------
// Polylines

/// Points (global) of a boundary line with widths; consecutive duplicates (< 1 mm) removed.
fn boundary_points(b: &osi3::LaneBoundary) -> Vec<(DVec3, f64, Option<i32>)> {
    let mut out: Vec<(DVec3, f64, Option<i32>)> = Vec::with_capacity(b.boundary_line.len());
    for p in &b.boundary_line {
        let Some(pos) = p.position.as_ref() else {
            continue;
        };
        let q = vec3_from_osi(Some(pos));
        if !q.is_finite() {
            continue;
        }
        let w = p.width.filter(|w| w.is_finite() && *w > 0.0).unwrap_or(0.0);
        if let Some(last) = out.last_mut()
            && last.0.distance(q) < 1e-3
        {
            // Keep the later dash flag (e.g. an END that coincides with a START is a zero gap).
            last.2 = p.dash.or(last.2);
            continue;
        }
        out.push((q, w, p.dash));
    }
    out
}

/// Cumulative arc length of a polyline.
fn arc_lengths(p: &[DVec3]) -> Vec<f64> {
    let mut s = Vec::with_capacity(p.len());
    let mut acc = 0.0;
    for (i, q) in p.iter().enumerate() {
        if i > 0 {
            acc += q.distance(p[i - 1]);
        }
        s.push(acc);
    }
    s
}

/// Insert points so that no segment is longer than `max`.
fn resample(p: &[DVec3], max: f64) -> Vec<DVec3> {
    let mut out = Vec::with_capacity(p.len());
    for (i, &q) in p.iter().enumerate() {
        if i > 0 {
            let a = p[i - 1];
            let n = (a.distance(q) / max).ceil() as usize;
            for k in 1..n {
                out.push(a.lerp(q, k as f64 / n as f64));
            }
        }
        out.push(q);
    }
    out
}

/// Concatenated boundary polyline of a lane side.
fn lane_side(
    ids: &[osi3::Identifier],
    boundaries: &HashMap<u64, &osi3::LaneBoundary>,
) -> Vec<DVec3> {
    let mut out: Vec<DVec3> = Vec::new();
    for id in ids {
        let Some(b) = id.value.and_then(|v| boundaries.get(&v)) else {
            continue;
        };
        for (p, _, _) in boundary_points(b) {
            if out.last().is_none_or(|l| l.distance(p) >= 1e-3) {
                out.push(p);
            }
        }
    }
    out
}

// ---------------------------------------------------------------------------------------------------
// Static world accumulation

struct StaticBuild {
    origin: DVec3,
    mesh: Mesh,
    parts: HashMap<(String, String), u16>,
    owners: Vec<StaticOwner>,
}

impl StaticBuild {
    fn part(&mut self, name: &str, material: &str) -> u16 {
        let key = (name.to_string(), material.to_string());
        if let Some(&p) = self.parts.get(&key) {
            return p;
        }
        self.mesh.parts.push(Part {
            name: name.into(),
            material: material.into(),
        });
        let p = (self.mesh.parts.len() - 1) as u16;
        self.parts.insert(key, p);
        p
    }

    /// Vertex from a global position.
    fn vertex(&mut self, global: DVec3) -> u32 {
        self.mesh.positions.push((global - self.origin).as_vec3());
        (self.mesh.positions.len() - 1) as u32
    }

    fn tri(&mut self, t: [u32; 3], part: u16) {
        self.mesh.triangles.push(t);
        self.mesh.triangle_part.push(part);
    }

    fn own(&mut self, first: usize, element: StaticElement) {
        let n = self.mesh.triangles.len() - first;
        if n > 0 {
            self.owners.push(StaticOwner {
                first_triangle: first as u32,
                triangle_count: n as u32,
                element,
            });
        }
    }

    /// Upward triangle between global points (skipped when degenerate).
    fn up_triangle(&mut self, idx: [u32; 3], pts: [DVec3; 3], part: u16) {
        let n = (pts[1] - pts[0]).cross(pts[2] - pts[0]);
        if n.length() < 1e-9 {
            return;
        }
        if n.z >= 0.0 {
            self.tri(idx, part)
        } else {
            self.tri([idx[0], idx[2], idx[1]], part)
        }
    }

    /// Triangulate the strip between two polylines (global), normals up.
    fn strip(&mut self, left: &[DVec3], right: &[DVec3], part: u16) {
        let mut right = right.to_vec();
        let (l0, ln) = (left[0], left[left.len() - 1]);
        let (r0, rn) = (right[0], right[right.len() - 1]);
        if l0.distance(rn) + ln.distance(r0) < l0.distance(r0) + ln.distance(rn) {
            right.reverse();
        }
        let tl = arc_lengths(left);
        let tr = arc_lengths(&right);
        let (ll, lr) = (tl[tl.len() - 1].max(1e-12), tr[tr.len() - 1].max(1e-12));
        let il: Vec<u32> = left.iter().map(|&p| self.vertex(p)).collect();
        let ir: Vec<u32> = right.iter().map(|&p| self.vertex(p)).collect();
        let (mut i, mut j) = (0, 0);
        while i + 1 < left.len() || j + 1 < right.len() {
            let advance_left = if i + 1 >= left.len() {
                false
            } else if j + 1 >= right.len() {
                true
            } else {
                tl[i + 1] / ll <= tr[j + 1] / lr
            };
            if advance_left {
                self.up_triangle(
                    [il[i], ir[j], il[i + 1]],
                    [left[i], right[j], left[i + 1]],
                    part,
                );
                i += 1;
            } else {
                self.up_triangle(
                    [il[i], ir[j], ir[j + 1]],
                    [left[i], right[j], right[j + 1]],
                    part,
                );
                j += 1;
            }
        }
    }

    /// A flat strip of width `w(s)` along the polyline `pts` (global), raised by `h`.
    fn paint(&mut self, pts: &[DVec3], widths: &[f64], h: f64, part: u16) {
        let n = pts.len();
        if n < 2 {
            return;
        }
        let mut left = Vec::with_capacity(n);
        let mut right = Vec::with_capacity(n);
        for i in 0..n {
            let t = pts[(i + 1).min(n - 1)] - pts[i.saturating_sub(1)];
            let side = DVec3::Z.cross(t).normalize_or_zero();
            if side == DVec3::ZERO {
                return;
            }
            let up = DVec3::Z * h;
            left.push(self.vertex(pts[i] + side * (0.5 * widths[i]) + up));
            right.push(self.vertex(pts[i] - side * (0.5 * widths[i]) + up));
        }
        for i in 0..n - 1 {
            // right_i, right_i+1, left_i+1 / left_i: counter-clockwise seen from above.
            self.tri([right[i], right[i + 1], left[i + 1]], part);
            self.tri([right[i], left[i + 1], left[i]], part);
        }
    }

    /// Append a mesh placed by `pose` (object → global).
    fn place(&mut self, m: &Mesh, pose: &Pose, element: StaticElement) {
        let first = self.mesh.triangles.len();
        let base = self.mesh.positions.len() as u32;
        for p in &m.positions {
            let g = pose.transform_point(p.as_dvec3());
            self.mesh.positions.push((g - self.origin).as_vec3());
        }
        let remap: Vec<u16> = m
            .parts
            .iter()
            .map(|p| self.part(&p.name, &p.material))
            .collect();
        for (t, &p) in m.triangles.iter().zip(&m.triangle_part) {
            self.tri(t.map(|i| i + base), remap[p as usize]);
        }
        self.own(first, element);
    }
}

/// Painted intervals (arc length) of a boundary line.
fn painted_intervals(
    pts: &[(DVec3, f64, Option<i32>)],
    s: &[f64],
    dashed: bool,
    dash: f64,
    gap: f64,
) -> Vec<(f64, f64)> {
    use osi3::lane_boundary::boundary_point::Dash as D;
    let total = s[s.len() - 1];
    if !dashed {
        return vec![(0.0, total)];
    }
    let flags: Vec<Option<D>> = pts
        .iter()
        .map(|p| p.2.and_then(|d| D::try_from(d).ok()))
        .collect();
    let has_flags = flags
        .iter()
        .any(|f| matches!(f, Some(D::Start | D::Continue | D::End | D::Gap)));
    let mut out = Vec::new();
    if has_flags {
        let mut open: Option<f64> = None;
        for (i, f) in flags.iter().enumerate() {
            match f {
                Some(D::Start) => {
                    if let Some(a) = open.take() {
                        out.push((a, s[i]));
                    }
                    open = Some(s[i]);
                }
                Some(D::Continue) => {
                    open.get_or_insert(s[i]);
                }
                Some(D::End) => {
                    if let Some(a) = open.take() {
                        out.push((a, s[i]));
                    }
                }
                Some(D::Gap) => {
                    open = None;
                }
                _ => {}
            }
        }
        if let Some(a) = open {
            out.push((a, total));
        }
    } else {
        let mut a = 0.0;
        while a < total {
            out.push((a, (a + dash).min(total)));
            a += dash + gap;
        }
    }
    out.retain(|(a, b)| b > a);
    out
}

/// The sub-polyline between arc lengths `a..b` with interpolated widths.
fn sub_polyline(
    pts: &[(DVec3, f64, Option<i32>)],
    s: &[f64],
    a: f64,
    b: f64,
    default_w: f64,
) -> (Vec<DVec3>, Vec<f64>) {
    let w = |i: usize| if pts[i].1 > 0.0 { pts[i].1 } else { default_w };
    let at = |x: f64| -> (DVec3, f64) {
        let i = s.partition_point(|&v| v <= x).clamp(1, s.len() - 1);
        let (s0, s1) = (s[i - 1], s[i]);
        let t = if s1 > s0 {
            ((x - s0) / (s1 - s0)).clamp(0.0, 1.0)
        } else {
            0.0
        };
        (
            pts[i - 1].0.lerp(pts[i].0, t),
            w(i - 1) + (w(i) - w(i - 1)) * t,
        )
    };
    let mut p = Vec::new();
    let mut ws = Vec::new();
    let (pa, wa) = at(a);
    p.push(pa);
    ws.push(wa);
    for i in 0..pts.len() {
        if s[i] > a + 1e-9 && s[i] < b - 1e-9 {
            p.push(pts[i].0);
            ws.push(w(i));
        }
    }
    let (pb, wb) = at(b);
    p.push(pb);
    ws.push(wb);
    (p, ws)
}

impl Scene {
    /// Build the scene of `gt` with default options (see [`SceneBuilder`]).
    pub fn from_ground_truth(
        gt: &osi3::GroundTruth,
        host_id: Option<u64>,
        materials: MaterialDb,
    ) -> Result<Scene, SceneError> {
        SceneBuilder::new(materials).host_id(host_id).build(gt)
    }

    pub fn options(&self) -> &SceneOptions {
        &self.options
    }

    /// Global point → scene frame.
    pub fn to_local(&self, global: DVec3) -> DVec3 {
        global - self.origin
    }

    /// Scene-frame point → global.
    pub fn to_global(&self, local: DVec3) -> DVec3 {
        local + self.origin
    }

    /// The instance of a moving object.
    pub fn instance(&self, object_id: u64) -> Option<&SceneInstance> {
        self.instances.iter().find(|i| i.object_id == object_id)
    }

    /// Phase centre (scene frame) of an object whose asset has a fixed one (see
    /// [`super::assets::phase_centre`]): a moving object's at its current pose, else a stationary
    /// object's.
    pub fn phase_centre(&self, object_id: u64) -> Option<DVec3> {
        match self.instance(object_id) {
            Some(i) => self.meshes[i.mesh]
                .phase_centre
                .map(|p| i.pose_local.transform_point(p)),
            None => self
                .static_phase_centres
                .iter()
                .find(|(id, _)| *id == object_id)
                .map(|(_, p)| *p),
        }
    }

    /// What static-world triangle `t` belongs to.
    pub fn static_element(&self, t: u32) -> Option<StaticElement> {
        self.static_owner(t).map(|o| o.element)
    }

    /// The owner record (element and triangle range) of static-world triangle `t`.
    pub fn static_owner(&self, t: u32) -> Option<&StaticOwner> {
        let i = self
            .static_owners
            .partition_point(|o| o.first_triangle <= t);
        let o = self.static_owners.get(i.checked_sub(1)?)?;
        (t < o.first_triangle + o.triangle_count).then_some(o)
    }

    /// Update to a new ground truth (see the module documentation).
    pub fn update(&mut self, gt: &osi3::GroundTruth) -> Result<SceneUpdate, SceneError> {
        self.warnings.clear();
        let mut report = SceneUpdate::default();
        self.host_id = self.host_override.or_else(|| gt_host_id(gt));
        self.wet = road_wet(&self.options, gt);
        if self.options.origin.is_none()
            && let Some(h) = host_object(gt, self.host_id)
        {
            let p = moving_object_pose(h).position;
            if p.is_finite() && p.distance(self.origin) > self.options.rebase_distance_m {
                self.origin = round_to_grid(p, self.options.origin_grid_m);
                report.rebased = true;
            }
        }
        if report.rebased
            || static_signature(gt, self.options.use_wet_materials && self.wet)
                != self.static_signature
        {
            self.rebuild_static(gt)?;
            report.static_rebuilt = true;
        }
        self.update_instances(gt, &mut report)?;
        Ok(report)
    }

    fn asset_context_dir(&self) -> Option<PathBuf> {
        self.options.asset_dir.clone()
    }

    /// The asset of an object: its reference, else the default; see the module docs for fallbacks.
    fn object_asset(
        &mut self,
        what: &str,
        reference: Option<&str>,
        default: AssetRef,
    ) -> Result<AssetRef, SceneError> {
        let Some(r) = reference.map(str::trim).filter(|r| !r.is_empty()) else {
            return Ok(default);
        };
        let ours = r
            .get(..7)
            .is_some_and(|p| p.eq_ignore_ascii_case("osiris:"));
        let err = |source| SceneError::Asset {
            object: what.to_string(),
            reference: r.to_string(),
            source: Box::new(source),
        };
        match AssetRef::parse(r) {
            Ok(a) => {
                if a.kind == AssetKind::Mesh && !ours && !self.options.strict_references {
                    let path = a.path().map(|p| match &self.options.asset_dir {
                        Some(d) if p.is_relative() => d.join(p),
                        _ => p.to_path_buf(),
                    });
                    if path.as_ref().is_some_and(|p| !p.is_file()) {
                        self.warnings.push(format!(
                            "{what}: mesh file `{}` not found; using `{}`",
                            path.unwrap_or_default().display(),
                            default
                        ));
                        return Ok(default);
                    }
                }
                Ok(a)
            }
            Err(e) if ours || self.options.strict_references => Err(err(e)),
            Err(e) => {
                self.warnings.push(format!(
                    "{what}: model_reference `{r}` not usable ({e}); using `{default}`"
                ));
                Ok(default)
            }
        }
    }

    /// The (cached) mesh of an asset at an OSI dimension.
    fn scene_mesh(
        &mut self,
        what: &str,
        reference: Option<&str>,
        asset: &AssetRef,
        dims: Option<DVec3>,
    ) -> Result<Arc<SceneMesh>, SceneError> {
        let key = match dims {
            Some(d) => format!("{asset} @ {:.3} x {:.3} x {:.3} m", d.x, d.y, d.z),
            None => format!("{asset} @ default size"),
        };
        if let Some(m) = self.cache.get(&key) {
            return Ok(m.clone());
        }
        let dir = self.asset_context_dir();
        let ctx = AssetContext {
            base_dir: dir.as_deref(),
            materials: Some(&self.materials),
        };
        let mesh = build_asset_with(asset, dims, &ctx).map_err(|source| SceneError::Asset {
            object: what.to_string(),
            reference: reference.map_or_else(|| asset.to_string(), str::to_string),
            source: Box::new(source),
        })?;
        let part_material = resolve_parts(&mut self.materials, &key, &mesh.parts)?;
        let m = Arc::new(SceneMesh {
            key: key.clone(),
            mesh,
            part_material,
            phase_centre: phase_centre(asset, dims),
        });
        self.cache.insert(key, m.clone());
        Ok(m)
    }

    fn road_materials(&mut self) -> (String, String) {
        let road = self.surface_variant(&self.options.road_material.clone());
        let marking = self.surface_variant(&self.options.marking_material.clone());
        (road, marking)
    }

    /// The material in effect for a road-surface material name: its `_wet` variant (`x_dry` →
    /// `x_wet`, `x` → `x_wet`) when the road is wet, `use_wet_materials` is set and the database
    /// has the variant; else the name itself.
    fn surface_variant(&mut self, name: &str) -> String {
        if !(self.options.use_wet_materials && self.wet) {
            return name.to_string();
        }
        let candidate = match name.strip_suffix("_dry") {
            Some(stem) => format!("{stem}_wet"),
            None => format!("{name}_wet"),
        };
        if self.materials.resolve(&candidate).is_ok() {
            candidate
        } else {
            name.to_string()
        }
    }

    fn rebuild_static(&mut self, gt: &osi3::GroundTruth) -> Result<(), SceneError> {
        let (road_material, marking_material) = self.road_materials();
        let mut w = StaticBuild {
            origin: self.origin,
            mesh: Mesh::default(),
            parts: HashMap::new(),
            owners: Vec::new(),
        };
        let max_seg = self.options.max_segment_m;

        // Road surface.
        let boundaries: HashMap<u64, &osi3::LaneBoundary> = gt
            .lane_boundary
            .iter()
            .filter_map(|b| Some((b.id.as_ref()?.value?, b)))
            .collect();
        let road = w.part("road", &road_material);
        for lane in &gt.lane {
            let Some(c) = lane.classification.as_ref() else {
                continue;
            };
            let left = lane_side(&c.left_lane_boundary_id, &boundaries);
            let right = lane_side(&c.right_lane_boundary_id, &boundaries);
            if left.len() < 2 || right.len() < 2 {
                continue;
            }
            let first = w.mesh.triangles.len();
            w.strip(&resample(&left, max_seg), &resample(&right, max_seg), road);
            w.own(first, StaticElement::Lane(object_id(lane.id.as_ref())));
        }
        if w.mesh.triangles.is_empty() {
            let z = fallback_plane_z(host_object(gt, self.host_id));
            let half = self.options.fallback_plane_half_size_m;
            let n = (2.0 * half / 50.0).ceil().max(1.0) as usize;
            let step = 2.0 * half / n as f64;
            let first = w.mesh.triangles.len();
            let c = DVec3::new(self.origin.x, self.origin.y, z);
            let idx: Vec<u32> = (0..=n)
                .flat_map(|j| (0..=n).map(move |i| (i, j)))
                .map(|(i, j)| c + DVec3::new(-half + i as f64 * step, -half + j as f64 * step, 0.0))
                .collect::<Vec<_>>()
                .into_iter()
                .map(|p| w.vertex(p))
                .collect();
            for j in 0..n {
                for i in 0..n {
                    let v = |ii: usize, jj: usize| idx[jj * (n + 1) + ii];
                    w.tri([v(i, j), v(i + 1, j), v(i + 1, j + 1)], road);
                    w.tri([v(i, j), v(i + 1, j + 1), v(i, j + 1)], road);
                }
            }
            w.own(first, StaticElement::RoadPlane);
        }
        let road_vertices = w.mesh.positions.len();

        // Lane markings.
        {
            use osi3::lane_boundary::classification::{Color as C, Type as T};
            let marking = w.part("marking", &marking_material);
            for b in &gt.lane_boundary {
                let cls = b.classification.as_ref();
                let ty = cls.and_then(|c| c.r#type).and_then(|t| T::try_from(t).ok());
                let dashed = match ty {
                    Some(T::SolidLine) => false,
                    Some(T::DashedLine) => true,
                    _ => continue,
                };
                if cls.and_then(|c| c.color).and_then(|c| C::try_from(c).ok()) == Some(C::None) {
                    continue;
                }
                let pts = boundary_points(b);
                if pts.len() < 2 {
                    continue;
                }
                let positions: Vec<DVec3> = pts.iter().map(|p| p.0).collect();
                let s = arc_lengths(&positions);
                let first = w.mesh.triangles.len();
                for (a, e) in painted_intervals(
                    &pts,
                    &s,
                    dashed,
                    self.options.dash_length_m,
                    self.options.dash_gap_m,
                ) {
                    let (p, ws) = sub_polyline(&pts, &s, a, e, self.options.marking_width_m);
                    // Resample with interpolated widths.
                    let mut rp = Vec::new();
                    let mut rw = Vec::new();
                    for i in 0..p.len() {
                        if i > 0 {
                            let k = (p[i - 1].distance(p[i]) / max_seg).ceil() as usize;
                            for q in 1..k {
                                let t = q as f64 / k as f64;
                                rp.push(p[i - 1].lerp(p[i], t));
                                rw.push(ws[i - 1] + (ws[i] - ws[i - 1]) * t);
                            }
                        }
                        rp.push(p[i]);
                        rw.push(ws[i]);
                    }
                    w.paint(&rp, &rw, self.options.marking_height_m, marking);
                }
                w.own(first, StaticElement::Marking(object_id(b.id.as_ref())));
            }
        }

        // Stationary objects.
        let mut phase_centres = Vec::new();
        for obj in &gt.stationary_object {
            let id = object_id(obj.id.as_ref());
            let what = format!("stationary object {id}");
            if obj
                .base
                .as_ref()
                .and_then(|b| b.position.as_ref())
                .is_none()
            {
                self.warnings
                    .push(format!("{what}: no base.position; skipped"));
                continue;
            }
            let reference = obj.model_reference.as_deref();
            let asset = self.object_asset(&what, reference, default_stationary_asset(obj))?;
            let dims = osi_dims(obj.base.as_ref().and_then(|b| b.dimension.as_ref()));
            let m = self.scene_mesh(&what, reference, &asset, dims)?;
            let pose = stationary_object_pose(obj);
            w.place(&m.mesh, &pose, StaticElement::Object(id));
            if let Some(p) = m.phase_centre {
                phase_centres.push((id, pose.transform_point(p) - self.origin));
            }
        }

        // Traffic signs, traffic lights, road markings.
        let road_z: Vec<glam::Vec3> = w.mesh.positions[..road_vertices].to_vec();
        let origin = self.origin;
        let fallback_z = fallback_plane_z(host_object(gt, self.host_id));
        let ground_z = move |p: DVec3| -> f64 {
            let q = (p - origin).as_vec3();
            road_z
                .iter()
                .min_by(|a, b| {
                    let da = (a.x - q.x).powi(2) + (a.y - q.y).powi(2);
                    let db = (b.x - q.x).powi(2) + (b.y - q.y).powi(2);
                    da.total_cmp(&db)
                })
                .map_or(fallback_z, |v| f64::from(v.z) + origin.z)
        };
        let paints: HashMap<&str, String> = ["lane_paint_white", "lane_paint_yellow"]
            .into_iter()
            .map(|n| (n, self.surface_variant(n)))
            .collect();
        let paint = |n: &str| paints.get(n).cloned().unwrap_or_else(|| n.to_string());
        let traffic = super::traffic::build(
            gt,
            &TrafficSettings {
                origin,
                sheeting: self.options.sign_sheeting,
                sign_posts: self.options.sign_posts,
                post_diameter_m: self.options.sign_post_diameter_m,
                housing_depth_m: self.options.signal_housing_depth_m,
                marking_height_m: self.options.marking_height_m,
                ground_z: &ground_z,
                paint: &paint,
            },
        );
        for piece in &traffic.pieces {
            w.place(&piece.mesh, &piece.pose, piece.element);
        }
        self.warnings.extend(traffic.warnings);

        let part_material = resolve_parts(&mut self.materials, "static world", &w.mesh.parts)?;
        self.static_world = SceneMesh {
            key: "static world".into(),
            mesh: w.mesh,
            part_material,
            phase_centre: None,
        };
        self.static_owners = w.owners;
        self.static_phase_centres = phase_centres;
        self.traffic_signs = traffic.signs;
        self.signal_bulbs = traffic.bulbs;
        self.road_markings = traffic.markings;
        self.static_signature = static_signature(gt, self.options.use_wet_materials && self.wet);
        self.static_revision += 1;
        Ok(())
    }

    fn update_instances(
        &mut self,
        gt: &osi3::GroundTruth,
        report: &mut SceneUpdate,
    ) -> Result<(), SceneError> {
        let before: HashSet<u64> = self.instances.iter().map(|i| i.object_id).collect();
        let first_new_mesh = self.meshes.len();
        let mut instances = Vec::with_capacity(gt.moving_object.len());
        for obj in &gt.moving_object {
            let id = object_id(obj.id.as_ref());
            if self.host_id.is_some_and(|h| h == id) {
                continue;
            }
            let what = format!("moving object {id}");
            if obj
                .base
                .as_ref()
                .and_then(|b| b.position.as_ref())
                .is_none()
            {
                self.warnings
                    .push(format!("{what}: no base.position; skipped"));
                continue;
            }
            let reference = obj.model_reference.as_deref();
            let asset = self.object_asset(&what, reference, default_moving_asset(obj))?;
            let dims = osi_dims(obj.base.as_ref().and_then(|b| b.dimension.as_ref()));
            let m = self.scene_mesh(&what, reference, &asset, dims)?;
            let mesh = match self.mesh_index.get(&m.key) {
                Some(&i) => i,
                None => {
                    self.meshes.push(m.clone());
                    self.mesh_index.insert(m.key.clone(), self.meshes.len() - 1);
                    self.meshes.len() - 1
                }
            };
            let pose = moving_object_pose(obj);
            let (v, w) = moving_object_twist(obj);
            instances.push(SceneInstance {
                object_id: id,
                mesh,
                pose_local: Pose::new(pose.position - self.origin, pose.rotation),
                velocity_m_s: v,
                angular_velocity_rad_s: w,
            });
        }
        let after: HashSet<u64> = instances.iter().map(|i| i.object_id).collect();
        report.added = instances
            .iter()
            .map(|i| i.object_id)
            .filter(|i| !before.contains(i))
            .collect();
        report.removed = self
            .instances
            .iter()
            .map(|i| i.object_id)
            .filter(|i| !after.contains(i))
            .collect();
        report.new_meshes = first_new_mesh..self.meshes.len();
        self.instances = instances;
        Ok(())
    }
}

fn resolve_parts(
    db: &mut MaterialDb,
    mesh: &str,
    parts: &[Part],
) -> Result<Vec<MaterialId>, SceneError> {
    parts
        .iter()
        .map(|p| {
            db.resolve(&p.material)
                .map_err(|source| SceneError::Material {
                    mesh: mesh.to_string(),
                    part: p.name.clone(),
                    source: Box::new(source),
                })
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dash_flags_and_pattern() {
        use osi3::lane_boundary::boundary_point::Dash as D;
        let p = |x: f64, d: Option<D>| (DVec3::new(x, 0.0, 0.0), 0.15, d.map(|d| d as i32));
        let pts = [
            p(0.0, Some(D::Start)),
            p(6.0, Some(D::End)),
            p(18.0, Some(D::Start)),
            p(20.0, Some(D::Continue)),
            p(24.0, Some(D::End)),
            p(30.0, Some(D::Start)),
        ];
        let s: Vec<f64> = pts.iter().map(|q| q.0.x).collect();
        assert_eq!(
            painted_intervals(&pts, &s, true, 3.0, 9.0),
            vec![(0.0, 6.0), (18.0, 24.0)]
        );
        let pts = [p(0.0, None), p(20.0, None)];
        let s = [0.0, 20.0];
        assert_eq!(
            painted_intervals(&pts, &s, true, 3.0, 9.0),
            vec![(0.0, 3.0), (12.0, 15.0)]
        );
        assert_eq!(
            painted_intervals(&pts, &s, false, 3.0, 9.0),
            vec![(0.0, 20.0)]
        );
    }

    #[test]
    fn origin_rounding() {
        assert_eq!(
            round_to_grid(DVec3::new(149.0, -151.0, 0.4), 100.0),
            DVec3::new(100.0, -200.0, 0.0)
        );
        assert_eq!(
            round_to_grid(DVec3::new(1.5, 2.5, 3.5), 0.0),
            DVec3::new(1.5, 2.5, 3.5)
        );
    }
}
