//! `pn compare a.exr b.exr`: error metrics of image `a` against the reference `b` and a
//! false-colour difference image (`pn_render::compare`).

use pn_render::compare::{compare_files, ChannelMetrics, Metrics};
use serde::Serialize;
use std::io::Write;
use std::path::PathBuf;

/// What `pn compare` compares.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct CompareRequest {
    /// The image to judge (EXR).
    pub a: PathBuf,
    /// The reference image (EXR), e.g. Mitsuba's.
    pub b: PathBuf,
    /// Folder for `difference.png` (a − b, diverging colours) and `metrics.json`.
    pub out: Option<PathBuf>,
    /// Print the metrics as JSON.
    pub json: bool,
}

/// The metrics, and per channel for colour images.
#[derive(Serialize)]
struct Output {
    #[serde(flatten)]
    metrics: Metrics,
    #[serde(skip_serializing_if = "Option::is_none")]
    channels: Option<Vec<ChannelMetrics>>,
}

/// Runs `pn compare`, printing the metrics to `stdout` (of the channel means, and per
/// channel when either image is coloured).
pub fn run(args: &CompareRequest, stdout: &mut dyn Write) -> anyhow::Result<()> {
    let (metrics, channels) = compare_files(&args.a, &args.b, args.out.as_deref())?;
    let out = Output { metrics, channels };
    if args.json {
        writeln!(stdout, "{}", serde_json::to_string_pretty(&out)?)?;
    } else {
        writeln!(stdout, "{} against {}", args.a.display(), args.b.display())?;
        writeln!(stdout, "{}", out.metrics)?;
        for c in out.channels.iter().flatten() {
            writeln!(
                stdout,
                "channel {}: rel_bias {:+.4}, rel_rmse {:.4}, rmse {:.4e}, mean {:.4e} / {:.4e}",
                c.channel, c.rel_bias, c.rel_rmse, c.rmse, c.mean_a, c.mean_b
            )?;
        }
    }
    if let Some(dir) = &args.out {
        writeln!(stdout, "wrote {}", dir.join("difference.png").display())?;
    }
    Ok(())
}
