//! [`OsmpSensor`]: an OSMP sensor model (SensorView → SensorData) driven through an [`Instance`];
//! [`OsmpSource`]: an OSMP source model (→ SensorView, e.g. a scenario player or `OSMPDummySource`).

use osiris_proto::osi3;
use prost::Message;

use super::{
    BinaryVariable, BoxError, Causality, Fmi2Status, Fmu, Instance, InstanceOptions, InstanceState,
    MasterError, OSI_MIME_BASE, Result, Value, VarType, mime_base,
};

/// Prefix of the SensorView input (`OSMPSensorViewIn[1]` is accepted too).
pub const SENSOR_VIEW_IN: &str = "OSMPSensorViewIn";
/// Prefix of a source model's SensorView output (`OSMPSensorViewOut[1]` is accepted too).
pub const SENSOR_VIEW_OUT: &str = "OSMPSensorViewOut";
/// Prefix of the SensorData output.
pub const SENSOR_DATA_OUT: &str = "OSMPSensorDataOut";
/// Prefix of the SensorViewConfiguration request (calculatedParameter).
pub const SENSOR_VIEW_IN_CONFIG_REQUEST: &str = "OSMPSensorViewInConfigRequest";
/// Prefix of the granted SensorViewConfiguration (parameter).
pub const SENSOR_VIEW_IN_CONFIG: &str = "OSMPSensorViewInConfig";
/// Prefix of the osiris perception extension output (non-OSMP prefix, private MIME `type=PerceptionData`).
pub const PERCEPTION_DATA_OUT: &str = "PerceptionDataOut";

/// Splits a buffer address into the OSMP `base.lo` / `base.hi` Integer values (each bit-cast to i32),
/// as `encode_pointer_to_integer` in `OSMPDummySensor.cpp`.
pub fn encode_pointer(addr: u64) -> (i32, i32) {
    (addr as u32 as i32, (addr >> 32) as u32 as i32)
}

/// Rebuilds a buffer address from `base.lo` / `base.hi`: `((hi as u32 as u64) << 32) | (lo as u32 as u64)`.
pub fn decode_pointer(lo: i32, hi: i32) -> u64 {
    (u64::from(hi as u32) << 32) | u64::from(lo as u32)
}

/// What one [`OsmpSensor::step`] produced. The bytes are copies, so they stay valid after later steps.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct StepOutputs {
    /// The encoded `osi3::SensorData`, or `None` if the FMU published no buffer (address 0 or size 0).
    pub sensor_data: Option<Vec<u8>>,
    /// The encoded `osiris.perception.PerceptionData`, if the FMU has that output and published a buffer.
    pub perception: Option<Vec<u8>>,
    /// The FMU's Boolean output `valid` if it has one, else whether SensorData was published.
    pub valid: bool,
    /// `fmi2DoStep`'s status: `Ok`, `Warning` or `Discard`.
    pub status: Fmi2Status,
}

/// An OSMP sensor model instance.
///
/// Lifecycle: [`OsmpSensor::instantiate`] → [`OsmpSensor::initialize`] (parameters, the
/// SensorViewConfiguration handshake) → [`OsmpSensor::step`] per communication point → drop (terminates and
/// frees).
///
/// The sensor finds its binary variables by prefix: `OSMPSensorViewIn` and `OSMPSensorDataOut` (required;
/// `…[1]` forms accepted, further indexed inputs stay unconnected), `OSMPSensorViewInConfigRequest` and
/// `OSMPSensorViewInConfig` (optional), and an output whose MIME type is `type=PerceptionData` or whose prefix
/// ends with `PerceptionDataOut` (optional).
///
/// Buffer addresses the FMU publishes are trusted, as the OSMP contract requires: a wrong address from the
/// FMU is a bug in the FMU, like any other memory error in loaded native code.
#[derive(Debug)]
pub struct OsmpSensor {
    instance: Instance,
    sensor_view_in: BinaryVariable,
    sensor_data_out: BinaryVariable,
    config_request: Option<BinaryVariable>,
    config: Option<BinaryVariable>,
    perception_out: Option<BinaryVariable>,
    valid_vr: Option<u32>,
    requested: Option<osi3::SensorViewConfiguration>,
    granted: Option<osi3::SensorViewConfiguration>,
}

impl OsmpSensor {
    /// Instantiates `fmu` and wraps the instance.
    pub fn instantiate(fmu: &Fmu, name: &str, options: InstanceOptions) -> Result<OsmpSensor> {
        // Check the model before instantiating.
        Self::find_variables(fmu.model_description())?;
        Self::new(fmu.instantiate(name, options)?)
    }

    /// Wraps a freshly instantiated (not yet initialized) instance of an OSMP sensor FMU.
    pub fn new(instance: Instance) -> Result<OsmpSensor> {
        let v = Self::find_variables(instance.model_description())?;
        Ok(OsmpSensor {
            instance,
            sensor_view_in: v.sensor_view_in,
            sensor_data_out: v.sensor_data_out,
            config_request: v.config_request,
            config: v.config,
            perception_out: v.perception_out,
            valid_vr: v.valid_vr,
            requested: None,
            granted: None,
        })
    }

    fn find_variables(md: &super::ModelDescription) -> Result<FoundVariables> {
        let not_osmp = |reason: String| MasterError::NotOsmpSensor {
            model: md.model_name.clone(),
            reason,
        };
        if md.osmp.is_none() {
            return Err(not_osmp(
                "no OSMP marker (<VendorAnnotations><Tool name=\"net.pmsf.osmp\"><osmp:osmp …/>)"
                    .to_owned(),
            ));
        }
        let find = |prefix: &str| {
            md.binary_variable(prefix)
                .or_else(|| md.binary_variable(&format!("{prefix}[1]")))
                .cloned()
        };
        let check = |b: &BinaryVariable, causality: Causality, osi_type: &str| -> Result<()> {
            if b.causality != causality {
                return Err(not_osmp(format!(
                    "binary variable `{}` has causality {}, expected {causality}",
                    b.prefix, b.causality
                )));
            }
            if mime_base(&b.mime) != OSI_MIME_BASE || b.mime_parameter("type") != Some(osi_type) {
                return Err(not_osmp(format!(
                    "binary variable `{}` has MIME type \"{}\", expected \"{OSI_MIME_BASE}; type={osi_type}; …\"",
                    b.prefix, b.mime
                )));
            }
            Ok(())
        };
        let required = |prefix: &str| {
            find(prefix).ok_or_else(|| {
                not_osmp(format!(
                    "no binary variable `{prefix}` (Integer variables `{prefix}.base.lo`, `.base.hi`, `.size`)"
                ))
            })
        };
        let sensor_view_in = required(SENSOR_VIEW_IN)?;
        check(&sensor_view_in, Causality::Input, "SensorView")?;
        let sensor_data_out = required(SENSOR_DATA_OUT)?;
        check(&sensor_data_out, Causality::Output, "SensorData")?;
        let config_request = find(SENSOR_VIEW_IN_CONFIG_REQUEST);
        if let Some(b) = &config_request {
            check(b, Causality::CalculatedParameter, "SensorViewConfiguration")?;
        }
        let config = find(SENSOR_VIEW_IN_CONFIG);
        if let Some(b) = &config {
            check(b, Causality::Parameter, "SensorViewConfiguration")?;
        }
        let perception_out = md
            .binary_variables
            .iter()
            .find(|b| {
                b.causality == Causality::Output
                    && (b.mime_parameter("type") == Some("PerceptionData")
                        || b.prefix.ends_with(PERCEPTION_DATA_OUT))
            })
            .cloned();
        let valid_vr = md
            .variable("valid")
            .filter(|v| v.var_type == VarType::Boolean && v.causality == Causality::Output)
            .map(|v| v.value_reference);
        Ok(FoundVariables {
            sensor_view_in,
            sensor_data_out,
            config_request,
            config,
            perception_out,
            valid_vr,
        })
    }

    /// The instance name.
    pub fn name(&self) -> &str {
        self.instance.name()
    }

    /// The underlying instance (log, state, model description).
    pub fn instance(&self) -> &Instance {
        &self.instance
    }

    /// The underlying instance, e.g. to set tunable parameters between steps.
    pub fn instance_mut(&mut self) -> &mut Instance {
        &mut self.instance
    }

    /// Unwraps the instance.
    pub fn into_instance(self) -> Instance {
        self.instance
    }

    /// The binary variables in use: (SensorViewIn, SensorDataOut, PerceptionDataOut).
    pub fn binary_variables(&self) -> (&BinaryVariable, &BinaryVariable, Option<&BinaryVariable>) {
        (
            &self.sensor_view_in,
            &self.sensor_data_out,
            self.perception_out.as_ref(),
        )
    }

    /// Whether the FMU has a perception extension output.
    pub fn has_perception_output(&self) -> bool {
        self.perception_out.is_some()
    }

    /// `DefaultExperiment/@stepSize` (the OSMP sensor cycle), if declared.
    pub fn default_step_size(&self) -> Option<f64> {
        self.instance
            .model_description()
            .default_experiment
            .and_then(|d| d.step_size)
    }

    /// The SensorViewConfiguration the model requested during initialization (if it has the request
    /// variable and published a buffer).
    pub fn requested_configuration(&self) -> Option<&osi3::SensorViewConfiguration> {
        self.requested.as_ref()
    }

    /// The SensorViewConfiguration granted to the model (set as `OSMPSensorViewInConfig`), if any.
    pub fn granted_configuration(&self) -> Option<&osi3::SensorViewConfiguration> {
        self.granted.as_ref()
    }

    /// Initializes with no stop time, granting the configuration request unchanged; see
    /// [`OsmpSensor::initialize_with`].
    pub fn initialize(&mut self, start_time: f64, params: &[(&str, Value)]) -> Result<()> {
        self.initialize_with(start_time, None, params, |_| Ok(()))
    }

    /// Sets `params` (by variable name, before initialization mode: parameters with `initial` exact/approx),
    /// calls `fmi2SetupExperiment(start_time, stop_time)`, enters initialization mode, runs the OSMP
    /// configuration handshake and exits initialization mode.
    ///
    /// Handshake: if the model publishes an `OSMPSensorViewInConfigRequest`, it is decoded, passed to `grant`
    /// (which may modify it to what the environment can supply, or refuse it with an error), encoded and set
    /// as `OSMPSensorViewInConfig`; the buffer lives until `fmi2ExitInitializationMode` returns.
    pub fn initialize_with(
        &mut self,
        start_time: f64,
        stop_time: Option<f64>,
        params: &[(&str, Value)],
        grant: impl FnOnce(&mut osi3::SensorViewConfiguration) -> Result<(), BoxError>,
    ) -> Result<()> {
        if self.instance.state() != InstanceState::Instantiated {
            return Err(self.illegal(
                "initialize",
                "Instantiated (initialize once after instantiation or reset)",
            ));
        }
        for (name, value) in params {
            self.instance.set(name, value.clone())?;
        }
        self.instance
            .setup_experiment(None, start_time, stop_time)?;
        self.instance.enter_initialization_mode()?;
        self.requested = None;
        self.granted = None;

        // Kept alive until exit_initialization_mode has returned.
        let mut config_buffer: Vec<u8> = Vec::new();
        let request = match self.config_request.clone() {
            Some(req) => self.read_buffer(&req)?.map(|bytes| (req, bytes)),
            None => None,
        };
        if let Some((req, bytes)) = request {
            let requested =
                osi3::SensorViewConfiguration::decode(bytes.as_slice()).map_err(|e| {
                    self.osmp_error(
                        &req.prefix,
                        format!("cannot decode the SensorViewConfiguration request: {e}"),
                    )
                })?;
            let mut granted = requested.clone();
            grant(&mut granted).map_err(|source| MasterError::ConfigNotGranted {
                instance: self.name().to_owned(),
                source,
            })?;
            if let Some(cfg) = self.config.clone() {
                config_buffer = granted.encode_to_vec();
                let (lo, hi) = encode_pointer(config_buffer.as_ptr() as u64);
                let size = self.buffer_size(&cfg.prefix, config_buffer.len())?;
                self.instance.set_integer(&cfg.vrs(), &[lo, hi, size])?;
                self.granted = Some(granted);
            }
            self.requested = Some(requested);
        }
        self.instance.exit_initialization_mode()?;
        drop(config_buffer);
        Ok(())
    }

    /// One communication step: points `OSMPSensorViewIn` at `sensor_view` (an encoded `osi3::SensorView`;
    /// empty = no input), calls `fmi2DoStep(t, h)` and copies the published output buffers.
    pub fn step(&mut self, sensor_view: &[u8], t: f64, h: f64) -> Result<StepOutputs> {
        if self.instance.state() != InstanceState::Initialized {
            return Err(self.illegal("step", "Initialized (call initialize first)"));
        }
        let size = self.buffer_size(&self.sensor_view_in.prefix, sensor_view.len())?;
        let (lo, hi) = if size == 0 {
            (0, 0)
        } else {
            encode_pointer(sensor_view.as_ptr() as u64)
        };
        let vrs = self.sensor_view_in.vrs();
        self.instance.set_integer(&vrs, &[lo, hi, size])?;
        // `sensor_view` is borrowed for this whole call, so it outlives the DoStep that reads it.
        let status = self.instance.do_step(t, h, true)?;

        let sensor_data = self.read_buffer(&self.sensor_data_out.clone())?;
        let perception = match self.perception_out.clone() {
            Some(b) => self.read_buffer(&b)?,
            None => None,
        };
        let valid = match self.valid_vr {
            Some(vr) => {
                let mut v = [false];
                self.instance.get_boolean(&[vr], &mut v)?;
                v[0]
            }
            None => sensor_data.is_some(),
        };
        Ok(StepOutputs {
            sensor_data,
            perception,
            valid,
            status,
        })
    }

    /// `fmi2Terminate` (dropping does it too).
    pub fn terminate(&mut self) -> Result<()> {
        self.instance.terminate().map(|_| ())
    }

    /// Reads a binary variable's triple and copies the buffer (`None` for address 0 or size 0).
    fn read_buffer(&mut self, b: &BinaryVariable) -> Result<Option<Vec<u8>>> {
        let mut v = [0i32; 3];
        self.instance.get_integer(&b.vrs(), &mut v)?;
        let [lo, hi, size] = v;
        let addr = decode_pointer(lo, hi);
        if size < 0 {
            return Err(self.osmp_error(&b.prefix, format!("negative size {size}")));
        }
        if addr == 0 || size == 0 {
            return Ok(None);
        }
        let Ok(addr) = usize::try_from(addr) else {
            return Err(self.osmp_error(
                &b.prefix,
                format!("address {addr:#x} does not fit this platform"),
            ));
        };
        // SAFETY: OSMP contract: the FMU published `size` readable bytes at `addr`, valid until the start of
        // the second DoStep after the producing one (outputs) or until exit-init (config request). We copy
        // them now, before any further DoStep.
        let bytes =
            unsafe { std::slice::from_raw_parts(addr as *const u8, size as usize) }.to_vec();
        Ok(Some(bytes))
    }

    fn buffer_size(&self, prefix: &str, len: usize) -> Result<i32> {
        i32::try_from(len).map_err(|_| {
            self.osmp_error(
                prefix,
                format!(
                    "buffer of {len} bytes exceeds the OSMP size limit of {} bytes",
                    i32::MAX
                ),
            )
        })
    }

    fn osmp_error(&self, prefix: &str, reason: String) -> MasterError {
        MasterError::Osmp {
            instance: self.name().to_owned(),
            prefix: prefix.to_owned(),
            reason,
        }
    }

    fn illegal(&self, action: &'static str, expected: &'static str) -> MasterError {
        MasterError::IllegalState {
            instance: self.name().to_owned(),
            action,
            state: format!("{:?}", self.instance.state()),
            expected,
        }
    }
}

/// An OSMP source model instance: an FMU with the output `OSMPSensorViewOut` (MIME type
/// `type=SensorView`), stepped by the master to produce the SensorViews it feeds to the sensors.
///
/// Lifecycle: [`OsmpSource::instantiate`] → [`OsmpSource::initialize`] → [`OsmpSource::step`] per
/// communication point → drop. After `fmi2DoStep(t, h)` the output is the SensorView at `t + h`.
#[derive(Debug)]
pub struct OsmpSource {
    instance: Instance,
    sensor_view_out: BinaryVariable,
}

impl OsmpSource {
    /// Instantiates `fmu` (checked first: OSMP marker, an `OSMPSensorViewOut` output of SensorViews).
    pub fn instantiate(fmu: &Fmu, name: &str, options: InstanceOptions) -> Result<OsmpSource> {
        let sensor_view_out = Self::find_output(fmu.model_description())?;
        Ok(OsmpSource {
            instance: fmu.instantiate(name, options)?,
            sensor_view_out,
        })
    }

    fn find_output(md: &super::ModelDescription) -> Result<BinaryVariable> {
        let not_source = |reason: String| MasterError::NotOsmpSensor {
            model: md.model_name.clone(),
            reason: format!("not a usable OSMP source: {reason}"),
        };
        if md.osmp.is_none() {
            return Err(not_source(
                "no OSMP marker (<VendorAnnotations><Tool name=\"net.pmsf.osmp\"><osmp:osmp …/>)"
                    .to_owned(),
            ));
        }
        let b = md
            .binary_variable(SENSOR_VIEW_OUT)
            .or_else(|| md.binary_variable(&format!("{SENSOR_VIEW_OUT}[1]")))
            .cloned()
            .ok_or_else(|| {
                not_source(format!(
                    "no binary variable `{SENSOR_VIEW_OUT}` (Integer variables `{SENSOR_VIEW_OUT}.base.lo`, \
                     `.base.hi`, `.size`)"
                ))
            })?;
        if b.causality != Causality::Output {
            return Err(not_source(format!(
                "binary variable `{}` has causality {}, expected output",
                b.prefix, b.causality
            )));
        }
        if mime_base(&b.mime) != OSI_MIME_BASE || b.mime_parameter("type") != Some("SensorView") {
            return Err(not_source(format!(
                "binary variable `{}` has MIME type \"{}\", expected \"{OSI_MIME_BASE}; type=SensorView; …\"",
                b.prefix, b.mime
            )));
        }
        Ok(b)
    }

    /// The instance name.
    pub fn name(&self) -> &str {
        self.instance.name()
    }

    /// The underlying instance.
    pub fn instance(&self) -> &Instance {
        &self.instance
    }

    /// The SensorView output in use.
    pub fn binary_variable(&self) -> &BinaryVariable {
        &self.sensor_view_out
    }

    /// `DefaultExperiment/@stepSize`, if declared.
    pub fn default_step_size(&self) -> Option<f64> {
        self.instance
            .model_description()
            .default_experiment
            .and_then(|d| d.step_size)
    }

    /// Sets `params` (by name), `fmi2SetupExperiment(start_time)`, enters and exits initialization mode.
    pub fn initialize(&mut self, start_time: f64, params: &[(&str, Value)]) -> Result<()> {
        if self.instance.state() != InstanceState::Instantiated {
            return Err(MasterError::IllegalState {
                instance: self.name().to_owned(),
                action: "initialize",
                state: format!("{:?}", self.instance.state()),
                expected: "Instantiated (initialize once after instantiation or reset)",
            });
        }
        for (name, value) in params {
            self.instance.set(name, value.clone())?;
        }
        self.instance.setup_experiment(None, start_time, None)?;
        self.instance.enter_initialization_mode()?;
        self.instance.exit_initialization_mode()?;
        Ok(())
    }

    /// `fmi2DoStep(t, h)`, then a copy of the published SensorView (`None`: no buffer).
    pub fn step(&mut self, t: f64, h: f64) -> Result<Option<Vec<u8>>> {
        if self.instance.state() != InstanceState::Initialized {
            return Err(MasterError::IllegalState {
                instance: self.name().to_owned(),
                action: "step",
                state: format!("{:?}", self.instance.state()),
                expected: "Initialized (call initialize first)",
            });
        }
        self.instance.do_step(t, h, true)?;
        let b = self.sensor_view_out.clone();
        let mut v = [0i32; 3];
        self.instance.get_integer(&b.vrs(), &mut v)?;
        let [lo, hi, size] = v;
        if size < 0 {
            return Err(MasterError::Osmp {
                instance: self.name().to_owned(),
                prefix: b.prefix,
                reason: format!("negative size {size}"),
            });
        }
        let addr = decode_pointer(lo, hi);
        if addr == 0 || size == 0 {
            return Ok(None);
        }
        let Ok(addr) = usize::try_from(addr) else {
            return Err(MasterError::Osmp {
                instance: self.name().to_owned(),
                prefix: b.prefix,
                reason: format!("address {addr:#x} does not fit this platform"),
            });
        };
        // SAFETY: OSMP contract: the FMU published `size` readable bytes at `addr`, valid until the
        // second DoStep after this one; we copy them now.
        Ok(Some(
            unsafe { std::slice::from_raw_parts(addr as *const u8, size as usize) }.to_vec(),
        ))
    }

    /// `fmi2Terminate` (dropping does it too).
    pub fn terminate(&mut self) -> Result<()> {
        self.instance.terminate().map(|_| ())
    }
}

struct FoundVariables {
    sensor_view_in: BinaryVariable,
    sensor_data_out: BinaryVariable,
    config_request: Option<BinaryVariable>,
    config: Option<BinaryVariable>,
    perception_out: Option<BinaryVariable>,
    valid_vr: Option<u32>,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pointer_round_trip_with_high_bits() {
        for addr in [
            0u64,
            1,
            0x7fff_ffff,
            0x8000_0000,
            0xffff_ffff,
            0x1_8000_0000,
            0x8000_0000_0000_0000,
            u64::MAX,
        ] {
            let (lo, hi) = encode_pointer(addr);
            assert_eq!(decode_pointer(lo, hi), addr, "{addr:#x}");
        }
        assert_eq!(encode_pointer(0x8000_0000), (i32::MIN, 0));
        assert_eq!(encode_pointer(0x8000_0000_0000_0000), (0, i32::MIN));
        assert_eq!(encode_pointer(u64::MAX), (-1, -1));
    }
}
