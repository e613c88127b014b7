//! osiris: co-simulation master, scenario sources, traces, FMU packaging and benchmarks.
