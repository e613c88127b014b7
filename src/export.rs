//! `osiris export`: one frame of a PerceptionData trace (written by `osiris run` as
//! `<sensor>.perception.osi`) as a file other tools open:
//!
//! * LiDAR point cloud → `.pcd` (PCL point cloud data v0.7, binary) or `.ply` (PLY 1.0, binary
//!   little endian), with x, y, z (m, sensor frame), intensity, timestamp (ns), channel, echo;
//! * radar range-Doppler map → `.png` (8-bit grey, range bins bottom-up, Doppler bins left to
//!   right from the most negative range rate; the map is in the trace only when the radar model
//!   is configured with `"radar": {"emit_range_doppler_map": true}`), and the
//!   same values as `.csv`.

use std::io::Write;
use std::path::Path;

use anyhow::{Context, Result, bail};
use osiris_proto::perception;

use crate::trace::OsiTraceReader;

/// Image and value bounds of a range-Doppler PNG: the map's peak down to `dynamic_range_db` below.
pub const RD_MAP_DYNAMIC_RANGE_DB: f32 = 60.0;

/// Read frame `frame` (0-based; `None`: the last frame with content for the output format) of a
/// PerceptionData trace and write it to `out`; the format follows `out`'s extension. Returns a
/// one-line description of what was written.
pub fn export_frame(trace: &Path, frame: Option<usize>, out: &Path) -> Result<String> {
    let ext = out
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase)
        .unwrap_or_default();
    let wants_cloud = matches!(ext.as_str(), "pcd" | "ply");
    let wants_map = matches!(ext.as_str(), "png" | "csv");
    if !wants_cloud && !wants_map {
        bail!(
            "{}: unknown output format `{ext}` (use .pcd or .ply for LiDAR point clouds, .png or .csv \
             for radar range-Doppler maps)",
            out.display()
        );
    }
    let reader =
        OsiTraceReader::open(trace).with_context(|| format!("opening {}", trace.display()))?;
    let mut chosen: Option<(usize, perception::PerceptionData)> = None;
    for (i, msg) in reader.messages::<perception::PerceptionData>().enumerate() {
        let msg = msg.with_context(|| format!("reading {}", trace.display()))?;
        let has = if wants_cloud {
            msg.lidar.is_some()
        } else {
            msg.radar
                .as_ref()
                .is_some_and(|r| r.range_doppler_map.is_some())
        };
        match frame {
            Some(f) if f == i => {
                chosen = Some((i, msg));
                break;
            }
            Some(_) => {}
            None if has => chosen = Some((i, msg)),
            None => {}
        }
    }
    let (index, msg) = chosen.with_context(|| match frame {
        Some(f) => format!("{} has no frame {f}", trace.display()),
        None => format!(
            "{} has no frame with a {}",
            trace.display(),
            if wants_cloud {
                "LiDAR point cloud"
            } else {
                "range-Doppler map (configure the radar with \"emit_range_doppler_map\": true)"
            }
        ),
    })?;
    let create = || {
        std::fs::File::create(out)
            .map(std::io::BufWriter::new)
            .with_context(|| format!("creating {}", out.display()))
    };
    if wants_cloud {
        let cloud = msg.lidar.as_ref().with_context(|| {
            format!("frame {index} of {} is not a LiDAR frame", trace.display())
        })?;
        let mut w = create()?;
        if ext == "pcd" {
            osiris_models::lidar::export::write_pcd(cloud, &mut w)?;
        } else {
            osiris_models::lidar::export::write_ply(cloud, &mut w)?;
        }
        w.flush()?;
        Ok(format!(
            "frame {index}: {} points → {}",
            cloud.x_m.len(),
            out.display()
        ))
    } else {
        let map = msg
            .radar
            .as_ref()
            .and_then(|r| r.range_doppler_map.as_ref())
            .with_context(|| {
                format!(
                    "frame {index} of {} has no range-Doppler map (configure the radar with \
                     \"emit_range_doppler_map\": true)",
                    trace.display()
                )
            })?;
        let (nr, nd) = check_map(map)?;
        let mut w = create()?;
        if ext == "png" {
            write_rd_png(map, nr, nd, &mut w)?;
        } else {
            write_rd_csv(map, nr, nd, &mut w)?;
        }
        w.flush()?;
        Ok(format!(
            "frame {index}: {nr} range × {nd} Doppler bins → {}",
            out.display()
        ))
    }
}

fn check_map(map: &perception::RangeDopplerMap) -> Result<(usize, usize)> {
    let nr = map.range_bins.unwrap_or(0) as usize;
    let nd = map.doppler_bins.unwrap_or(0) as usize;
    if nr == 0 || nd == 0 || map.power_dbm.len() != nr * nd {
        bail!(
            "malformed range-Doppler map: {nr} × {nd} bins but {} values",
            map.power_dbm.len()
        );
    }
    Ok((nr, nd))
}

/// 8-bit grey PNG: the map's maximum → 255, `RD_MAP_DYNAMIC_RANGE_DB` below it → 0; range bin 0
/// at the bottom row, Doppler bin 0 (most negative range rate) in the left column.
pub fn write_rd_png(
    map: &perception::RangeDopplerMap,
    range_bins: usize,
    doppler_bins: usize,
    w: impl Write,
) -> Result<()> {
    let max = map
        .power_dbm
        .iter()
        .copied()
        .filter(|v| v.is_finite())
        .fold(f32::NEG_INFINITY, f32::max);
    let floor = max - RD_MAP_DYNAMIC_RANGE_DB;
    let mut pixels = vec![0u8; range_bins * doppler_bins];
    for r in 0..range_bins {
        let row = range_bins - 1 - r;
        for d in 0..doppler_bins {
            let v = map.power_dbm[r * doppler_bins + d];
            let g = if v.is_finite() {
                ((v - floor) / RD_MAP_DYNAMIC_RANGE_DB * 255.0).clamp(0.0, 255.0)
            } else {
                0.0
            };
            pixels[row * doppler_bins + d] = g.round() as u8;
        }
    }
    let mut enc = png::Encoder::new(w, doppler_bins as u32, range_bins as u32);
    enc.set_color(png::ColorType::Grayscale);
    enc.set_depth(png::BitDepth::Eight);
    let mut writer = enc.write_header().context("writing the PNG header")?;
    writer
        .write_image_data(&pixels)
        .context("writing the PNG image")?;
    Ok(())
}

/// CSV: `range_m,range_rate_m_s,power_dbm`, one line per cell.
pub fn write_rd_csv(
    map: &perception::RangeDopplerMap,
    range_bins: usize,
    doppler_bins: usize,
    mut w: impl Write,
) -> Result<()> {
    let dr = map.range_bin_m.unwrap_or(0.0);
    let dv = map.range_rate_bin_m_s.unwrap_or(0.0);
    writeln!(w, "range_m,range_rate_m_s,power_dbm")?;
    for r in 0..range_bins {
        for d in 0..doppler_bins {
            let v = (d as f64 - (doppler_bins / 2) as f64) * dv;
            writeln!(
                w,
                "{:.4},{:.4},{:.2}",
                r as f64 * dr,
                v,
                map.power_dbm[r * doppler_bins + d]
            )?;
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rd_png_orientation_and_scaling() {
        // 3 range bins × 4 Doppler bins; peak at range bin 2, Doppler bin 1.
        let mut power = vec![-100.0f32; 12];
        power[2 * 4 + 1] = -40.0;
        power[0] = -70.0; // 30 dB below the peak: mid grey
        let map = perception::RangeDopplerMap {
            range_bins: Some(3),
            doppler_bins: Some(4),
            range_bin_m: Some(0.5),
            range_rate_bin_m_s: Some(0.1),
            power_dbm: power,
        };
        let mut bytes = Vec::new();
        write_rd_png(&map, 3, 4, &mut bytes).unwrap();
        let dec = png::Decoder::new(std::io::Cursor::new(bytes));
        let mut reader = dec.read_info().unwrap();
        let mut buf = vec![0; reader.output_buffer_size()];
        let info = reader.next_frame(&mut buf).unwrap();
        assert_eq!((info.width, info.height), (4, 3));
        // Range bin 2 is the top row.
        assert_eq!(buf[1], 255);
        // Range bin 0 is the bottom row; −70 dBm is 30 of 60 dB above the floor.
        assert_eq!(buf[2 * 4], 128);
        assert_eq!(buf[2 * 4 + 3], 0);
        let mut csv = Vec::new();
        write_rd_csv(&map, 3, 4, &mut csv).unwrap();
        let text = String::from_utf8(csv).unwrap();
        assert_eq!(text.lines().count(), 13);
        assert!(
            text.lines()
                .nth(1)
                .unwrap()
                .starts_with("0.0000,-0.2000,-70.00")
        );
    }
}
