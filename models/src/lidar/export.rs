//! Export of a LiDAR frame (`PerceptionData.lidar`) as PCD v0.7 or PLY 1.0, readable by PCL,
//! Open3D and CloudCompare.
//!
//! Fields per point: `x y z` (float32, m, sensor frame), `intensity` (float32, the frame's scale),
//! `t` (uint32, ns after the earliest point of the frame; the absolute time of that point, ns since
//! simulation start, is in a header comment `timestamp_ns_base`), `ring` (uint16, channel) and
//! `echo` (uint8, echo index within the pulse); an FMCW frame (range rates present) adds
//! `range_rate` (float32, m/s, positive receding; Doppler of the point, `LidarPerception.range_rate_m_s`).
//!
//! Formats: PCD v0.7 (PCL, <https://pointclouds.org/documentation/tutorials/pcd_file_format.html>),
//! binary or ASCII data; PLY 1.0 `binary_little_endian` (Turk 1994).

use std::io::{self, Write};

use osiris_proto::perception::LidarPerception;

/// The frame's points, checked for consistent array lengths.
fn check(c: &LidarPerception) -> io::Result<usize> {
    let n = c.x_m.len();
    let lens = [
        c.y_m.len(),
        c.z_m.len(),
        c.intensity.len(),
        c.timestamp_ns.len(),
        c.channel.len(),
        c.echo.len(),
    ];
    let rates = c.range_rate_m_s.len();
    if lens.iter().any(|&l| l != n) || (rates != 0 && rates != n) {
        return Err(io::Error::new(
            io::ErrorKind::InvalidData,
            format!(
                "LidarPerception arrays differ in length: x_m {n}, y/z/intensity/timestamp/channel/echo {lens:?}, range_rate_m_s {rates}"
            ),
        ));
    }
    Ok(n)
}

fn time_base(c: &LidarPerception) -> i64 {
    c.timestamp_ns.iter().copied().min().unwrap_or(0)
}

fn rel_t(c: &LidarPerception, base: i64, i: usize) -> u32 {
    (c.timestamp_ns[i] - base).clamp(0, i64::from(u32::MAX)) as u32
}

/// Whether the frame carries range rates (FMCW): one more field per point.
fn has_rates(c: &LidarPerception) -> bool {
    !c.range_rate_m_s.is_empty()
}

fn pcd_header(
    w: &mut impl Write,
    c: &LidarPerception,
    n: usize,
    base: i64,
    data: &str,
) -> io::Result<()> {
    let (fields, size, ty, count) = if has_rates(c) {
        (" range_rate", " 4", " F", " 1")
    } else {
        ("", "", "", "")
    };
    write!(
        w,
        "# .PCD v0.7 - Point Cloud Data file format\n\
         # osiris lidar frame; t = ns after timestamp_ns_base {base}\n\
         VERSION 0.7\n\
         FIELDS x y z intensity t ring echo{fields}\n\
         SIZE 4 4 4 4 4 2 1{size}\n\
         TYPE F F F F U U U{ty}\n\
         COUNT 1 1 1 1 1 1 1{count}\n\
         WIDTH {n}\n\
         HEIGHT 1\n\
         VIEWPOINT 0 0 0 1 0 0 0\n\
         POINTS {n}\n\
         DATA {data}\n"
    )
}

/// Write the frame as a binary PCD v0.7 file.
pub fn write_pcd(c: &LidarPerception, w: &mut impl Write) -> io::Result<()> {
    let n = check(c)?;
    let base = time_base(c);
    pcd_header(w, c, n, base, "binary")?;
    let mut buf = Vec::with_capacity(n * 23);
    for i in 0..n {
        buf.extend_from_slice(&c.x_m[i].to_le_bytes());
        buf.extend_from_slice(&c.y_m[i].to_le_bytes());
        buf.extend_from_slice(&c.z_m[i].to_le_bytes());
        buf.extend_from_slice(&c.intensity[i].to_le_bytes());
        buf.extend_from_slice(&rel_t(c, base, i).to_le_bytes());
        buf.extend_from_slice(&(c.channel[i].min(u32::from(u16::MAX)) as u16).to_le_bytes());
        buf.push(c.echo[i].min(255) as u8);
        if let Some(r) = c.range_rate_m_s.get(i) {
            buf.extend_from_slice(&r.to_le_bytes());
        }
    }
    w.write_all(&buf)
}

/// Write the frame as an ASCII PCD v0.7 file.
pub fn write_pcd_ascii(c: &LidarPerception, w: &mut impl Write) -> io::Result<()> {
    let n = check(c)?;
    let base = time_base(c);
    pcd_header(w, c, n, base, "ascii")?;
    for i in 0..n {
        write!(
            w,
            "{} {} {} {} {} {} {}",
            c.x_m[i],
            c.y_m[i],
            c.z_m[i],
            c.intensity[i],
            rel_t(c, base, i),
            c.channel[i].min(u32::from(u16::MAX)),
            c.echo[i].min(255)
        )?;
        match c.range_rate_m_s.get(i) {
            Some(r) => writeln!(w, " {r}")?,
            None => writeln!(w)?,
        }
    }
    Ok(())
}

/// Write the frame as a binary little-endian PLY 1.0 file.
pub fn write_ply(c: &LidarPerception, w: &mut impl Write) -> io::Result<()> {
    let n = check(c)?;
    let base = time_base(c);
    write!(
        w,
        "ply\n\
         format binary_little_endian 1.0\n\
         comment osiris lidar frame; t = ns after timestamp_ns_base {base}\n\
         element vertex {n}\n\
         property float x\n\
         property float y\n\
         property float z\n\
         property float intensity\n\
         property uint t\n\
         property ushort ring\n\
         property uchar echo\n\
         {rate}end_header\n",
        rate = if has_rates(c) {
            "property float range_rate\n"
        } else {
            ""
        }
    )?;
    let mut buf = Vec::with_capacity(n * 23);
    for i in 0..n {
        buf.extend_from_slice(&c.x_m[i].to_le_bytes());
        buf.extend_from_slice(&c.y_m[i].to_le_bytes());
        buf.extend_from_slice(&c.z_m[i].to_le_bytes());
        buf.extend_from_slice(&c.intensity[i].to_le_bytes());
        buf.extend_from_slice(&rel_t(c, base, i).to_le_bytes());
        buf.extend_from_slice(&(c.channel[i].min(u32::from(u16::MAX)) as u16).to_le_bytes());
        buf.push(c.echo[i].min(255) as u8);
        if let Some(r) = c.range_rate_m_s.get(i) {
            buf.extend_from_slice(&r.to_le_bytes());
        }
    }
    w.write_all(&buf)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cloud() -> LidarPerception {
        LidarPerception {
            x_m: vec![1.0, 2.5],
            y_m: vec![-1.0, 0.0],
            z_m: vec![0.5, 0.25],
            intensity: vec![10.0, 90.0],
            timestamp_ns: vec![1_000_000_500, 1_000_000_000],
            channel: vec![3, 127],
            echo: vec![0, 1],
            ..Default::default()
        }
    }

    #[test]
    fn pcd_binary_layout() {
        let mut out = Vec::new();
        write_pcd(&cloud(), &mut out).unwrap();
        let text_end = out.windows(12).position(|w| w == b"DATA binary\n").unwrap() + 12;
        let header = std::str::from_utf8(&out[..text_end]).unwrap();
        assert!(
            header.contains("POINTS 2\n") && header.contains("FIELDS x y z intensity t ring echo")
        );
        let body = &out[text_end..];
        assert_eq!(body.len(), 2 * 23);
        assert_eq!(f32::from_le_bytes(body[0..4].try_into().unwrap()), 1.0);
        assert_eq!(u32::from_le_bytes(body[16..20].try_into().unwrap()), 500);
        assert_eq!(
            u16::from_le_bytes(body[23 + 20..23 + 22].try_into().unwrap()),
            127
        );
        assert_eq!(body[45], 1);
    }

    #[test]
    fn ply_and_ascii() {
        let mut out = Vec::new();
        write_ply(&cloud(), &mut out).unwrap();
        let end = out.windows(11).position(|w| w == b"end_header\n").unwrap() + 11;
        assert_eq!(out.len() - end, 46);
        let mut a = Vec::new();
        write_pcd_ascii(&cloud(), &mut a).unwrap();
        let s = String::from_utf8(a).unwrap();
        assert!(s.ends_with("2.5 0 0.25 90 0 127 1\n"), "{s}");
        let mut bad = cloud();
        bad.echo.pop();
        assert!(write_pcd(&bad, &mut Vec::new()).is_err());
    }

    #[test]
    fn fmcw_frames_carry_the_range_rate() {
        let mut c = cloud();
        c.range_rate_m_s = vec![-3.5, 12.25];
        let mut out = Vec::new();
        write_pcd(&c, &mut out).unwrap();
        let text_end = out.windows(12).position(|w| w == b"DATA binary\n").unwrap() + 12;
        let header = std::str::from_utf8(&out[..text_end]).unwrap();
        assert!(header.contains("FIELDS x y z intensity t ring echo range_rate\n"));
        assert!(
            header.contains("SIZE 4 4 4 4 4 2 1 4\n") && header.contains("TYPE F F F F U U U F\n")
        );
        let body = &out[text_end..];
        assert_eq!(body.len(), 2 * 27);
        assert_eq!(
            f32::from_le_bytes(body[27 + 23..27 + 27].try_into().unwrap()),
            12.25
        );
        let mut ply = Vec::new();
        write_ply(&c, &mut ply).unwrap();
        let end = ply.windows(11).position(|w| w == b"end_header\n").unwrap() + 11;
        assert!(
            std::str::from_utf8(&ply[..end])
                .unwrap()
                .contains("property float range_rate\n")
        );
        assert_eq!(ply.len() - end, 54);
        let mut a = Vec::new();
        write_pcd_ascii(&c, &mut a).unwrap();
        assert!(
            String::from_utf8(a)
                .unwrap()
                .ends_with("2.5 0 0.25 90 0 127 1 12.25\n")
        );
        c.range_rate_m_s.pop();
        assert!(
            write_pcd(&c, &mut Vec::new()).is_err(),
            "one rate per point or none"
        );
    }
}
