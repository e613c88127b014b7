//! The shipped SensorView source FMUs: one [`FmuDescriptor`](crate::FmuDescriptor) each, exported
//! by a cdylib crate through [`crate::export_fmi2!`] (`fmu/scenario`).

pub mod scenario;
