//! OSMP semantics through the in-process ABI: no input, malformed input (random and truncated),
//! double-buffered outputs, the cached ConfigRequest and its echo, several instances interleaved
//! and on several threads.

mod common;

use common::*;
use osiris_fmu::sensors;
use osiris_fmu::variables::vr;
use osiris_models::SensorKind;
use osiris_proto::{Message, osi3};
use proptest::prelude::*;

fn addr_of(bytes: &[u8]) -> (i32, i32) {
    osiris_fmu::osmp::split_address(bytes.as_ptr() as usize)
}

#[test]
fn no_input_is_ok_with_empty_outputs() {
    let i = Inst::radar_initialized();
    let good = sample_view_bytes(0.0, 1);
    let (lo, hi) = addr_of(&good);
    let cases: [(&str, [i32; 3]); 5] = [
        ("all zero", [0, 0, 0]),
        ("address, size 0", [lo, hi, 0]),
        ("address, negative size", [lo, hi, -12]),
        ("null address, size", [0, 0, good.len() as i32]),
        ("null address, negative size", [0, 0, i32::MIN]),
    ];
    let mut t = 0.0;
    for (what, triple) in cases {
        // A valid frame first, so that there is something to clear.
        i.set_input(&good);
        assert_eq!(i.step(t, 0.05), OK);
        assert!(i.get_valid().1);
        t += 0.05;
        assert_eq!(i.set_ints(&vr::integer::SENSOR_VIEW_IN, &triple), OK);
        assert_eq!(i.step(t, 0.05), OK, "{what}");
        t += 0.05;
        assert_eq!(i.triple(vr::integer::SENSOR_DATA_OUT), [0, 0, 0], "{what}");
        assert_eq!(
            i.triple(vr::integer::PERCEPTION_DATA_OUT),
            [0, 0, 0],
            "{what}"
        );
        assert_eq!(i.get_ints(&[vr::integer::COUNT]).1, vec![0]);
        assert!(!i.get_valid().1, "{what}");
    }
}

#[test]
fn malformed_input_is_a_warning_and_the_frame_is_skipped() {
    let i = Inst::radar_initialized();
    let garbage = vec![0xffu8; 16];
    i.set_input(&garbage);
    assert_eq!(i.step(0.0, 0.05), WARNING);
    assert_eq!(i.triple(vr::integer::SENSOR_DATA_OUT), [0, 0, 0]);
    assert!(!i.get_valid().1);
    assert!(i.log.contains("is not a valid SensorView"));
    let good = sample_view_bytes(0.05, 1);
    i.set_input(&good);
    assert_eq!(i.step(0.05, 0.05), OK);
    assert!(i.get_valid().1);
    assert!(i.sensor_data().is_some());
}

/// After a bad frame, a valid SensorView still produces output.
fn assert_recovers(i: &Inst, t: f64) {
    let good = sample_view_bytes(t, 11);
    i.set_input(&good);
    assert_eq!(i.step(t, 0.05), OK, "{:?}", i.records().last());
    assert!(i.get_valid().1);
    let sd = i.sensor_data().expect("SensorData after a valid view");
    assert_eq!(sd.sensor_id, Some(osiris_proto::id(11)));
    let count = (sd.moving_object.len() + sd.stationary_object.len()) as i32;
    assert_eq!(i.get_ints(&[vr::integer::COUNT]).1, vec![count]);
}

#[test]
fn truncated_valid_buffers_never_panic() {
    let i = Inst::radar_initialized();
    let full = sample_view_bytes(0.5, 3);
    let mut t = 0.0;
    for len in 0..full.len() {
        let part = full[..len].to_vec();
        i.set_input(&part);
        let s = i.step(t, 0.05);
        t += 0.05;
        assert!(s == OK || s == WARNING, "len {len}: {s:?}");
        if s == WARNING {
            assert!(!i.get_valid().1);
            assert_eq!(i.triple(vr::integer::SENSOR_DATA_OUT), [0, 0, 0]);
        }
    }
    assert_recovers(&i, t);
    assert_all_formats_are_percent_s(&i.records());
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 256, failure_persistence: None, ..ProptestConfig::default() })]

    #[test]
    fn random_bytes_as_sensor_view_never_break_the_instance(
        frames in proptest::collection::vec(proptest::collection::vec(any::<u8>(), 0..600), 1..4),
    ) {
        let i = Inst::radar_initialized();
        let mut t = 0.0;
        for bytes in &frames {
            i.set_input(bytes);
            let s = i.step(t, 0.05);
            t += 0.05;
            prop_assert!(s == OK || s == WARNING, "status {:?}: {:?}", s, i.records().last());
            let (gs, valid) = i.get_valid();
            prop_assert_eq!(gs, OK);
            if !valid {
                prop_assert_eq!(i.triple(vr::integer::SENSOR_DATA_OUT), [0, 0, 0]);
            }
        }
        assert_recovers(&i, t);
    }

    #[test]
    fn mutated_valid_views_never_break_the_instance(
        flips in proptest::collection::vec((any::<prop::sample::Index>(), any::<u8>()), 1..8),
    ) {
        let i = Inst::radar_initialized();
        let mut bytes = sample_view_bytes(0.25, 4);
        for (idx, b) in &flips {
            let k = idx.index(bytes.len());
            bytes[k] = *b;
        }
        i.set_input(&bytes);
        let s = i.step(0.0, 0.05);
        prop_assert!(s == OK || s == WARNING, "status {:?}", s);
        assert_recovers(&i, 0.05);
    }
}

#[test]
fn outputs_are_double_buffered() {
    let i = Inst::radar_initialized();
    let views: Vec<Vec<u8>> = (0..4)
        .map(|k| sample_view_bytes(f64::from(k) * 0.05, 100 + k as u64))
        .collect();
    // (SensorData triple, PerceptionData triple, their bytes) per step.
    type Published = ([i32; 3], [i32; 3], Vec<u8>, Vec<u8>);
    let mut published: Vec<Published> = Vec::new();
    for (k, v) in views.iter().enumerate() {
        i.set_input(v);
        assert_eq!(i.step(k as f64 * 0.05, 0.05), OK);
        let sd = i.triple(vr::integer::SENSOR_DATA_OUT);
        let pd = i.triple(vr::integer::PERCEPTION_DATA_OUT);
        published.push((sd, pd, read_triple(sd).unwrap(), read_triple(pd).unwrap()));
        if k >= 1 {
            // The previous step's buffers are still intact and still decode to its frame.
            let (psd, ppd, psd_bytes, ppd_bytes) = &published[k - 1];
            assert_ne!(psd, &sd, "step {k} must publish the other buffer");
            assert_ne!(ppd, &pd);
            assert_eq!(
                &read_triple(*psd).unwrap(),
                psd_bytes,
                "SensorData of step {} overwritten",
                k - 1
            );
            assert_eq!(&read_triple(*ppd).unwrap(), ppd_bytes);
            let old = osi3::SensorData::decode(psd_bytes.as_slice()).unwrap();
            assert_eq!(old.sensor_id, Some(osiris_proto::id(100 + k as u64 - 1)));
        }
    }
    // A step without input keeps the last published frame's bytes alive as well.
    let (last_sd, _, last_bytes, _) = published.last().unwrap().clone();
    i.set_ints(&vr::integer::SENSOR_VIEW_IN, &[0, 0, 0]);
    assert_eq!(i.step(0.2, 0.05), OK);
    assert_eq!(read_triple(last_sd).unwrap(), last_bytes);
}

#[test]
fn config_request_is_cached_and_read_piecewise_consistently() {
    let i = Inst::radar();
    assert_eq!(i.setup(), OK);
    assert_eq!(i.enter(), OK);
    let (s, lo) = i.get_ints(&[vr::integer::CONFIG_REQUEST_BASE_LO]);
    assert_eq!(s, OK);
    let (_, hi) = i.get_ints(&[vr::integer::CONFIG_REQUEST_BASE_HI]);
    let (_, size) = i.get_ints(&[vr::integer::CONFIG_REQUEST_SIZE]);
    let (_, all) = i.get_ints(&vr::integer::CONFIG_REQUEST);
    assert_eq!(
        vec![lo[0], hi[0], size[0]],
        all,
        "separate reads name the same buffer"
    );
    let triple = [lo[0], hi[0], size[0]];
    let bytes = read_triple(triple).unwrap();
    let req = osi3::SensorViewConfiguration::decode(bytes.as_slice()).unwrap();
    let defaults = osiris_models::SensorConfig::default_for(SensorKind::Radar);
    assert_eq!(req.version, Some(osiris_proto::interface_version()));
    assert_eq!(req.range, Some(defaults.range_m));
    assert_eq!(
        req.field_of_view_horizontal,
        Some(defaults.fov_horizontal_rad)
    );
    assert!(req.mounting_position.is_some());
    assert!(req.update_cycle_time.is_some());
    // Unrelated calls (inputs, outputs, same-value sets) keep the cache.
    assert_eq!(i.set_ints(&vr::integer::SENSOR_VIEW_IN, &[0, 0, 0]), OK);
    assert_eq!(i.set_ints(&vr::integer::CONFIG, &[0, 0, 0]), OK);
    assert_eq!(i.get_ints(&[3, 4, 5, 15]).0, OK);
    assert_eq!(i.triple(vr::integer::CONFIG_REQUEST), triple);
    // A parameter change recomputes it.
    assert_eq!(i.set_reals(&[vr::real::RANGE_M], &[80.0]), OK);
    let t2 = i.triple(vr::integer::CONFIG_REQUEST);
    let req2 = osi3::SensorViewConfiguration::decode(read_triple(t2).unwrap().as_slice()).unwrap();
    assert_eq!(req2.range, Some(80.0));
    assert_eq!(i.triple(vr::integer::CONFIG_REQUEST), t2, "stable again");

    // Once a Config is granted, the request echoes it byte for byte.
    let granted = osi3::SensorViewConfiguration {
        version: Some(osiris_proto::interface_version()),
        sensor_id: Some(osiris_proto::id(77)),
        range: Some(60.0),
        field_of_view_horizontal: Some(1.0),
        ..Default::default()
    }
    .encode_to_vec();
    let (glo, ghi) = addr_of(&granted);
    assert_eq!(
        i.set_ints(&vr::integer::CONFIG, &[glo, ghi, granted.len() as i32]),
        OK
    );
    let t3 = i.triple(vr::integer::CONFIG_REQUEST);
    assert_eq!(read_triple(t3).unwrap(), granted);
    assert_eq!(
        i.get_ints(&[vr::integer::CONFIG_REQUEST_BASE_HI]).1[0],
        t3[1]
    );
    assert_eq!(
        i.get_ints(&[vr::integer::CONFIG_REQUEST_BASE_LO]).1[0],
        t3[0]
    );
    assert_eq!(
        i.get_ints(&vr::integer::CONFIG).1,
        vec![glo, ghi, granted.len() as i32]
    );
    let s = i.exit();
    assert!(s == OK || s == WARNING, "{s:?}: {:?}", i.records());
    drop(granted); // the importer's buffer is gone after fmi2ExitInitializationMode
    // The request stays readable (from the FMU's own copy) after initialization.
    let t4 = i.triple(vr::integer::CONFIG_REQUEST);
    assert_eq!(t4, t3);
    let echoed =
        osi3::SensorViewConfiguration::decode(read_triple(t4).unwrap().as_slice()).unwrap();
    assert_eq!(echoed.range, Some(60.0));
    let view = sample_view_bytes(0.0, 5);
    i.set_input(&view);
    assert_eq!(i.step(0.0, 0.05), OK);
}

#[test]
fn several_instances_interleaved_in_one_process() {
    let insts: Vec<Inst> = [
        SensorKind::Camera,
        SensorKind::Radar,
        SensorKind::Lidar,
        SensorKind::Radar,
    ]
    .iter()
    .map(|&k| {
        let i = Inst::new(sensors::descriptor(k));
        i.init();
        i
    })
    .collect();
    let mut keep = Vec::new();
    for step in 0..20u64 {
        let t = step as f64 * 0.05;
        for (n, i) in insts.iter().enumerate() {
            let bytes = sample_view_bytes(t, 1000 * (n as u64 + 1) + step);
            i.set_input(&bytes);
            keep.push(bytes);
        }
        for i in &insts {
            assert_eq!(i.step(t, 0.05), OK, "{:?}", i.records().last());
        }
        for (n, i) in insts.iter().enumerate() {
            let sd = i.sensor_data().unwrap();
            assert_eq!(
                sd.sensor_id,
                Some(osiris_proto::id(1000 * (n as u64 + 1) + step))
            );
            assert_eq!(i.perception().unwrap().cycle_counter, Some(step));
        }
    }
    for i in &insts {
        assert_eq!(i.terminate(), OK);
    }
}

#[test]
fn several_instances_on_different_threads() {
    let handles: Vec<_> = (0..4u64)
        .map(|n| {
            std::thread::spawn(move || {
                let kind = SensorKind::ALL[n as usize % 3];
                let i = Inst::new(sensors::descriptor(kind));
                i.init();
                for step in 0..100u64 {
                    let t = step as f64 * 0.05;
                    let bytes = sample_view_bytes(t, n * 10_000 + step);
                    i.set_input(&bytes);
                    assert_eq!(i.step(t, 0.05), OK);
                    let sd = i.sensor_data().unwrap();
                    assert_eq!(sd.sensor_id, Some(osiris_proto::id(n * 10_000 + step)));
                    assert_eq!(sd.timestamp, Some(osiris_proto::timestamp_from_seconds(t)));
                }
                assert_eq!(i.terminate(), OK);
                assert!(i.records().iter().all(|r| r.status == OK as i32));
                // The instance moves back to the spawning thread to be freed there.
                i
            })
        })
        .collect();
    let instances: Vec<Inst> = handles.into_iter().map(|h| h.join().unwrap()).collect();
    drop(instances);
}

#[test]
fn the_default_model_produces_valid_sensor_data() {
    for kind in SensorKind::ALL {
        let i = Inst::new(sensors::descriptor(kind));
        i.init();
        let mode = osiris_models::SensorConfig::default_for(kind).mode;
        let view = sample_view(0.5, 8);
        let bytes = view.encode_to_vec();
        i.set_input(&bytes);
        assert_eq!(i.step(0.5, 0.05), OK, "{kind:?}: {:?}", i.records());
        let sd = i.sensor_data().unwrap();
        assert_eq!(sd.version, Some(osiris_proto::interface_version()));
        assert_eq!(sd.timestamp, view.timestamp);
        assert_eq!(sd.sensor_id, view.sensor_id);
        assert_eq!(sd.mounting_position, view.mounting_position);
        let pd = i.perception().unwrap();
        assert_eq!(pd.model_mode.as_deref(), Some(mode.name()));
        assert_eq!(pd.timestamp, view.timestamp);
    }
}
