//! The co-simulation master against a mock OSMP sensor FMU written in C (compiled here with the system C
//! compiler), independent of the osiris FMU shell: loading (dir and zip), the variadic logger, typed get/set
//! by value reference and name, the configuration handshake, stepping with pointer packing and double
//! buffering, call-order errors, `Drop`, several instances, and the multi-sensor runner.

use std::convert::Infallible;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::{Arc, Mutex, OnceLock};

use osiris::master::{
    BaseType, Fmi2Status, Fmu, Frame, InstanceOptions, InstanceState, LogRecord, MasterError,
    OsmpSensor, RunOptions, StepRecord, Value, run,
};
use osiris_proto::osi3;
use prost::Message;

const GUID: &str = "{8c4e810f-3df3-4a00-8276-176fa3c9f000}";

/// The mock sensor: SensorData = { sensor_view: [the input SensorView] }, PerceptionData = 8 bytes (step
/// counter, little-endian), request = { range = 1.1 * nominal_range }.
const MOCK_C: &str = r#"
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

typedef void *fmi2Component;
typedef void *fmi2ComponentEnvironment;
typedef void *fmi2FMUstate;
typedef unsigned int fmi2ValueReference;
typedef double fmi2Real;
typedef int fmi2Integer;
typedef int fmi2Boolean;
typedef char fmi2Char;
typedef const fmi2Char *fmi2String;
typedef char fmi2Byte;
typedef enum { fmi2OK, fmi2Warning, fmi2Discard, fmi2Error, fmi2Fatal, fmi2Pending } fmi2Status;
typedef int fmi2Type;
typedef int fmi2StatusKind;
typedef struct {
    void (*logger)(fmi2ComponentEnvironment, fmi2String, fmi2Status, fmi2String, fmi2String, ...);
    void *(*allocateMemory)(size_t, size_t);
    void (*freeMemory)(void *);
    void (*stepFinished)(fmi2ComponentEnvironment, fmi2Status);
    fmi2ComponentEnvironment componentEnvironment;
} fmi2CallbackFunctions;

#define EXPORT __attribute__((visibility("default")))

static int live_instances = 0;
static int terminate_calls = 0;
EXPORT int mock_live_instances(void) { return __atomic_load_n(&live_instances, __ATOMIC_SEQ_CST); }
EXPORT int mock_terminate_calls(void) { return __atomic_load_n(&terminate_calls, __ATOMIC_SEQ_CST); }

enum { INSTANTIATED, INIT_MODE, STEP_MODE, TERMINATED };

typedef struct {
    fmi2CallbackFunctions cb;
    char name[128];
    char resources[1024];
    char *label;
    int logging_on;
    int state;
    int ints[16];
    double nominal_range, granted_range;
    int valid;
    unsigned char request[9];
    unsigned char *sd[2]; size_t sd_len[2];
    unsigned char *pd[2];
    int cur;
    long steps;
} Inst;

#define LOG(i, st, ...) (i)->cb.logger((i)->cb.componentEnvironment, (i)->name, st, "OSMP", __VA_ARGS__)
#define DEBUG(i, ...) do { if ((i)->logging_on) LOG(i, fmi2OK, __VA_ARGS__); } while (0)

static unsigned char *addr_of(int lo, int hi) {
    return (unsigned char *)(uintptr_t)(((uint64_t)(uint32_t)hi << 32) | (uint64_t)(uint32_t)lo);
}
static void publish(int *triple, const void *p, size_t n) {
    uint64_t a = (uint64_t)(uintptr_t)p;
    triple[0] = (int)(uint32_t)a; triple[1] = (int)(uint32_t)(a >> 32); triple[2] = (int)n;
}
static void set_defaults(Inst *i) {
    memset(i->ints, 0, sizeof i->ints);
    i->nominal_range = 135.0; i->granted_range = 0.0; i->valid = 0; i->steps = 0; i->state = INSTANTIATED;
    i->cb.freeMemory(i->label);
    i->label = i->cb.allocateMemory(5, 1); memcpy(i->label, "mock", 5);
}

EXPORT const char *fmi2GetTypesPlatform(void) { return "default"; }
EXPORT const char *fmi2GetVersion(void) { return "2.0"; }
EXPORT fmi2Status fmi2SetDebugLogging(fmi2Component c, fmi2Boolean on, size_t n, const fmi2String cats[]) {
    (void)n; (void)cats; ((Inst *)c)->logging_on = on; return fmi2OK;
}
EXPORT fmi2Component fmi2Instantiate(fmi2String name, fmi2Type type, fmi2String guid, fmi2String res,
                                     const fmi2CallbackFunctions *cb, fmi2Boolean visible, fmi2Boolean on) {
    (void)visible;
    if (!cb || !cb->logger || !cb->allocateMemory) return NULL;
    if (type != 1 || strcmp(guid, "{8c4e810f-3df3-4a00-8276-176fa3c9f000}") != 0) {
        cb->logger(cb->componentEnvironment, name, fmi2Error, "FMI",
                   "fmi2Instantiate: GUID %s does not match (fmuType %d)", guid, type);
        return NULL;
    }
    Inst *i = cb->allocateMemory(1, sizeof(Inst));
    i->cb = *cb;
    snprintf(i->name, sizeof i->name, "%s", name);
    snprintf(i->resources, sizeof i->resources, "%s", res ? res : "");
    i->logging_on = on;
    set_defaults(i);
    __atomic_add_fetch(&live_instances, 1, __ATOMIC_SEQ_CST);
    DEBUG(i, "instantiated %s with resources %s", name, i->resources);
    return i;
}
EXPORT void fmi2FreeInstance(fmi2Component c) {
    Inst *i = c; if (!i) return;
    for (int k = 0; k < 2; k++) { free(i->sd[k]); free(i->pd[k]); }
    i->cb.freeMemory(i->label);
    void (*f)(void *) = i->cb.freeMemory;
    f(i);
    __atomic_sub_fetch(&live_instances, 1, __ATOMIC_SEQ_CST);
}
EXPORT fmi2Status fmi2SetupExperiment(fmi2Component c, fmi2Boolean td, fmi2Real tol, fmi2Real start,
                                      fmi2Boolean sd, fmi2Real stop) {
    Inst *i = c; (void)td; (void)tol; (void)sd; (void)stop;
    if (i->state != INSTANTIATED) { LOG(i, fmi2Error, "fmi2SetupExperiment: illegal in state %d", i->state); return fmi2Error; }
    DEBUG(i, "setup experiment at t=%g", start);
    return fmi2OK;
}
EXPORT fmi2Status fmi2EnterInitializationMode(fmi2Component c) {
    Inst *i = c;
    if (i->state != INSTANTIATED) { LOG(i, fmi2Error, "fmi2EnterInitializationMode: illegal in state %d", i->state); return fmi2Error; }
    /* request = SensorViewConfiguration { range (7, fixed64) = 1.1 * nominal_range } */
    double range = 1.1 * i->nominal_range;
    i->request[0] = 0x39; memcpy(i->request + 1, &range, 8);
    publish(i->ints + 6, i->request, 9);
    i->state = INIT_MODE;
    return fmi2OK;
}
EXPORT fmi2Status fmi2ExitInitializationMode(fmi2Component c) {
    Inst *i = c;
    if (i->state != INIT_MODE) { LOG(i, fmi2Error, "fmi2ExitInitializationMode: illegal in state %d", i->state); return fmi2Error; }
    unsigned char *cfg = addr_of(i->ints[9], i->ints[10]);
    if (cfg && i->ints[11] == 9 && cfg[0] == 0x39) {
        memcpy(&i->granted_range, cfg + 1, 8);
        DEBUG(i, "granted range %g", i->granted_range);
    } else if (cfg && i->ints[11] > 0) {
        LOG(i, fmi2Error, "unexpected SensorViewConfiguration of %d bytes", i->ints[11]);
        return fmi2Error;
    }
    i->ints[9] = i->ints[10] = i->ints[11] = 0; /* the Config buffer is invalid from now on */
    i->state = STEP_MODE;
    return fmi2OK;
}
EXPORT fmi2Status fmi2Terminate(fmi2Component c) {
    Inst *i = c;
    __atomic_add_fetch(&terminate_calls, 1, __ATOMIC_SEQ_CST);
    if (i->state != INIT_MODE && i->state != STEP_MODE) { LOG(i, fmi2Error, "fmi2Terminate: illegal in state %d", i->state); return fmi2Error; }
    i->state = TERMINATED;
    return fmi2OK;
}
EXPORT fmi2Status fmi2Reset(fmi2Component c) { set_defaults((Inst *)c); return fmi2OK; }

static int int_ok(fmi2ValueReference vr) { return vr <= 15; }
EXPORT fmi2Status fmi2GetReal(fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2Real v[]) {
    Inst *i = c;
    for (size_t k = 0; k < n; k++) {
        if (vr[k] == 0) v[k] = i->nominal_range;
        else if (vr[k] == 1) v[k] = i->granted_range;
        else { LOG(i, fmi2Error, "fmi2GetReal: unknown value reference %u", vr[k]); return fmi2Error; }
    }
    return fmi2OK;
}
EXPORT fmi2Status fmi2GetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2Integer v[]) {
    Inst *i = c;
    for (size_t k = 0; k < n; k++) {
        if (!int_ok(vr[k])) { LOG(i, fmi2Error, "fmi2GetInteger: unknown value reference %u", vr[k]); return fmi2Error; }
        v[k] = i->ints[vr[k]];
    }
    return fmi2OK;
}
EXPORT fmi2Status fmi2GetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2Boolean v[]) {
    Inst *i = c;
    for (size_t k = 0; k < n; k++) {
        if (vr[k] != 0) { LOG(i, fmi2Error, "fmi2GetBoolean: unknown value reference %u", vr[k]); return fmi2Error; }
        v[k] = i->valid;
    }
    return fmi2OK;
}
EXPORT fmi2Status fmi2GetString(fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2String v[]) {
    Inst *i = c;
    for (size_t k = 0; k < n; k++) {
        if (vr[k] == 0) v[k] = i->label;
        else if (vr[k] == 1) v[k] = i->resources;
        else { LOG(i, fmi2Error, "fmi2GetString: unknown value reference %u", vr[k]); return fmi2Error; }
    }
    return fmi2OK;
}
EXPORT fmi2Status fmi2SetReal(fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2Real v[]) {
    Inst *i = c;
    for (size_t k = 0; k < n; k++) {
        if (vr[k] != 0) { LOG(i, fmi2Error, "fmi2SetReal: value reference %u cannot be set", vr[k]); return fmi2Error; }
        if (i->state != INSTANTIATED && i->state != INIT_MODE) {
            LOG(i, fmi2Error, "fmi2SetReal: nominal_range is a fixed parameter; it cannot be set after initialization");
            return fmi2Error;
        }
        i->nominal_range = v[k];
    }
    return fmi2OK;
}
EXPORT fmi2Status fmi2SetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2Integer v[]) {
    Inst *i = c;
    for (size_t k = 0; k < n; k++) {
        int ok = vr[k] <= 2 || (vr[k] >= 9 && vr[k] <= 11 && i->state != STEP_MODE);
        if (!ok) { LOG(i, fmi2Error, "fmi2SetInteger: value reference %u cannot be set now", vr[k]); return fmi2Error; }
        i->ints[vr[k]] = v[k];
    }
    return fmi2OK;
}
EXPORT fmi2Status fmi2SetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2Boolean v[]) {
    Inst *i = c; (void)vr; (void)n; (void)v;
    LOG(i, fmi2Error, "fmi2SetBoolean: no settable Boolean variables"); return fmi2Error;
}
EXPORT fmi2Status fmi2SetString(fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2String v[]) {
    Inst *i = c;
    for (size_t k = 0; k < n; k++) {
        if (vr[k] != 0) { LOG(i, fmi2Error, "fmi2SetString: value reference %u cannot be set", vr[k]); return fmi2Error; }
        size_t len = strlen(v[k]);
        i->cb.freeMemory(i->label);
        i->label = i->cb.allocateMemory(len + 1, 1);
        memcpy(i->label, v[k], len + 1);
        DEBUG(i, "label set to '%s' (%zu bytes)", i->label, len);
    }
    return fmi2OK;
}
EXPORT fmi2Status fmi2GetFMUstate(fmi2Component c, fmi2FMUstate *s) { (void)c; (void)s; return fmi2Error; }
EXPORT fmi2Status fmi2SetFMUstate(fmi2Component c, fmi2FMUstate s) { (void)c; (void)s; return fmi2Error; }
EXPORT fmi2Status fmi2FreeFMUstate(fmi2Component c, fmi2FMUstate *s) { (void)c; (void)s; return fmi2Error; }
EXPORT fmi2Status fmi2SerializedFMUstateSize(fmi2Component c, fmi2FMUstate s, size_t *n) { (void)c; (void)s; (void)n; return fmi2Error; }
EXPORT fmi2Status fmi2SerializeFMUstate(fmi2Component c, fmi2FMUstate s, fmi2Byte b[], size_t n) { (void)c; (void)s; (void)b; (void)n; return fmi2Error; }
EXPORT fmi2Status fmi2DeSerializeFMUstate(fmi2Component c, const fmi2Byte b[], size_t n, fmi2FMUstate *s) { (void)c; (void)s; (void)b; (void)n; return fmi2Error; }
EXPORT fmi2Status fmi2GetDirectionalDerivative(fmi2Component c, const fmi2ValueReference u[], size_t nu,
    const fmi2ValueReference k[], size_t nk, const fmi2Real dk[], fmi2Real du[]) {
    (void)c; (void)u; (void)nu; (void)k; (void)nk; (void)dk; (void)du; return fmi2Error;
}
EXPORT fmi2Status fmi2SetRealInputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t n,
    const fmi2Integer o[], const fmi2Real v[]) { (void)c; (void)vr; (void)n; (void)o; (void)v; return fmi2Error; }
EXPORT fmi2Status fmi2GetRealOutputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t n,
    const fmi2Integer o[], fmi2Real v[]) { (void)c; (void)vr; (void)n; (void)o; (void)v; return fmi2Error; }

EXPORT fmi2Status fmi2DoStep(fmi2Component c, fmi2Real t, fmi2Real h, fmi2Boolean noPrior) {
    Inst *i = c; (void)noPrior;
    if (i->state != STEP_MODE) {
        LOG(i, fmi2Error, "fmi2DoStep(t=%g, h=%g): illegal call order, the instance is not initialized (state %d)", t, h, i->state);
        return fmi2Error;
    }
    if (h <= 0) { LOG(i, fmi2Error, "fmi2DoStep: step size %g must be positive", h); return fmi2Error; }
    i->steps++;
    int k = i->cur; i->cur ^= 1;
    unsigned char *in = addr_of(i->ints[0], i->ints[1]);
    int n = i->ints[2];
    if (!in || n <= 0) {
        i->ints[3] = i->ints[4] = i->ints[5] = 0;
        i->ints[12] = i->ints[13] = i->ints[14] = 0;
        i->valid = 0;
        LOG(i, fmi2Warning, "fmi2DoStep(t=%g): no SensorView input", t);
        return fmi2Warning;
    }
    /* SensorData { sensor_view (8, LEN) = input }: tag 0x42, varint length, bytes */
    unsigned char hdr[16]; size_t hn = 0; hdr[hn++] = 0x42;
    for (uint32_t v = (uint32_t)n; ; ) { unsigned char b = v & 0x7f; v >>= 7; if (v) { hdr[hn++] = b | 0x80; } else { hdr[hn++] = b; break; } }
    i->sd[k] = realloc(i->sd[k], hn + (size_t)n);
    memcpy(i->sd[k], hdr, hn); memcpy(i->sd[k] + hn, in, (size_t)n);
    publish(i->ints + 3, i->sd[k], hn + (size_t)n);
    i->pd[k] = realloc(i->pd[k], 8);
    memcpy(i->pd[k], &i->steps, 8);
    publish(i->ints + 12, i->pd[k], 8);
    i->ints[15] = (int)i->steps;
    i->valid = 1;
    DEBUG(i, "step %ld at t=%g: %d bytes in", i->steps, t, n);
    return fmi2OK;
}
#ifndef OMIT_CANCEL_STEP
EXPORT fmi2Status fmi2CancelStep(fmi2Component c) { (void)c; return fmi2Error; }
#endif
EXPORT fmi2Status fmi2GetStatus(fmi2Component c, const fmi2StatusKind s, fmi2Status *v) { (void)c; (void)s; (void)v; return fmi2Discard; }
EXPORT fmi2Status fmi2GetRealStatus(fmi2Component c, const fmi2StatusKind s, fmi2Real *v) { (void)c; (void)s; (void)v; return fmi2Discard; }
EXPORT fmi2Status fmi2GetIntegerStatus(fmi2Component c, const fmi2StatusKind s, fmi2Integer *v) { (void)c; (void)s; (void)v; return fmi2Discard; }
EXPORT fmi2Status fmi2GetBooleanStatus(fmi2Component c, const fmi2StatusKind s, fmi2Boolean *v) { (void)c; (void)s; (void)v; return fmi2Discard; }
EXPORT fmi2Status fmi2GetStringStatus(fmi2Component c, const fmi2StatusKind s, fmi2String *v) { (void)c; (void)s; (void)v; return fmi2Discard; }
"#;

fn binary_triple(prefix: &str, first_vr: u32, attrs: &str, start: &str, mime: &str) -> String {
    ["base.lo", "base.hi", "size"]
        .iter()
        .enumerate()
        .map(|(k, role)| {
            format!(
                r#"<ScalarVariable name="{prefix}.{role}" valueReference="{vr}" {attrs}><Integer{start}/>
  <Annotations><Tool name="net.pmsf.osmp" xmlns:osmp="http://xsd.pmsf.net/OSISensorModelPackaging"><osmp:osmp-binary-variable name="{prefix}" role="{role}" mime-type="{mime}"/></Tool></Annotations></ScalarVariable>
"#,
                vr = first_vr + k as u32
            )
        })
        .collect()
}

fn model_description(guid: &str) -> String {
    let osi = |t: &str| format!("application/x-open-simulation-interface; type={t}; version=3.8.0");
    let mut vars = String::new();
    vars += &binary_triple(
        "OSMPSensorViewIn",
        0,
        r#"causality="input" variability="discrete""#,
        r#" start="0""#,
        &osi("SensorView"),
    );
    vars += &binary_triple(
        "OSMPSensorDataOut",
        3,
        r#"causality="output" variability="discrete" initial="exact""#,
        r#" start="0""#,
        &osi("SensorData"),
    );
    vars += &binary_triple(
        "OSMPSensorViewInConfigRequest",
        6,
        r#"causality="calculatedParameter" variability="fixed" initial="calculated""#,
        "",
        &osi("SensorViewConfiguration"),
    );
    vars += &binary_triple(
        "OSMPSensorViewInConfig",
        9,
        r#"causality="parameter" variability="fixed""#,
        r#" start="0""#,
        &osi("SensorViewConfiguration"),
    );
    vars += &binary_triple(
        "PerceptionDataOut",
        12,
        r#"causality="output" variability="discrete" initial="exact""#,
        r#" start="0""#,
        "application/x-osiris-perception-data; type=PerceptionData; version=1.0.0",
    );
    format!(
        r#"<?xml version="1.0" encoding="UTF-8"?>
<fmiModelDescription fmiVersion="2.0" modelName="MockOsmpSensor" guid="{guid}" variableNamingConvention="structured">
  <CoSimulation modelIdentifier="mock_osmp" canHandleVariableCommunicationStepSize="true" canBeInstantiatedOnlyOncePerProcess="false"/>
  <LogCategories><Category name="FMI"/><Category name="OSMP"/></LogCategories>
  <DefaultExperiment startTime="0.0" stepSize="0.020"/>
  <VendorAnnotations><Tool name="net.pmsf.osmp" xmlns:osmp="http://xsd.pmsf.net/OSISensorModelPackaging"><osmp:osmp version="1.6.0" osi-version="3.8.0"/></Tool></VendorAnnotations>
  <ModelVariables>
{vars}    <ScalarVariable name="count" valueReference="15" causality="output" variability="discrete" initial="exact"><Integer start="0"/></ScalarVariable>
    <ScalarVariable name="nominal_range" valueReference="0" causality="parameter" variability="fixed"><Real start="135.0"/></ScalarVariable>
    <ScalarVariable name="granted_range" valueReference="1" causality="output" variability="discrete" initial="exact"><Real start="0"/></ScalarVariable>
    <ScalarVariable name="valid" valueReference="0" causality="output" variability="discrete" initial="exact"><Boolean start="false"/></ScalarVariable>
    <ScalarVariable name="label" valueReference="0" causality="parameter" variability="tunable"><String start="mock"/></ScalarVariable>
    <ScalarVariable name="resource_location" valueReference="1" causality="output" variability="discrete" initial="exact"><String start=""/></ScalarVariable>
  </ModelVariables>
  <ModelStructure/>
</fmiModelDescription>
"#
    )
}

/// Compiles the mock (with extra `-D` flags) into `<tmp>/<name>.so`.
fn compile_mock(name: &str, defines: &[&str]) -> PathBuf {
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR"))
        .join(format!("mock_osmp_{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let src = dir.join(format!("{name}.c"));
    std::fs::write(&src, MOCK_C).unwrap();
    let out = dir.join(format!("{name}.so"));
    let cc = std::env::var("CC").unwrap_or_else(|_| "cc".to_owned());
    let result = Command::new(&cc)
        .args([
            "-shared",
            "-fPIC",
            "-O1",
            "-Wall",
            "-Wextra",
            "-fvisibility=hidden",
        ])
        .args(defines)
        .arg("-o")
        .arg(&out)
        .arg(&src)
        .output()
        .unwrap_or_else(|e| panic!("cannot run the C compiler `{cc}`: {e}"));
    let stderr = String::from_utf8_lossy(&result.stderr);
    assert!(
        result.status.success(),
        "compiling the mock FMU failed:\n{stderr}"
    );
    assert!(
        stderr.trim().is_empty(),
        "the mock FMU compiles with warnings:\n{stderr}"
    );
    out
}

/// The mock, compiled once per test process.
fn mock_library() -> &'static Path {
    static LIB: OnceLock<PathBuf> = OnceLock::new();
    LIB.get_or_init(|| compile_mock("mock_osmp", &[]))
}

/// An unpacked mock FMU in a fresh temp dir (its own copy of the binary, so global counters are private).
fn mock_fmu_dir(guid: &str) -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("modelDescription.xml"),
        model_description(guid),
    )
    .unwrap();
    let bin = dir.path().join("binaries/linux64");
    std::fs::create_dir_all(&bin).unwrap();
    std::fs::copy(mock_library(), bin.join("mock_osmp.so")).unwrap();
    std::fs::create_dir_all(dir.path().join("resources")).unwrap();
    dir
}

fn sensor_view(i: u64) -> osi3::SensorView {
    osi3::SensorView {
        version: Some(osiris_proto::interface_version()),
        timestamp: Some(osiris_proto::timestamp_from_seconds(i as f64 * 0.02)),
        sensor_id: Some(osiris_proto::id(100 + i)),
        ..Default::default()
    }
}

fn quiet() -> InstanceOptions {
    InstanceOptions {
        stderr_level: None,
        ..InstanceOptions::default()
    }
}

#[test]
fn loads_and_steps_an_osmp_sensor() {
    let dir = mock_fmu_dir(GUID);
    let fmu = Fmu::from_dir(dir.path()).unwrap();
    let md = fmu.model_description();
    assert_eq!(md.co_simulation.model_identifier, "mock_osmp");
    assert_eq!(md.binary_variables.len(), 5);
    assert_eq!(
        md.variable_by_ref(BaseType::Real, 0).unwrap().name,
        "nominal_range"
    );
    assert_eq!(
        md.variable_by_ref(BaseType::Integer, 0).unwrap().name,
        "OSMPSensorViewIn.base.lo"
    );
    assert_eq!(
        md.variable_by_ref(BaseType::Boolean, 0).unwrap().name,
        "valid"
    );
    assert_eq!(
        md.variable_by_ref(BaseType::String, 0).unwrap().name,
        "label"
    );
    assert!(
        fmu.resource_location().starts_with("file:///")
            && fmu.resource_location().ends_with("/resources/")
    );

    let mut sensor = OsmpSensor::instantiate(
        &fmu,
        "front",
        InstanceOptions {
            logging_on: true,
            ..quiet()
        },
    )
    .unwrap();
    assert!(sensor.has_perception_output());
    assert_eq!(sensor.default_step_size(), Some(0.02));
    sensor
        .initialize_with(0.0, None, &[("nominal_range", Value::from(100.0))], |cfg| {
            assert!((cfg.range.unwrap() - 110.0).abs() < 1e-9, "{cfg:?}");
            cfg.range = Some(50.0); // the environment can supply less than requested
            Ok(())
        })
        .unwrap();
    assert!((sensor.requested_configuration().unwrap().range.unwrap() - 110.0).abs() < 1e-9);
    assert_eq!(sensor.granted_configuration().unwrap().range, Some(50.0));
    assert_eq!(
        sensor.instance_mut().get("granted_range").unwrap(),
        Value::Real(50.0)
    );
    // fmuResourceLocation reached the FMU.
    let res = sensor.instance_mut().get("resource_location").unwrap();
    assert_eq!(res, Value::String(fmu.resource_location().to_owned()));

    let mut previous: Option<Vec<u8>> = None;
    for i in 0..5 {
        let sv = sensor_view(i).encode_to_vec();
        let out = sensor.step(&sv, i as f64 * 0.02, 0.02).unwrap();
        assert_eq!(out.status, Fmi2Status::Ok);
        assert!(out.valid);
        let sd = osi3::SensorData::decode(out.sensor_data.as_deref().unwrap()).unwrap();
        assert_eq!(sd.sensor_view, vec![sensor_view(i)]);
        assert_eq!(
            out.perception.as_deref().unwrap(),
            &(i as i64 + 1).to_le_bytes()
        );
        // Copies: the previous step's bytes are unaffected by the FMU's double buffer.
        if let Some(prev) = &previous {
            let sd_prev = osi3::SensorData::decode(prev.as_slice()).unwrap();
            assert_eq!(sd_prev.sensor_view, vec![sensor_view(i - 1)]);
        }
        previous = out.sensor_data;
    }
    assert_eq!(
        sensor.instance_mut().get("count").unwrap(),
        Value::Integer(5)
    );

    // The variadic logger formatted the FMU's printf arguments.
    let log = sensor.instance().log_records();
    assert!(
        log.iter()
            .any(|r| r.message == "granted range 50" && r.category == "OSMP"),
        "{log:#?}"
    );
    assert!(
        log.iter().any(
            |r| r.message.starts_with("step 3 at t=0.04: ") && r.message.ends_with(" bytes in")
        ),
        "{log:#?}"
    );
    assert!(log.iter().all(|r| r.instance == "front"));

    // No input: the FMU publishes nothing (None) and warns (Ok with the warning recorded).
    let warnings_before = sensor.instance().warning_count();
    let out = sensor.step(&[], 0.1, 0.02).unwrap();
    assert_eq!(out.status, Fmi2Status::Warning);
    assert_eq!(
        (out.sensor_data, out.perception, out.valid),
        (None, None, false)
    );
    assert_eq!(
        sensor.instance().warning_count(),
        warnings_before + 2,
        "FMU record + master record"
    );
}

#[test]
fn call_order_errors_carry_the_fmu_log() {
    let dir = mock_fmu_dir(GUID);
    let fmu = Fmu::from_dir(dir.path()).unwrap();

    // Stepping before initialization: the FMU answers fmi2Error and the master reports its log line.
    let mut inst = fmu.instantiate("early", quiet()).unwrap();
    let err = inst.do_step(0.0, 0.02, true).unwrap_err();
    let msg = err.to_string();
    assert!(
        msg.starts_with("fmi2DoStep on instance `early` returned fmi2Error; last log lines:"),
        "{msg}"
    );
    assert!(
        msg.contains("illegal call order, the instance is not initialized (state 0)"),
        "{msg}"
    );
    assert!(matches!(
        err,
        MasterError::Fmi {
            function: "fmi2DoStep",
            status: Fmi2Status::Error,
            ..
        }
    ));
    assert_eq!(inst.state(), InstanceState::Error);
    // After fmi2Error only get/reset are passed on.
    let err = inst.enter_initialization_mode().unwrap_err();
    assert!(matches!(err, MasterError::IllegalState { .. }), "{err}");
    assert_eq!(inst.get("nominal_range").unwrap(), Value::Real(135.0));
    inst.reset().unwrap();
    assert_eq!(inst.state(), InstanceState::Instantiated);
    inst.setup_experiment(None, 0.0, None).unwrap();
    inst.enter_initialization_mode().unwrap();
    inst.exit_initialization_mode().unwrap();
    // A fixed parameter cannot be set after initialization.
    let err = inst.set("nominal_range", 10.0).unwrap_err();
    assert!(err.to_string().contains("fixed parameter"), "{err}");

    // Master-side checks: OsmpSensor refuses to step before initialize, type and name errors.
    let mut sensor = OsmpSensor::instantiate(&fmu, "s", quiet()).unwrap();
    let err = sensor.step(&[], 0.0, 0.02).unwrap_err();
    assert_eq!(
        err.to_string(),
        "instance `s`: cannot step in state Instantiated (expected Initialized (call initialize first))"
    );
    let err = sensor
        .instance_mut()
        .set("nominal_range", "far")
        .unwrap_err();
    assert_eq!(
        err.to_string(),
        "variable `nominal_range` of model `MockOsmpSensor` is a Real, got a String value"
    );
    let err = sensor.instance_mut().set("no_such", 1).unwrap_err();
    assert_eq!(
        err.to_string(),
        "model `MockOsmpSensor` has no variable named `no_such`"
    );
    let err = sensor
        .instance_mut()
        .set_from_str("nominal_range", "far")
        .unwrap_err();
    assert!(err.to_string().contains("`far` is not a Real"), "{err}");
    sensor
        .instance_mut()
        .set_from_str("nominal_range", "20")
        .unwrap();

    // A refused grant is an error naming the instance.
    let err = sensor
        .initialize_with(0.0, None, &[], |_| Err("no lidar rays available".into()))
        .unwrap_err();
    assert_eq!(
        err.to_string(),
        "instance `s`: SensorViewConfiguration request not granted: no lidar rays available"
    );
}

#[test]
fn instantiation_failure_reports_the_fmu_log() {
    let dir = mock_fmu_dir("{00000000-0000-0000-0000-000000000000}");
    let fmu = Fmu::from_dir(dir.path()).unwrap();
    let err = fmu.instantiate("wrong_guid", quiet()).unwrap_err();
    let msg = err.to_string();
    assert!(
        msg.starts_with("fmi2Instantiate of `wrong_guid` (model `MockOsmpSensor`) returned NULL"),
        "{msg}"
    );
    assert!(
        msg.contains("GUID {00000000-0000-0000-0000-000000000000} does not match (fmuType 1)"),
        "{msg}"
    );
}

#[test]
fn long_messages_user_callback_and_strings() {
    let dir = mock_fmu_dir(GUID);
    let fmu = Fmu::from_dir(dir.path()).unwrap();
    let seen: Arc<Mutex<Vec<LogRecord>>> = Arc::default();
    let seen2 = seen.clone();
    let opts = InstanceOptions {
        logging_on: true,
        log_callback: Some(Arc::new(move |r: &LogRecord| {
            seen2.lock().unwrap().push(r.clone())
        })),
        log_capacity: 2,
        ..quiet()
    };
    let mut inst = fmu.instantiate("strings", opts).unwrap();
    let long = "x".repeat(5000); // longer than the shim's stack buffer
    inst.set("label", long.as_str()).unwrap();
    assert_eq!(inst.get("label").unwrap(), Value::String(long.clone()));
    assert_eq!(inst.get_string(&[0, 1]).unwrap()[0], long);
    let seen = seen.lock().unwrap();
    let rec = seen
        .iter()
        .find(|r| r.message.starts_with("label set to"))
        .expect("logged");
    assert_eq!(rec.message, format!("label set to '{long}' (5000 bytes)"));
    // The kept log is bounded by log_capacity; the callback saw everything.
    assert!(inst.log_records().len() <= 2);
    assert!(seen.len() >= 2);
    let err = inst.set("label", "a\0b").unwrap_err();
    assert!(matches!(err, MasterError::NulInString { .. }), "{err}");
}

#[test]
fn drop_terminates_and_frees() {
    let dir = mock_fmu_dir(GUID);
    let fmu = Fmu::from_dir(dir.path()).unwrap();
    // The same path is the same dlopen handle, so these read the counters of the library `fmu` loaded.
    let lib = unsafe { libloading::Library::new(fmu.binary_path()) }.unwrap();
    let live_fn: libloading::Symbol<unsafe extern "C" fn() -> i32> =
        unsafe { lib.get(b"mock_live_instances\0") }.unwrap();
    let terminated_fn: libloading::Symbol<unsafe extern "C" fn() -> i32> =
        unsafe { lib.get(b"mock_terminate_calls\0") }.unwrap();
    let live = || unsafe { live_fn() };
    let terminated = || unsafe { terminated_fn() };

    let mut a = OsmpSensor::instantiate(&fmu, "a", quiet()).unwrap();
    let b = fmu.instantiate("b", quiet()).unwrap();
    assert_eq!(live(), 2);
    a.initialize(0.0, &[]).unwrap();
    drop(a); // initialized: terminate + free
    assert_eq!((live(), terminated()), (1, 1));
    drop(b); // never initialized: free only
    assert_eq!((live(), terminated()), (0, 1));

    // Instances outlive the Fmu handle (they share the library).
    let c = fmu.instantiate("c", quiet()).unwrap();
    drop(fmu);
    assert_eq!(live(), 1);
    drop(c);
    assert_eq!(live(), 0);
}

#[test]
fn load_from_zip_and_clean_up() {
    let dir = mock_fmu_dir(GUID);
    let zip_path = dir.path().join("mock.fmu");
    {
        let mut zw = zip::ZipWriter::new(std::fs::File::create(&zip_path).unwrap());
        let opts = zip::write::SimpleFileOptions::default()
            .compression_method(zip::CompressionMethod::Deflated);
        for name in ["modelDescription.xml", "binaries/linux64/mock_osmp.so"] {
            zw.start_file(name, opts).unwrap();
            std::io::Write::write_all(&mut zw, &std::fs::read(dir.path().join(name)).unwrap())
                .unwrap();
        }
        zw.add_directory("resources/", opts).unwrap();
        zw.finish().unwrap();
    }
    let fmu = Fmu::load(&zip_path).unwrap();
    let unpacked = fmu.dir().to_owned();
    assert!(unpacked.join("resources").is_dir());
    let mut s = OsmpSensor::instantiate(&fmu, "z", quiet()).unwrap();
    drop(fmu);
    s.initialize(0.0, &[]).unwrap();
    let out = s.step(&sensor_view(1).encode_to_vec(), 0.0, 0.02).unwrap();
    assert!(out.sensor_data.is_some());
    assert!(
        unpacked.exists(),
        "the unzip dir lives as long as an instance"
    );
    drop(s);
    assert!(
        !unpacked.exists(),
        "the unzip dir is deleted with the last user"
    );
}

#[test]
fn multi_rate_steps_each_sensor_at_its_own_cycle() {
    // The mock's DefaultExperiment stepSize is 0.02 s; frames every 0.005 s: the sensor steps at
    // every 4th frame with h = 0.02 s, so its communication points stay contiguous.
    let dir = mock_fmu_dir(GUID);
    let fmu = Fmu::from_dir(dir.path()).unwrap();
    let mut sensors = vec![OsmpSensor::instantiate(&fmu, "s", quiet()).unwrap()];
    sensors[0].initialize(10.0, &[]).unwrap();
    let frames = (0..12u64).map(|f| {
        Ok::<_, Infallible>(Frame::shared(
            10.0 + f as f64 * 0.005,
            sensor_view(f).encode_to_vec(),
        ))
    });
    let mut seen = Vec::new();
    let summary = run(
        &mut sensors,
        frames,
        &RunOptions {
            multi_rate: true,
            ..RunOptions::default()
        },
        |r: StepRecord<'_>| {
            seen.push((r.frame_index, r.time, r.step_size));
            Ok::<_, Infallible>(())
        },
    )
    .unwrap();
    assert_eq!(summary.frames, 12);
    assert_eq!(summary.sensor_data_frames, vec![3]);
    let frames: Vec<usize> = seen.iter().map(|s| s.0).collect();
    assert_eq!(frames, vec![0, 4, 8]);
    for w in seen.windows(2) {
        assert!(
            (w[0].1 + w[0].2 - w[1].1).abs() < 1e-9,
            "contiguous: {seen:?}"
        );
    }
    assert!(seen.iter().all(|s| (s.2 - 0.02).abs() < 1e-12));
}

#[test]
fn runner_steps_several_sensors_and_instances() {
    let dir = mock_fmu_dir(GUID);
    let fmu = Fmu::from_dir(dir.path()).unwrap();
    let mut sensors: Vec<OsmpSensor> = (0..3)
        .map(|k| OsmpSensor::instantiate(&fmu, &format!("s{k}"), quiet()).unwrap())
        .collect();
    for s in &mut sensors {
        s.initialize(0.0, &[]).unwrap();
    }
    for parallel in [false, true] {
        let t0 = if parallel { 1.0 } else { 0.0 };
        // Per-sensor views: sensor k gets SensorView id 100 + 10*frame + k.
        let frames = (0..4u64).map(|f| {
            Ok::<_, Infallible>(Frame::per_sensor(
                t0 + f as f64 * 0.05,
                (0..3)
                    .map(|k| sensor_view(10 * f + k).encode_to_vec())
                    .collect(),
            ))
        });
        let mut seen = Vec::new();
        let summary = run(
            &mut sensors,
            frames,
            &RunOptions {
                step_size: None,
                parallel,
                multi_rate: false,
            },
            |r: StepRecord<'_>| {
                let sd =
                    osi3::SensorData::decode(r.outputs.sensor_data.as_deref().unwrap()).unwrap();
                let id = sd.sensor_view[0].sensor_id.unwrap().value.unwrap();
                assert_eq!(id, 100 + 10 * r.frame_index as u64 + r.sensor_index as u64);
                assert_eq!(r.sensor_name, format!("s{}", r.sensor_index));
                assert!(
                    (r.step_size - 0.05).abs() < 1e-12,
                    "h from frame spacing, last repeats"
                );
                seen.push((r.frame_index, r.sensor_index));
                Ok::<_, Infallible>(())
            },
        )
        .unwrap();
        assert_eq!(summary.frames, 4);
        assert_eq!(summary.sensor_data_frames, vec![4, 4, 4]);
        assert_eq!(summary.perception_frames, vec![4, 4, 4]);
        assert!((summary.end_time.unwrap() - (t0 + 0.2)).abs() < 1e-9);
        let expected: Vec<_> = (0..4).flat_map(|f| (0..3).map(move |k| (f, k))).collect();
        assert_eq!(seen, expected, "sink order: frame-major, sensor order");
    }

    // A shared view, fixed step size, a sink error and a bad frame.
    let frames = vec![Ok::<_, Infallible>(Frame::shared(
        2.0,
        sensor_view(7).encode_to_vec(),
    ))];
    let err = run(
        &mut sensors,
        frames,
        &RunOptions {
            step_size: Some(0.01),
            parallel: false,
            multi_rate: false,
        },
        |r: StepRecord<'_>| {
            if r.sensor_index == 1 {
                Err("disk full")
            } else {
                Ok(())
            }
        },
    )
    .unwrap_err();
    assert_eq!(
        err.to_string(),
        "output sink failed at frame 0, sensor 1: disk full"
    );
    let frames = vec![Ok::<_, Infallible>(Frame::per_sensor(
        3.0,
        vec![vec![], vec![]],
    ))];
    let err = run(
        &mut sensors,
        frames,
        &RunOptions::default(),
        |_: StepRecord<'_>| Ok::<_, Infallible>(()),
    )
    .unwrap_err();
    assert!(
        err.to_string().contains("2 SensorViews for 3 sensors"),
        "{err}"
    );
    let frames = vec![Ok(Frame::shared(3.0, vec![])), Err("trace truncated")];
    let err = run(
        &mut sensors,
        frames,
        &RunOptions::default(),
        |_: StepRecord<'_>| Ok::<_, Infallible>(()),
    )
    .unwrap_err();
    assert_eq!(
        err.to_string(),
        "frame source failed after 1 frames: trace truncated"
    );
}

#[test]
fn a_missing_fmi_function_is_named() {
    let dir = mock_fmu_dir(GUID);
    let lib = compile_mock("mock_no_cancel", &["-DOMIT_CANCEL_STEP"]);
    std::fs::copy(lib, dir.path().join("binaries/linux64/mock_osmp.so")).unwrap();
    let err = Fmu::from_dir(dir.path()).unwrap_err();
    assert!(
        matches!(
            err,
            MasterError::MissingSymbol {
                symbol: "fmi2CancelStep",
                ..
            }
        ),
        "{err}"
    );
    let msg = err.to_string();
    assert!(
        msg.contains("mock_osmp.so` does not export `fmi2CancelStep` (an FMI 2.0 co-simulation FMU must export all 34 functions)"),
        "{msg}"
    );
    assert_eq!(osiris::master::Fmi2Functions::SYMBOLS.len(), 34);
}

#[test]
fn thread_safety_markers() {
    fn send<T: Send>() {}
    fn send_sync<T: Send + Sync>() {}
    send::<osiris::master::Instance>();
    send::<OsmpSensor>();
    send_sync::<Fmu>();
    // An instance moved to another thread keeps working (no thread affinity).
    let dir = mock_fmu_dir(GUID);
    let fmu = Fmu::from_dir(dir.path()).unwrap();
    let mut s = OsmpSensor::instantiate(&fmu, "moved", quiet()).unwrap();
    s.initialize(0.0, &[]).unwrap();
    let s = std::thread::spawn(move || {
        s.step(&sensor_view(1).encode_to_vec(), 0.0, 0.02).unwrap();
        s
    })
    .join()
    .unwrap();
    drop(s);
}
