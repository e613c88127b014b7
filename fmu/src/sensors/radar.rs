//! The radar FMU (`osiris_radar`).

use osiris_models::SensorKind;

use crate::descriptor::FmuDescriptor;

/// Descriptor of the radar FMU: modelIdentifier `osiris_radar`, default step = the built-in
/// configuration's `update_cycle_s`.
pub static DESCRIPTOR: FmuDescriptor = FmuDescriptor::new(
    SensorKind::Radar,
    "osiris radar",
    "osiris_radar",
    "osiris radar sensor model (OSI 3.8.0 SensorView in, SensorData out, OSMP 1.6.0; raw perception \
     output in PerceptionDataOut). This version runs the ideal object-level model only: ground-truth \
     objects inside the field of view and range, occlusion by other objects, in the sensor frame. \
     The physics-based radar model has not landed yet; mode=physical fails at initialization.",
);
