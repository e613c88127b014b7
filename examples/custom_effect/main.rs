//! `cargo run --release --example custom_effect`: a consistency-catalogue effect written from
//! scratch (radar blockage by a bumper edge, `bumper.rs`), found on a campaign and then enabled,
//! with the error falling. See `bumper.rs` for the four steps.

mod bumper;

fn main() -> anyhow::Result<()> {
    // Optional argument: a folder to keep the campaign and the three reports in.
    let tmp = tempfile::tempdir()?;
    let dir = std::env::args_os()
        .nth(1)
        .map(std::path::PathBuf::from)
        .unwrap_or_else(|| tmp.path().to_path_buf());
    let d = bumper::demo(&dir, 3)?;
    let show = |what: &str, o: &bumper::Outcome| {
        println!(
            "{what:<34} status {:<20} power RMS {:6.2} dB (raw {:6.2} dB)  accepted {:?}{}",
            o.status,
            o.power_rms_db,
            o.power_rms_raw_db,
            o.accepted,
            o.edge_azimuth_deg
                .filter(|_| o.accepted.iter().any(|a| a == "radar.bumper_edge_blockage"))
                .map(|(v, s)| format!("  edge azimuth {v:.2} ± {s:.2} deg"))
                .unwrap_or_default()
        );
    };
    println!(
        "hidden effect: bumper edge at {:.1} deg azimuth, {} m from the antenna",
        bumper::HIDDEN_EDGE_AZIMUTH_DEG,
        bumper::EDGE_DISTANCE_M
    );
    show("1. built-in catalogue", &d.without);
    show("2. effect registered", &d.with);
    show("3. fitted effect enabled", &d.enabled);
    if std::env::args_os().nth(1).is_some() {
        println!(
            "reports: {}/{{without,with,enabled}}/report.html",
            dir.display()
        );
    } else {
        println!("(pass a folder as the first argument to keep the campaign and the reports)");
    }
    Ok(())
}
