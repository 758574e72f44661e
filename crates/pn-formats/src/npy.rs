//! Minimal NumPy `.npy` reading (float64/float32, C order) and writing (float64).

use anyhow::{bail, ensure, Context};
use std::io::Write;
use std::path::Path;

/// An n-dimensional float64 array in C order.
#[derive(Clone, Debug, PartialEq)]
pub struct NpyArray {
    /// Shape, slowest axis first.
    pub shape: Vec<usize>,
    /// Values in C order.
    pub data: Vec<f64>,
}

/// Writes `data` with `shape` as little-endian float64 `.npy` (version 1.0, C order).
pub fn write_npy(path: &Path, shape: &[usize], data: &[f64]) -> anyhow::Result<()> {
    let bytes = encode_npy(shape, data)?;
    std::fs::write(path, bytes).with_context(|| format!("cannot write {}", path.display()))
}

/// Encodes a float64 `.npy` file in memory.
pub fn encode_npy(shape: &[usize], data: &[f64]) -> anyhow::Result<Vec<u8>> {
    ensure!(
        shape.iter().product::<usize>() == data.len(),
        "npy shape {shape:?} does not match {} values",
        data.len()
    );
    let shape_str = match shape.len() {
        1 => format!("({},)", shape[0]),
        _ => format!(
            "({})",
            shape
                .iter()
                .map(|s| s.to_string())
                .collect::<Vec<_>>()
                .join(", ")
        ),
    };
    let mut header = format!("{{'descr': '<f8', 'fortran_order': False, 'shape': {shape_str}, }}");
    // Magic (6) + version (2) + header length (2) + header + '\n' is a multiple of 64.
    let total = 10 + header.len() + 1;
    header.push_str(&" ".repeat((64 - total % 64) % 64));
    header.push('\n');
    let mut out = Vec::with_capacity(10 + header.len() + 8 * data.len());
    out.extend_from_slice(b"\x93NUMPY\x01\x00");
    out.extend_from_slice(&(header.len() as u16).to_le_bytes());
    out.extend_from_slice(header.as_bytes());
    for v in data {
        out.write_all(&v.to_le_bytes())?;
    }
    Ok(out)
}

/// The longest header read (NumPy writes a few hundred bytes at most).
const MAX_HEADER: usize = 1 << 20;

/// Reads a `.npy` file of little-endian float64 or float32 in C order: the header first,
/// its shape checked against the file's length, then the data.
pub fn read_npy(path: &Path) -> anyhow::Result<NpyArray> {
    let (mut file, len) = crate::input::open_regular(path)?;
    let invalid = || format!("invalid .npy file {}", path.display());
    let mut head = crate::input::read_up_to(&mut file, 12).with_context(invalid)?;
    let (start, hlen) = header_span(&head).with_context(invalid)?;
    let more =
        crate::input::read_up_to(&mut file, (start + hlen).saturating_sub(head.len()) as u64)
            .with_context(invalid)?;
    head.extend(more);
    let h = header(&head).with_context(invalid)?;
    h.check_len(len).with_context(invalid)?;
    let bytes = crate::input::read_rest(&mut file, head, len).with_context(invalid)?;
    decode_npy(&bytes).with_context(invalid)
}

/// Where the header dict starts and its length, from the first 10 or 12 bytes.
fn header_span(bytes: &[u8]) -> anyhow::Result<(usize, usize)> {
    ensure!(
        bytes.len() >= 10 && &bytes[..6] == b"\x93NUMPY",
        "missing the \\x93NUMPY magic"
    );
    let major = bytes[6];
    let (hlen, start) = match major {
        1 => (u16::from_le_bytes([bytes[8], bytes[9]]) as usize, 10),
        2 | 3 => {
            ensure!(bytes.len() >= 12, "truncated header");
            (
                u32::from_le_bytes([bytes[8], bytes[9], bytes[10], bytes[11]]) as usize,
                12,
            )
        }
        v => bail!("unsupported .npy version {v}"),
    };
    ensure!(
        hlen <= MAX_HEADER,
        "the header declares {hlen} bytes, more than the {MAX_HEADER} this reader accepts"
    );
    Ok((start, hlen))
}

/// What a `.npy` header says.
struct Header {
    /// Where the data starts.
    data: usize,
    shape: Vec<usize>,
    /// Bytes per value (8 or 4).
    width: usize,
    /// Values (the shape's product).
    n: usize,
}

impl Header {
    /// The file's length must be the header's and the data's.
    fn check_len(&self, len: u64) -> anyhow::Result<()> {
        ensure!(
            len.checked_sub(self.data as u64) == Some((self.n * self.width) as u64),
            "shape {:?} needs {} bytes of data, the file has {}",
            self.shape,
            self.n * self.width,
            len.saturating_sub(self.data as u64)
        );
        Ok(())
    }
}

/// Parses the header (`bytes` holds at least all of it).
fn header(bytes: &[u8]) -> anyhow::Result<Header> {
    let (start, hlen) = header_span(bytes)?;
    ensure!(bytes.len() >= start + hlen, "truncated header");
    let header = std::str::from_utf8(&bytes[start..start + hlen]).context("header is not text")?;
    let descr = dict_value(header, "descr").context("header has no 'descr'")?;
    let descr = descr.trim_matches(|c| c == '\'' || c == '"');
    let width = match descr {
        "<f8" | "=f8" | "f8" => 8,
        "<f4" | "=f4" | "f4" => 4,
        other => bail!(
            "unsupported dtype {other:?} (expected little-endian float64 '<f8' or float32 '<f4')"
        ),
    };
    let fortran = dict_value(header, "fortran_order").context("header has no 'fortran_order'")?;
    ensure!(
        fortran.trim() == "False",
        "Fortran-ordered arrays are not supported (save with C order)"
    );
    let shape_txt = dict_value(header, "shape").context("header has no 'shape'")?;
    let inner = shape_txt
        .trim()
        .trim_start_matches('(')
        .trim_end_matches(')');
    let shape: Vec<usize> = inner
        .split(',')
        .map(str::trim)
        .filter(|s| !s.is_empty())
        .map(|s| {
            s.parse::<usize>()
                .with_context(|| format!("bad shape entry {s:?}"))
        })
        .collect::<anyhow::Result<_>>()?;
    // Checked: the header's shape is untrusted.
    let n = shape
        .iter()
        .try_fold(1usize, |acc, &d| acc.checked_mul(d))
        .filter(|n| n.checked_mul(width).is_some())
        .with_context(|| format!("shape {shape:?} is too large"))?;
    Ok(Header {
        data: start + hlen,
        shape,
        width,
        n,
    })
}

/// Decodes a `.npy` file held in memory.
pub fn decode_npy(bytes: &[u8]) -> anyhow::Result<NpyArray> {
    let h = header(bytes)?;
    h.check_len(bytes.len() as u64)?;
    let Header {
        data, shape, width, ..
    } = h;
    let payload = &bytes[data..];
    let data = if width == 8 {
        payload
            .chunks_exact(8)
            .map(|c| f64::from_le_bytes([c[0], c[1], c[2], c[3], c[4], c[5], c[6], c[7]]))
            .collect()
    } else {
        payload
            .chunks_exact(4)
            .map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]]) as f64)
            .collect()
    };
    Ok(NpyArray { shape, data })
}

/// The raw text of `key`'s value in the header dict (up to the next top-level comma).
fn dict_value<'a>(header: &'a str, key: &str) -> Option<&'a str> {
    let k1 = format!("'{key}'");
    let pos = header.find(&k1)? + k1.len();
    let rest = header[pos..].trim_start().strip_prefix(':')?;
    let mut depth = 0i32;
    for (i, ch) in rest.char_indices() {
        match ch {
            '(' => depth += 1,
            ')' => depth -= 1,
            ',' | '}' if depth == 0 => return Some(rest[..i].trim()),
            _ => {}
        }
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trip_and_alignment() {
        let bytes = encode_npy(&[2, 3], &[1.0, 2.0, 3.0, 4.0, 5.0, 6.0]).unwrap();
        assert_eq!((bytes.len() - 48) % 16, 0);
        let hlen = u16::from_le_bytes([bytes[8], bytes[9]]) as usize;
        assert_eq!((10 + hlen) % 64, 0);
        let a = decode_npy(&bytes).unwrap();
        assert_eq!(a.shape, vec![2, 3]);
        assert_eq!(a.data[4], 5.0);
        let one = decode_npy(&encode_npy(&[3], &[1.0, 2.0, 3.0]).unwrap()).unwrap();
        assert_eq!(one.shape, vec![3]);
    }

    #[test]
    fn rejects_wrong_size_and_dtype() {
        let mut bytes = encode_npy(&[2], &[1.0, 2.0]).unwrap();
        bytes.pop();
        assert!(decode_npy(&bytes).is_err());
        let s = String::from_utf8_lossy(&encode_npy(&[1], &[1.0]).unwrap()).replace("<f8", "<i8");
        assert!(decode_npy(s.as_bytes()).is_err());
    }
}
