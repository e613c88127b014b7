//! Camera recognition of traffic lights, traffic signs, road markings and lane boundaries: what a
//! front camera exists to see, read from the rendered view (`physics.md §8`).
//!
//! Runs after [`super::camera::CameraRecognition::step`] on the same frame and reuses its pass
//! over the object mask (per ground-truth id: visible pixel count, box, summed luminance). The
//! ground truth is used for the entities' identity, class and standard size (what a recogniser's
//! map or class knowledge gives) and for the occlusion reference of lane-boundary points; never for
//! where an entity is reported: positions come from the image.
//!
//! # Traffic lights (one OSI `TrafficLight` per bulb)
//!
//! 1. **Visible**: the bulb's pixels in the mask (its lens; the renderer gives each bulb's lens its
//!    OSI id). A bulb with fewer than `light_min_px` pixels (6, guessed: a lens under ≈ 3 px across
//!    blurs into the neighbouring bulbs of its head through the lens's point-spread function) is
//!    not reported.
//! 2. **Lit or dark** (`physics.md §8.2`): `ρ = L_lens / L_ref` with `L_lens` the mean luminance of the brightest
//!    quarter of the lens pixels (at least one) and `L_ref` the median luminance of a ring of
//!    `max(1, ⌈d_px/4⌉)` px around the lens box, without the lens (the housing or back plate);
//!    lit iff `ρ ≥ light_lit_ratio` (guessed 2.0). A lit LED lens captured while its PWM is off
//!    (`camera.led_flicker` with an exposure shorter than the PWM period) has the luminance of a dark
//!    lens and is read as off: a **state misread** (counted per frame in `PerceptionData`).
//! 3. **Output** (`DetectedTrafficLight`; copied classifications drop their lane assignments,
//!    which name ground-truth lanes): colour = the bulb's colour (a recogniser knows which
//!    position of a head is red, yellow, green; the colour is not re-estimated from clipped pixels),
//!    icon from the ground truth, mode = `CONSTANT` (or the ground truth's `FLASHING`/`COUNTING`)
//!    when read lit, `OFF` when read dark; position = the lens box centre's ray at the distance
//!    `d = D f / d_px` from the lens's standard diameter `D` (the bulb's OSI width) and its
//!    apparent diameter `d_px` (pinhole size–distance relation, `physics.md §8.1`).
//!
//! # Traffic signs
//!
//! 1. **Plate rows**: a sign's mask pixels are its plate(s) and post; the plate is the topmost run
//!    of rows whose pixel count is at least `sign_plate_row_fraction` (0.3) of the widest row (the
//!    post is a few pixels wide).
//! 2. **Detection**: `p = σ_h · σ_C` with the size factor `σ_h = 1/(1 + (h₅₀/h)^{k_h})` of the plate's
//!    pixel height `h` and the contrast factor `σ_C = 1/(1 + (C₅₀/|C|)^{k_C})` of its Weber contrast
//!    against the ring around it (the same logistic forms as the object detector; `physics.md §8.3`); zero
//!    below `sign_min_height_px` or `sign_min_contrast`. Bernoulli draw seeded per (seed, cycle, id)
//!    or `p ≥ 0.5`, as the object detector.
//! 3. **Classification**: the main-sign type (the ground truth's classification) is reported only
//!    when the plate is at least `sign_classify_min_height_px` high (guessed 20 px; the smallest
//!    signs of the German Traffic Sign Recognition Benchmark are 15 px, Stallkamp et al., Neural
//!    Networks 32:323, 2012); smaller signs are reported with type `TYPE_UNKNOWN`.
//! 4. **Geometry** from the plate's fill of its box `φ` (circle π/4 ≈ 0.785, triangle ½, rectangle
//!    1): `φ ≥ 0.9` rectangle (square when the box is within 10 % of square), `0.7 ≤ φ < 0.9`
//!    circle, `0.35 ≤ φ < 0.7` triangle (point up when the top rows are the emptier ones), else
//!    other.
//! 5. **Position**: the plate box centre's ray at `d = H f_y / h` with the standard plate height `H`
//!    (the sign's OSI height).
//!
//! # Road markings
//!
//! A marking with at least `marking_min_px` visible pixels and |Weber contrast| ≥
//! `marking_min_contrast` against the ring around it is reported with the ground truth's
//! classification; its position is the box centre's ray intersected with the road plane at the
//! camera height (flat road, levelled with the rotation the camera believes it has).
//!
//! # Lane boundaries (from the painted markings' contrast, `physics.md §8.4`)
//!
//! Each ground-truth boundary with a painted type (solid or dashed, colour not none) is sampled
//! every `lane_sample_step_m` along its `boundary_line` up to `lane_max_range_m` from the camera.
//! A sample counts as seen when
//! * it projects into the image and the pixel's primary ray first hits at the sample's distance
//!   (|depth − r| ≤ `lane_depth_tolerance`·r + 0.3 m: not occluded, and in front of no object),
//! * the line is at least `lane_min_width_px` wide in the image (`w f_x / r`), and
//! * the pixel's Weber contrast against the mean of the two pixels `max(2, 2 w_px)` px to its left
//!   and right is at least `lane_min_contrast` (guessed 0.3: paint on asphalt in daylight has
//!   ~1–3; a dash gap has ~0).
//!
//! A boundary with at least `lane_min_points` seen samples is reported as a `DetectedLaneBoundary`:
//! the seen samples' pixel rays intersected with the road plane (sensor frame; the camera's own
//! ground-plane geometry, so its pitch and height errors show), a confidence per point from the
//! contrast (`σ_C`), and the ground truth's classification.

use glam::{DMat3, DVec3};
use osiris_proto::{id, osi3, perception};
use rand::{Rng as _, SeedableRng as _, rngs::SmallRng};
use serde::{Deserialize, Serialize};

use super::camera::{CameraRecognitionInput, Stats, ring_contrast};
use crate::error::{ModelError, check_range};
use crate::frames::{rotation_from_rpy, rpy_from_rotation, rpy_to_osi, vec3_to_osi};
use crate::rng::splitmix64;

/// Traffic-light, sign, marking and lane-boundary recognition parameters
/// (`"recognition": {"traffic": {...}}` of the camera config). Every default is guessed unless the
/// module doc names a source.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct TrafficRecognitionConfig {
    /// Smallest number of lens pixels for a bulb to be reported.
    pub light_min_px: u64,
    /// Lens-to-surround luminance ratio at and above which a bulb is read as lit.
    pub light_lit_ratio: f64,
    /// Smallest plate height for a sign to be detected, px.
    pub sign_min_height_px: f64,
    /// Plate height at which the size factor is 0.5, px.
    pub sign_height_50_px: f64,
    /// Exponent of the size factor.
    pub sign_height_slope: f64,
    /// Smallest |Weber contrast| of a plate against its surround.
    pub sign_min_contrast: f64,
    /// |Weber contrast| at which the contrast factor is 0.5.
    pub sign_contrast_50: f64,
    /// Exponent of the contrast factor.
    pub sign_contrast_slope: f64,
    /// Smallest plate height at which the main-sign type is classified, px.
    pub sign_classify_min_height_px: f64,
    /// A row belongs to the plate when its pixel count is at least this fraction of the widest row.
    pub sign_plate_row_fraction: f64,
    /// Bernoulli draw with the detection probability (true) or detect iff p ≥ 0.5 (false).
    pub random_draw: bool,
    /// Smallest number of visible pixels of a road marking.
    pub marking_min_px: u64,
    /// Smallest |Weber contrast| of a road marking against its surround.
    pub marking_min_contrast: f64,
    /// Spacing of the lane-boundary samples along the line, m.
    pub lane_sample_step_m: f64,
    /// Farthest lane-boundary sample from the camera, m.
    pub lane_max_range_m: f64,
    /// Occlusion test: allowed |depth − distance| as a fraction of the distance (plus 0.3 m).
    pub lane_depth_tolerance: f64,
    /// Narrowest line in the image, px.
    pub lane_min_width_px: f64,
    /// Smallest Weber contrast of the paint against the road beside it.
    pub lane_min_contrast: f64,
    /// Fewest seen samples for a boundary to be reported.
    pub lane_min_points: usize,
    /// Line width used when the boundary has none, m (the scene's default marking width).
    pub lane_default_width_m: f64,
}

impl Default for TrafficRecognitionConfig {
    fn default() -> Self {
        TrafficRecognitionConfig {
            light_min_px: 6,
            light_lit_ratio: 2.0,
            sign_min_height_px: 10.0,
            sign_height_50_px: 16.0,
            sign_height_slope: 4.0,
            sign_min_contrast: 0.05,
            sign_contrast_50: 0.2,
            sign_contrast_slope: 2.0,
            sign_classify_min_height_px: 20.0,
            sign_plate_row_fraction: 0.3,
            random_draw: true,
            marking_min_px: 12,
            marking_min_contrast: 0.2,
            lane_sample_step_m: 2.0,
            lane_max_range_m: 60.0,
            lane_depth_tolerance: 0.05,
            lane_min_width_px: 1.0,
            lane_min_contrast: 0.3,
            lane_min_points: 3,
            lane_default_width_m: 0.12,
        }
    }
}

impl TrafficRecognitionConfig {
    pub fn validate(&self) -> Result<(), ModelError> {
        let check = |key: &str, v: f64, lo: f64, hi: f64| {
            check_range("camera.recognition.traffic", key, v, lo, hi)
        };
        check("light_min_px", self.light_min_px as f64, 1.0, 1e6)?;
        check("light_lit_ratio", self.light_lit_ratio, 1.0, 1e6)?;
        check("sign_min_height_px", self.sign_min_height_px, 0.0, 1e5)?;
        check("sign_height_50_px", self.sign_height_50_px, 1e-3, 1e5)?;
        check("sign_height_slope", self.sign_height_slope, 0.0, 100.0)?;
        check("sign_min_contrast", self.sign_min_contrast, 0.0, 1e3)?;
        check("sign_contrast_50", self.sign_contrast_50, 1e-6, 1e3)?;
        check("sign_contrast_slope", self.sign_contrast_slope, 0.0, 100.0)?;
        check(
            "sign_classify_min_height_px",
            self.sign_classify_min_height_px,
            0.0,
            1e5,
        )?;
        check(
            "sign_plate_row_fraction",
            self.sign_plate_row_fraction,
            0.0,
            1.0,
        )?;
        check("marking_min_px", self.marking_min_px as f64, 1.0, 1e9)?;
        check("marking_min_contrast", self.marking_min_contrast, 0.0, 1e3)?;
        check("lane_sample_step_m", self.lane_sample_step_m, 0.05, 100.0)?;
        check("lane_max_range_m", self.lane_max_range_m, 1.0, 1e4)?;
        check("lane_depth_tolerance", self.lane_depth_tolerance, 0.0, 1.0)?;
        check("lane_min_width_px", self.lane_min_width_px, 0.0, 1e3)?;
        check("lane_min_contrast", self.lane_min_contrast, 0.0, 1e3)?;
        check("lane_min_points", self.lane_min_points as f64, 1.0, 1e6)?;
        check("lane_default_width_m", self.lane_default_width_m, 0.01, 5.0)?;
        Ok(())
    }

    /// Detection probability of a sign plate `height_px` high with Weber contrast `contrast`.
    pub fn sign_probability(&self, height_px: f64, contrast: f64) -> f64 {
        if height_px < self.sign_min_height_px || !contrast.is_finite() {
            return 0.0;
        }
        let c = contrast.abs();
        if c < self.sign_min_contrast || c <= 0.0 {
            return 0.0;
        }
        let s_h = 1.0 / (1.0 + (self.sign_height_50_px / height_px).powf(self.sign_height_slope));
        let s_c = 1.0 / (1.0 + (self.sign_contrast_50 / c).powf(self.sign_contrast_slope));
        (s_h * s_c).clamp(0.0, 1.0)
    }
}

/// What the traffic recognition reports for one frame.
#[derive(Debug, Clone, Default)]
pub struct TrafficOutput {
    pub traffic_light: Vec<osi3::DetectedTrafficLight>,
    pub traffic_sign: Vec<osi3::DetectedTrafficSign>,
    pub road_marking: Vec<osi3::DetectedRoadMarking>,
    pub lane_boundary: Vec<osi3::DetectedLaneBoundary>,
    /// Per bulb, sign and boundary measured (detected or not): the PerceptionData records.
    pub light_records: Vec<perception::CameraTrafficLight>,
    pub sign_records: Vec<perception::CameraTrafficSign>,
    pub lane_records: Vec<perception::CameraLaneBoundary>,
    /// Bulbs lit in the ground truth (mode CONSTANT or COUNTING) but read dark, and the reverse.
    pub state_misreads: u32,
}

impl TrafficOutput {
    pub fn clear(&mut self) {
        self.traffic_light.clear();
        self.traffic_sign.clear();
        self.road_marking.clear();
        self.lane_boundary.clear();
        self.light_records.clear();
        self.sign_records.clear();
        self.lane_records.clear();
        self.state_misreads = 0;
    }
}

/// The traffic recognition (plan once; buffers kept across frames).
pub struct TrafficRecognition {
    config: TrafficRecognitionConfig,
    scratch: Vec<f32>,
    rows: Vec<u32>,
}

fn gid(i: Option<&osi3::Identifier>) -> Option<u64> {
    i.and_then(|i| i.value)
}

fn header(gt_id: u64, p: f64) -> osi3::DetectedItemHeader {
    use osi3::detected_item_header::MeasurementState;
    osi3::DetectedItemHeader {
        tracking_id: Some(id(gt_id)),
        ground_truth_id: vec![id(gt_id)],
        existence_probability: Some(p),
        age: Some(0.0),
        measurement_state: Some(MeasurementState::Measured as i32),
        sensor_id: Vec::new(),
    }
}

fn base_stationary(position_s: DVec3, size: [f64; 3], rot_s: &DMat3) -> osi3::BaseStationary {
    osi3::BaseStationary {
        dimension: Some(osi3::Dimension3d {
            length: Some(size[0]),
            width: Some(size[1]),
            height: Some(size[2]),
        }),
        position: Some(vec3_to_osi(position_s)),
        orientation: Some(rpy_to_osi(rpy_from_rotation(rot_s))),
        ..Default::default()
    }
}

fn dims(b: Option<&osi3::BaseStationary>) -> Option<[f64; 3]> {
    let d = b?.dimension.as_ref()?;
    Some([d.length?, d.width?, d.height?]).filter(|d| d.iter().all(|v| v.is_finite()))
}

/// Median of `v` (reordered); NaN when empty.
fn median(v: &mut [f32]) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    let mid = v.len() / 2;
    let (_, m, _) = v.select_nth_unstable_by(mid, |a, b| a.total_cmp(b));
    *m as f64
}

/// The sign geometry from the plate's fill of its box and which half is emptier.
fn sign_geometry(
    fill: f64,
    aspect: f64,
    top_heavier: bool,
) -> osi3::detected_traffic_sign::detected_main_sign::Geometry {
    use osi3::detected_traffic_sign::detected_main_sign::Geometry as G;
    if fill >= 0.9 {
        if (aspect - 1.0).abs() <= 0.1 {
            G::Square
        } else {
            G::Rectangle
        }
    } else if fill >= 0.7 {
        G::Circle
    } else if fill >= 0.35 {
        if top_heavier {
            G::TriangleDown
        } else {
            G::TriangleTop
        }
    } else {
        G::Other
    }
}

impl TrafficRecognition {
    pub fn new(config: &TrafficRecognitionConfig) -> Result<TrafficRecognition, ModelError> {
        config.validate()?;
        Ok(TrafficRecognition {
            config: config.clone(),
            scratch: Vec::new(),
            rows: Vec::new(),
        })
    }

    pub fn config(&self) -> &TrafficRecognitionConfig {
        &self.config
    }

    /// Recognise the frame's lights, signs, markings and lane boundaries. `stats`: the object
    /// recognition's per-object-index pixel statistics of the same frame.
    pub(crate) fn step(
        &mut self,
        input: &CameraRecognitionInput<'_>,
        stats: &[Stats],
        out: &mut TrafficOutput,
    ) {
        out.clear();
        let lens = input.lens;
        let (w, h) = (lens.width(), lens.height());
        let n = w * h;
        let aux = input.aux;
        if n == 0 || aux.object_index.len() < n || lens.ray_directions().len() < n {
            return;
        }
        let lum = (input.luminance.len() >= n).then_some(input.luminance);
        let gt = input.ground_truth;
        let index_of = |gt_id: u64| -> Option<usize> {
            aux.object_ids
                .iter()
                .position(|&i| i == gt_id)
                .filter(|&k| stats.get(k).is_some_and(|s| s.count > 0))
        };
        for light in &gt.traffic_light {
            let Some(gt_id) = gid(light.id.as_ref()) else {
                continue;
            };
            if let Some(k) = index_of(gt_id) {
                self.light(input, lum, k, &stats[k], light, gt_id, out);
            }
        }
        for sign in &gt.traffic_sign {
            let Some(gt_id) = gid(sign.id.as_ref()) else {
                continue;
            };
            if let Some(k) = index_of(gt_id) {
                self.sign(input, lum, k, &stats[k], sign, gt_id, out);
            }
        }
        for marking in &gt.road_marking {
            let Some(gt_id) = gid(marking.id.as_ref()) else {
                continue;
            };
            if let Some(k) = index_of(gt_id) {
                self.marking(input, lum, k, &stats[k], marking, gt_id, out);
            }
        }
        if let Some(l) = lum {
            for b in &gt.lane_boundary {
                self.lane_boundary(input, l, b, out);
            }
        }
    }

    /// The pixel ray through the centre of a pixel-edge box, sensor frame.
    fn box_ray(input: &CameraRecognitionInput<'_>, s: &Stats) -> DVec3 {
        let w = input.lens.width();
        let u = (s.u_min + s.u_max) / 2;
        let v = (s.v_min + s.v_max) / 2;
        input.lens.ray_directions()[v * w + u]
            .as_dvec3()
            .normalize_or(DVec3::X)
    }

    /// Where the pixel ray `dir_s` (sensor frame) meets the road plane at the camera's believed
    /// height, sensor frame; None at or above the horizon.
    fn ground_point(input: &CameraRecognitionInput<'_>, dir_s: DVec3) -> Option<DVec3> {
        let r_s = input.reported_rotation;
        let d = r_s * dir_s;
        let horiz = d.truncate().length();
        if d.z >= -1e-6 || horiz <= 0.0 || input.camera_height_m <= 0.0 {
            return None;
        }
        let dist = input.camera_height_m * horiz / -d.z;
        let g = DVec3::new(
            d.x / horiz * dist,
            d.y / horiz * dist,
            -input.camera_height_m,
        );
        Some(r_s.transpose() * g)
    }

    fn draw(&self, input: &CameraRecognitionInput<'_>, gt_id: u64, p: f64) -> bool {
        if self.config.random_draw {
            let mut rng = SmallRng::seed_from_u64(
                input.seed ^ splitmix64(input.cycle) ^ splitmix64(gt_id.rotate_left(29) ^ 0x7A5F),
            );
            rng.random::<f64>() < p
        } else {
            p >= 0.5
        }
    }

    #[allow(clippy::too_many_arguments)]
    fn light(
        &mut self,
        input: &CameraRecognitionInput<'_>,
        lum: Option<&[f32]>,
        k: usize,
        s: &Stats,
        light: &osi3::TrafficLight,
        gt_id: u64,
        out: &mut TrafficOutput,
    ) {
        use osi3::traffic_light::classification::Mode;
        let cfg = &self.config;
        let (w, h) = (input.lens.width(), input.lens.height());
        let aux = input.aux;
        let class = light.classification.clone().unwrap_or_default();
        let mode = class.mode.unwrap_or(Mode::Unknown as i32);
        let truth_lit = mode == Mode::Constant as i32 || mode == Mode::Counting as i32;
        let truth_known = truth_lit || mode == Mode::Off as i32;
        let box_w = s.u_max - s.u_min + 1;
        let box_h = s.v_max - s.v_min + 1;
        let d_px = box_w.max(box_h) as f64;
        let mut record = perception::CameraTrafficLight {
            object_id: Some(gt_id),
            lens_px: Some(s.count as u32),
            lit_truth: truth_known.then_some(truth_lit),
            ..Default::default()
        };
        let Some(l) = lum.filter(|_| s.count >= cfg.light_min_px) else {
            record.detected = Some(false);
            out.light_records.push(record);
            return;
        };
        // L_lens: the brightest quarter of the lens pixels.
        self.scratch.clear();
        for v in s.v_min..=s.v_max {
            for u in s.u_min..=s.u_max {
                let i = v * w + u;
                if aux.object_index[i] == k as u32 {
                    self.scratch.push(l[i]);
                }
            }
        }
        self.scratch.sort_unstable_by(|a, b| b.total_cmp(a));
        let top = (self.scratch.len() / 4).max(1);
        let l_lens = self.scratch[..top].iter().map(|&x| x as f64).sum::<f64>() / top as f64;
        // L_ref: the median of the ring around the lens box.
        let ring = ((d_px / 4.0).ceil() as usize).max(1);
        let (u0, u1) = (s.u_min.saturating_sub(ring), (s.u_max + ring).min(w - 1));
        let (v0, v1) = (s.v_min.saturating_sub(ring), (s.v_max + ring).min(h - 1));
        self.scratch.clear();
        for v in v0..=v1 {
            for u in u0..=u1 {
                let inside = u >= s.u_min && u <= s.u_max && v >= s.v_min && v <= s.v_max;
                let i = v * w + u;
                if !inside && aux.object_index[i] != k as u32 {
                    self.scratch.push(l[i]);
                }
            }
        }
        let l_ref = median(&mut self.scratch);
        let ratio = if l_ref > 0.0 {
            l_lens / l_ref
        } else if l_lens > 0.0 {
            f64::INFINITY
        } else {
            0.0
        };
        let lit = ratio >= cfg.light_lit_ratio;
        let misread = truth_known && lit != truth_lit;
        if misread {
            out.state_misreads += 1;
        }
        record.lens_luminance_ratio = Some(if ratio.is_finite() { ratio } else { 1e9 });
        record.lit_measured = Some(lit);
        record.state_misread = Some(misread);
        record.detected = Some(true);
        out.light_records.push(record);

        // Position from the lens's standard diameter.
        let size = dims(light.base.as_ref()).unwrap_or([0.05, 0.2, 0.2]);
        let diameter_m = size[1].min(size[2]).max(0.01);
        let (fx, fy) = input.lens.focal_length_px();
        let f = 0.5 * (fx + fy);
        let dist = diameter_m * f / d_px;
        let ray = Self::box_ray(input, s);
        // The lens faces the camera: its optical axis (+x of the bulb frame) along −ray.
        let yaw = (-ray.y).atan2(-ray.x);
        let rot_s = rotation_from_rpy(0.0, 0.0, yaw);
        let measured_mode = if lit {
            if mode == Mode::Flashing as i32 || mode == Mode::Counting as i32 {
                mode
            } else {
                Mode::Constant as i32
            }
        } else {
            Mode::Off as i32
        };
        let classification = osi3::traffic_light::Classification {
            color: class.color,
            icon: class.icon,
            mode: Some(measured_mode),
            counter: None,
            assigned_lane_id: Vec::new(),
            is_out_of_service: class.is_out_of_service,
            logical_lane_assignment: Vec::new(),
        };
        out.traffic_light.push(osi3::DetectedTrafficLight {
            header: Some(header(gt_id, 1.0)),
            base: Some(base_stationary(ray * dist, size, &rot_s)),
            candidate: vec![osi3::detected_traffic_light::CandidateTrafficLight {
                probability: Some(1.0),
                classification: Some(classification),
            }],
            ..Default::default()
        });
    }

    #[allow(clippy::too_many_arguments)]
    fn sign(
        &mut self,
        input: &CameraRecognitionInput<'_>,
        lum: Option<&[f32]>,
        k: usize,
        s: &Stats,
        sign: &osi3::TrafficSign,
        gt_id: u64,
        out: &mut TrafficOutput,
    ) {
        use osi3::traffic_sign::main_sign::classification::Type;
        let cfg = &self.config;
        let (w, h) = (input.lens.width(), input.lens.height());
        let aux = input.aux;
        // 1. Plate rows: the topmost run of wide rows.
        self.rows.clear();
        for v in s.v_min..=s.v_max {
            let row = &aux.object_index[v * w + s.u_min..=v * w + s.u_max];
            self.rows
                .push(row.iter().filter(|&&o| o == k as u32).count() as u32);
        }
        let widest = self.rows.iter().copied().max().unwrap_or(0) as f64;
        let wide = |c: u32| c as f64 >= cfg.sign_plate_row_fraction * widest && c > 0;
        let Some(first) = self.rows.iter().position(|&c| wide(c)) else {
            return;
        };
        let last = first + self.rows[first..].iter().take_while(|&&c| wide(c)).count() - 1;
        let (pv0, pv1) = (s.v_min + first, s.v_min + last);
        let mut plate = Stats::default();
        for v in pv0..=pv1 {
            for u in s.u_min..=s.u_max {
                let i = v * w + u;
                if aux.object_index[i] == k as u32 {
                    plate.count += 1;
                    plate.u_min = plate.u_min.min(u);
                    plate.u_max = plate.u_max.max(u);
                    plate.v_min = plate.v_min.min(v);
                    plate.v_max = plate.v_max.max(v);
                    if let Some(l) = lum {
                        plate.lum_sum += l[i] as f64;
                    }
                }
            }
        }
        if plate.count == 0 {
            return;
        }
        let pw = (plate.u_max - plate.u_min + 1) as f64;
        let ph = (plate.v_max - plate.v_min + 1) as f64;
        // 2. Detection.
        let contrast = match lum {
            Some(l) => {
                let ring = 2usize.max((0.25 * pw.max(ph)).ceil() as usize);
                ring_contrast(aux, l, w, h, k as u32, &plate, ring)
            }
            None => f64::NAN,
        };
        let p = cfg.sign_probability(ph, contrast);
        let detected = p > 0.0 && self.draw(input, gt_id, p);
        let classified = ph >= cfg.sign_classify_min_height_px;
        out.sign_records.push(perception::CameraTrafficSign {
            object_id: Some(gt_id),
            height_px: Some(ph),
            contrast: Some(if contrast.is_finite() { contrast } else { 0.0 }),
            detection_probability: Some(p),
            classified: Some(detected && classified),
            detected: Some(detected),
        });
        if !detected {
            return;
        }
        // 3.–4. Classification and geometry.
        let main = sign.main_sign.clone().unwrap_or_default();
        let mut classification = main.classification.clone().unwrap_or_default();
        // Lane assignments name ground-truth lanes, which a SensorData does not carry.
        classification.assigned_lane_id.clear();
        classification.logical_lane_assignment.clear();
        if !classified {
            classification = osi3::traffic_sign::main_sign::Classification {
                r#type: Some(Type::Unknown as i32),
                ..Default::default()
            };
        }
        let fill = plate.count as f64 / (pw * ph);
        let half = (plate.v_min + plate.v_max) / 2;
        let (mut top, mut bottom) = (0u64, 0u64);
        for (r, &c) in self.rows[first..=last].iter().enumerate() {
            if pv0 + r <= half {
                top += c as u64;
            } else {
                bottom += c as u64;
            }
        }
        let geometry = sign_geometry(fill, pw / ph, top > bottom);
        // 5. Position from the standard plate height.
        let size = dims(main.base.as_ref()).unwrap_or([0.02, 0.6, 0.6]);
        let (_, fy) = input.lens.focal_length_px();
        let dist = size[2].max(0.05) * fy / ph;
        let ray = Self::box_ray(input, &plate);
        let yaw = (-ray.y).atan2(-ray.x);
        let rot_s = rotation_from_rpy(0.0, 0.0, yaw);
        use osi3::detected_traffic_sign::detected_main_sign::CandidateMainSign;
        out.traffic_sign.push(osi3::DetectedTrafficSign {
            header: Some(header(gt_id, p)),
            main_sign: Some(osi3::detected_traffic_sign::DetectedMainSign {
                candidate: vec![CandidateMainSign {
                    probability: Some(1.0),
                    classification: Some(classification),
                }],
                base: Some(base_stationary(ray * dist, size, &rot_s)),
                base_rmse: None,
                geometry: Some(geometry as i32),
            }),
            supplementary_sign: Vec::new(),
        });
    }

    #[allow(clippy::too_many_arguments)]
    fn marking(
        &mut self,
        input: &CameraRecognitionInput<'_>,
        lum: Option<&[f32]>,
        k: usize,
        s: &Stats,
        marking: &osi3::RoadMarking,
        gt_id: u64,
        out: &mut TrafficOutput,
    ) {
        let cfg = &self.config;
        let (w, h) = (input.lens.width(), input.lens.height());
        let Some(l) = lum else { return };
        if s.count < cfg.marking_min_px {
            return;
        }
        let bw = (s.u_max - s.u_min + 1) as f64;
        let bh = (s.v_max - s.v_min + 1) as f64;
        let ring = 2usize.max((0.25 * bw.max(bh)).ceil() as usize);
        let contrast = ring_contrast(input.aux, l, w, h, k as u32, s, ring);
        if contrast.is_nan() || contrast.abs() < cfg.marking_min_contrast {
            return;
        }
        let Some(ground) = Self::ground_point(input, Self::box_ray(input, s)) else {
            return;
        };
        let size = dims(marking.base.as_ref()).unwrap_or([1.0, 0.3, 0.001]);
        let p = (1.0 / (1.0 + (cfg.marking_min_contrast / contrast.abs()).powi(2))).min(1.0);
        out.road_marking.push(osi3::DetectedRoadMarking {
            header: Some(header(gt_id, p)),
            base: Some(base_stationary(
                ground,
                size,
                &input.reported_rotation.transpose(),
            )),
            candidate: vec![osi3::detected_road_marking::CandidateRoadMarking {
                probability: Some(1.0),
                classification: marking.classification.clone().map(|mut c| {
                    // Lane assignments name ground-truth lanes, which a SensorData does not carry.
                    c.assigned_lane_id.clear();
                    c.logical_lane_assignment.clear();
                    c
                }),
            }],
            ..Default::default()
        });
    }

    fn lane_boundary(
        &mut self,
        input: &CameraRecognitionInput<'_>,
        l: &[f32],
        b: &osi3::LaneBoundary,
        out: &mut TrafficOutput,
    ) {
        use osi3::lane_boundary::classification::{Color, Type};
        let cfg = &self.config;
        let Some(gt_id) = gid(b.id.as_ref()) else {
            return;
        };
        let class = b.classification.clone().unwrap_or_default();
        let painted = matches!(
            class.r#type,
            Some(t) if t == Type::SolidLine as i32 || t == Type::DashedLine as i32
        ) && class.color != Some(Color::None as i32);
        if !painted {
            return;
        }
        let lens = input.lens;
        let (w, h) = (lens.width(), lens.height());
        let (fx, _) = lens.focal_length_px();
        let frame = input.frame;
        let pts: Vec<(DVec3, f64)> = b
            .boundary_line
            .iter()
            .filter_map(|p| {
                let q = p.position.as_ref()?;
                let v = DVec3::new(q.x?, q.y?, q.z.unwrap_or(0.0));
                v.is_finite().then_some((
                    v,
                    p.width
                        .filter(|w| w.is_finite() && *w > 0.0)
                        .unwrap_or(cfg.lane_default_width_m),
                ))
            })
            .collect();
        let mut sampled = 0u32;
        let mut seen: Vec<(DVec3, f64)> = Vec::new();
        let mut contrast_sum = 0.0;
        let mut carry = 0.0;
        for seg in pts.windows(2) {
            let (a, wa) = seg[0];
            let (bb, wb) = seg[1];
            let len = (bb - a).length();
            if len <= 1e-9 {
                continue;
            }
            let mut t = carry;
            while t <= len {
                let f = t / len;
                let p_g = a.lerp(bb, f);
                let width_m = wa + (wb - wa) * f;
                t += cfg.lane_sample_step_m;
                let p_s = frame.point_to_sensor(p_g);
                let r = p_s.length();
                if r > cfg.lane_max_range_m || p_s.x <= 0.0 {
                    continue;
                }
                sampled += 1;
                let Some(px) = lens.project(p_s / r) else {
                    continue;
                };
                let (u, v) = (px.x.floor(), px.y.floor());
                if u < 0.0 || v < 0.0 || u >= w as f64 || v >= h as f64 {
                    continue;
                }
                let (u, v) = (u as usize, v as usize);
                let i = v * w + u;
                let depth = input.aux.depth_m.get(i).copied().unwrap_or(f32::INFINITY) as f64;
                if (depth - r).abs() > cfg.lane_depth_tolerance * r + 0.3 {
                    continue;
                }
                let width_px = width_m * fx / r;
                if width_px < cfg.lane_min_width_px {
                    continue;
                }
                let off = (2.0 * width_px).max(2.0).ceil() as usize;
                if u < off || u + off >= w {
                    continue;
                }
                let bg = 0.5 * (l[i - off] as f64 + l[i + off] as f64);
                let c = if bg > 0.0 {
                    (l[i] as f64 - bg) / bg
                } else {
                    0.0
                };
                if c < cfg.lane_min_contrast {
                    continue;
                }
                let Some(g) = Self::ground_point(input, lens.ray_directions()[i].as_dvec3()) else {
                    continue;
                };
                let conf = 1.0 / (1.0 + (cfg.lane_min_contrast / c).powi(2));
                contrast_sum += c;
                seen.push((g, conf));
            }
            carry = t - len;
        }
        out.lane_records.push(perception::CameraLaneBoundary {
            object_id: Some(gt_id),
            points_sampled: Some(sampled),
            points_detected: Some(seen.len() as u32),
            mean_contrast: Some(if seen.is_empty() {
                0.0
            } else {
                contrast_sum / seen.len() as f64
            }),
        });
        if seen.len() < cfg.lane_min_points {
            return;
        }
        let conf_mean = seen.iter().map(|s| s.1).sum::<f64>() / seen.len() as f64;
        out.lane_boundary.push(osi3::DetectedLaneBoundary {
            header: Some(header(gt_id, conf_mean)),
            candidate: vec![osi3::detected_lane_boundary::CandidateLaneBoundary {
                probability: Some(1.0),
                classification: Some(osi3::lane_boundary::Classification {
                    r#type: class.r#type,
                    color: class.color,
                    ..Default::default()
                }),
            }],
            boundary_line: seen
                .iter()
                .map(|(g, _)| osi3::lane_boundary::BoundaryPoint {
                    position: Some(vec3_to_osi(*g)),
                    ..Default::default()
                })
                .collect(),
            boundary_line_confidences: seen.iter().map(|s| s.1).collect(),
            ..Default::default()
        });
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn geometry_from_fill() {
        use osi3::detected_traffic_sign::detected_main_sign::Geometry as G;
        assert_eq!(
            sign_geometry(std::f64::consts::FRAC_PI_4, 1.0, false),
            G::Circle
        );
        assert_eq!(sign_geometry(0.5, 1.15, false), G::TriangleTop);
        assert_eq!(sign_geometry(0.5, 1.15, true), G::TriangleDown);
        assert_eq!(sign_geometry(0.98, 1.0, false), G::Square);
        assert_eq!(sign_geometry(0.98, 1.6, false), G::Rectangle);
    }

    #[test]
    fn sign_probability_thresholds() {
        let c = TrafficRecognitionConfig::default();
        assert_eq!(c.sign_probability(5.0, 1.0), 0.0);
        assert_eq!(c.sign_probability(50.0, 0.01), 0.0);
        // At h₅₀ and C₅₀ both factors are ½.
        let p = c.sign_probability(c.sign_height_50_px, c.sign_contrast_50);
        assert!((p - 0.25).abs() < 1e-12, "{p}");
    }

    // A synthetic view: an ideal pinhole camera 1.5 m above a flat road, looking along +x, with
    // a painted line, a traffic-light bulb and a sign drawn into the mask and luminance by hand.
    use super::super::camera::{
        CameraLens, CameraRecognition, CameraRecognitionConfig, PixelObjects,
    };
    use crate::frames::{Pose, SensorFrame};
    use glam::{DVec2, Vec3};

    struct Pinhole {
        w: usize,
        h: usize,
        f: f64,
        rays: Vec<Vec3>,
    }

    impl Pinhole {
        fn new(w: usize, h: usize, f: f64) -> Pinhole {
            let mut rays = Vec::with_capacity(w * h);
            for v in 0..h {
                for u in 0..w {
                    let (x, y) = (u as f64 + 0.5, v as f64 + 0.5);
                    let d = DVec3::new(f, w as f64 / 2.0 - x, h as f64 / 2.0 - y).normalize();
                    rays.push(d.as_vec3());
                }
            }
            Pinhole { w, h, f, rays }
        }
    }

    impl CameraLens for Pinhole {
        fn width(&self) -> usize {
            self.w
        }
        fn height(&self) -> usize {
            self.h
        }
        fn focal_length_px(&self) -> (f64, f64) {
            (self.f, self.f)
        }
        fn principal_point_px(&self) -> (f64, f64) {
            (self.w as f64 / 2.0, self.h as f64 / 2.0)
        }
        fn ray_directions(&self) -> &[Vec3] {
            &self.rays
        }
        fn project(&self, d: DVec3) -> Option<DVec2> {
            if d.x <= 0.0 {
                return None;
            }
            let u = self.w as f64 / 2.0 - self.f * d.y / d.x;
            let v = self.h as f64 / 2.0 - self.f * d.z / d.x;
            (u >= 0.0 && v >= 0.0 && u < self.w as f64 && v < self.h as f64)
                .then_some(DVec2::new(u, v))
        }
    }

    const CAM_H: f64 = 1.5;
    const LINE_Y: f64 = 1.75;
    const LINE_W: f64 = 0.15;

    struct View {
        lens: Pinhole,
        index: Vec<u32>,
        depth: Vec<f32>,
        lum: Vec<f32>,
        ids: Vec<u64>,
        gt: osi3::GroundTruth,
    }

    fn v3(x: f64, y: f64, z: f64) -> osi3::Vector3d {
        osi3::Vector3d {
            x: Some(x),
            y: Some(y),
            z: Some(z),
        }
    }

    /// Road (L 0.1) with a solid painted line at y = 1.75 m (L 0.6), a bulb of `lens_lum` in a
    /// dark housing (L 0.02) and a 0.6 m circular sign plate at 30 m.
    fn view(lens_lum: f32) -> View {
        use osi3::lane_boundary::classification::{Color, Type};
        use osi3::traffic_light::classification::{Color as LC, Mode};
        let lens = Pinhole::new(320, 200, 400.0);
        let (w, h) = (lens.w, lens.h);
        let mut index = vec![NO; w * h];
        let mut depth = vec![f32::INFINITY; w * h];
        let mut lum = vec![0.3f32; w * h];
        for (i, r) in lens.rays.iter().enumerate() {
            let d = r.as_dvec3();
            if d.z < 0.0 {
                let t = CAM_H / -d.z;
                let p = d * t;
                depth[i] = t as f32;
                lum[i] = if (p.y - LINE_Y).abs() <= LINE_W / 2.0 {
                    0.6
                } else {
                    0.1
                };
            }
        }
        // Bulb (id 500): a 0.2 m lens at (25, −2, 4) in a housing 0.35 m square.
        let bulb = DVec3::new(25.0, -2.0, 4.0 - CAM_H);
        let paint = |index: &mut Vec<u32>,
                     lum: &mut Vec<f32>,
                     depth: &mut Vec<f32>,
                     c: DVec3,
                     half_m: f64,
                     k: u32,
                     l: f32,
                     circle: bool| {
            let p = lens.project(c / c.length()).unwrap();
            let r = half_m * lens.f / c.x;
            for v in 0..h {
                for u in 0..w {
                    let (du, dv) = (u as f64 + 0.5 - p.x, v as f64 + 0.5 - p.y);
                    let inside = if circle {
                        du.hypot(dv) <= r
                    } else {
                        du.abs() <= r && dv.abs() <= r
                    };
                    if inside {
                        index[v * w + u] = k;
                        lum[v * w + u] = l;
                        depth[v * w + u] = c.length() as f32;
                    }
                }
            }
        };
        paint(
            &mut index, &mut lum, &mut depth, bulb, 0.175, NO, 0.02, false,
        );
        paint(
            &mut index, &mut lum, &mut depth, bulb, 0.10, 0, lens_lum, true,
        );
        // Sign (id 600): a 0.6 m circle at 13.33 m (18 px), 2 m up, left.
        let sign = DVec3::new(13.33, 4.0, 2.0 - CAM_H);
        paint(&mut index, &mut lum, &mut depth, sign, 0.30, 1, 0.9, true);
        let gt = osi3::GroundTruth {
            lane_boundary: vec![osi3::LaneBoundary {
                id: Some(id(300)),
                boundary_line: (0..=12)
                    .map(|i| osi3::lane_boundary::BoundaryPoint {
                        position: Some(v3(5.0 * i as f64, LINE_Y, -CAM_H)),
                        width: Some(LINE_W),
                        ..Default::default()
                    })
                    .collect(),
                classification: Some(osi3::lane_boundary::Classification {
                    r#type: Some(Type::SolidLine as i32),
                    color: Some(Color::White as i32),
                    ..Default::default()
                }),
                ..Default::default()
            }],
            traffic_light: vec![osi3::TrafficLight {
                id: Some(id(500)),
                base: Some(osi3::BaseStationary {
                    dimension: Some(osi3::Dimension3d {
                        length: Some(0.05),
                        width: Some(0.2),
                        height: Some(0.2),
                    }),
                    position: Some(v3(bulb.x, bulb.y, bulb.z)),
                    ..Default::default()
                }),
                classification: Some(osi3::traffic_light::Classification {
                    color: Some(LC::Red as i32),
                    mode: Some(Mode::Constant as i32),
                    ..Default::default()
                }),
                ..Default::default()
            }],
            traffic_sign: vec![osi3::TrafficSign {
                id: Some(id(600)),
                main_sign: Some(osi3::traffic_sign::MainSign {
                    base: Some(osi3::BaseStationary {
                        dimension: Some(osi3::Dimension3d {
                            length: Some(0.02),
                            width: Some(0.6),
                            height: Some(0.6),
                        }),
                        ..Default::default()
                    }),
                    classification: Some(osi3::traffic_sign::main_sign::Classification {
                        r#type: Some(
                            osi3::traffic_sign::main_sign::classification::Type::SpeedLimitBegin
                                as i32,
                        ),
                        ..Default::default()
                    }),
                    ..Default::default()
                }),
                ..Default::default()
            }],
            ..Default::default()
        };
        View {
            lens,
            index,
            depth,
            lum,
            ids: vec![500, 600],
            gt,
        }
    }

    const NO: u32 = super::super::camera::NO_OBJECT;

    fn run(v: &View, cfg: &TrafficRecognitionConfig) -> TrafficOutput {
        let frame = SensorFrame::at_rest(Pose::default());
        let input = CameraRecognitionInput {
            aux: PixelObjects {
                object_index: &v.index,
                depth_m: &v.depth,
                object_ids: &v.ids,
            },
            luminance: &v.lum,
            lens: &v.lens,
            ground_truth: &v.gt,
            frame: &frame,
            reported_rotation: DMat3::IDENTITY,
            camera_height_m: CAM_H,
            time_s: 0.0,
            seed: 1,
            cycle: 0,
        };
        let mut objects = CameraRecognition::new(&CameraRecognitionConfig::default()).unwrap();
        objects.step(&input, &mut Vec::new(), &mut Vec::new());
        let mut t = TrafficRecognition::new(cfg).unwrap();
        let mut out = TrafficOutput::default();
        t.step(&input, objects.pixel_stats(), &mut out);
        out
    }

    fn pos(b: Option<&osi3::BaseStationary>) -> DVec3 {
        let p = b.unwrap().position.as_ref().unwrap();
        DVec3::new(p.x.unwrap(), p.y.unwrap(), p.z.unwrap())
    }

    #[test]
    fn lit_bulb_is_read_lit_and_placed_by_its_size() {
        let out = run(&view(2.0), &TrafficRecognitionConfig::default());
        assert_eq!(out.traffic_light.len(), 1);
        assert_eq!(out.state_misreads, 0);
        let l = &out.traffic_light[0];
        let mode = l.candidate[0].classification.as_ref().unwrap().mode;
        assert_eq!(
            mode,
            Some(osi3::traffic_light::classification::Mode::Constant as i32)
        );
        // Lens ratio: 2.0 / 0.02 (median of the housing ring).
        let ratio = out.light_records[0].lens_luminance_ratio.unwrap();
        assert!((ratio - 100.0).abs() < 1.0, "{ratio}");
        // d = D f / d_px: the disc of 0.2 m at 25 m is 3.2 px; pixel rounding of the diameter
        // gives a distance within one pixel's share (±1/3.2 ≈ 31 %) of 25 m.
        let p = pos(l.base.as_ref());
        let r = p.length();
        assert!((r - 25.5).abs() < 0.35 * 25.5, "{p}");
        assert!((p.y / p.x - (-2.0 / 25.0)).abs() < 0.02, "{p}");
    }

    #[test]
    fn dark_captured_bulb_is_a_state_misread() {
        // The lens as dark as its housing: what a PWM-off capture of a lit LED gives.
        let out = run(&view(0.02), &TrafficRecognitionConfig::default());
        assert_eq!(out.state_misreads, 1);
        let l = &out.traffic_light[0];
        let mode = l.candidate[0].classification.as_ref().unwrap().mode;
        assert_eq!(
            mode,
            Some(osi3::traffic_light::classification::Mode::Off as i32)
        );
        assert_eq!(out.light_records[0].state_misread, Some(true));
    }

    #[test]
    fn sign_detected_classified_by_size_and_circle_geometry() {
        use osi3::detected_traffic_sign::detected_main_sign::Geometry;
        use osi3::traffic_sign::main_sign::classification::Type;
        let cfg = TrafficRecognitionConfig {
            random_draw: false,
            ..Default::default()
        };
        let out = run(&view(2.0), &cfg);
        assert_eq!(out.traffic_sign.len(), 1);
        let s = out.traffic_sign[0].main_sign.as_ref().unwrap();
        // 0.6 m at 13.33 m with f = 400 px: 18 px high, below the 20 px classification size.
        let h_px = out.sign_records[0].height_px.unwrap();
        assert!((h_px - 18.0).abs() <= 1.0, "{h_px}");
        let ty = s.candidate[0].classification.as_ref().unwrap().r#type;
        assert_eq!(ty, Some(Type::Unknown as i32));
        assert_eq!(s.geometry, Some(Geometry::Circle as i32));
        // Bigger in the image (a longer lens): classified with the ground truth's type.
        let cfg = TrafficRecognitionConfig {
            sign_classify_min_height_px: 6.0,
            ..cfg
        };
        let out = run(&view(2.0), &cfg);
        let s = out.traffic_sign[0].main_sign.as_ref().unwrap();
        let ty = s.candidate[0].classification.as_ref().unwrap().r#type;
        assert_eq!(ty, Some(Type::SpeedLimitBegin as i32));
        let p = pos(s.base.as_ref());
        assert!((p.length() - 13.9).abs() < 0.1 * 13.9, "{p}");
    }

    #[test]
    fn painted_line_points_on_the_road_at_its_lateral_offset() {
        let cfg = TrafficRecognitionConfig::default();
        let out = run(&view(2.0), &cfg);
        assert_eq!(out.lane_boundary.len(), 1);
        let b = &out.lane_boundary[0];
        // Samples every 2 m from 0 to 60 m ahead; those in view (x > 4.9 m: the image's lower
        // edge at 100 px below the centre, f = 400 px, h = 1.5 m → x = 1.5·400/100 = 6 m) and
        // at least 1 px wide (0.15·400/r ≥ 1 → r ≤ 60 m) are seen.
        assert!(b.boundary_line.len() >= 20, "{}", b.boundary_line.len());
        for p in &b.boundary_line {
            let q = p.position.as_ref().unwrap();
            let (x, y, z) = (q.x.unwrap(), q.y.unwrap(), q.z.unwrap());
            // Pixel quantisation: the pixel centre's ray, at most half a pixel off the line.
            let tol = 0.5 * x / 400.0 + LINE_W / 2.0;
            assert!((y - LINE_Y).abs() <= tol + 1e-9, "({x}, {y})");
            assert!((z + CAM_H).abs() < 1e-9);
        }
        // Without contrast (paint as dark as the road) nothing is seen.
        let mut v = view(2.0);
        for l in &mut v.lum {
            if (*l - 0.6).abs() < 1e-6 {
                *l = 0.1;
            }
        }
        let out = run(&v, &cfg);
        assert!(out.lane_boundary.is_empty());
        assert_eq!(out.lane_records[0].points_detected, Some(0));
    }
}
