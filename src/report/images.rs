//! Images of the report: camera ISP frames as JPEG (scaled down), range-Doppler maps as PNG (the
//! encoder of `osiris export`), embedded as base64 data URIs.

use base64::Engine as _;
use osiris_proto::perception;

/// A `data:` URI of `bytes`.
pub fn data_uri(mime: &str, bytes: &[u8]) -> String {
    format!(
        "data:{mime};base64,{}",
        base64::engine::general_purpose::STANDARD.encode(bytes)
    )
}

/// Width of the camera frames in the report, px (larger images are scaled down to it).
pub const CAMERA_WIDTH_PX: u32 = 640;
/// JPEG quality of the camera frames in the report.
pub const CAMERA_JPEG_QUALITY: u8 = 85;

/// An 8-bit RGB or grey camera image, scaled down to [`CAMERA_WIDTH_PX`] wide, as JPEG
/// (`None`: malformed or another sample format).
pub fn camera_jpeg(img: &perception::CameraImage) -> Option<Vec<u8>> {
    use image::{DynamicImage, GrayImage, RgbImage};
    use perception::camera_image::SampleFormat;
    if img.sample_format() != SampleFormat::U8 {
        return None;
    }
    let (w, h) = (img.width_px?, img.height_px?);
    let data = img.data.as_deref()?.to_vec();
    let full = match img.channels.unwrap_or(1) {
        3 => DynamicImage::ImageRgb8(RgbImage::from_raw(w, h, data)?),
        1 => DynamicImage::ImageLuma8(GrayImage::from_raw(w, h, data)?),
        _ => return None,
    };
    let shown = if w > CAMERA_WIDTH_PX {
        let sh = ((h as f64 * CAMERA_WIDTH_PX as f64 / w as f64).round() as u32).max(1);
        full.resize_exact(CAMERA_WIDTH_PX, sh, image::imageops::FilterType::Triangle)
    } else {
        full
    };
    let mut out = Vec::new();
    image::codecs::jpeg::JpegEncoder::new_with_quality(&mut out, CAMERA_JPEG_QUALITY)
        .encode_image(&shown)
        .ok()?;
    Some(out)
}

/// A range-Doppler map as PNG with (range bins, Doppler bins, range bin m, range-rate bin m/s)
/// (`None`: malformed).
pub fn rd_png(map: &perception::RangeDopplerMap) -> Option<(Vec<u8>, [f64; 4])> {
    let nr = map.range_bins.unwrap_or(0) as usize;
    let nd = map.doppler_bins.unwrap_or(0) as usize;
    if nr == 0 || nd == 0 || map.power_dbm.len() != nr * nd {
        return None;
    }
    let mut png = Vec::new();
    crate::export::write_rd_png(map, nr, nd, &mut png).ok()?;
    Some((
        png,
        [
            nr as f64,
            nd as f64,
            map.range_bin_m.unwrap_or(0.0),
            map.range_rate_bin_m_s.unwrap_or(0.0),
        ],
    ))
}
