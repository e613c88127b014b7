//! Renders the FMI 2.0 co-simulation `modelDescription.xml` of an FMU (OSMP 1.6.0 packaging), from
//! its descriptor and the variable table of its role.
//!
//! Element order follows `fmi2ModelDescription.xsd`: CoSimulation, UnitDefinitions, LogCategories,
//! DefaultExperiment, VendorAnnotations, ModelVariables, ModelStructure. The output is
//! byte-for-byte reproducible (no timestamps); the GUID is a UUID v5 of the document rendered with
//! an empty `guid`, so any change to the document changes the GUID.

use std::fmt::Write as _;

use uuid::Uuid;

use crate::descriptor::FmuDescriptor;
use crate::logging::LogCategory;
use crate::variables::{Causality, Initial, Start, VarType};

/// OSMP version declared in the marker annotation.
pub const OSMP_VERSION: &str = "1.6.0";
/// OSI version declared in the marker annotation.
pub const OSMP_OSI_VERSION: &str = "3.8.0";
/// XML namespace of the OSMP annotations.
pub const OSMP_NAMESPACE: &str = "http://xsd.pmsf.net/OSISensorModelPackaging";
/// Namespace of the v5 GUIDs (a fixed random UUID owned by osiris).
pub const GUID_NAMESPACE: Uuid = Uuid::from_u128(0x5e0c_1f3a_8d2b_4c71_9a6e_3b0f_d27c_4a19);

/// The complete modelDescription.xml of `desc` (with its GUID).
pub fn render(desc: &FmuDescriptor) -> String {
    render_with_guid(desc, desc.guid())
}

/// The GUID of `desc`: UUID v5 (namespace [`GUID_NAMESPACE`]) of the document rendered with
/// `guid=""`, hyphenated lower case.
pub fn compute_guid(desc: &FmuDescriptor) -> String {
    let placeholder = render_with_guid(desc, "");
    Uuid::new_v5(&GUID_NAMESPACE, placeholder.as_bytes())
        .hyphenated()
        .to_string()
}

/// XML attribute escaping.
fn esc(s: &str) -> String {
    let mut out = String::with_capacity(s.len());
    for ch in s.chars() {
        match ch {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '"' => out.push_str("&quot;"),
            '\n' => out.push_str("&#10;"),
            c => out.push(c),
        }
    }
    out
}

/// An `xs:double` that round-trips (`Display` of f64 is the shortest round-trip form and never uses
/// an exponent).
fn xml_double(v: f64) -> String {
    assert!(v.is_finite(), "non-finite value in the modelDescription");
    format!("{v}")
}

fn osmp_tool_open() -> String {
    format!(r#"<Tool name="net.pmsf.osmp" xmlns:osmp="{OSMP_NAMESPACE}">"#)
}

fn render_with_guid(desc: &FmuDescriptor, guid: &str) -> String {
    let version = env!("CARGO_PKG_VERSION");
    let mut x = String::with_capacity(16 * 1024);
    // `write!` into a String cannot fail.
    let _ = writeln!(x, r#"<?xml version="1.0" encoding="UTF-8"?>"#);
    let _ = writeln!(x, "<fmiModelDescription");
    let _ = writeln!(x, r#"  fmiVersion="2.0""#);
    let _ = writeln!(x, r#"  modelName="{}""#, esc(desc.model_name));
    let _ = writeln!(x, r#"  guid="{}""#, esc(guid));
    let _ = writeln!(x, r#"  description="{}""#, esc(desc.description));
    let _ = writeln!(x, r#"  version="{version}""#);
    let _ = writeln!(x, r#"  generationTool="osiris-fmu {version}""#);
    let _ = writeln!(x, r#"  license="MPL-2.0""#);
    let _ = writeln!(x, r#"  variableNamingConvention="structured">"#);

    let _ = writeln!(x, "  <CoSimulation");
    let _ = writeln!(x, r#"    modelIdentifier="{}""#, esc(desc.model_identifier));
    let _ = writeln!(x, r#"    needsExecutionTool="false""#);
    let _ = writeln!(x, r#"    canHandleVariableCommunicationStepSize="true""#);
    let _ = writeln!(x, r#"    canInterpolateInputs="false""#);
    let _ = writeln!(x, r#"    maxOutputDerivativeOrder="0""#);
    let _ = writeln!(x, r#"    canRunAsynchronuously="false""#);
    let _ = writeln!(x, r#"    canBeInstantiatedOnlyOncePerProcess="false""#);
    let _ = writeln!(x, r#"    canNotUseMemoryManagementFunctions="true""#);
    let _ = writeln!(x, r#"    canGetAndSetFMUstate="false""#);
    let _ = writeln!(x, r#"    canSerializeFMUstate="false""#);
    let _ = writeln!(x, r#"    providesDirectionalDerivative="false"/>"#);

    let variables = desc.variables();
    // Units of the Real parameters, in first-use order.
    let mut units: Vec<&str> = Vec::new();
    for v in variables.iter() {
        if let Some(u) = v.unit
            && !units.contains(&u)
        {
            units.push(u);
        }
    }
    if !units.is_empty() {
        let _ = writeln!(x, "  <UnitDefinitions>");
        for u in &units {
            let base = match *u {
                "m" => r#"<BaseUnit m="1"/>"#,
                "rad" => r#"<BaseUnit rad="1"/>"#,
                "s" => r#"<BaseUnit s="1"/>"#,
                other => panic!("unit `{other}` has no BaseUnit mapping"),
            };
            let _ = writeln!(x, r#"    <Unit name="{}">{base}</Unit>"#, esc(u));
        }
        let _ = writeln!(x, "  </UnitDefinitions>");
    }

    let _ = writeln!(x, "  <LogCategories>");
    for c in LogCategory::ALL {
        let _ = writeln!(
            x,
            r#"    <Category name="{}" description="{}"/>"#,
            c.name(),
            esc(c.description())
        );
    }
    let _ = writeln!(x, "  </LogCategories>");

    let stop = desc
        .default_stop_time_s()
        .map(|t| format!(r#" stopTime="{}""#, xml_double(t)))
        .unwrap_or_default();
    let _ = writeln!(
        x,
        r#"  <DefaultExperiment startTime="0"{stop} stepSize="{}"/>"#,
        xml_double(desc.default_step_size_s())
    );

    let _ = writeln!(x, "  <VendorAnnotations>");
    let _ = writeln!(
        x,
        r#"    {}<osmp:osmp version="{OSMP_VERSION}" osi-version="{OSMP_OSI_VERSION}"/></Tool>"#,
        osmp_tool_open()
    );
    let _ = writeln!(x, "  </VendorAnnotations>");

    let _ = writeln!(x, "  <ModelVariables>");
    for (i, v) in variables.iter().enumerate() {
        let _ = writeln!(x, "    <!-- Index {} -->", i + 1);
        let _ = write!(
            x,
            r#"    <ScalarVariable name="{}" valueReference="{}" description="{}" causality="{}" variability="{}""#,
            esc(v.name),
            v.vr,
            esc(v.description),
            v.causality.name(),
            v.variability.name()
        );
        if let Some(initial) = v.initial {
            let _ = write!(x, r#" initial="{}""#, initial.name());
        }
        let _ = writeln!(x, ">");
        let start = match v.start {
            Start::None => String::new(),
            Start::Integer(i) => format!(r#" start="{i}""#),
            Start::Boolean(b) => format!(r#" start="{b}""#),
            Start::RealDefault(_) => {
                let value = v.start.real(desc.sensor_kind()).expect("Real start");
                format!(r#" start="{}""#, xml_double(value))
            }
            Start::String(_) | Start::ModeDefault => {
                let value = v.start.string(desc.sensor_kind()).expect("String start");
                format!(r#" start="{}""#, esc(value))
            }
        };
        let unit = v
            .unit
            .map(|u| format!(r#" unit="{}""#, esc(u)))
            .unwrap_or_default();
        let _ = writeln!(x, "      <{}{start}{unit}/>", v.ty.name());
        if let Some(osmp) = v.osmp {
            let _ = writeln!(x, "      <Annotations>");
            let _ = writeln!(
                x,
                r#"        {}<osmp:osmp-binary-variable name="{}" role="{}" mime-type="{}"/></Tool>"#,
                osmp_tool_open(),
                esc(osmp.prefix),
                osmp.role.name(),
                esc(osmp.mime_type)
            );
            let _ = writeln!(x, "      </Annotations>");
        }
        let _ = writeln!(x, "    </ScalarVariable>");
    }
    let _ = writeln!(x, "  </ModelVariables>");

    let _ = writeln!(x, "  <ModelStructure>");
    let _ = writeln!(x, "    <Outputs>");
    for (i, v) in variables.iter().enumerate() {
        if v.causality == Causality::Output {
            let _ = writeln!(x, r#"      <Unknown index="{}"/>"#, i + 1);
        }
    }
    let _ = writeln!(x, "    </Outputs>");
    // InitialUnknowns: the calculatedParameters (a sensor's ConfigRequest) and the outputs computed
    // during initialization (a source's first SensorView). They depend on the Config triple and
    // every Real and String parameter.
    let calculated: Vec<usize> = variables
        .iter()
        .enumerate()
        .filter(|(_, v)| {
            v.causality == Causality::CalculatedParameter
                || (v.causality == Causality::Output && v.initial == Some(Initial::Calculated))
        })
        .map(|(i, _)| i + 1)
        .collect();
    if !calculated.is_empty() {
        let deps: Vec<String> = variables
            .iter()
            .enumerate()
            .filter(|(_, v)| {
                v.causality == Causality::Parameter
                    && (v.osmp.is_some_and(|o| o.prefix == "OSMPSensorViewInConfig")
                        || matches!(v.ty, VarType::Real | VarType::String))
            })
            .map(|(i, _)| (i + 1).to_string())
            .collect();
        let _ = writeln!(x, "    <InitialUnknowns>");
        for i in calculated {
            let _ = writeln!(
                x,
                r#"      <Unknown index="{i}" dependencies="{}"/>"#,
                deps.join(" ")
            );
        }
        let _ = writeln!(x, "    </InitialUnknowns>");
    }
    let _ = writeln!(x, "  </ModelStructure>");
    let _ = writeln!(x, "</fmiModelDescription>");
    x
}
