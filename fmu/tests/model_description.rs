//! The checked-in `modelDescription/{camera,radar,lidar,scenario}.xml` must equal the rendered XML,
//! and the rendered XML must carry the variable contract.
//!
//! Regenerate after an intended change with:
//! `OSIRIS_BLESS=1 cargo test -p osiris-fmu --test model_description`

use std::collections::HashSet;
use std::path::PathBuf;

use osiris_fmu::variables::{SOURCE_VARIABLES, VARIABLES, vr};
use osiris_fmu::{FmuDescriptor, sensors, sources};
use osiris_models::{SensorConfig, SensorKind};

fn checked_in_path(desc: &FmuDescriptor) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("..")
        .join("modelDescription")
        .join(format!("{}.xml", desc.name()))
}

/// Every shipped FMU: the three sensors and the scenario player.
fn all_descriptors() -> Vec<&'static FmuDescriptor> {
    let mut all: Vec<_> = SensorKind::ALL
        .into_iter()
        .map(sensors::descriptor)
        .collect();
    all.push(&sources::scenario::DESCRIPTOR);
    all
}

#[test]
fn checked_in_model_descriptions_match_the_renderer() {
    let bless = std::env::var_os("OSIRIS_BLESS").is_some_and(|v| v == "1");
    let mut drift = Vec::new();
    for desc in all_descriptors() {
        let rendered = desc.model_description();
        let path = checked_in_path(desc);
        if bless {
            std::fs::create_dir_all(path.parent().unwrap()).unwrap();
            std::fs::write(&path, &rendered).unwrap();
            continue;
        }
        match std::fs::read_to_string(&path) {
            Ok(on_disk) if on_disk == rendered => {}
            Ok(_) => drift.push(format!("{} differs from the rendered XML", path.display())),
            Err(e) => drift.push(format!("{} cannot be read: {e}", path.display())),
        }
    }
    assert!(
        drift.is_empty(),
        "modelDescription drift:\n  {}\nIf the change is intended, regenerate them with\n  \
         OSIRIS_BLESS=1 cargo test -p osiris-fmu --test model_description\nand commit the files.",
        drift.join("\n  ")
    );
}

#[test]
fn rendering_is_deterministic_and_the_guid_is_the_xml_guid() {
    let mut guids = HashSet::new();
    for desc in all_descriptors() {
        let a = desc.model_description();
        let b = osiris_fmu::model_description::render(desc);
        assert_eq!(a, b);
        assert_eq!(
            desc.guid(),
            osiris_fmu::model_description::compute_guid(desc)
        );
        let doc = roxmltree::Document::parse(&a).unwrap();
        let root = doc.root_element();
        assert_eq!(root.attribute("guid"), Some(desc.guid()));
        assert!(uuid::Uuid::parse_str(desc.guid()).is_ok());
        assert!(
            guids.insert(desc.guid().to_string()),
            "GUIDs must differ between FMUs"
        );
        assert!(!a.contains("generationDateAndTime"));
    }
}

#[test]
fn structure_follows_fmi2_and_osmp() {
    for kind in SensorKind::ALL {
        let desc = sensors::descriptor(kind);
        let xml = desc.model_description();
        let doc = roxmltree::Document::parse(&xml).unwrap();
        let root = doc.root_element();
        assert_eq!(root.tag_name().name(), "fmiModelDescription");
        assert_eq!(root.attribute("fmiVersion"), Some("2.0"));
        assert_eq!(
            root.attribute("variableNamingConvention"),
            Some("structured")
        );
        assert_eq!(root.attribute("modelName"), Some(desc.model_name));

        // Element order per the XSD.
        let order: Vec<&str> = root
            .children()
            .filter(|n| n.is_element())
            .map(|n| n.tag_name().name())
            .collect();
        assert_eq!(
            order,
            [
                "CoSimulation",
                "UnitDefinitions",
                "LogCategories",
                "DefaultExperiment",
                "VendorAnnotations",
                "ModelVariables",
                "ModelStructure"
            ]
        );

        let cs = root
            .children()
            .find(|n| n.has_tag_name("CoSimulation"))
            .unwrap();
        assert_eq!(cs.attribute("modelIdentifier"), Some(desc.model_identifier));
        assert_eq!(
            cs.attribute("modelIdentifier"),
            Some(format!("osiris_{}", kind.name()).as_str())
        );
        for (attr, value) in [
            ("needsExecutionTool", "false"),
            ("canHandleVariableCommunicationStepSize", "true"),
            ("canBeInstantiatedOnlyOncePerProcess", "false"),
            ("canNotUseMemoryManagementFunctions", "true"),
            ("canGetAndSetFMUstate", "false"),
            ("canSerializeFMUstate", "false"),
        ] {
            assert_eq!(cs.attribute(attr), Some(value), "{attr}");
        }

        let cats: Vec<&str> = root
            .descendants()
            .filter(|n| n.has_tag_name("Category"))
            .filter_map(|n| n.attribute("name"))
            .collect();
        assert_eq!(
            cats,
            [
                "logStatusWarning",
                "logStatusError",
                "logStatusFatal",
                "logAll",
                "FMI",
                "OSMP",
                "OSI"
            ]
        );

        let de = root
            .children()
            .find(|n| n.has_tag_name("DefaultExperiment"))
            .unwrap();
        assert_eq!(de.attribute("startTime"), Some("0"));
        let step: f64 = de.attribute("stepSize").unwrap().parse().unwrap();
        assert_eq!(step, SensorConfig::default_for(kind).update_cycle_s);

        let marker = root
            .descendants()
            .find(|n| {
                n.tag_name().name() == "osmp"
                    && n.tag_name().namespace()
                        == Some(osiris_fmu::model_description::OSMP_NAMESPACE)
            })
            .expect("OSMP marker");
        assert_eq!(marker.attribute("version"), Some("1.6.0"));
        assert_eq!(marker.attribute("osi-version"), Some("3.8.0"));

        // Variables: the contract table.
        let svs: Vec<roxmltree::Node> = root
            .descendants()
            .filter(|n| n.has_tag_name("ScalarVariable"))
            .collect();
        assert_eq!(svs.len(), VARIABLES.len());
        let mut names = HashSet::new();
        let mut keys = HashSet::new();
        let defaults = SensorConfig::default_for(kind);
        let mut by_name = std::collections::HashMap::new();
        for (i, sv) in svs.iter().enumerate() {
            let name = sv.attribute("name").unwrap();
            assert!(names.insert(name), "duplicate name {name}");
            let ty = sv
                .children()
                .find(|n| n.is_element() && n.tag_name().name() != "Annotations")
                .unwrap();
            let vr: u32 = sv.attribute("valueReference").unwrap().parse().unwrap();
            assert!(
                keys.insert((ty.tag_name().name().to_string(), vr)),
                "duplicate VR {vr}"
            );
            by_name.insert(name, (i + 1, ty.tag_name().name(), vr, *sv, ty));
        }
        let expect = |name: &str,
                      ty: &str,
                      vr: u32,
                      caus: &str,
                      var: &str,
                      init: Option<&str>,
                      start: Option<&str>| {
            let (_, t, v, sv, tyn) = by_name
                .get(name)
                .unwrap_or_else(|| panic!("{name} missing"));
            assert_eq!((*t, *v), (ty, vr), "{name}");
            assert_eq!(sv.attribute("causality"), Some(caus), "{name}");
            assert_eq!(sv.attribute("variability"), Some(var), "{name}");
            assert_eq!(sv.attribute("initial"), init, "{name}");
            assert_eq!(tyn.attribute("start"), start, "{name}");
        };
        for (prefix, base, caus, var, init, start, mime) in [
            (
                "OSMPSensorViewIn",
                0,
                "input",
                "discrete",
                None,
                Some("0"),
                osiris_proto::MIME_SENSOR_VIEW,
            ),
            (
                "OSMPSensorDataOut",
                3,
                "output",
                "discrete",
                Some("exact"),
                Some("0"),
                osiris_proto::MIME_SENSOR_DATA,
            ),
            (
                "OSMPSensorViewInConfigRequest",
                6,
                "calculatedParameter",
                "fixed",
                Some("calculated"),
                None,
                osiris_proto::MIME_SENSOR_VIEW_CONFIGURATION,
            ),
            (
                "OSMPSensorViewInConfig",
                9,
                "parameter",
                "fixed",
                None,
                Some("0"),
                osiris_proto::MIME_SENSOR_VIEW_CONFIGURATION,
            ),
            (
                "PerceptionDataOut",
                12,
                "output",
                "discrete",
                Some("exact"),
                Some("0"),
                osiris_proto::MIME_PERCEPTION_DATA,
            ),
        ] {
            for (k, role) in ["base.lo", "base.hi", "size"].iter().enumerate() {
                let name = format!("{prefix}.{role}");
                expect(&name, "Integer", base + k as u32, caus, var, init, start);
                let sv = by_name[name.as_str()].3;
                let ann = sv
                    .descendants()
                    .find(|n| n.tag_name().name() == "osmp-binary-variable")
                    .unwrap_or_else(|| panic!("{name} annotation"));
                assert_eq!(ann.attribute("name"), Some(prefix));
                assert_eq!(ann.attribute("role"), Some(*role));
                assert_eq!(ann.attribute("mime-type"), Some(mime));
                let tool = ann.parent().unwrap();
                assert_eq!(tool.attribute("name"), Some("net.pmsf.osmp"));
            }
        }
        expect(
            "count",
            "Integer",
            vr::integer::COUNT,
            "output",
            "discrete",
            Some("exact"),
            Some("0"),
        );
        expect(
            "valid",
            "Boolean",
            vr::boolean::VALID,
            "output",
            "discrete",
            Some("exact"),
            Some("false"),
        );
        for (name, r, value, unit) in [
            ("range_m", vr::real::RANGE_M, defaults.range_m, "m"),
            (
                "fov_horizontal_rad",
                vr::real::FOV_HORIZONTAL_RAD,
                defaults.fov_horizontal_rad,
                "rad",
            ),
            (
                "fov_vertical_rad",
                vr::real::FOV_VERTICAL_RAD,
                defaults.fov_vertical_rad,
                "rad",
            ),
        ] {
            expect(
                name,
                "Real",
                r,
                "parameter",
                "fixed",
                None,
                Some(value.to_string().as_str()),
            );
            assert_eq!(by_name[name].4.attribute("unit"), Some(unit));
            let parsed: f64 = by_name[name].4.attribute("start").unwrap().parse().unwrap();
            assert_eq!(parsed, value, "{name} start round-trips");
        }
        expect(
            "config",
            "String",
            vr::string::CONFIG,
            "parameter",
            "fixed",
            None,
            Some("config.json"),
        );
        expect(
            "mode",
            "String",
            vr::string::MODE,
            "parameter",
            "fixed",
            None,
            Some(SensorConfig::default_for(kind).mode.name()),
        );

        // ModelStructure: every output listed, the ConfigRequest triple as InitialUnknowns.
        let outputs: Vec<usize> = root
            .descendants()
            .find(|n| n.has_tag_name("Outputs"))
            .unwrap()
            .children()
            .filter(|n| n.has_tag_name("Unknown"))
            .map(|n| n.attribute("index").unwrap().parse().unwrap())
            .collect();
        let mut expected_outputs: Vec<usize> = by_name
            .values()
            .filter(|v| v.3.attribute("causality") == Some("output"))
            .map(|v| v.0)
            .collect();
        expected_outputs.sort();
        assert_eq!(outputs, expected_outputs);
        let iu: Vec<(usize, String)> = root
            .descendants()
            .find(|n| n.has_tag_name("InitialUnknowns"))
            .unwrap()
            .children()
            .filter(|n| n.has_tag_name("Unknown"))
            .map(|n| {
                (
                    n.attribute("index").unwrap().parse().unwrap(),
                    n.attribute("dependencies").unwrap().to_string(),
                )
            })
            .collect();
        let idx = |n: &str| by_name[n].0;
        let deps: Vec<String> = [
            "OSMPSensorViewInConfig.base.lo",
            "OSMPSensorViewInConfig.base.hi",
            "OSMPSensorViewInConfig.size",
            "range_m",
            "fov_horizontal_rad",
            "fov_vertical_rad",
            "config",
            "mode",
        ]
        .iter()
        .map(|n| idx(n).to_string())
        .collect();
        assert_eq!(
            iu,
            [
                "OSMPSensorViewInConfigRequest.base.lo",
                "OSMPSensorViewInConfigRequest.base.hi",
                "OSMPSensorViewInConfigRequest.size"
            ]
            .iter()
            .map(|n| (idx(n), deps.join(" ")))
            .collect::<Vec<_>>()
        );
    }
}

#[test]
fn default_config_json_parses_back_to_the_defaults() {
    for kind in SensorKind::ALL {
        let json = sensors::default_config_json(kind);
        assert_eq!(
            SensorConfig::from_json_str(&json).unwrap(),
            SensorConfig::default_for(kind)
        );
    }
}

#[test]
fn scenario_source_follows_osmp_source_rules() {
    let desc = &sources::scenario::DESCRIPTOR;
    assert!(desc.is_source());
    assert_eq!(desc.name(), "scenario");
    let xml = desc.model_description();
    let doc = roxmltree::Document::parse(&xml).unwrap();
    let root = doc.root_element();
    let cs = root
        .children()
        .find(|n| n.has_tag_name("CoSimulation"))
        .unwrap();
    assert_eq!(cs.attribute("modelIdentifier"), Some("osiris_scenario"));
    let de = root
        .children()
        .find(|n| n.has_tag_name("DefaultExperiment"))
        .unwrap();
    let c = osiris_scenario::ScenarioConfig::default();
    assert_eq!(de.attribute("startTime"), Some("0"));
    assert_eq!(
        de.attribute("stopTime"),
        Some(c.duration_s.to_string().as_str())
    );
    assert_eq!(
        de.attribute("stepSize"),
        Some(c.step_s.to_string().as_str())
    );

    let svs: Vec<roxmltree::Node> = root
        .descendants()
        .filter(|n| n.has_tag_name("ScalarVariable"))
        .collect();
    assert_eq!(svs.len(), SOURCE_VARIABLES.len());
    // (name, type, VR, causality, variability, initial, start): the OSMP names of a SensorView
    // source; the output VRs are those of the official OSMPDummySource.
    /// (name, type, VR, causality, variability, initial, start).
    type Row<'a> = (
        &'a str,
        &'a str,
        &'a str,
        &'a str,
        &'a str,
        Option<&'a str>,
        Option<&'a str>,
    );
    let table: Vec<Row> = svs
        .iter()
        .map(|sv| {
            let ty = sv
                .children()
                .find(|n| n.is_element() && n.tag_name().name() != "Annotations")
                .unwrap();
            (
                sv.attribute("name").unwrap(),
                ty.tag_name().name(),
                sv.attribute("valueReference").unwrap(),
                sv.attribute("causality").unwrap(),
                sv.attribute("variability").unwrap(),
                sv.attribute("initial"),
                ty.attribute("start"),
            )
        })
        .collect();
    let out = |name, ty, vr| (name, ty, vr, "output", "discrete", Some("calculated"), None);
    let param = |name, vr, start| (name, "String", vr, "parameter", "fixed", None, Some(start));
    assert_eq!(
        table,
        [
            out("OSMPSensorViewOut.base.lo", "Integer", "0"),
            out("OSMPSensorViewOut.base.hi", "Integer", "1"),
            out("OSMPSensorViewOut.size", "Integer", "2"),
            out("valid", "Boolean", "0"),
            out("count", "Integer", "3"),
            param("scenario", "0", "scenario.json"),
            param("trace_path", "1", ""),
            param("sensor", "2", ""),
        ]
    );
    for (sv, role) in svs.iter().zip(["base.lo", "base.hi", "size"]) {
        let ann = sv
            .descendants()
            .find(|n| n.tag_name().name() == "osmp-binary-variable")
            .unwrap();
        assert_eq!(ann.attribute("name"), Some("OSMPSensorViewOut"));
        assert_eq!(ann.attribute("role"), Some(role));
        assert_eq!(
            ann.attribute("mime-type"),
            Some(osiris_proto::MIME_SENSOR_VIEW)
        );
    }
    assert!(
        !xml.contains("OSMPSensorViewIn") && !xml.contains("OSMPSensorDataOut"),
        "a source has no sensor variables"
    );
    assert_eq!(vr::source::integer::SENSOR_VIEW_OUT, [0, 1, 2]);

    // ModelStructure: the five outputs, all InitialUnknowns depending on the three parameters.
    let unknowns = |section: &str| -> Vec<(String, Option<String>)> {
        root.descendants()
            .find(|n| n.has_tag_name(section))
            .unwrap_or_else(|| panic!("{section} missing"))
            .children()
            .filter(|n| n.has_tag_name("Unknown"))
            .map(|n| {
                (
                    n.attribute("index").unwrap().to_string(),
                    n.attribute("dependencies").map(str::to_owned),
                )
            })
            .collect()
    };
    let five: Vec<String> = (1..=5).map(|i| i.to_string()).collect();
    assert_eq!(
        unknowns("Outputs"),
        five.iter().map(|i| (i.clone(), None)).collect::<Vec<_>>()
    );
    assert_eq!(
        unknowns("InitialUnknowns"),
        five.iter()
            .map(|i| (i.clone(), Some("6 7 8".to_owned())))
            .collect::<Vec<_>>()
    );
}
