//! Radar propagation: ray-traced paths from the space-design layer → [`PathReturn`]s.
//!
//! # Method: shooting and bouncing rays + physical optics (SBR-PO)
//!
//! Ling, Chou & Lee, "Shooting and bouncing rays: calculating the RCS of an arbitrarily shaped
//! cavity", IEEE TAP 37(2):194–205, 1989.
//!
//! * **Launch.** For every target (moving object, stationary object) inside the field of view a grid of
//!   ray tubes is launched from the radar over the target's angular extent. The angular spacing is
//!   `Δθ = Δ / R_near` with `Δ = min(tube_spacing_m, smallest target extent / min_tubes_across)`, so
//!   a tube's cross-section at the target is about `Δ × Δ`; the total is capped at `max_tubes`
//!   (spacings grow uniformly). The default `Δ` = 2 cm ≈ 5 λ at 77 GHz: the aperture factor below
//!   integrates the phase across a tube footprint (linear on a flat facet, with the quadratic
//!   curvature term on a smooth surface), so Δ need not be below λ.
//! * **Smooth surfaces** (physics.md §1.8). Where a mesh approximates a curved surface (corner
//!   normals within the 46° crease angle of each other, [`CREASE_ANGLE_DEG`]) a hit is moved to the
//!   half-strength Phong surface of its triangle and uses the interpolated normal for the
//!   reflection, the Fresnel angle and the footprint; the footprint's quadratic phase comes from the
//!   interpolated normal's derivative. A tessellated sphere of radius a then returns σ = πa² and a
//!   doubly curved body σ = π·a₁·a₂, independent of range, instead of each facet's mirror return.
//! * **Bounce.** Each tube is traced with `closest_hit`; a tube of target `j` whose first reflecting
//!   surface is not on `j` is dropped (that surface belongs to another target's grid). At every hit
//!   the field vector is reflected with the polarisation-aware coefficients Γ_TE, Γ_TM of the
//!   material (`Material::reflection_mmwave`; a conductor gives −1/+1) in the s/p basis
//!   (`s = d × n`, `p = s × d`) and the tube continues along `r = d − 2(d·n)n` (up to
//!   `max_bounces`; one with `space.multipath` off). Slabs that transmit more than they reflect (glass, bumpers:
//!   `Material::transmission_mmwave`, `space.transmission`) are crossed: the field is multiplied by
//!   T_TE, T_TM, the return by the same effective co-polar coefficient (reciprocity, same
//!   surfaces on the way back); a slab of the target itself also scatters its Γ back to the radar.
//! * **Scattering (PO).** At every hit, the tube's contribution back to the radar (direction `o`) is
//!   `√σ_t = (√(4π)/λ) · A_t · S · (E_r · p_rx)`, with `A_t` the tube cross-section at the hit
//!   (grows with the unfolded path length), `E_r` the reflected unit field, `p_rx` the receive
//!   polarisation and `S = sinc(g·u_s/2) sinc(g·v_s/2)` the aperture factor of the tube's footprint
//!   (`g = k(d − o)`, `u_s`, `v_s` the footprint edge vectors): 1 for a specular return, the exact
//!   PO integral over a flat footprint otherwise. For a plate at normal incidence Σ√σ_t = √(4π)A/λ
//!   (σ = 4πA²/λ²); for a triangular trihedral at boresight the triple-bounce tubes fill the
//!   effective aperture a²/√3 in phase (σ = 4πa⁴/(3λ²); Knott, *Radar Cross Section* 2nd ed.).
//! * **Radar equation.** Each tube's complex amplitude at the receiver is
//!   `a_t = √(P_t G_t(DoD) G_r(DoA) λ² / ((4π)³ L_sys)) · √σ_t / (R_out R_back) · √L_atm · e^{jkL}`
//!   (physics.md §1.1; `R_out R_back = R²` for a monostatic single bounce).
//! * **Scattering centres.** Contributions are summed coherently per (object, bounce count, cube of
//!   `cluster_size_m`) at their amplitude-weighted centroid: one [`PathReturn`] each, with the
//!   phase beyond `4πR/λ` kept in the amplitude.
//! * **Ground multipath** (image method, physics.md §1.3): every scattering centre above the road
//!   gets the image paths DG, GD (one leg via the road) and GG with the road's Fresnel coefficient
//!   at the grazing angle; tubes that hit the road are not traced further: the road's specular
//!   part enters through the images, its own diffuse backscatter as road clutter (below).
//!   The image is that of the centre's phase centre: for a mostly multiple-bounce centre of an
//!   object whose asset has a fixed one, that point (a trihedral's apex,
//!   [`crate::environment::assets::phase_centre`]); else the point at the centre's path range along
//!   its hit-point centroid (the centroid itself for single reflections).
//! * **Diffuse scattering** (`radar.diffuse_scattering`, physics.md §1.9): on a rough surface
//!   (material `roughness_m` σ_h) the Ament factor takes (1 − χ²) of the coherent power; that part
//!   is scattered by Lambert's law, σ⁰ = 4ρ cos²θ with ρ = (1 − χ²)|Γ|². Every tube's first hit on
//!   its target adds σ_t = σ⁰·A_t/cos θ with a complex Gaussian amplitude (seeded per cycle and
//!   tube) to its scattering centre.
//! * **Road clutter** (`radar.road_clutter`, physics.md §1.9): a polar grid of road cells in the
//!   field of view, one ray each (shadowed cells return nothing), each one path of
//!   σ = γ sin ψ · A_cell (constant-γ model), Rayleigh amplitude, stationary Doppler.
//!
//! Cost: one `closest_hit` per tube and interaction (≤ `max_bounces` + crossings), tubes in
//! parallel (rayon, fixed output slots per tube, so the sums are deterministic), contributions
//! sorted by (key, tube) and reduced; all buffers are reused between frames.

use crate::constants::SPEED_OF_LIGHT_M_S;
use std::f64::consts::PI;

use glam::{DMat3, DVec3};
use num_complex::Complex64;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use super::PathReturn;
use super::antenna::{Antennas, FrontEndConfig, Polarisation};
use crate::effects::{EffectInfo, Effects};
use crate::environment::material::{MaterialEffects, Polarisation as PlanePol};
use crate::environment::scene::{Scene, StaticElement};
use crate::environment::weather::{self, FOG_EXTINCTION as ENV_FOG, Weather};
use crate::error::ModelError;
use crate::rng::splitmix64;
use crate::space::{Hit, Ray, Space};
use crate::world::WorldFrame;

/// `radar.two_way_spreading`: the 1/(R_out² R_back²) spreading of the radar equation.
pub const TWO_WAY_SPREADING: EffectInfo = EffectInfo {
    name: "radar.two_way_spreading",
    default_on: true,
    summary: "two-way spherical spreading P_r = P_t G_t G_r λ² σ / ((4π)³ R⁴ L) (R⁴ = R_out² R_back² per \
              path); off: R⁴ replaced by the fixed reference R₀⁴ (`propagation.reference_range_m`), to isolate \
              the spreading law in consistency studies",
    source: "Skolnik, Radar Handbook 3rd ed. ch. 1; Richards, Scheer & Holm, Principles of Modern Radar (2010) \
             ch. 2 (physics.md §1.1)",
    requires: None,
};

/// `radar.rcs_area_scaling`: physical-optics scattering amplitude of extended surfaces.
pub const RCS_AREA_SCALING: EffectInfo = EffectInfo {
    name: "radar.rcs_area_scaling",
    default_on: true,
    summary: "SBR + physical optics: √σ = Σ_tubes (√(4π)/λ)·A_t·S·e^{jkL} (flat plate σ = 4πA²/λ², \
              triangular trihedral 4πa⁴/(3λ²)); off: each object is one point scatterer of constant RCS \
              `propagation.point_rcs_dbsm` at its contribution-weighted centroid",
    source: "Ling, Chou & Lee, IEEE TAP 37(2):194, 1989 (SBR); Knott, Shaeffer & Tuley, Radar Cross Section \
             2nd ed. (2004) (physics.md §1.2)",
    requires: None,
};

/// `radar.ground_multipath`: the road's image paths (two-ray model).
pub const GROUND_MULTIPATH: EffectInfo = EffectInfo {
    name: "radar.ground_multipath",
    default_on: true,
    summary: "road multipath by the image method: paths DD, DG, GD, GG of each scattering centre's phase centre \
              (its asset's where it has a fixed one and the return is multiple-bounce, e.g. a trihedral's apex; \
              else the hit-point centroid, at the path range) with the road Fresnel coefficient Γ(ψ) at the \
              grazing angle, one-way F = 1 + Γ(g_img/g_dir)(R_d/R_g)e^{−jkΔR}, point-target power ∝ |F|⁴; off: \
              direct paths only",
    source: "Rappaport, Wireless Communications §4.6; Richards et al., Principles of Modern Radar ch. 4 \
             (physics.md §1.3); phase centres: models/ASSETS.md",
    requires: None,
};

/// `radar.multipath`: multi-bounce paths between different objects (ghosts).
pub const MULTIPATH: EffectInfo = EffectInfo {
    name: "radar.multipath",
    default_on: true,
    summary: "multi-bounce SBR paths between different objects and the static world (e.g. guardrail → car \
              → radar ghosts behind the guardrail), specular r = d − 2(d·n)n with Fresnel Γ per bounce; off: a \
              tube stops when it would leave the object it hit first (intra-object bounces, e.g. a corner \
              reflector's, stay part of that object's RCS)",
    source: "Ling, Chou & Lee, IEEE TAP 37(2):194, 1989; geometric optics image method",
    requires: None,
};

/// `radar.rain_attenuation`: two-way P.838-3 rain attenuation.
pub const RAIN_ATTENUATION: EffectInfo = EffectInfo {
    name: "radar.rain_attenuation",
    default_on: true,
    summary: "rain attenuation over the path, 10^(−γ_R·L/10) with γ_R = k R^α dB/km (P.838-3, k, α for the \
              radar's H or V polarisation) and L the total (two-way) path length; also needs \
              `env.rain_extinction`",
    source: "ITU-R P.838-3 (physics.md §1.4)",
    requires: Some("env.rain_extinction"),
};

/// `radar.atmospheric_absorption`: two-way gaseous absorption.
pub const ATMOSPHERIC_ABSORPTION: EffectInfo = EffectInfo {
    name: "radar.atmospheric_absorption",
    default_on: true,
    summary: "O₂ + H₂O absorption over the two-way path, 10^(−γ_gas·L/10), γ ≈ 0.35 dB/km at 77 GHz; also \
              needs `env.atmospheric_absorption`",
    source: "ITU-R P.676-12 (physics.md §1.5)",
    requires: Some("env.atmospheric_absorption"),
};

/// `radar.micro_doppler`: wheel rotation.
pub const MICRO_DOPPLER: EffectInfo = EffectInfo {
    name: "radar.micro_doppler",
    default_on: true,
    summary: "rotating wheels: points on a vehicle's `wheels` part move with v_body + ω_w × (p − c_axle), \
              ω_w = v_forward / r_wheel about the axle (0 at the contact patch, 2v at the top), spreading the \
              Doppler of the wheels; off: rigid-body velocity",
    source: "V. C. Chen, The Micro-Doppler Effect in Radar (Artech House, 2011) ch. 2",
    requires: None,
};

/// `radar.road_clutter`: diffuse backscatter of the road surface (stationary clutter).
pub const ROAD_CLUTTER: EffectInfo = EffectInfo {
    name: "radar.road_clutter",
    default_on: true,
    summary: "diffuse backscatter of the road: a polar grid of road cells in the field of view (one \
              `closest_hit` each: cells behind an object are shadowed) returns σ = σ⁰(ψ)·A_cell with the \
              constant-γ model σ⁰ = γ·sin ψ (ψ the grazing angle of the cell's ray on the road), a \
              Rayleigh amplitude (complex Gaussian, seeded per cycle and cell) and the Doppler of a \
              stationary point; off: the road returns only through the image paths",
    source: "constant-γ clutter model: Barton, Radar Equations for Modern Radar (2013) ch. 9; Nathanson, \
             Radar Design Principles 2nd ed. (1991) ch. 7; γ of asphalt at 77 GHz: estimate from the \
             near-grazing road levels of Li & Sarabandi, IEEE TAP 47(5):851, 1999 (physics.md §1.9)",
    requires: None,
};

/// `radar.diffuse_scattering`: the incoherent rough-surface term of object surfaces.
pub const DIFFUSE_SCATTERING: EffectInfo = EffectInfo {
    name: "radar.diffuse_scattering",
    default_on: true,
    summary: "incoherent scattering of rough object surfaces: the power the Ament factor takes from the \
              coherent reflection, ρ(θ) = (1 − e^{−4(kσ_h cos θ)²})·|Γ(θ)|², is scattered by Lambert's law, \
              σ⁰ = 4ρ cos²θ; every tube's first hit adds √(σ⁰·A_t/cos θ) with a complex Gaussian (Rayleigh) \
              amplitude to its scattering centre; also needs `space.mmwave_roughness`; off: coherent \
              (PO) scattering only",
    source: "Beckmann & Spizzichino, The Scattering of Electromagnetic Waves from Rough Surfaces (1963); \
             Ulaby, Moore & Fung, Microwave Remote Sensing vol. II (1982) ch. 12 (coherent / incoherent \
             split, Lambert's law) (physics.md §1.9)",
    requires: Some("space.mmwave_roughness"),
};

/// Effects declared by this module.
pub const EFFECTS: &[EffectInfo] = &[
    TWO_WAY_SPREADING,
    RCS_AREA_SCALING,
    GROUND_MULTIPATH,
    MULTIPATH,
    RAIN_ATTENUATION,
    ATMOSPHERIC_ABSORPTION,
    MICRO_DOPPLER,
    ROAD_CLUTTER,
    DIFFUSE_SCATTERING,
];

/// Ray-tube launching and grouping parameters (`radar.propagation`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct PropagationConfig {
    /// Nominal ray-tube spacing at the target, m (see the module doc for the choice of 2 cm).
    pub tube_spacing_m: f64,
    /// At least this many tubes across a target's smallest extent (small targets get finer tubes).
    pub min_tubes_across: f64,
    /// Upper bound on tubes per frame (spacings grow uniformly beyond it).
    pub max_tubes: usize,
    /// Maximum reflections per tube (3 covers a trihedral).
    pub max_bounces: u32,
    /// Edge of the cubes tube contributions are summed in (one scattering centre each), m.
    pub cluster_size_m: f64,
    /// At most this many paths per frame: every object's strongest scattering centre first, then
    /// the strongest others (the baseband's cost grows with the path count).
    pub max_paths: usize,
    /// Scattering centres weaker than this at the receiver input are dropped, dBm.
    pub min_power_dbm: f64,
    /// RCS of an object with `radar.rcs_area_scaling` off, dBsm (10 dBsm: a car, physics.md §1.2).
    pub point_rcs_dbsm: f64,
    /// R₀ of `radar.two_way_spreading` off, m.
    pub reference_range_m: f64,
    /// γ of the road's constant-γ clutter model σ⁰ = γ·sin ψ (`radar.road_clutter`), dB (−20 dB:
    /// estimate for asphalt at 77 GHz, physics.md §1.9).
    pub clutter_gamma_db: f64,
    /// Ground-range size of a road clutter cell, m.
    pub clutter_cell_m: f64,
    /// Azimuth size of a road clutter cell, deg.
    pub clutter_cell_deg: f64,
    /// Road clutter cells extend to this ground range (or the sensor range if smaller), m.
    pub clutter_max_range_m: f64,
    /// At most this many clutter cells per frame (both cell sizes grow uniformly beyond it): each
    /// cell is one path for the baseband.
    pub clutter_max_cells: usize,
}

impl Default for PropagationConfig {
    fn default() -> Self {
        PropagationConfig {
            tube_spacing_m: 0.02,
            min_tubes_across: 24.0,
            max_tubes: 25_000,
            max_bounces: 3,
            cluster_size_m: 0.15,
            max_paths: 600,
            min_power_dbm: -180.0,
            point_rcs_dbsm: 10.0,
            reference_range_m: 10.0,
            clutter_gamma_db: -20.0,
            clutter_cell_m: 0.5,
            clutter_cell_deg: 2.0,
            clutter_max_range_m: 60.0,
            clutter_max_cells: 1500,
        }
    }
}

impl PropagationConfig {
    /// Check the values; errors name the key (`radar.propagation.<key>`).
    pub fn validate(&self) -> Result<(), ModelError> {
        let pos = |k: &str, v: f64| {
            if v.is_finite() && v > 0.0 {
                Ok(())
            } else {
                Err(ModelError::Config(format!(
                    "`radar.propagation.{k}` must be a positive number, got {v}"
                )))
            }
        };
        pos("tube_spacing_m", self.tube_spacing_m)?;
        pos("min_tubes_across", self.min_tubes_across)?;
        pos("cluster_size_m", self.cluster_size_m)?;
        pos("reference_range_m", self.reference_range_m)?;
        pos("clutter_cell_m", self.clutter_cell_m)?;
        pos("clutter_cell_deg", self.clutter_cell_deg)?;
        pos("clutter_max_range_m", self.clutter_max_range_m)?;
        for (k, v) in [
            ("clutter_max_cells", self.clutter_max_cells),
            ("max_tubes", self.max_tubes),
            ("max_paths", self.max_paths),
            ("max_bounces", self.max_bounces as usize),
        ] {
            if v == 0 {
                return Err(ModelError::Config(format!(
                    "`radar.propagation.{k}` must be at least 1"
                )));
            }
        }
        if self.max_bounces > 8 {
            return Err(ModelError::Config(format!(
                "`radar.propagation.max_bounces` must be at most 8, got {}",
                self.max_bounces
            )));
        }
        for (k, v) in [
            ("min_power_dbm", self.min_power_dbm),
            ("point_rcs_dbsm", self.point_rcs_dbsm),
            ("clutter_gamma_db", self.clutter_gamma_db),
        ] {
            if !v.is_finite() {
                return Err(ModelError::Config(format!(
                    "`radar.propagation.{k}` must be finite, got {v}"
                )));
            }
        }
        Ok(())
    }
}

/// Effect switches the propagation applies.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Switches {
    spreading: bool,
    area_scaling: bool,
    ground: bool,
    multipath: bool,
    rain: bool,
    gas: bool,
    fog: bool,
    micro_doppler: bool,
    road_clutter: bool,
    diffuse: bool,
    material: MaterialEffects,
}

/// A launched ray tube.
#[derive(Debug, Clone, Copy)]
struct Tube {
    direction: DVec3,
    /// Cross-section axes (unit, ⊥ direction).
    u: DVec3,
    v: DVec3,
    /// Cross-section side lengths per metre of unfolded path length (angular spacings), rad.
    su: f64,
    sv: f64,
    /// The target the tube was launched at.
    target: Owner,
}

/// Who a surface belongs to.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Owner {
    /// Moving object instance (object id).
    Object(u64),
    /// Stationary object in the static world.
    Stationary(u64),
    /// Road surface / markings.
    Road,
    /// Anything else.
    Other,
}

impl Owner {
    fn object_id(self) -> u64 {
        match self {
            Owner::Object(i) | Owner::Stationary(i) => i,
            _ => osiris_proto::INVALID_ID,
        }
    }
}

/// One tube's contribution at one hit.
#[derive(Debug, Clone, Copy)]
struct Contribution {
    key: u128,
    /// Complex amplitude at the receiver incl. e^{jkL}, √W.
    amplitude: Complex64,
    /// Last hit point (scene frame).
    point: DVec3,
    /// Total path length, m.
    length_m: f64,
    /// Rate of the total path length, m/s.
    length_rate_m_s: f64,
    /// Departure direction (scene frame, unit).
    departure: DVec3,
    /// Velocity of the last hit point, m/s.
    velocity: DVec3,
    object_id: u64,
    /// Reflections on the path (1: single bounce).
    bounces: u32,
    /// Tube index × max bounces + slot: a total order within a key (deterministic sums).
    order: u64,
}

const EMPTY_KEY: u128 = u128::MAX;

impl Contribution {
    const EMPTY: Contribution = Contribution {
        key: EMPTY_KEY,
        amplitude: Complex64::new(0.0, 0.0),
        point: DVec3::ZERO,
        length_m: 0.0,
        length_rate_m_s: 0.0,
        departure: DVec3::ZERO,
        velocity: DVec3::ZERO,
        object_id: 0,
        bounces: 0,
        order: 0,
    };
}

/// Wheel geometry of a mesh (mesh frame).
#[derive(Debug, Clone, Copy)]
struct Wheels {
    part: u16,
    radius_m: f64,
    axle_z_m: f64,
    front_x_m: f64,
    rear_x_m: f64,
}

/// A scattering centre before the ground images.
#[derive(Debug, Clone, Copy)]
struct Centre {
    amplitude: Complex64,
    point: DVec3,
    range_m: f64,
    rate_m_s: f64,
    departure: DVec3,
    velocity: DVec3,
    object_id: u64,
    power_w: f64,
    /// The strongest centre of its object (kept first when paths are capped).
    leading: bool,
    /// Mostly (by amplitude) multiple-bounce paths: the last hit points are not where the path's
    /// phase is referenced (see [`Propagator::ground_images`]).
    multi_bounce: bool,
}

/// Crease angle of the interpolated normals: triangles sharing a vertex whose normals differ by
/// less than this are treated as facets of one smooth surface (a polygon of ≥ 8 sides, a tessellated
/// sphere, torus or lofted body); larger angles (a box's edges, a trihedral's plates) stay creases.
pub const CREASE_ANGLE_DEG: f64 = 46.0;

/// Interpolated corner normals of a mesh for the radar's smooth-surface physical optics
/// (physics.md §1.8): for every triangle corner, the angle-weighted mean of the geometric normals
/// of the triangles around that vertex (shared vertex index) within [`CREASE_ANGLE_DEG`] of the
/// triangle's own; `None` for a triangle whose corner normals all equal its own (flat).
#[derive(Debug, Clone, Default)]
struct SmoothNormals {
    /// Index into `normals` per triangle (`u32::MAX`: flat).
    slot: Vec<u32>,
    normals: Vec<[glam::Vec3; 3]>,
}

impl SmoothNormals {
    fn new(mesh: &crate::environment::mesh::Mesh) -> SmoothNormals {
        let nt = mesh.triangles.len();
        let nv = mesh.positions.len();
        let mut facet = Vec::with_capacity(nt);
        let mut angle = Vec::with_capacity(nt);
        for t in 0..nt {
            let tri = mesh.triangles[t];
            if tri.iter().any(|&i| i as usize >= nv) {
                facet.push(DVec3::ZERO);
                angle.push([0.0; 3]);
                continue;
            }
            let p = mesh.triangle(t).map(|v| v.as_dvec3());
            facet.push((p[1] - p[0]).cross(p[2] - p[0]).normalize_or_zero());
            angle.push(std::array::from_fn(|k| {
                let (e1, e2) = (p[(k + 1) % 3] - p[k], p[(k + 2) % 3] - p[k]);
                let a = e1.angle_between(e2);
                if a.is_finite() { a } else { 0.0 }
            }));
        }
        // Triangles around each vertex (CSR).
        let mut start = vec![0u32; nv + 1];
        for tri in &mesh.triangles {
            for &i in tri {
                if (i as usize) < nv {
                    start[i as usize + 1] += 1;
                }
            }
        }
        for i in 0..nv {
            start[i + 1] += start[i];
        }
        let mut fill = start.clone();
        let mut around = vec![0u32; start[nv] as usize];
        for (t, tri) in mesh.triangles.iter().enumerate() {
            for &i in tri {
                if (i as usize) < nv {
                    around[fill[i as usize] as usize] = t as u32;
                    fill[i as usize] += 1;
                }
            }
        }
        let cos_crease = CREASE_ANGLE_DEG.to_radians().cos();
        let mut out = SmoothNormals {
            slot: vec![u32::MAX; nt],
            normals: Vec::new(),
        };
        for t in 0..nt {
            let nf = facet[t];
            if nf == DVec3::ZERO {
                continue;
            }
            let mut corners = [glam::Vec3::ZERO; 3];
            let mut curved = false;
            for (k, &vi) in mesh.triangles[t].iter().enumerate() {
                let vi = vi as usize;
                let mut sum = DVec3::ZERO;
                for &o in &around[start[vi] as usize..start[vi + 1] as usize] {
                    let o = o as usize;
                    let no = facet[o];
                    if no.dot(nf) < cos_crease {
                        continue;
                    }
                    let corner = mesh.triangles[o].iter().position(|&j| j as usize == vi);
                    let w = corner.map_or(0.0, |c| angle[o][c]);
                    sum += no * w;
                }
                let n = sum.normalize_or_zero();
                let n = if n == DVec3::ZERO { nf } else { n };
                if n.dot(nf) < 1.0 - 1e-9 {
                    curved = true;
                }
                corners[k] = n.as_vec3();
            }
            if curved {
                out.slot[t] = out.normals.len() as u32;
                out.normals.push(corners);
            }
        }
        out
    }

    fn corner_normals(&self, t: usize) -> Option<&[glam::Vec3; 3]> {
        let s = *self.slot.get(t)?;
        (s != u32::MAX).then(|| &self.normals[s as usize])
    }
}

/// Incidence-angle samples of the coefficient tables (0 … 90° in 0.25° steps).
const COEFF_SAMPLES: usize = 361;

/// A material's mm-wave coefficients at the carrier under the effect switches, tabulated against
/// the incidence angle (evaluating the multilayer stack per hit is the propagation's most
/// expensive arithmetic): `[Γ_TE, Γ_TM, T_TE, T_TM]` (T = 0 for opaque materials), linearly
/// interpolated.
struct Coefficients {
    slab: bool,
    table: Vec<[Complex64; 4]>,
    /// Diffuse albedo ρ(θ) = (1 − χ²)·½(|Γ_TE|² + |Γ_TM|²) of `radar.diffuse_scattering`: the power
    /// fraction the Ament factor χ takes from the smooth-surface reflection (0 with
    /// `space.mmwave_roughness` off).
    albedo: Vec<f64>,
}

impl Coefficients {
    fn new(
        mat: &crate::environment::material::Material,
        freq_hz: f64,
        fx: &MaterialEffects,
    ) -> Coefficients {
        let zero = Complex64::new(0.0, 0.0);
        let table = (0..COEFF_SAMPLES)
            .map(|i| {
                let th = (i as f64 / (COEFF_SAMPLES - 1) as f64) * 0.5 * PI;
                [
                    mat.reflection_mmwave(freq_hz, th, PlanePol::Te, fx),
                    mat.reflection_mmwave(freq_hz, th, PlanePol::Tm, fx),
                    mat.transmission_mmwave(freq_hz, th, PlanePol::Te)
                        .unwrap_or(zero),
                    mat.transmission_mmwave(freq_hz, th, PlanePol::Tm)
                        .unwrap_or(zero),
                ]
            })
            .collect();
        let smooth = MaterialEffects {
            mmwave_roughness: false,
            ..*fx
        };
        let albedo = (0..COEFF_SAMPLES)
            .map(|i| {
                if !fx.mmwave_roughness {
                    return 0.0;
                }
                let th = (i as f64 / (COEFF_SAMPLES - 1) as f64) * 0.5 * PI;
                let chi = mat.ament_factor(freq_hz, th);
                let r = 0.5
                    * (mat
                        .reflection_mmwave(freq_hz, th, PlanePol::Te, &smooth)
                        .norm_sqr()
                        + mat
                            .reflection_mmwave(freq_hz, th, PlanePol::Tm, &smooth)
                            .norm_sqr());
                (1.0 - chi * chi) * r
            })
            .collect();
        Coefficients {
            slab: mat.mmwave.is_slab(),
            table,
            albedo,
        }
    }

    fn albedo_at(&self, incidence_rad: f64) -> f64 {
        let x = (incidence_rad / (0.5 * PI)).clamp(0.0, 1.0) * (COEFF_SAMPLES - 1) as f64;
        let i = (x.floor() as usize).min(COEFF_SAMPLES - 2);
        let f = x - i as f64;
        self.albedo[i] * (1.0 - f) + self.albedo[i + 1] * f
    }

    fn at(&self, incidence_rad: f64) -> [Complex64; 4] {
        let x = (incidence_rad / (0.5 * PI)).clamp(0.0, 1.0) * (COEFF_SAMPLES - 1) as f64;
        let i = (x.floor() as usize).min(COEFF_SAMPLES - 2);
        let f = x - i as f64;
        let (a, b) = (&self.table[i], &self.table[i + 1]);
        std::array::from_fn(|k| a[k] * (1.0 - f) + b[k] * f)
    }
}

/// Per-frame constants shared by the tube loop.
struct FrameCtx<'a> {
    space: &'a Space,
    scene: &'a Scene,
    origin: DVec3,
    sensor_velocity: DVec3,
    sensor_rotation: DMat3,
    /// Sensor rotation transposed (scene → sensor).
    to_sensor: DMat3,
    /// Power extinction, Np/m (power) over the total path.
    extinction_per_m: f64,
    max_range_m: f64,
    /// Seed of this cycle's random draws (diffuse and clutter amplitudes).
    seed: u64,
}

/// A pair of independent standard normal deviates from the hash `h` (Box–Muller on two 53-bit
/// uniforms of SplitMix64): the random draws of one diffuse contribution or clutter cell, the same
/// for the same seed whatever the thread count.
fn gaussian_pair(h: u64) -> (f64, f64) {
    let a = splitmix64(h);
    let b = splitmix64(a ^ 0xD1B5_4A32_D192_ED03);
    let u1 = ((a >> 11) as f64 + 0.5) / (1u64 << 53) as f64;
    let u2 = (b >> 11) as f64 / (1u64 << 53) as f64;
    let r = (-2.0 * u1.ln()).sqrt();
    let (s, c) = (2.0 * PI * u2).sin_cos();
    (r * c, r * s)
}

/// The radar propagation of one model instance (planned once, buffers reused).
pub struct Propagator {
    cfg: PropagationConfig,
    sw: Switches,
    antennas: Antennas,
    polarisation: Polarisation,
    freq_hz: f64,
    lambda_m: f64,
    /// √(P_t λ² / ((4π)³ L_sys)), √W·m (gains applied per tube).
    amp_const: f64,
    tubes: Vec<Tube>,
    contributions: Vec<Contribution>,
    centres: Vec<Centre>,
    wheels: Vec<Option<Wheels>>,
    /// Interpolated corner normals per mesh of the scene (see [`SmoothNormals`]).
    smooth: Vec<SmoothNormals>,
    /// The same for the static world (rebuilt with `static_revision`).
    smooth_static: SmoothNormals,
    stationary: Vec<(u64, DVec3, DVec3)>,
    static_revision: u64,
    /// Coefficient tables per material id (see [`Coefficients`]), built for the materials in use.
    coefficients: Vec<Option<Box<Coefficients>>>,
    /// Materials-database size the tables were built for.
    coefficients_db_len: usize,
    /// Per-frame scratch: targets, their angular windows, tube counts.
    targets: Vec<(Owner, DVec3, DVec3)>,
    windows: Vec<(Owner, [f64; 5])>,
    counts: Vec<f64>,
    /// Road clutter cells of the frame (fixed slots, reused).
    clutter: Vec<Option<PathReturn>>,
    /// Tubes launched in the last frame.
    pub last_tube_count: usize,
}

/// Scene-frame box of a moving instance.
fn instance_box(scene: &Scene, i: usize) -> Option<(DVec3, DVec3)> {
    let inst = &scene.instances[i];
    let (lo, hi) = scene.meshes[inst.mesh].mesh.bounds()?;
    let (lo, hi) = (lo.as_dvec3(), hi.as_dvec3());
    let mut a = DVec3::splat(f64::INFINITY);
    let mut b = DVec3::splat(f64::NEG_INFINITY);
    for k in 0..8 {
        let c = DVec3::new(
            if k & 1 == 0 { lo.x } else { hi.x },
            if k & 2 == 0 { lo.y } else { hi.y },
            if k & 4 == 0 { lo.z } else { hi.z },
        );
        let p = inst.pose_local.transform_point(c);
        a = a.min(p);
        b = b.max(p);
    }
    Some((a, b))
}

fn sinc(x: f64) -> f64 {
    if x.abs() < 1e-6 { 1.0 } else { x.sin() / x }
}

/// Any unit vector ⊥ `d`.
fn perpendicular(d: DVec3) -> DVec3 {
    let a = if d.z.abs() < 0.9 { DVec3::Z } else { DVec3::X };
    d.cross(a).normalize()
}

fn reflect(v: DVec3, n: DVec3) -> DVec3 {
    v - 2.0 * v.dot(n) * n
}

/// Complex 3-vector (field).
type CVec = [Complex64; 3];

fn cdot(e: &CVec, r: DVec3) -> Complex64 {
    e[0] * r.x + e[1] * r.y + e[2] * r.z
}

fn cscale(r: DVec3, a: Complex64) -> CVec {
    [a * r.x, a * r.y, a * r.z]
}

fn cadd(a: CVec, b: CVec) -> CVec {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}

/// Sensor-frame azimuth and elevation of a scene-frame direction.
fn az_el(to_sensor: &DMat3, d: DVec3) -> (f64, f64) {
    let s = *to_sensor * d;
    (s.y.atan2(s.x), s.z.atan2(s.x.hypot(s.y)))
}

impl Propagator {
    /// Plan the propagation (effects must declare the radar and environment effects).
    pub fn new(
        cfg: &PropagationConfig,
        front_end: &FrontEndConfig,
        carrier_frequency_hz: f64,
        effects: &Effects,
    ) -> Result<Propagator, ModelError> {
        cfg.validate()?;
        front_end.validate()?;
        if !(carrier_frequency_hz.is_finite() && carrier_frequency_hz > 1e9) {
            return Err(ModelError::Config(format!(
                "`radar.waveform.carrier_frequency_hz` must be > 1 GHz, got {carrier_frequency_hz}"
            )));
        }
        let lambda = SPEED_OF_LIGHT_M_S / carrier_frequency_hz;
        let l_sys = 10f64.powf(front_end.system_losses_db / 10.0);
        let amp_const =
            (front_end.tx_power_w() * lambda * lambda / ((4.0 * PI).powi(3) * l_sys)).sqrt();
        Ok(Propagator {
            cfg: cfg.clone(),
            sw: Switches {
                spreading: effects.is_on(&TWO_WAY_SPREADING),
                area_scaling: effects.is_on(&RCS_AREA_SCALING),
                ground: effects.is_on(&GROUND_MULTIPATH),
                multipath: effects.is_on(&MULTIPATH),
                rain: effects.is_on(&RAIN_ATTENUATION),
                gas: effects.is_on(&ATMOSPHERIC_ABSORPTION),
                fog: effects.is_on(&ENV_FOG),
                micro_doppler: effects.is_on(&MICRO_DOPPLER),
                road_clutter: effects.is_on(&ROAD_CLUTTER),
                diffuse: effects.is_on(&DIFFUSE_SCATTERING),
                material: MaterialEffects::from_effects(effects),
            },
            antennas: Antennas::new(front_end, effects),
            polarisation: front_end.polarisation,
            freq_hz: carrier_frequency_hz,
            lambda_m: lambda,
            amp_const,
            tubes: Vec::new(),
            contributions: Vec::new(),
            centres: Vec::new(),
            wheels: Vec::new(),
            smooth: Vec::new(),
            smooth_static: SmoothNormals::default(),
            stationary: Vec::new(),
            static_revision: u64::MAX,
            coefficients: Vec::new(),
            coefficients_db_len: 0,
            targets: Vec::new(),
            windows: Vec::new(),
            counts: Vec::new(),
            clutter: Vec::new(),
            last_tube_count: 0,
        })
    }

    /// Wavelength at the carrier, m.
    pub fn wavelength_m(&self) -> f64 {
        self.lambda_m
    }

    /// Two-way power extinction coefficient of `weather` applied per metre of total path, 1/m
    /// (fog via `env.fog_extinction`, rain via `radar.rain_attenuation` with the P.838-3
    /// coefficients of the configured polarisation, gases via `radar.atmospheric_absorption`).
    pub fn extinction_per_m(&self, weather: &Weather) -> f64 {
        let tilt = match self.polarisation {
            Polarisation::H => 0.0,
            Polarisation::V => 90.0,
        };
        let mut db_km = 0.0;
        if self.sw.rain {
            db_km += weather::rain_attenuation_mmwave_db_per_km(
                weather.rain_mm_h,
                self.freq_hz,
                0.0,
                tilt,
            );
        }
        if self.sw.gas {
            db_km += weather::gas_attenuation_mmwave_db_per_km(
                self.freq_hz,
                weather.water_vapour_g_m3(),
            );
        }
        if self.sw.fog {
            db_km += weather::fog_attenuation_mmwave_db_per_km(
                weather.fog_visibility_m,
                self.freq_hz,
                weather.temperature_c,
            );
        }
        weather::db_per_km_to_per_m(db_km)
    }

    /// Receive / transmit polarisation unit vector for a wave travelling along `d` (scene frame).
    fn pol_vector(&self, rot: &DMat3, d: DVec3) -> DVec3 {
        let h = match self.polarisation {
            Polarisation::H => rot.y_axis,
            Polarisation::V => rot.z_axis,
        };
        let p = h - h.dot(d) * d;
        if p.length_squared() < 1e-12 {
            perpendicular(d)
        } else {
            p.normalize()
        }
    }

    fn refresh_caches(&mut self, scene: &Scene) {
        // Coefficient tables of the materials in use.
        if self.coefficients_db_len != scene.materials.len() {
            self.coefficients.clear();
            self.coefficients_db_len = scene.materials.len();
        }
        self.coefficients
            .resize_with(scene.materials.len(), || None);
        let used = scene
            .static_world
            .part_material
            .iter()
            .chain(scene.meshes.iter().flat_map(|m| m.part_material.iter()));
        for id in used {
            let slot = &mut self.coefficients[id.0 as usize];
            if slot.is_none() {
                *slot = Some(Box::new(Coefficients::new(
                    scene.materials.get(*id),
                    self.freq_hz,
                    &self.sw.material,
                )));
            }
        }
        // Wheels per mesh.
        while self.wheels.len() < scene.meshes.len() {
            let m = &scene.meshes[self.wheels.len()].mesh;
            let w = m
                .parts
                .iter()
                .position(|p| p.name == "wheels")
                .and_then(|part| {
                    let part = part as u16;
                    let (mut zlo, mut zhi) = (f64::INFINITY, f64::NEG_INFINITY);
                    let (mut fx, mut nf, mut rx, mut nr) = (0.0, 0usize, 0.0, 0usize);
                    for (t, tri) in m.triangles.iter().enumerate() {
                        if m.triangle_part[t] != part {
                            continue;
                        }
                        for &i in tri {
                            let p = m.positions[i as usize].as_dvec3();
                            zlo = zlo.min(p.z);
                            zhi = zhi.max(p.z);
                            if p.x >= 0.0 {
                                fx += p.x;
                                nf += 1;
                            } else {
                                rx += p.x;
                                nr += 1;
                            }
                        }
                    }
                    (zhi > zlo && nf + nr > 0).then(|| Wheels {
                        part,
                        radius_m: 0.5 * (zhi - zlo),
                        axle_z_m: 0.5 * (zhi + zlo),
                        front_x_m: if nf > 0 {
                            fx / nf as f64
                        } else {
                            rx / nr as f64
                        },
                        rear_x_m: if nr > 0 {
                            rx / nr as f64
                        } else {
                            fx / nf as f64
                        },
                    })
                });
            self.wheels.push(w);
        }
        // Corner normals per mesh.
        while self.smooth.len() < scene.meshes.len() {
            let m = &scene.meshes[self.smooth.len()].mesh;
            self.smooth.push(SmoothNormals::new(m));
        }
        // Stationary object boxes.
        if self.static_revision != scene.static_revision {
            self.static_revision = scene.static_revision;
            self.smooth_static = SmoothNormals::new(&scene.static_world.mesh);
            self.stationary.clear();
            let m = &scene.static_world.mesh;
            for o in &scene.static_owners {
                // Stationary objects and the road furniture of traffic signs and lights: targets
                // the tubes are launched at (road markings are road).
                if let StaticElement::Object(id)
                | StaticElement::TrafficSign(id)
                | StaticElement::SignPost(id)
                | StaticElement::TrafficLight(id)
                | StaticElement::SignalHousing(id) = o.element
                {
                    let mut a = DVec3::splat(f64::INFINITY);
                    let mut b = DVec3::splat(f64::NEG_INFINITY);
                    for t in o.first_triangle..o.first_triangle + o.triangle_count {
                        for &i in &m.triangles[t as usize] {
                            let p = m.positions[i as usize].as_dvec3();
                            a = a.min(p);
                            b = b.max(p);
                        }
                    }
                    if a.x <= b.x {
                        self.stationary.push((id, a, b));
                    }
                }
            }
        }
    }

    /// Launch the tube grids of all targets in view.
    fn launch(
        &mut self,
        scene: &Scene,
        ctx_origin: DVec3,
        rot: &DMat3,
        fov: (f64, f64),
        range: f64,
    ) {
        self.tubes.clear();
        // (owner, box lo, box hi)
        let mut targets = std::mem::take(&mut self.targets);
        let mut windows = std::mem::take(&mut self.windows);
        targets.clear();
        windows.clear();
        for i in 0..scene.instances.len() {
            if let Some((a, b)) = instance_box(scene, i) {
                targets.push((Owner::Object(scene.instances[i].object_id), a, b));
            }
        }
        for &(id, a, b) in &self.stationary {
            targets.push((Owner::Stationary(id), a, b));
        }
        let to_sensor = rot.transpose();
        // Angular windows (az0, az1, el0, el1, spacing rad).
        let mut total = 0.0;
        for &(owner, lo, hi) in &targets {
            let near = (ctx_origin.clamp(lo, hi) - ctx_origin).length();
            if near > range || near < 0.05 {
                continue;
            }
            let (mut az0, mut az1, mut el0, mut el1) = (
                f64::INFINITY,
                f64::NEG_INFINITY,
                f64::INFINITY,
                f64::NEG_INFINITY,
            );
            let mut behind = false;
            for k in 0..8 {
                let c = DVec3::new(
                    if k & 1 == 0 { lo.x } else { hi.x },
                    if k & 2 == 0 { lo.y } else { hi.y },
                    if k & 4 == 0 { lo.z } else { hi.z },
                );
                let s = to_sensor * (c - ctx_origin);
                if s.x <= 0.0 {
                    behind = true;
                }
                let (az, el) = (s.y.atan2(s.x), s.z.atan2(s.x.hypot(s.y)));
                az0 = az0.min(az);
                az1 = az1.max(az);
                el0 = el0.min(el);
                el1 = el1.max(el);
            }
            if behind {
                // The box reaches behind the sensor plane (a guardrail alongside): its angular
                // extent is not bounded by its corners; cover the whole field of view.
                (az0, az1, el0, el1) = (-PI, PI, -0.5 * PI, 0.5 * PI);
            }
            az0 = az0.max(-0.5 * fov.0);
            az1 = az1.min(0.5 * fov.0);
            el0 = el0.max(-0.5 * fov.1);
            el1 = el1.min(0.5 * fov.1);
            if az0 >= az1 || el0 >= el1 {
                continue;
            }
            let size = hi - lo;
            // Smallest extent of the box (not below 1 cm).
            let min_extent = size.min_element().max(0.01);
            let spacing = self
                .cfg
                .tube_spacing_m
                .min(min_extent / self.cfg.min_tubes_across);
            let dtheta = spacing / near;
            let n = ((az1 - az0) / dtheta).ceil() * ((el1 - el0) / dtheta).ceil();
            total += n;
            windows.push((owner, [az0, az1, el0, el1, dtheta]));
        }
        // Budget by water-filling: every target keeps its tubes up to a common cap `c` chosen so
        // that Σ min(n_i, c) = max_tubes; larger targets (guardrails, near cars) get coarser tubes,
        // small ones (corner reflectors) keep their resolution.
        let cap = if total > self.cfg.max_tubes as f64 {
            self.counts.clear();
            self.counts.extend(
                windows
                    .iter()
                    .map(|(_, w)| ((w[1] - w[0]) / w[4]).ceil() * ((w[3] - w[2]) / w[4]).ceil()),
            );
            self.counts.sort_unstable_by(f64::total_cmp);
            let mut budget = self.cfg.max_tubes as f64;
            let mut cap = f64::INFINITY;
            let m = self.counts.len();
            for (i, &n) in self.counts.iter().enumerate() {
                let share = budget / (m - i) as f64;
                if n > share {
                    cap = share;
                    break;
                }
                budget -= n;
            }
            cap
        } else {
            f64::INFINITY
        };
        for &(owner, [az0, az1, el0, el1, dtheta]) in &windows {
            let n = ((az1 - az0) / dtheta).ceil() * ((el1 - el0) / dtheta).ceil();
            let dtheta = if n > cap {
                dtheta * (n / cap).sqrt()
            } else {
                dtheta
            };
            let n_az = (((az1 - az0) / dtheta).ceil() as usize).max(1);
            let n_el = (((el1 - el0) / dtheta).ceil() as usize).max(1);
            let daz = (az1 - az0) / n_az as f64;
            let del = (el1 - el0) / n_el as f64;
            for j in 0..n_el {
                let el = el0 + (j as f64 + 0.5) * del;
                let (se, ce) = el.sin_cos();
                for i in 0..n_az {
                    let az = az0 + (i as f64 + 0.5) * daz;
                    let (sa, ca) = az.sin_cos();
                    let d = DVec3::new(ce * ca, ce * sa, se);
                    let u = DVec3::new(-sa, ca, 0.0);
                    let v = DVec3::new(-se * ca, -se * sa, ce);
                    self.tubes.push(Tube {
                        direction: *rot * d,
                        u: *rot * u,
                        v: *rot * v,
                        su: daz * ce,
                        sv: del,
                        target: owner,
                    });
                }
            }
        }
        self.last_tube_count = self.tubes.len();
        self.targets = targets;
        self.windows = windows;
    }

    /// The paths of one frame (appended to `out` after clearing it); `seed` seeds the frame's random
    /// draws (diffuse amplitudes, road clutter).
    pub fn compute(
        &mut self,
        frame: &WorldFrame<'_>,
        fov: (f64, f64),
        max_range_m: f64,
        seed: u64,
        out: &mut Vec<PathReturn>,
    ) {
        out.clear();
        let scene = frame.scene;
        self.refresh_caches(scene);
        let rot = frame.sensor_pose.rotation;
        let origin = frame.sensor_origin();
        self.launch(scene, origin, &rot, fov, max_range_m);
        let ctx = FrameCtx {
            space: frame.space,
            scene,
            origin,
            sensor_velocity: frame.sensor_velocity_m_s,
            sensor_rotation: rot,
            to_sensor: rot.transpose(),
            extinction_per_m: self.extinction_per_m(&frame.weather),
            max_range_m,
            seed,
        };
        // Contribution slots per tube: one per bounce, one more for the diffuse term.
        let nb = self.cfg.max_bounces as usize + usize::from(self.sw.diffuse);
        self.contributions.clear();
        self.contributions
            .resize(self.tubes.len() * nb, Contribution::EMPTY);
        let mut contributions = std::mem::take(&mut self.contributions);
        {
            let this = &*self;
            let ctx = &ctx;
            contributions
                .par_chunks_mut(nb * TUBES_PER_TASK)
                .enumerate()
                .for_each(|(c, chunk)| {
                    for (k, slot) in chunk.chunks_mut(nb).enumerate() {
                        let t = c * TUBES_PER_TASK + k;
                        this.trace_tube(ctx, &this.tubes[t], (t * nb) as u64, slot);
                    }
                });
        }
        self.contributions = contributions;
        self.contributions.retain(|c| c.key != EMPTY_KEY);
        self.contributions
            .par_sort_unstable_by(|a, b| a.key.cmp(&b.key).then(a.order.cmp(&b.order)));
        self.group(&ctx);
        self.emit(&ctx, out);
        if self.sw.road_clutter {
            self.road_clutter(&ctx, fov.0, out);
        }
    }

    /// `radar.road_clutter` (physics.md §1.9): a polar grid of road cells around the sensor's
    /// horizontal heading (`fov_h` wide, ground ranges up to `clutter_max_range_m`, at most
    /// `clutter_max_cells`). Each cell's centre is aimed at on the horizontal plane through the road
    /// point below the sensor; the ray's first hit must be the road (else the cell is shadowed or
    /// off the road). The cell returns one path of σ = γ·sin ψ·A_cell (ψ: grazing angle of the ray
    /// on the road's normal, A_cell = r·Δr·Δφ) with a complex Gaussian amplitude and the range rate
    /// of a stationary point. One `closest_hit` per cell, cells in parallel into fixed slots.
    fn road_clutter(&mut self, ctx: &FrameCtx<'_>, fov_h: f64, out: &mut Vec<PathReturn>) {
        // The road below the sensor.
        let mut probe = Ray::new(ctx.origin, -DVec3::Z).with_t_max(50.0);
        let mut below = None;
        for _ in 0..8 {
            let Some(h) = closest_hit_sealed(ctx.space, &probe) else {
                break;
            };
            if self.owner_of(ctx.scene, &h) == Owner::Road {
                below = Some(h);
                break;
            }
            probe = probe.with_t_min(h.distance_m + 1e-4);
        }
        let Some(below) = below else { return };
        let height = ctx.origin.z - below.point.z;
        if height <= 1e-3 {
            return;
        }
        let fwd = ctx.sensor_rotation.x_axis;
        let heading = fwd.y.atan2(fwd.x);
        let r_max = self.cfg.clutter_max_range_m.min(ctx.max_range_m);
        let fov_h = fov_h.min(2.0 * PI);
        let (mut dr, mut dphi) = (
            self.cfg.clutter_cell_m,
            self.cfg.clutter_cell_deg.to_radians(),
        );
        let count = |dr: f64, dphi: f64| ((r_max / dr).ceil(), (fov_h / dphi).ceil());
        let (n_r, n_phi) = count(dr, dphi);
        let cap = self.cfg.clutter_max_cells as f64;
        if n_r * n_phi > cap {
            let scale = (n_r * n_phi / cap).sqrt();
            dr *= scale;
            dphi *= scale;
        }
        let (n_r, n_phi) = count(dr, dphi);
        let (n_r, n_phi) = (n_r.max(1.0) as usize, n_phi.max(1.0) as usize);
        let dr = r_max / n_r as f64;
        let dphi = fov_h / n_phi as f64;
        let gamma = 10f64.powf(self.cfg.clutter_gamma_db / 10.0);
        let mut cells = std::mem::take(&mut self.clutter);
        cells.clear();
        cells.resize(n_r * n_phi, None);
        {
            let this = &*self;
            cells
                .par_chunks_mut(CELLS_PER_TASK)
                .enumerate()
                .for_each(|(c, chunk)| {
                    for (k, slot) in chunk.iter_mut().enumerate() {
                        let i = c * CELLS_PER_TASK + k;
                        let (ir, ip) = (i / n_phi, i % n_phi);
                        let r = (ir as f64 + 0.5) * dr;
                        let phi = heading - 0.5 * fov_h + (ip as f64 + 0.5) * dphi;
                        let area = r * dr * dphi;
                        *slot = this.clutter_cell(ctx, r, phi, height, area * gamma, i as u64);
                    }
                });
        }
        out.extend(cells.iter().flatten());
        self.clutter = cells;
    }

    /// One road clutter cell at ground range `r`, azimuth `phi` (scene frame), `height` below the
    /// sensor; `gamma_area` = γ·A_cell, m².
    fn clutter_cell(
        &self,
        ctx: &FrameCtx<'_>,
        r: f64,
        phi: f64,
        height: f64,
        gamma_area: f64,
        index: u64,
    ) -> Option<PathReturn> {
        let aim = DVec3::new(r * phi.cos(), r * phi.sin(), -height);
        let dist = aim.length();
        let d = aim / dist;
        let hit = closest_hit_sealed(
            ctx.space,
            &Ray::new(ctx.origin, d).with_t_max(2.0 * dist + 1.0),
        )?;
        if self.owner_of(ctx.scene, &hit) != Owner::Road {
            return None;
        }
        let range = hit.distance_m;
        if range > ctx.max_range_m {
            return None;
        }
        let sin_psi = -d.dot(hit.facing_normal());
        if sin_psi <= 0.0 {
            return None;
        }
        let sigma = gamma_area * sin_psi;
        let (az, el) = az_el(&ctx.to_sensor, d);
        let gains = 10f64
            .powf((self.antennas.tx_gain_dbi(az, el) + self.antennas.rx_gain_dbi(az, el)) / 20.0);
        let spread = if self.sw.spreading {
            range * range
        } else {
            self.cfg.reference_range_m.powi(2)
        };
        let atm = (-ctx.extinction_per_m * range).exp();
        let mag = self.amp_const * gains * sigma.sqrt() * atm / spread;
        let (x, y) = gaussian_pair(ctx.seed ^ splitmix64(index ^ (0x005E_EDC1_u64 << 32)));
        Some(PathReturn {
            range_m: range,
            range_rate_m_s: -ctx.sensor_velocity.dot(d),
            tx_azimuth_rad: az,
            tx_elevation_rad: el,
            rx_azimuth_rad: az,
            rx_elevation_rad: el,
            amplitude: Complex64::new(x, y) * (mag * std::f64::consts::FRAC_1_SQRT_2),
            object_id: osiris_proto::INVALID_ID,
        })
    }
}

/// Road clutter cells per rayon task.
const CELLS_PER_TASK: usize = 64;

/// `closest_hit`, retried once with the ray moved 1 mm sideways when it hits nothing: a ray that
/// runs (within rounding) along a shared triangle edge, e.g. straight down onto the seam of two
/// road tiles below an object at y ≈ 0, can slip between the two triangles' f32 tests.
fn closest_hit_sealed(space: &Space, ray: &Ray) -> Option<Hit> {
    space.closest_hit(ray).or_else(|| {
        let moved = Ray {
            origin: ray.origin + perpendicular(ray.direction) * 1e-3,
            ..*ray
        };
        space.closest_hit(&moved)
    })
}

/// Tubes per rayon task.
const TUBES_PER_TASK: usize = 64;

/// Offset separating a continued ray from the surface it leaves (above the f32 rounding of scene
/// coordinates, as the space layer's own bounce offset).
fn surface_epsilon(p: DVec3) -> f64 {
    1e-5 + 8.0 * f64::from(f32::EPSILON) * (p.abs().max_element() + 1.0)
}

impl Propagator {
    fn owner_of(&self, scene: &Scene, hit: &Hit) -> Owner {
        match hit.object_id {
            Some(id) => Owner::Object(id),
            None => match scene.static_element(hit.triangle) {
                Some(
                    StaticElement::Object(id)
                    | StaticElement::TrafficSign(id)
                    | StaticElement::SignPost(id)
                    | StaticElement::TrafficLight(id)
                    | StaticElement::SignalHousing(id),
                ) => Owner::Stationary(id),
                Some(
                    StaticElement::Lane(_)
                    | StaticElement::RoadPlane
                    | StaticElement::Marking(_)
                    | StaticElement::RoadMarking(_),
                ) => Owner::Road,
                None => Owner::Other,
            },
        }
    }

    /// The facing normal at a hit and the distance the hit moves back along the ray to reach the
    /// smooth surface the facets approximate (physics.md §1.8): on a triangle with interpolated corner
    /// normals ([`SmoothNormals`]), the normal is the barycentric interpolation of the corner normals
    /// and the surface is the half-strength Phong tessellation of the triangle (Boubekeur & Alexa,
    /// ACM TOG 27(5), 2008, shape factor ½: it has the curvature the corner normals imply, so a
    /// tessellated sphere of radius a returns σ = πa²). Flat triangles, back faces and normals that
    /// would turn the reflection into the facet keep the facet (shift 0).
    fn smooth_surface(&self, scene: &Scene, hit: &Hit, d: DVec3) -> (DVec3, f64, Option<DMat3>) {
        let flat = (hit.facing_normal(), 0.0, None);
        if !hit.front_face {
            return flat;
        }
        let (smooth, mesh, pose) = match hit.instance {
            Some(i) => {
                let Some(inst) = scene.instances.get(i as usize) else {
                    return flat;
                };
                let (Some(sm), Some(m)) = (self.smooth.get(inst.mesh), scene.meshes.get(inst.mesh))
                else {
                    return flat;
                };
                (sm, &m.mesh, Some(&inst.pose_local))
            }
            None => (&self.smooth_static, &scene.static_world.mesh, None),
        };
        let t = hit.triangle as usize;
        let Some(corners_n) = smooth.corner_normals(t) else {
            return flat;
        };
        if t >= mesh.triangles.len() {
            return flat;
        }
        let [a, b, c] = mesh.triangle(t).map(|v| v.as_dvec3());
        let (p, dl) = match pose {
            Some(pose) => (
                pose.inverse_transform_point(hit.point),
                pose.inverse_transform_vector(d),
            ),
            None => (hit.point, d),
        };
        let nf = (b - a).cross(c - a);
        let area2 = nf.length_squared();
        if area2 <= 0.0 {
            return flat;
        }
        let nf = nf / area2.sqrt();
        let cos_f = -dl.dot(nf);
        if cos_f <= 1e-3 {
            return flat;
        }
        // Barycentrics of the hit point.
        let (v0, v1, v2) = (b - a, c - a, p - a);
        let (d00, d01, d11) = (v0.dot(v0), v0.dot(v1), v1.dot(v1));
        let (d20, d21) = (v2.dot(v0), v2.dot(v1));
        let den = d00 * d11 - d01 * d01;
        if den.abs() <= 1e-30 {
            return flat;
        }
        let w1 = ((d11 * d20 - d01 * d21) / den).clamp(0.0, 1.0);
        let w2 = ((d00 * d21 - d01 * d20) / den).clamp(0.0, 1.0 - w1);
        let w0 = 1.0 - w1 - w2;
        let weights = [w0, w1, w2];
        let verts = [a, b, c];
        let mut ns = DVec3::ZERO;
        let mut phong = DVec3::ZERO;
        for k in 0..3 {
            let nk = corners_n[k].as_dvec3();
            ns += nk * weights[k];
            phong -= nk * ((p - verts[k]).dot(nk) * weights[k]);
        }
        let n_len = ns.length();
        let ns = ns.normalize_or_zero();
        // Derivative of the (unnormalised) interpolated normal, J = Σ nᵢ ⊗ ∇bᵢ with the barycentric
        // gradients ∇b₀ = n_f × (c − b)/2A etc.; J/|N| is the surface's shape operator (the
        // curvature the physical-optics phase needs, [`Propagator::aperture`]).
        let grads = [nf.cross(c - b), nf.cross(a - c), nf.cross(b - a)].map(|g| g / area2.sqrt());
        let mut jac = DMat3::ZERO;
        for k in 0..3 {
            let nk = corners_n[k].as_dvec3();
            jac += DMat3::from_cols(nk * grads[k].x, nk * grads[k].y, nk * grads[k].z);
        }
        let jac = match pose {
            Some(pose) => pose.rotation * jac * pose.rotation.transpose(),
            None => jac,
        } * (1.0 / n_len.max(1e-9));
        // Height of the smooth surface above the facet, and the ray's extra way to it.
        let height = 0.5 * phong.dot(nf);
        let shift = height / cos_f;
        let ns_scene = match pose {
            Some(pose) => pose.transform_vector(ns),
            None => ns,
        };
        let facet = hit.facing_normal();
        // The interpolated normal must face the ray and reflect it away from the facet.
        let dn = d.dot(ns_scene);
        if ns_scene == DVec3::ZERO || dn >= -1e-6 || reflect(d, ns_scene).dot(facet) <= 1e-6 {
            return flat;
        }
        if !shift.is_finite() || shift.abs() > 0.25 * hit.distance_m {
            return flat;
        }
        (ns_scene, shift, jac.is_finite().then_some(jac))
    }

    /// Physical-optics aperture factor of a tube footprint: (1/A)∫ e^{jφ} over the footprint spanned
    /// by `side_u·us` × `side_v·vs` with the phase φ = g·r of the surface point r. On a flat facet
    /// φ is linear and the factor is sinc(g·u_s/2) sinc(g·v_s/2). On a curved surface (shape
    /// operator `curv` at the hit, normal `n`) the surface falls away from its tangent plane by
    /// ½·w·(curv w) along −n, which adds the quadratic phase −½(g·n)·w·(curv w) for w = x·us + y·vs:
    /// the footprint is then split into m × m cells (m chosen so the quadratic phase across a cell
    /// stays ≤ 0.1 rad, at most 8), each summed with its own linear-phase sinc. A curved surface's
    /// Fresnel zone can be as small as the tube (a sphere of 0.5 m at 77 GHz: ≈ 3 cm), where the
    /// linear factor alone misses the sum by ±3 dB.
    #[allow(clippy::too_many_arguments)]
    fn aperture(
        g: DVec3,
        n: DVec3,
        us: DVec3,
        vs: DVec3,
        side_u: f64,
        side_v: f64,
        curv: Option<DMat3>,
    ) -> Complex64 {
        let (au, av) = (g.dot(us), g.dot(vs));
        let linear = || Complex64::new(sinc(0.5 * au * side_u) * sinc(0.5 * av * side_v), 0.0);
        let Some(j) = curv else {
            return linear();
        };
        let gn = g.dot(n);
        let q = |w1: DVec3, w2: DVec3| -0.25 * gn * (w1.dot(j * w2) + w2.dot(j * w1));
        let (quu, qvv, quv) = (q(us, us), q(vs, vs), q(us, vs));
        let (hu, hv) = (0.5 * side_u, 0.5 * side_v);
        let size = (quu.abs() * hu * hu)
            .max(qvv.abs() * hv * hv)
            .max(quv.abs() * hu * hv);
        if !size.is_finite() || size < 1e-3 {
            return linear();
        }
        let m = ((size / 0.1).sqrt().ceil() as usize).clamp(1, 8);
        let (cu, cv) = (side_u / m as f64, side_v / m as f64);
        let mut sum = Complex64::new(0.0, 0.0);
        for i in 0..m {
            let x = -hu + (i as f64 + 0.5) * cu;
            for k in 0..m {
                let y = -hv + (k as f64 + 0.5) * cv;
                let phase = au * x + av * y + quu * x * x + 2.0 * quv * x * y + qvv * y * y;
                let gu = au + 2.0 * quu * x + 2.0 * quv * y;
                let gv = av + 2.0 * quv * x + 2.0 * qvv * y;
                sum += Complex64::from_polar(sinc(0.5 * gu * cu) * sinc(0.5 * gv * cv), phase);
            }
        }
        sum / (m * m) as f64
    }

    /// Velocity of the material point hit, with wheel spin (`radar.micro_doppler`).
    fn point_velocity(&self, scene: &Scene, hit: &Hit) -> DVec3 {
        let mut v = hit.velocity_m_s;
        if !self.sw.micro_doppler {
            return v;
        }
        let Some(inst) = hit.instance.and_then(|i| scene.instances.get(i as usize)) else {
            return v;
        };
        let Some(Some(w)) = self.wheels.get(inst.mesh) else {
            return v;
        };
        if hit.part != w.part || w.radius_m <= 0.0 {
            return v;
        }
        let pl = inst.pose_local.inverse_transform_point(hit.point);
        let axle_x = if (pl.x - w.front_x_m).abs() < (pl.x - w.rear_x_m).abs() {
            w.front_x_m
        } else {
            w.rear_x_m
        };
        let v_local = inst.pose_local.inverse_transform_vector(inst.velocity_m_s);
        let omega = DVec3::new(0.0, v_local.x / w.radius_m, 0.0);
        let r = DVec3::new(pl.x - axle_x, 0.0, pl.z - w.axle_z_m);
        v += inst.pose_local.transform_vector(omega.cross(r));
        v
    }

    fn trace_tube(&self, ctx: &FrameCtx<'_>, tube: &Tube, order: u64, slot: &mut [Contribution]) {
        let k = 2.0 * PI / self.lambda_m;
        let mut d = tube.direction;
        let (mut u, mut v) = (tube.u, tube.v);
        let p_tx = self.pol_vector(&ctx.sensor_rotation, d);
        let mut e: CVec = cscale(p_tx, Complex64::new(1.0, 0.0));
        let mut origin = ctx.origin;
        let mut prev_v = ctx.sensor_velocity;
        let mut length = 0.0;
        let mut rate = 0.0;
        let mut back = Complex64::new(1.0, 0.0);
        let mut written = 0usize;
        let mut bounces = 0u32;
        let (az_d, el_d) = az_el(&ctx.to_sensor, d);
        let g_tx = self.antennas.tx_gain_dbi(az_d, el_d);
        // `space.multipath` (on the space): more than one reflection per tube.
        let max_bounces = ctx.space.effects.path_interactions(self.cfg.max_bounces);
        let mut guard = 0;
        while bounces < max_bounces && guard < 16 {
            guard += 1;
            let eps = surface_epsilon(origin);
            let remaining = 2.0 * ctx.max_range_m - length;
            if remaining <= 0.0 {
                break;
            }
            let ray = Ray::new(origin, d)
                .with_t_min(if length > 0.0 { eps } else { 0.0 })
                .with_t_max(remaining);
            let Some(hit) = ctx.space.closest_hit(&ray) else {
                break;
            };
            let owner = self.owner_of(ctx.scene, &hit);
            if owner == Owner::Road {
                break;
            }
            // Ownership: before the first reflection, slabs of other objects are crossed silently and
            // the first reflecting surface must be the target's (other surfaces belong to other
            // grids); with `radar.multipath` off the tube never leaves the target.
            let on_target = owner == tube.target;
            let Some(Some(coeff)) = self.coefficients.get(hit.material.0 as usize) else {
                break;
            };
            let may_cross = ctx.space.effects.transmission && coeff.slab;
            let foreign = !on_target && (bounces == 0 || !self.sw.multipath);
            if foreign && (!may_cross || bounces > 0) {
                break;
            }
            // The surface the facets approximate: corrected hit point and interpolated normal.
            let (n, shift, curv) = self.smooth_surface(ctx.scene, &hit, d);
            // Rays continue from the facet (the traced geometry); the path lengths from the smooth
            // surface (first order in the shift).
            let flat_point = hit.point;
            let hit = Hit {
                point: hit.point - d * shift,
                distance_m: hit.distance_m - shift,
                ..hit
            };
            let cos_i = (-d.dot(n)).clamp(0.0, 1.0);
            let theta = cos_i.acos();
            let [gte, gtm, tte, ttm] = coeff.at(theta);
            // Slab (bumper, glass) that passes more than it reflects: the tube crosses it.
            let crossing = (may_cross && tte.norm_sqr() >= gte.norm_sqr()).then_some((tte, ttm));
            if foreign && crossing.is_none() {
                break;
            }
            let vel = self.point_velocity(ctx.scene, &hit);
            length += hit.distance_m;
            rate += (vel - prev_v).dot(d);
            // s/p basis of this interaction.
            let sx = d.cross(n);
            let s = if sx.length_squared() < 1e-18 {
                perpendicular(d)
            } else {
                sx.normalize()
            };
            let p_i = s.cross(d);
            let d_r = reflect(d, n);
            let p_r = s.cross(d_r);
            let es = cdot(&e, s);
            let ep = cdot(&e, p_i);
            let e_r = cadd(cscale(s, gte * es), cscale(p_r, gtm * ep));
            let contributes = crossing.is_none() || (on_target && bounces == 0);
            // Contribution back to the radar (PO over the tube footprint).
            let to_radar = ctx.origin - hit.point;
            let r_back = to_radar.length();
            let o = to_radar / r_back;
            let side_u = tube.su * length;
            let side_v = tube.sv * length;
            let dn = d.dot(n);
            if contributes && dn.abs() > 1e-9 && written < slot.len() {
                let us = u - (u.dot(n) / dn) * d;
                let vs = v - (v.dot(n) / dn) * d;
                let g = k * (d - o);
                let aperture = Self::aperture(g, n, us, vs, side_u, side_v, curv);
                let arrival = -o;
                let p_rx = self.pol_vector(&ctx.sensor_rotation, arrival);
                let co = cdot(&e_r, p_rx) * back;
                let sqrt_sigma = (4.0 * PI).sqrt() / self.lambda_m * side_u * side_v * aperture;
                let (az_a, el_a) = az_el(&ctx.to_sensor, arrival);
                let g_rx = self.antennas.rx_gain_dbi(az_a, el_a);
                let total = length + r_back;
                let spread = if self.sw.spreading {
                    length * r_back
                } else {
                    self.cfg.reference_range_m.powi(2)
                };
                let gains = 10f64.powf((g_tx + g_rx) / 20.0);
                let atm = (-0.5 * ctx.extinction_per_m * total).exp();
                let mag = self.amp_const * gains * sqrt_sigma * atm / spread;
                let amp = co * mag * Complex64::from_polar(1.0, k * total);
                if amp.norm_sqr() > 0.0 {
                    let rate_total = rate + (ctx.sensor_velocity - vel).dot(o);
                    slot[written] = Contribution {
                        key: self.key(owner.object_id(), bounces + 1, hit.point),
                        amplitude: amp,
                        point: hit.point,
                        length_m: total,
                        length_rate_m_s: rate_total,
                        departure: tube.direction,
                        velocity: vel,
                        object_id: owner.object_id(),
                        bounces: bounces + 1,
                        order: order + written as u64,
                    };
                    written += 1;
                }
                // `radar.diffuse_scattering`: the incoherent term of the radar's direct illumination,
                // σ_t = σ⁰(θ)·A_t/cos θ = 4ρ(θ)·cos θ·A_t (Lambert's law, physics.md §1.9).
                if self.sw.diffuse
                    && bounces == 0
                    && on_target
                    && crossing.is_none()
                    && written < slot.len()
                {
                    let sigma_t = 4.0 * coeff.albedo_at(theta) * cos_i * side_u * side_v;
                    if sigma_t > 0.0 {
                        let mag = self.amp_const * gains * sigma_t.sqrt() * atm / spread;
                        let (x, y) = gaussian_pair(ctx.seed ^ splitmix64(order + written as u64));
                        let amp = back
                            * Complex64::new(x, y)
                            * (mag * std::f64::consts::FRAC_1_SQRT_2)
                            * Complex64::from_polar(1.0, k * total);
                        slot[written] = Contribution {
                            key: self.key(owner.object_id(), 1, hit.point),
                            amplitude: amp,
                            point: hit.point,
                            length_m: total,
                            length_rate_m_s: rate + (ctx.sensor_velocity - vel).dot(o),
                            departure: tube.direction,
                            velocity: vel,
                            object_id: owner.object_id(),
                            bounces: 1,
                            order: order + written as u64,
                        };
                        written += 1;
                    }
                }
            }
            if let Some((tte, ttm)) = crossing {
                let before = es.norm_sqr() + ep.norm_sqr();
                if before > 0.0 {
                    // Effective co-polar coefficient of the crossing, applied again on the way back.
                    back *= (es.conj() * tte * es + ep.conj() * ttm * ep) / before;
                }
                e = cadd(cscale(s, tte * es), cscale(p_i, ttm * ep));
                origin = flat_point + d * eps * 4.0;
                length += shift;
                prev_v = vel;
                continue;
            }
            bounces += 1;
            // Continue.
            e = e_r;
            length += shift * d.dot(d_r);
            d = d_r;
            u = reflect(u, n);
            v = reflect(v, n);
            origin = flat_point;
            prev_v = vel;
        }
    }

    fn key(&self, object_id: u64, bounces: u32, p: DVec3) -> u128 {
        if !self.sw.area_scaling {
            return (u128::from(object_id) << 64) | (1 << 63);
        }
        let c = (p / self.cfg.cluster_size_m).floor();
        let q = |x: f64| ((x as i64 + (1 << 19)) as u64) & 0xF_FFFF;
        (u128::from(object_id) << 64)
            | (u128::from(bounces.min(15)) << 60)
            | (u128::from(q(c.x)) << 40)
            | (u128::from(q(c.y)) << 20)
            | u128::from(q(c.z))
    }

    /// Sum the (sorted) contributions into scattering centres.
    fn group(&mut self, ctx: &FrameCtx<'_>) {
        self.centres.clear();
        let k = 2.0 * PI / self.lambda_m;
        let cs = &self.contributions;
        let mut i = 0;
        while i < cs.len() {
            let key = cs[i].key;
            let mut j = i;
            let mut amp = Complex64::new(0.0, 0.0);
            let (mut w, mut pt, mut len, mut rate, mut dep, mut vel) =
                (0.0, DVec3::ZERO, 0.0, 0.0, DVec3::ZERO, DVec3::ZERO);
            let mut w_multi = 0.0;
            while j < cs.len() && cs[j].key == key {
                let c = &cs[j];
                let wt = c.amplitude.norm();
                amp += c.amplitude;
                w += wt;
                if c.bounces > 1 {
                    w_multi += wt;
                }
                pt += c.point * wt;
                len += c.length_m * wt;
                rate += c.length_rate_m_s * wt;
                dep += c.departure * wt;
                vel += c.velocity * wt;
                j += 1;
            }
            if w > 0.0 {
                let range = 0.5 * len / w;
                let mut amplitude = amp * Complex64::from_polar(1.0, -2.0 * k * range);
                let point = pt / w;
                let departure = dep.normalize_or_zero();
                if !self.sw.area_scaling {
                    // One point scatterer of the configured RCS at the centroid.
                    let arrival = (point - ctx.origin).normalize_or_zero();
                    let (az_d, el_d) = az_el(&ctx.to_sensor, departure);
                    let (az_a, el_a) = az_el(&ctx.to_sensor, arrival);
                    let gains = 10f64.powf(
                        (self.antennas.tx_gain_dbi(az_d, el_d)
                            + self.antennas.rx_gain_dbi(az_a, el_a))
                            / 20.0,
                    );
                    let spread = if self.sw.spreading {
                        range * range
                    } else {
                        self.cfg.reference_range_m.powi(2)
                    };
                    let sqrt_sigma = 10f64.powf(self.cfg.point_rcs_dbsm / 20.0);
                    let atm = (-ctx.extinction_per_m * range).exp();
                    let mag = self.amp_const * gains * sqrt_sigma * atm / spread;
                    let phase = if amplitude.norm() > 0.0 {
                        amplitude / amplitude.norm()
                    } else {
                        Complex64::new(1.0, 0.0)
                    };
                    amplitude = phase * mag;
                }
                self.centres.push(Centre {
                    amplitude,
                    point,
                    range_m: range,
                    rate_m_s: 0.5 * rate / w,
                    departure,
                    velocity: vel / w,
                    object_id: cs[i].object_id,
                    power_w: amplitude.norm_sqr(),
                    leading: false,
                    multi_bounce: w_multi > 0.5 * w,
                });
            }
            i = j;
        }
        // Keep the strongest centres.
        let min_w = 1e-3 * 10f64.powf(self.cfg.min_power_dbm / 10.0);
        self.centres.retain(|c| c.power_w >= min_w);
        // Centres come in key order, i.e. grouped by object: mark each object's strongest.
        let mut i = 0;
        while i < self.centres.len() {
            let id = self.centres[i].object_id;
            let mut j = i;
            let mut best = i;
            while j < self.centres.len() && self.centres[j].object_id == id {
                if self.centres[j].power_w > self.centres[best].power_w {
                    best = j;
                }
                j += 1;
            }
            self.centres[best].leading = true;
            i = j;
        }
        let per_centre = if self.sw.ground { 4 } else { 1 };
        let keep = (self.cfg.max_paths / per_centre).max(1);
        if self.centres.len() > keep {
            self.centres.select_nth_unstable_by(keep - 1, |a, b| {
                b.leading
                    .cmp(&a.leading)
                    .then(b.power_w.total_cmp(&a.power_w))
            });
            self.centres.truncate(keep);
        }
        // Deterministic order (range).
        self.centres.sort_unstable_by(|a, b| {
            a.range_m
                .total_cmp(&b.range_m)
                .then(a.object_id.cmp(&b.object_id))
        });
    }

    fn emit(&self, ctx: &FrameCtx<'_>, out: &mut Vec<PathReturn>) {
        for c in &self.centres {
            let (tx_az, tx_el) = az_el(&ctx.to_sensor, c.departure);
            let arrival = (c.point - ctx.origin).normalize_or_zero();
            let (rx_az, rx_el) = az_el(&ctx.to_sensor, arrival);
            let direct = PathReturn {
                range_m: c.range_m,
                range_rate_m_s: c.rate_m_s,
                tx_azimuth_rad: tx_az,
                tx_elevation_rad: tx_el,
                rx_azimuth_rad: rx_az,
                rx_elevation_rad: rx_el,
                amplitude: c.amplitude,
                object_id: c.object_id,
            };
            out.push(direct);
            if self.sw.ground && c.object_id != osiris_proto::INVALID_ID {
                self.ground_images(ctx, c, &direct, out);
            }
        }
    }

    /// DG, GD and GG paths of a scattering centre over the road below it (image method).
    fn ground_images(
        &self,
        ctx: &FrameCtx<'_>,
        c: &Centre,
        direct: &PathReturn,
        out: &mut Vec<PathReturn>,
    ) {
        // The point the images are taken of: the centre's phase centre, where the direct path's
        // phase is referenced. Default: the point at the path range along the direction of the
        // hit-point centroid; for single reflections that is the centroid itself (the reflecting
        // points are the reference). A multiple-bounce path is not referenced at its last hit
        // points: where the object's asset has a fixed phase centre (a trihedral's apex: every
        // triple-bounce path has the length of the path to the apex) that point is used.
        let asset_centre = c
            .multi_bounce
            .then(|| ctx.scene.phase_centre(c.object_id))
            .flatten();
        let p_c = asset_centre
            .unwrap_or_else(|| ctx.origin + c.range_m * (c.point - ctx.origin).normalize_or_zero());
        // Road below the centre.
        let mut probe = Ray::new(p_c + DVec3::Z * 1e-3, -DVec3::Z).with_t_max(50.0);
        let mut road = None;
        for _ in 0..8 {
            let Some(h) = closest_hit_sealed(ctx.space, &probe) else {
                break;
            };
            if self.owner_of(ctx.scene, &h) == Owner::Road {
                road = Some(h);
                break;
            }
            probe = probe.with_t_min(h.distance_m + 1e-4);
        }
        let Some(g) = road else { return };
        let n = g.facing_normal();
        if n.z <= 0.5 {
            return;
        }
        let h = (p_c - g.point).dot(n);
        let ht = (ctx.origin - g.point).dot(n);
        if h <= 1e-3 || ht <= 1e-3 {
            return;
        }
        let image = p_c - 2.0 * h * n;
        let to_image = image - ctx.origin;
        let r_g = to_image.length();
        let to_point = p_c - ctx.origin;
        let r_d = to_point.length();
        // Specular point and the ray to it (must reach the road unobstructed).
        let q = ctx.origin + to_image * (ht / (ht + h));
        let dq = q - ctx.origin;
        let lq = dq.length();
        let Some(hq) =
            closest_hit_sealed(ctx.space, &Ray::new(ctx.origin, dq).with_t_max(lq + 0.05))
        else {
            return;
        };
        if self.owner_of(ctx.scene, &hq) != Owner::Road || (hq.distance_m - lq).abs() > 0.05 {
            return;
        }
        let psi = ((ht + h) / r_g).clamp(-1.0, 1.0).asin();
        let mat = ctx.scene.materials.get(hq.material);
        let gamma = mat.reflection_mmwave(
            self.freq_hz,
            0.5 * PI - psi,
            self.polarisation.for_ground(),
            &self.sw.material,
        );
        // One-way ranges, rates.
        let vp = c.velocity;
        let v_img = vp - 2.0 * vp.dot(n) * n;
        let rate_d = (vp - ctx.sensor_velocity).dot(to_point / r_d);
        let rate_g = (v_img - ctx.sensor_velocity).dot(to_image / r_g);
        let (az_g, el_g) = az_el(&ctx.to_sensor, to_image / r_g);
        let g_db = |tx: bool, az: f64, el: f64| {
            if tx {
                self.antennas.tx_gain_dbi(az, el)
            } else {
                self.antennas.rx_gain_dbi(az, el)
            }
        };
        let gain_ratio = |tx: bool, az: f64, el: f64, az0: f64, el0: f64| {
            10f64.powf((g_db(tx, az, el) - g_db(tx, az0, el0)) / 20.0)
        };
        let ratio = if self.sw.spreading { r_d / r_g } else { 1.0 };
        // Extra one-way length of a ground leg (amplitude: half the power extinction).
        let atm = (-0.5 * ctx.extinction_per_m * (r_g - r_d)).exp();
        // (tx via ground, rx via ground)
        for (tx_g, rx_g) in [(true, false), (false, true), (true, true)] {
            let mut a = direct.amplitude * gamma * ratio * atm;
            let mut p = *direct;
            let mut range = c.range_m;
            let mut rate = c.rate_m_s;
            if tx_g {
                a *= gain_ratio(
                    true,
                    az_g,
                    el_g,
                    direct.tx_azimuth_rad,
                    direct.tx_elevation_rad,
                );
                p.tx_azimuth_rad = az_g;
                p.tx_elevation_rad = el_g;
                range += 0.5 * (r_g - r_d);
                rate += 0.5 * (rate_g - rate_d);
            }
            if rx_g {
                a *= gain_ratio(
                    false,
                    az_g,
                    el_g,
                    direct.rx_azimuth_rad,
                    direct.rx_elevation_rad,
                );
                p.rx_azimuth_rad = az_g;
                p.rx_elevation_rad = el_g;
                range += 0.5 * (r_g - r_d);
                rate += 0.5 * (rate_g - rate_d);
            }
            if tx_g && rx_g {
                a *= gamma * ratio * atm;
            }
            p.amplitude = a;
            p.range_m = range;
            p.range_rate_m_s = rate;
            out.push(p);
        }
    }
}
