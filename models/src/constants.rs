//! Physical constants (SI 2019 exact values, BIPM SI Brochure 9th ed., 2019), written once.

/// Speed of light in vacuum, m/s (exact).
pub const SPEED_OF_LIGHT_M_S: f64 = 299_792_458.0;
/// Planck constant, J·s (exact).
pub const PLANCK_J_S: f64 = 6.626_070_15e-34;
/// Boltzmann constant, J/K (exact).
pub const BOLTZMANN_J_PER_K: f64 = 1.380_649e-23;
