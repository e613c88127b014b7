//! `osiris export`: one frame of a PerceptionData trace (written by `osiris run` as
//! `<sensor>.perception.osi`, or a PerceptionData channel of its `.mcap` trace) as a file other tools
//! open:
//!
//! * LiDAR point cloud → `.pcd` (PCL point cloud data v0.7, binary) or `.ply` (PLY 1.0, binary
//!   little endian), with x, y, z (m, sensor frame), intensity, timestamp (ns), channel, echo;
//! * radar range-Doppler map → `.png` (8-bit grey, range bins bottom-up, Doppler bins left to
//!   right from the most negative range rate; the map is in the trace only when the radar model
//!   is configured with `"radar": {"emit_range_doppler_map": true}`), and the
//!   same values as `.csv`;
//! * camera images → `.png`: the ISP output as 8-bit sRGB, a RAW mosaic (companded HDR, one
//!   capture, or the linear HDR) as 16-bit grey with the DN values (`--image`).

use std::io::Write;
use std::path::Path;

use anyhow::{Context, Result, bail};
use osiris_proto::{Message, perception};

use crate::trace::OsiTraceReader;

/// Image and value bounds of a range-Doppler PNG: the map's peak down to `dynamic_range_db` below.
pub const RD_MAP_DYNAMIC_RANGE_DB: f32 = 60.0;

/// Which camera image `osiris export --image` writes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum CameraImageSel {
    /// The ISP output, 8-bit sRGB.
    Isp,
    /// The PWL-companded HDR RAW (16-bit grey PNG, DN as stored).
    Raw,
    /// The linear HDR RAW (20–24 bit), shifted right to fit 16 bits.
    Linear,
    /// The RAW of one capture of the HDR sequence (0 = most sensitive).
    Exposure(u32),
}

impl std::str::FromStr for CameraImageSel {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "isp" => Ok(CameraImageSel::Isp),
            "raw" => Ok(CameraImageSel::Raw),
            "linear" => Ok(CameraImageSel::Linear),
            _ => s
                .strip_prefix("exposure:")
                .and_then(|n| n.parse().ok())
                .map(CameraImageSel::Exposure)
                .ok_or_else(|| format!("unknown image `{s}` (isp, raw, linear or exposure:<N>)")),
        }
    }
}

impl CameraImageSel {
    fn matches(self, img: &perception::CameraImage) -> bool {
        use perception::camera_image::Kind;
        let kind = img.kind();
        match self {
            CameraImageSel::Isp => kind == Kind::Isp,
            CameraImageSel::Raw => kind == Kind::RawHdrCompanded,
            CameraImageSel::Linear => kind == Kind::RawHdrLinear,
            CameraImageSel::Exposure(n) => {
                kind == Kind::RawExposure && img.exposure_index.unwrap_or(0) == n
            }
        }
    }

    fn describe(self) -> String {
        match self {
            CameraImageSel::Isp => "ISP image".into(),
            CameraImageSel::Raw => "companded RAW image".into(),
            CameraImageSel::Linear => {
                "linear HDR RAW image (configure the camera with \"emit\": {\"raw_hdr_linear\": true})"
                    .into()
            }
            CameraImageSel::Exposure(n) => format!(
                "RAW image of capture {n} (configure the camera with \"emit\": {{\"raw_exposures\": \
                 true}})"
            ),
        }
    }
}

/// The PerceptionData messages of a trace: an `.osi` trace of them, or a channel of an `.mcap` trace
/// (recognised by its magic): the channel `channel`, else the only PerceptionData channel.
pub fn perception_messages(
    trace: &Path,
    channel: Option<&str>,
) -> Result<Box<dyn Iterator<Item = Result<perception::PerceptionData>>>> {
    use osiris_proto::trace::mcap::{McapTraceReader, PERCEPTION_DATA_SCHEMA, is_mcap_file};
    if is_mcap_file(trace)? {
        let reader = McapTraceReader::open(trace)?;
        let ch = reader.select_channel(PERCEPTION_DATA_SCHEMA, channel)?;
        let (topic, name) = (ch.topic.clone(), trace.display().to_string());
        let mut index = 0usize;
        Ok(Box::new(reader.messages(ch.id)?.map(move |m| {
            let i = index;
            index += 1;
            let m = m?;
            perception::PerceptionData::decode(m.data.as_slice()).with_context(|| {
                format!("{name}: channel `{topic}`, message {i}: cannot decode the PerceptionData")
            })
        })))
    } else {
        if let Some(c) = channel {
            bail!(
                "{}: --channel {c} is for .mcap traces; this is an .osi trace (one message stream)",
                trace.display()
            );
        }
        let reader =
            OsiTraceReader::open(trace).with_context(|| format!("opening {}", trace.display()))?;
        Ok(Box::new(
            reader
                .messages::<perception::PerceptionData>()
                .map(|m| m.map_err(anyhow::Error::from)),
        ))
    }
}

/// Read frame `frame` (0-based; `None`: the last frame with content for the output format) of a
/// PerceptionData trace (`.osi`, or a channel of an `.mcap` trace: `channel`, else the only
/// PerceptionData channel) and write it to `out`; the format follows `out`'s extension; `image`: the
/// camera image to write (`None`: the ISP image for camera traces). Returns a one-line description
/// of what was written.
pub fn export_frame(
    trace: &Path,
    channel: Option<&str>,
    frame: Option<usize>,
    out: &Path,
    image: Option<CameraImageSel>,
) -> Result<String> {
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
    let messages = perception_messages(trace, channel)?;
    let sel = image.unwrap_or(CameraImageSel::Isp);
    let mut chosen: Option<(usize, perception::PerceptionData)> = None;
    let mut camera_trace = image.is_some();
    for (i, msg) in messages.enumerate() {
        let msg = msg.with_context(|| format!("reading {}", trace.display()))?;
        camera_trace |= msg.camera.is_some();
        let has = if wants_cloud {
            msg.lidar.is_some()
        } else if camera_trace {
            ext == "png"
                && msg
                    .camera
                    .as_ref()
                    .is_some_and(|c| c.image.iter().any(|img| sel.matches(img)))
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
                "LiDAR point cloud".to_string()
            } else if camera_trace {
                if ext == "png" {
                    sel.describe()
                } else {
                    "camera image in this format (camera images are written as .png)".to_string()
                }
            } else {
                "range-Doppler map (configure the radar with \"emit_range_doppler_map\": true)"
                    .to_string()
            }
        ),
    })?;
    let create = || {
        std::fs::File::create(out)
            .map(std::io::BufWriter::new)
            .with_context(|| format!("creating {}", out.display()))
    };
    if let Some(cam) = msg.camera.as_ref().filter(|_| !wants_cloud && camera_trace) {
        if ext != "png" {
            bail!("camera images are written as .png, not .{ext}");
        }
        let img = cam
            .image
            .iter()
            .find(|img| sel.matches(img))
            .with_context(|| format!("frame {index} has no {}", sel.describe()))?;
        let mut w = create()?;
        let what = write_camera_png(img, &mut w)?;
        w.flush()?;
        return Ok(format!("frame {index}: {what} → {}", out.display()));
    }
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

/// Write a camera image as PNG: U8 RGB as 8-bit RGB, U8 mono as 8-bit grey, U16 mosaics as 16-bit
/// grey with the stored DN, U32 (linear HDR) as 16-bit grey shifted right by `bit_depth − 16`.
/// Returns a description.
pub fn write_camera_png(img: &perception::CameraImage, w: impl Write) -> Result<String> {
    use perception::camera_image::SampleFormat;
    let width = img.width_px.unwrap_or(0) as usize;
    let height = img.height_px.unwrap_or(0) as usize;
    let channels = img.channels.unwrap_or(1) as usize;
    let data = img.data.as_deref().unwrap_or_default();
    if width == 0 || height == 0 || !(channels == 1 || channels == 3) {
        bail!("malformed camera image: {width} × {height} px, {channels} channels");
    }
    let n = width * height * channels;
    let format = img.sample_format();
    let bytes_per = match format {
        SampleFormat::U8 => 1,
        SampleFormat::U16Le => 2,
        SampleFormat::U32Le | SampleFormat::F32Le => 4,
        SampleFormat::Unknown => bail!("camera image without a sample format"),
    };
    if data.len() != n * bytes_per {
        bail!(
            "malformed camera image: {width} × {height} × {channels} samples of {bytes_per} bytes \
             need {} bytes, got {}",
            n * bytes_per,
            data.len()
        );
    }
    let colour = if channels == 3 {
        png::ColorType::Rgb
    } else {
        png::ColorType::Grayscale
    };
    let (depth, pixels, what): (png::BitDepth, Vec<u8>, String) = match format {
        SampleFormat::U8 => (
            png::BitDepth::Eight,
            data.to_vec(),
            format!("{width} × {height} 8-bit image"),
        ),
        SampleFormat::U16Le => (
            png::BitDepth::Sixteen,
            data.chunks_exact(2).flat_map(|c| [c[1], c[0]]).collect(),
            format!(
                "{width} × {height} RAW ({} significant bits) as 16-bit PNG",
                img.bit_depth.unwrap_or(16)
            ),
        ),
        SampleFormat::U32Le => {
            let shift = img.bit_depth.unwrap_or(32).saturating_sub(16);
            (
                png::BitDepth::Sixteen,
                data.chunks_exact(4)
                    .flat_map(|c| {
                        let v = u32::from_le_bytes([c[0], c[1], c[2], c[3]]) >> shift;
                        (v.min(65_535) as u16).to_be_bytes()
                    })
                    .collect(),
                format!(
                    "{width} × {height} linear RAW ({} bits, shifted right by {shift}) as 16-bit PNG",
                    img.bit_depth.unwrap_or(32)
                ),
            )
        }
        SampleFormat::F32Le => bail!("float camera images are not exported (use U16/U32 RAW)"),
        SampleFormat::Unknown => unreachable!("checked above"),
    };
    let mut enc = png::Encoder::new(w, width as u32, height as u32);
    enc.set_color(colour);
    enc.set_depth(depth);
    let mut writer = enc.write_header().context("writing the PNG header")?;
    writer
        .write_image_data(&pixels)
        .context("writing the PNG image")?;
    Ok(what)
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

    fn decode(bytes: Vec<u8>) -> (png::OutputInfo, Vec<u8>) {
        let dec = png::Decoder::new(std::io::Cursor::new(bytes));
        let mut reader = dec.read_info().unwrap();
        let mut buf = vec![0; reader.output_buffer_size()];
        let info = reader.next_frame(&mut buf).unwrap();
        buf.truncate(info.buffer_size());
        (info, buf)
    }

    #[test]
    fn camera_raw_and_isp_png() {
        use perception::camera_image::{Kind, SampleFormat};
        // 4 × 2 RAW mosaic, 12-bit codes, stored little-endian.
        let codes: Vec<u16> = vec![0, 1, 255, 256, 4095, 1000, 2, 3];
        let raw = perception::CameraImage {
            kind: Some(Kind::RawHdrCompanded as i32),
            width_px: Some(4),
            height_px: Some(2),
            channels: Some(1),
            bit_depth: Some(12),
            sample_format: Some(SampleFormat::U16Le as i32),
            data: Some(codes.iter().flat_map(|v| v.to_le_bytes()).collect()),
            ..Default::default()
        };
        let mut bytes = Vec::new();
        write_camera_png(&raw, &mut bytes).unwrap();
        let (info, buf) = decode(bytes);
        assert_eq!((info.width, info.height), (4, 2));
        assert_eq!(info.bit_depth, png::BitDepth::Sixteen);
        let back: Vec<u16> = buf
            .chunks_exact(2)
            .map(|c| u16::from_be_bytes([c[0], c[1]]))
            .collect();
        assert_eq!(back, codes);
        // 24-bit linear: shifted right by 8.
        let lin = perception::CameraImage {
            kind: Some(Kind::RawHdrLinear as i32),
            width_px: Some(2),
            height_px: Some(1),
            channels: Some(1),
            bit_depth: Some(24),
            sample_format: Some(SampleFormat::U32Le as i32),
            data: Some(
                [0x00ff_ffffu32, 0x0000_0100]
                    .iter()
                    .flat_map(|v| v.to_le_bytes())
                    .collect(),
            ),
            ..Default::default()
        };
        let mut bytes = Vec::new();
        write_camera_png(&lin, &mut bytes).unwrap();
        let (_, buf) = decode(bytes);
        assert_eq!(buf, vec![0xff, 0xff, 0x00, 0x01]);
        // 8-bit RGB.
        let rgb = perception::CameraImage {
            kind: Some(Kind::Isp as i32),
            width_px: Some(2),
            height_px: Some(1),
            channels: Some(3),
            bit_depth: Some(8),
            sample_format: Some(SampleFormat::U8 as i32),
            data: Some(vec![1, 2, 3, 4, 5, 6]),
            ..Default::default()
        };
        let mut bytes = Vec::new();
        write_camera_png(&rgb, &mut bytes).unwrap();
        let (info, buf) = decode(bytes);
        assert_eq!(info.color_type, png::ColorType::Rgb);
        assert_eq!(buf, vec![1, 2, 3, 4, 5, 6]);
        // Wrong data length is an error, not a panic.
        let bad = perception::CameraImage {
            data: Some(vec![0; 3]),
            ..raw
        };
        assert!(write_camera_png(&bad, &mut Vec::new()).is_err());
        assert_eq!(
            "exposure:2".parse::<CameraImageSel>(),
            Ok(CameraImageSel::Exposure(2))
        );
        assert!("foo".parse::<CameraImageSel>().is_err());
    }
}
