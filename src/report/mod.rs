//! What a run's sensors saw: KPI tables (`objects.csv`, `frames.csv`) and a self-contained
//! `report.html`, built incrementally from one step at a time by [`ReportBuilder`] — fed by
//! `osiris run` (every sensor step) and by `osiris view` (every SensorData message of a trace).
//!
//! * [`kpi`]: ground truth in the field of view vs the reported detected objects;
//! * `html`: the report page (timelines, camera strip, bird's-eye views, range-Doppler map).
//!
//! See docs/report.md for the column definitions and what each plot shows.

pub mod kpi;

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

    /// Write `objects.csv` and `frames.csv` into `dir`.
    pub fn write(&self, dir: &Path) -> Result<ReportPaths> {
        std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
        let objects_csv = dir.join("objects.csv");
        std::fs::write(&objects_csv, self.objects_csv())
            .with_context(|| format!("writing {}", objects_csv.display()))?;
        let frames_csv = dir.join("frames.csv");
        std::fs::write(&frames_csv, self.frames_csv())
            .with_context(|| format!("writing {}", frames_csv.display()))?;
        Ok(ReportPaths {
            objects_csv,
            frames_csv,
            report_html: None,
        })
    }
}
