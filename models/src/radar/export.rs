//! Output assembly of a radar step: the chain's detections as OSI `SensorData` (radar detections
//! under their detection header, the recognised moving objects, and with ground truth the OSI 3.8.0
//! semantics of `crate::semantics`) and as the `PerceptionData.radar` extension (peaks with their
//! ground-truth object, the waveform, optionally the range-Doppler map). The step in `mod.rs`
//! plans, perceives and recognises; what it hands to the FMU shell is built here. (Unlike
//! `lidar/export.rs`, which writes point-cloud files, nothing here leaves the step's messages.)

use osiris_proto::{id, interface_version, osi3, perception};
use prost::Message as _;

use crate::frames::Spherical;
use crate::recognition::RadarDetection;
use crate::sensor::{ModelMode, StepOutput};
use crate::world::WorldFrame;

use super::antenna::Antennas;
use super::baseband::{ChainDetection, RadarChain};
use super::{RadarConfig, rcs_estimate_dbsm};

/// The previous step's output lists, taken out of the output to reuse their allocations.
pub(super) struct Buffers {
    pub(super) detections: Vec<osi3::RadarDetection>,
    pub(super) peaks: Vec<perception::RadarPeak>,
    pub(super) moving: Vec<osi3::DetectedMovingObject>,
}

impl Buffers {
    /// Take the lists out of `out`, then clear `out` and the lists.
    pub(super) fn take(out: &mut StepOutput) -> Buffers {
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
        let mut moving = std::mem::take(&mut out.sensor_data.moving_object);
        out.sensor_data.clear();
        out.perception.clear();
        dets.clear();
        peaks.clear();
        moving.clear();
        Buffers {
            detections: dets,
            peaks,
            moving,
        }
    }
}

/// Existence probability of a detection from its SNR: a logistic ramp, 0.5 at 13 dB (the
/// CA-CFAR threshold at P_FA 1e-6, physics.md §1.7), 0.95 at 20 dB (guessed shape).
fn existence_from_snr(snr_db: f64) -> f64 {
    1.0 / (1.0 + (-(snr_db - 13.0) * 0.42).exp())
}

/// Every chain detection as an OSI radar detection (its detected object is set after
/// recognition, [`detected_objects`]), a perception peak (with the ground-truth object) and a
/// recognition input in `detections` (cleared first). The RCS is the radar equation inverted,
/// [`rcs_estimate_dbsm`].
pub(super) fn detections(
    radar: &RadarConfig,
    antennas: &Antennas,
    chain_out: &[ChainDetection],
    bufs: &mut Buffers,
    detections: &mut Vec<RadarDetection>,
) {
    let (dets, peaks) = (&mut bufs.detections, &mut bufs.peaks);
    detections.clear();
    for d in chain_out {
        let rcs = rcs_estimate_dbsm(radar, antennas, d);
        let oid = (d.object_id != osiris_proto::INVALID_ID).then(|| id(d.object_id));
        let sph = Spherical {
            distance: d.range_m,
            azimuth: d.azimuth_rad,
            elevation: d.elevation_rad,
        };
        dets.push(osi3::RadarDetection {
            existence_probability: Some(existence_from_snr(d.snr_db)),
            // The detected object it belongs to, set after recognition (OSI 3.8.0 semantics,
            // `crate::semantics`); the ground truth stays in the perception peak.
            object_id: None,
            position: Some(sph.to_osi()),
            // OSI: radial velocity positive towards the sensor (see ideal.rs).
            radial_velocity: Some(-d.range_rate_m_s),
            rcs: Some(rcs),
            snr: Some(d.snr_db),
            ..Default::default()
        });
        peaks.push(perception::RadarPeak {
            range_m: Some(d.range_m),
            range_rate_m_s: Some(d.range_rate_m_s),
            azimuth_rad: Some(d.azimuth_rad),
            elevation_rad: Some(d.elevation_rad),
            power_dbm: Some(d.power_dbm),
            snr_db: Some(d.snr_db),
            rcs_dbsm: Some(rcs),
            object_id: oid,
        });
        detections.push(RadarDetection {
            range_m: d.range_m,
            azimuth_rad: d.azimuth_rad,
            elevation_rad: d.elevation_rad,
            range_rate_m_s: d.range_rate_m_s,
            snr_db: d.snr_db,
            rcs_dbsm: rcs,
            object_id: d.object_id,
        });
    }
}

/// The detected object of every OSI detection, from recognition (one entry per detection).
pub(super) fn detected_objects(dets: &mut [osi3::RadarDetection], objects: &[Option<u64>]) {
    for (d, o) in dets.iter_mut().zip(objects) {
        d.object_id = o.map(id);
    }
}

/// `SensorData`: the header, the detections under their detection header, the moving objects,
/// and with ground truth `gt` the OSI semantics (`reported`: the recognition's reported ground
/// truth).
pub(super) fn sensor_data(
    sd: &mut osi3::SensorData,
    frame: &WorldFrame<'_>,
    cycle: u64,
    dets: Vec<osi3::RadarDetection>,
    moving: Vec<osi3::DetectedMovingObject>,
    gt: Option<&osi3::GroundTruth>,
    reported: &[(u64, Option<u64>)],
) {
    frame.fill_sensor_data_header(sd, cycle);
    let header = frame.detection_header(cycle, dets.len());
    sd.feature_data = Some(osi3::FeatureData {
        version: Some(interface_version()),
        radar_sensor: vec![osi3::RadarDetectionData {
            header: Some(header),
            detection: dets,
        }],
        ..Default::default()
    });
    sd.moving_object = moving;
    if let Some(gt) = gt {
        crate::semantics::complete(
            sd,
            gt,
            &crate::semantics::PoseFrames::new(&frame.frame, &frame.mounting),
            &|t| reported.iter().find(|r| r.0 == t).and_then(|r| r.1),
        );
    }
}

/// `PerceptionData`: the common header and the radar block (peaks, waveform, and with
/// `emit_range_doppler_map` the chain's range-Doppler map).
pub(super) fn perception(
    p: &mut perception::PerceptionData,
    frame: &WorldFrame<'_>,
    cycle: u64,
    peaks: Vec<perception::RadarPeak>,
    radar: &RadarConfig,
    chain: &RadarChain,
) {
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
    p.osi_version = Some(interface_version());
    p.extension_version = Some(osiris_proto::PERCEPTION_EXTENSION_VERSION.to_string());
    p.timestamp = Some(frame.timestamp);
    p.sensor_id = frame.sensor_id;
    p.mounting_position = Some(frame.mounting);
    p.model_mode = Some(ModelMode::Physical.name().to_string());
    p.cycle_counter = Some(cycle);
    p.radar = Some(perception::RadarPerception {
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
    });
}
