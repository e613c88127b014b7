//! `report.html`: one self-contained page (inline CSS, inline SVG plots, base64 images, one small
//! inline script), one `<section class="sensor">` per sensor.

use std::fmt::Write as _;

use super::{
    CAMERA_STRIP_FRAMES, CameraShot, ReportBuilder, SectionKind, SensorReport, images, plots,
};

/// The `id` of a sensor's section: `sensor-` + its name with characters other than ASCII letters,
/// digits, `-` and `_` as `-`.
pub fn section_id(name: &str) -> String {
    let slug: String = name
        .chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || c == '-' || c == '_' {
                c
            } else {
                '-'
            }
        })
        .collect();
    format!("sensor-{slug}")
}

/// HTML text escape.
pub fn escape(s: &str) -> String {
    let mut out = String::with_capacity(s.len());
    for c in s.chars() {
        match c {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '"' => out.push_str("&quot;"),
            '\'' => out.push_str("&#39;"),
            c => out.push(c),
        }
    }
    out
}

const STYLE: &str = "body{font-family:sans-serif;margin:1.5em;color:#222;max-width:1400px}\
h1{font-size:1.5em}h2{font-size:1.25em;border-bottom:1px solid #ccc;padding-top:.5em}\
table{border-collapse:collapse;margin:.5em 0}td,th{border:1px solid #ccc;padding:.2em .6em;text-align:right}\
th{background:#f3f3f3}td:first-child,th:first-child{text-align:left}\
.strip{display:flex;flex-wrap:wrap;gap:8px}.shot{margin:0}.shot figcaption{font-size:.8em;color:#555}\
.frame{position:relative;display:inline-block;line-height:0}.frame svg{position:absolute;left:0;top:0}\
.note{color:#555;font-size:.9em}.plots svg{display:block;margin:.4em 0;max-width:100%;height:auto}";

/// Sets `document.body.dataset.rendered` to the sensors whose section has at least one image or
/// SVG and all of them loaded with a non-zero size (checked by the headless-browser test).
const SCRIPT: &str = "(function(){function check(){var ok=[];\
document.querySelectorAll('section.sensor').forEach(function(s){\
var els=s.querySelectorAll('img,svg');if(!els.length)return;var good=true;\
els.forEach(function(e){var r=e.getBoundingClientRect();\
if(e.tagName.toLowerCase()==='img'&&!(e.complete&&e.naturalWidth>0))good=false;\
if(!(r.width>0&&r.height>0))good=false;});\
if(good)ok.push(s.dataset.sensor);});document.body.dataset.rendered=ok.join(',');}\
check();window.addEventListener('load',check);})();";

/// The whole page.
pub fn page(report: &ReportBuilder) -> String {
    let mut h = String::new();
    let _ = write!(
        h,
        "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">\
         <title>osiris report</title><style>{STYLE}</style></head><body>\n\
         <h1>osiris report</h1><p>{}</p>\n",
        escape(&report.title)
    );
    h.push_str(
        "<table><tr><th>sensor</th><th>kind</th><th>SensorData frames</th>\
         <th>ground truth in view / frame</th><th>detected / frame</th>\
         <th>detection rate</th><th>false alarms / frame</th><th>mean |range error| m</th>\
         <th>mean FMU step ms</th></tr>\n",
    );
    for s in &report.sensors {
        summary_row(&mut h, s);
    }
    h.push_str(
        "</table>\n<p class=\"note\">Detection rate: ground-truth objects in view that a \
        reported detected object names (header.ground_truth_id), over all ground-truth objects in \
        view. Columns of objects.csv and frames.csv: docs/report.md.</p>\n",
    );
    for s in &report.sensors {
        section(&mut h, s);
    }
    let _ = write!(h, "<script>{SCRIPT}</script>\n</body></html>\n");
    h
}

fn mean(v: impl Iterator<Item = f64>) -> Option<f64> {
    let (n, sum) = v.fold((0usize, 0.0), |(n, s), x| (n + 1, s + x));
    (n > 0).then(|| sum / n as f64)
}

fn fmt_opt(v: Option<f64>, digits: usize) -> String {
    v.map_or("–".to_owned(), |v| format!("{v:.digits$}"))
}

fn summary_row(h: &mut String, s: &SensorReport) {
    let n = s.frames.len();
    let truth = mean(
        s.frames
            .iter()
            .filter_map(|f| f.ground_truth_in_fov.map(|v| v as f64)),
    );
    let detected = mean(s.frames.iter().map(|f| f.detected_objects as f64));
    let rate = mean(
        s.objects
            .iter()
            .map(|o| f64::from(u8::from(o.detected.is_some()))),
    );
    let fa = mean(
        s.frames
            .iter()
            .filter_map(|f| f.false_alarms.map(|v| v as f64)),
    );
    let err = mean(
        s.objects
            .iter()
            .filter_map(|o| Some((o.detected.as_ref()?.range_m? - o.gt_range_m).abs())),
    );
    let wall = mean(s.frames.iter().filter_map(|f| f.step_wall_ms));
    let _ = writeln!(
        h,
        "<tr><td><a href=\"#{8}\">{0}</a></td><td>{1}</td><td>{n}</td><td>{2}</td><td>{3}</td>\
         <td>{4}</td><td>{5}</td><td>{6}</td><td>{7}</td></tr>",
        escape(&s.name),
        s.kind.unwrap_or(SectionKind::Other).name(),
        fmt_opt(truth, 2),
        fmt_opt(detected, 2),
        rate.map_or("–".to_owned(), |r| format!("{:.1} %", 100.0 * r)),
        fmt_opt(fa, 2),
        fmt_opt(err, 3),
        fmt_opt(wall, 2),
        section_id(&s.name),
    );
}

fn section(h: &mut String, s: &SensorReport) {
    let kind = s.kind.unwrap_or(SectionKind::Other);
    let name = escape(&s.name);
    let _ = writeln!(
        h,
        "<section id=\"{}\" class=\"sensor\" data-kind=\"{}\" data-sensor=\"{name}\">\
         <h2>{name} <small>({})</small></h2>",
        section_id(&s.name),
        kind.name(),
        kind.name()
    );
    if s.frames_with_ground_truth == 0 {
        h.push_str(
            "<p class=\"note\">No ground truth for this sensor (no SensorView with a \
             global_ground_truth: none embedded in the SensorData and none given with \
             --sensor-view): objects.csv has no rows for it, the plots show what it reported.</p>\n",
        );
    }
    h.push_str("<div class=\"plots\">\n");
    h.push_str(&plots::timeline(&s.frames));
    h.push('\n');
    if !s.objects.is_empty() {
        h.push_str(&plots::detections_per_object(&s.objects, s.frames.len()));
        h.push('\n');
        if s.objects
            .iter()
            .any(|o| o.detected.as_ref().is_some_and(|d| d.range_m.is_some()))
        {
            h.push_str(&plots::range_errors(&s.objects));
            h.push('\n');
        }
    }
    h.push_str("</div>\n");
    traffic_control(h, s);
    if kind == SectionKind::Camera {
        camera_strip(h, &s.camera_shots);
    }
    if let Some(shot) = &s.bev {
        h.push_str("<div class=\"plots\">\n");
        h.push_str(&plots::bev(shot, kind));
        h.push_str("\n</div>\n");
        if let Some((png, [nr, nd, dr, dv])) = &shot.rd_png {
            let _ = writeln!(
                h,
                "<figure class=\"shot\"><img alt=\"range-Doppler map\" src=\"{}\" width=\"{}\" \
                 height=\"{}\" style=\"image-rendering:pixelated\"><figcaption>range-Doppler map of \
                 frame {}: {nr} range bins of {dr:.3} m (bottom: 0 m) × {nd} Doppler bins of {dv:.3} \
                 m/s (left: most negative range rate); grey = power, {} dB below the peak = black\
                 </figcaption></figure>",
                images::data_uri("image/png", png),
                (*nd as u32 * 3).clamp(128, 768),
                (*nr as u32 * 2).clamp(128, 768),
                shot.frame,
                crate::export::RD_MAP_DYNAMIC_RANGE_DB
            );
        }
    }
    h.push_str("</section>\n");
}

/// The traffic-control outputs of a sensor (SensorData traffic lights, signs, lane boundaries;
/// frames.csv columns), when it reported any: per-frame counts and the bulb-state errors against
/// the ground truth.
fn traffic_control(h: &mut String, s: &SensorReport) {
    let f = &s.frames;
    let errors: Vec<usize> = f
        .iter()
        .filter_map(|r| r.traffic_light_state_errors)
        .collect();
    let reported = f
        .iter()
        .any(|r| r.traffic_lights + r.traffic_signs + r.lane_boundaries > 0);
    if !reported && errors.iter().all(|&e| e == 0) {
        return;
    }
    let n = f.len().max(1) as f64;
    let row = |h: &mut String, what: &str, count: &dyn Fn(&super::kpi::FrameRow) -> usize| {
        let total: usize = f.iter().map(count).sum();
        let with = f.iter().filter(|r| count(r) > 0).count();
        let max = f.iter().map(count).max().unwrap_or(0);
        let first = f
            .iter()
            .find(|r| count(r) > 0)
            .map_or("–".to_owned(), |r| format!("{:.3} s", r.time_s));
        let _ = writeln!(
            h,
            "<tr><td>{what}</td><td>{:.2}</td><td>{max}</td><td>{with} / {}</td><td>{first}</td></tr>",
            total as f64 / n,
            f.len()
        );
    };
    h.push_str(
        "<h3>Traffic control</h3><table><tr><th>reported</th><th>per frame</th><th>max</th>\
         <th>frames with one</th><th>first at</th></tr>\n",
    );
    row(h, "traffic-light bulbs", &|r| r.traffic_lights);
    row(h, "traffic signs", &|r| r.traffic_signs);
    row(h, "lane boundaries", &|r| r.lane_boundaries);
    let judged = errors.len();
    let total: usize = errors.iter().sum();
    let frames_with = errors.iter().filter(|&&e| e > 0).count();
    let _ = writeln!(
        h,
        "</table><p class=\"note\">Bulb state misreads against the ground truth (a reported \
         lit/dark state that differs from the bulb's mode: CONSTANT or COUNTING lit, OFF dark; \
         FLASHING not judged): {total} in {frames_with} of {judged} frames with ground truth. \
         From SensorData.traffic_light, traffic_sign and lane_boundary; per frame in frames.csv.</p>"
    );
}

/// Evenly spaced ISP frames with the recognised objects' boxes as SVG overlays.
fn camera_strip(h: &mut String, shots: &[CameraShot]) {
    if shots.is_empty() {
        h.push_str(
            "<p class=\"note\">No ISP camera images in the PerceptionData (or no PerceptionData).</p>\n",
        );
        return;
    }
    let n = shots.len();
    let picks: Vec<usize> = if n <= CAMERA_STRIP_FRAMES {
        (0..n).collect()
    } else {
        let mut v: Vec<usize> = (0..CAMERA_STRIP_FRAMES)
            .map(|k| (k * (n - 1) + (CAMERA_STRIP_FRAMES - 1) / 2) / (CAMERA_STRIP_FRAMES - 1))
            .collect();
        v.dedup();
        v
    };
    h.push_str(
        "<p class=\"note\">ISP frames; red boxes: the camera's recognised objects (PerceptionData \
         camera objects, labelled above with their ground-truth id); green dashed boxes: the ground \
         truth in view (labelled below), projected with a pinhole camera of the SensorView's \
         horizontal field of view — approximate: the lens distortion and principal-point offset \
         are not known to the report.</p>\n<div class=\"strip\">\n",
    );
    for &i in &picks {
        let shot = &shots[i];
        let Some(jpeg) = images::camera_jpeg(&shot.image) else {
            continue;
        };
        let (w, hgt) = (
            shot.image.width_px.unwrap_or(1),
            shot.image.height_px.unwrap_or(1),
        );
        let shown_w = 420u32;
        let shown_h = (shown_w as f64 * hgt as f64 / w.max(1) as f64).round() as u32;
        let _ = write!(
            h,
            "<figure class=\"shot\"><div class=\"frame\"><img alt=\"camera frame {}\" src=\"{}\" \
             width=\"{shown_w}\" height=\"{shown_h}\"><svg xmlns=\"http://www.w3.org/2000/svg\" \
             width=\"{shown_w}\" height=\"{shown_h}\" viewBox=\"0 0 {w} {hgt}\">",
            shot.frame,
            images::data_uri("image/jpeg", &jpeg)
        );
        for (b, id) in &shot.truth {
            let _ = write!(
                h,
                "<rect x=\"{:.1}\" y=\"{:.1}\" width=\"{:.1}\" height=\"{:.1}\" fill=\"none\" \
                 stroke=\"#00c050\" stroke-dasharray=\"{:.1}\" stroke-width=\"{:.1}\"/><text x=\"{:.1}\" \
                 y=\"{:.1}\" fill=\"#00c050\" font-size=\"{:.0}\">{id}</text>",
                b[0],
                b[1],
                b[2] - b[0],
                b[3] - b[1],
                w as f64 / 100.0,
                w as f64 / 400.0,
                b[0],
                (b[3] + w as f64 / 45.0).min(hgt as f64),
                w as f64 / 45.0,
            );
        }
        for (b, id) in &shot.boxes {
            let _ = write!(
                h,
                "<rect x=\"{:.1}\" y=\"{:.1}\" width=\"{:.1}\" height=\"{:.1}\" fill=\"none\" \
                 stroke=\"#ff2a00\" stroke-width=\"{:.1}\"/><text x=\"{:.1}\" y=\"{:.1}\" \
                 fill=\"#ff2a00\" font-size=\"{:.0}\">{id}</text>",
                b[0],
                b[1],
                (b[2] - b[0]).max(0.0),
                (b[3] - b[1]).max(0.0),
                w as f64 / 320.0,
                b[0],
                (b[1] - 3.0).max(10.0),
                w as f64 / 45.0,
            );
        }
        let _ = writeln!(
            h,
            "</svg></div><figcaption>frame {}, t = {:.3} s, {} recognised</figcaption></figure>",
            shot.frame,
            shot.time_s,
            shot.boxes.len()
        );
    }
    h.push_str("</div>\n");
}
