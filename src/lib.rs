//! osiris: co-simulation master, scenario sources, traces, FMU packaging and benchmarks.
//!
//! * [`master`]: a small FMI 2.0 co-simulation master for OSMP sensor FMUs (libloading).
//! * [`trace`]: OSI `.osi` trace files (4-byte little-endian length prefix per message).
//! * [`scenario`]: the built-in scenario generator (JSON-configurable) and the SensorView players of
//!   `scenario.fmu` (the `osiris-scenario` crate).
//! * [`package`]: builds `camera.fmu`, `radar.fmu`, `lidar.fmu` and `scenario.fmu`.
//! * [`bench`]: `osiris bench <what>` figures.
//! * [`cli`]: the `osiris` command line.
//! * [`export`]: PerceptionData frames as PCD/PLY point clouds and range-Doppler PNGs.
//! * [`report`]: KPI tables and the self-contained `report.html` of a run or a trace.

pub mod bench;
pub mod cli;
pub mod export;
pub mod master;
pub mod package;
pub mod report;

/// The consistency workflow (the `osiris-consistency` crate).
pub use osiris_consistency as consistency;
/// OSI `.osi` trace files (`osiris_proto::trace`).
pub use osiris_proto::trace;
/// The built-in scenario generator and SensorView players (the `osiris-scenario` crate).
pub use osiris_scenario as scenario;
