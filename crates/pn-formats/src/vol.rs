//! Mitsuba `.vol` grids (docs/design.md §6): `VOL`, u8 version 3, i32 encoding 1 (float32),
//! i32 xres yres zres, i32 channels, 6×f32 bounding box, then f32 data with x fastest.

use anyhow::{bail, ensure, Context};
use pn_runtime::field::VoxelGrid;
use std::path::Path;

const HEADER: usize = 3 + 1 + 4 + 12 + 4 + 24;

/// Reads a single-channel `.vol` file into a [`VoxelGrid`] (reordered to x slowest): the
/// header first, its declared size checked against the file's length, then the data.
pub fn read_vol(path: &Path) -> anyhow::Result<VoxelGrid> {
    let (mut file, len) = crate::input::open_regular(path)?;
    let invalid = || format!("invalid .vol file {}", path.display());
    let head = crate::input::read_up_to(&mut file, HEADER as u64).with_context(invalid)?;
    let h = header(&head).with_context(invalid)?;
    h.check_len(len).with_context(invalid)?;
    let bytes = crate::input::read_rest(&mut file, head, len).with_context(invalid)?;
    decode_vol(&bytes).with_context(invalid)
}

/// What a `.vol` header says.
struct Header {
    dims: [usize; 3],
    min: [f64; 3],
    max: [f64; 3],
    /// Values (`dims`' product).
    n: usize,
}

impl Header {
    /// The file's length must be the header's and the data's.
    fn check_len(&self, len: u64) -> anyhow::Result<()> {
        let [nx, ny, nz] = self.dims;
        let data = len.saturating_sub(HEADER as u64);
        ensure!(
            len == (HEADER + 4 * self.n) as u64,
            "header says {nx}×{ny}×{nz} float32 values ({} bytes of data) but the file has {data} bytes of data",
            4 * self.n,
        );
        Ok(())
    }
}

/// Parses the 48-byte header (`bytes` may go on with the data).
fn header(bytes: &[u8]) -> anyhow::Result<Header> {
    ensure!(
        bytes.len() >= HEADER,
        "file is {} bytes, shorter than the 48-byte header",
        bytes.len()
    );
    ensure!(&bytes[..3] == b"VOL", "missing the 'VOL' magic");
    ensure!(
        bytes[3] == 3,
        "unsupported version {} (expected 3)",
        bytes[3]
    );
    let word = |o: usize| [bytes[o], bytes[o + 1], bytes[o + 2], bytes[o + 3]];
    let i32_at = |o: usize| i32::from_le_bytes(word(o));
    let f32_at = |o: usize| f32::from_le_bytes(word(o)) as f64;
    let encoding = i32_at(4);
    if encoding != 1 {
        bail!("unsupported encoding {encoding} (only 1 = float32 is supported)");
    }
    let (nx, ny, nz, ch) = (i32_at(8), i32_at(12), i32_at(16), i32_at(20));
    ensure!(
        nx > 0 && ny > 0 && nz > 0,
        "resolution {nx}×{ny}×{nz} must be positive"
    );
    ensure!(
        ch == 1,
        "{ch} channels; only single-channel grids are supported"
    );
    let (nx, ny, nz) = (nx as usize, ny as usize, nz as usize);
    // Checked: the header's dimensions are untrusted (up to 2³¹ each).
    let n = nx
        .checked_mul(ny)
        .and_then(|v| v.checked_mul(nz))
        .filter(|n| {
            n.checked_mul(4)
                .and_then(|b| b.checked_add(HEADER))
                .is_some()
        })
        .with_context(|| format!("resolution {nx}×{ny}×{nz} is too large"))?;
    Ok(Header {
        dims: [nx, ny, nz],
        min: [f32_at(24), f32_at(28), f32_at(32)],
        max: [f32_at(36), f32_at(40), f32_at(44)],
        n,
    })
}

/// Decodes a `.vol` file held in memory.
pub fn decode_vol(bytes: &[u8]) -> anyhow::Result<VoxelGrid> {
    let h = header(bytes)?;
    h.check_len(bytes.len() as u64)?;
    let Header {
        dims: [nx, ny, nz],
        min,
        max,
        n,
    } = h;
    let f32_at =
        |o: usize| f32::from_le_bytes([bytes[o], bytes[o + 1], bytes[o + 2], bytes[o + 3]]) as f64;
    let mut data = vec![0.0; n];
    for z in 0..nz {
        for y in 0..ny {
            for x in 0..nx {
                let o = HEADER + 4 * ((z * ny + y) * nx + x);
                data[(x * ny + y) * nz + z] = f32_at(o);
            }
        }
    }
    VoxelGrid::new([nx, ny, nz], min, max, data)
}

/// Encodes a [`VoxelGrid`] as a single-channel `.vol` file.
pub fn encode_vol(grid: &VoxelGrid) -> Vec<u8> {
    encode_vol_scaled(grid, &[1.0])
}

/// Encodes a [`VoxelGrid`] as a `.vol` file with one channel per factor: channel c holds
/// `factors[c]` × the grid's value (channels interleaved per voxel, as Mitsuba reads them;
/// three channels are an RGB volume).
pub fn encode_vol_scaled(grid: &VoxelGrid, factors: &[f64]) -> Vec<u8> {
    let [nx, ny, nz] = grid.dims;
    let ch = factors.len();
    let mut out = Vec::with_capacity(HEADER + 4 * ch * nx * ny * nz);
    out.extend_from_slice(b"VOL\x03");
    for v in [1i32, nx as i32, ny as i32, nz as i32, ch as i32] {
        out.extend_from_slice(&v.to_le_bytes());
    }
    for v in grid.min.iter().chain(&grid.max) {
        out.extend_from_slice(&(*v as f32).to_le_bytes());
    }
    for z in 0..nz {
        for y in 0..ny {
            for x in 0..nx {
                for f in factors {
                    out.extend_from_slice(&((f * grid.at(x, y, z)) as f32).to_le_bytes());
                }
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trip_keeps_orientation() {
        let data: Vec<f64> = (0..24).map(|v| v as f64).collect();
        let g = VoxelGrid::new([2, 3, 4], [0.0; 3], [1.0, 2.0, 3.0], data).unwrap();
        let back = decode_vol(&encode_vol(&g)).unwrap();
        assert_eq!(back, g);
        // x fastest in the file: the second value is cell (1, 0, 0).
        let bytes = encode_vol(&g);
        let second = f32::from_le_bytes(bytes[HEADER + 4..HEADER + 8].try_into().unwrap());
        assert_eq!(second as f64, g.at(1, 0, 0));
    }

    #[test]
    fn channels_are_interleaved_per_voxel() {
        let g = VoxelGrid::new([2, 1, 1], [0.0; 3], [1.0; 3], vec![1.0, 2.0]).unwrap();
        let bytes = encode_vol_scaled(&g, &[1.0, 0.5, 0.25]);
        assert_eq!(i32::from_le_bytes(bytes[20..24].try_into().unwrap()), 3);
        let f = |i: usize| {
            f32::from_le_bytes(
                bytes[HEADER + 4 * i..HEADER + 4 * i + 4]
                    .try_into()
                    .unwrap(),
            )
        };
        assert_eq!(
            (0..6).map(f).collect::<Vec<_>>(),
            [1.0, 0.5, 0.25, 2.0, 1.0, 0.5]
        );
        assert_eq!(bytes.len(), HEADER + 4 * 6);
    }

    #[test]
    fn wrong_size_or_encoding_is_rejected() {
        let g = VoxelGrid::new([1, 1, 2], [0.0; 3], [1.0; 3], vec![1.0, 2.0]).unwrap();
        let mut b = encode_vol(&g);
        b.pop();
        assert!(decode_vol(&b)
            .unwrap_err()
            .to_string()
            .contains("bytes of data"));
        let mut b = encode_vol(&g);
        b[4] = 2;
        assert!(decode_vol(&b).unwrap_err().to_string().contains("encoding"));
    }
}
