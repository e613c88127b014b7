//! Extending the consistency catalogue (GitHub issue 7): a user effect implemented from scratch
//! (`examples/custom_effect/bumper.rs`, shared with the example), registered, found and enabled;
//! catalogue registration rules; detection-threshold censoring in the radar catalogue.

#[path = "../examples/custom_effect/bumper.rs"]
mod bumper;

use osiris::consistency::campaign::CampaignSensor;
use osiris::consistency::catalogue::{Catalogue, Effect, Param};
use osiris::consistency::expr::{ncdf, npdf};
use osiris::consistency::{NVARS, V_PRX};

#[test]
fn knife_edge_loss_matches_itu_p526() {
    // ITU-R P.526-15 Fig. 9 / eq. 31: J(0) = 6.0 dB (grazing the edge), J(−0.78) = 0, and the
    // large-ν asymptote 13 + 20 log10 ν dB.
    assert!((bumper::knife_edge_loss_db(0.0) - 6.0).abs() < 0.1);
    assert!(bumper::knife_edge_loss_db(-0.78).abs() < 0.05);
    assert_eq!(bumper::knife_edge_loss_db(-2.0), 0.0);
    let nu: f64 = 10.0;
    assert!((bumper::knife_edge_loss_db(nu) - (13.0 + 20.0 * nu.log10())).abs() < 0.3);
}

#[test]
fn a_registered_effect_is_found_fitted_and_enabling_it_makes_the_error_fall() {
    let dir = tempfile::tempdir().unwrap();
    let d = bumper::demo(dir.path(), 3).unwrap();
    eprintln!("{d:#?}");
    // Not in the built-in catalogue: the misfit is not explained, and no built-in effect is
    // confidently (wrongly) named.
    assert_ne!(d.without.status, "EXPLAINED");
    assert_ne!(d.without.status, "CONSISTENT");
    assert!(
        !d.without
            .accepted
            .iter()
            .any(|a| a == "radar.bumper_edge_blockage")
    );
    // Registered: accepted, edge azimuth fitted within 1° of the hidden 15°.
    assert_eq!(d.with.status, "EXPLAINED", "{d:#?}");
    assert_eq!(
        d.with.accepted,
        vec!["radar.bumper_edge_blockage".to_string()]
    );
    let (edge, sigma) = d.with.edge_azimuth_deg.unwrap();
    assert!(
        (edge - bumper::HIDDEN_EDGE_AZIMUTH_DEG).abs() < 1.0,
        "edge {edge} ± {sigma}"
    );
    assert!(sigma > 0.0 && sigma < 1.0, "σ {sigma}");
    // Enabled (the model output corrected by the fitted effect): the headline error falls to the
    // scatter of the truth generator (12 % amplitude fluctuation + 0.5 dB quantisation, ≈ 1 dB)
    // and nothing is left to attribute.
    assert!(
        d.enabled.power_rms_db < 0.5 * d.without.power_rms_db,
        "{} -> {}",
        d.without.power_rms_db,
        d.enabled.power_rms_db
    );
    assert!(d.enabled.power_rms_db < 1.5, "{}", d.enabled.power_rms_db);
    assert!(d.enabled.power_rms_raw_db < d.without.power_rms_raw_db);
    assert!(d.enabled.accepted.is_empty(), "{d:#?}");
}

#[test]
fn registration_validates_and_a_catalogue_is_passed_as_a_value() {
    let mut c = Catalogue::builtin(CampaignSensor::Radar).unwrap();
    let n = c.effects.len();
    // Duplicate id.
    let dup = Effect::from_signature(
        "radar.two_way_spreading",
        "power_db",
        "p0*range",
        &[],
        vec![Param::new("p0", [0.0, 1.0], 0.5)],
    )
    .unwrap();
    let err = c.register(Box::new(dup)).unwrap_err().to_string();
    assert!(err.contains("radar.two_way_spreading"), "{err}");
    // Three parameters, bad bounds, nominal outside, unknown variable: errors naming the effect.
    let three = (0..3)
        .map(|i| Param::new(&format!("p{i}"), [0.0, 1.0], 0.5))
        .collect();
    assert!(Effect::from_signature("x.three", "power_db", "p0+p1+p2", &[], three).is_err());
    let bad = Effect::from_signature(
        "x.bounds",
        "power_db",
        "p0",
        &[],
        vec![Param::new("p0", [1.0, 1.0], 1.0)],
    );
    assert!(bad.unwrap_err().to_string().contains("x.bounds"));
    let outside = Effect::from_signature(
        "x.nominal",
        "power_db",
        "p0",
        &[],
        vec![Param::new("p0", [0.0, 1.0], 2.0)],
    );
    assert!(outside.unwrap_err().to_string().contains("nominal"));
    assert!(Effect::from_signature("x.var", "power_db", "p0*speed", &[], vec![]).is_err());
    // A valid one: registered in this catalogue value only; the built-in catalogue is untouched.
    c.register(Box::new(bumper::BumperEdgeBlockage::default()))
        .unwrap();
    assert_eq!(c.effects.len(), n + 1);
    let id = "radar.bumper_edge_blockage";
    assert!(c.get(id).is_some());
    assert!(
        Catalogue::builtin(CampaignSensor::Radar)
            .unwrap()
            .get(id)
            .is_none()
    );
    // A catalogue of another sensor is refused by the workflow, naming both.
    let lidar = Catalogue::builtin(CampaignSensor::Lidar).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let files = osiris::consistency::truth::write_radar(
        &dir.path().join("c"),
        &osiris::consistency::truth::RadarTruth::default(),
    )
    .unwrap();
    let args = osiris::consistency::ConsistencyArgs {
        meta: files.toml.clone(),
        out: dir.path().join("out"),
        simulated: Some(files.simulated.clone()),
        model: None,
        enable: vec![],
        disable: vec![],
        history: None,
    };
    let err = osiris::consistency::cli::run_with_catalogue(&args, Some(&lidar), None)
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("lidar catalogue") && err.contains("radar campaign"),
        "{err}"
    );
    // The documentation of a registered effect is serialised with the catalogue.
    let json = serde_json::to_value(&c).unwrap();
    assert!(
        json["effects"]
            .as_array()
            .unwrap()
            .iter()
            .any(|e| e["id"] == id)
    );
}

#[test]
fn censoring_signature_is_the_truncated_normal_mean() {
    let c = Catalogue::builtin(CampaignSensor::Radar).unwrap();
    let e = c.get("radar.detection_censoring").unwrap();
    assert_eq!(e.quantity(), "power_db");
    assert_eq!(e.model_switch(), None);
    let mut x = [0.0; NVARS];
    let (t, s) = (-100.0, 2.0);
    // Far above the threshold: no bias.
    x[V_PRX] = t + 10.0 * s;
    assert!(e.eval(&x, &[t, s]).abs() < 1e-6);
    // At the threshold the truncated mean of N(μ, s²) exceeds μ by s·φ(0)/Φ(0) = s·√(2/π)
    // (Johnson, Kotz & Balakrishnan, §13.10.1).
    x[V_PRX] = t;
    let want = s * (2.0 / std::f64::consts::PI).sqrt();
    assert!((e.eval(&x, &[t, s]) - want).abs() < 1e-6);
    // Independent check by numerical integration of E[X | X > T] − μ, μ = T − s.
    x[V_PRX] = t - s;
    let (mut num, mut den) = (0.0, 0.0);
    let dz = 1e-4;
    let mut z: f64 = 1.0; // (X − μ)/s from the threshold up
    while z < 12.0 {
        let w = (-0.5 * z * z).exp();
        num += z * w * dz;
        den += w * dz;
        z += dz;
    }
    let want = s * num / den;
    assert!(
        (e.eval(&x, &[t, s]) - want).abs() < 1e-3,
        "{} vs {want}",
        e.eval(&x, &[t, s])
    );
    // Φ and φ used by the signature.
    assert!((ncdf(1.0) - 0.841_344_746).abs() < 1e-6);
    assert!((npdf(0.0) - 0.398_942_280).abs() < 1e-8);
}
