//! The environment model: what the world is made of, and how it is lit and weathered.
//!
//! * [`mesh`]: triangle meshes with per-triangle parts (each part has a material name).
//! * [`material`]: the materials database (`models/resources/materials.json`): visible spectral
//!   reflectance, NIR BRDF at 905/1550 nm, 76–81 GHz permittivity (Fresnel), transmission, wet variants.
//! * [`assets`]: built-in parametric assets (`osiris:<asset>?<param>=<value>&...`) and user meshes.
//! * [`scene`]: OSI GroundTruth → scene (road, lane markings, object instances).
//! * [`traffic`]: traffic signs, traffic lights and road markings of the scene (geometry, materials).
//! * [`sun`]: sun position (NREL SPA).
//! * [`sky`]: clear-sky direct and diffuse spectral irradiance (SPCTRAL2).
//! * [`weather`]: rain and fog extinction per band, wet road.
//! * [`lamps`]: vehicle lamps with light-distribution tables.

pub mod assets;
pub mod lamps;
pub mod material;
pub mod mesh;
pub mod scene;
pub mod sky;
pub mod sky_distribution;
pub mod sun;
pub mod traffic;
pub mod weather;

/// Every effect of the environment model (materials, weather, sky distribution).
pub fn effects() -> Vec<crate::effects::EffectInfo> {
    [
        material::EFFECTS,
        weather::EFFECTS,
        &[sky_distribution::SKY_DISTRIBUTION],
    ]
    .concat()
}
