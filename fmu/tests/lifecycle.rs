//! fmi2Instantiate checks, resource URIs, the state machine (illegal call orders), reset, logging,
//! unsupported functions and panics, all in-process through `osiris_fmu::abi`.

mod common;

use std::ffi::{CString, c_char};
use std::ptr;

use common::*;
use osiris_fmu::abi;
use osiris_fmu::ffi::*;
use osiris_fmu::variables::vr;
use osiris_fmu::{FmuDescriptor, sensors};
use osiris_models::{
    CommonConfig, ModelError, ModelMode, SensorConfig, SensorKind, SensorModel, StepInput,
    StepOutput,
};
use osiris_proto::{Message, osi3};

// -------------------------------------------------------------------------------------------------
// fmi2Instantiate

#[test]
fn guid_mismatch_returns_null_and_logs_the_reason() {
    let log = Inst::try_new(
        &sensors::radar::DESCRIPTOR,
        Opts {
            guid: Some("not-the-guid"),
            ..Default::default()
        },
    )
    .err()
    .expect("NULL");
    let recs = log.records();
    assert!(
        recs.iter()
            .any(|r| r.message.contains("GUID mismatch") && r.message.contains("not-the-guid")),
        "{recs:?}"
    );
    assert!(
        recs.iter()
            .any(|r| r.status == ERROR as i32 && r.category == "logStatusError")
    );
    assert_all_formats_are_percent_s(&recs);
    // Another FMU's GUID is a mismatch too.
    let camera_guid = sensors::camera::DESCRIPTOR.guid();
    assert!(
        Inst::try_new(
            &sensors::radar::DESCRIPTOR,
            Opts {
                guid: Some(camera_guid),
                ..Default::default()
            }
        )
        .is_err()
    );
}

#[test]
fn guid_mismatch_is_reported_even_with_logging_off() {
    let log = Inst::try_new(
        &sensors::radar::DESCRIPTOR,
        Opts {
            guid: Some("{00000000-0000-0000-0000-000000000000}"),
            logging_on: false,
            ..Default::default()
        },
    )
    .err()
    .expect("NULL");
    assert!(log.contains("GUID mismatch"));
}

#[test]
fn wrong_fmu_type_returns_null() {
    for t in [FMI2_MODEL_EXCHANGE, 2, -1, 77] {
        let log = Inst::try_new(
            &sensors::lidar::DESCRIPTOR,
            Opts {
                fmu_type: t,
                ..Default::default()
            },
        )
        .err()
        .expect("NULL");
        assert!(log.contains("fmuType"), "{:?}", log.records());
    }
}

#[test]
fn null_or_empty_instance_name_returns_null() {
    let log = Inst::try_new(
        &sensors::camera::DESCRIPTOR,
        Opts {
            name: None,
            ..Default::default()
        },
    )
    .err()
    .unwrap();
    assert!(log.contains("instanceName is NULL"));
    let log = Inst::try_new(
        &sensors::camera::DESCRIPTOR,
        Opts {
            name: Some(""),
            ..Default::default()
        },
    )
    .err()
    .unwrap();
    assert!(log.contains("instanceName is empty"));
}

#[test]
fn null_callbacks_null_guid_null_logger() {
    let desc = &sensors::radar::DESCRIPTOR;
    let name = CString::new("x").unwrap();
    let guid = CString::new(desc.guid()).unwrap();
    let c = unsafe {
        abi::instantiate(
            desc,
            name.as_ptr(),
            FMI2_CO_SIMULATION,
            guid.as_ptr(),
            ptr::null(),
            ptr::null(),
            0,
            1,
        )
    };
    assert!(c.is_null(), "NULL callbacks struct");
    let callbacks = Fmi2CallbackFunctions::default();
    let c = unsafe {
        abi::instantiate(
            desc,
            name.as_ptr(),
            FMI2_CO_SIMULATION,
            ptr::null(),
            ptr::null(),
            &callbacks,
            0,
            1,
        )
    };
    assert!(c.is_null(), "NULL GUID");
    // A NULL logger is fine: the instance works silently, errors included.
    let i = Inst::try_new(
        desc,
        Opts {
            null_logger: true,
            ..Default::default()
        },
    )
    .ok()
    .unwrap();
    i.init();
    assert_eq!(i.step(0.0, 0.05), OK);
    assert_eq!(i.terminate(), OK);
    assert_eq!(i.terminate(), ERROR);
    assert!(i.records().is_empty());
}

#[test]
fn instance_name_and_callbacks_are_copied() {
    // Inst::try_new drops its name, GUID, location strings and the callbacks struct right after
    // fmi2Instantiate; the instance must still log with its name.
    let i = Inst::try_new(
        &sensors::radar::DESCRIPTOR,
        Opts {
            name: Some("front radar"),
            ..Default::default()
        },
    )
    .ok()
    .unwrap();
    assert_eq!(i.step(0.0, 0.1), ERROR);
    let recs = i.records();
    assert!(
        recs.iter()
            .any(|r| r.instance_name == "front radar" && r.message.contains("fmi2DoStep")),
        "{recs:?}"
    );
}

// -------------------------------------------------------------------------------------------------
// Resource locations

#[test]
fn resource_uri_forms() {
    let dir = tempfile::tempdir().unwrap();
    let spaced = dir.path().join("my resources");
    std::fs::create_dir(&spaced).unwrap();
    let p = spaced.to_str().unwrap();
    let enc = p.replace(' ', "%20");
    for uri in [
        format!("file://{enc}"),
        format!("file://{enc}/"),
        format!("file:{enc}"),
        format!("file:{enc}/"),
        format!("file://localhost{enc}"),
        format!("file://localhost{enc}/"),
        dir_uri(&spaced),
        p.to_string(),
    ] {
        let got = abi::resource_dir_from_uri(&uri).unwrap_or_else(|e| panic!("{uri}: {e}"));
        assert_eq!(
            got.components().collect::<Vec<_>>(),
            spaced.components().collect::<Vec<_>>(),
            "{uri}"
        );
    }
    for bad in [
        "http://example.com/resources",
        "file://otherhost/x",
        "relative/path",
        "::::",
    ] {
        assert!(abi::resource_dir_from_uri(bad).is_err(), "{bad}");
    }
}

/// The resources directory each URI form names is really used: its config.json (with a
/// distinctive range) shows up in the ConfigRequest.
#[test]
fn resource_uri_forms_reach_the_config_file() {
    let dir = tempfile::tempdir().unwrap();
    let res = dir.path().join("res dir");
    std::fs::create_dir(&res).unwrap();
    let mut cfg = SensorConfig::default_for(SensorKind::Radar);
    cfg.range_m = 123.5;
    std::fs::write(
        res.join("config.json"),
        serde_json::to_string(&cfg).unwrap(),
    )
    .unwrap();
    let enc = res.to_str().unwrap().replace(' ', "%20");
    for uri in [
        format!("file://{enc}"),
        format!("file:{enc}/"),
        format!("file://localhost{enc}/"),
    ] {
        let i = Inst::try_new(
            &sensors::radar::DESCRIPTOR,
            Opts {
                resources: Some(Some(uri.clone())),
                ..Default::default()
            },
        )
        .ok()
        .unwrap();
        assert_eq!(i.setup(), OK);
        assert_eq!(i.enter(), OK);
        let (s, t) = i.get_ints(&vr::integer::CONFIG_REQUEST);
        assert_eq!(s, OK, "{uri}: {:?}", i.records());
        let req = osi3::SensorViewConfiguration::decode(
            read_triple([t[0], t[1], t[2]]).unwrap().as_slice(),
        )
        .unwrap();
        assert_eq!(req.range, Some(123.5), "{uri}");
    }
}

#[test]
fn null_resource_location() {
    // `config` left at its start value: built-in defaults, with a warning.
    let i = Inst::try_new(
        &sensors::radar::DESCRIPTOR,
        Opts {
            resources: Some(None),
            ..Default::default()
        },
    )
    .ok()
    .unwrap();
    assert_eq!(i.setup(), OK);
    assert_eq!(i.enter(), OK);
    assert_eq!(i.exit(), WARNING);
    assert!(i.log.contains("no resource location"));
    let bytes = sample_view_bytes(0.0, 5);
    i.set_input(&bytes);
    assert_eq!(i.step(0.0, 0.05), OK);
    assert!(i.get_valid().1);

    // `config` explicitly naming a relative file: error at the call that needs it.
    let i = Inst::try_new(
        &sensors::radar::DESCRIPTOR,
        Opts {
            resources: Some(None),
            ..Default::default()
        },
    )
    .ok()
    .unwrap();
    assert_eq!(i.set_strings(&[vr::string::CONFIG], &["config.json"]), OK);
    assert_eq!(i.enter(), OK);
    assert_eq!(i.exit(), ERROR);
    assert!(i.log.contains("got no resource location"));
    // `config` = "" needs no resources.
    let i = Inst::try_new(
        &sensors::radar::DESCRIPTOR,
        Opts {
            resources: Some(None),
            ..Default::default()
        },
    )
    .ok()
    .unwrap();
    assert_eq!(i.set_strings(&[vr::string::CONFIG], &[""]), OK);
    i.init();
}

#[test]
fn unusable_resource_location_is_a_warning_not_a_failure() {
    let i = Inst::try_new(
        &sensors::radar::DESCRIPTOR,
        Opts {
            resources: Some(Some("http://example.com/r".into())),
            ..Default::default()
        },
    )
    .ok()
    .unwrap();
    assert!(i.log.contains("unsupported URI scheme"));
    assert_eq!(i.set_strings(&[vr::string::CONFIG], &[""]), OK);
    i.init();
}

// -------------------------------------------------------------------------------------------------
// Configuration

#[test]
fn config_inline_json_file_and_errors() {
    let kind = SensorKind::Camera;
    let desc = &sensors::camera::DESCRIPTOR;
    let mut cfg = SensorConfig::default_for(kind);
    cfg.range_m = 77.0;
    let json = serde_json::to_string(&cfg).unwrap();

    let request_range = |i: &Inst| {
        let (s, t) = i.get_ints(&vr::integer::CONFIG_REQUEST);
        assert_eq!(s, OK, "{:?}", i.records());
        osi3::SensorViewConfiguration::decode(read_triple([t[0], t[1], t[2]]).unwrap().as_slice())
            .unwrap()
            .range
    };

    // Inline JSON (leading whitespace allowed).
    let i = Inst::new(desc);
    assert_eq!(
        i.set_strings(&[vr::string::CONFIG], &[&format!("  \n{json}")]),
        OK
    );
    assert_eq!(i.enter(), OK);
    assert_eq!(request_range(&i), Some(77.0));

    // Absolute path.
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("cam.json");
    std::fs::write(&path, &json).unwrap();
    let i = Inst::new(desc);
    assert_eq!(
        i.set_strings(&[vr::string::CONFIG], &[path.to_str().unwrap()]),
        OK
    );
    assert_eq!(i.enter(), OK);
    assert_eq!(request_range(&i), Some(77.0));

    // A Real parameter overrides its key only when set.
    let i = Inst::new(desc);
    assert_eq!(i.set_strings(&[vr::string::CONFIG], &[&json]), OK);
    assert_eq!(i.set_reals(&[vr::real::RANGE_M], &[55.0]), OK);
    assert_eq!(i.enter(), OK);
    assert_eq!(request_range(&i), Some(55.0));
    // Changing a parameter in initialization mode rebuilds the model and the request.
    assert_eq!(i.set_reals(&[vr::real::RANGE_M], &[44.0]), OK);
    assert_eq!(request_range(&i), Some(44.0));
    assert_eq!(i.exit(), OK);

    // Broken JSON: error with line and column, from the call that needs the model.
    let i = Inst::new(desc);
    assert_eq!(
        i.set_strings(
            &[vr::string::CONFIG],
            &["{\n  \"kind\": \"camera\",\n  \"range_m\": oops\n}"]
        ),
        OK
    );
    assert_eq!(i.enter(), OK);
    assert_eq!(i.get_ints(&vr::integer::CONFIG_REQUEST).0, ERROR);
    let recs = i.records();
    assert!(
        recs.iter()
            .any(|r| r.message.contains("line 3") && r.message.contains("column")),
        "{recs:?}"
    );
    // The instance is now in the error state; reset recovers it.
    assert_eq!(i.exit(), ERROR);
    assert_eq!(i.reset(), OK);
    i.init();

    // Wrong kind.
    let i = Inst::new(desc);
    let radar = serde_json::to_string(&SensorConfig::default_for(SensorKind::Radar)).unwrap();
    assert_eq!(i.set_strings(&[vr::string::CONFIG], &[&radar]), OK);
    assert_eq!(i.enter(), OK);
    assert_eq!(i.exit(), ERROR);
    assert!(
        i.log
            .contains("declares kind `radar`, but this is the camera FMU"),
        "{:?}",
        i.records()
    );

    // Missing file.
    let i = Inst::new(desc);
    assert_eq!(i.set_strings(&[vr::string::CONFIG], &["nope.json"]), OK);
    assert_eq!(i.enter(), OK);
    assert_eq!(i.exit(), ERROR);
    assert!(i.log.contains("cannot read config file"));

    // Invalid value through a parameter.
    let i = Inst::new(desc);
    assert_eq!(i.set_reals(&[vr::real::FOV_VERTICAL_RAD], &[-1.0]), OK);
    assert_eq!(i.enter(), OK);
    assert_eq!(i.exit(), ERROR);
    assert!(i.log.contains("fov_vertical_rad"));

    // An unknown mode.
    let i = Inst::new(desc);
    assert_eq!(i.set_strings(&[vr::string::MODE], &["fancy"]), OK);
    assert_eq!(i.enter(), OK);
    assert_eq!(i.exit(), ERROR);
    assert!(i.log.contains("unknown model mode"), "{:?}", i.records());
}

#[test]
fn parameters_read_back_set_or_start_values() {
    let i = Inst::radar();
    let defaults = SensorConfig::default_for(SensorKind::Radar);
    assert_eq!(i.set_reals(&[vr::real::FOV_HORIZONTAL_RAD], &[1.0]), OK);
    assert_eq!(i.set_strings(&[vr::string::MODE], &["ideal"]), OK);
    assert_eq!(i.enter(), OK);
    let (s, v) = i.get_reals(&[0, 1, 2]);
    assert_eq!(s, OK);
    assert_eq!(v, vec![defaults.range_m, 1.0, defaults.fov_vertical_rad]);
    let (s, v) = i.get_strings(&[0, 1, 0]);
    assert_eq!(s, OK);
    assert_eq!(v, vec!["config.json", "ideal", "config.json"]);
    let (s, v) = i.get_ints(&[9, 10, 11, 15]);
    assert_eq!(s, OK);
    assert_eq!(v, vec![0, 0, 0, 0]);
    assert_eq!(i.get_valid(), (OK, false));
}

// -------------------------------------------------------------------------------------------------
// State machine

/// Each closure is an illegal call in the given state: it must return fmi2Error, leave the
/// instance usable (the legal continuation works) and the instance must free cleanly.
#[test]
fn illegal_call_orders_return_error() {
    let bytes = sample_view_bytes(0.0, 1);
    type Call = fn(&Inst) -> Fmi2Status;
    let in_instantiated: Vec<(&str, Call)> = vec![
        ("DoStep", |i| i.step(0.0, 0.1)),
        ("ExitInit", |i| i.exit()),
        ("Terminate", |i| i.terminate()),
        ("GetInteger", |i| i.get_ints(&[3]).0),
        ("GetInteger request", |i| i.get_ints(&[6]).0),
        ("GetReal", |i| i.get_reals(&[0]).0),
        ("GetBoolean", |i| i.get_valid().0),
        ("GetString", |i| i.get_strings(&[0]).0),
        ("GetStatus", |i| {
            let mut s = OK;
            unsafe { abi::get_status(i.c, FMI2_DO_STEP_STATUS, &mut s) }
        }),
        ("GetRealStatus", |i| {
            let mut t = 0.0;
            unsafe { abi::get_real_status(i.c, FMI2_LAST_SUCCESSFUL_TIME, &mut t) }
        }),
        ("SetOutput", |i| i.set_ints(&[3], &[1])),
        ("SetRequest", |i| i.set_ints(&[6], &[1])),
        ("SetBoolean", |i| unsafe {
            abi::set_boolean(i.c, &0, 1, &1)
        }),
        ("SetUnknownVR", |i| i.set_ints(&[16], &[1])),
        ("SetUnknownRealVR", |i| i.set_reals(&[3], &[1.0])),
        ("SetUnknownStringVR", |i| i.set_strings(&[2], &["x"])),
        ("NullString", |i| {
            let v: [Fmi2String; 1] = [ptr::null()];
            unsafe { abi::set_string(i.c, &vr::string::MODE, 1, v.as_ptr()) }
        }),
    ];
    for (what, call) in in_instantiated {
        let i = Inst::radar();
        assert_eq!(call(&i), ERROR, "{what} in instantiated");
        let recs = i.records();
        assert!(
            recs.iter().any(|r| r.status == ERROR as i32),
            "{what}: {recs:?}"
        );
        // Still usable.
        i.init();
        i.set_input(&bytes);
        assert_eq!(i.step(0.0, 0.05), OK, "{what}");
    }

    let in_init_mode: Vec<(&str, Call)> = vec![
        ("DoStep", |i| i.step(0.0, 0.1)),
        ("EnterInit", |i| i.enter()),
        ("SetupExperiment", |i| i.setup()),
        ("Terminate", |i| i.terminate()),
        ("SetOutputCount", |i| i.set_ints(&[15], &[3])),
        ("GetUnknownVR", |i| i.get_ints(&[99]).0),
        ("GetUnknownRealVR", |i| i.get_reals(&[5]).0),
        ("GetUnknownBoolVR", |i| {
            let mut v = 0;
            unsafe { abi::get_boolean(i.c, &1, 1, &mut v) }
        }),
    ];
    for (what, call) in in_init_mode {
        let i = Inst::radar();
        assert_eq!(i.setup(), OK);
        assert_eq!(i.enter(), OK);
        assert_eq!(call(&i), ERROR, "{what} in initializationMode");
        assert_eq!(i.exit(), OK, "{what}");
        i.set_input(&bytes);
        assert_eq!(i.step(0.0, 0.05), OK, "{what}");
    }

    let in_slave_initialized: Vec<(&str, Call)> = vec![
        ("EnterInit", |i| i.enter()),
        ("ExitInit", |i| i.exit()),
        ("SetupExperiment", |i| i.setup()),
        ("SetFixedReal", |i| {
            i.set_reals(&[vr::real::RANGE_M], &[10.0])
        }),
        ("SetFixedString", |i| {
            i.set_strings(&[vr::string::CONFIG], &[""])
        }),
        ("SetConfigTriple", |i| {
            i.set_ints(&vr::integer::CONFIG, &[0, 0, 0])
        }),
        ("SetMixedInputAndFixed", |i| i.set_ints(&[0, 9], &[0, 0])),
        ("CancelStep", |i| unsafe { abi::cancel_step(i.c) }),
        ("ZeroStep", |i| i.step(0.0, 0.0)),
        ("NegativeStep", |i| i.step(0.0, -0.1)),
        ("NaNStep", |i| i.step(f64::NAN, 0.1)),
        ("InfStep", |i| i.step(0.0, f64::INFINITY)),
        ("GetStatusBadKind", |i| {
            let mut s = OK;
            unsafe { abi::get_status(i.c, FMI2_LAST_SUCCESSFUL_TIME, &mut s) }
        }),
        ("GetStatusNullValue", |i| unsafe {
            abi::get_status(i.c, FMI2_DO_STEP_STATUS, ptr::null_mut())
        }),
        ("GetRealStatusBadKind", |i| {
            let mut t = 0.0;
            unsafe { abi::get_real_status(i.c, FMI2_TERMINATED, &mut t) }
        }),
        ("GetBooleanStatusBadKind", |i| {
            let mut b = 0;
            unsafe { abi::get_boolean_status(i.c, FMI2_DO_STEP_STATUS, &mut b) }
        }),
        ("GetStringStatusBadKind", |i| {
            let mut s: Fmi2String = ptr::null();
            unsafe { abi::get_string_status(i.c, FMI2_TERMINATED, &mut s) }
        }),
        ("NullVrArray", |i| {
            let mut v = [0; 2];
            unsafe { abi::get_integer(i.c, ptr::null(), 2, v.as_mut_ptr()) }
        }),
        ("NullValueArray", |i| unsafe {
            abi::get_integer(i.c, [3u32, 4].as_ptr(), 2, ptr::null_mut())
        }),
        ("NullSetArray", |i| unsafe {
            abi::set_integer(i.c, [0u32].as_ptr(), 1, ptr::null())
        }),
        ("NullCategories", |i| unsafe {
            abi::set_debug_logging(i.c, FMI2_TRUE, 2, ptr::null())
        }),
    ];
    for (what, call) in in_slave_initialized {
        let i = Inst::radar_initialized();
        assert_eq!(call(&i), ERROR, "{what} in slaveInitialized");
        i.set_input(&bytes);
        assert_eq!(i.step(0.0, 0.05), OK, "{what}: {:?}", i.records());
        assert_eq!(i.terminate(), OK, "{what}");
    }

    let in_terminated: Vec<(&str, Call)> = vec![
        ("DoStep", |i| i.step(0.0, 0.1)),
        ("Terminate", |i| i.terminate()),
        ("EnterInit", |i| i.enter()),
        ("ExitInit", |i| i.exit()),
        ("SetupExperiment", |i| i.setup()),
        ("SetInput", |i| i.set_ints(&[0, 1, 2], &[0, 0, 0])),
        ("SetReal", |i| i.set_reals(&[0], &[1.0])),
    ];
    for (what, call) in in_terminated {
        let i = Inst::radar_initialized();
        assert_eq!(i.terminate(), OK);
        assert_eq!(call(&i), ERROR, "{what} in terminated");
        // Gets and reset stay legal.
        assert_eq!(i.get_ints(&[3, 4, 5]).0, OK);
        assert_eq!(i.reset(), OK);
        i.init();
    }
}

#[test]
fn error_messages_name_the_function_and_the_state() {
    let i = Inst::radar();
    assert_eq!(i.step(0.0, 0.1), ERROR);
    assert_eq!(i.set_ints(&[4], &[0]), ERROR);
    i.init();
    assert_eq!(i.set_reals(&[0], &[1.0]), ERROR);
    let msgs: Vec<String> = i
        .records()
        .into_iter()
        .filter(|r| r.status == ERROR as i32)
        .map(|r| r.message)
        .collect();
    assert!(
        msgs[0].contains("fmi2DoStep") && msgs[0].contains("state instantiated"),
        "{msgs:?}"
    );
    assert!(
        msgs[1].contains("fmi2SetInteger") && msgs[1].contains("OSMPSensorDataOut.base.hi"),
        "{msgs:?}"
    );
    assert!(
        msgs[2].contains("fmi2SetReal")
            && msgs[2].contains("range_m")
            && msgs[2].contains("slaveInitialized"),
        "{msgs:?}"
    );
}

#[test]
fn a_rejected_set_changes_nothing() {
    let i = Inst::radar();
    // One bad VR in the batch: nothing is applied.
    assert_eq!(i.set_ints(&[9, 5], &[1234, 1]), ERROR);
    assert_eq!(i.enter(), OK);
    assert_eq!(i.get_ints(&[9]).1, vec![0]);
}

#[test]
fn null_instance_and_free_null() {
    let c = ptr::null_mut();
    unsafe {
        abi::free_instance(c);
        assert_eq!(abi::setup_experiment(c, 0, 0.0, 0.0, 0, 0.0), ERROR);
        assert_eq!(abi::enter_initialization_mode(c), ERROR);
        assert_eq!(abi::exit_initialization_mode(c), ERROR);
        assert_eq!(abi::terminate(c), ERROR);
        assert_eq!(abi::reset(c), ERROR);
        assert_eq!(abi::do_step(c, 0.0, 0.1, 1), ERROR);
        assert_eq!(abi::set_debug_logging(c, 1, 0, ptr::null()), ERROR);
        let mut v = 0;
        assert_eq!(abi::get_integer(c, &0, 1, &mut v), ERROR);
        assert_eq!(abi::set_integer(c, &0, 1, &v), ERROR);
        assert_eq!(abi::get_fmu_state(c, ptr::null_mut()), ERROR);
        assert_eq!(abi::cancel_step(c), ERROR);
    }
    let v = unsafe { std::ffi::CStr::from_ptr(abi::get_version()) };
    assert_eq!(v.to_str(), Ok("2.0"));
    let p = unsafe { std::ffi::CStr::from_ptr(abi::get_types_platform()) };
    assert_eq!(p.to_str(), Ok("default"));
}

#[test]
fn zero_length_arrays_are_ok_with_null_pointers() {
    let i = Inst::radar_initialized();
    unsafe {
        assert_eq!(abi::get_integer(i.c, ptr::null(), 0, ptr::null_mut()), OK);
        assert_eq!(abi::set_integer(i.c, ptr::null(), 0, ptr::null()), OK);
        assert_eq!(abi::get_real(i.c, ptr::null(), 0, ptr::null_mut()), OK);
        assert_eq!(abi::get_string(i.c, ptr::null(), 0, ptr::null_mut()), OK);
    }
}

#[test]
fn unsupported_functions_return_error_with_a_log_line() {
    let i = Inst::radar_initialized();
    let mut state: Fmi2FmuState = ptr::null_mut();
    let mut size = 0usize;
    let mut buf = [0 as c_char; 8];
    let mut d = [0.0f64; 1];
    unsafe {
        assert_eq!(abi::get_fmu_state(i.c, &mut state), ERROR);
        assert!(state.is_null());
        assert_eq!(abi::set_fmu_state(i.c, 8 as Fmi2FmuState), ERROR);
        assert_eq!(abi::serialized_fmu_state_size(i.c, state, &mut size), ERROR);
        assert_eq!(
            abi::serialize_fmu_state(i.c, state, buf.as_mut_ptr(), buf.len()),
            ERROR
        );
        assert_eq!(
            abi::deserialize_fmu_state(i.c, buf.as_ptr(), buf.len(), &mut state),
            ERROR
        );
        assert_eq!(
            abi::get_directional_derivative(i.c, &0, 1, &0, 1, d.as_ptr(), d.as_mut_ptr()),
            ERROR
        );
        assert_eq!(
            abi::set_real_input_derivatives(i.c, &0, 1, &1, d.as_ptr()),
            ERROR
        );
        assert_eq!(
            abi::get_real_output_derivatives(i.c, &0, 1, &1, d.as_mut_ptr()),
            ERROR
        );
        // Freeing a NULL state is a no-op by the standard.
        assert_eq!(abi::free_fmu_state(i.c, &mut state), OK);
        assert_eq!(abi::free_fmu_state(i.c, ptr::null_mut()), OK);
        let mut bogus = 8 as Fmi2FmuState;
        assert_eq!(abi::free_fmu_state(i.c, &mut bogus), ERROR);
    }
    let recs = i.records();
    for f in [
        "fmi2GetFMUstate",
        "fmi2SetFMUstate",
        "fmi2SerializedFMUstateSize",
        "fmi2SerializeFMUstate",
        "fmi2DeSerializeFMUstate",
        "fmi2GetDirectionalDerivative",
        "fmi2SetRealInputDerivatives",
        "fmi2GetRealOutputDerivatives",
        "fmi2FreeFMUstate",
    ] {
        assert!(
            recs.iter()
                .any(|r| r.message.starts_with(f) && r.message.contains("not supported")),
            "{f}"
        );
    }
    // None of them broke the instance.
    let bytes = sample_view_bytes(0.0, 1);
    i.set_input(&bytes);
    assert_eq!(i.step(0.0, 0.05), OK);
}

#[test]
fn status_functions() {
    let i = Inst::radar_initialized();
    let bytes = sample_view_bytes(0.0, 1);
    i.set_input(&bytes);
    assert_eq!(i.step(0.0, 0.05), OK);
    assert_eq!(i.step(0.05, 0.05), OK);
    unsafe {
        let mut s = OK;
        assert_eq!(abi::get_status(i.c, FMI2_DO_STEP_STATUS, &mut s), DISCARD);
        let mut t = 0.0;
        assert_eq!(
            abi::get_real_status(i.c, FMI2_LAST_SUCCESSFUL_TIME, &mut t),
            OK
        );
        assert!((t - 0.1).abs() < 1e-12);
        let mut b = 7;
        assert_eq!(abi::get_boolean_status(i.c, FMI2_TERMINATED, &mut b), OK);
        assert_eq!(b, FMI2_FALSE);
        let mut n = 0;
        assert_eq!(
            abi::get_integer_status(i.c, FMI2_DO_STEP_STATUS, &mut n),
            DISCARD
        );
        let mut st: Fmi2String = ptr::null();
        assert_eq!(
            abi::get_string_status(i.c, FMI2_PENDING_STATUS, &mut st),
            DISCARD
        );
    }
}

#[test]
fn stepping_past_the_stop_time_is_an_error() {
    let i = Inst::radar();
    assert_eq!(
        unsafe { abi::setup_experiment(i.c, FMI2_TRUE, 1e-6, 0.0, FMI2_TRUE, 0.1) },
        OK
    );
    assert_eq!(i.enter(), OK);
    assert_eq!(i.exit(), OK);
    assert_eq!(i.step(0.0, 0.05), OK);
    // FMPy-style jitter is fine.
    assert_eq!(i.step(0.05, 0.05000000000000002), OK);
    assert_eq!(i.step(0.1, 0.05), ERROR);
    // Setup with stop < start is rejected.
    let j = Inst::radar();
    assert_eq!(
        unsafe { abi::setup_experiment(j.c, FMI2_FALSE, 0.0, 1.0, FMI2_TRUE, 0.5) },
        ERROR
    );
}

#[test]
fn failure_enters_the_error_state_and_reset_recovers() {
    // An invalid parameter: building the model fails at fmi2ExitInitializationMode.
    let i = Inst::new(&osiris_fmu::sensors::camera::DESCRIPTOR);
    assert_eq!(i.set_reals(&[vr::real::FOV_VERTICAL_RAD], &[-1.0]), OK);
    assert_eq!(i.enter(), OK);
    assert_eq!(i.exit(), ERROR);
    // error state: DoStep, ExitInit, Terminate rejected; Get, SetDebugLogging, Reset allowed.
    assert_eq!(i.step(0.0, 0.05), ERROR);
    assert_eq!(i.exit(), ERROR);
    assert_eq!(i.terminate(), ERROR);
    assert_eq!(i.get_ints(&[3, 4, 5]).0, OK);
    assert_eq!(
        unsafe { abi::set_debug_logging(i.c, FMI2_TRUE, 0, ptr::null()) },
        OK
    );
    assert_eq!(i.reset(), OK);
    // After reset the parameters are back at their start values; the ideal mode keeps the step
    // cheap.
    assert_eq!(i.set_strings(&[vr::string::MODE], &["ideal"]), OK);
    i.init();
    let bytes = sample_view_bytes(0.0, 1);
    i.set_input(&bytes);
    assert_eq!(i.step(0.0, 0.05), OK);
}

#[test]
fn reset_restores_the_state_after_instantiate() {
    let i = Inst::radar();
    let defaults = SensorConfig::default_for(SensorKind::Radar);
    assert_eq!(i.set_reals(&[vr::real::RANGE_M], &[12.0]), OK);
    assert_eq!(
        i.set_strings(&[vr::string::CONFIG, vr::string::MODE], &["", "ideal"]),
        OK
    );
    i.init();
    let bytes = sample_view_bytes(0.0, 9);
    i.set_input(&bytes);
    assert_eq!(i.step(0.0, 0.05), OK);
    assert_ne!(i.triple(vr::integer::SENSOR_DATA_OUT), [0, 0, 0]);
    assert!(i.get_valid().1);
    let counter_before = i.perception().unwrap().cycle_counter;
    assert_eq!(counter_before, Some(0));

    for state in ["slaveInitialized", "terminated"] {
        if state == "terminated" {
            assert_eq!(i.terminate(), OK);
        }
        assert_eq!(i.reset(), OK, "{state}");
        // Get is illegal in instantiated again.
        assert_eq!(i.get_ints(&[3]).0, ERROR);
        assert_eq!(i.enter(), OK);
        assert_eq!(
            i.get_ints(&[0, 1, 2, 3, 4, 5, 9, 10, 11, 12, 13, 14, 15]).1,
            vec![0; 13]
        );
        assert!(!i.get_valid().1);
        assert_eq!(i.get_reals(&[0]).1, vec![defaults.range_m]);
        assert_eq!(
            i.get_strings(&[0, 1]).1,
            vec!["config.json", defaults.mode.name()]
        );
        // The rebuilt model uses the start values (the resources' config.json).
        let (_, t) = i.get_ints(&vr::integer::CONFIG_REQUEST);
        let req = osi3::SensorViewConfiguration::decode(
            read_triple([t[0], t[1], t[2]]).unwrap().as_slice(),
        )
        .unwrap();
        assert_eq!(req.range, Some(defaults.range_m));
        assert_eq!(i.exit(), OK);
        i.set_input(&bytes);
        assert_eq!(i.step(0.0, 0.05), OK);
        assert_eq!(
            i.perception().unwrap().cycle_counter,
            Some(0),
            "cycle counter restarts"
        );
    }
    // Reset from instantiated and from initializationMode is legal too.
    assert_eq!(i.reset(), OK);
    assert_eq!(i.reset(), OK);
    assert_eq!(i.enter(), OK);
    assert_eq!(i.reset(), OK);
}

// -------------------------------------------------------------------------------------------------
// Logging

#[test]
fn logger_always_gets_percent_s_and_the_text_verbatim() {
    let i = Inst::radar();
    // '%' in text must not be interpreted; '#' is escaped as '##' (FMI message syntax).
    assert_eq!(
        i.set_strings(&[vr::string::CONFIG], &["no%s such%d #r0# file.json"]),
        OK
    );
    assert_eq!(i.enter(), OK);
    assert_eq!(i.exit(), ERROR);
    let recs = i.records();
    assert_all_formats_are_percent_s(&recs);
    assert!(
        recs.iter()
            .any(|r| r.message.contains("no%s such%d ##r0## file.json")),
        "{recs:?}"
    );
    assert!(
        recs.iter()
            .any(|r| r.category == "FMI" && r.status == OK as i32),
        "debug messages with loggingOn"
    );
    assert!(recs.iter().all(|r| r.instance_name == "test"));
}

#[test]
fn logging_categories() {
    // loggingOn = false: no debug messages, errors still reported.
    let i = Inst::try_new(
        &sensors::radar::DESCRIPTOR,
        Opts {
            logging_on: false,
            ..Default::default()
        },
    )
    .ok()
    .unwrap();
    i.init();
    assert_eq!(i.step(0.0, -1.0), ERROR);
    let recs = i.records();
    assert!(recs.iter().all(|r| r.status != OK as i32), "{recs:?}");
    assert!(
        recs.iter()
            .any(|r| r.status == ERROR as i32 && r.category == "logStatusError")
    );

    // Only OSMP enabled: OSMP debug messages yes, FMI debug messages and errors no.
    let i = Inst::radar();
    let cats = [CString::new("OSMP").unwrap()];
    let ptrs: Vec<Fmi2String> = cats.iter().map(|c| c.as_ptr()).collect();
    assert_eq!(
        unsafe { abi::set_debug_logging(i.c, FMI2_TRUE, 1, ptrs.as_ptr()) },
        OK
    );
    i.log.take();
    i.init();
    assert_eq!(i.step(0.0, 0.05), OK); // no input: an OSMP debug message
    assert_eq!(i.step(0.0, -1.0), ERROR); // an FMI error: not enabled
    let recs = i.records();
    assert!(!recs.is_empty());
    assert!(
        recs.iter()
            .all(|r| r.category == "OSMP" && r.status == OK as i32),
        "{recs:?}"
    );

    // Unknown category: warning; the known ones are applied.
    let cats = ["logStatusError", "logStatusWarning", "bogus"].map(|c| CString::new(c).unwrap());
    let ptrs: Vec<Fmi2String> = cats.iter().map(|c| c.as_ptr()).collect();
    i.log.take();
    assert_eq!(
        unsafe { abi::set_debug_logging(i.c, FMI2_TRUE, 3, ptrs.as_ptr()) },
        WARNING
    );
    assert!(i.log.contains("`bogus`"), "{:?}", i.records());
    i.log.take();
    assert_eq!(i.step(0.05, 0.05), OK);
    assert_eq!(i.step(0.0, -1.0), ERROR);
    let recs = i.records();
    assert_eq!(recs.len(), 1, "{recs:?}");
    assert_eq!(recs[0].category, "logStatusError");

    // loggingOn = false via SetDebugLogging, then all back on with nCategories = 0.
    assert_eq!(
        unsafe { abi::set_debug_logging(i.c, FMI2_FALSE, 0, ptr::null()) },
        OK
    );
    i.log.take();
    assert_eq!(i.step(0.1, 0.05), OK);
    assert!(i.records().is_empty());
    assert_eq!(
        unsafe { abi::set_debug_logging(i.c, FMI2_TRUE, 0, ptr::null()) },
        OK
    );
    assert_eq!(i.step(0.15, 0.05), OK);
    assert!(!i.records().is_empty());
    assert_all_formats_are_percent_s(&i.records());
}

// -------------------------------------------------------------------------------------------------
// Model behaviour through test descriptors: panics, model errors, notes, metadata.

#[derive(Clone, Copy, PartialEq)]
enum Behaviour {
    PanicInStep,
    PanicInBuild,
    InputError,
    ConfigErrorInStep,
    Notes,
    Fill,
}

struct TestModel {
    config: CommonConfig,
    behaviour: Behaviour,
}

impl SensorModel for TestModel {
    fn kind(&self) -> SensorKind {
        self.config.kind
    }
    fn mode(&self) -> ModelMode {
        ModelMode::Ideal
    }
    fn config(&self) -> &CommonConfig {
        &self.config
    }
    fn view_configuration_request(&self) -> osi3::SensorViewConfiguration {
        osi3::SensorViewConfiguration::default()
    }
    fn apply_view_configuration(
        &mut self,
        g: &osi3::SensorViewConfiguration,
    ) -> Result<Vec<String>, ModelError> {
        if self.behaviour == Behaviour::Notes {
            if g.range == Some(-1.0) {
                return Err(ModelError::Config("negative range granted".into()));
            }
            return Ok(vec![format!("granted range {:?}", g.range)]);
        }
        Ok(vec![])
    }
    fn step(&mut self, input: &StepInput<'_>, out: &mut StepOutput) -> Result<(), ModelError> {
        match self.behaviour {
            Behaviour::PanicInStep => panic!("test model panics at t = {}", input.time_s),
            Behaviour::InputError => return Err(ModelError::Input("no host vehicle".into())),
            Behaviour::ConfigErrorInStep => {
                return Err(ModelError::Config("nothing".into()));
            }
            _ => {}
        }
        *out = StepOutput::default();
        if self.behaviour == Behaviour::Fill {
            out.sensor_data.moving_object = vec![Default::default(); 2];
            out.sensor_data.stationary_object = vec![Default::default(); 1];
            out.sensor_data.feature_data = Some(osi3::FeatureData {
                radar_sensor: vec![osi3::RadarDetectionData::default()],
                lidar_sensor: vec![osi3::LidarDetectionData {
                    header: Some(osi3::SensorDetectionHeader {
                        mounting_position: Some(osi3::MountingPosition::default()),
                        ..Default::default()
                    }),
                    ..Default::default()
                }],
                ..Default::default()
            });
            // A model-set field the shell must not overwrite.
            out.perception.model_mode = Some("custom".into());
        }
        Ok(())
    }
    fn reset(&mut self) {}
}

macro_rules! test_descriptor {
    ($name:ident, $builder:ident, $behaviour:expr) => {
        fn $builder(config: SensorConfig) -> Result<Box<dyn SensorModel>, ModelError> {
            if $behaviour == Behaviour::PanicInBuild {
                panic!("test model panics while building");
            }
            Ok(Box::new(TestModel {
                config: config.common(),
                behaviour: $behaviour,
            }))
        }
        static $name: FmuDescriptor = FmuDescriptor::with_builder(
            SensorKind::Radar,
            "osiris radar",
            "osiris_radar",
            "test model",
            $builder,
        );
    };
}

test_descriptor!(PANIC_STEP, build_panic_step, Behaviour::PanicInStep);
test_descriptor!(PANIC_BUILD, build_panic_build, Behaviour::PanicInBuild);
test_descriptor!(INPUT_ERROR, build_input_error, Behaviour::InputError);
test_descriptor!(
    CONFIG_ERROR,
    build_config_error,
    Behaviour::ConfigErrorInStep
);
test_descriptor!(NOTES, build_notes, Behaviour::Notes);
test_descriptor!(FILL, build_fill, Behaviour::Fill);

#[test]
fn a_panic_is_fatal_and_breaks_only_that_instance() {
    let other = Inst::new(&PANIC_STEP);
    other.init();
    let i = Inst::new(&PANIC_STEP);
    i.init();
    let bytes = sample_view_bytes(0.0, 1);
    i.set_input(&bytes);
    assert_eq!(i.step(0.0, 0.05), FATAL);
    let recs = i.records();
    assert!(
        recs.iter().any(|r| r.status == FATAL as i32
            && r.category == "logStatusFatal"
            && r.message.contains("test model panics at t = 0")),
        "{recs:?}"
    );
    // Broken: everything but FreeInstance is an error now, reset included.
    assert_eq!(i.step(0.05, 0.05), ERROR);
    assert_eq!(i.get_ints(&[3]).0, ERROR);
    assert_eq!(i.reset(), ERROR);
    assert_eq!(i.terminate(), ERROR);
    assert!(i.log.contains("broken"));
    // The other instance is unaffected (it has no input, so its model is not called).
    assert_eq!(other.step(0.0, 0.05), OK);
    drop(i); // fmi2FreeInstance frees the broken instance cleanly
}

#[test]
fn a_panic_while_building_the_model_is_fatal() {
    let i = Inst::new(&PANIC_BUILD);
    assert_eq!(i.enter(), OK);
    assert_eq!(i.get_ints(&vr::integer::CONFIG_REQUEST).0, FATAL);
    assert_eq!(i.exit(), ERROR);
}

#[test]
fn model_input_errors_skip_the_frame_other_errors_fail() {
    let i = Inst::new(&INPUT_ERROR);
    i.init();
    let bytes = sample_view_bytes(0.0, 1);
    for k in 0..3 {
        i.set_input(&bytes);
        assert_eq!(i.step(f64::from(k) * 0.05, 0.05), WARNING);
        assert_eq!(i.triple(vr::integer::SENSOR_DATA_OUT), [0, 0, 0]);
        assert!(!i.get_valid().1);
    }
    assert!(i.log.contains("no host vehicle"));

    let i = Inst::new(&CONFIG_ERROR);
    i.init();
    i.set_input(&bytes);
    assert_eq!(i.step(0.0, 0.05), ERROR);
    assert_eq!(i.step(0.05, 0.05), ERROR, "error state");
    assert!(i.log.contains("model step at t = 0 s failed"));
}

#[test]
fn granted_config_notes_are_warnings_and_rejections_errors() {
    let granted = osi3::SensorViewConfiguration {
        range: Some(50.0),
        ..Default::default()
    }
    .encode_to_vec();
    let i = Inst::new(&NOTES);
    assert_eq!(i.setup(), OK);
    assert_eq!(i.enter(), OK);
    let (lo, hi) = osiris_fmu::osmp::split_address(granted.as_ptr() as usize);
    assert_eq!(
        i.set_ints(&vr::integer::CONFIG, &[lo, hi, granted.len() as i32]),
        OK
    );
    assert_eq!(i.exit(), WARNING);
    let recs = i.records();
    assert!(
        recs.iter()
            .any(|r| r.status == WARNING as i32 && r.message.contains("granted range Some(50.0)")),
        "{recs:?}"
    );

    let bad = osi3::SensorViewConfiguration {
        range: Some(-1.0),
        ..Default::default()
    }
    .encode_to_vec();
    let i = Inst::new(&NOTES);
    assert_eq!(i.enter(), OK);
    let (lo, hi) = osiris_fmu::osmp::split_address(bad.as_ptr() as usize);
    assert_eq!(
        i.set_ints(&vr::integer::CONFIG, &[lo, hi, bad.len() as i32]),
        OK
    );
    assert_eq!(i.exit(), ERROR);
    assert!(i.log.contains("negative range granted"));

    let garbage = [0xffu8; 9];
    let i = Inst::new(&NOTES);
    assert_eq!(i.enter(), OK);
    let (lo, hi) = osiris_fmu::osmp::split_address(garbage.as_ptr() as usize);
    assert_eq!(
        i.set_ints(&vr::integer::CONFIG, &[lo, hi, garbage.len() as i32]),
        OK
    );
    assert_eq!(i.exit(), ERROR);
    assert!(i.log.contains("not a valid SensorViewConfiguration"));
}

#[test]
fn the_shell_publishes_the_model_output_as_it_is() {
    // The shell fills nothing: what a model leaves unset stays unset, what it sets stays.
    let i = Inst::new(&FILL);
    i.init();
    let bytes = sample_view(1.5, 42).encode_to_vec();
    i.set_input(&bytes);
    assert_eq!(i.step(1.5, 0.05), OK);
    let sd = i.sensor_data().unwrap();
    assert_eq!(sd.version, None);
    assert_eq!(sd.timestamp, None);
    let fd = sd.feature_data.unwrap();
    assert_eq!(fd.radar_sensor[0].header, None);
    assert_eq!(
        fd.lidar_sensor[0].header.unwrap().mounting_position,
        Some(osi3::MountingPosition::default())
    );
    assert_eq!(i.get_ints(&[vr::integer::COUNT]).1, vec![3]);
    let pd = i.perception().unwrap();
    assert_eq!(pd.model_mode.as_deref(), Some("custom"));
    assert_eq!(pd.cycle_counter, None);
}

#[test]
fn every_shipped_model_fills_the_frame_metadata() {
    for mode in ["ideal", "physical"] {
        let i = Inst::radar();
        assert_eq!(i.set_strings(&[vr::string::MODE], &[mode]), OK);
        i.init();
        let view = sample_view(1.5, 42);
        let bytes = view.encode_to_vec();
        for k in 0..2u64 {
            i.set_input(&bytes);
            assert_eq!(i.step(1.5, 0.05), OK, "{mode}: {:?}", i.records());
            let sd = i.sensor_data().unwrap();
            assert_eq!(sd.version, Some(osiris_proto::interface_version()));
            assert_eq!(sd.timestamp, view.timestamp);
            assert_eq!(sd.sensor_id, view.sensor_id);
            assert_eq!(sd.mounting_position, view.mounting_position);
            let fd = sd.feature_data.unwrap();
            assert_eq!(fd.version, Some(osiris_proto::interface_version()));
            let radar_header = fd.radar_sensor[0].header.unwrap();
            assert_eq!(radar_header.mounting_position, view.mounting_position);
            assert_eq!(radar_header.sensor_id, view.sensor_id);
            assert_eq!(radar_header.measurement_time, view.timestamp);
            assert_eq!(radar_header.cycle_counter, Some(k));
            assert_eq!(
                radar_header.number_of_valid_detections,
                Some(fd.radar_sensor[0].detection.len() as u32)
            );

            let pd = i.perception().unwrap();
            assert_eq!(pd.osi_version, Some(osiris_proto::interface_version()));
            assert_eq!(
                pd.extension_version.as_deref(),
                Some(osiris_proto::PERCEPTION_EXTENSION_VERSION)
            );
            assert_eq!(pd.timestamp, view.timestamp);
            assert_eq!(pd.sensor_id, view.sensor_id);
            assert_eq!(pd.mounting_position, view.mounting_position);
            assert_eq!(pd.cycle_counter, Some(k));
            assert_eq!(pd.model_mode.as_deref(), Some(mode));
        }

        // The measurement time falls back to the ground truth's timestamp, then to the
        // communication point; the mounting position to the configured one.
        let mut v = sample_view(2.0, 42);
        v.timestamp = None;
        v.mounting_position = None;
        let gt_time = osiris_proto::timestamp_from_seconds(2.01);
        v.global_ground_truth.as_mut().unwrap().timestamp = Some(gt_time);
        let bytes = v.encode_to_vec();
        i.set_input(&bytes);
        assert_eq!(i.step(2.0, 0.05), OK, "{mode}: {:?}", i.records());
        let sd = i.sensor_data().unwrap();
        assert_eq!(sd.timestamp, Some(gt_time), "{mode}");
        let configured = SensorConfig::default_for(SensorKind::Radar)
            .mounting
            .to_osi();
        assert_eq!(sd.mounting_position, Some(configured), "{mode}");
        assert_eq!(
            sd.feature_data.unwrap().radar_sensor[0]
                .header
                .unwrap()
                .mounting_position,
            Some(configured)
        );
        v.global_ground_truth.as_mut().unwrap().timestamp = None;
        let bytes = v.encode_to_vec();
        i.set_input(&bytes);
        assert_eq!(i.step(2.25, 0.05), OK);
        assert_eq!(
            i.sensor_data().unwrap().timestamp,
            Some(osiris_proto::timestamp_from_seconds(2.25)),
            "{mode}"
        );
        assert_eq!(i.perception().unwrap().cycle_counter, Some(3), "{mode}");
    }
}
