//! Image files: linear OpenEXR (f32, grey stored as equal R, G, B) and tone-mapped PNG,
//! and reading an EXR back as grey (the mean of its colour channels).

use anyhow::{ensure, Context};
use std::path::Path;

fn check_size(width: usize, height: usize, data: &[f32]) -> anyhow::Result<()> {
    ensure!(
        width > 0 && height > 0 && data.len() == width * height,
        "image {width}×{height} needs {} values, got {}",
        width * height,
        data.len()
    );
    Ok(())
}

/// Writes a grey image as a linear f32 RGB OpenEXR file (equal channels).
pub fn write_exr_gray(
    path: &Path,
    width: usize,
    height: usize,
    data: &[f32],
) -> anyhow::Result<()> {
    check_size(width, height, data)?;
    let rgb: Vec<f32> = data.iter().flat_map(|v| [*v, *v, *v]).collect();
    let img = image::Rgb32FImage::from_raw(width as u32, height as u32, rgb)
        .context("image buffer size")?;
    img.save_with_format(path, image::ImageFormat::OpenExr)
        .with_context(|| format!("cannot write {}", path.display()))
}

/// Reads an OpenEXR file as grey: `(width, height, values)` row-major from the top-left,
/// each value the mean of R, G and B.
pub fn read_exr_gray(path: &Path) -> anyhow::Result<(usize, usize, Vec<f32>)> {
    let img = image::ImageReader::open(path)
        .with_context(|| format!("cannot open {}", path.display()))?
        .with_guessed_format()
        .with_context(|| format!("cannot read {}", path.display()))?
        .decode()
        .with_context(|| format!("cannot decode {} as an image", path.display()))?
        .into_rgb32f();
    let (w, h) = (img.width() as usize, img.height() as usize);
    let data = img
        .pixels()
        .map(|p| ((p.0[0] as f64 + p.0[1] as f64 + p.0[2] as f64) / 3.0) as f32)
        .collect();
    Ok((w, h, data))
}

/// The exposure that maps the 99th percentile of the positive values to 1 (1 if there are
/// none).
pub fn exposure(data: &[f32]) -> f32 {
    let mut v: Vec<f32> = data
        .iter()
        .copied()
        .filter(|x| *x > 0.0 && x.is_finite())
        .collect();
    if v.is_empty() {
        return 1.0;
    }
    v.sort_by(|a, b| a.total_cmp(b));
    let p = v[((v.len() - 1) as f64 * 0.99).round() as usize];
    if p > 0.0 {
        1.0 / p
    } else {
        1.0
    }
}

/// sRGB encoding of a linear value in [0, 1] to 8 bits.
pub fn srgb8(x: f32) -> u8 {
    let x = x.clamp(0.0, 1.0);
    let s = if x <= 0.003_130_8 {
        12.92 * x
    } else {
        1.055 * x.powf(1.0 / 2.4) - 0.055
    };
    (s * 255.0 + 0.5) as u8
}

/// Writes a grey image as an 8-bit PNG: linear values times `exposure` (see [`exposure`];
/// `None` computes it from the image), clamped, sRGB-encoded.
pub fn write_png_tonemapped(
    path: &Path,
    width: usize,
    height: usize,
    data: &[f32],
    exposure_scale: Option<f32>,
) -> anyhow::Result<()> {
    check_size(width, height, data)?;
    let e = exposure_scale.unwrap_or_else(|| exposure(data));
    let px: Vec<u8> = data.iter().map(|v| srgb8(v * e)).collect();
    let img =
        image::GrayImage::from_raw(width as u32, height as u32, px).context("image buffer size")?;
    img.save_with_format(path, image::ImageFormat::Png)
        .with_context(|| format!("cannot write {}", path.display()))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn exr_round_trip_is_exact() {
        let dir = std::env::temp_dir().join(format!("pn-render-io-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let data: Vec<f32> = (0..12).map(|v| v as f32 * 0.37 + 1e-3).collect();
        let p = dir.join("a.exr");
        write_exr_gray(&p, 4, 3, &data).unwrap();
        let (w, h, back) = read_exr_gray(&p).unwrap();
        assert_eq!((w, h), (4, 3));
        assert_eq!(back, data);
        write_png_tonemapped(&dir.join("a.png"), 4, 3, &data, None).unwrap();
        assert!(write_exr_gray(&p, 5, 3, &data).is_err());
        assert!(read_exr_gray(&dir.join("missing.exr")).is_err());
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn tone_mapping_uses_the_99th_percentile() {
        let mut d: Vec<f32> = (1..=100).map(|v| v as f32).collect();
        d.push(1e6);
        // 101 values: index round(100·0.99) = 99 → value 100.
        assert_eq!(exposure(&d), 0.01);
        assert_eq!(srgb8(1.0), 255);
        assert_eq!(srgb8(0.0), 0);
        assert_eq!(exposure(&[0.0, 0.0]), 1.0);
    }
}
