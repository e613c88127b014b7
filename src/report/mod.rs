//! What a run's sensors saw: KPI tables (`objects.csv`, `frames.csv`) and a self-contained
//! `report.html`, built incrementally from one step at a time by [`ReportBuilder`] — fed by
//! `osiris run` (every sensor step) and by `osiris view` (every SensorData message of a trace).
//!
//! * [`kpi`]: ground truth in the field of view vs the reported detected objects;
//! * `html`: the report page (timelines, camera strip, bird's-eye views, range-Doppler map).
//!
//! See docs/report.md for the column definitions and what each plot shows.

mod html;
mod images;
pub mod kpi;
mod plots;
pub mod view;

use std::path::{Path, PathBuf};

use anyhow::{Context, Result};
use osiris_proto::{osi3, perception};

use kpi::{DetectedBox, FrameRow, ObjectRow};

/// The sensor technology a report section is drawn for.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SectionKind {
    Camera,
    Radar,
    Lidar,
    Other,
}

impl SectionKind {
    /// `camera`, `radar`, `lidar`, `other`.
    pub fn name(self) -> &'static str {
        match self {
            SectionKind::Camera => "camera",
            SectionKind::Radar => "radar",
            SectionKind::Lidar => "lidar",
            SectionKind::Other => "other",
        }
    }

    /// From a label (`camera`, `radar`, `lidar`; anything else: other).
    pub fn from_label(label: &str) -> SectionKind {
        match label {
            "camera" => SectionKind::Camera,
            "radar" => SectionKind::Radar,
            "lidar" => SectionKind::Lidar,
            _ => SectionKind::Other,
        }
    }

    /// Guess from what one step carries: the PerceptionData content, else the SensorData feature
    /// data, else the SensorView's technology view.
    fn infer(
        pd: Option<&perception::PerceptionData>,
        sd: &osi3::SensorData,
        sv: Option<&osi3::SensorView>,
    ) -> SectionKind {
        if let Some(pd) = pd {
            if pd.camera.is_some() {
                return SectionKind::Camera;
            }
            if pd.radar.is_some() {
                return SectionKind::Radar;
            }
            if pd.lidar.is_some() {
                return SectionKind::Lidar;
            }
        }
        if let Some(fd) = &sd.feature_data {
            if !fd.camera_sensor.is_empty() {
                return SectionKind::Camera;
            }
            if !fd.radar_sensor.is_empty() {
                return SectionKind::Radar;
            }
            if !fd.lidar_sensor.is_empty() {
                return SectionKind::Lidar;
            }
        }
        if let Some(sv) = sv {
            if !sv.camera_sensor_view.is_empty() {
                return SectionKind::Camera;
            }
            if !sv.radar_sensor_view.is_empty() {
                return SectionKind::Radar;
            }
            if !sv.lidar_sensor_view.is_empty() {
                return SectionKind::Lidar;
            }
        }
        SectionKind::Other
    }
}

/// One step of one sensor, as the report consumes it.
#[derive(Debug, Clone, Copy)]
pub struct ReportStep<'a> {
    /// Sensor (instance) name: one report section per name.
    pub sensor: &'a str,
    /// Time of the step, s (used when the SensorData has no timestamp).
    pub time_s: f64,
    /// The SensorView the sensor was given (`None`: no ground truth for this frame).
    pub sensor_view: Option<&'a osi3::SensorView>,
    pub sensor_data: &'a osi3::SensorData,
    pub perception: Option<&'a perception::PerceptionData>,
    /// Wall time of the sensor's FMU step, ms.
    pub step_wall_ms: Option<f64>,
}

/// Everything the report keeps of one sensor.
#[derive(Debug)]
pub struct SensorReport {
    pub name: String,
    pub kind: Option<SectionKind>,
    pub frames: Vec<FrameRow>,
    pub objects: Vec<ObjectRow>,
    /// Frames that had a SensorView with ground truth.
    pub frames_with_ground_truth: usize,
    /// The last frame's detected objects (sensor frame), for the bird's-eye views of sensors
    /// without richer data.
    pub last_boxes: Vec<DetectedBox>,
    /// Camera: evenly spaced ISP frames (every `camera_stride`-th SensorData frame).
    camera_shots: Vec<CameraShot>,
    camera_stride: usize,
    /// The frame drawn as bird's-eye view: the one with the most ground-truth objects in view plus
    /// detected objects (the first of equals; a radar frame with a range-Doppler map first).
    bev: Option<BevShot>,
    bev_score: Option<usize>,
}

/// Most camera frames kept while the run goes on (the strip shows [`CAMERA_STRIP_FRAMES`]).
const CAMERA_KEEP_MAX: usize = 12;
/// ISP frames in a camera section's strip.
pub const CAMERA_STRIP_FRAMES: usize = 6;
/// Most points of a LiDAR bird's-eye view.
pub const BEV_MAX_POINTS: usize = 30_000;

/// An ISP frame with the recognised objects' image boxes.
#[derive(Debug, Clone)]
struct CameraShot {
    frame: usize,
    time_s: f64,
    image: perception::CameraImage,
    /// (u_min, v_min, u_max, v_max) px and the ground-truth id.
    boxes: Vec<([f64; 4], u64)>,
    /// Ground truth in view projected with a pinhole camera of the declared horizontal field of
    /// view (approximate: the lens distortion is not known here): box and id.
    truth: Vec<([f64; 4], u64)>,
}

/// Image box (u_min, v_min, u_max, v_max) px of an upright ground-truth box seen by a pinhole camera
/// of horizontal field of view `fov` on a `width` × `height` image (principal point in the centre;
/// u right, v down); `None` when a corner is not in front of the camera or the box is off the image.
fn pinhole_box(o: &ObjectRow, fov: f64, width: f64, height: f64) -> Option<[f64; 4]> {
    let f = 0.5 * width / (0.5 * fov).tan();
    let [x, y, z] = o.gt_position_m;
    let (l, w, yaw) = (0.5 * o.gt_box[0], 0.5 * o.gt_box[1], o.gt_box[2]);
    let h = 0.5 * o.gt_height_m;
    let (s, c) = yaw.sin_cos();
    let mut b = [
        f64::INFINITY,
        f64::INFINITY,
        f64::NEG_INFINITY,
        f64::NEG_INFINITY,
    ];
    for (a, bb, dz) in [
        (l, w, h),
        (l, -w, h),
        (-l, w, h),
        (-l, -w, h),
        (l, w, -h),
        (l, -w, -h),
        (-l, w, -h),
        (-l, -w, -h),
    ] {
        let px = x + a * c - bb * s;
        let py = y + a * s + bb * c;
        let pz = z + dz;
        if px < 0.1 {
            return None;
        }
        let u = 0.5 * width - f * py / px;
        let v = 0.5 * height - f * pz / px;
        b = [b[0].min(u), b[1].min(v), b[2].max(u), b[3].max(v)];
    }
    let clipped = [
        b[0].max(0.0),
        b[1].max(0.0),
        b[2].min(width),
        b[3].min(height),
    ];
    (clipped[0] < clipped[2] && clipped[1] < clipped[3] && clipped.iter().all(|v| v.is_finite()))
        .then_some(clipped)
}

/// One frame's points, detections and boxes in the sensor frame.
#[derive(Debug, Clone, Default)]
struct BevShot {
    frame: usize,
    time_s: f64,
    /// (x, y, value): m, m, intensity or range rate.
    points: Vec<[f32; 3]>,
    /// What `points[..][2]` is.
    value_label: &'static str,
    /// Radar detections: (x m, y m, range rate m/s).
    detections: Vec<[f32; 3]>,
    boxes: Vec<DetectedBox>,
    truth: Vec<ObjectRow>,
    /// Range-Doppler map as PNG (range bins bottom-up, Doppler bins left to right) and
    /// (range bins, Doppler bins, range bin m, range-rate bin m/s).
    rd_png: Option<(Vec<u8>, [f64; 4])>,
}

/// Output files of [`ReportBuilder::write`].
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ReportPaths {
    pub objects_csv: PathBuf,
    pub frames_csv: PathBuf,
    pub report_html: Option<PathBuf>,
}

/// Incremental report of one or more sensors: [`ReportBuilder::push`] per step, then
/// [`ReportBuilder::write`].
#[derive(Debug, Default)]
pub struct ReportBuilder {
    sensors: Vec<SensorReport>,
    /// Where the input came from (shown in the report).
    pub title: String,
}

impl ReportBuilder {
    pub fn new(title: impl Into<String>) -> ReportBuilder {
        ReportBuilder {
            sensors: Vec::new(),
            title: title.into(),
        }
    }

    /// Declare a sensor (sections appear in declaration order; undeclared sensors are added by
    /// [`ReportBuilder::push`] in the order they first appear). `kind`: `None` = inferred from the
    /// first step.
    pub fn add_sensor(&mut self, name: &str, kind: Option<SectionKind>) {
        if let Some(s) = self.sensors.iter_mut().find(|s| s.name == name) {
            s.kind = kind.or(s.kind);
            return;
        }
        self.sensors.push(SensorReport {
            name: name.to_owned(),
            kind,
            frames: Vec::new(),
            objects: Vec::new(),
            frames_with_ground_truth: 0,
            last_boxes: Vec::new(),
            camera_shots: Vec::new(),
            camera_stride: 1,
            bev: None,
            bev_score: None,
        });
    }

    /// The sensors so far.
    pub fn sensors(&self) -> &[SensorReport] {
        &self.sensors
    }

    /// Add one SensorData frame of `step.sensor`.
    pub fn push(&mut self, step: ReportStep<'_>) {
        if !self.sensors.iter().any(|s| s.name == step.sensor) {
            self.add_sensor(step.sensor, None);
        }
        let Some(s) = self.sensors.iter_mut().find(|s| s.name == step.sensor) else {
            return;
        };
        if s.kind.is_none() {
            s.kind = Some(SectionKind::infer(
                step.perception,
                step.sensor_data,
                step.sensor_view,
            ));
        }
        let time_s = step
            .sensor_data
            .timestamp
            .as_ref()
            .map_or(step.time_s, |t| {
                t.seconds.unwrap_or(0) as f64 + 1e-9 * t.nanos.unwrap_or(0) as f64
            });
        let frame = s.frames.len();
        let (row, objects, boxes) = kpi::frame_rows(
            frame,
            time_s,
            step.sensor_view,
            step.sensor_data,
            step.step_wall_ms,
        );
        if row.ground_truth_in_fov.is_some() {
            s.frames_with_ground_truth += 1;
        }
        if let Some(cam) = step.perception.and_then(|p| p.camera.as_ref())
            && frame % s.camera_stride == 0
            && let Some(img) = cam.image.iter().find(|i| {
                i.kind() == perception::camera_image::Kind::Isp
                    && i.sample_format() == perception::camera_image::SampleFormat::U8
            })
        {
            s.camera_shots.push(CameraShot {
                frame,
                time_s,
                image: img.clone(),
                boxes: cam
                    .object
                    .iter()
                    .map(|o| {
                        (
                            [
                                o.box_u_min_px.unwrap_or(0.0),
                                o.box_v_min_px.unwrap_or(0.0),
                                o.box_u_max_px.unwrap_or(0.0),
                                o.box_v_max_px.unwrap_or(0.0),
                            ],
                            o.object_id.unwrap_or(0),
                        )
                    })
                    .collect(),
                truth: match step
                    .sensor_view
                    .and_then(kpi::ViewGeometry::of)
                    .and_then(|g| g.fov_horizontal_rad)
                {
                    Some(fov) => {
                        let (w, h) = (
                            f64::from(img.width_px.unwrap_or(0)),
                            f64::from(img.height_px.unwrap_or(0)),
                        );
                        objects
                            .iter()
                            .filter_map(|o| Some((pinhole_box(o, fov, w, h)?, o.gt_id)))
                            .collect()
                    }
                    None => Vec::new(),
                },
            });
            if s.camera_shots.len() > CAMERA_KEEP_MAX {
                s.camera_stride *= 2;
                let stride = s.camera_stride;
                s.camera_shots.retain(|c| c.frame % stride == 0);
            }
        }
        let score = objects.len() + boxes.len();
        let has_rd = step
            .perception
            .and_then(|p| p.radar.as_ref())
            .is_some_and(|r| r.range_doppler_map.is_some());
        let lacks_rd = s.bev.as_ref().is_some_and(|b| b.rd_png.is_none());
        if s.bev_score.is_none_or(|b| score > b) || (has_rd && lacks_rd) {
            s.bev_score = Some(score);
            s.bev = Some(bev_shot(frame, time_s, step, &boxes, &objects));
        }
        s.frames.push(row);
        s.objects.extend(objects);
        s.last_boxes = boxes;
    }

    /// `objects.csv` text.
    pub fn objects_csv(&self) -> String {
        let mut out = String::from(kpi::OBJECTS_HEADER);
        out.push('\n');
        for s in &self.sensors {
            for r in &s.objects {
                kpi::object_line(&mut out, &s.name, r);
            }
        }
        out
    }

    /// `frames.csv` text.
    pub fn frames_csv(&self) -> String {
        let mut out = String::from(kpi::FRAMES_HEADER);
        out.push('\n');
        for s in &self.sensors {
            for r in &s.frames {
                kpi::frame_line(&mut out, &s.name, r);
            }
        }
        out
    }

    /// Write `objects.csv`, `frames.csv` and, with `html`, `report.html` into `dir`.
    pub fn write(&self, dir: &Path, html: bool) -> Result<ReportPaths> {
        std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
        let objects_csv = dir.join("objects.csv");
        std::fs::write(&objects_csv, self.objects_csv())
            .with_context(|| format!("writing {}", objects_csv.display()))?;
        let frames_csv = dir.join("frames.csv");
        std::fs::write(&frames_csv, self.frames_csv())
            .with_context(|| format!("writing {}", frames_csv.display()))?;
        let report_html = if html {
            let path = dir.join("report.html");
            std::fs::write(&path, html::page(self))
                .with_context(|| format!("writing {}", path.display()))?;
            Some(path)
        } else {
            None
        };
        Ok(ReportPaths {
            objects_csv,
            frames_csv,
            report_html,
        })
    }
}

/// The bird's-eye-view content of one step.
fn bev_shot(
    frame: usize,
    time_s: f64,
    step: ReportStep<'_>,
    boxes: &[DetectedBox],
    truth: &[ObjectRow],
) -> BevShot {
    use osiris_models::frames::Spherical;
    let mut shot = BevShot {
        frame,
        time_s,
        value_label: "intensity",
        boxes: boxes.to_vec(),
        truth: truth.to_vec(),
        ..BevShot::default()
    };
    let lidar = step.perception.and_then(|p| p.lidar.as_ref());
    if let Some(l) = lidar.filter(|l| !l.x_m.is_empty()) {
        let n = l.x_m.len().min(l.y_m.len());
        let stride = n.div_ceil(BEV_MAX_POINTS).max(1);
        let fmcw = l.range_rate_m_s.len() == n;
        shot.value_label = if fmcw { "range rate m/s" } else { "intensity" };
        shot.points = (0..n)
            .step_by(stride)
            .map(|i| {
                let v = if fmcw {
                    l.range_rate_m_s[i]
                } else {
                    l.intensity.get(i).copied().unwrap_or(0.0)
                };
                [l.x_m[i], l.y_m[i], v]
            })
            .collect();
    } else if let Some(fd) = &step.sensor_data.feature_data {
        let dets: Vec<&osi3::LidarDetection> =
            fd.lidar_sensor.iter().flat_map(|d| &d.detection).collect();
        let stride = dets.len().div_ceil(BEV_MAX_POINTS).max(1);
        shot.points = dets
            .iter()
            .step_by(stride)
            .filter_map(|d| {
                let p = Spherical::from_osi(d.position.as_ref()?).to_cartesian();
                Some([p.x as f32, p.y as f32, d.intensity.unwrap_or(0.0) as f32])
            })
            .collect();
    }
    if let Some(fd) = &step.sensor_data.feature_data {
        shot.detections = fd
            .radar_sensor
            .iter()
            .flat_map(|d| &d.detection)
            .filter_map(|d| {
                let p = Spherical::from_osi(d.position.as_ref()?).to_cartesian();
                // OSI `radial_velocity` is the negative of the range rate (osiris models, OSI sign).
                Some([
                    p.x as f32,
                    p.y as f32,
                    -d.radial_velocity.unwrap_or(0.0) as f32,
                ])
            })
            .collect();
    }
    if let Some(map) = step
        .perception
        .and_then(|p| p.radar.as_ref())
        .and_then(|r| r.range_doppler_map.as_ref())
    {
        shot.rd_png = images::rd_png(map);
    }
    shot
}
