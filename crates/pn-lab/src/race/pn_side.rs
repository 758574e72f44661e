//! The pn side of `pn race`: each point is a whole `pn render` subprocess (the running
//! binary), timed around the process, with the time split read from its `report.json`.

use super::proc::{run_timed, Timed};
use anyhow::{bail, ensure, Context, Result};
use std::fmt;
use std::path::{Path, PathBuf};
use std::process::Command;

/// A deterministic method: CDA, flux-limited diffusion, P_N of an order, POP, or single
/// scattering only.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Family {
    /// Single scattering only (`--method none`).
    None,
    /// Classical diffusion.
    Cda,
    /// Flux-limited diffusion (`--method fld`, Levermore–Pomraning limiter).
    Fld,
    /// P_N of this order.
    Pn(usize),
    /// Diffusion-synthetic-accelerated S_N: transport sweeps carrying the scattering to this
    /// order, each followed by a diffusion correction (`--method cda` with `sweep_order`,
    /// `sweep_acceleration` and the diamond scheme; docs/forward-scattering.md).
    Sn(usize),
    /// Principal-Ordinates Propagation (`--method pop`, directional and point lights;
    /// docs/pop-design.md) with a grid of the point's resolution and as many iterations (the
    /// paper's §7 rule).
    Pop,
    /// A linear PDE system written as text (`pn render --pde FILE`, docs/pde-text.md); the
    /// file and its parameters are the point's [`PnPoint::pde`].
    Pde,
}

impl Family {
    /// The `pn render` arguments selecting it.
    fn args(self) -> Vec<String> {
        match self {
            Family::None => vec!["--method".into(), "none".into()],
            Family::Cda => vec!["--method".into(), "cda".into()],
            Family::Fld => vec!["--method".into(), "fld".into()],
            Family::Pn(n) => vec![
                "--method".into(),
                "pn".into(),
                "--order".into(),
                n.to_string(),
            ],
            Family::Sn(l) => [
                "--method",
                "cda",
                "--set",
                &format!("solve.sweep_order={l}"),
                "--set",
                "solve.sweep_acceleration=true",
                "--set",
                "solve.sweep_scheme=diamond",
            ]
            .map(String::from)
            .to_vec(),
            Family::Pop => vec!["--method".into(), "pop".into()],
            Family::Pde => vec![],
        }
    }

    /// The method column (`none`, `cda`, `fld`, `pn`, `pop`).
    pub fn method(self) -> &'static str {
        match self {
            Family::None => "none",
            Family::Cda => "cda",
            Family::Fld => "fld",
            Family::Pn(_) => "pn",
            Family::Sn(_) => "sn",
            Family::Pop => "pop",
            Family::Pde => "pde",
        }
    }

    /// The order column (empty but for P_N and S_N).
    pub fn order(self) -> Option<usize> {
        match self {
            Family::Pn(n) | Family::Sn(n) => Some(n),
            _ => None,
        }
    }
}

impl fmt::Display for Family {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Family::None => write!(f, "single scattering"),
            Family::Cda => write!(f, "CDA"),
            Family::Fld => write!(f, "FLD"),
            Family::Pn(n) => write!(f, "P_{n}"),
            Family::Sn(n) => write!(f, "DSA S_N(L={n})"),
            Family::Pop => write!(f, "POP"),
            Family::Pde => write!(f, "PDE"),
        }
    }
}

/// One pn setting of the race: method, solve resolution (cells across the medium box) and,
/// optionally, the deterministic renderer's rays per pixel and step.
#[derive(Clone, Debug, PartialEq)]
pub struct PnPoint {
    /// The method.
    pub family: Family,
    /// Solve-grid cells per axis (ignored for single scattering).
    pub solve_res: usize,
    /// `pn render --rays` (None: the renderer's default).
    pub rays: Option<usize>,
    /// `pn render --step` (None: the renderer's default).
    pub step: Option<f64>,
    /// `[solve] sweeps` (None: the scene's).
    pub sweeps: Option<usize>,
    /// The PDE file and parameters of a [`Family::Pde`] point.
    pub pde: Option<PdePoint>,
}

/// The PDE of a race point: `pn render --pde FILE [--pde-param NAME=VALUE …]`.
#[derive(Clone, Debug, PartialEq)]
pub struct PdePoint {
    /// The file as given (its label).
    pub file: String,
    /// The file, absolute (the renders run in other folders).
    pub path: PathBuf,
    /// `NAME=VALUE` overrides of the file's `param`s, in the order given.
    pub params: Vec<(String, String)>,
}

impl PdePoint {
    /// The curve's name: the file's stem and its parameters (`sp3`, `fpn N=5`).
    fn name(&self) -> String {
        let stem = Path::new(&self.file)
            .file_stem()
            .map_or_else(|| self.file.clone(), |s| s.to_string_lossy().into_owned());
        std::iter::once(stem)
            .chain(self.params.iter().map(|(k, v)| format!("{k}={v}")))
            .collect::<Vec<_>>()
            .join(" ")
    }
}

impl PnPoint {
    /// Parses `cda@24`, `fld@24`, `p5@32` (`P5@32`), `sn5@24` (diffusion-accelerated S_N to
    /// order 5), `pop@20`, `none`, each optionally followed by `:rays=K`, `:step=S` and/or
    /// `:sweeps=K` (`p5@32:rays=1:step=1`, `sn5@24:sweeps=3`).
    ///
    /// A text PDE is `FILE.pde@RES` (the file relative to the working folder), its `param`s
    /// overridden by further `:NAME=VALUE` options: `pdes/sp3.pde@16`,
    /// `pdes/fpn.pde@16:N=5:rays=1`.
    pub fn parse(s: &str) -> Result<Self> {
        let trimmed = s.trim();
        let mut parts = trimmed.split(':');
        let head = parts.next().unwrap_or("");
        // A text PDE's file (original case: a path), if the head is FILE.pde@RES.
        let pde_file = head
            .rsplit_once('@')
            .map(|(f, _)| f)
            .filter(|f| f.to_ascii_lowercase().ends_with(".pde"));
        let lower = head.to_ascii_lowercase();
        let t = lower.as_str();
        let (mut rays, mut step, mut sweeps) = (None, None, None);
        let mut params = Vec::new();
        let bad_option = |opt: &str| {
            anyhow::anyhow!(
                "pn point {s:?}: options are :rays=K, :step=S and :sweeps=K (and :NAME=VALUE \
                 for a .pde file's parameters), got {opt:?}"
            )
        };
        for opt in parts {
            let (key, v) = opt.split_once('=').ok_or_else(|| bad_option(opt))?;
            match key.to_ascii_lowercase().as_str() {
                "rays" => {
                    let n: usize = v
                        .parse()
                        .with_context(|| format!("pn point {s:?}: rays must be an integer"))?;
                    ensure!(n >= 1, "pn point {s:?}: rays must be at least 1");
                    rays = Some(n);
                }
                "step" => {
                    let x: f64 = v
                        .parse()
                        .with_context(|| format!("pn point {s:?}: step must be a number"))?;
                    ensure!(
                        x.is_finite() && x > 0.0,
                        "pn point {s:?}: step must be positive"
                    );
                    step = Some(x);
                }
                "sweeps" => {
                    let n: usize = v
                        .parse()
                        .with_context(|| format!("pn point {s:?}: sweeps must be an integer"))?;
                    sweeps = Some(n);
                }
                _ if pde_file.is_some() => {
                    ensure!(
                        !key.is_empty() && !v.is_empty(),
                        "pn point {s:?}: a PDE parameter is NAME=VALUE, got {opt:?}"
                    );
                    params.push((key.to_string(), v.to_string()));
                }
                _ => return Err(bad_option(opt)),
            }
        }
        if t == "none" {
            return Ok(Self {
                family: Family::None,
                solve_res: 0,
                rays,
                step,
                sweeps,
                pde: None,
            });
        }
        let Some((f, r)) = t.rsplit_once('@') else {
            bail!("pn point {s:?}: expected METHOD@RES, e.g. p5@24, cda@32 or pdes/sp3.pde@16");
        };
        let pde = match pde_file {
            Some(file) => {
                let path = std::fs::canonicalize(file).with_context(|| {
                    format!("pn point {s:?}: cannot open the PDE file {file:?}")
                })?;
                Some(PdePoint {
                    file: file.to_string(),
                    path,
                    params,
                })
            }
            None => None,
        };
        let family = match f {
            _ if pde.is_some() => Family::Pde,
            "cda" => Family::Cda,
            "fld" => Family::Fld,
            "pop" => Family::Pop,
            _ if f.starts_with("sn") => {
                let l = f[2..].parse::<usize>().with_context(|| {
                    format!("pn point {s:?}: sN needs the sweeps' order, e.g. sn5")
                })?;
                ensure!(
                    (1..=15).contains(&l),
                    "pn point {s:?}: the sweeps' order {l} outside 1..=15"
                );
                Family::Sn(l)
            }
            _ => {
                let n = f
                    .strip_prefix('p')
                    .and_then(|n| n.parse::<usize>().ok())
                    .with_context(|| {
                        format!(
                            "pn point {s:?}: the method is cda, fld, pop, pN (p1, p3, p5, …) or \
                             snL (sn5: accelerated S_N)"
                        )
                    })?;
                ensure!(
                    (1..=60).contains(&n),
                    "pn point {s:?}: order {n} outside 1..=60"
                );
                Family::Pn(n)
            }
        };
        let solve_res: usize = r
            .parse()
            .with_context(|| format!("pn point {s:?}: the resolution must be an integer"))?;
        ensure!(
            (4..=512).contains(&solve_res),
            "pn point {s:?}: solve resolution {solve_res} outside 4..=512"
        );
        Ok(Self {
            family,
            solve_res,
            rays,
            step,
            sweeps,
            pde,
        })
    }

    /// The point as [`PnPoint::parse`] reads it: `p5@24`, `cda@32:rays=1`, `none`.
    pub fn label(&self) -> String {
        let mut s = match self.family {
            Family::None => "none".into(),
            Family::Cda => format!("cda@{}", self.solve_res),
            Family::Fld => format!("fld@{}", self.solve_res),
            Family::Pn(n) => format!("p{n}@{}", self.solve_res),
            Family::Sn(n) => format!("sn{n}@{}", self.solve_res),
            Family::Pop => format!("pop@{}", self.solve_res),
            Family::Pde => {
                let pde = self.pde.as_ref();
                let mut l = format!(
                    "{}@{}",
                    pde.map_or("?", |p| p.file.as_str()),
                    self.solve_res
                );
                for (k, v) in pde.map_or(&[][..], |p| &p.params[..]) {
                    l += &format!(":{k}={v}");
                }
                l
            }
        };
        if let Some(r) = self.rays {
            s += &format!(":rays={r}");
        }
        if let Some(x) = self.step {
            s += &format!(":step={x}");
        }
        if let Some(k) = self.sweeps {
            s += &format!(":sweeps={k}");
        }
        s
    }

    /// The family column of the CSV: `cda`, `p5`, `none`.
    pub fn family_key(&self) -> String {
        match self.family {
            Family::None => "none".into(),
            Family::Cda => "cda".into(),
            Family::Fld => "fld".into(),
            Family::Pn(n) => format!("p{n}"),
            Family::Sn(n) => format!("sn{n}"),
            Family::Pop => "pop".into(),
            Family::Pde => format!(
                "pde:{}",
                self.pde.as_ref().map_or_else(String::new, PdePoint::name)
            ),
        }
    }

    /// A folder name for the point's render.
    pub fn folder(&self) -> String {
        self.label()
            .replace(['@', ':', '/', '\\', ' '], "_")
            .replace('=', "")
    }

    /// The `pn render` arguments selecting the method (the PDE file and parameters of a
    /// [`Family::Pde`] point).
    pub fn method_args(&self) -> Vec<String> {
        let mut v = self.family.args();
        if let Some(p) = &self.pde {
            v.extend(["--pde".to_string(), p.path.display().to_string()]);
            for (k, val) in &p.params {
                v.extend(["--pde-param".to_string(), format!("{k}={val}")]);
            }
        }
        v
    }

    /// The `pn render` arguments of the renderer settings.
    pub fn render_args(&self) -> Vec<String> {
        let mut v = vec![];
        if let Some(r) = self.rays {
            v.extend(["--rays".to_string(), r.to_string()]);
        }
        if let Some(x) = self.step {
            v.extend(["--step".to_string(), x.to_string()]);
        }
        if let Some(k) = self.sweeps {
            v.extend(["--set".to_string(), format!("solve.sweeps={k}")]);
        }
        v
    }

    /// A readable name: `P_5 @ 24³`.
    pub fn pretty(&self) -> String {
        match (&self.family, &self.pde) {
            (Family::None, _) => "single scattering".into(),
            (Family::Pde, Some(p)) => format!("{} @ {}³", p.name(), self.solve_res),
            (f, _) => format!("{f} @ {}³", self.solve_res),
        }
    }
}

/// How to run `pn render`.
#[derive(Clone, Debug)]
pub struct PnRunner {
    /// The `pn` binary.
    pub binary: PathBuf,
    /// The scene argument (file or built-in name).
    pub scene: String,
    /// Extra arguments for every render (renderer settings).
    pub render_args: Vec<String>,
    /// `--threads` to pass on.
    pub threads: Option<usize>,
}

/// A finished `pn render`.
#[derive(Clone, Debug)]
pub struct PnResult {
    /// Wall seconds of the whole process.
    pub wall: f64,
    /// The report's `seconds` object (phase name → seconds).
    pub phases: Vec<(String, f64)>,
    /// The images it wrote (`image.exr`, or the turntable's views in order).
    pub images: Vec<PathBuf>,
    /// Solver iterations (if any).
    pub iterations: Option<u64>,
    /// Whether the solver converged (true when there was no solve).
    pub converged: bool,
}

impl PnResult {
    /// The seconds of phase `name`, if the report has it.
    pub fn phase(&self, name: &str) -> Option<f64> {
        self.phases.iter().find(|(k, _)| k == name).map(|(_, v)| *v)
    }
}

impl PnRunner {
    /// Runs `pn render` for `point` into `out` with `extra` arguments (after the runner's
    /// render arguments, so they override them), timing the whole process.
    pub fn render(&self, point: &PnPoint, out: &Path, extra: &[String]) -> Result<PnResult> {
        let mut cmd = Command::new(&self.binary);
        cmd.arg("render").arg(&self.scene).args(point.method_args());
        if point.family != Family::None {
            cmd.args(["--solve-res", &point.solve_res.to_string()]);
        }
        if point.family == Family::Pop {
            let n = point.solve_res.to_string();
            cmd.args(["--pop-resolution", &n, "--pop-iterations", &n]);
        }
        if let Some(t) = self.threads {
            cmd.args(["--threads", &t.to_string()]);
        }
        cmd.args(&self.render_args)
            .args(point.render_args())
            .args(extra)
            .arg("--out")
            .arg(out);
        let Timed { wall, .. } = run_timed(&mut cmd, &format!("pn render ({})", point.label()))?;
        let report_path = out.join("report.json");
        let report: serde_json::Value = serde_json::from_str(
            &std::fs::read_to_string(&report_path)
                .with_context(|| format!("cannot read {}", report_path.display()))?,
        )
        .with_context(|| format!("malformed {}", report_path.display()))?;
        let phases = report["seconds"]
            .as_object()
            .map(|o| {
                o.iter()
                    .filter_map(|(k, v)| v.as_f64().map(|s| (k.clone(), s)))
                    .collect()
            })
            .unwrap_or_default();
        let mut images = vec![];
        let single = out.join("image.exr");
        if single.is_file() {
            images.push(single);
        } else {
            // A turntable: every EXR in the folder, in name order (view 0 first).
            let mut v: Vec<PathBuf> = std::fs::read_dir(out)
                .with_context(|| format!("cannot list {}", out.display()))?
                .filter_map(|e| e.ok().map(|e| e.path()))
                .filter(|p| p.extension().is_some_and(|x| x == "exr"))
                .collect();
            v.sort();
            images = v;
        }
        ensure!(
            !images.is_empty(),
            "pn render ({}) wrote no EXR into {}",
            point.label(),
            out.display()
        );
        Ok(PnResult {
            wall,
            phases,
            images,
            iterations: report["solver"]["iterations"].as_u64(),
            converged: report["solver"]["converged"].as_bool().unwrap_or(true),
        })
    }
}

/// The settings text of a pn row: `res=24` plus the render arguments (`spp=16`; a `--set`
/// as its `SECTION.KEY=VALUE`), with no comma or double quote (a CSV cell).
pub(super) fn pn_settings(p: &PnPoint, args: &[String]) -> String {
    let mut s = if p.family == Family::None {
        String::from("-")
    } else {
        format!("res={}", p.solve_res)
    };
    let all: Vec<String> = args.iter().cloned().chain(p.render_args()).collect();
    let mut it = all.iter().peekable();
    while let Some(a) = it.next() {
        let key = a.trim_start_matches('-');
        if let Some(v) = key.strip_prefix("set=") {
            s += &format!(" {v}");
            continue;
        }
        match it.peek() {
            Some(v) if key == "set" => {
                s += &format!(" {v}");
                it.next();
            }
            Some(v) if !v.starts_with("--") => {
                s += &format!(" {key}={v}");
                it.next();
            }
            _ => s += &format!(" {key}"),
        }
    }
    s.replace(',', ";").replace('"', "'")
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A text PDE point: the file (absolute for the render), its parameters, the curve's
    /// family, the `pn render` arguments; a missing file and a bad parameter are errors.
    #[test]
    fn pde_points_parse() {
        let dir = std::env::temp_dir().join(format!("pn-race-pde-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let file = dir.join("Fpn.pde");
        std::fs::write(&file, "pde fpn\n").unwrap();
        let spec = format!("{}@16:N=5:rays=1", file.display());
        let p = PnPoint::parse(&spec).unwrap();
        assert_eq!((p.family, p.solve_res, p.rays), (Family::Pde, 16, Some(1)));
        assert_eq!(p.family_key(), "pde:Fpn N=5");
        assert_eq!(p.pretty(), "Fpn N=5 @ 16³");
        assert_eq!(p.label(), format!("{}@16:N=5:rays=1", file.display()));
        assert_eq!(PnPoint::parse(&p.label()).unwrap(), p);
        let args = p.method_args();
        assert_eq!(args[0], "--pde");
        assert!(Path::new(&args[1]).is_absolute());
        assert_eq!(args[2..], ["--pde-param", "N=5"]);
        assert!(!p.folder().contains(['/', ':', '@', '=']));
        let e = PnPoint::parse(&format!("{}/missing.pde@16", dir.display())).unwrap_err();
        assert!(
            format!("{e:#}").contains("cannot open the PDE file"),
            "{e:#}"
        );
        assert!(PnPoint::parse(&format!("{}@16:=3", file.display())).is_err());
        assert!(PnPoint::parse("p3@16:N=5").is_err());
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn points_parse_and_refuse_nonsense() {
        let p = PnPoint::parse("P5@24").unwrap();
        assert_eq!(p.family, Family::Pn(5));
        assert_eq!((p.solve_res, p.label().as_str()), (24, "p5@24"));
        assert_eq!(PnPoint::parse("cda@16").unwrap().family, Family::Cda);
        assert_eq!(PnPoint::parse("none").unwrap().family, Family::None);
        let p = PnPoint::parse("POP@20").unwrap();
        assert_eq!((p.family, p.label().as_str()), (Family::Pop, "pop@20"));
        assert_eq!((p.family.method(), p.family.order()), ("pop", None));
        let p = PnPoint::parse("fld@24").unwrap();
        assert_eq!((p.family, p.label().as_str()), (Family::Fld, "fld@24"));
        assert_eq!((p.family.method(), p.family_key().as_str()), ("fld", "fld"));
        let p = PnPoint::parse("p3@32:rays=1:step=0.25").unwrap();
        assert_eq!((p.rays, p.step), (Some(1), Some(0.25)));
        assert_eq!(p.label(), "p3@32:rays=1:step=0.25");
        assert_eq!(p.folder(), "p3_32_rays1_step0.25");
        assert_eq!(p.render_args(), ["--rays", "1", "--step", "0.25"]);
        let p = PnPoint::parse("SN5@24:rays=1:sweeps=3").unwrap();
        assert_eq!((p.family, p.sweeps), (Family::Sn(5), Some(3)));
        assert_eq!(p.label(), "sn5@24:rays=1:sweeps=3");
        assert_eq!(PnPoint::parse(&p.label()).unwrap(), p);
        assert_eq!((p.family.method(), p.family.order()), ("sn", Some(5)));
        assert_eq!(p.render_args(), ["--rays", "1", "--set", "solve.sweeps=3"]);
        assert!(p
            .method_args()
            .windows(2)
            .any(|w| w == ["--set", "solve.sweep_order=5"]));
        for bad in [
            "p5",
            "q3@24",
            "p0@24",
            "p5@x",
            "p5@2",
            "p61@16",
            "p5@24:rays=0",
            "p5@24:step=-1",
            "p5@24:spp=3",
            "sn@24",
            "sn16@24",
            "sn5@24:sweeps=-1",
        ] {
            assert!(PnPoint::parse(bad).is_err(), "{bad}");
        }
    }

    #[test]
    fn settings_text_of_a_row() {
        assert_eq!(
            pn_settings(
                &PnPoint::parse("p5@24").unwrap(),
                &["--spp".into(), "16".into()]
            ),
            "res=24 spp=16"
        );
        assert_eq!(
            pn_settings(
                &PnPoint::parse("p3@24").unwrap(),
                &[
                    "--set".into(),
                    "camera.position=[0,0,3]".into(),
                    "--set=solve.absorber=\"box\"".into(),
                    "--exact-transmittance".into()
                ]
            ),
            "res=24 camera.position=[0;0;3] solve.absorber='box' exact-transmittance"
        );
    }
}
