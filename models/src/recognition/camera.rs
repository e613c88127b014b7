//! Camera recognition: objects from the rendered view. For each ground-truth object the visible
//! pixel fraction (occlusion from the render), its contrast against the background and its size in
//! pixels give a detection probability; a detected object gets a 2D box from its visible pixels, a
//! class, a distance from the box and the camera height → OSI `DetectedMovingObject` plus the DIVP
//! camera recognition fields ([`perception::CameraObject`]).
//!
//! # Per frame ([`CameraRecognition::step`])
//!
//! 1. **Visible pixels**: one pass over the render's object mask ([`PixelObjects::object_index`])
//!    gives per object the visible pixel count, the 2D box of the visible pixels, the mean linear
//!    luminance and the nearest depth.
//! 2. **Occlusion reference**: the pixels the object *would* cover unoccluded are counted by
//!    intersecting every pixel ray of the lens ([`CameraLens::ray_directions`]) inside the projected
//!    ground-truth box ([`CameraLens::project`] of its corners) with that box (slab test). The visible
//!    fraction is `f = visible / expected` (ground-truth pose and size are used only here).
//! 3. **Contrast**: Weber contrast `C = (L_obj − L_bg)/L_bg` of the mean luminance of the
//!    object's pixels against the mean of each side (above, below, left, right) of a ring around
//!    its box (width `max(ring_min_px, ring_fraction · max(box w, box h))`), without the object's
//!    pixels; the side with the largest |contrast| counts (an outline is visible where it stands
//!    out from any part of its surroundings).
//! 4. **Detection probability**: `p_d = p_max · σ_f · σ_h · σ_C` with
//!    `σ_f = 1/(1 + exp(−k_f (f − f₅₀)))`, `σ_h = 1/(1 + (h₅₀/h)^{k_h})` (logistic in log pixel
//!    height), `σ_C = 1/(1 + (C₅₀/|C|)^{k_C})` (logistic in log contrast), and `p_d = 0` below the
//!    hard thresholds (min visible fraction, min height px, min |C|). The form follows the
//!    observation that detector miss rates rise steeply with falling pixel height (Dollár, Wojek,
//!    Schiele, Perona, "Pedestrian detection: an evaluation of the state of the art", IEEE PAMI
//!    34(4), 2012: near-scale ≥ 80 px detected well, far-scale ≤ 30 px mostly missed) and that
//!    detection needs a contrast above a threshold (Blackwell, JOSA 36(11), 1946); every
//!    coefficient is a guessed default, configurable.
//! 5. **Draw**: a Bernoulli draw with `p_d`, seeded per (seed, cycle, ground-truth id), so the
//!    result does not depend on scheduling (or `random_draw: false`: detected iff `p_d ≥ 0.5`).
//! 6. **Distance** (flat road): the bottom edge of the box (row `v_max + 1`, the pixel edge below
//!    the lowest visible pixel) gives the ray to the object's ground contact; with the camera
//!    height `h` and the depression angle α of that ray in the levelled sensor frame, the
//!    horizontal distance is `d = h / tan α` (pinhole ground-plane geometry, e.g. Stein, Mano,
//!    Shashua, "Vision-based ACC with a single camera: bounds on range and range rate accuracy",
//!    IEEE IV 2003). When the bottom is cut by the image border or hidden behind a nearer object,
//!    or the edge is above the horizon, the class's typical height `H` gives `d = H f_y / h_px`.
//!    **Tyres**: the lowest pixels of a four-wheeled vehicle (type codes 1–4, 10) are its tyres'
//!    road contact, not its near face: when the bottom rows of the box are sparsely filled
//!    (fill < `wheel_fill_max`, two tyres rather than a face reaching the road), the distance is
//!    reduced by the class's overhang `overhang_fraction · L`, weighted by how end-on the view is
//!    (`(L − w_box)/(L − W)` clamped to 0…1 with the box width `w_box = w_px·d/f_x` and the typical
//!    length L and width W: a side view keeps the contact distance).
//! 7. **Outputs**: [`perception::CameraObject`] in the sensor frame (x forward, y left, z up) with
//!    the reference point at the bottom centre of the visible face (the ground contact point);
//!    OSI `DetectedMovingObject` in the sensor frame (OSI SensorData: environment information in
//!    the virtual sensor frame of `mounting_position`, as the ideal model writes it):
//!    box centre = ground point + half the typical length along the horizontal line of sight +
//!    half the typical height up, dimension = the class's typical size, orientation along the line
//!    of sight (heading is not observed by a single frame), existence probability `p_d`, one
//!    candidate with the ground-truth type. No tracking: every frame stands alone (no velocity).
//!
//! Per-object buffers are kept across frames; the only per-pixel work is the mask pass, the
//! ring sums and the ray-box tests inside each object's projected box.

use crate::rng::splitmix64;
use glam::{DMat3, DVec2, DVec3};
use osiris_proto::{id, osi3, perception};
use rand::{Rng as _, SeedableRng as _, rngs::SmallRng};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crate::error::{ModelError, check_range};
use crate::frames::{
    SensorFrame, moving_object_pose, rotation_from_rpy, rpy_from_rotation, rpy_to_osi, vec3_to_osi,
};

/// Camera recognition parameters (`"recognition"` key of the camera config). Every default is a
/// guessed value (see the module doc for the model).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct CameraRecognitionConfig {
    /// Hard threshold: objects with a smaller visible fraction are not detected (0…1).
    pub min_visible_fraction: f64,
    /// Hard threshold: objects whose visible box is lower than this are not detected, px.
    pub min_height_px: f64,
    /// Hard threshold: objects with a smaller |Weber contrast| are not detected.
    pub min_contrast: f64,
    /// Visible fraction at which the occlusion factor is 0.5.
    pub visible_fraction_50: f64,
    /// Slope of the occlusion logistic, 1/(unit fraction).
    pub visible_fraction_slope: f64,
    /// Box height at which the size factor is 0.5, px.
    pub height_50_px: f64,
    /// Exponent of the size factor (slope of the logistic in ln px).
    pub height_slope: f64,
    /// |Weber contrast| at which the contrast factor is 0.5 for an object `height_50_px` high; larger
    /// objects need proportionally less (Blackwell 1946; guessed simplification).
    pub contrast_50: f64,
    /// Exponent of the contrast factor (slope of the logistic in ln |C|).
    pub contrast_slope: f64,
    /// Largest detection probability (residual miss rate of the detector).
    pub max_probability: f64,
    /// Bernoulli draw with p_d (true) or detect iff p_d ≥ 0.5 (false).
    pub random_draw: bool,
    /// Smallest width of the background ring around the box, px.
    pub ring_min_px: f64,
    /// Ring width as a fraction of the larger box side.
    pub ring_fraction: f64,
    /// Bottom rows of the box (fraction of its height, at least one row) whose object-pixel
    /// fill decides whether the lowest pixels are tyres (guessed).
    pub wheel_rows_fraction: f64,
    /// Fill of those rows below which the ground contact counts as tyres, not a face reaching
    /// the road (guessed: a box-like face fills them, two tyres about 25 %).
    pub wheel_fill_max: f64,
    /// Overhang from the axle to the near face of a four-wheeled vehicle, as a fraction of its
    /// typical length (guessed: 0.2, a 0.9 m overhang of a 4.5 m car; the `osiris:car` asset
    /// has its axles at ±0.30·l).
    pub overhang_fraction: f64,
    /// Traffic lights, signs, road markings and lane boundaries ([`super::traffic`]).
    pub traffic: super::traffic::TrafficRecognitionConfig,
}

impl Default for CameraRecognitionConfig {
    fn default() -> Self {
        CameraRecognitionConfig {
            min_visible_fraction: 0.1,
            min_height_px: 8.0,
            min_contrast: 0.02,
            visible_fraction_50: 0.3,
            visible_fraction_slope: 15.0,
            height_50_px: 15.0,
            height_slope: 4.0,
            contrast_50: 0.05,
            contrast_slope: 2.0,
            max_probability: 0.99,
            random_draw: true,
            ring_min_px: 3.0,
            ring_fraction: 0.25,
            wheel_rows_fraction: 0.05,
            wheel_fill_max: 0.6,
            overhang_fraction: 0.2,
            traffic: Default::default(),
        }
    }
}

impl CameraRecognitionConfig {
    pub fn validate(&self) -> Result<(), ModelError> {
        let check =
            |key: &str, v: f64, lo: f64, hi: f64| check_range("camera.recognition", key, v, lo, hi);
        check("min_visible_fraction", self.min_visible_fraction, 0.0, 1.0)?;
        check("min_height_px", self.min_height_px, 0.0, 1e5)?;
        check("min_contrast", self.min_contrast, 0.0, 1e3)?;
        check("visible_fraction_50", self.visible_fraction_50, 0.0, 1.0)?;
        check(
            "visible_fraction_slope",
            self.visible_fraction_slope,
            0.0,
            1e4,
        )?;
        check("height_50_px", self.height_50_px, 1e-3, 1e5)?;
        check("height_slope", self.height_slope, 0.0, 100.0)?;
        check("contrast_50", self.contrast_50, 1e-6, 1e3)?;
        check("contrast_slope", self.contrast_slope, 0.0, 100.0)?;
        check("max_probability", self.max_probability, 0.0, 1.0)?;
        check("ring_min_px", self.ring_min_px, 1.0, 1e4)?;
        check("ring_fraction", self.ring_fraction, 0.0, 10.0)?;
        check("wheel_rows_fraction", self.wheel_rows_fraction, 0.0, 1.0)?;
        check("wheel_fill_max", self.wheel_fill_max, 0.0, 1.0)?;
        check("overhang_fraction", self.overhang_fraction, 0.0, 0.5)?;
        self.traffic.validate()
    }

    /// Detection probability of an object with visible fraction `f`, box height `height_px` and
    /// Weber contrast `contrast` (NaN: unknown, the contrast factor is 1).
    pub fn detection_probability(&self, f: f64, height_px: f64, contrast: f64) -> f64 {
        let c = contrast.abs();
        if !(f >= self.min_visible_fraction && height_px >= self.min_height_px) {
            return 0.0;
        }
        if contrast.is_finite() && c < self.min_contrast {
            return 0.0;
        }
        let s_f =
            1.0 / (1.0 + (-self.visible_fraction_slope * (f - self.visible_fraction_50)).exp());
        let s_h = 1.0 / (1.0 + (self.height_50_px / height_px).powf(self.height_slope));
        // Larger targets are seen at lower contrast (Blackwell, JOSA 36(11):624, 1946: threshold
        // contrast falls with target size); here the 50 % contrast falls as 1/height above
        // `height_50_px` (a guessed simplification).
        let c50 = self.contrast_50 * (self.height_50_px / height_px).min(1.0);
        let s_c = if contrast.is_finite() {
            if c > 0.0 {
                1.0 / (1.0 + (c50 / c).powf(self.contrast_slope))
            } else {
                0.0
            }
        } else {
            1.0
        };
        (self.max_probability * s_f * s_h * s_c).clamp(0.0, 1.0)
    }
}

/// DIVP camera type code of a ground-truth moving object (DIVP FY2019 recognition interface,
/// after ISO/TC22/SC31/WG9): vehicles by classification 1 mini car (small car), 2 car (compact,
/// medium, luxury, van, unknown), 3 truck (heavy truck, semitractor/-trailer, trailer, work
/// machine), 4 bus (and tram), 5 motorcycle, 6 bicycle, 10 other vehicles; pedestrians 101 adult,
/// 102 child (box height < 1.3 m); animals 203; everything else 204.
pub fn divp_type_code(obj: &osi3::MovingObject) -> u32 {
    use osi3::moving_object::Type;
    use osi3::moving_object::vehicle_classification::Type as V;
    match obj.r#type.and_then(|t| Type::try_from(t).ok()) {
        Some(Type::Vehicle) => {
            let class = obj
                .vehicle_classification
                .as_ref()
                .and_then(|c| c.r#type)
                .and_then(|t| V::try_from(t).ok());
            match class {
                Some(V::SmallCar) => 1,
                Some(
                    V::HeavyTruck | V::Semitractor | V::Semitrailer | V::Trailer | V::WorkMachine,
                ) => 3,
                Some(V::Bus | V::Tram) => 4,
                Some(V::Motorbike) => 5,
                Some(V::Bicycle) => 6,
                Some(
                    V::Train
                    | V::Wheelchair
                    | V::StandupScooter
                    | V::MicromobilityDevice
                    | V::Watercraft
                    | V::Aircraft
                    | V::Other,
                ) => 10,
                _ => 2,
            }
        }
        Some(Type::Pedestrian) => {
            let h = obj
                .base
                .as_ref()
                .and_then(|b| b.dimension.as_ref())
                .and_then(|d| d.height)
                .unwrap_or(1.75);
            if h < 1.3 { 102 } else { 101 }
        }
        Some(Type::Animal) => 203,
        _ => 204,
    }
}

/// Typical (length, width, height) of a DIVP type code, m. Rounded typical values (guessed, not a
/// cited standard): mini car 3.4 × 1.48 × 1.6 (Japanese kei-car limits 3.4 × 1.48 × 2.0), car
/// 4.5 × 1.8 × 1.5, truck 10 × 2.5 × 3.5, bus 12 × 2.5 × 3.2, motorcycle 2.1 × 0.8 × 1.4,
/// bicycle 1.8 × 0.6 × 1.7, adult 0.6 × 0.6 × 1.75, child 0.4 × 0.4 × 1.1, animal 1.2 × 0.5 × 1.0,
/// other 1 m cube.
pub fn typical_size_m(type_code: u32) -> [f64; 3] {
    match type_code {
        1 => [3.4, 1.48, 1.6],
        2 | 10 => [4.5, 1.8, 1.5],
        3 => [10.0, 2.5, 3.5],
        4 => [12.0, 2.5, 3.2],
        5 => [2.1, 0.8, 1.4],
        6 => [1.8, 0.6, 1.7],
        101 => [0.6, 0.6, 1.75],
        102 => [0.4, 0.4, 1.1],
        203 => [1.2, 0.5, 1.0],
        _ => [1.0, 1.0, 1.0],
    }
}

/// No object at this pixel (sky, road, lane markings): the [`PixelObjects::object_index`] of a
/// pixel whose primary ray hit no object.
pub const NO_OBJECT: u32 = u32::MAX;

/// What recognition reads of the render: per-pixel object ids and depths, row-major (the camera's
/// `RenderAux` lends them, `RenderAux::objects`).
#[derive(Debug, Clone, Copy)]
pub struct PixelObjects<'a> {
    /// Index into `object_ids` of the object the pixel's primary ray hit, or [`NO_OBJECT`].
    pub object_index: &'a [u32],
    /// Distance along the primary ray to the first hit, m (`f32::INFINITY` for sky).
    pub depth_m: &'a [f32],
    /// Ground-truth ids (moving and stationary objects) referenced by `object_index`.
    pub object_ids: &'a [u64],
}

/// What recognition needs of the camera's lens (the camera's `Lens` implements it): the image size,
/// the pinhole parameters, the primary ray of every pixel and the lens's own projection.
pub trait CameraLens: Sync {
    /// Image width, px.
    fn width(&self) -> usize;
    /// Image height, px.
    fn height(&self) -> usize;
    /// Focal lengths (f_x, f_y) in pixels.
    fn focal_length_px(&self) -> (f64, f64);
    /// Principal point (c_x, c_y) in pixels (pixel centres at +0.5).
    fn principal_point_px(&self) -> (f64, f64);
    /// Unit primary-ray direction of every pixel centre in the sensor frame, row-major.
    fn ray_directions(&self) -> &[glam::Vec3];
    /// Image position (u right, v down, px) of a sensor-frame direction; None behind the camera
    /// or outside the image.
    fn project(&self, dir_sensor: DVec3) -> Option<DVec2>;
}

/// What recognition sees of one frame.
pub struct CameraRecognitionInput<'a> {
    /// Per-pixel object ids and depths of the render.
    pub aux: PixelObjects<'a>,
    /// Linear relative luminance per pixel (ISP, before tone mapping), row-major.
    pub luminance: &'a [f32],
    pub lens: &'a dyn CameraLens,
    /// The SensorView's ground truth (object classes and sizes; never their positions).
    pub ground_truth: &'a osi3::GroundTruth,
    /// The true sensor frame in global coordinates (where the ground truth projects into the
    /// image: the occlusion reference).
    pub frame: &'a SensorFrame,
    /// The sensor → global rotation the camera believes (its nominal mounting on the host,
    /// `WorldFrame::nominal_frame`): levels the pixel rays for the ground-plane distance. The same
    /// as `frame.pose.rotation` for a calibrated camera.
    pub reported_rotation: DMat3,
    /// Height of the camera's optical centre above the road as the camera believes it (its
    /// nominal mounting), m.
    pub camera_height_m: f64,
    pub time_s: f64,
    pub seed: u64,
    pub cycle: u64,
}

/// Per-object statistics of the visible pixels of one frame.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Stats {
    pub(crate) count: u64,
    pub(crate) u_min: usize,
    pub(crate) u_max: usize,
    pub(crate) v_min: usize,
    pub(crate) v_max: usize,
    pub(crate) lum_sum: f64,
    pub(crate) depth_min: f32,
}

impl Default for Stats {
    fn default() -> Self {
        Stats {
            count: 0,
            u_min: usize::MAX,
            u_max: 0,
            v_min: usize::MAX,
            v_max: 0,
            lum_sum: 0.0,
            depth_min: f32::INFINITY,
        }
    }
}

/// What recognition measured of one object in one frame (before the detection draw).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Measurement {
    /// Index into [`PixelObjects::object_ids`].
    pub object_index: u32,
    pub ground_truth_id: u64,
    pub visible_px: u64,
    /// Pixels of the unoccluded object (ray-box test of the ground-truth box).
    pub expected_px: u64,
    pub visible_fraction: f64,
    /// Weber contrast (NaN when no luminance was given).
    pub contrast: f64,
    /// Visible box: pixel-edge coordinates (u_min, v_min, u_max, v_max), px.
    pub box_px: [f64; 4],
    pub detection_probability: f64,
    pub detected: bool,
    /// Bottom-centre ground point of the visible face, sensor frame, m.
    pub ground_point_m: DVec3,
    /// Estimated object height, m.
    pub height_m: f64,
    /// Whether the distance came from the camera height (true) or the class height (false).
    pub from_ground_contact: bool,
    /// Overhang subtracted from the tyre-contact distance (0: none), m.
    pub overhang_m: f64,
}

/// Camera recognition (keeps its buffers across frames).
pub struct CameraRecognition {
    config: CameraRecognitionConfig,
    stats: Vec<Stats>,
    measurements: Vec<Measurement>,
}

/// Ray (from the origin) – oriented box slab test in box coordinates: does the ray hit the box?
fn ray_hits_box(origin_b: DVec3, dir_b: DVec3, half: DVec3) -> bool {
    let mut t0 = 0.0f64;
    let mut t1 = f64::INFINITY;
    for k in 0..3 {
        let o = origin_b[k];
        let d = dir_b[k];
        if d.abs() < 1e-12 {
            if o.abs() > half[k] {
                return false;
            }
        } else {
            let a = (-half[k] - o) / d;
            let b = (half[k] - o) / d;
            t0 = t0.max(a.min(b));
            t1 = t1.min(a.max(b));
            if t0 > t1 {
                return false;
            }
        }
    }
    true
}

impl CameraRecognition {
    pub fn new(config: &CameraRecognitionConfig) -> Result<CameraRecognition, ModelError> {
        config.validate()?;
        Ok(CameraRecognition {
            config: config.clone(),
            stats: Vec::new(),
            measurements: Vec::new(),
        })
    }

    /// The measurements of the last step (every ground-truth moving object seen in the render,
    /// detected or not).
    pub fn measurements(&self) -> &[Measurement] {
        &self.measurements
    }

    /// Recognise the objects of one frame: OSI objects (sensor frame, as OSI SensorData's
    /// `moving_object`) and the DIVP fields (sensor frame).
    pub fn step(
        &mut self,
        input: &CameraRecognitionInput<'_>,
        objects: &mut Vec<osi3::DetectedMovingObject>,
        divp: &mut Vec<perception::CameraObject>,
    ) {
        objects.clear();
        divp.clear();
        self.measurements.clear();
        let lens = input.lens;
        let (w, h) = (lens.width(), lens.height());
        let n = w * h;
        let aux = input.aux;
        if n == 0 || aux.object_index.len() < n || lens.ray_directions().len() < n {
            return;
        }
        let n_obj = aux.object_ids.len();
        self.stats.clear();
        self.stats.resize(n_obj, Stats::default());
        let lum = (input.luminance.len() >= n).then_some(input.luminance);

        // 1. Visible pixels: blocks of rows in parallel, merged in block order.
        const BLOCK_ROWS: usize = 32;
        let blocks: Vec<Vec<(u32, Stats)>> = (0..h.div_ceil(BLOCK_ROWS))
            .into_par_iter()
            .map(|b| {
                let mut local: Vec<(u32, Stats)> = Vec::new();
                // The object of the previous pixel (runs of one object are the rule).
                let mut last = usize::MAX;
                for v in b * BLOCK_ROWS..((b + 1) * BLOCK_ROWS).min(h) {
                    for u in 0..w {
                        let i = v * w + u;
                        let k = aux.object_index[i];
                        if k == NO_OBJECT || k as usize >= n_obj {
                            continue;
                        }
                        if last >= local.len() || local[last].0 != k {
                            last = match local.iter().position(|e| e.0 == k) {
                                Some(p) => p,
                                None => {
                                    local.push((k, Stats::default()));
                                    local.len() - 1
                                }
                            };
                        }
                        let s = &mut local[last].1;
                        s.count += 1;
                        s.u_min = s.u_min.min(u);
                        s.u_max = s.u_max.max(u);
                        s.v_min = s.v_min.min(v);
                        s.v_max = s.v_max.max(v);
                        if let Some(l) = lum {
                            s.lum_sum += l[i] as f64;
                        }
                        if let Some(&d) = aux.depth_m.get(i) {
                            s.depth_min = s.depth_min.min(d);
                        }
                    }
                }
                local
            })
            .collect();
        for (k, b) in blocks.into_iter().flatten() {
            let s = &mut self.stats[k as usize];
            s.count += b.count;
            s.u_min = s.u_min.min(b.u_min);
            s.u_max = s.u_max.max(b.u_max);
            s.v_min = s.v_min.min(b.v_min);
            s.v_max = s.v_max.max(b.v_max);
            s.lum_sum += b.lum_sum;
            s.depth_min = s.depth_min.min(b.depth_min);
        }

        let gt = input.ground_truth;
        let host_id = gt.host_vehicle_id.as_ref().and_then(|i| i.value);
        let frame = input.frame;
        let rays = lens.ray_directions();
        let (fx, fy) = lens.focal_length_px();
        // The camera levels its rays with the rotation it believes it has (a pitch error of the
        // mounting biases the ground-plane distance, as on a real camera).
        let r_s = input.reported_rotation;
        // Elevation tangent of a pixel ray in the levelled frame (global axes), and its
        // horizontal direction (sensor frame).
        let elev_tan = |u: usize, v: usize| -> f64 {
            let d = r_s * rays[v * w + u].as_dvec3();
            d.z / d.truncate().length().max(1e-12)
        };

        for (k, s) in self.stats.iter().enumerate() {
            if s.count == 0 {
                continue;
            }
            let gt_id = aux.object_ids[k];
            if Some(gt_id) == host_id {
                continue;
            }
            let Some(obj) = gt
                .moving_object
                .iter()
                .find(|o| o.id.as_ref().and_then(|i| i.value) == Some(gt_id))
            else {
                continue;
            };
            let type_code = divp_type_code(obj);
            let typical = typical_size_m(type_code);

            // 2. Occlusion reference.
            let dim = obj.base.as_ref().and_then(|b| b.dimension.as_ref());
            let half = 0.5
                * DVec3::new(
                    dim.and_then(|d| d.length).unwrap_or(typical[0]),
                    dim.and_then(|d| d.width).unwrap_or(typical[1]),
                    dim.and_then(|d| d.height).unwrap_or(typical[2]),
                );
            let pose = moving_object_pose(obj);
            let centre_s = frame.point_to_sensor(pose.position);
            let rot_s = frame.rotation_to_sensor(&pose.rotation);
            let expected = expected_pixels(lens, centre_s, rot_s, half);
            let visible_fraction = if expected > 0 {
                (s.count as f64 / expected as f64).min(1.0)
            } else {
                1.0
            };

            // 3. Contrast.
            let box_w = (s.u_max - s.u_min + 1) as f64;
            let box_h = (s.v_max - s.v_min + 1) as f64;
            let contrast = match lum {
                Some(l) => {
                    let ring = self
                        .config
                        .ring_min_px
                        .max(self.config.ring_fraction * box_w.max(box_h))
                        .ceil() as usize;
                    ring_contrast(aux, l, w, h, k as u32, s, ring)
                }
                None => f64::NAN,
            };

            // 4.–5. Probability and draw.
            let p = self
                .config
                .detection_probability(visible_fraction, box_h, contrast);
            let detected = if self.config.random_draw {
                let mut rng = SmallRng::seed_from_u64(
                    input.seed
                        ^ splitmix64(input.cycle)
                        ^ splitmix64(gt_id.rotate_left(32) ^ 0x5EED),
                );
                rng.random::<f64>() < p
            } else {
                p >= 0.5
            };

            // 6. Distance.
            let u_c = ((s.u_min + s.u_max) / 2).min(w - 1);
            let t_row = |v: usize| elev_tan(u_c, v);
            let t_bottom = if s.v_max >= 1 {
                let a = t_row(s.v_max);
                a + 0.5 * (a - t_row(s.v_max - 1))
            } else {
                t_row(s.v_max)
            };
            let t_top = if s.v_min + 1 < h {
                let a = t_row(s.v_min);
                a + 0.5 * (a - t_row(s.v_min + 1))
            } else {
                t_row(s.v_min)
            };
            let bottom_cut = s.v_max + 1 >= h;
            let bottom_hidden = !bottom_cut
                && (s.u_min..=s.u_max).any(|u| {
                    let i = (s.v_max + 1) * w + u;
                    let o = aux.object_index[i];
                    o != NO_OBJECT
                        && o != k as u32
                        && aux.depth_m.get(i).is_some_and(|&d| d < s.depth_min)
                });
            let h_cam = input.camera_height_m;
            let dir_g = r_s * rays[s.v_max * w + u_c].as_dvec3();
            let horiz = DVec2::new(dir_g.x, dir_g.y).normalize_or(DVec2::X);
            let (dist, from_ground) =
                if !bottom_cut && !bottom_hidden && t_bottom < -1e-6 && h_cam > 0.0 {
                    (h_cam / -t_bottom, true)
                } else {
                    (typical[2] * fy / box_h.max(1.0), false)
                };
            let height_m = (dist * (t_top - t_bottom)).max(0.0);
            // Tyre contact → near face of a four-wheeled vehicle (see the module doc).
            let mut overhang_m = 0.0;
            if from_ground && matches!(type_code, 1..=4 | 10) {
                let rows = ((self.config.wheel_rows_fraction * box_h).round() as usize)
                    .clamp(1, s.v_max - s.v_min + 1);
                let mut filled = 0usize;
                for v in s.v_max + 1 - rows..=s.v_max {
                    filled += aux.object_index[v * w + s.u_min..=v * w + s.u_max]
                        .iter()
                        .filter(|&&o| o == k as u32)
                        .count();
                }
                let fill = filled as f64 / (rows as f64 * box_w);
                if fill < self.config.wheel_fill_max {
                    let width_m = box_w * dist / fx;
                    let (l, wd) = (typical[0], typical[1]);
                    let end_on = ((l - width_m) / (l - wd).max(1e-6)).clamp(0.0, 1.0);
                    overhang_m = self.config.overhang_fraction * l * end_on;
                }
            }
            let dist = (dist - overhang_m).max(0.0);
            let ground_g = DVec3::new(horiz.x * dist, horiz.y * dist, -h_cam);
            let ground_s = r_s.transpose() * ground_g;

            self.measurements.push(Measurement {
                object_index: k as u32,
                ground_truth_id: gt_id,
                visible_px: s.count,
                expected_px: expected,
                visible_fraction,
                contrast,
                box_px: [
                    s.u_min as f64,
                    s.v_min as f64,
                    (s.u_max + 1) as f64,
                    (s.v_max + 1) as f64,
                ],
                detection_probability: p,
                detected,
                ground_point_m: ground_s,
                height_m,
                from_ground_contact: from_ground,
                overhang_m,
            });
            if !detected {
                continue;
            }

            // 7. Outputs.
            divp.push(perception::CameraObject {
                object_id: Some(gt_id),
                screen_width_px: Some(box_w as u32),
                screen_height_px: Some(box_h as u32),
                centre_u_px: Some((s.u_min + s.u_max).div_ceil(2) as u32),
                centre_v_px: Some((s.v_min + s.v_max).div_ceil(2) as u32),
                longitudinal_distance_m: Some(ground_s.x),
                lateral_distance_m: Some(ground_s.y),
                vertical_position_m: Some(ground_s.z),
                height_m: Some(height_m),
                type_code: Some(type_code),
                visible_fraction: Some(visible_fraction),
                contrast: Some(if contrast.is_finite() { contrast } else { 0.0 }),
                detection_probability: Some(p),
                box_u_min_px: Some(s.u_min as f64),
                box_v_min_px: Some(s.v_min as f64),
                box_u_max_px: Some((s.u_max + 1) as f64),
                box_v_max_px: Some((s.v_max + 1) as f64),
            });
            let centre_g = ground_g
                + DVec3::new(horiz.x, horiz.y, 0.0) * (0.5 * typical[0])
                + DVec3::Z * (0.5 * typical[2]);
            // OSI SensorData: environment information in the (virtual) sensor frame of
            // `mounting_position`, as the ideal model and the LiDAR/radar recognition write it.
            let centre_s = r_s.transpose() * centre_g;
            let rot_los: DMat3 = rotation_from_rpy(0.0, 0.0, horiz.y.atan2(horiz.x));
            let rot_s = r_s.transpose() * rot_los;
            objects.push(osi_object(obj, gt_id, p, centre_s, &rot_s, typical));
        }
    }

    /// Per object index of the last step's pixel mask: its visible-pixel statistics.
    pub(crate) fn pixel_stats(&self) -> &[Stats] {
        &self.stats
    }

    pub fn reset(&mut self) {
        self.stats.clear();
        self.measurements.clear();
    }
}

/// Pixels whose lens ray hits the box (sensor-frame centre, box → sensor rotation, half extents).
fn expected_pixels(lens: &dyn CameraLens, centre_s: DVec3, rot_s: DMat3, half: DVec3) -> u64 {
    let (w, h) = (lens.width(), lens.height());
    let (fx, fy) = lens.focal_length_px();
    let (cx, cy) = lens.principal_point_px();
    let (mut u0, mut u1, mut v0, mut v1) = (
        f64::INFINITY,
        f64::NEG_INFINITY,
        f64::INFINITY,
        f64::NEG_INFINITY,
    );
    let mut behind = false;
    for corner in 0..8 {
        let sgn = |b: usize| if corner & b != 0 { 1.0 } else { -1.0 };
        let p = centre_s + rot_s * (half * DVec3::new(sgn(1), sgn(2), sgn(4)));
        if p.x <= 1e-6 {
            behind = true;
            break;
        }
        // The lens's own projection inside the image; the pinhole extrapolation outside.
        let q = lens
            .project(p)
            .unwrap_or_else(|| DVec2::new(cx - fx * p.y / p.x, cy - fy * p.z / p.x));
        u0 = u0.min(q.x);
        u1 = u1.max(q.x);
        v0 = v0.min(q.y);
        v1 = v1.max(q.y);
    }
    let (ua, ub, va, vb) = if behind {
        (0, w - 1, 0, h - 1)
    } else {
        let mu = 2.0 + 0.05 * (u1 - u0);
        let mv = 2.0 + 0.05 * (v1 - v0);
        let clamp = |x: f64, n: usize| x.clamp(0.0, (n - 1) as f64) as usize;
        if u1 + mu < 0.0 || v1 + mv < 0.0 || u0 - mu > w as f64 || v0 - mv > h as f64 {
            return 0;
        }
        (
            clamp(u0 - mu, w),
            clamp(u1 + mu, w),
            clamp(v0 - mv, h),
            clamp(v1 + mv, h),
        )
    };
    let rt = rot_s.transpose();
    let origin_b = rt * (-centre_s);
    let rays = lens.ray_directions();
    (va..=vb)
        .into_par_iter()
        .map(|v| {
            (ua..=ub)
                .filter(|&u| ray_hits_box(origin_b, rt * rays[v * w + u].as_dvec3(), half))
                .count() as u64
        })
        .sum()
}

/// Weber contrast of an object's mean luminance against the side of a ring of `ring` px around its
/// visible box (above, below, left, right, each without the object's pixels) whose mean differs
/// most (NaN when no side has enough pixels): step 3 of the module doc.
pub(crate) fn ring_contrast(
    aux: PixelObjects<'_>,
    l: &[f32],
    w: usize,
    h: usize,
    k: u32,
    s: &Stats,
    ring: usize,
) -> f64 {
    let (u0, u1) = (s.u_min.saturating_sub(ring), (s.u_max + ring).min(w - 1));
    let (v0, v1) = (s.v_min.saturating_sub(ring), (s.v_max + ring).min(h - 1));
    // Ring sums per side (above, below, left, right of the box): an outline
    // is seen where it contrasts with any part of its surroundings (sky above,
    // road below), which one mean over the whole ring would average away.
    let mut sum = [0.0f64; 4];
    let mut cnt = [0u64; 4];
    for v in v0..=v1 {
        for u in u0..=u1 {
            let inside = u >= s.u_min && u <= s.u_max && v >= s.v_min && v <= s.v_max;
            let i = v * w + u;
            if inside || aux.object_index[i] == k {
                continue;
            }
            let side = if v < s.v_min {
                0
            } else if v > s.v_max {
                1
            } else if u < s.u_min {
                2
            } else {
                3
            };
            sum[side] += l[i] as f64;
            cnt[side] += 1;
        }
    }
    let l_obj = s.lum_sum / s.count as f64;
    let min_side = (ring as u64).max(4);
    let mut best = f64::NAN;
    for side in 0..4 {
        if cnt[side] < min_side {
            continue;
        }
        let l_bg = sum[side] / cnt[side] as f64;
        let c = (l_obj - l_bg) / l_bg.max(1e-9 * l_obj.abs().max(1e-30));
        if best.is_nan() || c.abs() > best.abs() {
            best = c;
        }
    }
    best
}

/// The OSI detected object (sensor frame).
fn osi_object(
    obj: &osi3::MovingObject,
    gt_id: u64,
    p: f64,
    centre_host: DVec3,
    rot_host: &DMat3,
    size: [f64; 3],
) -> osi3::DetectedMovingObject {
    use osi3::detected_item_header::MeasurementState;
    use osi3::detected_moving_object::{CandidateMovingObject, ReferencePoint};
    osi3::DetectedMovingObject {
        header: Some(osi3::DetectedItemHeader {
            tracking_id: Some(id(gt_id)),
            ground_truth_id: vec![id(gt_id)],
            existence_probability: Some(p),
            age: Some(0.0),
            measurement_state: Some(MeasurementState::Measured as i32),
            sensor_id: Vec::new(),
        }),
        base: Some(osi3::BaseMoving {
            dimension: Some(osi3::Dimension3d {
                length: Some(size[0]),
                width: Some(size[1]),
                height: Some(size[2]),
            }),
            position: Some(vec3_to_osi(centre_host)),
            orientation: Some(rpy_to_osi(rpy_from_rotation(rot_host))),
            ..Default::default()
        }),
        reference_point: Some(ReferencePoint::Center as i32),
        candidate: vec![CandidateMovingObject {
            probability: Some(1.0),
            r#type: obj.r#type,
            vehicle_classification: obj.vehicle_classification.as_ref().map(|c| {
                osi3::moving_object::VehicleClassification {
                    r#type: c.r#type,
                    ..Default::default()
                }
            }),
            ..Default::default()
        }],
        ..Default::default()
    }
}
