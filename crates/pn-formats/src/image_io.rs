//! Image files: linear OpenEXR (f32; grey stored as equal R, G, B, or three channels) and
//! tone-mapped PNG (grey or RGB), and reading an EXR back as grey (the mean of its colour
//! channels) or as its three channels.

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
    write_exr_rgb(path, width, height, [data; 3])
}

/// Reads an OpenEXR file as grey: `(width, height, values)` row-major from the top-left,
/// each value the mean of R, G and B.
pub fn read_exr_gray(path: &Path) -> anyhow::Result<(usize, usize, Vec<f32>)> {
    let (w, h, channels) = read_exr_rgb(path)?;
    Ok((w, h, channel_mean(&channels)))
}

/// The per-pixel mean of R, G and B (how a colour image is read as grey).
pub fn channel_mean([r, g, b]: &[Vec<f32>; 3]) -> Vec<f32> {
    r.iter()
        .zip(g)
        .zip(b)
        .map(|((r, g), b)| ((*r as f64 + *g as f64 + *b as f64) / 3.0) as f32)
        .collect()
}

/// Three channel images (R, G, B; each row-major from the top-left) interleaved into one
/// RGB f32 image, each checked against the size.
fn rgb_image(
    width: usize,
    height: usize,
    channels: [&[f32]; 3],
) -> anyhow::Result<image::Rgb32FImage> {
    for c in channels {
        check_size(width, height, c)?;
    }
    let rgb: Vec<f32> = (0..width * height)
        .flat_map(|i| channels.map(|c| c[i]))
        .collect();
    image::Rgb32FImage::from_raw(width as u32, height as u32, rgb).context("image buffer size")
}

/// Writes three channel images (R, G, B; each row-major from the top-left) as one linear f32
/// RGB OpenEXR file.
pub fn write_exr_rgb(
    path: &Path,
    width: usize,
    height: usize,
    channels: [&[f32]; 3],
) -> anyhow::Result<()> {
    rgb_image(width, height, channels)?
        .save_with_format(path, image::ImageFormat::OpenExr)
        .with_context(|| format!("cannot write {}", path.display()))
}

/// Reads an image file's R, G and B channels: `(width, height, [r, g, b])`, each row-major
/// from the top-left.
pub fn read_exr_rgb(path: &Path) -> anyhow::Result<(usize, usize, [Vec<f32>; 3])> {
    // The header first: its size is checked before the decoder allocates for it (the
    // fuzzer's 410-byte EXR declared an image that took 3.4 GB and 16 s to decode).
    let (w, h) = image_reader(path)?
        .into_dimensions()
        .with_context(|| format!("cannot decode {} as an image", path.display()))?;
    anyhow::ensure!(
        u64::from(w) * u64::from(h) <= MAX_PIXELS,
        "{}: a {w}×{h} image, more than the {MAX_PIXELS} pixels an input image may have",
        path.display()
    );
    check_exr_windows(path)?;
    let img = image_reader(path)?
        .decode()
        .with_context(|| format!("cannot decode {} as an image", path.display()))?
        .into_rgb32f();
    let (w, h) = (img.width() as usize, img.height() as usize);
    let channel = |c: usize| img.pixels().map(|p| p.0[c]).collect::<Vec<f32>>();
    Ok((w, h, [channel(0), channel(1), channel(2)]))
}

/// The width and height of an image file, from its header alone (nothing decoded), so that
/// a caller can refuse a huge image before reading it.
pub fn image_dimensions(path: &Path) -> anyhow::Result<(usize, usize)> {
    let (w, h) = image_reader(path)?
        .into_dimensions()
        .with_context(|| format!("cannot read the header of {} as an image", path.display()))?;
    Ok((w as usize, h as usize))
}

/// Three channel images (R, G, B; row-major from the top-left) as the bytes of a linear f32
/// RGB OpenEXR file (what [`write_exr_rgb`] writes).
pub fn encode_exr_rgb(
    width: usize,
    height: usize,
    channels: [&[f32]; 3],
) -> anyhow::Result<Vec<u8>> {
    let mut bytes = std::io::Cursor::new(Vec::new());
    rgb_image(width, height, channels)?
        .write_to(&mut bytes, image::ImageFormat::OpenExr)
        .context("cannot encode the image as OpenEXR")?;
    Ok(bytes.into_inner())
}

/// An OpenEXR file's data windows (what its decoder allocates, whatever the display window
/// says) hold at most [`MAX_PIXELS`] each; other files pass.
fn check_exr_windows(path: &Path) -> anyhow::Result<()> {
    let (mut file, _) = crate::input::open_regular(path)
        .with_context(|| format!("cannot open {}", path.display()))?;
    let head = crate::input::read_up_to(&mut file, 1 << 16)?;
    if !head.starts_with(&[0x76, 0x2f, 0x31, 0x01]) {
        return Ok(());
    }
    let key = b"dataWindow\0box2i\0";
    let mut at = 0;
    // `at` stays within `head`: a key at the very end must not move it past (fuzzer finding).
    while let Some(i) = head
        .get(at..)
        .and_then(|rest| rest.windows(key.len()).position(|w| w == key))
    {
        let v = at + i + key.len() + 4;
        let int = |k: usize| {
            head.get(v + 4 * k..v + 4 * k + 4)
                .map(|b| i64::from(i32::from_le_bytes([b[0], b[1], b[2], b[3]])))
        };
        if let (Some(x0), Some(y0), Some(x1), Some(y1)) = (int(0), int(1), int(2), int(3)) {
            let (w, h) = (x1 - x0 + 1, y1 - y0 + 1);
            anyhow::ensure!(
                w > 0 && h > 0 && (w as u64) * (h as u64) <= MAX_PIXELS,
                "{}: an EXR data window of {w}×{h} pixels (at most {MAX_PIXELS})",
                path.display()
            );
        }
        at += i + key.len();
    }
    Ok(())
}

/// The most pixels an input image may have (8192 × 4096; 400 MB as RGB float32).
const MAX_PIXELS: u64 = 1 << 25;

/// A reader of the image file `path` (a regular file only: a stream such as /dev/zero is
/// refused at once), its format from the contents, else from the extension.
fn image_reader(
    path: &Path,
) -> anyhow::Result<image::ImageReader<std::io::BufReader<std::fs::File>>> {
    let (file, _) = crate::input::open_regular(path)
        .with_context(|| format!("cannot open {}", path.display()))?;
    let mut reader = image::ImageReader::new(std::io::BufReader::new(file));
    if let Ok(format) = image::ImageFormat::from_path(path) {
        reader.set_format(format);
    }
    reader
        .with_guessed_format()
        .with_context(|| format!("cannot read {}", path.display()))
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

/// Writes three channel images as an 8-bit RGB PNG, tone-mapped like
/// [`write_png_tonemapped`] with one exposure for all channels (from the values of all three
/// when `exposure_scale` is `None`), so that colours keep their ratios below the clamp.
pub fn write_png_tonemapped_rgb(
    path: &Path,
    width: usize,
    height: usize,
    channels: [&[f32]; 3],
    exposure_scale: Option<f32>,
) -> anyhow::Result<()> {
    for c in channels {
        check_size(width, height, c)?;
    }
    let e = exposure_scale.unwrap_or_else(|| exposure(&channels.concat()));
    let px: Vec<u8> = (0..width * height)
        .flat_map(|i| channels.map(|c| srgb8(c[i] * e)))
        .collect();
    let img =
        image::RgbImage::from_raw(width as u32, height as u32, px).context("image buffer size")?;
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
    fn rgb_exr_round_trip_keeps_the_channels() {
        let dir = std::env::temp_dir().join(format!("pn-render-io-rgb-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let r: Vec<f32> = (0..6).map(|v| v as f32 * 0.5).collect();
        let g: Vec<f32> = (0..6).map(|v| v as f32 * 0.25 + 1.0).collect();
        let b: Vec<f32> = (0..6).map(|v| 3.0 - v as f32 * 0.125).collect();
        let p = dir.join("c.exr");
        write_exr_rgb(&p, 3, 2, [&r, &g, &b]).unwrap();
        let (w, h, [r2, g2, b2]) = read_exr_rgb(&p).unwrap();
        assert_eq!((w, h), (3, 2));
        assert_eq!((r2, g2, b2), (r.clone(), g.clone(), b.clone()));
        let (_, _, grey) = read_exr_gray(&p).unwrap();
        assert!((grey[1] - (r[1] + g[1] + b[1]) / 3.0).abs() < 1e-6);
        write_png_tonemapped_rgb(&dir.join("c.png"), 3, 2, [&r, &g, &b], None).unwrap();
        let png = image::open(dir.join("c.png")).unwrap().into_rgb8();
        // Pixel 0: R = 0, G = 1, B = 3 (B is the 99th percentile of all values: exposure 1/3).
        assert_eq!(png.get_pixel(0, 0).0, [0, srgb8(1.0 / 3.0), 255]);
        assert!(write_exr_rgb(&p, 3, 2, [&r, &g, &b[..5]]).is_err());
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
