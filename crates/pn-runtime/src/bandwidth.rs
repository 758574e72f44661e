//! The machine's memory bandwidth, measured, and the roofline of a memory-bound operator.
//!
//! # Method ([`measure`])
//!
//! A STREAM-like measurement (McCalpin's STREAM, <https://www.cs.virginia.edu/stream/>):
//! three `f64` arrays `a`, `b`, `c`, first touched by the threads that later stream them.
//! [`measure_default`] sizes each array by STREAM's rule, at least four times the
//! last-level cache ([`default_array_bytes`]): with arrays that fit in the cache the
//! kernels measure the cache, not the memory. (On a VM reporting a 300 MiB L3, the fixed
//! 3 × 64 MiB arrays used before gave a "triad" of 48–59 GB/s, the L3's; 3 × 256 MiB and
//! more give 29–30 GB/s, the DRAM's.) Two kernels:
//!
//! * **copy** `c[i] = a[i]`: 16 bytes per element (one read, one write);
//! * **triad** `a[i] = b[i] + s·c[i]`: 24 bytes per element (two reads, one write).
//!
//! Bytes are counted as STREAM counts them: every array read or written once, the
//! write-allocate read of the written line not counted (so the numbers are comparable with
//! published STREAM results, and with the operator byte models, which count the same way,
//! [`pn_krylov::operator::LinearOperator::bytes_per_application`]). Each kernel runs
//! `repetitions` times and the **best** (shortest) time is reported, as STREAM does: the
//! bandwidth the machine can deliver, not its average under load. The parallel figures run
//! on the current rayon pool (all its threads, chunks of [`CHUNK`] elements); the
//! single-thread figures run the same loops on the calling thread.
//!
//! # Roofline
//!
//! For an operator whose application moves `bytes` (its model) and takes `seconds`
//! (measured, [`median_seconds`]), the achieved bandwidth is `bytes / seconds`, and
//! [`roofline_ratio`] `= seconds / (bytes / bandwidth)` is how many times slower the
//! application is than the memory-bandwidth limit (1 = at the limit; below 1 when the data
//! stay in cache between applications, so the DRAM limit does not bind).

use crate::memory_estimate::available_memory_bytes;
use rayon::prelude::*;
use std::hint::black_box;
use std::time::Instant;

/// Smallest bytes of each of the three arrays of [`measure_default`]: 64 MiB (used as is
/// where the last-level cache is unknown or under 16 MiB).
pub const DEFAULT_ARRAY_BYTES: usize = 64 << 20;
/// STREAM's rule: each array at least this many times the last-level cache.
pub const CACHE_MULTIPLE: usize = 4;
/// Repetitions of each kernel in [`measure_default`] (the best is kept).
pub const DEFAULT_REPETITIONS: usize = 10;
/// Elements per rayon task in the parallel kernels (512 KiB of each array).
pub const CHUNK: usize = 1 << 16;

/// Measured memory bandwidth in GB/s (10⁹ bytes per second).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Bandwidth {
    /// Triad `a = b + s·c` on all threads of the rayon pool.
    pub triad_gbs: f64,
    /// Copy `c = a` on all threads.
    pub copy_gbs: f64,
    /// Triad on one thread.
    pub triad_gbs_single: f64,
    /// Copy on one thread.
    pub copy_gbs_single: f64,
    /// Threads of the parallel figures.
    pub threads: usize,
    /// Bytes of each array.
    pub array_bytes: usize,
    /// Repetitions of each kernel (the best time is kept).
    pub repetitions: usize,
}

impl Bandwidth {
    /// One line for reports: `triad 9.8 GB/s, copy 8.7 GB/s on 2 threads (1 thread: …)`.
    pub fn describe(&self) -> String {
        format!(
            "triad {:.2} GB/s, copy {:.2} GB/s on {} thread{} (one thread: triad {:.2}, copy {:.2} GB/s); \
             3 arrays of {} MiB f64, best of {}",
            self.triad_gbs,
            self.copy_gbs,
            self.threads,
            if self.threads == 1 { "" } else { "s" },
            self.triad_gbs_single,
            self.copy_gbs_single,
            self.array_bytes >> 20,
            self.repetitions
        )
    }
}

/// [`measure`] with three arrays of [`default_array_bytes`], best of 10 (one to ten
/// seconds, depending on the cache).
pub fn measure_default() -> Bandwidth {
    measure(default_array_bytes(), DEFAULT_REPETITIONS)
}

/// Bytes of each array of [`measure_default`]: [`CACHE_MULTIPLE`] times the last-level
/// cache ([`last_level_cache_bytes`]), at least [`DEFAULT_ARRAY_BYTES`], and at most an
/// eighth of the memory available now (the three arrays then take at most 3/8 of it).
pub fn default_array_bytes() -> usize {
    let wanted = last_level_cache_bytes().map_or(DEFAULT_ARRAY_BYTES, |c| {
        (CACHE_MULTIPLE * c).max(DEFAULT_ARRAY_BYTES)
    });
    match available_memory_bytes() {
        Some(avail) => wanted.min((avail as usize / 8).max(DEFAULT_ARRAY_BYTES)),
        None => wanted,
    }
}

/// The largest cache of CPU 0 (Linux `sysfs`, `/sys/devices/system/cpu/cpu0/cache`), in
/// bytes; `None` where it is not reported.
pub fn last_level_cache_bytes() -> Option<usize> {
    let dir = std::fs::read_dir("/sys/devices/system/cpu/cpu0/cache").ok()?;
    dir.filter_map(|e| {
        let size = std::fs::read_to_string(e.ok()?.path().join("size")).ok()?;
        parse_cache_size(&size)
    })
    .max()
}

/// A `sysfs` cache size (`"48K"`, `"2048K"`, `"300M"`, `"1G"` or plain bytes) in bytes.
fn parse_cache_size(text: &str) -> Option<usize> {
    let t = text.trim();
    let (digits, unit) = match t.char_indices().find(|(_, c)| !c.is_ascii_digit()) {
        Some((i, _)) => (&t[..i], t[i..].trim()),
        None => (t, ""),
    };
    let shift = match unit {
        "" => 0,
        "K" | "k" => 10,
        "M" => 20,
        "G" => 30,
        _ => return None,
    };
    digits.parse::<usize>().ok()?.checked_mul(1 << shift)
}

/// Measures copy and triad bandwidth with three arrays of `array_bytes` each (rounded down
/// to whole `f64`, at least one), best of `repetitions` (at least one); see the module
/// documentation for the method.
pub fn measure(array_bytes: usize, repetitions: usize) -> Bandwidth {
    let n = (array_bytes / 8).max(1);
    let reps = repetitions.max(1);
    // `vec![0.0; n]` maps zeroed pages lazily; the parallel fill touches them first, by the
    // same chunking as the kernels.
    let fill = |v: f64| {
        let mut x = vec![0.0; n];
        x.par_chunks_mut(CHUNK).for_each(|c| c.fill(v));
        x
    };
    let (mut a, b, mut c) = (fill(1.0), fill(2.0), fill(0.5));
    let s = black_box(3.0);
    let gbs = |bytes_per_elem: usize, secs: f64| (bytes_per_elem * n) as f64 / secs / 1e9;
    let best = |f: &mut dyn FnMut()| {
        (0..reps)
            .map(|_| {
                let t = Instant::now();
                f();
                t.elapsed().as_secs_f64()
            })
            .fold(f64::INFINITY, f64::min)
            .max(1e-12)
    };
    let copy_par = best(&mut || {
        c.par_chunks_mut(CHUNK)
            .zip(a.par_chunks(CHUNK))
            .for_each(|(c, a)| c.copy_from_slice(a));
        black_box(&mut c);
    });
    let triad_par = best(&mut || {
        a.par_chunks_mut(CHUNK)
            .zip(b.par_chunks(CHUNK).zip(c.par_chunks(CHUNK)))
            .for_each(|(a, (b, c))| {
                a.iter_mut()
                    .zip(b.iter().zip(c))
                    .for_each(|(a, (b, c))| *a = b + s * c)
            });
        black_box(&mut a);
    });
    let copy_one = best(&mut || {
        c.copy_from_slice(&a);
        black_box(&mut c);
    });
    let triad_one = best(&mut || {
        a.iter_mut()
            .zip(b.iter().zip(&c))
            .for_each(|(a, (b, c))| *a = b + s * c);
        black_box(&mut a);
    });
    Bandwidth {
        triad_gbs: gbs(24, triad_par),
        copy_gbs: gbs(16, copy_par),
        triad_gbs_single: gbs(24, triad_one),
        copy_gbs_single: gbs(16, copy_one),
        threads: rayon::current_num_threads(),
        array_bytes: n * 8,
        repetitions: reps,
    }
}

/// The median time of one call of `f`, over at least `min_reps` calls after one warm-up call,
/// and more (up to `max_reps`) while the calls so far took less than `budget_s` seconds.
pub fn median_seconds(min_reps: usize, max_reps: usize, budget_s: f64, mut f: impl FnMut()) -> f64 {
    f();
    let (min_reps, max_reps) = (min_reps.max(1), max_reps.max(min_reps.max(1)));
    let mut times = Vec::with_capacity(max_reps);
    let mut total = 0.0;
    while times.len() < min_reps || (times.len() < max_reps && total < budget_s) {
        let t = Instant::now();
        f();
        let dt = t.elapsed().as_secs_f64();
        total += dt;
        times.push(dt);
    }
    times.sort_by(f64::total_cmp);
    let m = times.len();
    if m % 2 == 1 {
        times[m / 2]
    } else {
        0.5 * (times[m / 2 - 1] + times[m / 2])
    }
}

/// Bandwidth achieved by moving `bytes` in `seconds`, in GB/s.
pub fn achieved_gbs(bytes: f64, seconds: f64) -> f64 {
    bytes / seconds.max(1e-300) / 1e9
}

/// `seconds / (bytes / bandwidth)`: how many times the time of moving `bytes` at
/// `bandwidth_gbs` the application took (1 at the bandwidth limit, 2 at half of it).
pub fn roofline_ratio(bytes: f64, seconds: f64, bandwidth_gbs: f64) -> f64 {
    seconds / (bytes / (bandwidth_gbs * 1e9))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn small_measurement_is_finite_and_positive() {
        // 1 MiB arrays keep the test fast; the numbers are cache bandwidth, not DRAM.
        let bw = measure(1 << 20, 2);
        for v in [
            bw.triad_gbs,
            bw.copy_gbs,
            bw.triad_gbs_single,
            bw.copy_gbs_single,
        ] {
            assert!(v.is_finite() && v > 0.0, "{bw:?}");
        }
        assert_eq!((bw.array_bytes, bw.repetitions), (1 << 20, 2));
        assert!(bw.threads >= 1);
        assert!(bw.describe().contains("triad"), "{}", bw.describe());
    }

    #[test]
    fn cache_sizes_parse_as_sysfs_writes_them() {
        assert_eq!(parse_cache_size("48K\n"), Some(48 << 10));
        assert_eq!(parse_cache_size("307200K"), Some(300 << 20));
        assert_eq!(parse_cache_size("32M"), Some(32 << 20));
        assert_eq!(parse_cache_size("4096"), Some(4096));
        assert_eq!(parse_cache_size("12 X"), None);
        assert_eq!(parse_cache_size(""), None);
        // The default arrays are never smaller than the floor, and, where the cache is
        // reported, at least four times it (unless memory is short).
        let bytes = default_array_bytes();
        assert!(bytes >= DEFAULT_ARRAY_BYTES);
        if let (Some(c), Some(avail)) = (last_level_cache_bytes(), available_memory_bytes()) {
            assert!(bytes >= (CACHE_MULTIPLE * c).min(avail as usize / 8));
        }
    }

    #[test]
    fn median_and_ratio() {
        let mut calls = 0;
        let m = median_seconds(3, 3, 0.0, || calls += 1);
        assert_eq!(calls, 4, "one warm-up and three timed calls");
        assert!(m >= 0.0 && m.is_finite());
        // 1 GB at 10 GB/s takes 0.1 s: 0.2 s is twice the limit.
        assert!((roofline_ratio(1e9, 0.2, 10.0) - 2.0).abs() < 1e-12);
        assert!((achieved_gbs(1e9, 0.2) - 5.0).abs() < 1e-12);
    }
}
