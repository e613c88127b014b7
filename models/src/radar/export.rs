//! The radar's content of one cycle's output (`crate::physical::Physics::emit`): the chain's
//! detections as OSI `SensorData` radar detections, the recognised moving objects, and the
//! `PerceptionData.radar` extension (peaks with their ground-truth object, the waveform, optionally
//! the range-Doppler map). Headers, OSI semantics and the loop around it are `crate::physical`'s.

use osiris_proto::{id, osi3, perception};
use prost::Message as _;

use crate::frames::Spherical;
use crate::sensor::StepOutput;

use super::RadarPhysics;

/// Existence probability of a detection from its SNR: a logistic ramp, 0.5 at 13 dB (the
/// CA-CFAR threshold at P_FA 1e-6, physics.md §1.7), 0.95 at 20 dB (guessed shape).
fn existence_from_snr(snr_db: f64) -> f64 {
    1.0 / (1.0 + (-(snr_db - 13.0) * 0.42).exp())
}

/// The cycle's content: every chain detection as an OSI radar detection under its detected object
/// (from recognition; OSI 3.8.0 semantics, `crate::semantics`) and as a perception peak with its
/// ground-truth object; the recognised moving objects; the PerceptionData radar block (peaks,
/// waveform, and with `emit_range_doppler_map` the chain's range-Doppler map). The lists of the
/// previous cycle are reused.
pub(super) fn emit(p: &mut RadarPhysics, out: &mut StepOutput) {
    let mut dets = out
        .sensor_data
        .feature_data
        .as_mut()
        .and_then(|fd| fd.radar_sensor.first_mut())
        .map(|x| std::mem::take(&mut x.detection))
        .unwrap_or_default();
    let mut peaks = out
        .perception
        .radar
        .as_mut()
        .map(|r| std::mem::take(&mut r.peak))
        .unwrap_or_default();
    let mut free = out
        .perception
        .radar
        .as_mut()
        .and_then(|r| r.free_space.take())
        .unwrap_or_default();
    // The recognised objects go out; the previous output's list comes back for the next cycle.
    let mut moving = std::mem::take(&mut out.sensor_data.moving_object);
    std::mem::swap(&mut moving, &mut p.moving);
    out.sensor_data.clear();
    out.perception.clear();
    dets.clear();
    peaks.clear();
    let objects = p.recognition.detection_objects();
    for (i, (c, d)) in p.chain_out.iter().zip(&p.detections).enumerate() {
        let o = objects.get(i).copied().flatten();
        let sph = Spherical {
            distance: d.range_m,
            azimuth: d.azimuth_rad,
            elevation: d.elevation_rad,
        };
        dets.push(osi3::RadarDetection {
            existence_probability: Some(existence_from_snr(d.snr_db)),
            // The detected object it belongs to; the ground truth stays in the perception peak.
            object_id: o.map(id),
            position: Some(sph.to_osi()),
            // OSI: radial velocity positive towards the sensor (see ideal.rs).
            radial_velocity: Some(-d.range_rate_m_s),
            rcs: Some(d.rcs_dbsm),
            snr: Some(d.snr_db),
            ..Default::default()
        });
        peaks.push(perception::RadarPeak {
            range_m: Some(d.range_m),
            range_rate_m_s: Some(d.range_rate_m_s),
            azimuth_rad: Some(d.azimuth_rad),
            elevation_rad: Some(d.elevation_rad),
            power_dbm: Some(c.power_dbm),
            snr_db: Some(d.snr_db),
            rcs_dbsm: Some(d.rcs_dbsm),
            object_id: (d.object_id != osiris_proto::INVALID_ID).then(|| id(d.object_id)),
        });
    }
    let sd = &mut out.sensor_data;
    sd.feature_data = Some(osi3::FeatureData {
        radar_sensor: vec![osi3::RadarDetectionData {
            header: None,
            detection: dets,
        }],
        ..Default::default()
    });
    sd.moving_object = moving;

    let (radar, chain) = (&p.radar, &p.chain);
    let w = &radar.waveform;
    let rd_map = radar.emit_range_doppler_map.then(|| {
        let m = chain.range_doppler_map();
        perception::RangeDopplerMap {
            range_bins: Some(m.range_bins as u32),
            doppler_bins: Some(m.doppler_bins as u32),
            range_bin_m: Some(m.range_bin_m),
            range_rate_bin_m_s: Some(m.doppler_bin_m_s),
            power_dbm: m.power_dbm,
        }
    });
    let free_space = p.recognition.free_space().map(|f| {
        free.azimuth_start_rad = Some(f.azimuth_start_rad());
        free.azimuth_step_rad = Some(f.sector_width_rad());
        free.boundary_distance_m.clear();
        free.boundary_distance_m.extend_from_slice(f.boundary_m());
        free.cell_size_m = Some(f.config().cell_size_m);
        if f.config().emit_grid {
            let corner = f.grid_corner_m() - f.sensor_position_m().truncate();
            free.cells_per_edge = Some(f.cells_per_edge() as u32);
            free.corner_x_m = Some(corner.x);
            free.corner_y_m = Some(corner.y);
            f.probabilities_into(&mut free.occupancy);
        } else {
            free.cells_per_edge = Some(0);
            free.corner_x_m = None;
            free.corner_y_m = None;
            free.occupancy.clear();
        }
        free
    });
    out.perception.radar = Some(perception::RadarPerception {
        peak: peaks,
        waveform: Some(perception::RadarWaveform {
            carrier_frequency_hz: Some(w.carrier_frequency_hz),
            bandwidth_hz: Some(w.sampled_bandwidth_hz()),
            chirp_duration_s: Some(w.chirp_interval_s()),
            samples_per_chirp: Some(w.samples_per_chirp as u32),
            chirps_per_frame: Some(w.chirps_per_frame as u32),
            virtual_channels: Some(radar.array.n_virtual() as u32),
        }),
        range_doppler_map: rd_map,
        azimuth_misalignment_rad: p.online_calibration.then(|| p.misalignment.estimate_rad()),
        misalignment_detections: p
            .online_calibration
            .then_some(p.misalignment.detections_used),
        free_space,
    });
}
