//! Ghost statistics of a radar run: every detection of a physical radar's `SensorData` classified
//! against the ground-truth geometry, and the recognition's reported objects matched to the ground
//! truth, so that the multipath ghosts in the detections and the effect of the recognition's ghost
//! rejection ([`super::radar`], steps 2 and 4) are counted. Usable from tests, a CLI or a bench:
//! feed [`GhostStatistics::add_frame`] one cycle at a time, read [`GhostStatistics::counts`].
//!
//! # Classification of a detection (independent of the recognition)
//!
//! A detection whose perception peak has no ground-truth object (`RadarPeak.object_id` unset: the
//! road's own backscatter, `radar.road_clutter`) is **static** wherever its errors put it.
//! Otherwise its position
//! `p = T_sensor→global · r·(cos e cos a, cos e sin a, sin e)` is tested, in this order:
//!
//! 1. **below ground**: `p_z < road_z_m − ground_margin_m` (a road-surface image path);
//! 2. **behind a guardrail**: the x-y line of sight from the sensor to `p` crosses the centre line
//!    of a ground-truth stationary object whose `model_reference` contains `guardrail_reference`
//!    (its box's long axis, over its length) and `p` lies more than `guardrail_margin_m` beyond
//!    that line, perpendicular to it (a mirror path via the rail);
//! 3. **real**: the ground-truth object of its perception peak (`RadarPeak.object_id`) is a moving
//!    object and `p` lies in that object's box grown by `box_margin_m` on every side;
//! 4. **static**: no moving object (static world: rail, posts, road clutter);
//! 5. **displaced**: a moving object's return outside its box that is neither below ground nor
//!    behind a guardrail (other multipath, or a return smeared by range / angle errors).
//!
//! Classes 1, 2 and 5 are the ghosts.
//!
//! # Reported objects and real targets
//!
//! A reported object (`SensorData.moving_object` and `stationary_object`, positions in the sensor
//! frame) is **real** when its position lies in a ground-truth moving object's box grown by
//! `object_margin_m` (the radar estimates the box centre from the reflection centroid and the
//! class's typical size, which differs from the true size), else a
//! **ghost object** (counted per cycle, and per distinct tracking id). A ground-truth moving object
//! is **visible** in a cycle when at least `min_target_detections` of the cycle's detections are
//! real returns of it; a visible target not matched by any reported object is **missed** in that
//! cycle. A target visible in at least `late_frames` cycles and never reported is **lost**; one
//! first reported more than `late_frames` cycles after it was first visible is **late** (the
//! tracker's M-of-N confirmation alone delays the first report by `confirm_m − 1` cycles).

use glam::{DVec2, DVec3};
use osiris_proto::{osi3, perception};

use crate::error::ModelError;
use crate::frames::Pose;

/// Parameters of the ground-truth classification (margins are guessed: a few range / azimuth
/// resolution cells of the default waveform at 50 m).
#[derive(Debug, Clone, PartialEq)]
pub struct GhostStatsConfig {
    /// Height of the road surface, global frame, m (the road is taken as level).
    pub road_z_m: f64,
    /// A detection this far below the road is a below-ground ghost, m.
    pub ground_margin_m: f64,
    /// A detection this far beyond a guardrail's centre line is a mirror ghost, m.
    pub guardrail_margin_m: f64,
    /// A return of a moving object inside its box grown by this on every side is real, m.
    pub box_margin_m: f64,
    /// A reported object inside a ground-truth box grown by this matches it, m.
    pub object_margin_m: f64,
    /// Real detections of a ground-truth object that make it visible in a cycle.
    pub min_target_detections: usize,
    /// Cycles after the first visible one by which a target must be reported, else it is late.
    pub late_frames: usize,
    /// Substring of a stationary object's `model_reference` that marks a guardrail.
    pub guardrail_reference: String,
}

impl Default for GhostStatsConfig {
    fn default() -> Self {
        GhostStatsConfig {
            road_z_m: 0.0,
            ground_margin_m: 0.3,
            guardrail_margin_m: 0.5,
            box_margin_m: 0.5,
            object_margin_m: 1.5,
            min_target_detections: 2,
            late_frames: 5,
            guardrail_reference: "guardrail".into(),
        }
    }
}

impl GhostStatsConfig {
    /// Checks the values (keys named by their field).
    pub fn validate(&self) -> Result<(), ModelError> {
        for (key, v) in [
            ("ground_margin_m", self.ground_margin_m),
            ("guardrail_margin_m", self.guardrail_margin_m),
            ("box_margin_m", self.box_margin_m),
            ("object_margin_m", self.object_margin_m),
        ] {
            if !(v.is_finite() && v >= 0.0) {
                return Err(ModelError::Config(format!(
                    "ghost statistics: {key} must be a non-negative number (got {v})"
                )));
            }
        }
        if !self.road_z_m.is_finite() {
            return Err(ModelError::Config(format!(
                "ghost statistics: road_z_m must be finite (got {})",
                self.road_z_m
            )));
        }
        if self.min_target_detections == 0 {
            return Err(ModelError::Config(
                "ghost statistics: min_target_detections must be at least 1".into(),
            ));
        }
        Ok(())
    }
}

/// Ground-truth class of one detection (module documentation).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum DetectionClass {
    Real,
    Static,
    BehindGuardrail,
    BelowGround,
    Displaced,
}

impl DetectionClass {
    /// Whether the class is a ghost (below ground, behind a guardrail, displaced).
    pub fn is_ghost(self) -> bool {
        matches!(
            self,
            DetectionClass::BehindGuardrail
                | DetectionClass::BelowGround
                | DetectionClass::Displaced
        )
    }
}

/// The counts of a run (module documentation for the definitions).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct GhostCounts {
    pub frames: usize,
    /// Every detection of every cycle.
    pub detections: usize,
    pub real: usize,
    pub static_world: usize,
    pub behind_guardrail: usize,
    pub below_ground: usize,
    pub displaced: usize,
    /// Ghost detections the recognition assigned to a reported object (their OSI `object_id` set).
    pub ghost_detections_in_objects: usize,
    /// Reported objects, summed over the cycles.
    pub reported_objects: usize,
    /// Reported objects matching no ground-truth moving object, summed over the cycles.
    pub ghost_objects: usize,
    /// Of those, lying behind a guardrail.
    pub ghost_objects_behind_guardrail: usize,
    /// Of those, lying below the road.
    pub ghost_objects_below_ground: usize,
    /// Distinct tracking ids ever reported as a ghost object.
    pub ghost_tracks: usize,
    /// (target, cycle) pairs with the target visible.
    pub target_frames_visible: usize,
    /// Of those, not matched by a reported object.
    pub target_frames_missed: usize,
    /// Distinct targets visible in some cycle.
    pub targets_visible: usize,
    /// Targets visible in at least `late_frames` cycles and never reported.
    pub targets_lost: usize,
    /// Targets first reported more than `late_frames` cycles after first being visible.
    pub targets_late: usize,
}

impl GhostCounts {
    /// All ghost detections (below ground, behind a guardrail, displaced).
    pub fn ghost_detections(&self) -> usize {
        self.behind_guardrail + self.below_ground + self.displaced
    }
}

#[derive(Debug, Clone, Copy)]
struct Target {
    id: u64,
    first_visible: usize,
    frames_visible: usize,
    first_reported: Option<usize>,
}

#[derive(Debug, Clone, Copy)]
struct GtBox {
    id: u64,
    pose: Pose,
    half: DVec3,
}

impl GtBox {
    fn contains(&self, p_global: DVec3, margin: f64) -> bool {
        let q = self.pose.inverse_transform_point(p_global);
        q.x.abs() <= self.half.x + margin
            && q.y.abs() <= self.half.y + margin
            && q.z.abs() <= self.half.z + margin
    }
}

/// Accumulates [`GhostCounts`] over the cycles of a run (buffers reused across cycles).
#[derive(Debug, Clone)]
pub struct GhostStatistics {
    config: GhostStatsConfig,
    counts: GhostCounts,
    targets: Vec<Target>,
    ghost_track_ids: Vec<u64>,
    boxes: Vec<GtBox>,
    rails: Vec<(DVec2, DVec2)>,
    /// Per box of the cycle: its real detections.
    hits: Vec<usize>,
    /// Per box of the cycle: matched by a reported object.
    matched: Vec<bool>,
}

fn box_of(id: Option<&osi3::Identifier>, base: Option<&osi3::BaseMoving>) -> Option<GtBox> {
    let b = base?;
    let d = b.dimension.as_ref()?;
    Some(GtBox {
        id: id.and_then(|i| i.value)?,
        pose: Pose::from_osi(b.position.as_ref(), b.orientation.as_ref()),
        half: 0.5
            * DVec3::new(
                d.length.unwrap_or(0.0),
                d.width.unwrap_or(0.0),
                d.height.unwrap_or(0.0),
            ),
    })
}

/// Whether the x-y segment `sensor → p` crosses the segment `a → b` and `p` lies more than
/// `margin_m` beyond its line (perpendicular distance: along a grazing line of sight a small
/// azimuth error would move a rail return far "behind" it).
fn beyond(sensor: DVec2, p: DVec2, a: DVec2, b: DVec2, margin_m: f64) -> bool {
    let d = p - sensor;
    let e = b - a;
    let den = d.perp_dot(e);
    if den.abs() < 1e-12 {
        return false;
    }
    let w = a - sensor;
    let t = w.perp_dot(e) / den;
    let s = w.perp_dot(d) / den;
    let perpendicular = (p - a).perp_dot(e).abs() / e.length();
    (0.0..=1.0).contains(&s) && (0.0..1.0).contains(&t) && perpendicular > margin_m
}

impl GhostStatistics {
    pub fn new(config: GhostStatsConfig) -> Result<GhostStatistics, ModelError> {
        config.validate()?;
        Ok(GhostStatistics {
            config,
            counts: GhostCounts::default(),
            targets: Vec::new(),
            ghost_track_ids: Vec::new(),
            boxes: Vec::new(),
            rails: Vec::new(),
            hits: Vec::new(),
            matched: Vec::new(),
        })
    }

    /// The parameters.
    pub fn config(&self) -> &GhostStatsConfig {
        &self.config
    }

    /// Class of a detection at `p` (global frame) whose peak's ground truth is `object_id`
    /// (`None`: static world), seen from `sensor` (global frame), against the ground truth of the
    /// last [`GhostStatistics::add_frame`] (or of [`GhostStatistics::set_ground_truth`]).
    pub fn classify(&self, sensor: DVec3, p: DVec3, object_id: Option<u64>) -> DetectionClass {
        let c = &self.config;
        if p.z < c.road_z_m - c.ground_margin_m {
            return DetectionClass::BelowGround;
        }
        let (s2, p2) = (sensor.truncate(), p.truncate());
        if self
            .rails
            .iter()
            .any(|&(a, b)| beyond(s2, p2, a, b, c.guardrail_margin_m))
        {
            return DetectionClass::BehindGuardrail;
        }
        match object_id.and_then(|id| self.boxes.iter().find(|b| b.id == id)) {
            Some(b) if b.contains(p, c.box_margin_m) => DetectionClass::Real,
            Some(_) => DetectionClass::Displaced,
            None => DetectionClass::Static,
        }
    }

    /// Takes the ground truth's moving-object boxes (except the host's) and guardrail centre
    /// lines for [`GhostStatistics::classify`].
    pub fn set_ground_truth(&mut self, gt: &osi3::GroundTruth) {
        let host = gt.host_vehicle_id.as_ref().and_then(|i| i.value);
        self.boxes.clear();
        self.boxes.extend(
            gt.moving_object
                .iter()
                .filter_map(|o| box_of(o.id.as_ref(), o.base.as_ref()))
                .filter(|b| Some(b.id) != host),
        );
        self.rails.clear();
        for s in &gt.stationary_object {
            let is_rail = s
                .model_reference
                .as_deref()
                .is_some_and(|r| r.contains(&self.config.guardrail_reference));
            let Some(b) = s.base.as_ref().filter(|_| is_rail) else {
                continue;
            };
            let pose = Pose::from_osi(b.position.as_ref(), b.orientation.as_ref());
            let len = b.dimension.as_ref().and_then(|d| d.length).unwrap_or(0.0);
            let a = pose.transform_point(DVec3::new(-0.5 * len, 0.0, 0.0));
            let e = pose.transform_point(DVec3::new(0.5 * len, 0.0, 0.0));
            self.rails.push((a.truncate(), e.truncate()));
        }
    }

    /// One cycle: the ground truth the sensor saw, the sensor's pose (sensor frame → global), the
    /// cycle's `SensorData` (radar detections, reported objects) and the perception extension's
    /// radar block (the ground truth of each detection, index for index).
    pub fn add_frame(
        &mut self,
        gt: &osi3::GroundTruth,
        sensor_pose: &Pose,
        sensor_data: &osi3::SensorData,
        radar: &perception::RadarPerception,
    ) {
        self.set_ground_truth(gt);
        let frame = self.counts.frames;
        self.counts.frames += 1;
        self.hits.clear();
        self.hits.resize(self.boxes.len(), 0);
        self.matched.clear();
        self.matched.resize(self.boxes.len(), false);
        let sensor = sensor_pose.position;
        let dets = sensor_data
            .feature_data
            .as_ref()
            .and_then(|f| f.radar_sensor.first())
            .map(|s| s.detection.as_slice())
            .unwrap_or_default();
        for (d, peak) in dets.iter().zip(&radar.peak) {
            let Some(pos) = d.position.as_ref() else {
                continue;
            };
            let (r, az, el) = (
                pos.distance.unwrap_or(0.0),
                pos.azimuth.unwrap_or(0.0),
                pos.elevation.unwrap_or(0.0),
            );
            let p_s = r * DVec3::new(el.cos() * az.cos(), el.cos() * az.sin(), el.sin());
            let p = sensor_pose.transform_point(p_s);
            let oid = peak.object_id.as_ref().and_then(|i| i.value);
            // A return of no object (the road: clutter, `radar.road_clutter`) is static wherever
            // its range and angle errors put it; an object's return (moving, or a rail whose
            // tube a car → rail → radar path started from) is tested for the ghost classes.
            let class = if oid.is_some() {
                self.classify(sensor, p, oid)
            } else {
                DetectionClass::Static
            };
            let n = &mut self.counts;
            n.detections += 1;
            match class {
                DetectionClass::Real => {
                    n.real += 1;
                    if let Some(k) = self.boxes.iter().position(|b| Some(b.id) == oid) {
                        self.hits[k] += 1;
                    }
                }
                DetectionClass::Static => n.static_world += 1,
                DetectionClass::BehindGuardrail => n.behind_guardrail += 1,
                DetectionClass::BelowGround => n.below_ground += 1,
                DetectionClass::Displaced => n.displaced += 1,
            }
            if class.is_ghost() && d.object_id.as_ref().and_then(|i| i.value).is_some() {
                n.ghost_detections_in_objects += 1;
            }
        }
        let positions = sensor_data
            .moving_object
            .iter()
            .map(|o| {
                (
                    o.header.as_ref(),
                    o.base.as_ref().and_then(|b| b.position.as_ref()),
                )
            })
            .chain(sensor_data.stationary_object.iter().map(|o| {
                (
                    o.header.as_ref(),
                    o.base.as_ref().and_then(|b| b.position.as_ref()),
                )
            }));
        for (header, pos) in positions {
            let Some(pos) = pos else { continue };
            let p = sensor_pose.transform_point(crate::frames::vec3_from_osi(Some(pos)));
            self.counts.reported_objects += 1;
            let mut real = false;
            for (k, b) in self.boxes.iter().enumerate() {
                if b.contains(p, self.config.object_margin_m) {
                    self.matched[k] = true;
                    real = true;
                }
            }
            if real {
                continue;
            }
            self.counts.ghost_objects += 1;
            match self.classify(sensor, p, None) {
                DetectionClass::BelowGround => self.counts.ghost_objects_below_ground += 1,
                DetectionClass::BehindGuardrail => self.counts.ghost_objects_behind_guardrail += 1,
                _ => {}
            }
            if let Some(t) = header
                .and_then(|h| h.tracking_id.as_ref())
                .and_then(|i| i.value)
                && !self.ghost_track_ids.contains(&t)
            {
                self.ghost_track_ids.push(t);
            }
        }
        for (k, b) in self.boxes.iter().enumerate() {
            let visible = self.hits[k] >= self.config.min_target_detections;
            let reported = self.matched[k];
            let i = match self.targets.iter().position(|t| t.id == b.id) {
                Some(i) => i,
                None if visible => {
                    self.targets.push(Target {
                        id: b.id,
                        first_visible: frame,
                        frames_visible: 0,
                        first_reported: None,
                    });
                    self.targets.len() - 1
                }
                None => continue,
            };
            let t = &mut self.targets[i];
            if visible {
                t.frames_visible += 1;
                self.counts.target_frames_visible += 1;
                if !reported {
                    self.counts.target_frames_missed += 1;
                }
            }
            if reported && t.first_reported.is_none() {
                t.first_reported = Some(frame);
            }
        }
    }

    /// The counts so far.
    pub fn counts(&self) -> GhostCounts {
        let late = self.config.late_frames;
        let mut n = self.counts;
        n.ghost_tracks = self.ghost_track_ids.len();
        n.targets_visible = self.targets.len();
        n.targets_lost = self
            .targets
            .iter()
            .filter(|t| t.first_reported.is_none() && t.frames_visible >= late)
            .count();
        n.targets_late = self
            .targets
            .iter()
            .filter(|t| t.first_reported.is_some_and(|f| f > t.first_visible + late))
            .count();
        n
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn crossing_a_rail() {
        let (a, b) = (DVec2::new(0.0, -5.0), DVec2::new(100.0, -5.0));
        let s = DVec2::ZERO;
        assert!(beyond(s, DVec2::new(30.0, -8.0), a, b, 0.5));
        assert!(!beyond(s, DVec2::new(30.0, -5.2), a, b, 0.5));
        assert!(!beyond(s, DVec2::new(30.0, -3.0), a, b, 0.5));
        assert!(!beyond(s, DVec2::new(-30.0, -8.0), a, b, 0.5));
    }
}
