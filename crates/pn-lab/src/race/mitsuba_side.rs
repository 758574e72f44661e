//! The Mitsuba side of `pn race`: the helper script (`mitsuba_race.py`, compiled into the
//! binary), one timed Python process per render, and the cached two-halves reference.

use super::metrics::{two_halves, TwoHalves};
use super::proc::{run_timed, Timed};
use anyhow::{Context, Result};
use pn_drivers::mitsuba;
use pn_formats::write_exr_gray;
use pn_render::compare::{read_gray, GrayImage};
use pn_render::mitsuba::{ExportOptions, ALBEDO_FILE, DENSITY_FILE, SCRIPT_FILE, SKY_FILE};
use pn_render::RenderScene;
use serde::{Deserialize, Serialize};
use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::Command;

/// The helper script, written next to each export.
pub const HELPER: &str = include_str!("mitsuba_race.py");
/// Its file name.
pub const HELPER_FILE: &str = "mitsuba_race.py";
/// The Open Image Denoise binding `scripts/mitsuba-venv.sh` installs.
pub const PYOIDN_VERSION: &str = "2.5.1.0";

/// Seeds of the reference halves (the test renders use seeds 1, 2, …).
const REFERENCE_SEEDS: [u64; 2] = [900_001, 900_002];

/// The Python interpreter and the helper script it runs.
#[derive(Clone, Debug)]
pub struct Mitsuba {
    /// Interpreter with `mitsuba` and `pyoidn`.
    pub python: PathBuf,
    /// The Mitsuba version it reported.
    pub version: String,
}

impl Mitsuba {
    /// Finds the interpreter ([`mitsuba::find_python`]) and checks that it imports Mitsuba
    /// and pyoidn, with errors that name `scripts/mitsuba-venv.sh`.
    pub fn find(explicit: Option<&Path>, scratch: &Path) -> Result<Self> {
        let python = mitsuba::find_python(explicit)?;
        mitsuba::check_python(&python)?;
        let helper = write_helper(scratch)?;
        let out = Command::new(&python)
            .arg(&helper)
            .arg("check")
            .output()
            .with_context(|| format!("cannot run {}", python.display()))?;
        anyhow::ensure!(
            out.status.success(),
            "{} cannot run the race helper (Mitsuba + pyoidn {PYOIDN_VERSION}): {}\n\
             install both with scripts/mitsuba-venv.sh",
            python.display(),
            String::from_utf8_lossy(&out.stderr).trim()
        );
        let v: serde_json::Value = serde_json::from_str(
            String::from_utf8_lossy(&out.stdout)
                .lines()
                .last()
                .unwrap_or(""),
        )
        .context("unexpected output of mitsuba_race.py check")?;
        Ok(Self {
            python,
            version: v["mitsuba"].as_str().unwrap_or("?").to_string(),
        })
    }
}

/// Writes the helper script into `dir`; returns its path.
pub fn write_helper(dir: &Path) -> Result<PathBuf> {
    std::fs::create_dir_all(dir).with_context(|| format!("cannot create {}", dir.display()))?;
    let p = dir.join(HELPER_FILE);
    std::fs::write(&p, HELPER).with_context(|| format!("cannot write {}", p.display()))?;
    Ok(p)
}

/// One Mitsuba render request.
#[derive(Clone, Debug)]
pub struct MitsubaJob<'a> {
    /// Folder of `pn export-mitsuba` (with `render_mitsuba.py` and the helper).
    pub export: &'a Path,
    /// Samples per pixel.
    pub spp: usize,
    /// Sampler seed.
    pub seed: u64,
    /// `volpath` max_depth (−1 all bounces, 2 single scattering).
    pub max_depth: i64,
    /// Denoise with Open Image Denoise.
    pub denoise: bool,
    /// Output EXR (with views: `<stem>_<k>.exr`).
    pub out: &'a Path,
    /// A JSON file of cameras (turntable), or None for the scene camera.
    pub views: Option<&'a Path>,
}

/// What the helper reported, plus the wall time of the whole process.
#[derive(Clone, Debug)]
pub struct MitsubaResult {
    /// Wall seconds of the whole Python process (start, import, load, render, write).
    pub wall: f64,
    /// Seconds in `mi.render` (all views).
    pub render: f64,
    /// Seconds in pyoidn.
    pub denoise: f64,
    /// The images written.
    pub images: Vec<PathBuf>,
}

/// Runs one Mitsuba render as its own Python process and times it.
pub fn render(m: &Mitsuba, job: &MitsubaJob) -> Result<MitsubaResult> {
    let mut cmd = Command::new(&m.python);
    cmd.arg(job.export.join(HELPER_FILE))
        .arg("render")
        .arg("--export")
        .arg(job.export)
        .args(["--spp", &job.spp.to_string()])
        .args(["--seed", &job.seed.to_string()])
        .args(["--max-depth", &job.max_depth.to_string()])
        .arg("--out")
        .arg(job.out);
    if job.denoise {
        cmd.arg("--denoise");
    }
    if let Some(v) = job.views {
        cmd.arg("--views").arg(v);
    }
    let Timed { wall, stdout } = run_timed(&mut cmd, "Mitsuba render (mitsuba_race.py)")?;
    let last = stdout.lines().last().unwrap_or("");
    let v: serde_json::Value = serde_json::from_str(last)
        .with_context(|| format!("unexpected output of mitsuba_race.py: {stdout}"))?;
    let images = v["images"]
        .as_array()
        .map(|a| {
            a.iter()
                .filter_map(|s| s.as_str().map(PathBuf::from))
                .collect()
        })
        .unwrap_or_default();
    Ok(MitsubaResult {
        wall,
        render: v["seconds_render"].as_f64().unwrap_or(f64::NAN),
        denoise: v["seconds_denoise"].as_f64().unwrap_or(0.0),
        images,
    })
}

/// Exports `scene` for Mitsuba into `dir` (fixed script options, so that the files depend on
/// the scene alone) and writes the helper beside it.
pub fn export_scene(scene: &RenderScene, dir: &Path) -> Result<()> {
    let opts = ExportOptions {
        spp: 1,
        seed: 1,
        max_depth: -1,
    };
    mitsuba::export(scene, dir, &opts)?;
    write_helper(dir)?;
    Ok(())
}

/// 64-bit FNV-1a.
fn fnv1a(h: &mut u64, bytes: &[u8]) {
    for b in bytes {
        *h ^= u64::from(*b);
        *h = h.wrapping_mul(0x0000_0100_0000_01b3);
    }
}

/// The cache key of a reference: a hash of the exported files (script, density, albedo),
/// the spp, max_depth, seeds and the Mitsuba version.
pub fn cache_key(export: &Path, spp: usize, max_depth: i64, version: &str) -> Result<String> {
    let mut h = 0xcbf2_9ce4_8422_2325u64;
    for f in [SCRIPT_FILE, DENSITY_FILE, ALBEDO_FILE, SKY_FILE] {
        let p = export.join(f);
        if p.is_file() {
            fnv1a(&mut h, f.as_bytes());
            fnv1a(
                &mut h,
                &std::fs::read(&p).with_context(|| format!("cannot read {}", p.display()))?,
            );
        }
    }
    fnv1a(
        &mut h,
        format!("spp={spp};depth={max_depth};seeds={REFERENCE_SEEDS:?};mitsuba={version}")
            .as_bytes(),
    );
    Ok(format!("{h:016x}"))
}

/// The metadata stored with a cached reference.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct ReferenceInfo {
    /// Scene name.
    pub scene: String,
    /// Cache key.
    pub key: String,
    /// Samples per pixel of each half.
    pub spp_per_half: usize,
    /// `volpath` max_depth.
    pub max_depth: i64,
    /// Seeds of the halves.
    pub seeds: [u64; 2],
    /// Relative RMSE noise of the mean ([`TwoHalves::noise_rel_rmse`]).
    pub noise_rel_rmse: f64,
    /// Relative noise of the image mean ([`TwoHalves::noise_rel_mean`]).
    pub noise_rel_mean: f64,
    /// Relative difference of the halves' means.
    pub halves_rel_diff: f64,
    /// Wall seconds the two renders took.
    pub seconds: f64,
    /// Mitsuba version.
    pub mitsuba: String,
}

/// A reference image with its noise.
#[derive(Clone, Debug)]
pub struct Reference {
    /// The mean of the halves.
    pub image: GrayImage,
    /// Its metadata.
    pub info: ReferenceInfo,
}

/// The reference of `scene_name` exported in `export` at `total_spp` (two halves of
/// `total_spp/2`) and `max_depth`: read from `cache/<scene>-<depth>-<key>/` when present,
/// else rendered and stored there.
pub fn reference(
    m: &Mitsuba,
    scene_name: &str,
    export: &Path,
    cache: &Path,
    total_spp: usize,
    max_depth: i64,
    log: &mut dyn Write,
) -> Result<Reference> {
    anyhow::ensure!(
        total_spp >= 2,
        "the reference needs at least 2 spp (two halves), got {total_spp}"
    );
    let half = total_spp / 2;
    let key = cache_key(export, half, max_depth, &m.version)?;
    let depth = if max_depth < 0 {
        "all".to_string()
    } else {
        max_depth.to_string()
    };
    let dir = cache.join(format!("{scene_name}-depth{depth}-{key}"));
    let info_path = dir.join("reference.json");
    let image_path = dir.join("reference.exr");
    if info_path.is_file() && image_path.is_file() {
        let info: ReferenceInfo = serde_json::from_str(
            &std::fs::read_to_string(&info_path)
                .with_context(|| format!("cannot read {}", info_path.display()))?,
        )
        .with_context(|| format!("malformed {}", info_path.display()))?;
        let image = read_gray(&image_path)?;
        writeln!(
            log,
            "  reference (max_depth {max_depth}, {total_spp} spp): cached in {}",
            dir.display()
        )?;
        return Ok(Reference { image, info });
    }
    writeln!(
        log,
        "  reference (max_depth {max_depth}, 2 × {half} spp): rendering into {} …",
        dir.display()
    )?;
    log.flush()?;
    std::fs::create_dir_all(&dir).with_context(|| format!("cannot create {}", dir.display()))?;
    let mut halves = Vec::new();
    let mut seconds = 0.0;
    for (i, seed) in REFERENCE_SEEDS.iter().enumerate() {
        let out = dir.join(format!("half{i}.exr"));
        let r = render(
            m,
            &MitsubaJob {
                export,
                spp: half,
                seed: *seed,
                max_depth,
                denoise: false,
                out: &out,
                views: None,
            },
        )?;
        seconds += r.wall;
        halves.push(read_gray(&out)?);
    }
    let TwoHalves {
        mean,
        noise_rel_rmse,
        noise_rel_mean,
        halves_rel_diff,
    } = two_halves(&halves[0], &halves[1])?;
    let data: Vec<f32> = mean.data.iter().map(|v| *v as f32).collect();
    write_exr_gray(&image_path, mean.width, mean.height, &data)?;
    let info = ReferenceInfo {
        scene: scene_name.to_string(),
        key,
        spp_per_half: half,
        max_depth,
        seeds: REFERENCE_SEEDS,
        noise_rel_rmse,
        noise_rel_mean,
        halves_rel_diff,
        seconds,
        mitsuba: m.version.clone(),
    };
    std::fs::write(&info_path, serde_json::to_string_pretty(&info)? + "\n")
        .with_context(|| format!("cannot write {}", info_path.display()))?;
    // The stored image is f32: read it back so that cached and fresh runs agree exactly.
    let image = read_gray(&image_path)?;
    writeln!(
        log,
        "  reference: {seconds:.1} s, noise of the mean: relative RMSE {noise_rel_rmse:.4}, \
         relative mean {noise_rel_mean:.2e}"
    )?;
    Ok(Reference { image, info })
}
