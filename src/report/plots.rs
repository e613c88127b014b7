//! The report's plots as inline SVG, drawn with `plotters` (SVG backend, no system fonts: the text
//! is left to the browser).

use plotters::coord::Shift;
use plotters::prelude::*;

use super::kpi::{DetectedBox, FrameRow, ObjectRow};
use super::{BevShot, SectionKind};

type PlotResult = Result<(), String>;

fn err<E: std::fmt::Display>(e: E) -> String {
    e.to_string()
}

/// Draw into an SVG string of `size` px; a drawing error gives a small SVG saying so (the report
/// stays readable).
fn svg(
    size: (u32, u32),
    draw: impl FnOnce(&DrawingArea<SVGBackend<'_>, Shift>) -> PlotResult,
) -> String {
    let mut out = String::new();
    let result = {
        let root = SVGBackend::with_string(&mut out, size).into_drawing_area();
        let r = root
            .fill(&WHITE)
            .map_err(err)
            .and_then(|()| draw(&root))
            .and_then(|()| root.present().map_err(err));
        drop(root);
        r
    };
    match result {
        Ok(()) => out,
        Err(e) => format!(
            r#"<svg xmlns="http://www.w3.org/2000/svg" width="{}" height="40"><text x="4" y="20" font-size="12">plot failed: {}</text></svg>"#,
            size.0,
            super::html::escape(&e)
        ),
    }
}

const FONT: &str = "sans-serif";
const GT_COLOUR: RGBColor = RGBColor(0, 150, 60);
const DET_COLOUR: RGBColor = RGBColor(220, 60, 20);
const FA_COLOUR: RGBColor = RGBColor(200, 0, 160);

fn upper(v: impl Iterator<Item = f64>, min: f64) -> f64 {
    v.filter(|x| x.is_finite()).fold(min, f64::max)
}

/// One count of a [`FrameRow`].
type FrameValue = Box<dyn Fn(&FrameRow) -> Option<usize>>;

/// Ground truth in view, detected, matched and false alarms per SensorData frame.
pub fn timeline(frames: &[FrameRow]) -> String {
    svg((900, 260), |root| {
        let n = frames.len().max(2) as f64;
        let ymax = upper(
            frames
                .iter()
                .map(|f| (f.detected_objects.max(f.ground_truth_in_fov.unwrap_or(0))) as f64),
            1.0,
        ) * 1.15;
        let mut chart = ChartBuilder::on(root)
            .caption("objects per frame", (FONT, 15))
            .margin(8)
            .x_label_area_size(32)
            .y_label_area_size(40)
            .build_cartesian_2d(0f64..n - 1.0, 0f64..ymax)
            .map_err(err)?;
        chart
            .configure_mesh()
            .x_desc("SensorData frame")
            .y_desc("objects")
            .draw()
            .map_err(err)?;
        let series: [(&str, RGBColor, FrameValue); 4] = [
            (
                "ground truth in view",
                BLACK,
                Box::new(|f| f.ground_truth_in_fov),
            ),
            (
                "detected objects",
                BLUE,
                Box::new(|f| Some(f.detected_objects)),
            ),
            ("matched", GT_COLOUR, Box::new(|f| f.matched_objects)),
            ("false alarms", FA_COLOUR, Box::new(|f| f.false_alarms)),
        ];
        for (label, colour, value) in series {
            let pts: Vec<(f64, f64)> = frames
                .iter()
                .filter_map(|f| value(f).map(|v| (f.frame as f64, v as f64)))
                .collect();
            if pts.is_empty() {
                continue;
            }
            chart
                .draw_series(LineSeries::new(pts, colour.stroke_width(2)))
                .map_err(err)?
                .label(label)
                .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], colour));
        }
        chart
            .configure_series_labels()
            .background_style(WHITE.mix(0.85))
            .border_style(BLACK)
            .position(SeriesLabelPosition::UpperRight)
            .draw()
            .map_err(err)
    })
}

/// Which ground-truth objects were detected in which frame: one row per ground-truth id (the
/// `MAX_IDS` seen most often), a dot per frame it was in view (filled: detected).
pub fn detections_per_object(objects: &[ObjectRow], n_frames: usize) -> String {
    const MAX_IDS: usize = 30;
    let mut ids: Vec<(u64, String, usize)> = Vec::new();
    for o in objects {
        match ids.iter_mut().find(|(i, _, _)| *i == o.gt_id) {
            Some(e) => e.2 += 1,
            None => ids.push((o.gt_id, o.gt_type.clone(), 1)),
        }
    }
    ids.sort_by(|a, b| b.2.cmp(&a.2).then(a.0.cmp(&b.0)));
    ids.truncate(MAX_IDS);
    ids.sort_by_key(|e| e.0);
    let rows = ids.len().max(1);
    let height = (80 + 18 * rows as u32).max(160);
    svg((900, height), |root| {
        let n = n_frames.max(2) as f64;
        let mut chart = ChartBuilder::on(root)
            .caption(
                "ground truth in view per frame (filled: detected)",
                (FONT, 15),
            )
            .margin(8)
            .x_label_area_size(32)
            .y_label_area_size(110)
            .build_cartesian_2d(-0.5f64..n - 0.5, -1i32..rows as i32)
            .map_err(err)?;
        let labels: Vec<String> = ids.iter().map(|(i, t, _)| format!("{i} {t}")).collect();
        chart
            .configure_mesh()
            .x_desc("SensorData frame")
            .y_labels(rows + 2)
            .y_label_formatter(&|v: &i32| {
                usize::try_from(*v)
                    .ok()
                    .and_then(|i| labels.get(i).cloned())
                    .unwrap_or_default()
            })
            .disable_y_mesh()
            .draw()
            .map_err(err)?;
        let row_of = |id: u64| ids.iter().position(|e| e.0 == id);
        chart
            .draw_series(objects.iter().filter_map(|o| {
                let r = row_of(o.gt_id)? as i32;
                let style = if o.detected.is_some() {
                    GT_COLOUR.filled()
                } else {
                    RGBColor(190, 190, 190).stroke_width(1)
                };
                Some(Circle::new((o.frame as f64, r), 3, style))
            }))
            .map_err(err)?;
        Ok(())
    })
}

/// Range error (detected − truth) of the detected ground-truth objects against the frame and
/// against the true range.
pub fn range_errors(objects: &[ObjectRow]) -> String {
    let pts: Vec<(f64, f64, f64)> = objects
        .iter()
        .filter_map(|o| {
            let r = o.detected.as_ref()?.range_m?;
            Some((o.frame as f64, o.gt_range_m, r - o.gt_range_m))
        })
        .collect();
    svg((900, 260), |root| {
        let (left, right) = root.split_horizontally(450);
        let e = upper(pts.iter().map(|p| p.2.abs()), 0.1) * 1.15;
        let fmax = upper(pts.iter().map(|p| p.0), 1.0);
        let rmax = upper(pts.iter().map(|p| p.1), 1.0) * 1.05;
        for (area, xmax, xdesc, pick) in [
            (&left, fmax, "SensorData frame", 0usize),
            (&right, rmax, "true range m", 1usize),
        ] {
            let mut chart = ChartBuilder::on(area)
                .caption(format!("range error m vs {xdesc}"), (FONT, 14))
                .margin(8)
                .x_label_area_size(32)
                .y_label_area_size(48)
                .build_cartesian_2d(0f64..xmax, -e..e)
                .map_err(err)?;
            chart
                .configure_mesh()
                .x_desc(xdesc)
                .y_desc("range error m")
                .draw()
                .map_err(err)?;
            chart
                .draw_series(pts.iter().map(|p| {
                    let x = if pick == 0 { p.0 } else { p.1 };
                    Circle::new((x, p.2), 2, DET_COLOUR.filled())
                }))
                .map_err(err)?;
        }
        Ok(())
    })
}

/// Colour of `t` in [0, 1]: blue → green → yellow → red.
fn ramp(t: f64) -> RGBColor {
    let t = t.clamp(0.0, 1.0);
    let hsl = HSLColor((1.0 - t) * 0.66, 0.9, 0.45);
    let (r, g, b) = hsl.rgb();
    RGBColor(r, g, b)
}

/// Corners of a box (centre, length, width, yaw) in the sensor frame, as bird's-eye coordinates
/// (lateral to the right, forward up).
fn box_outline(c: [f64; 3], l: f64, w: f64, yaw: f64) -> Vec<(f64, f64)> {
    let (s, co) = yaw.sin_cos();
    let (l, w) = (l.max(0.3) / 2.0, w.max(0.3) / 2.0);
    [(l, w), (l, -w), (-l, -w), (-l, w), (l, w)]
        .iter()
        .map(|(a, b)| {
            let x = c[0] + a * co - b * s;
            let y = c[1] + a * s + b * co;
            (-y, x)
        })
        .collect()
}

/// Bird's-eye view of one frame in the sensor frame: points (LiDAR, coloured by intensity or
/// range rate), radar detections with range-rate arrows, ground-truth boxes (green) and detected
/// boxes (red).
pub fn bev(shot: &BevShot, kind: SectionKind) -> String {
    let boxes: &[DetectedBox] = &shot.boxes;
    let mut fwd = 20f64;
    let mut lat = 10f64;
    let mut back = -5f64;
    let mut grow = |x: f64, y: f64| {
        if x.is_finite() && y.is_finite() && x.abs() < 400.0 && y.abs() < 400.0 {
            fwd = fwd.max(x);
            back = back.min(x);
            lat = lat.max(y.abs());
        }
    };
    for p in &shot.points {
        grow(p[0] as f64, p[1] as f64);
    }
    for d in &shot.detections {
        grow(d[0] as f64, d[1] as f64);
    }
    for b in boxes {
        if let Some(p) = b.position_m {
            grow(p[0], p[1]);
        }
    }
    for t in &shot.truth {
        grow(t.gt_position_m[0], t.gt_position_m[1]);
    }
    let (fwd, back, lat) = (fwd * 1.05 + 2.0, back * 1.05 - 2.0, lat * 1.05 + 2.0);
    let values: Vec<f64> = shot.points.iter().map(|p| p[2] as f64).collect();
    let signed = shot.value_label.starts_with("range rate");
    let vmax = if signed {
        upper(values.iter().map(|v| v.abs()), 1.0)
    } else {
        let mut sorted: Vec<f64> = values.iter().copied().filter(|v| v.is_finite()).collect();
        sorted.sort_by(f64::total_cmp);
        sorted
            .get(sorted.len().saturating_sub(1) * 99 / 100)
            .copied()
            .unwrap_or(1.0)
            .max(1e-9)
    };
    let rr_max = upper(shot.detections.iter().map(|d| (d[2] as f64).abs()), 1.0);
    let title = match kind {
        SectionKind::Lidar if !shot.points.is_empty() => format!(
            "bird's-eye view, frame {} (t = {:.3} s): {} points coloured by {}",
            shot.frame,
            shot.time_s,
            shot.points.len(),
            shot.value_label
        ),
        SectionKind::Radar => format!(
            "bird's-eye view, frame {} (t = {:.3} s): {} detections, colour and arrow = range rate",
            shot.frame,
            shot.time_s,
            shot.detections.len()
        ),
        _ => format!(
            "bird's-eye view, frame {} (t = {:.3} s)",
            shot.frame, shot.time_s
        ),
    };
    let aspect = (fwd - back) / (2.0 * lat);
    let width = 640u32;
    let height = ((width as f64 - 60.0) * aspect + 80.0).clamp(300.0, 900.0) as u32;
    svg((width, height), |root| {
        let mut chart = ChartBuilder::on(root)
            .caption(title, (FONT, 13))
            .margin(8)
            .x_label_area_size(32)
            .y_label_area_size(44)
            .build_cartesian_2d(-lat..lat, back..fwd)
            .map_err(err)?;
        chart
            .configure_mesh()
            .x_desc("right m (sensor frame: −y)")
            .y_desc("forward m (x)")
            .disable_mesh()
            .draw()
            .map_err(err)?;
        chart
            .draw_series(shot.points.iter().map(|p| {
                let v = p[2] as f64;
                let t = if signed {
                    0.5 + 0.5 * v / vmax
                } else {
                    v / vmax
                };
                Circle::new((-(p[1] as f64), p[0] as f64), 1, ramp(t).filled())
            }))
            .map_err(err)?;
        for d in &shot.detections {
            let (x, y, rr) = (d[0] as f64, d[1] as f64, d[2] as f64);
            let colour = ramp(0.5 + 0.5 * rr / rr_max);
            let r = (x * x + y * y).sqrt().max(1e-6);
            // Arrow: the range rate along the line of sight, 1 s of motion.
            let tip = (x + rr * x / r, y + rr * y / r);
            chart
                .draw_series([PathElement::new(
                    vec![(-y, x), (-tip.1, tip.0)],
                    colour.stroke_width(1),
                )])
                .map_err(err)?;
            chart
                .draw_series([Circle::new((-y, x), 3, colour.filled())])
                .map_err(err)?;
        }
        for t in &shot.truth {
            let outline = box_outline(t.gt_position_m, t.gt_box[0], t.gt_box[1], t.gt_box[2]);
            let label_at = outline[0];
            chart
                .draw_series([PathElement::new(outline, GT_COLOUR.stroke_width(2))])
                .map_err(err)?;
            chart
                .draw_series([Text::new(
                    format!("{}", t.gt_id),
                    label_at,
                    (FONT, 10).into_font().color(&GT_COLOUR),
                )])
                .map_err(err)?;
        }
        for b in boxes {
            let Some(p) = b.position_m else { continue };
            let colour = if b.ground_truth_ids.is_empty() {
                FA_COLOUR
            } else {
                DET_COLOUR
            };
            chart
                .draw_series([PathElement::new(
                    box_outline(p, b.size[0], b.size[1], b.size[2]),
                    colour.stroke_width(1),
                )])
                .map_err(err)?;
        }
        // The sensor.
        chart
            .draw_series([Polygon::new(
                vec![(0.0, 0.0), (-0.8, -1.5), (0.8, -1.5)],
                BLACK.filled(),
            )])
            .map_err(err)?;
        Ok(())
    })
}
