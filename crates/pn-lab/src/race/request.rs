//! The options of `pn race` ([`RaceRequest`]) and the plan they give (every default filled
//! in and checked before anything renders).

use super::ablation;
use super::pn_side::{Family, PnPoint};
use anyhow::{ensure, Result};
use std::path::PathBuf;

/// The pn points of a full race.
pub const DEFAULT_PN_POINTS: &str = "cda@16,cda@24,cda@32,cda@48,p1@16,p1@24,p1@32,p1@48,\
                                     p3@16,p3@24,p3@32,p3@48,p5@16,p5@24,p5@32,p7@16,p7@24";

/// Most timed runs per point (`--repeat`).
pub const MAX_REPEAT: usize = 15;

/// Mitsuba's spp ladder of a full race.
pub const DEFAULT_MITSUBA_SPP: &[usize] = &[1, 4, 16, 64, 256];

/// The options of `pn race`.
#[derive(Clone, Debug, PartialEq)]
pub struct RaceRequest {
    /// Scene files or built-in names.
    pub scenes: Vec<String>,
    /// Output folder (everything: CSV, PNG, Markdown).
    pub out: PathBuf,
    /// Reference cache (default `out/race-cache`).
    pub cache: Option<PathBuf>,
    /// The Python interpreter with Mitsuba and pyoidn (default: see
    /// `pn_drivers::mitsuba::find_python`).
    pub python: Option<PathBuf>,
    /// The `pn` binary for the pn points (the command line passes itself).
    pub pn_binary: PathBuf,
    /// Reference spp in all (two halves; default 4096, 64 with `quick`).
    pub reference_spp: Option<usize>,
    /// Mitsuba's spp ladder (default 1, 4, 16, 64, 256; 1, 4 with `quick`).
    pub mitsuba_spp: Option<Vec<usize>>,
    /// The Mitsuba spp whose error the crossing points are measured against (default 64;
    /// the largest of the ladder with `quick`).
    pub target_spp: Option<usize>,
    /// Also run denoised Mitsuba.
    pub denoise: bool,
    /// pn points (default [`DEFAULT_PN_POINTS`]; `p1@16` with `quick`).
    pub pn_points: Option<Vec<PnPoint>>,
    /// Extra `pn render` arguments for every pn render (renderer settings).
    pub render_args: Vec<String>,
    /// Turntable views (0 = no turntable; default 16, 2 with `quick`).
    pub turntable: Option<usize>,
    /// The pn point of the turntable (default: the fastest that reaches the target error,
    /// else the most accurate).
    pub turntable_point: Option<PnPoint>,
    /// Run the single-scattering comparison.
    pub single_scatter: bool,
    /// Run the ablation study on every scene.
    pub ablation: bool,
    /// The ablation study file (default: the built-in [`ablation::DEFAULT_STUDY`]).
    pub ablation_study: Option<PathBuf>,
    /// A small smoke run.
    pub quick: bool,
    /// `--threads` for the pn renders.
    pub threads: Option<usize>,
    /// Timed runs per Mitsuba and pn point; the run with the median wall time is kept.
    pub repeat: usize,
    /// Only regenerate `results.md` from the CSV files in `out`.
    pub markdown_only: bool,
    /// Keep `<out>/<scene>/work/` (exports, images, renders) after the scene.
    pub keep_work: bool,
    /// Where the race writes its scratch files (the probe of the Python interpreter, in a
    /// folder of its own that is removed afterwards); the command line passes the system's
    /// temporary folder.
    pub temp_dir: PathBuf,
}

impl Default for RaceRequest {
    /// The full race on the nebula into `out/race`.
    fn default() -> Self {
        Self {
            scenes: vec!["nebula".into()],
            out: PathBuf::from("out/race"),
            cache: None,
            python: None,
            pn_binary: PathBuf::from("pn"),
            reference_spp: None,
            mitsuba_spp: None,
            target_spp: None,
            denoise: true,
            pn_points: None,
            render_args: vec![],
            turntable: None,
            turntable_point: None,
            single_scatter: true,
            ablation: false,
            ablation_study: None,
            quick: false,
            threads: None,
            repeat: 1,
            markdown_only: false,
            keep_work: false,
            temp_dir: PathBuf::from("out/race-tmp"),
        }
    }
}

/// The request with every default filled in.
pub(crate) struct Plan {
    pub(crate) reference_spp: usize,
    pub(crate) mitsuba_spp: Vec<usize>,
    pub(crate) target_spp: usize,
    pub(crate) pn_points: Vec<PnPoint>,
    pub(crate) turntable: usize,
    pub(crate) study: Option<ablation::Study>,
}

impl Plan {
    pub(crate) fn new(r: &RaceRequest) -> Result<Self> {
        let reference_spp = r.reference_spp.unwrap_or(if r.quick { 64 } else { 4096 });
        ensure!(
            reference_spp >= 2,
            "--reference-spp must be at least 2 (two halves), got {reference_spp}"
        );
        let mut mitsuba_spp = r.mitsuba_spp.clone().unwrap_or_else(|| {
            if r.quick {
                vec![1, 4]
            } else {
                DEFAULT_MITSUBA_SPP.to_vec()
            }
        });
        mitsuba_spp.sort_unstable();
        mitsuba_spp.dedup();
        ensure!(
            !mitsuba_spp.is_empty() && mitsuba_spp[0] >= 1,
            "--mitsuba-spp needs positive values"
        );
        let last = mitsuba_spp[mitsuba_spp.len() - 1];
        let target_spp = r
            .target_spp
            .unwrap_or(if r.quick || !mitsuba_spp.contains(&64) {
                last
            } else {
                64
            });
        ensure!(
            mitsuba_spp.contains(&target_spp),
            "--target-spp {target_spp} is not in --mitsuba-spp {mitsuba_spp:?}"
        );
        let pn_points = match &r.pn_points {
            Some(p) => p.clone(),
            None if r.quick => vec![PnPoint::parse("p1@16")?],
            None => parse_points(DEFAULT_PN_POINTS)?,
        };
        ensure!(!pn_points.is_empty(), "--pn-points is empty");
        ensure!(
            (1..=MAX_REPEAT).contains(&r.repeat),
            "--repeat must lie in 1..={MAX_REPEAT}, got {}",
            r.repeat
        );
        ensure!(
            pn_points.iter().all(|p| p.family != Family::None),
            "--pn-points: single scattering (none) is its own comparison, not a race point"
        );
        let study = match (&r.ablation_study, r.ablation) {
            (_, false) => None,
            (Some(p), true) => Some(ablation::Study::from_file(p)?),
            (None, true) => Some(ablation::Study::builtin()?),
        };
        Ok(Self {
            reference_spp,
            mitsuba_spp,
            target_spp,
            pn_points,
            turntable: r.turntable.unwrap_or(if r.quick { 2 } else { 16 }),
            study,
        })
    }
}

/// Parses a comma-separated list of pn points (`cda@16,p5@24`).
pub fn parse_points(s: &str) -> Result<Vec<PnPoint>> {
    s.split(',')
        .filter(|t| !t.trim().is_empty())
        .map(PnPoint::parse)
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn plan_defaults_and_refusals() {
        let r = RaceRequest::default();
        let p = Plan::new(&r).unwrap();
        assert_eq!((p.reference_spp, p.target_spp, p.turntable), (4096, 64, 16));
        assert_eq!(p.pn_points.len(), 17);
        let q = Plan::new(&RaceRequest {
            quick: true,
            ..r.clone()
        })
        .unwrap();
        assert_eq!((q.mitsuba_spp.clone(), q.target_spp), (vec![1, 4], 4));
        for bad in [
            RaceRequest {
                reference_spp: Some(1),
                ..r.clone()
            },
            RaceRequest {
                target_spp: Some(8),
                ..r.clone()
            },
            RaceRequest {
                mitsuba_spp: Some(vec![0, 4]),
                ..r.clone()
            },
            RaceRequest {
                pn_points: Some(vec![PnPoint::parse("none").unwrap()]),
                ..r.clone()
            },
            RaceRequest {
                repeat: 0,
                ..r.clone()
            },
            RaceRequest {
                repeat: MAX_REPEAT + 1,
                ..r.clone()
            },
        ] {
            assert!(Plan::new(&bad).is_err());
        }
    }
}
