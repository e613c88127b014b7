//! The co-simulation master: `modelDescription.xml` parsing and OSMP checks, pointer packing, FMU zip
//! safety, and an end-to-end run of the osiris radar FMU built by the fmu/ shell.
//!
//! See also `tests/master_mock_fmu.rs` (the master against a mock C FMU).

use std::path::Path;

use osiris::master::{
    BaseType, BinaryRole, Causality, Fmi2Status, Fmu, Initial, InstanceOptions, InstanceState,
    MasterError, ModelDescription, ModelDescriptionError as E, OsmpSensor, Value, VarType,
    Variability, decode_pointer, encode_pointer, locate_fmu_library,
};
use osiris_proto::osi3;
use prost::Message;

/// A hand-written OSMP sensor model description in the style of `OSMPDummySensor`.
const GOOD: &str = r#"<?xml version="1.0" encoding="UTF-8"?>
<fmiModelDescription fmiVersion="2.0" modelName="OSMPDummySensor" guid="{0e3e3b1e-6a1c-4c4b-9d52-6a3c1f0d0001}"
    description="Demo" generationTool="hand" variableNamingConvention="structured">
  <CoSimulation modelIdentifier="OSMPDummySensor" canHandleVariableCommunicationStepSize="true"
      canNotUseMemoryManagementFunctions="true" needsExecutionTool="false"/>
  <LogCategories>
    <Category name="FMI" description="Enable logging of all FMI calls"/>
    <Category name="OSMP"/>
    <Category name="OSI"/>
  </LogCategories>
  <DefaultExperiment startTime="0.0" stepSize="0.020"/>
  <VendorAnnotations>
    <Tool name="net.pmsf.osmp" xmlns:osmp="http://xsd.pmsf.net/OSISensorModelPackaging">
      <osmp:osmp version="1.6.0" osi-version="3.8.0"/>
    </Tool>
  </VendorAnnotations>
  <ModelVariables>
    <ScalarVariable name="OSMPSensorViewIn.base.lo" valueReference="0" causality="input" variability="discrete">
      <Integer start="0"/>
      <Annotations><Tool name="net.pmsf.osmp" xmlns:osmp="http://xsd.pmsf.net/OSISensorModelPackaging"><osmp:osmp-binary-variable name="OSMPSensorViewIn" role="base.lo" mime-type="application/x-open-simulation-interface; type=SensorView; version=3.8.0"/></Tool></Annotations>
    </ScalarVariable>
    <ScalarVariable name="OSMPSensorViewIn.base.hi" valueReference="1" causality="input" variability="discrete">
      <Integer start="0"/>
      <Annotations><Tool name="net.pmsf.osmp" xmlns:osmp="http://xsd.pmsf.net/OSISensorModelPackaging"><osmp:osmp-binary-variable name="OSMPSensorViewIn" role="base.hi" mime-type="application/x-open-simulation-interface; type=SensorView; version=3.8.0"/></Tool></Annotations>
    </ScalarVariable>
    <ScalarVariable name="OSMPSensorViewIn.size" valueReference="2" causality="input" variability="discrete">
      <Integer start="0"/>
      <Annotations><Tool name="net.pmsf.osmp" xmlns:osmp="http://xsd.pmsf.net/OSISensorModelPackaging"><osmp:osmp-binary-variable name="OSMPSensorViewIn" role="size" mime-type="application/x-open-simulation-interface; type=SensorView; version=3.8.0"/></Tool></Annotations>
    </ScalarVariable>
    <ScalarVariable name="OSMPSensorDataOut.base.lo" valueReference="3" causality="output" variability="discrete" initial="exact">
      <Integer start="0"/>
      <Annotations><Tool name="net.pmsf.osmp" xmlns:osmp="http://xsd.pmsf.net/OSISensorModelPackaging"><osmp:osmp-binary-variable name="OSMPSensorDataOut" role="base.lo" mime-type="application/x-open-simulation-interface; type=SensorData; version=3.8.0"/></Tool></Annotations>
    </ScalarVariable>
    <ScalarVariable name="OSMPSensorDataOut.base.hi" valueReference="4" causality="output" variability="discrete" initial="exact">
      <Integer start="0"/>
      <Annotations><Tool name="net.pmsf.osmp" xmlns:osmp="http://xsd.pmsf.net/OSISensorModelPackaging"><osmp:osmp-binary-variable name="OSMPSensorDataOut" role="base.hi" mime-type="application/x-open-simulation-interface; type=SensorData; version=3.8.0"/></Tool></Annotations>
    </ScalarVariable>
    <ScalarVariable name="OSMPSensorDataOut.size" valueReference="5" causality="output" variability="discrete" initial="exact">
      <Integer start="0"/>
      <Annotations><Tool name="net.pmsf.osmp" xmlns:osmp="http://xsd.pmsf.net/OSISensorModelPackaging"><osmp:osmp-binary-variable name="OSMPSensorDataOut" role="size" mime-type="application/x-open-simulation-interface; type=SensorData; version=3.8.0"/></Tool></Annotations>
    </ScalarVariable>
    <ScalarVariable name="OSMPSensorViewInConfigRequest.base.lo" valueReference="6" causality="calculatedParameter" variability="fixed" initial="calculated">
      <Integer/>
      <Annotations><Tool name="net.pmsf.osmp" xmlns:osmp="http://xsd.pmsf.net/OSISensorModelPackaging"><osmp:osmp-binary-variable name="OSMPSensorViewInConfigRequest" role="base.lo" mime-type="application/x-open-simulation-interface; type=SensorViewConfiguration"/></Tool></Annotations>
    </ScalarVariable>
    <ScalarVariable name="OSMPSensorViewInConfigRequest.base.hi" valueReference="7" causality="calculatedParameter" variability="fixed" initial="calculated">
      <Integer/>
      <Annotations><Tool name="net.pmsf.osmp" xmlns:osmp="http://xsd.pmsf.net/OSISensorModelPackaging"><osmp:osmp-binary-variable name="OSMPSensorViewInConfigRequest" role="base.hi" mime-type="application/x-open-simulation-interface; type=SensorViewConfiguration"/></Tool></Annotations>
    </ScalarVariable>
    <ScalarVariable name="OSMPSensorViewInConfigRequest.size" valueReference="8" causality="calculatedParameter" variability="fixed" initial="calculated">
      <Integer/>
      <Annotations><Tool name="net.pmsf.osmp" xmlns:osmp="http://xsd.pmsf.net/OSISensorModelPackaging"><osmp:osmp-binary-variable name="OSMPSensorViewInConfigRequest" role="size" mime-type="application/x-open-simulation-interface; type=SensorViewConfiguration"/></Tool></Annotations>
    </ScalarVariable>
    <ScalarVariable name="OSMPSensorViewInConfig.base.lo" valueReference="9" causality="parameter" variability="fixed">
      <Integer start="0"/>
      <Annotations><Tool name="net.pmsf.osmp" xmlns:osmp="http://xsd.pmsf.net/OSISensorModelPackaging"><osmp:osmp-binary-variable name="OSMPSensorViewInConfig" role="base.lo" mime-type="application/x-open-simulation-interface; type=SensorViewConfiguration; version=3.8.0"/></Tool></Annotations>
    </ScalarVariable>
    <ScalarVariable name="OSMPSensorViewInConfig.base.hi" valueReference="10" causality="parameter" variability="fixed">
      <Integer start="0"/>
      <Annotations><Tool name="net.pmsf.osmp" xmlns:osmp="http://xsd.pmsf.net/OSISensorModelPackaging"><osmp:osmp-binary-variable name="OSMPSensorViewInConfig" role="base.hi" mime-type="application/x-open-simulation-interface; type=SensorViewConfiguration; version=3.8.0"/></Tool></Annotations>
    </ScalarVariable>
    <ScalarVariable name="OSMPSensorViewInConfig.size" valueReference="11" causality="parameter" variability="fixed">
      <Integer start="0"/>
      <Annotations><Tool name="net.pmsf.osmp" xmlns:osmp="http://xsd.pmsf.net/OSISensorModelPackaging"><osmp:osmp-binary-variable name="OSMPSensorViewInConfig" role="size" mime-type="application/x-open-simulation-interface; type=SensorViewConfiguration; version=3.8.0"/></Tool></Annotations>
    </ScalarVariable>
    <ScalarVariable name="count" valueReference="12" causality="output" variability="discrete" initial="exact">
      <Integer start="0"/>
    </ScalarVariable>
    <ScalarVariable name="valid" valueReference="0" causality="output" variability="discrete" initial="exact">
      <Boolean start="false"/>
    </ScalarVariable>
    <ScalarVariable name="nominalrange" valueReference="0" causality="parameter" variability="fixed">
      <Real start="135.0"/>
    </ScalarVariable>
    <ScalarVariable name="mode" valueReference="0" causality="parameter" variability="fixed">
      <String start="ideal"/>
    </ScalarVariable>
    <ScalarVariable name="quality" valueReference="13" causality="parameter" variability="tunable">
      <Enumeration declaredType="Quality" start="2"/>
    </ScalarVariable>
  </ModelVariables>
  <ModelStructure>
    <Outputs><Unknown index="4"/><Unknown index="5"/><Unknown index="6"/><Unknown index="13"/><Unknown index="14"/></Outputs>
    <InitialUnknowns>
      <Unknown index="7" dependencies="10 11 12 15"/><Unknown index="8" dependencies="10 11 12 15"/><Unknown index="9" dependencies="10 11 12 15"/>
    </InitialUnknowns>
  </ModelStructure>
</fmiModelDescription>
"#;

/// Parses `xml`, expecting an error; returns the inner error and checks the file is named.
fn md_error(xml: &str) -> (E, String) {
    match ModelDescription::parse_named(xml, "fixtures/dummy.xml") {
        Ok(_) => panic!("expected an error"),
        Err(err @ MasterError::ModelDescription { .. }) => {
            let msg = err.to_string();
            assert!(msg.starts_with("fixtures/dummy.xml: "), "{msg}");
            let MasterError::ModelDescription { error, .. } = err else {
                unreachable!()
            };
            (error, msg)
        }
        Err(other) => panic!("unexpected error kind: {other}"),
    }
}

/// Removes the `<ScalarVariable>` named `name` from GOOD.
fn without_variable(name: &str) -> String {
    let start = GOOD
        .find(&format!(r#"<ScalarVariable name="{name}""#))
        .expect("variable in fixture");
    let end = start + GOOD[start..].find("</ScalarVariable>").unwrap() + "</ScalarVariable>".len();
    format!("{}{}", &GOOD[..start], &GOOD[end..])
}

/// Replaces the first occurrence of `from` after the variable `name` starts.
fn in_variable(name: &str, from: &str, to: &str) -> String {
    let start = GOOD
        .find(&format!(r#"<ScalarVariable name="{name}""#))
        .expect("variable in fixture");
    let pos = start + GOOD[start..].find(from).expect("text in variable");
    format!("{}{to}{}", &GOOD[..pos], &GOOD[pos + from.len()..])
}

#[test]
fn parses_a_good_osmp_model_description() {
    let md = ModelDescription::parse(GOOD).unwrap();
    assert_eq!(md.fmi_version, "2.0");
    assert_eq!(md.model_name, "OSMPDummySensor");
    assert_eq!(md.guid, "{0e3e3b1e-6a1c-4c4b-9d52-6a3c1f0d0001}");
    assert_eq!(md.variable_naming_convention, "structured");
    assert_eq!(md.description.as_deref(), Some("Demo"));
    let cs = &md.co_simulation;
    assert_eq!(cs.model_identifier, "OSMPDummySensor");
    assert!(
        cs.can_handle_variable_communication_step_size
            && cs.can_not_use_memory_management_functions
    );
    assert!(
        !cs.needs_execution_tool
            && !cs.can_get_and_set_fmu_state
            && !cs.can_be_instantiated_only_once_per_process
    );
    assert_eq!(cs.max_output_derivative_order, 0);
    let de = md.default_experiment.unwrap();
    assert_eq!(
        (de.start_time, de.step_size, de.stop_time),
        (Some(0.0), Some(0.02), None)
    );
    assert_eq!(md.log_categories, ["FMI", "OSMP", "OSI"]);
    let osmp = md.osmp.as_ref().unwrap();
    assert_eq!(
        (osmp.version.as_str(), osmp.osi_version.as_deref()),
        ("1.6.0", Some("3.8.0"))
    );
    assert_eq!(md.variables.len(), 17);

    // Binary variables, in order of appearance.
    let prefixes: Vec<_> = md
        .binary_variables
        .iter()
        .map(|b| b.prefix.as_str())
        .collect();
    assert_eq!(
        prefixes,
        [
            "OSMPSensorViewIn",
            "OSMPSensorDataOut",
            "OSMPSensorViewInConfigRequest",
            "OSMPSensorViewInConfig"
        ]
    );
    let sd = md.binary_variable("OSMPSensorDataOut").unwrap();
    assert_eq!((sd.lo_vr, sd.hi_vr, sd.size_vr), (3, 4, 5));
    assert_eq!(sd.vrs(), [3, 4, 5]);
    assert_eq!(
        (sd.causality, sd.variability),
        (Causality::Output, Variability::Discrete)
    );
    assert_eq!(sd.mime, osiris_proto::MIME_SENSOR_DATA);
    assert_eq!(sd.mime_parameter("type"), Some("SensorData"));
    assert_eq!(sd.mime_parameter("version"), Some("3.8.0"));
    let req = md.binary_variable("OSMPSensorViewInConfigRequest").unwrap();
    assert_eq!(req.causality, Causality::CalculatedParameter);
    assert_eq!(
        req.mime_parameter("version"),
        None,
        "defaults to the marker's osi-version"
    );

    // Variables keyed by (base type, vr): VR 0 exists in four namespaces.
    assert_eq!(
        md.variable_by_ref(BaseType::Integer, 0).unwrap().name,
        "OSMPSensorViewIn.base.lo"
    );
    assert_eq!(
        md.variable_by_ref(BaseType::Boolean, 0).unwrap().name,
        "valid"
    );
    assert_eq!(
        md.variable_by_ref(BaseType::Real, 0).unwrap().name,
        "nominalrange"
    );
    assert_eq!(
        md.variable_by_ref(BaseType::String, 0).unwrap().name,
        "mode"
    );
    assert_eq!(
        md.variable_by_ref(BaseType::Integer, 13).unwrap().name,
        "quality",
        "Enumeration is Integer"
    );
    assert!(md.variable_by_ref(BaseType::Real, 1).is_none());

    let v = md.variable("OSMPSensorDataOut.size").unwrap();
    assert_eq!(
        (v.var_type, v.initial, v.start.clone()),
        (
            VarType::Integer,
            Some(Initial::Exact),
            Some(Value::Integer(0))
        )
    );
    let ann = v.osmp_binary.as_ref().unwrap();
    assert_eq!(
        (ann.name.as_str(), ann.role),
        ("OSMPSensorDataOut", BinaryRole::Size)
    );
    let v = md
        .variable("OSMPSensorViewInConfigRequest.base.hi")
        .unwrap();
    assert_eq!(
        (v.causality, v.variability, v.initial, v.start.clone()),
        (
            Causality::CalculatedParameter,
            Variability::Fixed,
            Some(Initial::Calculated),
            None
        )
    );
    let v = md.variable("OSMPSensorViewIn.base.lo").unwrap();
    assert_eq!(v.initial, None);
    assert_eq!(
        md.variable("valid").unwrap().start,
        Some(Value::Boolean(false))
    );
    assert_eq!(
        md.variable("nominalrange").unwrap().start,
        Some(Value::Real(135.0))
    );
    assert_eq!(
        md.variable("mode").unwrap().start,
        Some(Value::String("ideal".into()))
    );
    let q = md.variable("quality").unwrap();
    assert_eq!(
        (q.var_type, q.declared_type.as_deref(), q.start.clone()),
        (
            VarType::Enumeration,
            Some("Quality"),
            Some(Value::Integer(2))
        )
    );
    // Defaults of absent attributes.
    let plain = GOOD.replace(r#" variableNamingConvention="structured""#, "");
    assert_eq!(
        ModelDescription::parse(&plain)
            .unwrap()
            .variable_naming_convention,
        "flat"
    );
}

#[test]
fn incomplete_triple_is_rejected() {
    let (err, msg) = md_error(&without_variable("OSMPSensorDataOut.base.hi"));
    assert_eq!(
        err,
        E::IncompleteBinaryVariable {
            prefix: "OSMPSensorDataOut".into(),
            missing: vec!["base.hi"]
        }
    );
    assert_eq!(
        msg,
        "fixtures/dummy.xml: OSMP binary variable `OSMPSensorDataOut` is incomplete: missing \
         `OSMPSensorDataOut.base.hi`, expected Integer variables `OSMPSensorDataOut.base.lo`, \
         `OSMPSensorDataOut.base.hi` and `OSMPSensorDataOut.size`"
    );
    let xml = without_variable("OSMPSensorViewIn.base.lo");
    let xml = {
        // also drop .size: two roles missing
        let start = xml
            .find(r#"<ScalarVariable name="OSMPSensorViewIn.size""#)
            .unwrap();
        let end =
            start + xml[start..].find("</ScalarVariable>").unwrap() + "</ScalarVariable>".len();
        format!("{}{}", &xml[..start], &xml[end..])
    };
    let (err, _) = md_error(&xml);
    assert_eq!(
        err,
        E::IncompleteBinaryVariable {
            prefix: "OSMPSensorViewIn".into(),
            missing: vec!["base.lo", "size"]
        }
    );
}

#[test]
fn mismatched_mime_is_rejected() {
    let xml = in_variable("OSMPSensorViewIn.size", "version=3.8.0", "version=3.7.0");
    let (err, msg) = md_error(&xml);
    assert!(
        matches!(&err, E::BinaryVariableMismatch { prefix, attribute: "mime-type", .. } if prefix == "OSMPSensorViewIn"),
        "{err:?}"
    );
    assert!(
        msg.contains("its three variables differ in mime-type"),
        "{msg}"
    );
    assert!(msg.contains(r#"OSMPSensorViewIn.size="application/x-open-simulation-interface; type=SensorView; version=3.7.0""#), "{msg}");
    assert!(msg.ends_with("expected identical"), "{msg}");
    // An absent mime-type defaults to application/octet-stream, which differs too.
    let xml = in_variable(
        "OSMPSensorDataOut.base.lo",
        r#" mime-type="application/x-open-simulation-interface; type=SensorData; version=3.8.0""#,
        "",
    );
    let (err, msg) = md_error(&xml);
    assert!(
        matches!(
            err,
            E::BinaryVariableMismatch {
                attribute: "mime-type",
                ..
            }
        ),
        "{err:?}"
    );
    assert!(
        msg.contains(r#"OSMPSensorDataOut.base.lo="application/octet-stream""#),
        "{msg}"
    );
}

#[test]
fn mismatched_causality_or_variability_is_rejected() {
    let xml = in_variable(
        "OSMPSensorViewIn.base.hi",
        r#"causality="input""#,
        r#"causality="parameter""#,
    );
    let (err, msg) = md_error(&xml);
    assert_eq!(
        err,
        E::BinaryVariableMismatch {
            prefix: "OSMPSensorViewIn".into(),
            attribute: "causality",
            values: "OSMPSensorViewIn.base.lo=input, OSMPSensorViewIn.base.hi=parameter, OSMPSensorViewIn.size=input"
                .into()
        }
    );
    assert!(msg.contains("differ in causality"), "{msg}");
    let xml = in_variable(
        "OSMPSensorViewInConfig.size",
        r#"variability="fixed""#,
        r#"variability="tunable""#,
    );
    let (err, _) = md_error(&xml);
    assert!(
        matches!(
            err,
            E::BinaryVariableMismatch {
                attribute: "variability",
                ..
            }
        ),
        "{err:?}"
    );
}

#[test]
fn missing_marker_is_rejected() {
    let start = GOOD.find("<VendorAnnotations>").unwrap();
    let end = GOOD.find("</VendorAnnotations>").unwrap() + "</VendorAnnotations>".len();
    let xml = format!("{}{}", &GOOD[..start], &GOOD[end..]);
    let (err, msg) = md_error(&xml);
    assert_eq!(
        err,
        E::MissingOsmpMarker {
            variable: "OSMPSensorViewIn.base.lo".into()
        }
    );
    assert!(msg.contains("has an osmp-binary-variable annotation but the model has no OSMP marker, expected <VendorAnnotations><Tool name=\"net.pmsf.osmp\">"), "{msg}");

    // A marker of another tool does not count.
    let xml = GOOD.replacen(
        r#"<Tool name="net.pmsf.osmp""#,
        r#"<Tool name="com.example""#,
        1,
    );
    assert!(matches!(md_error(&xml).0, E::MissingOsmpMarker { .. }));

    // A plain FMU without any OSMP annotation parses, but is no OSMP sensor.
    let plain = r#"<fmiModelDescription fmiVersion="2.0" modelName="Plain" guid="g">
        <CoSimulation modelIdentifier="plain"/><ModelVariables/><ModelStructure/></fmiModelDescription>"#;
    let md = ModelDescription::parse(plain).unwrap();
    assert!(md.osmp.is_none() && md.binary_variables.is_empty() && md.variables.is_empty());

    // A bad marker version.
    let xml = GOOD.replace(r#"osmp:osmp version="1.6.0""#, r#"osmp:osmp version="2.0""#);
    let (err, msg) = md_error(&xml);
    assert!(
        matches!(
            err,
            E::InvalidAttribute {
                attribute: "version",
                ..
            }
        ),
        "{err:?}"
    );
    assert!(
        msg.contains(r#"has version="2.0", expected an OSMP version matching `1.x.y` (osmp.xsd)"#),
        "{msg}"
    );
}

#[test]
fn wrong_fmi_version_is_rejected() {
    let xml = GOOD.replace(r#"fmiVersion="2.0""#, r#"fmiVersion="3.0""#);
    let (err, msg) = md_error(&xml);
    assert_eq!(
        err,
        E::UnsupportedFmiVersion {
            found: "3.0".into()
        }
    );
    assert_eq!(
        msg,
        r#"fixtures/dummy.xml: fmiVersion="3.0", expected fmiVersion="2.0" (this master imports FMI 2.0 only)"#
    );
    let xml = GOOD.replace(r#"fmiVersion="2.0""#, "");
    let (err, msg) = md_error(&xml);
    assert_eq!(
        err,
        E::MissingAttribute {
            element: "<fmiModelDescription>".into(),
            attribute: "fmiVersion"
        }
    );
    assert_eq!(
        msg,
        "fixtures/dummy.xml: <fmiModelDescription> lacks the required attribute `fmiVersion`"
    );
    // The default file name of parse().
    let err = ModelDescription::parse(&GOOD.replace(r#"fmiVersion="2.0""#, r#"fmiVersion="1.0""#))
        .unwrap_err();
    assert!(
        err.to_string()
            .starts_with("modelDescription.xml: fmiVersion=\"1.0\""),
        "{err}"
    );
}

#[test]
fn other_structural_errors() {
    let cases: Vec<(String, E)> = vec![
        (GOOD.replace("<CoSimulation", "<ModelExchange").replace("needsExecutionTool=\"false\"/>", "/>"), E::NoCoSimulation),
        (
            GOOD.replace(r#"modelIdentifier="OSMPDummySensor""#, r#"modelIdentifier="1bad-id""#),
            E::InvalidAttribute {
                element: "<CoSimulation>".into(),
                attribute: "modelIdentifier",
                value: "1bad-id".into(),
                expected: "a C identifier".into(),
            },
        ),
        (
            GOOD.replace(r#"canHandleVariableCommunicationStepSize="true""#, r#"canHandleVariableCommunicationStepSize="yes""#),
            E::InvalidAttribute {
                element: "<CoSimulation>".into(),
                attribute: "canHandleVariableCommunicationStepSize",
                value: "yes".into(),
                expected: "true or false".into(),
            },
        ),
        (
            in_variable("count", r#"causality="output""#, r#"causality="outptu""#),
            E::InvalidAttribute {
                element: "<ScalarVariable name=\"count\">".into(),
                attribute: "causality",
                value: "outptu".into(),
                expected: "one of `parameter` `calculatedParameter` `input` `output` `local` `independent`".into(),
            },
        ),
        (in_variable("count", r#"name="count""#, r#"name="valid""#), E::DuplicateVariableName { name: "valid".into() }),
        (
            in_variable("nominalrange", r#"<Real start="135.0"/>"#, r#"<Real start="far"/>"#),
            E::InvalidVariable {
                name: "nominalrange".into(),
                reason: "start value: `far` is not a Real (expected a floating-point number)".into(),
            },
        ),
        (
            in_variable("count", r#"<Integer start="0"/>"#, ""),
            E::InvalidVariable {
                name: "count".into(),
                reason: "has 0 type elements, expected exactly one of <Real>, <Integer>, <Boolean>, <String>, <Enumeration>"
                    .into(),
            },
        ),
        (
            in_variable("OSMPSensorViewIn.size", r#"role="size""#, r#"role="base.hi""#),
            E::InvalidBinaryAnnotation {
                variable: "OSMPSensorViewIn.size".into(),
                reason: "is annotated as role `base.hi` of `OSMPSensorViewIn`, expected it to be named \
                         `OSMPSensorViewIn.base.hi`"
                    .into(),
            },
        ),
        (
            in_variable("OSMPSensorViewIn.size", r#"name="OSMPSensorViewIn""#, r#"name="OSMPSensorViewOut""#),
            E::InvalidBinaryAnnotation {
                variable: "OSMPSensorViewIn.size".into(),
                reason: "is annotated as role `size` of `OSMPSensorViewOut`, expected it to be named \
                         `OSMPSensorViewOut.size`"
                    .into(),
            },
        ),
        (
            in_variable("OSMPSensorViewIn.size", r#"role="size""#, r#"role="full""#),
            E::InvalidBinaryAnnotation {
                variable: "OSMPSensorViewIn.size".into(),
                reason: "role `full` is the FMI 3.0 form; FMI 2.0 binary variables use `base.lo`, `base.hi` and `size`"
                    .into(),
            },
        ),
        (
            in_variable("OSMPSensorViewIn.size", r#"<Integer start="0"/>"#, r#"<Real start="0"/>"#),
            E::InvalidBinaryAnnotation {
                variable: "OSMPSensorViewIn.size".into(),
                reason: "is a Real, expected an Integer variable".into(),
            },
        ),
        (
            GOOD.replace(r#" osi-version="3.8.0""#, ""),
            E::MissingMimeVersion {
                prefix: "OSMPSensorViewInConfigRequest".into(),
                mime: "application/x-open-simulation-interface; type=SensorViewConfiguration".into(),
            },
        ),
        (
            in_variable("count", r#"name="count""#, r#"name="OSMPSensorDataOut""#),
            E::PrefixNameClash { prefix: "OSMPSensorDataOut".into() },
        ),
    ];
    for (xml, expected) in cases {
        let (err, msg) = md_error(&xml);
        assert_eq!(err, expected, "{msg}");
    }
    let (err, _) = md_error("<fmiModelDescription");
    assert!(matches!(err, E::Xml(_)), "{err:?}");
    let (err, msg) = md_error(r#"<fmiModelDescriptionX fmiVersion="2.0"/>"#);
    assert_eq!(
        err,
        E::WrongRoot {
            found: "fmiModelDescriptionX".into()
        }
    );
    assert!(msg.ends_with("expected <fmiModelDescription>"));
}

#[test]
fn pointer_packing_round_trips_high_bits() {
    // Bit 31 set in the low half, bit 63 in the high half: both halves are negative i32s.
    let cases = [
        (0x0000_0000_8000_0000u64, (i32::MIN, 0)),
        (0x8000_0000_0000_0000, (0, i32::MIN)),
        (0x8000_0000_8000_0000, (i32::MIN, i32::MIN)),
        (0xFFFF_FFFF_FFFF_FFFF, (-1, -1)),
        (0x0000_7F12_3456_789A, (0x3456_789A, 0x7F12)),
        (0x0000_7FFF_F000_0010, (0xF000_0010_u32 as i32, 0x7FFF)),
    ];
    for (addr, halves) in cases {
        assert_eq!(encode_pointer(addr), halves, "{addr:#x}");
        assert_eq!(decode_pointer(halves.0, halves.1), addr, "{addr:#x}");
    }
    // OSMP's formula, as the FMPy recipe computes it (signed halves).
    let buf = [1u8; 10];
    let addr = buf.as_ptr() as u64;
    let (lo, hi) = encode_pointer(addr);
    let lo_py = {
        let x = addr & 0xFFFF_FFFF;
        if x >= 1 << 31 {
            x as i64 - (1 << 32)
        } else {
            x as i64
        }
    };
    assert_eq!(i64::from(lo), lo_py);
    assert_eq!(decode_pointer(lo, hi), addr);
}

fn write_zip(path: &Path, entries: &[(&str, &[u8])]) {
    let mut zw = zip::ZipWriter::new(std::fs::File::create(path).unwrap());
    let opts = zip::write::SimpleFileOptions::default();
    for (name, data) in entries {
        zw.start_file(*name, opts).unwrap();
        std::io::Write::write_all(&mut zw, data).unwrap();
    }
    zw.finish().unwrap();
}

#[test]
fn unsafe_zip_entries_and_missing_files_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    for (entry, reason) in [
        (
            "../evil.txt",
            "path component `..` escapes the extraction directory",
        ),
        (
            "resources/../../evil.txt",
            "path component `..` escapes the extraction directory",
        ),
        ("/etc/evil", "absolute path"),
        (
            "resources\\evil",
            "backslash in path (FMI 2.0 §2.3 requires `/`)",
        ),
    ] {
        let fmu = dir.path().join("bad.fmu");
        write_zip(
            &fmu,
            &[("modelDescription.xml", GOOD.as_bytes()), (entry, b"x")],
        );
        let err = Fmu::load(&fmu).unwrap_err();
        assert_eq!(
            err.to_string(),
            format!(
                "FMU `{}`: refusing zip entry `{entry}`: {reason}",
                fmu.display()
            )
        );
    }
    assert!(!dir.path().parent().unwrap().join("evil.txt").exists());

    // No binary for modelIdentifier OSMPDummySensor.
    let fmu = dir.path().join("nobin.fmu");
    write_zip(&fmu, &[("modelDescription.xml", GOOD.as_bytes())]);
    let err = Fmu::load(&fmu).unwrap_err();
    assert_eq!(
        err.to_string(),
        format!(
            "FMU `{}`: missing `binaries/linux64/OSMPDummySensor.so` (the binary for this platform, named after the \
             CoSimulation modelIdentifier)",
            fmu.display()
        )
    );
    // No model description; a model description error names the file inside the zip.
    let fmu = dir.path().join("nomd.fmu");
    write_zip(&fmu, &[("resources/config.json", b"{}")]);
    assert!(matches!(
        Fmu::load(&fmu).unwrap_err(),
        MasterError::MissingFile { .. }
    ));
    let fmu = dir.path().join("v1.fmu");
    write_zip(
        &fmu,
        &[(
            "modelDescription.xml",
            GOOD.replace(r#"fmiVersion="2.0""#, r#"fmiVersion="1.0""#)
                .as_bytes(),
        )],
    );
    let msg = Fmu::load(&fmu).unwrap_err().to_string();
    assert!(
        msg.starts_with(&format!(
            "{}!/modelDescription.xml: fmiVersion=\"1.0\"",
            fmu.display()
        )),
        "{msg}"
    );
    // Not a zip at all.
    let fmu = dir.path().join("junk.fmu");
    std::fs::write(&fmu, b"not a zip").unwrap();
    assert!(matches!(
        Fmu::load(&fmu).unwrap_err(),
        MasterError::Zip { .. }
    ));
}

// ---------------------------------------------------------------------------------------------------------
// End to end with the osiris FMU shell.

/// Assembles an unpacked FMU of `kind`: `modelDescription/<kind>.xml` (rendered by the shell's
/// `osiris_fmu::model_description::render` while that file is not checked in), the cdylib of the current
/// profile (built by `locate_fmu_library` if needed) and `resources/config.json` (the built-in config).
fn assemble_fmu_dir(kind: &str) -> tempfile::TempDir {
    let sensor_kind: osiris_models::SensorKind = kind.parse().unwrap();
    let checked_in = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("modelDescription")
        .join(format!("{kind}.xml"));
    let xml = if checked_in.is_file() {
        std::fs::read_to_string(&checked_in).unwrap()
    } else {
        eprintln!(
            "note: `{}` does not exist; rendering the model description",
            checked_in.display()
        );
        osiris_fmu::model_description::render(osiris_fmu::sensors::descriptor(sensor_kind))
    };
    let md = ModelDescription::parse_named(&xml, &checked_in.display().to_string()).unwrap();
    let lib = locate_fmu_library(kind).unwrap_or_else(|e| panic!("{e}"));
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("modelDescription.xml"), xml).unwrap();
    let bin = dir.path().join("binaries/linux64");
    std::fs::create_dir_all(&bin).unwrap();
    std::fs::copy(
        &lib,
        bin.join(format!("{}.so", md.co_simulation.model_identifier)),
    )
    .unwrap();
    std::fs::create_dir_all(dir.path().join("resources")).unwrap();
    std::fs::write(
        dir.path().join("resources/config.json"),
        osiris_fmu::sensors::default_config_json(sensor_kind),
    )
    .unwrap();
    dir
}

/// A SensorView with the host vehicle and one car 20 m ahead of it.
fn sensor_view_with_car(t: f64) -> osi3::SensorView {
    use osiris_proto::{id, interface_version, timestamp_from_seconds};
    let v3 = |x, y, z| osi3::Vector3d {
        x: Some(x),
        y: Some(y),
        z: Some(z),
    };
    let moving = |ident: u64, x: f64| osi3::MovingObject {
        id: Some(id(ident)),
        base: Some(osi3::BaseMoving {
            dimension: Some(osi3::Dimension3d {
                length: Some(4.5),
                width: Some(1.8),
                height: Some(1.5),
            }),
            position: Some(v3(x, 0.0, 0.75)),
            orientation: Some(osi3::Orientation3d {
                roll: Some(0.0),
                pitch: Some(0.0),
                yaw: Some(0.0),
            }),
            velocity: Some(v3(0.0, 0.0, 0.0)),
            ..Default::default()
        }),
        r#type: Some(osi3::moving_object::Type::Vehicle as i32),
        ..Default::default()
    };
    osi3::SensorView {
        version: Some(interface_version()),
        timestamp: Some(timestamp_from_seconds(t)),
        sensor_id: Some(id(1)),
        mounting_position: Some(osi3::MountingPosition {
            position: Some(v3(3.5, 0.0, 0.5)),
            orientation: Some(osi3::Orientation3d {
                roll: Some(0.0),
                pitch: Some(0.0),
                yaw: Some(0.0),
            }),
        }),
        host_vehicle_id: Some(id(1)),
        global_ground_truth: Some(osi3::GroundTruth {
            version: Some(interface_version()),
            timestamp: Some(timestamp_from_seconds(t)),
            host_vehicle_id: Some(id(1)),
            moving_object: vec![moving(1, 0.0), moving(2, 25.0)],
            ..Default::default()
        }),
        ..Default::default()
    }
}

fn end_to_end(kind: &str) {
    let dir = assemble_fmu_dir(kind);
    let fmu = Fmu::from_dir(dir.path()).unwrap();
    assert!(fmu.model_description().is_osmp());
    let opts = InstanceOptions {
        stderr_level: None,
        ..InstanceOptions::default()
    };

    // Two instances of one FMU in one process.
    let mut sensors: Vec<OsmpSensor> = ["a", "b"]
        .iter()
        .map(|n| OsmpSensor::instantiate(&fmu, &format!("{kind}_{n}"), opts.clone()).unwrap())
        .collect();
    for s in &mut sensors {
        s.initialize(0.0, &[]).unwrap();
        assert!(
            s.granted_configuration().is_some(),
            "{kind}: the shell publishes a SensorViewConfiguration request"
        );
    }
    let h = sensors[0].default_step_size().unwrap_or(0.05);
    for step in 0..3 {
        let t = f64::from(step) * h;
        let sv = sensor_view_with_car(t).encode_to_vec();
        for s in &mut sensors {
            let out = s.step(&sv, t, h).unwrap_or_else(|e| panic!("{kind}: {e}"));
            assert_ne!(out.status, Fmi2Status::Discard);
            let bytes = out.sensor_data.unwrap_or_else(|| {
                panic!(
                    "{kind}: no SensorData; log: {:#?}",
                    s.instance().log_records()
                )
            });
            let sd = osi3::SensorData::decode(bytes.as_slice()).unwrap();
            // Detected objects (the ideal model at once; the physical models' trackers confirm
            // an object after a few cycles) or feature-data detections on the car (their ground
            // truth is the PerceptionData's: a detection's OSI `object_id` names the detected
            // object it belongs to).
            let pd = out
                .perception
                .as_ref()
                .map(|p| osiris_proto::perception::PerceptionData::decode(p.as_slice()).unwrap());
            let detected: Vec<u64> = sd
                .moving_object
                .iter()
                .flat_map(|o| o.header.iter().flat_map(|h| h.ground_truth_id.iter()))
                .filter_map(|id| id.value)
                .chain(pd.iter().flat_map(|p| {
                    p.radar
                        .iter()
                        .flat_map(|r| r.peak.iter().filter_map(|k| k.object_id?.value))
                        .chain(p.lidar.iter().flat_map(|l| l.object_id.iter().copied()))
                }))
                .collect();
            assert!(
                detected.contains(&2),
                "{kind}: the car 25 m ahead is detected ({} moving objects, ids {:?})",
                sd.moving_object.len(),
                detected.iter().take(20).collect::<Vec<_>>()
            );
            assert!(
                sd.version.is_some() && sd.timestamp.is_some(),
                "{kind}: {sd:?}"
            );
            if let Some(p) = &out.perception {
                osiris_proto::perception::PerceptionData::decode(p.as_slice()).unwrap();
            }
        }
    }

    // Illegal call order, reported by the FMU: stepping an instance that was never initialized.
    let mut raw = fmu
        .instantiate(&format!("{kind}_raw"), opts.clone())
        .unwrap();
    let err = raw.do_step(0.0, h, true).unwrap_err();
    assert!(
        matches!(
            err,
            MasterError::Fmi {
                function: "fmi2DoStep",
                status: Fmi2Status::Error | Fmi2Status::Fatal,
                ..
            }
        ),
        "{err}"
    );
    let MasterError::Fmi { log, .. } = &err else {
        unreachable!()
    };
    assert!(
        log.iter().any(|l| l.contains("fmi2DoStep")),
        "{kind}: the error carries the FMU's log line naming the call: {err}"
    );
    assert!(matches!(
        raw.state(),
        InstanceState::Error | InstanceState::Fatal
    ));
    // Exiting initialization mode without entering it is illegal too.
    let mut raw2 = fmu
        .instantiate(&format!("{kind}_raw2"), opts.clone())
        .unwrap();
    let err = raw2.exit_initialization_mode().unwrap_err();
    assert!(
        matches!(
            err,
            MasterError::Fmi {
                function: "fmi2ExitInitializationMode",
                ..
            }
        ),
        "{err}"
    );
    // A master-side refusal: stepping an uninitialized sensor.
    let mut s = OsmpSensor::instantiate(&fmu, &format!("{kind}_early"), opts).unwrap();
    assert!(matches!(
        s.step(&[], 0.0, h).unwrap_err(),
        MasterError::IllegalState { .. }
    ));
}

#[test]
fn end_to_end_radar_fmu() {
    end_to_end("radar");
}

#[test]
fn end_to_end_camera_fmu() {
    end_to_end("camera");
}

#[test]
fn end_to_end_lidar_fmu() {
    end_to_end("lidar");
}

// ---------------------------------------------------------------------------------------------------------
// Multi-rate stepping: each sensor at its own cycle on the master's clock.

/// Runs the radar FMU (ideal mode, cycle 0.05 s) multi-rate over frames at `times`; returns per step
/// (communication point, step size, frame time, the SensorData timestamp).
fn radar_steps(times: &[f64]) -> Vec<(f64, f64, f64, f64)> {
    use osiris::master::{Frame, RunOptions, StepRecord, run};
    let dir = assemble_fmu_dir("radar");
    let fmu = Fmu::from_dir(dir.path()).unwrap();
    let opts = InstanceOptions {
        stderr_level: None,
        ..InstanceOptions::default()
    };
    let mut sensors = vec![OsmpSensor::instantiate(&fmu, "radar", opts).unwrap()];
    assert_eq!(sensors[0].default_step_size(), Some(0.05));
    sensors[0]
        .initialize(times[0], &[("mode", Value::from("ideal"))])
        .unwrap();
    let frames = times.iter().map(|&t| {
        Ok::<_, std::convert::Infallible>(Frame::shared(t, sensor_view_with_car(t).encode_to_vec()))
    });
    let mut seen = Vec::new();
    run(
        &mut sensors,
        frames,
        &RunOptions {
            multi_rate: true,
            ..RunOptions::default()
        },
        |r: StepRecord<'_>| {
            let sd = osi3::SensorData::decode(r.outputs.sensor_data.as_deref().unwrap()).unwrap();
            let ts = osiris_proto::timestamp_to_seconds(sd.timestamp.as_ref().unwrap());
            assert_eq!(
                r.sensor_view,
                sensor_view_with_car(r.frame_time).encode_to_vec()
            );
            seen.push((r.time, r.step_size, r.frame_time, ts));
            Ok::<_, std::convert::Infallible>(())
        },
    )
    .unwrap();
    seen
}

#[test]
fn a_sensor_fires_exactly_at_its_cycle_over_even_frames() {
    // 0.05 s radar over 0.01 s frames: every 5th frame, exactly 0.05 s apart, contiguous steps.
    let times: Vec<f64> = (0..101).map(|i| f64::from(i) * 0.01).collect();
    let seen = radar_steps(&times);
    assert_eq!(seen.len(), 21);
    for (n, &(t, h, frame_t, sd_t)) in seen.iter().enumerate() {
        let instant = n as f64 * 0.05;
        assert!((t - instant).abs() < 1e-12, "step {n}: t = {t}");
        assert!((h - 0.05).abs() < 1e-12, "step {n}: h = {h}");
        assert!(
            (frame_t - instant).abs() < 1e-9,
            "step {n}: frame {frame_t}"
        );
        assert!(
            (sd_t - instant).abs() < 1e-9,
            "step {n}: SensorData at {sd_t}"
        );
    }
    for w in seen.windows(2) {
        assert!((w[1].3 - w[0].3 - 0.05).abs() < 1e-9, "{w:?}");
        assert!(
            (w[0].0 + w[0].1 - w[1].0).abs() < 1e-12,
            "contiguous: {w:?}"
        );
    }
}

#[test]
fn a_sensor_keeps_its_cycle_over_jittered_frames() {
    // 0.01 s frames with ±2 ms of deterministic pseudo-random jitter (an LCG): the radar takes the
    // frame nearest to each 0.05 s instant, so its SensorData times stay within ±2 ms of the grid (no
    // drift) and its intervals within 0.05 s ± 4 ms: never the 0.04 / 0.06 s of a frame too early or
    // too late. Its communication points are the exact grid.
    let mut state: u64 = 0x2545_f491_4f6c_dd1d;
    let mut jitter = || {
        state = state
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(1);
        ((state >> 11) as f64 / (1u64 << 53) as f64 - 0.5) * 0.004
    };
    let times: Vec<f64> = (0..501)
        .map(|i| 1.0 + f64::from(i) * 0.01 + if i == 0 { 0.0 } else { jitter() })
        .collect();
    let seen = radar_steps(&times);
    assert_eq!(seen.len(), 101);
    for (n, &(t, h, frame_t, sd_t)) in seen.iter().enumerate() {
        let instant = 1.0 + n as f64 * 0.05;
        assert!((t - instant).abs() < 1e-9, "step {n}: t = {t}");
        assert!((h - 0.05).abs() < 1e-9, "step {n}: h = {h}");
        assert!((sd_t - frame_t).abs() < 1e-9);
        assert!(
            (frame_t - instant).abs() <= 0.002 + 1e-9,
            "step {n}: frame {frame_t} for the instant {instant}"
        );
    }
    for w in seen.windows(2) {
        let interval = w[1].3 - w[0].3;
        assert!(
            (interval - 0.05).abs() <= 0.004 + 1e-9,
            "interval {interval}: {w:?}"
        );
    }
}

#[test]
fn a_sensor_faster_than_the_frames_steps_at_every_frame_with_contiguous_steps() {
    // Frames 0.12 s apart, radar cycle 0.05 s: every frame serves the instants nearest to it; the
    // steps cover them all, so the communication points stay on the grid and contiguous.
    let times: Vec<f64> = (0..6).map(|i| f64::from(i) * 0.12).collect();
    let seen = radar_steps(&times);
    assert_eq!(seen.len(), 6);
    for w in seen.windows(2) {
        assert!((w[0].0 + w[0].1 - w[1].0).abs() < 1e-12, "{seen:?}");
    }
    for &(t, h, _, _) in &seen {
        let k = t / 0.05;
        assert!((k - k.round()).abs() < 1e-9, "{t} on the grid");
        let m = h / 0.05;
        assert!(
            (m - m.round()).abs() < 1e-9 && m >= 1.0,
            "{h} a multiple of the cycle"
        );
    }
}

/// The radar FMU with `"radar": {"preset": "imaging"}` in its `resources/config.json` runs the
/// 4D imaging radar (12 Tx × 16 Rx = 192 virtual channels, 512 × 64 cube), and with
/// `radar.road_clutter` (on by default) the road's own returns are among its peaks (peaks of no
/// object); with the effect switched off in the same file there are none.
#[test]
fn imaging_preset_and_road_clutter_run_in_the_radar_fmu_by_config() {
    let run = |clutter: bool| {
        let dir = assemble_fmu_dir("radar");
        let path = dir.path().join("resources/config.json");
        let mut cfg: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(&path).unwrap()).unwrap();
        cfg["radar"] = serde_json::json!({ "preset": "imaging" });
        cfg["effects"]["radar.road_clutter"] = serde_json::json!(clutter);
        std::fs::write(&path, serde_json::to_string_pretty(&cfg).unwrap()).unwrap();
        let fmu = Fmu::from_dir(dir.path()).unwrap();
        let opts = InstanceOptions {
            stderr_level: None,
            ..InstanceOptions::default()
        };
        let mut s = OsmpSensor::instantiate(&fmu, "radar_imaging", opts).unwrap();
        s.initialize(0.0, &[]).unwrap();
        let h = s.default_step_size().unwrap_or(0.05);
        let sv = sensor_view_with_car(0.0).encode_to_vec();
        let out = s.step(&sv, 0.0, h).unwrap();
        let pd = osiris_proto::perception::PerceptionData::decode(
            out.perception.as_deref().expect("PerceptionData"),
        )
        .unwrap();
        let radar = pd.radar.expect("radar perception");
        let w = radar.waveform.expect("waveform");
        assert_eq!(
            (w.virtual_channels, w.samples_per_chirp, w.chirps_per_frame),
            (Some(192), Some(512), Some(64)),
            "{w:?}"
        );
        let on_car = radar
            .peak
            .iter()
            .filter(|p| p.object_id.and_then(|i| i.value) == Some(2))
            .count();
        let road = radar
            .peak
            .iter()
            .filter(|p| {
                p.object_id
                    .and_then(|i| i.value)
                    .is_none_or(|v| v == u64::MAX)
            })
            .count();
        (on_car, road)
    };
    let (car_on, road_on) = run(true);
    let (car_off, road_off) = run(false);
    assert!(car_on > 0 && car_off > 0, "{car_on} / {car_off}");
    assert!(
        road_on > 0,
        "no road clutter peak with radar.road_clutter on"
    );
    assert_eq!(road_off, 0, "road peaks with radar.road_clutter off");
}
