//! Running work on a rayon pool of a chosen size (`--threads`).

/// Runs `f` on a dedicated pool of `threads` workers, or on the global pool for `None`.
///
/// Either way `f` itself runs on a worker of the pool, so that its parallel loops split their
/// work among the workers directly: a loop started from a thread outside the pool is sent to
/// the pool and that thread sleeps until it is done, a hand-over that costs more than the
/// work of a short loop (the whole `pn solve checkerboard`, whose loops are short, took
/// 0.33 s from outside the pool and 0.28 s on a worker; docs/solvers.md, "Short loops").
pub fn with_threads<R: Send>(
    threads: Option<usize>,
    f: impl FnOnce() -> R + Send,
) -> anyhow::Result<R> {
    match threads {
        None if rayon::current_thread_index().is_some() => Ok(f()),
        None => Ok(rayon::scope(|_| f())),
        Some(n) => {
            check_threads(n)?;
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(n)
                .build()
                .map_err(|e| anyhow::anyhow!("cannot start {n} worker threads: {e}"))?;
            Ok(pool.install(f))
        }
    }
}

/// Worker threads allowed per core (oversubscription helps no solve; the bound keeps a
/// typo such as `--threads 1000000` from spending minutes starting threads).
pub const THREADS_PER_CORE: usize = 16;

/// The cores (hardware threads) this process may use; 1 where unknown.
fn cores() -> usize {
    std::thread::available_parallelism().map_or(1, usize::from)
}

/// The largest `--threads` accepted: [`THREADS_PER_CORE`] per core.
pub fn max_threads() -> usize {
    THREADS_PER_CORE * cores()
}

/// Checks a `--threads` value against the machine: at least 1, at most [`max_threads`].
pub fn check_threads(n: usize) -> anyhow::Result<usize> {
    if n == 0 {
        anyhow::bail!("--threads must be at least 1");
    }
    if n > max_threads() {
        anyhow::bail!(
            "--threads {n} is more than this machine can use: at most {} ({THREADS_PER_CORE} \
             per core of its {})",
            max_threads(),
            cores()
        );
    }
    Ok(n)
}

/// Number of worker threads `with_threads(threads, ..)` uses.
pub fn effective_threads(threads: Option<usize>) -> usize {
    threads.unwrap_or_else(rayon::current_num_threads)
}
