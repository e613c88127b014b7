//! The scenario player FMU binary (`osiris_scenario.so`): the shared shell's 34 FMI 2.0
//! co-simulation exports over the scenario SensorView source. All logic lives in `osiris_fmu`
//! (`sources::scenario`) and `osiris_scenario`; see `modelDescription/scenario.xml`.

osiris_fmu::export_fmi2!(&osiris_fmu::sources::scenario::DESCRIPTOR);
