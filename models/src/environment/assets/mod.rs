//! Built-in parametric assets and user meshes: the geometry an OSI object's `model_reference` names.
//!
//! # References
//!
//! * `osiris:<asset>?<param>=<value>&...`: a built-in parametric asset, e.g. `osiris:car?paint=black`,
//!   `osiris:trihedral?edge_m=0.1`, `osiris:board?width_m=1&height_m=1&material=lambertian_50`.
//!   Names, keys and values are percent-decoded (RFC 3986; `+` is a plus, not a space); the scheme is
//!   case-insensitive, asset names and keys are not. Empty `&&` pairs are ignored; a key given twice,
//!   a key without `=`, an unknown key or a value out of range is an error naming the asset, the
//!   parameter and what is allowed. [`AssetKind::ALL`] lists the assets; [`AssetKind::spec`] their
//!   parameters (the tables in `models/ASSETS.md` are generated from the same specs,
//!   see [`catalogue_markdown`]).
//! * A path to a user mesh (`.obj`, `.gltf`, `.glb`), optionally as `file://` URI and optionally
//!   followed by `?<param>=<value>&...` with the parameters of the `mesh` asset; or, for paths that
//!   contain `?`, `osiris:mesh?path=<percent-encoded path>&...`. Relative paths are resolved against
//!   [`AssetContext::base_dir`] (the scene's asset directory), else the working directory.
//!
//! [`AssetRef::parse`] validates a reference; [`AssetRef`]'s `Display` is its canonical form
//! (parameters sorted, numbers in shortest form), used as cache key.
//!
//! # Frames and sizing
//!
//! A mesh is given in its object frame: origin at the centre of the OSI bounding box
//! (`base.position`), +x the direction the asset faces (a vehicle's forward direction, a board's face
//! normal, a trihedral's boresight), +y left, +z up; metres. The object's OSI orientation rotates that
//! frame into the world, so an asset at azimuth φ from a sensor faces the sensor with yaw = φ + π.
//!
//! [`build_asset`] sizes the mesh: per axis, an explicit size parameter (e.g. `length_m`) wins, then
//! the OSI dimension (when given and > 0), then the asset's default. Most assets are stretched so
//! that their bounding box is exactly that size (a car fills its OSI box). The trihedral and the board
//! are never scaled: their edge length and width/height are physical parameters (they determine the
//! RCS and reflectance area); a taller OSI box gets a mounting post below them (`mount=auto`).
//!
//! # Triangles
//!
//! Counter-clockwise seen from outside (outward geometric normals); every solid part is a closed,
//! consistently oriented component (checked by the functions of [`geometry`]); only the zero-thickness
//! board (`thickness_m=0`) is open. Parts overlap where they touch (e.g. a wheel in its arch): the
//! ray tracer reports the first surface hit, so only the outer surfaces are ever seen.

pub mod geometry;
mod roadside;
pub mod signals;
mod targets;
mod user;
mod vehicles;
mod vru;

use std::borrow::Cow;
use std::collections::BTreeMap;
use std::fmt;
use std::path::{Path, PathBuf};

use glam::DVec3;

use crate::environment::material::MaterialDb;
use crate::environment::mesh::Mesh;

pub use user::{Fit, Up, UserMeshOptions, load_user_mesh, load_user_mesh_with};

/// Errors of asset references, parameters and user meshes.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum AssetError {
    #[error("empty model reference")]
    Empty,
    #[error("model reference `{reference}`: {message}")]
    Syntax { reference: String, message: String },
    #[error("unknown asset `{name}` in `{reference}`; known assets: {known}")]
    UnknownAsset {
        reference: String,
        name: String,
        known: String,
    },
    #[error("asset `{asset}`: unknown parameter `{param}`; allowed: {allowed}")]
    UnknownParam {
        asset: &'static str,
        param: String,
        allowed: String,
    },
    #[error("asset `{asset}`: parameter `{param}` is given more than once")]
    DuplicateParam { asset: &'static str, param: String },
    #[error("asset `{asset}`: parameter `{param}` = `{value}`: expected {expected}")]
    InvalidParam {
        asset: &'static str,
        param: &'static str,
        value: String,
        expected: String,
    },
    #[error("asset `{asset}`: missing parameter `{param}`")]
    MissingParam {
        asset: &'static str,
        param: &'static str,
    },
    #[error("mesh file `{}`: unsupported format (supported: .obj, .gltf, .glb)", path.display())]
    UnsupportedFormat { path: PathBuf },
    #[error("mesh file `{}`: {message}", path.display())]
    MeshFile { path: PathBuf, message: String },
}

/// The built-in assets (and `mesh`, a user mesh file).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum AssetKind {
    Car,
    Van,
    Truck,
    Bus,
    Pedestrian,
    Cyclist,
    Motorcycle,
    Guardrail,
    Pole,
    Cone,
    Trihedral,
    Board,
    Box,
    Mesh,
}

/// Type of a parameter value.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum ParamKind {
    /// A finite number in `[min, max]`.
    Number {
        min: f64,
        max: f64,
        unit: &'static str,
    },
    /// An integer in `[min, max]`.
    Integer { min: i64, max: i64 },
    /// One of the listed words.
    Choice(&'static [&'static str]),
    /// A material name (`[a-z0-9_.]+`, resolved later through the materials database), or one of the
    /// aliases `(alias, material)`.
    Material(&'static [(&'static str, &'static str)]),
    /// A file path (any text).
    Path,
}

/// Default of a parameter.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum ParamDefault {
    Number(f64),
    Text(&'static str),
    /// Derived from something else (e.g. the OSI dimension); described in words.
    Derived(&'static str),
}

/// One parameter of an asset.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ParamSpec {
    pub name: &'static str,
    pub kind: ParamKind,
    pub default: ParamDefault,
    pub doc: &'static str,
}

/// A part an asset produces: name, material (or the parameter that sets it) and what it is.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PartSpec {
    pub name: &'static str,
    pub material: &'static str,
    pub doc: &'static str,
}

/// Description of an asset: parameters, parts, default size.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AssetSpec {
    pub kind: AssetKind,
    pub summary: &'static str,
    /// Default OSI dimension (length x, width y, height z), m.
    pub default_dimensions: [f64; 3],
    /// How the mesh is sized to the OSI dimension.
    pub sizing: &'static str,
    pub params: &'static [ParamSpec],
    pub parts: &'static [PartSpec],
}

/// A parsed parameter value.
#[derive(Debug, Clone, PartialEq)]
pub enum ParamValue {
    Number(f64),
    Text(String),
}

/// A validated asset reference: asset and the parameters given explicitly.
#[derive(Debug, Clone, PartialEq)]
pub struct AssetRef {
    pub kind: AssetKind,
    params: BTreeMap<&'static str, ParamValue>,
}

/// Where user meshes are found and which materials their names may map to.
#[derive(Debug, Clone, Copy, Default)]
pub struct AssetContext<'a> {
    /// Directory relative user-mesh paths are resolved against (default: the working directory).
    pub base_dir: Option<&'a Path>,
    /// Materials a user mesh's material names are matched against (default: [`MaterialDb::builtin`]).
    pub materials: Option<&'a MaterialDb>,
}

// ---------------------------------------------------------------------------------------------------
// Specs

const PAINT: &[(&str, &str)] = &[("white", "car_paint_white"), ("black", "car_paint_black")];
const CLOTHING: &[(&str, &str)] = &[
    ("cotton", "clothing_cotton"),
    ("black_leather", "clothing_black_leather"),
];

const fn num(
    name: &'static str,
    min: f64,
    max: f64,
    unit: &'static str,
    default: ParamDefault,
    doc: &'static str,
) -> ParamSpec {
    ParamSpec {
        name,
        kind: ParamKind::Number { min, max, unit },
        default,
        doc,
    }
}
const fn mat(
    name: &'static str,
    aliases: &'static [(&'static str, &'static str)],
    default: &'static str,
    doc: &'static str,
) -> ParamSpec {
    ParamSpec {
        name,
        kind: ParamKind::Material(aliases),
        default: ParamDefault::Text(default),
        doc,
    }
}
const fn choice(
    name: &'static str,
    values: &'static [&'static str],
    default: &'static str,
    doc: &'static str,
) -> ParamSpec {
    ParamSpec {
        name,
        kind: ParamKind::Choice(values),
        default: ParamDefault::Text(default),
        doc,
    }
}
const fn part(name: &'static str, material: &'static str, doc: &'static str) -> PartSpec {
    PartSpec {
        name,
        material,
        doc,
    }
}

const OSI_L: ParamDefault = ParamDefault::Derived("OSI length, else the default dimension");
const OSI_W: ParamDefault = ParamDefault::Derived("OSI width, else the default dimension");
const OSI_H: ParamDefault = ParamDefault::Derived("OSI height, else the default dimension");
const LENGTH: ParamSpec = num(
    "length_m",
    0.1,
    100.0,
    "m",
    OSI_L,
    "bounding-box length (x); overrides the OSI dimension",
);
const WIDTH: ParamSpec = num(
    "width_m",
    0.1,
    20.0,
    "m",
    OSI_W,
    "bounding-box width (y); overrides the OSI dimension",
);
const HEIGHT: ParamSpec = num(
    "height_m",
    0.1,
    20.0,
    "m",
    OSI_H,
    "bounding-box height (z); overrides the OSI dimension",
);
const STRETCH: &str = "stretched to the box (length × width × height)";

const VEHICLE_PARTS: &[PartSpec] = &[
    part(
        "body",
        "`paint`",
        "lower body and greenhouse frame (roof, pillars)",
    ),
    part("glass", "glass", "windscreen, side and rear windows"),
    part(
        "interior",
        "plastic_black",
        "dark cabin interior seen through the glass",
    ),
    part(
        "wheels",
        "rubber",
        "tyres (tori of elliptical section) and domed wheel discs",
    ),
    part("bumpers", "plastic_black", "front and rear bumpers"),
    part("head_lamps", "polycarbonate", "head-lamp lenses (front)"),
    part("tail_lamps", "polycarbonate", "tail-lamp lenses (rear)"),
    part(
        "licence_plates",
        "retroreflective_sheeting",
        "front and rear plates, 520 × 110 mm",
    ),
];
const TRUCK_PARTS: &[PartSpec] = &[
    part("cab", "`paint`", "cab"),
    part("cargo_box", "`cargo`", "box body"),
    part("chassis", "steel", "frame rails and rear under-run bar"),
    part("glass", "glass", "windscreen and side windows"),
    part("interior", "plastic_black", "cab interior"),
    part("wheels", "rubber", "tyres: one front and two rear axles"),
    part("bumpers", "plastic_black", "front bumper"),
    part("head_lamps", "polycarbonate", "head lamps"),
    part("tail_lamps", "polycarbonate", "tail lamps"),
    part(
        "licence_plates",
        "retroreflective_sheeting",
        "front and rear plates",
    ),
];
const PERSON_PARTS: &[PartSpec] = &[
    part("torso", "`clothing`", "trunk"),
    part("arms", "`clothing`", "upper arms and forearms"),
    part("legs", "`clothing`", "thighs and shanks"),
    part("head", "skin", "head and neck"),
    part("hands", "skin", "hands"),
    part("shoes", "clothing_black_leather", "shoes"),
];
const CYCLIST_PARTS: &[PartSpec] = &[
    part(
        "frame",
        "`frame`",
        "frame tubes, fork, handlebar, seat post",
    ),
    part("wheels", "rubber", "tyres (tori)"),
    part(
        "rims",
        "aluminium",
        "rims (tori of elliptical section) and hubs",
    ),
    part("spokes", "steel", "spokes (32 round 2 mm wires per wheel)"),
    part("saddle", "plastic_black", "saddle and pedals"),
    part("torso", "`clothing`", "rider's trunk"),
    part("arms", "`clothing`", "rider's arms"),
    part("legs", "`clothing`", "rider's legs"),
    part("head", "skin", "rider's head"),
    part("hands", "skin", "rider's hands"),
    part("shoes", "clothing_black_leather", "rider's shoes"),
];
const MOTORCYCLE_PARTS: &[PartSpec] = &[
    part("body", "`paint`", "tank and fairing"),
    part("engine", "aluminium", "engine block"),
    part("frame", "steel", "frame, fork, handlebar"),
    part("wheels", "rubber", "tyres (tori)"),
    part(
        "rims",
        "aluminium",
        "rims (tori of elliptical section) and hubs",
    ),
    part("saddle", "plastic_black", "seat"),
    part("head_lamps", "polycarbonate", "head lamp"),
    part("tail_lamps", "polycarbonate", "tail lamp"),
    part("licence_plates", "retroreflective_sheeting", "rear plate"),
    part("torso", "`clothing`", "rider's trunk"),
    part("arms", "`clothing`", "rider's arms"),
    part("legs", "`clothing`", "rider's legs"),
    part("helmet", "`helmet`", "rider's helmet"),
    part("hands", "`clothing`", "rider's gloves"),
    part("shoes", "clothing_black_leather", "rider's boots"),
];

static SPECS: [AssetSpec; 14] = [
    AssetSpec {
        kind: AssetKind::Car,
        summary: "passenger car (saloon): body, greenhouse with windows, four wheels, bumpers, lamps, plates",
        default_dimensions: [4.5, 1.8, 1.5],
        sizing: STRETCH,
        params: &[
            mat(
                "paint",
                PAINT,
                "white",
                "body paint: `white`, `black` or any material name",
            ),
            LENGTH,
            WIDTH,
            HEIGHT,
        ],
        parts: VEHICLE_PARTS,
    },
    AssetSpec {
        kind: AssetKind::Van,
        summary: "delivery van: short bonnet, tall cargo body with rear-door windows",
        default_dimensions: [5.4, 2.0, 2.3],
        sizing: STRETCH,
        params: &[
            mat(
                "paint",
                PAINT,
                "white",
                "body paint: `white`, `black` or any material name",
            ),
            LENGTH,
            WIDTH,
            HEIGHT,
        ],
        parts: VEHICLE_PARTS,
    },
    AssetSpec {
        kind: AssetKind::Truck,
        summary: "rigid truck: cab with windows, box body on a chassis, three axles",
        default_dimensions: [10.0, 2.55, 3.6],
        sizing: STRETCH,
        params: &[
            mat(
                "paint",
                PAINT,
                "white",
                "cab paint: `white`, `black` or any material name",
            ),
            mat(
                "cargo",
                PAINT,
                "aluminium",
                "box-body skin: `white`, `black` or any material name",
            ),
            LENGTH,
            WIDTH,
            HEIGHT,
        ],
        parts: TRUCK_PARTS,
    },
    AssetSpec {
        kind: AssetKind::Bus,
        summary: "city/coach bus: one body with windscreen, side window band and rear window, two axles",
        default_dimensions: [12.0, 2.55, 3.2],
        sizing: STRETCH,
        params: &[
            mat(
                "paint",
                PAINT,
                "white",
                "body paint: `white`, `black` or any material name",
            ),
            LENGTH,
            WIDTH,
            HEIGHT,
        ],
        parts: VEHICLE_PARTS,
    },
    AssetSpec {
        kind: AssetKind::Pedestrian,
        summary: "adult pedestrian (Drillis–Contini segment proportions), walking or standing, facing +x",
        default_dimensions: [0.5, 0.6, 1.8],
        sizing: STRETCH,
        params: &[
            mat(
                "clothing",
                CLOTHING,
                "cotton",
                "clothes: `cotton`, `black_leather` or any material name",
            ),
            choice(
                "pose",
                &["walking", "standing"],
                "walking",
                "mid-stride (left leg forward) or standing",
            ),
            LENGTH,
            WIDTH,
            HEIGHT,
        ],
        parts: PERSON_PARTS,
    },
    AssetSpec {
        kind: AssetKind::Cyclist,
        summary: "bicycle (700c wheels, aluminium frame tubes) with a pedalling rider",
        default_dimensions: [1.8, 0.6, 1.75],
        sizing: STRETCH,
        params: &[
            mat(
                "clothing",
                CLOTHING,
                "cotton",
                "rider's clothes: `cotton`, `black_leather` or any material name",
            ),
            mat("frame", &[], "aluminium", "frame material"),
            LENGTH,
            WIDTH,
            HEIGHT,
        ],
        parts: CYCLIST_PARTS,
    },
    AssetSpec {
        kind: AssetKind::Motorcycle,
        summary: "motorcycle with rider (helmet, leathers)",
        default_dimensions: [2.2, 0.8, 1.4],
        sizing: STRETCH,
        params: &[
            mat("paint", PAINT, "black", "tank and fairing paint"),
            mat("clothing", CLOTHING, "black_leather", "rider's clothes"),
            mat("helmet", PAINT, "white", "helmet shell"),
            LENGTH,
            WIDTH,
            HEIGHT,
        ],
        parts: MOTORCYCLE_PARTS,
    },
    AssetSpec {
        kind: AssetKind::Guardrail,
        summary: "W-beam guardrail (folded 3 mm strip, 311 mm × 83 mm profile) on posts with spacers, along x",
        default_dimensions: [4.0, 0.3, 0.75],
        sizing: "length along x from the OSI dimension (posts keep their spacing); beam top at the box top; \
                 width and height stretched",
        params: &[
            mat("material", &[], "steel", "beam, post and spacer material"),
            num(
                "post_spacing_m",
                0.5,
                10.0,
                "m",
                ParamDefault::Number(2.0),
                "distance between posts",
            ),
            choice(
                "face",
                &["left", "right", "both"],
                "left",
                "side the beam is on (left = +y): the traffic side",
            ),
        ],
        parts: &[
            part("beam", "`material`", "W-beam rail"),
            part("posts", "`material`", "posts and spacers"),
        ],
    },
    AssetSpec {
        kind: AssetKind::Pole,
        summary: "vertical cylindrical pole",
        default_dimensions: [0.1, 0.1, 3.0],
        sizing: STRETCH,
        params: &[
            mat(
                "material",
                &[],
                "steel",
                "`steel`, `concrete` or any material name",
            ),
            ParamSpec {
                name: "segments",
                kind: ParamKind::Integer { min: 6, max: 128 },
                default: ParamDefault::Number(16.0),
                doc: "facets around the circumference",
            },
        ],
        parts: &[part("pole", "`material`", "the pole")],
    },
    AssetSpec {
        kind: AssetKind::Cone,
        summary: "traffic cone: square base, conical body, retroreflective band(s)",
        default_dimensions: [0.3, 0.3, 0.5],
        sizing: STRETCH,
        params: &[
            mat(
                "material",
                &[],
                "lambertian_40",
                "body material (placeholder for orange PVC until the database has one)",
            ),
            ParamSpec {
                name: "bands",
                kind: ParamKind::Integer { min: 0, max: 3 },
                default: ParamDefault::Derived("1 below 0.6 m height, else 2"),
                doc: "number of retroreflective bands",
            },
        ],
        parts: &[
            part("base", "plastic_black", "square base plate"),
            part("body", "`material`", "cone"),
            part(
                "bands",
                "retroreflective_sheeting",
                "retroreflective sleeve band(s)",
            ),
        ],
    },
    AssetSpec {
        kind: AssetKind::Trihedral,
        summary: "triangular trihedral corner reflector: three mutually orthogonal triangular plates of inner \
                  edge `edge_m`, inner corner at the back, boresight (the (1,1,1) axis) along +x, one inner \
                  edge in the x–z plane pointing up",
        default_dimensions: [0.15, 0.15, 0.15],
        sizing: "never scaled (edge_m is physical); centred in the OSI box, at its top when the box is taller, \
                 with a post down to the box bottom (`mount=auto`)",
        params: &[
            num(
                "edge_m",
                0.005,
                5.0,
                "m",
                ParamDefault::Number(0.1),
                "inner edge length a (σ_max = 4πa⁴/(3λ²))",
            ),
            num(
                "thickness_m",
                0.0005,
                0.05,
                "m",
                ParamDefault::Number(0.002),
                "plate thickness (added behind the reflecting faces)",
            ),
            mat("material", &[], "aluminium", "plate material"),
            choice(
                "mount",
                &["auto", "none"],
                "auto",
                "post below the reflector when the OSI box is taller",
            ),
        ],
        parts: &[
            part("plates", "`material`", "the three plates"),
            part("mount", "steel", "mounting post"),
        ],
    },
    AssetSpec {
        kind: AssetKind::Board,
        summary: "flat target board: face (normal +x) width_m × height_m, width along y, height along z",
        default_dimensions: [0.01, 1.0, 1.0],
        sizing: "never scaled: width_m/height_m/thickness_m, else the OSI width/height/length; at the top of a \
                 taller OSI box with a post below (`mount=auto`)",
        params: &[
            num(
                "width_m",
                0.01,
                50.0,
                "m",
                ParamDefault::Derived("OSI width, else 1"),
                "face width (y)",
            ),
            num(
                "height_m",
                0.01,
                50.0,
                "m",
                ParamDefault::Derived("OSI height, else 1"),
                "face height (z)",
            ),
            num(
                "thickness_m",
                0.0,
                1.0,
                "m",
                ParamDefault::Derived("OSI length, else 0.01"),
                "thickness (x); 0 gives a single open rectangle",
            ),
            mat("material", &[], "lambertian_50", "face material"),
            ParamSpec {
                name: "back",
                kind: ParamKind::Material(&[]),
                default: ParamDefault::Derived("`material`"),
                doc: "material of the back and the edges",
            },
            choice(
                "mount",
                &["auto", "none"],
                "auto",
                "post below the board when the OSI box is taller",
            ),
        ],
        parts: &[
            part("face", "`material`", "front face (+x)"),
            part("back", "`back`", "back and edges"),
            part("mount", "steel", "mounting post"),
        ],
    },
    AssetSpec {
        kind: AssetKind::Box,
        summary: "closed box filling the OSI bounding box (generic fallback)",
        default_dimensions: [1.0, 1.0, 1.0],
        sizing: STRETCH,
        params: &[mat("material", &[], "lambertian_50", "material")],
        parts: &[part("box", "`material`", "the box")],
    },
    AssetSpec {
        kind: AssetKind::Mesh,
        summary: "user mesh file (Wavefront OBJ via `tobj`, glTF 2.0 / GLB via `gltf`), named by its path",
        default_dimensions: [1.0, 1.0, 1.0],
        sizing: "see `fit`",
        params: &[
            ParamSpec {
                name: "path",
                kind: ParamKind::Path,
                default: ParamDefault::Derived("required"),
                doc: "file path (.obj, .gltf, .glb)",
            },
            mat(
                "material",
                &[],
                "lambertian_50",
                "material of file materials whose names are not osiris materials",
            ),
            ParamSpec {
                name: "up",
                kind: ParamKind::Choice(&["z", "y"]),
                default: ParamDefault::Derived("`y` for .gltf/.glb, `z` for .obj"),
                doc: "file axes: `z` = osiris (x forward, y left, z up); `y` = glTF (+y up, +z forward, +x left)",
            },
            num(
                "yaw_deg",
                -360.0,
                360.0,
                "deg",
                ParamDefault::Number(0.0),
                "rotation about +z after the axis conversion",
            ),
            num(
                "scale",
                1e-6,
                1e6,
                "",
                ParamDefault::Number(1.0),
                "uniform scale to metres (e.g. 0.001 for mm)",
            ),
            choice(
                "fit",
                &["center", "stretch", "uniform", "none"],
                "center",
                "`center`: move the bounding-box centre to the origin; `stretch`: also scale each axis to the OSI box; \
                 `uniform`: scale uniformly to fit inside it; `none`: keep the file's origin",
            ),
        ],
        parts: &[part(
            "<file material name>",
            "that name if it is an osiris material, else `material`",
            "one part per file material",
        )],
    },
];

impl AssetKind {
    pub const ALL: [AssetKind; 14] = [
        AssetKind::Car,
        AssetKind::Van,
        AssetKind::Truck,
        AssetKind::Bus,
        AssetKind::Pedestrian,
        AssetKind::Cyclist,
        AssetKind::Motorcycle,
        AssetKind::Guardrail,
        AssetKind::Pole,
        AssetKind::Cone,
        AssetKind::Trihedral,
        AssetKind::Board,
        AssetKind::Box,
        AssetKind::Mesh,
    ];

    /// The name used in `osiris:<name>`.
    pub fn name(self) -> &'static str {
        match self {
            AssetKind::Car => "car",
            AssetKind::Van => "van",
            AssetKind::Truck => "truck",
            AssetKind::Bus => "bus",
            AssetKind::Pedestrian => "pedestrian",
            AssetKind::Cyclist => "cyclist",
            AssetKind::Motorcycle => "motorcycle",
            AssetKind::Guardrail => "guardrail",
            AssetKind::Pole => "pole",
            AssetKind::Cone => "cone",
            AssetKind::Trihedral => "trihedral",
            AssetKind::Board => "board",
            AssetKind::Box => "box",
            AssetKind::Mesh => "mesh",
        }
    }

    pub fn from_name(name: &str) -> Option<AssetKind> {
        AssetKind::ALL.into_iter().find(|k| k.name() == name)
    }

    /// Parameters, parts and default size.
    pub fn spec(self) -> &'static AssetSpec {
        &SPECS[self as usize]
    }

    /// Default OSI dimension (length, width, height), m.
    pub fn default_dimensions(self) -> DVec3 {
        DVec3::from_array(self.spec().default_dimensions)
    }
}

impl AssetSpec {
    pub fn param(&self, name: &str) -> Option<&'static ParamSpec> {
        self.params.iter().find(|p| p.name == name)
    }

    fn allowed(&self) -> String {
        if self.params.is_empty() {
            "none".into()
        } else {
            self.params
                .iter()
                .map(|p| p.name)
                .collect::<Vec<_>>()
                .join(", ")
        }
    }
}

fn known_assets() -> String {
    AssetKind::ALL
        .iter()
        .map(|k| k.name())
        .collect::<Vec<_>>()
        .join(", ")
}

// ---------------------------------------------------------------------------------------------------
// Percent-encoding

/// Percent-decode `s` (RFC 3986 `%XX`; `+` is kept). Errors name the offending sequence.
pub fn percent_decode(s: &str) -> Result<Cow<'_, str>, String> {
    if !s.contains('%') {
        return Ok(Cow::Borrowed(s));
    }
    let b = s.as_bytes();
    let mut out = Vec::with_capacity(b.len());
    let mut i = 0;
    while i < b.len() {
        if b[i] == b'%' {
            let hex = b
                .get(i + 1..i + 3)
                .and_then(|h| std::str::from_utf8(h).ok());
            match hex.and_then(|h| u8::from_str_radix(h, 16).ok()) {
                Some(v) if hex.is_some_and(|h| h.bytes().all(|c| c.is_ascii_hexdigit())) => {
                    out.push(v);
                    i += 3;
                }
                _ => {
                    let end = (i + 3).min(b.len());
                    return Err(format!(
                        "invalid percent-encoding `{}`",
                        String::from_utf8_lossy(&b[i..end])
                    ));
                }
            }
        } else {
            out.push(b[i]);
            i += 1;
        }
    }
    String::from_utf8(out)
        .map(Cow::Owned)
        .map_err(|_| "percent-encoding does not decode to UTF-8".to_string())
}

/// Percent-encode everything but RFC 3986 unreserved characters and `/`.
pub fn percent_encode(s: &str) -> String {
    let mut out = String::with_capacity(s.len());
    for &c in s.as_bytes() {
        if c.is_ascii_alphanumeric() || matches!(c, b'-' | b'.' | b'_' | b'~' | b'/') {
            out.push(c as char);
        } else {
            out.push_str(&format!("%{c:02X}"));
        }
    }
    out
}

// ---------------------------------------------------------------------------------------------------
// Lenient accessors (used by the ideal model)

/// Asset name of an `osiris:` reference (`osiris:car?paint=black` → `car`), without validation.
pub fn model_reference_name(reference: &str) -> Option<&str> {
    let rest = strip_scheme(reference.trim())?;
    Some(rest.split_once('?').map_or(rest, |(n, _)| n))
}

/// Percent-decoded value of `key` in a reference's query (`?k1=v1&k2=v2`), without validation; the
/// first occurrence wins.
pub fn model_reference_param<'a>(reference: &'a str, key: &str) -> Option<Cow<'a, str>> {
    let (_, query) = reference.trim().split_once('?')?;
    query.split('&').find_map(|kv| {
        let (k, v) = kv.split_once('=')?;
        (percent_decode(k).ok()? == key)
            .then(|| percent_decode(v).ok())
            .flatten()
    })
}

fn strip_scheme(s: &str) -> Option<&str> {
    let prefix = s.get(..7)?;
    prefix.eq_ignore_ascii_case("osiris:").then(|| &s[7..])
}

// ---------------------------------------------------------------------------------------------------
// Parsing

fn is_material_name(s: &str) -> bool {
    !s.is_empty()
        && s.bytes()
            .all(|c| c.is_ascii_lowercase() || c.is_ascii_digit() || c == b'_' || c == b'.')
}

fn validate(
    kind: AssetKind,
    spec: &'static ParamSpec,
    raw: &str,
) -> Result<ParamValue, AssetError> {
    let invalid = |expected: String| AssetError::InvalidParam {
        asset: kind.name(),
        param: spec.name,
        value: raw.to_string(),
        expected,
    };
    match spec.kind {
        ParamKind::Number { min, max, unit } => {
            let unit = if unit.is_empty() {
                String::new()
            } else {
                format!(" {unit}")
            };
            let expected = || format!("a number in [{min}, {max}]{unit}");
            let v: f64 = raw.trim().parse().map_err(|_| invalid(expected()))?;
            if v.is_finite() && (min..=max).contains(&v) {
                Ok(ParamValue::Number(v))
            } else {
                Err(invalid(expected()))
            }
        }
        ParamKind::Integer { min, max } => {
            let expected = || format!("an integer in [{min}, {max}]");
            let v: i64 = raw.trim().parse().map_err(|_| invalid(expected()))?;
            if (min..=max).contains(&v) {
                Ok(ParamValue::Number(v as f64))
            } else {
                Err(invalid(expected()))
            }
        }
        ParamKind::Choice(values) => {
            if values.contains(&raw) {
                Ok(ParamValue::Text(raw.to_string()))
            } else {
                Err(invalid(format!("one of {}", values.join(", "))))
            }
        }
        ParamKind::Material(aliases) => {
            if let Some((_, m)) = aliases.iter().find(|(a, _)| *a == raw) {
                Ok(ParamValue::Text((*m).to_string()))
            } else if is_material_name(raw) {
                Ok(ParamValue::Text(raw.to_string()))
            } else {
                let a: Vec<&str> = aliases.iter().map(|(a, _)| *a).collect();
                let a = if a.is_empty() {
                    String::new()
                } else {
                    format!("{} or ", a.join(", "))
                };
                Err(invalid(format!(
                    "{a}a material name (lowercase letters, digits, `_`, `.`)"
                )))
            }
        }
        ParamKind::Path => {
            if raw.is_empty() {
                Err(invalid("a file path".into()))
            } else {
                Ok(ParamValue::Text(raw.to_string()))
            }
        }
    }
}

fn parse_query(
    kind: AssetKind,
    reference: &str,
    query: &str,
) -> Result<BTreeMap<&'static str, ParamValue>, AssetError> {
    let spec = kind.spec();
    let mut params = BTreeMap::new();
    let syntax = |message: String| AssetError::Syntax {
        reference: reference.to_string(),
        message,
    };
    for pair in query.split('&').filter(|p| !p.is_empty()) {
        let Some((k, v)) = pair.split_once('=') else {
            return Err(syntax(format!("parameter `{pair}` has no `=value`")));
        };
        let k = percent_decode(k).map_err(syntax)?;
        let v = percent_decode(v).map_err(syntax)?;
        let Some(p) = spec.param(&k) else {
            return Err(AssetError::UnknownParam {
                asset: kind.name(),
                param: k.into_owned(),
                allowed: spec.allowed(),
            });
        };
        if params.contains_key(p.name) {
            return Err(AssetError::DuplicateParam {
                asset: kind.name(),
                param: p.name.to_string(),
            });
        }
        params.insert(p.name, validate(kind, p, &v)?);
    }
    Ok(params)
}

fn mesh_extension_ok(path: &str) -> bool {
    let ext = Path::new(path)
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase);
    matches!(ext.as_deref(), Some("obj" | "gltf" | "glb"))
}

impl AssetRef {
    /// Parse and validate a model reference (see the module documentation).
    pub fn parse(reference: &str) -> Result<AssetRef, AssetError> {
        let r = reference.trim();
        if r.is_empty() {
            return Err(AssetError::Empty);
        }
        if let Some(rest) = strip_scheme(r) {
            let (name, query) = rest.split_once('?').unwrap_or((rest, ""));
            let name = percent_decode(name).map_err(|message| AssetError::Syntax {
                reference: r.into(),
                message,
            })?;
            let Some(kind) = AssetKind::from_name(&name) else {
                return Err(AssetError::UnknownAsset {
                    reference: r.into(),
                    name: name.into_owned(),
                    known: known_assets(),
                });
            };
            let params = parse_query(kind, r, query)?;
            if kind == AssetKind::Mesh {
                let Some(ParamValue::Text(path)) = params.get("path") else {
                    return Err(AssetError::MissingParam {
                        asset: "mesh",
                        param: "path",
                    });
                };
                if !mesh_extension_ok(path) {
                    return Err(AssetError::UnsupportedFormat { path: path.into() });
                }
            }
            return Ok(AssetRef { kind, params });
        }
        // A user mesh path (or file:// URI), optionally with `?params`.
        let (path, query) = r.split_once('?').unwrap_or((r, ""));
        let path: Cow<'_, str> = match path.get(..7) {
            Some(p) if p.eq_ignore_ascii_case("file://") => {
                let rest = &path[7..];
                // file:///abs/path or file://localhost/abs/path
                let rest = rest.strip_prefix("localhost").unwrap_or(rest);
                percent_decode(rest).map_err(|message| AssetError::Syntax {
                    reference: r.into(),
                    message,
                })?
            }
            _ => Cow::Borrowed(path),
        };
        if !mesh_extension_ok(&path) {
            return Err(AssetError::UnsupportedFormat {
                path: path.as_ref().into(),
            });
        }
        let mut params = parse_query(AssetKind::Mesh, r, query)?;
        if params.contains_key("path") {
            return Err(AssetError::DuplicateParam {
                asset: "mesh",
                param: "path".into(),
            });
        }
        params.insert("path", ParamValue::Text(path.into_owned()));
        Ok(AssetRef {
            kind: AssetKind::Mesh,
            params,
        })
    }

    /// The asset with all parameters at their defaults.
    pub fn builtin(kind: AssetKind) -> AssetRef {
        AssetRef {
            kind,
            params: BTreeMap::new(),
        }
    }

    /// Set a parameter (validated like a parsed one).
    pub fn with(mut self, key: &str, value: &str) -> Result<AssetRef, AssetError> {
        let spec = self.kind.spec();
        let Some(p) = spec.param(key) else {
            return Err(AssetError::UnknownParam {
                asset: self.kind.name(),
                param: key.into(),
                allowed: spec.allowed(),
            });
        };
        self.params.insert(p.name, validate(self.kind, p, value)?);
        Ok(self)
    }

    /// The explicitly given value of a parameter.
    pub fn given(&self, key: &str) -> Option<&ParamValue> {
        self.params.get(key)
    }

    /// Number parameter: the given value, else its numeric default.
    pub fn number(&self, key: &str) -> Option<f64> {
        match self.params.get(key) {
            Some(ParamValue::Number(v)) => Some(*v),
            Some(ParamValue::Text(_)) => None,
            None => match self.kind.spec().param(key)?.default {
                ParamDefault::Number(v) => Some(v),
                _ => None,
            },
        }
    }

    /// Text parameter (material aliases resolved): the given value, else its text default (aliases
    /// of the default resolved too).
    pub fn text(&self, key: &str) -> Option<Cow<'_, str>> {
        match self.params.get(key) {
            Some(ParamValue::Text(s)) => Some(Cow::Borrowed(s.as_str())),
            Some(ParamValue::Number(_)) => None,
            None => {
                let spec = self.kind.spec().param(key)?;
                match spec.default {
                    ParamDefault::Text(t) => {
                        if let ParamKind::Material(aliases) = spec.kind
                            && let Some((_, m)) = aliases.iter().find(|(a, _)| *a == t)
                        {
                            return Some(Cow::Borrowed(m));
                        }
                        Some(Cow::Borrowed(t))
                    }
                    _ => None,
                }
            }
        }
    }

    /// Path of a user mesh (`mesh` asset).
    pub fn path(&self) -> Option<&Path> {
        match self.params.get("path") {
            Some(ParamValue::Text(p)) if self.kind == AssetKind::Mesh => Some(Path::new(p)),
            _ => None,
        }
    }

    /// The box the mesh is sized to: per axis the explicit `length_m`/`width_m`/`height_m` parameter,
    /// else the OSI dimension (finite, > 0), else the asset's default.
    pub fn target_dimensions(&self, osi: Option<DVec3>) -> DVec3 {
        let mut d = self.kind.default_dimensions();
        if let Some(o) = osi {
            for i in 0..3 {
                if o[i].is_finite() && o[i] > 0.0 {
                    d[i] = o[i];
                }
            }
        }
        let keys = ["length_m", "width_m", "height_m"];
        for (i, k) in keys.iter().enumerate() {
            if let Some(ParamValue::Number(v)) = self.params.get(k) {
                d[i] = *v;
            }
        }
        d
    }
}

impl fmt::Display for AssetRef {
    /// Canonical form: `osiris:<asset>` plus the given parameters sorted by key, numbers in shortest
    /// round-trip form, text percent-encoded.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "osiris:{}", self.kind.name())?;
        for (i, (k, v)) in self.params.iter().enumerate() {
            let sep = if i == 0 { '?' } else { '&' };
            match v {
                ParamValue::Number(x) => write!(f, "{sep}{k}={x}")?,
                ParamValue::Text(s) => write!(f, "{sep}{k}={}", percent_encode(s))?,
            }
        }
        Ok(())
    }
}

impl std::str::FromStr for AssetRef {
    type Err = AssetError;
    fn from_str(s: &str) -> Result<AssetRef, AssetError> {
        AssetRef::parse(s)
    }
}

// ---------------------------------------------------------------------------------------------------
// Building

/// Build the mesh of an asset in its object frame (see the module documentation), sized to the OSI
/// dimension `dims` (length, width, height; `None` or non-positive components: the asset's default).
/// User meshes are read relative to the working directory and matched against the built-in materials.
pub fn build_asset(asset: &AssetRef, dims: Option<DVec3>) -> Result<Mesh, AssetError> {
    build_asset_with(asset, dims, &AssetContext::default())
}

/// [`build_asset`] with a base directory for user meshes and the materials their names may map to.
pub fn build_asset_with(
    asset: &AssetRef,
    dims: Option<DVec3>,
    ctx: &AssetContext<'_>,
) -> Result<Mesh, AssetError> {
    let d = asset.target_dimensions(dims);
    Ok(match asset.kind {
        AssetKind::Car => vehicles::car(asset, d, vehicles::CarShape::Saloon),
        AssetKind::Van => vehicles::car(asset, d, vehicles::CarShape::Van),
        AssetKind::Truck => vehicles::truck(asset, d),
        AssetKind::Bus => vehicles::bus(asset, d),
        AssetKind::Pedestrian => vru::pedestrian(asset, d),
        AssetKind::Cyclist => vru::cyclist(asset, d),
        AssetKind::Motorcycle => vru::motorcycle(asset, d),
        AssetKind::Guardrail => roadside::guardrail(asset, d),
        AssetKind::Pole => roadside::pole(asset, d),
        AssetKind::Cone => roadside::cone(asset, d),
        AssetKind::Trihedral => targets::trihedral(asset, dims.map(|_| d)),
        AssetKind::Board => targets::board(asset, dims),
        AssetKind::Box => targets::solid_box(asset, d),
        AssetKind::Mesh => user::build(asset, dims, ctx)?,
    })
}

/// The phase centre (radar reference point) of an asset in its object frame, for the OSI dimension
/// `dims` as in [`build_asset`]; `None` for assets without a fixed one. See "Phase centres and
/// reference points" in `models/ASSETS.md`:
/// * `trihedral`: the apex (inner corner): every triple-bounce path has the length of the path to the
///   apex and back, so the apex is the phase centre of the reflector's return at any range;
/// * `board`: the centre of the face, the phase centre of its specular return in the far field
///   (R > 2D²/λ, D the face diagonal);
/// * every other asset (vehicles, VRUs, roadside furniture, boxes, user meshes): `None`; their returns
///   come from many aspect-dependent scattering centres, each of which is its own reference point.
pub fn phase_centre(asset: &AssetRef, dims: Option<DVec3>) -> Option<DVec3> {
    match asset.kind {
        AssetKind::Trihedral => Some(targets::trihedral_apex(
            asset,
            dims.map(|_| asset.target_dimensions(dims)),
        )),
        AssetKind::Board => Some(targets::board_face_centre(asset, dims)),
        _ => None,
    }
}

/// The asset tables of `models/ASSETS.md` (Markdown), generated from the specs.
pub fn catalogue_markdown() -> String {
    let mut s = String::new();
    for kind in AssetKind::ALL {
        let spec = kind.spec();
        let [l, w, h] = spec.default_dimensions;
        let mut summary = spec.summary.to_string();
        if let Some(c) = summary.get_mut(..1) {
            c.make_ascii_uppercase();
        }
        s.push_str(&format!("### `{}`\n\n{summary}.\n\n", kind.name()));
        s.push_str(&format!(
            "Default size {l} × {w} × {h} m; sizing: {}.\n\n",
            spec.sizing
        ));
        s.push_str("| parameter | values | default | meaning |\n|---|---|---|---|\n");
        for p in spec.params {
            let values = match p.kind {
                ParamKind::Number { min, max, unit } => {
                    format!("{min} … {max} {unit}").trim_end().to_string()
                }
                ParamKind::Integer { min, max } => format!("{min} … {max}"),
                ParamKind::Choice(v) => v
                    .iter()
                    .map(|x| format!("`{x}`"))
                    .collect::<Vec<_>>()
                    .join(", "),
                ParamKind::Material(a) => {
                    let mut v: Vec<String> =
                        a.iter().map(|(x, m)| format!("`{x}` ({m})")).collect();
                    v.push("material name".into());
                    v.join(", ")
                }
                ParamKind::Path => "path".into(),
            };
            let default = match p.default {
                ParamDefault::Number(v) => format!("{v}"),
                ParamDefault::Text(t) => format!("`{t}`"),
                ParamDefault::Derived(t) => t.to_string(),
            };
            s.push_str(&format!(
                "| `{}` | {values} | {default} | {} |\n",
                p.name, p.doc
            ));
        }
        s.push_str("\n| part | material | what |\n|---|---|---|\n");
        for p in spec.parts {
            s.push_str(&format!("| `{}` | {} | {} |\n", p.name, p.material, p.doc));
        }
        s.push('\n');
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn specs_are_indexed_by_kind() {
        for k in AssetKind::ALL {
            assert_eq!(k.spec().kind, k);
            assert_eq!(AssetKind::from_name(k.name()), Some(k));
        }
    }

    #[test]
    fn defaults_are_valid_values() {
        for k in AssetKind::ALL {
            for p in k.spec().params {
                match p.default {
                    ParamDefault::Number(v) => {
                        assert!(
                            validate(k, p, &v.to_string()).is_ok(),
                            "{} {}",
                            k.name(),
                            p.name
                        )
                    }
                    ParamDefault::Text(t) => {
                        assert!(validate(k, p, t).is_ok(), "{} {}", k.name(), p.name)
                    }
                    ParamDefault::Derived(_) => {}
                }
            }
        }
    }

    #[test]
    fn lenient_accessors() {
        let r = "osiris:board?width_m=1&material=lambertian_50&note=a%20b";
        assert_eq!(model_reference_name(r), Some("board"));
        assert_eq!(
            model_reference_param(r, "material").as_deref(),
            Some("lambertian_50")
        );
        assert_eq!(model_reference_param(r, "note").as_deref(), Some("a b"));
        assert_eq!(model_reference_param(r, "paint"), None);
        assert_eq!(model_reference_name("OSIRIS:truck"), Some("truck"));
        assert_eq!(model_reference_name("car.obj"), None);
    }

    #[test]
    fn percent_coding_round_trip() {
        let s = "dir with space/ä&b=c%.obj";
        assert_eq!(percent_decode(&percent_encode(s)).unwrap(), s);
        assert!(percent_decode("%4").is_err());
        assert!(percent_decode("%zz").is_err());
        assert!(percent_decode("%ff").is_err()); // not UTF-8
    }
}
