//! Shared helpers of the osiris-fmu integration tests: an in-process "master" over the generic ABI
//! functions with the real C types, and sample OSI messages.

#![allow(dead_code)]

use std::ffi::{CStr, CString, c_char, c_void};
use std::ptr;

use osiris_fmu::abi;
use osiris_fmu::ffi::*;
use osiris_fmu::variables::vr;
use osiris_fmu::{FmuDescriptor, sensors};
use osiris_fmu_testlog::{LogCollector, LogRecord};
use osiris_models::SensorKind;
use osiris_proto::{Message, osi3, perception};

unsafe extern "C" {
    /// The C-variadic test logger of `osiris-fmu-testlog` (`fmu/testlog/c/logger.c`).
    fn osiris_testlog_logger(
        env: *mut c_void,
        instance_name: *const c_char,
        status: Fmi2Status,
        category: *const c_char,
        message: *const c_char,
        ...
    );
}

/// The test logger as an `fmi2CallbackLogger`.
pub fn test_logger() -> Fmi2CallbackLogger {
    osiris_testlog_logger
}

pub const OK: Fmi2Status = Fmi2Status::Ok;
pub const WARNING: Fmi2Status = Fmi2Status::Warning;
pub const DISCARD: Fmi2Status = Fmi2Status::Discard;
pub const ERROR: Fmi2Status = Fmi2Status::Error;
pub const FATAL: Fmi2Status = Fmi2Status::Fatal;

/// A temporary resources directory holding the kind's default `config.json`.
pub fn resources_dir(kind: SensorKind) -> tempfile::TempDir {
    resources_dir_of(sensors::descriptor(kind))
}

/// A temporary resources directory holding what the FMU's `resources/` ships (a sensor's
/// `config.json`, the scenario player's `scenario.json`).
pub fn resources_dir_of(desc: &FmuDescriptor) -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    for (name, content) in desc.resource_files() {
        std::fs::write(dir.path().join(name), content).unwrap();
    }
    dir
}

/// `file:///…/` URI of a directory.
pub fn dir_uri(dir: &std::path::Path) -> String {
    url::Url::from_directory_path(dir).unwrap().to_string()
}

/// Options of [`Inst::try_new`].
pub struct Opts<'a> {
    pub name: Option<&'a str>,
    pub fmu_type: Fmi2Type,
    /// `None`: the descriptor's GUID.
    pub guid: Option<&'a str>,
    /// `Some(None)`: NULL resource location; `None`: a fresh temp dir with the default config.
    pub resources: Option<Option<String>>,
    pub logging_on: bool,
    /// Use a NULL logger.
    pub null_logger: bool,
}

impl Default for Opts<'_> {
    fn default() -> Self {
        Opts {
            name: Some("test"),
            fmu_type: FMI2_CO_SIMULATION,
            guid: None,
            resources: None,
            logging_on: true,
            null_logger: false,
        }
    }
}

/// An instance plus its log collector and resources directory. Freed on drop.
pub struct Inst {
    pub c: Fmi2Component,
    pub log: Box<LogCollector>,
    pub desc: &'static FmuDescriptor,
    _resources: Option<tempfile::TempDir>,
}

// The instance is used by one thread at a time (moved, not shared).
unsafe impl Send for Inst {}

impl Inst {
    /// `fmi2Instantiate` with options; `Err(log)` if it returned NULL.
    pub fn try_new(
        desc: &'static FmuDescriptor,
        opts: Opts<'_>,
    ) -> Result<Inst, Box<LogCollector>> {
        let log = LogCollector::new();
        let mut callbacks = Box::new(Fmi2CallbackFunctions {
            logger: if opts.null_logger {
                None
            } else {
                Some(test_logger())
            },
            component_environment: log.env(),
            ..Default::default()
        });
        let name = opts.name.map(|n| CString::new(n).unwrap());
        let guid = CString::new(opts.guid.unwrap_or(desc.guid())).unwrap();
        let (tmp, location) = match opts.resources {
            None => {
                let d = resources_dir_of(desc);
                let uri = dir_uri(d.path());
                (Some(d), Some(uri))
            }
            Some(loc) => (None, loc),
        };
        let location = location.map(|l| CString::new(l).unwrap());
        let c = unsafe {
            abi::instantiate(
                desc,
                name.as_ref().map_or(ptr::null(), |n| n.as_ptr()),
                opts.fmu_type,
                guid.as_ptr(),
                location.as_ref().map_or(ptr::null(), |l| l.as_ptr()),
                &*callbacks,
                FMI2_FALSE,
                if opts.logging_on {
                    FMI2_TRUE
                } else {
                    FMI2_FALSE
                },
            )
        };
        // The callbacks struct, name, GUID and location die here: the FMU must have copied them.
        *callbacks = Fmi2CallbackFunctions::default();
        drop(callbacks);
        drop(name);
        drop(location);
        if c.is_null() {
            Err(log)
        } else {
            Ok(Inst {
                c,
                log,
                desc,
                _resources: tmp,
            })
        }
    }

    /// A radar instance with default options.
    pub fn radar() -> Inst {
        Inst::new(&sensors::radar::DESCRIPTOR)
    }

    pub fn new(desc: &'static FmuDescriptor) -> Inst {
        Inst::try_new(desc, Opts::default())
            .unwrap_or_else(|log| panic!("instantiate failed: {:?}", log.records()))
    }

    pub fn setup(&self) -> Fmi2Status {
        unsafe { abi::setup_experiment(self.c, FMI2_FALSE, 0.0, 0.0, FMI2_FALSE, 0.0) }
    }
    pub fn enter(&self) -> Fmi2Status {
        unsafe { abi::enter_initialization_mode(self.c) }
    }
    pub fn exit(&self) -> Fmi2Status {
        unsafe { abi::exit_initialization_mode(self.c) }
    }
    pub fn terminate(&self) -> Fmi2Status {
        unsafe { abi::terminate(self.c) }
    }
    pub fn reset(&self) -> Fmi2Status {
        unsafe { abi::reset(self.c) }
    }
    /// setup + enter + exit, each expected OK.
    pub fn init(&self) {
        assert_eq!(self.setup(), OK, "{:?}", self.log.records());
        assert_eq!(self.enter(), OK, "{:?}", self.log.records());
        assert_eq!(self.exit(), OK, "{:?}", self.log.records());
    }
    /// An initialized radar instance.
    pub fn radar_initialized() -> Inst {
        let i = Inst::radar();
        i.init();
        i
    }

    pub fn step(&self, t: f64, h: f64) -> Fmi2Status {
        unsafe { abi::do_step(self.c, t, h, FMI2_TRUE) }
    }

    pub fn set_ints(&self, vrs: &[u32], values: &[i32]) -> Fmi2Status {
        assert_eq!(vrs.len(), values.len());
        unsafe { abi::set_integer(self.c, vrs.as_ptr(), vrs.len(), values.as_ptr()) }
    }
    pub fn get_ints(&self, vrs: &[u32]) -> (Fmi2Status, Vec<i32>) {
        let mut out = vec![-7; vrs.len()];
        let s = unsafe { abi::get_integer(self.c, vrs.as_ptr(), vrs.len(), out.as_mut_ptr()) };
        (s, out)
    }
    pub fn set_reals(&self, vrs: &[u32], values: &[f64]) -> Fmi2Status {
        unsafe { abi::set_real(self.c, vrs.as_ptr(), vrs.len(), values.as_ptr()) }
    }
    pub fn get_reals(&self, vrs: &[u32]) -> (Fmi2Status, Vec<f64>) {
        let mut out = vec![f64::NAN; vrs.len()];
        let s = unsafe { abi::get_real(self.c, vrs.as_ptr(), vrs.len(), out.as_mut_ptr()) };
        (s, out)
    }
    pub fn set_strings(&self, vrs: &[u32], values: &[&str]) -> Fmi2Status {
        let owned: Vec<CString> = values.iter().map(|v| CString::new(*v).unwrap()).collect();
        let ptrs: Vec<Fmi2String> = owned.iter().map(|s| s.as_ptr()).collect();
        unsafe { abi::set_string(self.c, vrs.as_ptr(), vrs.len(), ptrs.as_ptr()) }
    }
    pub fn get_strings(&self, vrs: &[u32]) -> (Fmi2Status, Vec<String>) {
        let mut out = vec![ptr::null(); vrs.len()];
        let s = unsafe { abi::get_string(self.c, vrs.as_ptr(), vrs.len(), out.as_mut_ptr()) };
        let strings = out
            .iter()
            .map(|&p| {
                if p.is_null() {
                    "(NULL)".into()
                } else {
                    unsafe { CStr::from_ptr(p) }.to_str().unwrap().to_string()
                }
            })
            .collect();
        (s, strings)
    }
    pub fn get_valid(&self) -> (Fmi2Status, bool) {
        let mut v = -1;
        let s = unsafe { abi::get_boolean(self.c, &vr::boolean::VALID, 1, &mut v) };
        (s, v != 0)
    }

    /// Point the SensorView input at `bytes` (which must outlive the next DoStep).
    pub fn set_input(&self, bytes: &[u8]) -> Fmi2Status {
        let (lo, hi) = osiris_fmu::osmp::split_address(bytes.as_ptr() as usize);
        self.set_ints(&vr::integer::SENSOR_VIEW_IN, &[lo, hi, bytes.len() as i32])
    }
    /// The published triple of an output.
    pub fn triple(&self, vrs: [u32; 3]) -> [i32; 3] {
        let (s, v) = self.get_ints(&vrs);
        assert_eq!(s, OK);
        [v[0], v[1], v[2]]
    }
    /// The published SensorData (None for 0/0/0).
    pub fn sensor_data(&self) -> Option<osi3::SensorData> {
        read_triple(self.triple(vr::integer::SENSOR_DATA_OUT))
            .map(|b| osi3::SensorData::decode(b.as_slice()).unwrap())
    }
    /// The published PerceptionData (None for 0/0/0).
    pub fn perception(&self) -> Option<perception::PerceptionData> {
        read_triple(self.triple(vr::integer::PERCEPTION_DATA_OUT))
            .map(|b| perception::PerceptionData::decode(b.as_slice()).unwrap())
    }

    pub fn records(&self) -> Vec<LogRecord> {
        self.log.records()
    }
}

impl Drop for Inst {
    fn drop(&mut self) {
        unsafe { abi::free_instance(self.c) };
    }
}

/// Copy the bytes an OSMP triple names (None for "no buffer").
pub fn read_triple(t: [i32; 3]) -> Option<Vec<u8>> {
    let (addr, len) = osiris_fmu::osmp::address(t).unwrap()?;
    Some(unsafe { std::slice::from_raw_parts(addr as *const u8, len) }.to_vec())
}

fn v3(x: f64, y: f64, z: f64) -> osi3::Vector3d {
    osi3::Vector3d {
        x: Some(x),
        y: Some(y),
        z: Some(z),
    }
}

fn car(id: u64, x: f64, y: f64) -> osi3::MovingObject {
    osi3::MovingObject {
        id: Some(osiris_proto::id(id)),
        base: Some(osi3::BaseMoving {
            dimension: Some(osi3::Dimension3d {
                length: Some(4.5),
                width: Some(1.8),
                height: Some(1.5),
            }),
            position: Some(v3(x, y, 0.75)),
            orientation: Some(osi3::Orientation3d {
                roll: Some(0.0),
                pitch: Some(0.0),
                yaw: Some(0.0),
            }),
            velocity: Some(v3(10.0, 0.0, 0.0)),
            ..Default::default()
        }),
        ..Default::default()
    }
}

/// A SensorView at `t_s` with a host (id 1) and two cars ahead, sensor id `sensor_id`, a
/// timestamp, ground truth and a mounting position.
pub fn sample_view(t_s: f64, sensor_id: u64) -> osi3::SensorView {
    let ts = osiris_proto::timestamp_from_seconds(t_s);
    osi3::SensorView {
        version: Some(osiris_proto::interface_version()),
        timestamp: Some(ts),
        sensor_id: Some(osiris_proto::id(sensor_id)),
        mounting_position: Some(osi3::MountingPosition {
            position: Some(v3(3.5, 0.1, 0.6)),
            orientation: Some(osi3::Orientation3d {
                roll: Some(0.0),
                pitch: Some(0.0),
                yaw: Some(0.0),
            }),
        }),
        host_vehicle_id: Some(osiris_proto::id(1)),
        global_ground_truth: Some(osi3::GroundTruth {
            version: Some(osiris_proto::interface_version()),
            timestamp: Some(ts),
            host_vehicle_id: Some(osiris_proto::id(1)),
            moving_object: vec![
                car(1, 10.0 * t_s, 0.0),
                car(2, 10.0 * t_s + 30.0, 0.0),
                car(3, 10.0 * t_s + 60.0, 3.5),
            ],
            ..Default::default()
        }),
        ..Default::default()
    }
}

/// Encoded [`sample_view`].
pub fn sample_view_bytes(t_s: f64, sensor_id: u64) -> Vec<u8> {
    sample_view(t_s, sensor_id).encode_to_vec()
}

/// Every record was logged with the format "%s".
pub fn assert_all_formats_are_percent_s(records: &[LogRecord]) {
    for r in records {
        assert_eq!(r.format, "%s", "{r:?}");
    }
}
