//! `modelDescription.xml` of an FMI 2.0 co-simulation FMU, with the OSMP annotations.
//!
//! Parsed with `roxmltree` (the `fmi` crate rejects the per-variable `<Annotations>` OSMP needs). Besides the
//! FMI elements the master uses, [`ModelDescription::parse`] groups the OSMP notional binary variables
//! (`<prefix>.base.lo`, `<prefix>.base.hi`, `<prefix>.size`) into [`BinaryVariable`]s and checks them: complete
//! triples of Integer variables, one annotation per variable, identical causality, variability and MIME type,
//! and the `net.pmsf.osmp` marker in `<VendorAnnotations>`.

use std::collections::HashMap;
use std::fmt;

use super::{MasterError, ModelDescriptionError as E};

/// Name of the OSMP `<Tool>` in `<VendorAnnotations>` and in per-variable `<Annotations>`.
pub const OSMP_TOOL: &str = "net.pmsf.osmp";
/// XML namespace of the OSMP annotation elements.
pub const OSMP_NAMESPACE: &str = "http://xsd.pmsf.net/OSISensorModelPackaging";
/// Base MIME type of OSI buffers.
pub const OSI_MIME_BASE: &str = "application/x-open-simulation-interface";
/// MIME type of a binary variable whose annotation has no `mime-type` (OSMP default).
pub const DEFAULT_MIME: &str = "application/octet-stream";

/// A parsed `modelDescription.xml`.
#[derive(Debug, Clone)]
pub struct ModelDescription {
    /// Always `"2.0"`.
    pub fmi_version: String,
    pub model_name: String,
    pub guid: String,
    pub description: Option<String>,
    pub generation_tool: Option<String>,
    /// `flat` (the default) or `structured` (OSMP requires `structured`).
    pub variable_naming_convention: String,
    pub co_simulation: CoSimulation,
    pub default_experiment: Option<DefaultExperiment>,
    /// Names of the `<LogCategories>`.
    pub log_categories: Vec<String>,
    /// The OSMP marker, if the FMU declares one.
    pub osmp: Option<OsmpMarker>,
    /// Every `<ScalarVariable>`, in document order (index + 1 = the ModelStructure index).
    pub variables: Vec<ScalarVariable>,
    /// The OSMP binary variables, in order of first appearance.
    pub binary_variables: Vec<BinaryVariable>,
    by_name: HashMap<String, usize>,
    by_ref: HashMap<(BaseType, u32), usize>,
}

/// The `<CoSimulation>` element.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct CoSimulation {
    /// C identifier; the binary is `binaries/linux64/<modelIdentifier>.so`.
    pub model_identifier: String,
    pub needs_execution_tool: bool,
    pub can_handle_variable_communication_step_size: bool,
    pub can_interpolate_inputs: bool,
    pub max_output_derivative_order: u32,
    pub can_run_asynchronuously: bool,
    pub can_be_instantiated_only_once_per_process: bool,
    pub can_not_use_memory_management_functions: bool,
    pub can_get_and_set_fmu_state: bool,
    pub can_serialize_fmu_state: bool,
    pub provides_directional_derivative: bool,
}

/// The `<DefaultExperiment>` element (OSMP: `step_size` is the sensor cycle).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct DefaultExperiment {
    pub start_time: Option<f64>,
    pub stop_time: Option<f64>,
    pub tolerance: Option<f64>,
    pub step_size: Option<f64>,
}

/// `<VendorAnnotations><Tool name="net.pmsf.osmp"><osmp:osmp version=… osi-version=…/>`.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct OsmpMarker {
    /// OSMP version, e.g. `1.6.0`.
    pub version: String,
    /// OSI version, e.g. `3.8.0`; the default `version=` of OSI MIME types.
    pub osi_version: Option<String>,
}

/// FMI 2.0 base types: value references are unique per base type only.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum BaseType {
    Real,
    /// Integer and Enumeration share one value-reference namespace.
    Integer,
    Boolean,
    String,
}

/// The type element of a `<ScalarVariable>`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum VarType {
    Real,
    Integer,
    Boolean,
    String,
    Enumeration,
}

impl VarType {
    /// The value-reference namespace of this type.
    pub fn base(self) -> BaseType {
        match self {
            VarType::Real => BaseType::Real,
            VarType::Integer | VarType::Enumeration => BaseType::Integer,
            VarType::Boolean => BaseType::Boolean,
            VarType::String => BaseType::String,
        }
    }

    /// The XML element name.
    pub fn name(self) -> &'static str {
        match self {
            VarType::Real => "Real",
            VarType::Integer => "Integer",
            VarType::Boolean => "Boolean",
            VarType::String => "String",
            VarType::Enumeration => "Enumeration",
        }
    }

    fn from_element(name: &str) -> Option<Self> {
        Some(match name {
            "Real" => VarType::Real,
            "Integer" => VarType::Integer,
            "Boolean" => VarType::Boolean,
            "String" => VarType::String,
            "Enumeration" => VarType::Enumeration,
            _ => return None,
        })
    }
}

impl fmt::Display for VarType {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

macro_rules! attr_enum {
    ($(#[$m:meta])* $name:ident { $($variant:ident = $text:literal),+ $(,)? }) => {
        $(#[$m])*
        #[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
        pub enum $name { $($variant),+ }
        impl $name {
            /// The attribute value as written in the XML.
            pub fn as_str(self) -> &'static str {
                match self { $($name::$variant => $text),+ }
            }
            const EXPECTED: &'static str = concat!("one of" $(, " `", $text, "`")+);
            fn parse(text: &str) -> Option<Self> {
                match text { $($text => Some($name::$variant),)+ _ => None }
            }
        }
        impl fmt::Display for $name {
            fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result { f.write_str(self.as_str()) }
        }
    };
}

attr_enum!(
    /// `causality` of a variable (default `local`).
    Causality {
        Parameter = "parameter",
        CalculatedParameter = "calculatedParameter",
        Input = "input",
        Output = "output",
        Local = "local",
        Independent = "independent",
    }
);
attr_enum!(
    /// `variability` of a variable (default `continuous`).
    Variability {
        Constant = "constant",
        Fixed = "fixed",
        Tunable = "tunable",
        Discrete = "discrete",
        Continuous = "continuous",
    }
);
attr_enum!(
    /// `initial` of a variable.
    Initial {
        Exact = "exact",
        Approx = "approx",
        Calculated = "calculated",
    }
);

/// A scalar value of one of the FMI 2.0 types (Enumeration values are [`Value::Integer`]).
#[derive(Debug, Clone, PartialEq)]
pub enum Value {
    Real(f64),
    Integer(i32),
    Boolean(bool),
    String(String),
}

impl Value {
    /// Parses `text` as a value of type `ty` (booleans: `true`/`false`/`1`/`0`).
    pub fn parse(ty: VarType, text: &str) -> Result<Value, String> {
        let t = text.trim();
        match ty {
            VarType::Real => t
                .parse::<f64>()
                .map(Value::Real)
                .map_err(|_| format!("`{text}` is not a Real (expected a floating-point number)")),
            VarType::Integer | VarType::Enumeration => t
                .parse::<i32>()
                .map(Value::Integer)
                .map_err(|_| format!("`{text}` is not an {ty} (expected a 32-bit signed integer)")),
            VarType::Boolean => parse_xs_boolean(t)
                .map(Value::Boolean)
                .ok_or_else(|| format!("`{text}` is not a Boolean (expected true, false, 1 or 0)")),
            VarType::String => Ok(Value::String(text.to_owned())),
        }
    }

    /// The type name (`Real`, `Integer`, `Boolean`, `String`).
    pub fn type_name(&self) -> &'static str {
        match self {
            Value::Real(_) => "Real",
            Value::Integer(_) => "Integer",
            Value::Boolean(_) => "Boolean",
            Value::String(_) => "String",
        }
    }
}

impl fmt::Display for Value {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Value::Real(v) => write!(f, "{v}"),
            Value::Integer(v) => write!(f, "{v}"),
            Value::Boolean(v) => write!(f, "{v}"),
            Value::String(v) => write!(f, "{v:?}"),
        }
    }
}

impl From<f64> for Value {
    fn from(v: f64) -> Self {
        Value::Real(v)
    }
}
impl From<i32> for Value {
    fn from(v: i32) -> Self {
        Value::Integer(v)
    }
}
impl From<bool> for Value {
    fn from(v: bool) -> Self {
        Value::Boolean(v)
    }
}
impl From<&str> for Value {
    fn from(v: &str) -> Self {
        Value::String(v.to_owned())
    }
}
impl From<String> for Value {
    fn from(v: String) -> Self {
        Value::String(v)
    }
}

/// One `<ScalarVariable>`.
#[derive(Debug, Clone, PartialEq)]
pub struct ScalarVariable {
    pub name: String,
    pub value_reference: u32,
    pub description: Option<String>,
    pub causality: Causality,
    pub variability: Variability,
    /// As written; `None` if absent (the FMI default then depends on causality and variability).
    pub initial: Option<Initial>,
    pub var_type: VarType,
    /// `declaredType` (required for Enumeration).
    pub declared_type: Option<String>,
    pub start: Option<Value>,
    /// The OSMP `osmp-binary-variable` annotation, if any.
    pub osmp_binary: Option<OsmpBinaryAnnotation>,
}

/// `<Annotations><Tool name="net.pmsf.osmp"><osmp:osmp-binary-variable name role mime-type/>`.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct OsmpBinaryAnnotation {
    /// The binary variable's prefix.
    pub name: String,
    pub role: BinaryRole,
    /// As written, or [`DEFAULT_MIME`] if absent.
    pub mime_type: String,
}

/// Role of an Integer variable within an OSMP binary variable.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum BinaryRole {
    BaseLo,
    BaseHi,
    Size,
}

impl BinaryRole {
    pub const ALL: [BinaryRole; 3] = [BinaryRole::BaseLo, BinaryRole::BaseHi, BinaryRole::Size];

    /// `base.lo`, `base.hi` or `size`.
    pub fn as_str(self) -> &'static str {
        match self {
            BinaryRole::BaseLo => "base.lo",
            BinaryRole::BaseHi => "base.hi",
            BinaryRole::Size => "size",
        }
    }
}

impl fmt::Display for BinaryRole {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.as_str())
    }
}

/// An OSMP notional binary variable: three Integer variables carrying a buffer's address and size.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct BinaryVariable {
    /// e.g. `OSMPSensorViewIn`.
    pub prefix: String,
    pub lo_vr: u32,
    pub hi_vr: u32,
    pub size_vr: u32,
    /// The MIME type shared by the three annotations.
    pub mime: String,
    pub causality: Causality,
    pub variability: Variability,
}

impl BinaryVariable {
    /// `[lo_vr, hi_vr, size_vr]`, the order of one `fmi2GetInteger` / `fmi2SetInteger` call.
    pub fn vrs(&self) -> [u32; 3] {
        [self.lo_vr, self.hi_vr, self.size_vr]
    }

    /// A MIME parameter, e.g. `mime_parameter("type")` → `Some("SensorView")`.
    pub fn mime_parameter(&self, key: &str) -> Option<&str> {
        mime_parameter(&self.mime, key)
    }
}

/// A parameter of a MIME string `base; key=value; …` (keys case-insensitive, values unquoted).
pub fn mime_parameter<'a>(mime: &'a str, key: &str) -> Option<&'a str> {
    mime.split(';').skip(1).find_map(|p| {
        let (k, v) = p.split_once('=')?;
        k.trim()
            .eq_ignore_ascii_case(key)
            .then(|| v.trim().trim_matches('"'))
    })
}

/// The base type of a MIME string (before the first `;`), trimmed.
pub fn mime_base(mime: &str) -> &str {
    mime.split(';').next().unwrap_or("").trim()
}

fn parse_xs_boolean(text: &str) -> Option<bool> {
    match text.trim() {
        "true" | "1" => Some(true),
        "false" | "0" => Some(false),
        _ => None,
    }
}

/// Checks the OSMP version pattern `[1][.][0-9][.][0-9]+` of `osmp.xsd`.
fn is_osmp_version(v: &str) -> bool {
    let b = v.as_bytes();
    b.len() >= 5
        && b[0] == b'1'
        && b[1] == b'.'
        && b[2].is_ascii_digit()
        && b[3] == b'.'
        && b[4..].iter().all(u8::is_ascii_digit)
}

type Node<'a, 'i> = roxmltree::Node<'a, 'i>;

fn element_label(node: Node) -> String {
    match node.tag_name().name() {
        "ScalarVariable" => match node.attribute("name") {
            Some(n) => format!("<ScalarVariable name=\"{n}\">"),
            None => "<ScalarVariable>".to_owned(),
        },
        other => format!("<{other}>"),
    }
}

fn required<'a>(node: Node<'a, '_>, attribute: &'static str) -> Result<&'a str, E> {
    node.attribute(attribute)
        .ok_or_else(|| E::MissingAttribute {
            element: element_label(node),
            attribute,
        })
}

fn invalid(node: Node, attribute: &'static str, value: &str, expected: impl Into<String>) -> E {
    E::InvalidAttribute {
        element: element_label(node),
        attribute,
        value: value.to_owned(),
        expected: expected.into(),
    }
}

fn opt_bool(node: Node, attribute: &'static str) -> Result<bool, E> {
    match node.attribute(attribute) {
        None => Ok(false),
        Some(v) => parse_xs_boolean(v).ok_or_else(|| invalid(node, attribute, v, "true or false")),
    }
}

fn opt_f64(node: Node, attribute: &'static str) -> Result<Option<f64>, E> {
    node.attribute(attribute)
        .map(|v| {
            v.trim()
                .parse::<f64>()
                .map_err(|_| invalid(node, attribute, v, "a floating-point number"))
        })
        .transpose()
}

fn children<'a, 'i>(node: Node<'a, 'i>, name: &'static str) -> impl Iterator<Item = Node<'a, 'i>> {
    node.children()
        .filter(move |c| c.is_element() && c.tag_name().name() == name)
}

fn child<'a, 'i>(node: Node<'a, 'i>, name: &'static str) -> Option<Node<'a, 'i>> {
    children(node, name).next()
}

/// The OSMP element `local` inside `<Tool name="net.pmsf.osmp">` children of `parent`.
fn osmp_elements<'a, 'i>(parent: Node<'a, 'i>, local: &'static str) -> Vec<Node<'a, 'i>> {
    children(parent, "Tool")
        .filter(|t| t.attribute("name") == Some(OSMP_TOOL))
        .flat_map(move |t| {
            t.children()
                .filter(move |c| c.is_element() && c.tag_name().name() == local)
        })
        .collect()
}

impl ModelDescription {
    /// Parses and checks a `modelDescription.xml` (errors name the file `modelDescription.xml`).
    pub fn parse(xml: &str) -> Result<ModelDescription, MasterError> {
        Self::parse_named(xml, "modelDescription.xml")
    }

    /// As [`ModelDescription::parse`], with `file` (e.g. the path) named in errors.
    pub fn parse_named(xml: &str, file: &str) -> Result<ModelDescription, MasterError> {
        Self::parse_inner(xml).map_err(|error| MasterError::ModelDescription {
            file: file.to_owned(),
            error,
        })
    }

    /// Reads and parses the file at `path`.
    pub fn from_file(path: &std::path::Path) -> Result<ModelDescription, MasterError> {
        let xml = std::fs::read_to_string(path).map_err(|source| MasterError::Io {
            action: "read the model description",
            path: path.to_owned(),
            source,
        })?;
        Self::parse_named(&xml, &path.display().to_string())
    }

    fn parse_inner(xml: &str) -> Result<ModelDescription, E> {
        let doc = roxmltree::Document::parse(xml).map_err(|e| E::Xml(e.to_string()))?;
        let root = doc.root_element();
        if root.tag_name().name() != "fmiModelDescription" {
            return Err(E::WrongRoot {
                found: root.tag_name().name().to_owned(),
            });
        }
        let fmi_version = required(root, "fmiVersion")?;
        if fmi_version != "2.0" {
            return Err(E::UnsupportedFmiVersion {
                found: fmi_version.to_owned(),
            });
        }
        let model_name = required(root, "modelName")?.to_owned();
        let guid = required(root, "guid")?.to_owned();
        let variable_naming_convention = match root.attribute("variableNamingConvention") {
            None => "flat".to_owned(),
            Some(v @ ("flat" | "structured")) => v.to_owned(),
            Some(v) => {
                return Err(invalid(
                    root,
                    "variableNamingConvention",
                    v,
                    "`flat` or `structured`",
                ));
            }
        };

        let cs = child(root, "CoSimulation").ok_or(E::NoCoSimulation)?;
        let co_simulation = CoSimulation {
            model_identifier: required(cs, "modelIdentifier")?.to_owned(),
            needs_execution_tool: opt_bool(cs, "needsExecutionTool")?,
            can_handle_variable_communication_step_size: opt_bool(
                cs,
                "canHandleVariableCommunicationStepSize",
            )?,
            can_interpolate_inputs: opt_bool(cs, "canInterpolateInputs")?,
            max_output_derivative_order: match cs.attribute("maxOutputDerivativeOrder") {
                None => 0,
                Some(v) => v.trim().parse().map_err(|_| {
                    invalid(cs, "maxOutputDerivativeOrder", v, "an unsigned integer")
                })?,
            },
            can_run_asynchronuously: opt_bool(cs, "canRunAsynchronuously")?,
            can_be_instantiated_only_once_per_process: opt_bool(
                cs,
                "canBeInstantiatedOnlyOncePerProcess",
            )?,
            can_not_use_memory_management_functions: opt_bool(
                cs,
                "canNotUseMemoryManagementFunctions",
            )?,
            can_get_and_set_fmu_state: opt_bool(cs, "canGetAndSetFMUstate")?,
            can_serialize_fmu_state: opt_bool(cs, "canSerializeFMUstate")?,
            provides_directional_derivative: opt_bool(cs, "providesDirectionalDerivative")?,
        };
        let id = &co_simulation.model_identifier;
        let is_c_identifier = id
            .chars()
            .next()
            .is_some_and(|c| c.is_ascii_alphabetic() || c == '_')
            && id.chars().all(|c| c.is_ascii_alphanumeric() || c == '_');
        if !is_c_identifier {
            return Err(invalid(cs, "modelIdentifier", id, "a C identifier"));
        }

        let default_experiment = child(root, "DefaultExperiment")
            .map(|d| {
                Ok::<_, E>(DefaultExperiment {
                    start_time: opt_f64(d, "startTime")?,
                    stop_time: opt_f64(d, "stopTime")?,
                    tolerance: opt_f64(d, "tolerance")?,
                    step_size: opt_f64(d, "stepSize")?,
                })
            })
            .transpose()?;

        let log_categories = child(root, "LogCategories")
            .map(|lc| {
                children(lc, "Category")
                    .map(|c| required(c, "name").map(str::to_owned))
                    .collect::<Result<Vec<_>, _>>()
            })
            .transpose()?
            .unwrap_or_default();

        let osmp = match child(root, "VendorAnnotations").map(|va| osmp_elements(va, "osmp")) {
            Some(markers) if !markers.is_empty() => {
                let m = markers[0];
                let version = required(m, "version")?;
                if !is_osmp_version(version) {
                    return Err(invalid(
                        m,
                        "version",
                        version,
                        "an OSMP version matching `1.x.y` (osmp.xsd)",
                    ));
                }
                Some(OsmpMarker {
                    version: version.to_owned(),
                    osi_version: m.attribute("osi-version").map(str::to_owned),
                })
            }
            _ => None,
        };

        let mv = child(root, "ModelVariables").ok_or(E::MissingElement {
            element: "ModelVariables",
            parent: "fmiModelDescription",
        })?;
        let mut variables = Vec::new();
        let mut by_name = HashMap::new();
        let mut by_ref = HashMap::new();
        for sv in children(mv, "ScalarVariable") {
            let var = parse_scalar_variable(sv)?;
            if by_name.insert(var.name.clone(), variables.len()).is_some() {
                return Err(E::DuplicateVariableName { name: var.name });
            }
            by_ref
                .entry((var.var_type.base(), var.value_reference))
                .or_insert(variables.len());
            variables.push(var);
        }

        let binary_variables = group_binary_variables(&variables, osmp.as_ref())?;
        Ok(ModelDescription {
            fmi_version: fmi_version.to_owned(),
            model_name,
            guid,
            description: root.attribute("description").map(str::to_owned),
            generation_tool: root.attribute("generationTool").map(str::to_owned),
            variable_naming_convention,
            co_simulation,
            default_experiment,
            log_categories,
            osmp,
            variables,
            binary_variables,
            by_name,
            by_ref,
        })
    }

    /// The variable named `name`.
    pub fn variable(&self, name: &str) -> Option<&ScalarVariable> {
        self.by_name.get(name).map(|&i| &self.variables[i])
    }

    /// The first variable with value reference `vr` in the namespace of `base` (others are aliases).
    pub fn variable_by_ref(&self, base: BaseType, vr: u32) -> Option<&ScalarVariable> {
        self.by_ref.get(&(base, vr)).map(|&i| &self.variables[i])
    }

    /// The binary variable with this prefix.
    pub fn binary_variable(&self, prefix: &str) -> Option<&BinaryVariable> {
        self.binary_variables.iter().find(|b| b.prefix == prefix)
    }

    /// Whether the FMU carries the OSMP marker.
    pub fn is_osmp(&self) -> bool {
        self.osmp.is_some()
    }
}

fn parse_scalar_variable(sv: Node) -> Result<ScalarVariable, E> {
    let name = required(sv, "name")?.to_owned();
    let vr_text = required(sv, "valueReference")?;
    let value_reference = vr_text
        .trim()
        .parse::<u32>()
        .map_err(|_| invalid(sv, "valueReference", vr_text, "an unsigned 32-bit integer"))?;
    let causality = match sv.attribute("causality") {
        None => Causality::Local,
        Some(v) => {
            Causality::parse(v).ok_or_else(|| invalid(sv, "causality", v, Causality::EXPECTED))?
        }
    };
    let variability = match sv.attribute("variability") {
        None => Variability::Continuous,
        Some(v) => Variability::parse(v)
            .ok_or_else(|| invalid(sv, "variability", v, Variability::EXPECTED))?,
    };
    let initial = sv
        .attribute("initial")
        .map(|v| Initial::parse(v).ok_or_else(|| invalid(sv, "initial", v, Initial::EXPECTED)))
        .transpose()?;

    let typed: Vec<(Node, VarType)> = sv
        .children()
        .filter(|c| c.is_element())
        .filter_map(|c| VarType::from_element(c.tag_name().name()).map(|t| (c, t)))
        .collect();
    let [(type_node, var_type)] = typed[..] else {
        return Err(E::InvalidVariable {
            name,
            reason: format!(
                "has {} type elements, expected exactly one of <Real>, <Integer>, <Boolean>, <String>, <Enumeration>",
                typed.len()
            ),
        });
    };
    let declared_type = type_node.attribute("declaredType").map(str::to_owned);
    if var_type == VarType::Enumeration && declared_type.is_none() {
        return Err(E::MissingAttribute {
            element: format!("<Enumeration> of variable `{name}`"),
            attribute: "declaredType",
        });
    }
    let start = type_node
        .attribute("start")
        .map(|s| {
            Value::parse(var_type, s).map_err(|reason| E::InvalidVariable {
                name: name.clone(),
                reason: format!("start value: {reason}"),
            })
        })
        .transpose()?;

    let mut osmp_binary = None;
    if let Some(ann) = child(sv, "Annotations") {
        let found = osmp_elements(ann, "osmp-binary-variable");
        if found.len() > 1 {
            return Err(E::InvalidBinaryAnnotation {
                variable: name,
                reason: format!(
                    "has {} osmp-binary-variable annotations, expected exactly one",
                    found.len()
                ),
            });
        }
        if let Some(&a) = found.first() {
            let prefix = required(a, "name")?.to_owned();
            let role_text = required(a, "role")?;
            let role = match role_text {
                "base.lo" => BinaryRole::BaseLo,
                "base.hi" => BinaryRole::BaseHi,
                "size" => BinaryRole::Size,
                "full" => {
                    return Err(E::InvalidBinaryAnnotation {
                        variable: name,
                        reason: "role `full` is the FMI 3.0 form; FMI 2.0 binary variables use `base.lo`, `base.hi` and `size`"
                            .to_owned(),
                    });
                }
                other => {
                    return Err(invalid(
                        a,
                        "role",
                        other,
                        "one of `base.lo`, `base.hi`, `size`",
                    ));
                }
            };
            osmp_binary = Some(OsmpBinaryAnnotation {
                name: prefix,
                role,
                mime_type: a.attribute("mime-type").unwrap_or(DEFAULT_MIME).to_owned(),
            });
        }
    }

    Ok(ScalarVariable {
        name,
        value_reference,
        description: sv.attribute("description").map(str::to_owned),
        causality,
        variability,
        initial,
        var_type,
        declared_type,
        start,
        osmp_binary,
    })
}

fn group_binary_variables(
    vars: &[ScalarVariable],
    marker: Option<&OsmpMarker>,
) -> Result<Vec<BinaryVariable>, E> {
    // prefix → [lo, hi, size] variable indices, in order of first appearance.
    let mut groups: Vec<(String, [Option<usize>; 3])> = Vec::new();
    for (i, v) in vars.iter().enumerate() {
        let Some(ann) = &v.osmp_binary else { continue };
        if marker.is_none() {
            return Err(E::MissingOsmpMarker {
                variable: v.name.clone(),
            });
        }
        if v.var_type != VarType::Integer {
            return Err(E::InvalidBinaryAnnotation {
                variable: v.name.clone(),
                reason: format!("is a {}, expected an Integer variable", v.var_type),
            });
        }
        let expected_name = format!("{}.{}", ann.name, ann.role);
        if v.name != expected_name {
            return Err(E::InvalidBinaryAnnotation {
                variable: v.name.clone(),
                reason: format!(
                    "is annotated as role `{}` of `{}`, expected it to be named `{expected_name}`",
                    ann.role, ann.name
                ),
            });
        }
        let pos = match groups.iter().position(|(p, _)| *p == ann.name) {
            Some(p) => p,
            None => {
                groups.push((ann.name.clone(), [None; 3]));
                groups.len() - 1
            }
        };
        // Names are unique and each role fixes the name, so a role cannot be taken twice.
        groups[pos].1[ann.role as usize] = Some(i);
    }

    let mut out = Vec::with_capacity(groups.len());
    for (prefix, slots) in groups {
        let missing: Vec<&'static str> = BinaryRole::ALL
            .iter()
            .zip(&slots)
            .filter(|(_, s)| s.is_none())
            .map(|(r, _)| r.as_str())
            .collect();
        if !missing.is_empty() {
            return Err(E::IncompleteBinaryVariable { prefix, missing });
        }
        let [lo, hi, size] = slots.map(|s| &vars[s.expect("checked complete")]);
        let triple = [lo, hi, size];
        let describe = |f: &dyn Fn(&ScalarVariable) -> String| {
            triple
                .iter()
                .map(|v| format!("{}={}", v.name, f(v)))
                .collect::<Vec<_>>()
                .join(", ")
        };
        if triple.iter().any(|v| v.causality != lo.causality) {
            return Err(E::BinaryVariableMismatch {
                prefix,
                attribute: "causality",
                values: describe(&|v| v.causality.to_string()),
            });
        }
        if triple.iter().any(|v| v.variability != lo.variability) {
            return Err(E::BinaryVariableMismatch {
                prefix,
                attribute: "variability",
                values: describe(&|v| v.variability.to_string()),
            });
        }
        let mime_of =
            |v: &ScalarVariable| v.osmp_binary.as_ref().expect("annotated").mime_type.clone();
        let mime = mime_of(lo);
        if triple.iter().any(|v| mime_of(v) != mime) {
            return Err(E::BinaryVariableMismatch {
                prefix,
                attribute: "mime-type",
                values: describe(&|v| format!("\"{}\"", mime_of(v))),
            });
        }
        if mime_base(&mime) == OSI_MIME_BASE
            && mime_parameter(&mime, "version").is_none()
            && marker.and_then(|m| m.osi_version.as_ref()).is_none()
        {
            return Err(E::MissingMimeVersion { prefix, mime });
        }
        if vars.iter().any(|v| v.name == prefix) {
            return Err(E::PrefixNameClash { prefix });
        }
        out.push(BinaryVariable {
            prefix,
            lo_vr: lo.value_reference,
            hi_vr: hi.value_reference,
            size_vr: size.value_reference,
            mime,
            causality: lo.causality,
            variability: lo.variability,
        });
    }
    Ok(out)
}
