//! Mitsuba 3 ground truth, the files and the processes (docs/rendering.md): writes the export
//! of a render scene that `pn_render::mitsuba` computes (`density.vol`, `albedo.vol` for an
//! albedo grid, `render_mitsuba.py`) into a folder through `pn-formats`, finds the Python
//! interpreter that has Mitsuba, and runs the script. Used by `pn export-mitsuba`
//! ([`crate::export_mitsuba`]), the lab (`pn race`, `pn figure`) and the tests.

use anyhow::{bail, ensure, Context};
use pn_render::mitsuba::{
    export_files, ExportOptions, ALBEDO_FILE, DENSITY_FILE, PYTHON_ENV, SCRIPT_FILE, SKY_FILE,
    VENV_PYTHON,
};
use pn_render::{DensityFilter, RenderScene};
use std::path::{Path, PathBuf};
use std::process::Command;

/// The files of an export.
#[derive(Clone, Debug, PartialEq)]
pub struct Exported {
    /// The folder.
    pub dir: PathBuf,
    /// `render_mitsuba.py`.
    pub script: PathBuf,
    /// `density.vol`.
    pub density: PathBuf,
    /// `albedo.vol` where the albedo is a grid.
    pub albedo: Option<PathBuf>,
    /// The `filter_type` the script gives the grids (the scene's filter).
    pub filter: DensityFilter,
}

/// Writes `dir/density.vol` (and `dir/albedo.vol` for an albedo grid) and
/// `dir/render_mitsuba.py` for `scene` ([`pn_render::mitsuba::export_files`]); creates `dir`.
pub fn export(scene: &RenderScene, dir: &Path, opts: &ExportOptions) -> anyhow::Result<Exported> {
    let files = export_files(scene, opts)?;
    let density = dir.join(DENSITY_FILE);
    let albedo = files.albedo.as_ref().map(|_| dir.join(ALBEDO_FILE));
    let script = dir.join(SCRIPT_FILE);
    // All or none: a script that cannot be written leaves no density.vol behind.
    let mut out: Vec<(&str, &[u8])> = vec![(DENSITY_FILE, &files.density)];
    if let Some(bytes) = &files.albedo {
        out.push((ALBEDO_FILE, bytes));
    }
    if let Some(bytes) = &files.sky {
        out.push((SKY_FILE, bytes));
    }
    out.push((SCRIPT_FILE, files.script.as_bytes()));
    pn_formats::files::write_all_or_none(dir, &out)?;
    Ok(Exported {
        dir: dir.to_path_buf(),
        script,
        density,
        albedo,
        filter: files.filter,
    })
}

/// The Python interpreter to run Mitsuba with: `explicit`, the caller's choice (the `pn`
/// binary passes `--python`, else `$PN_MITSUBA_PYTHON`; this library reads no environment),
/// else `.venv-mitsuba/bin/python` in the current folder or in the repository this binary
/// was built from. Errors name `scripts/mitsuba-venv.sh`.
pub fn find_python(explicit: Option<&Path>) -> anyhow::Result<PathBuf> {
    if let Some(p) = explicit {
        return Ok(p.to_path_buf());
    }
    let repo = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    for base in [Path::new("."), repo.as_path()] {
        let p = base.join(VENV_PYTHON);
        if p.is_file() {
            return Ok(p);
        }
    }
    bail!(
        "no Python with Mitsuba found: run scripts/mitsuba-venv.sh (creates {VENV_PYTHON}), \
         or pass --python / set {PYTHON_ENV} to an interpreter that has `mitsuba` installed"
    )
}

/// Checks that `python` runs and imports `mitsuba` with the `scalar_rgb` variant; returns
/// the Mitsuba version.
pub fn check_python(python: &Path) -> anyhow::Result<String> {
    let out = Command::new(python)
        .args([
            "-c",
            "import mitsuba as mi; mi.set_variant('scalar_rgb'); print(mi.__version__)",
        ])
        .output()
        .with_context(|| {
            format!(
                "cannot run the Python interpreter {} (create one with scripts/mitsuba-venv.sh)",
                python.display()
            )
        })?;
    if !out.status.success() {
        bail!(
            "{} cannot import mitsuba (scalar_rgb): {}\ninstall it with scripts/mitsuba-venv.sh",
            python.display(),
            String::from_utf8_lossy(&out.stderr).trim()
        );
    }
    Ok(String::from_utf8_lossy(&out.stdout).trim().to_string())
}

/// Overrides for one run of an exported script (`None`: the exported value).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct RunOptions {
    /// Samples per pixel.
    pub spp: Option<usize>,
    /// Sampler seed.
    pub seed: Option<u64>,
    /// `volpath` max_depth.
    pub max_depth: Option<i64>,
    /// Output EXR (default `dir/mitsuba.exr`).
    pub out: Option<PathBuf>,
}

/// The result of one Mitsuba render.
#[derive(Clone, Debug, PartialEq)]
pub struct MitsubaRun {
    /// The EXR written.
    pub image: PathBuf,
    /// Seconds spent in `mi.render` (scene loading excluded).
    pub seconds: f64,
}

/// Runs `dir/render_mitsuba.py` with `python` as exported; returns the EXR's path.
pub fn run_mitsuba(dir: &Path, python: &Path) -> anyhow::Result<PathBuf> {
    Ok(run_mitsuba_with(dir, python, &RunOptions::default())?.image)
}

/// Runs `dir/render_mitsuba.py` with `python` and the overrides in `opts`.
pub fn run_mitsuba_with(
    dir: &Path,
    python: &Path,
    opts: &RunOptions,
) -> anyhow::Result<MitsubaRun> {
    let script = dir.join(SCRIPT_FILE);
    ensure!(
        script.is_file(),
        "{} does not exist: run `pn export-mitsuba` first",
        script.display()
    );
    check_python(python)?;
    let mut cmd = Command::new(python);
    cmd.arg(&script);
    if let Some(s) = opts.spp {
        ensure!(s >= 1, "spp must be at least 1");
        cmd.args(["--spp", &s.to_string()]);
    }
    if let Some(s) = opts.seed {
        cmd.args(["--seed", &s.to_string()]);
    }
    if let Some(d) = opts.max_depth {
        ensure!(d == -1 || d >= 1, "max_depth must be -1 or at least 1");
        cmd.args(["--max-depth", &d.to_string()]);
    }
    if let Some(o) = &opts.out {
        cmd.arg("--out").arg(o);
    }
    let out = cmd
        .output()
        .with_context(|| format!("cannot run {} {}", python.display(), script.display()))?;
    if !out.status.success() {
        bail!(
            "Mitsuba render failed ({}): {}",
            out.status,
            String::from_utf8_lossy(&out.stderr).trim()
        );
    }
    let stdout = String::from_utf8_lossy(&out.stdout);
    let last = stdout.lines().last().unwrap_or("");
    let v: serde_json::Value = serde_json::from_str(last)
        .with_context(|| format!("unexpected output of {}: {stdout}", script.display()))?;
    let image = v["image"]
        .as_str()
        .map(PathBuf::from)
        .with_context(|| format!("no image in the output of {}", script.display()))?;
    let seconds = v["seconds"].as_f64().unwrap_or(f64::NAN);
    Ok(MitsubaRun { image, seconds })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn scene() -> RenderScene {
        RenderScene::builtin("lowalbedo").unwrap()
    }

    #[test]
    fn export_writes_a_vol_that_reads_back() {
        let s = scene();
        let dir = std::env::temp_dir().join(format!("pn-mitsuba-export-{}", std::process::id()));
        let o = ExportOptions::from_scene(&s);
        let e = export(&s, &dir, &o).unwrap();
        let back = pn_formats::read_vol(&e.density).unwrap();
        let g = s.density_grid().unwrap();
        assert_eq!(back.dims, g.res);
        let [i, j, k] = [3, 17, 25];
        assert_eq!(back.at(i, j, k) as f32, g.data[g.index(i, j, k)]);
        assert!(e.script.is_file() && e.albedo.is_none());
        // The files are the bytes pn_render computes.
        let files = export_files(&s, &o).unwrap();
        assert_eq!(std::fs::read(&e.density).unwrap(), files.density);
        assert_eq!(std::fs::read_to_string(&e.script).unwrap(), files.script);
        std::fs::remove_dir_all(&dir).ok();
    }

    #[test]
    fn bad_options_write_nothing() {
        let s = scene();
        let dir = std::env::temp_dir().join(format!("pn-mitsuba-bad-{}", std::process::id()));
        let o = ExportOptions {
            spp: 0,
            ..ExportOptions::from_scene(&s)
        };
        assert!(export(&s, &dir, &o).is_err());
        assert!(!dir.exists());
    }

    #[test]
    fn missing_python_is_a_clear_error() {
        let e = check_python(Path::new("/nonexistent/python")).unwrap_err();
        assert!(format!("{e:#}").contains("mitsuba-venv.sh"));
    }
}
