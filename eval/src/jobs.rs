//! Independent pieces of work (sequences to estimate, folds to train) spread over the
//! machine's cores.
//!
//! Each item runs whole on one worker thread of a pool of `jobs` threads, and the results
//! come back in the items' order, so a run's output does not depend on how many jobs it had.
//! candle's kernels run on their caller's thread when `RAYON_NUM_THREADS=1` (the `dynotraj`
//! command sets it for itself), so folds on different workers do not contend for threads.

use rayon::prelude::*;

/// The number of jobs used when none is given: the cores this process may run on.
#[must_use]
pub fn default_jobs() -> usize {
    std::thread::available_parallelism().map_or(1, std::num::NonZero::get)
}

/// `f` applied to every item of `items` on a pool of `jobs` threads (at least one), results in
/// item order. With one job the items run one after another on the caller's thread.
///
/// # Errors
/// The pool's threads cannot be started.
pub fn map_jobs<T: Sync, R: Send>(
    items: &[T],
    jobs: usize,
    f: impl Fn(&T) -> R + Sync + Send,
) -> anyhow::Result<Vec<R>> {
    if jobs <= 1 || items.len() <= 1 {
        return Ok(items.iter().map(f).collect());
    }
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(jobs.min(items.len()))
        .thread_name(|i| format!("dynotraj-job-{i}"))
        .build()
        .map_err(|e| anyhow::anyhow!("starting {jobs} worker threads: {e}"))?;
    // One item per task: the items are long (seconds to minutes) and uneven.
    Ok(pool.install(|| items.par_iter().with_max_len(1).map(f).collect()))
}

/// Parses a `--jobs` value: a positive whole number.
///
/// # Errors
/// Anything else, with what was expected.
pub fn parse_jobs(text: &str) -> Result<usize, String> {
    match text.trim().parse::<usize>() {
        Ok(n) if n >= 1 => Ok(n),
        _ => Err(format!("expected a whole number of jobs >= 1, found `{text}`")),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn results_keep_the_item_order_for_any_number_of_jobs() {
        let items: Vec<u64> = (0..37).collect();
        let slow_square = |&x: &u64| {
            std::thread::sleep(std::time::Duration::from_millis(37 - x));
            x * x
        };
        let one = map_jobs(&items, 1, slow_square).unwrap();
        let two = map_jobs(&items, 2, slow_square).unwrap();
        assert_eq!(one, items.iter().map(|x| x * x).collect::<Vec<_>>());
        assert_eq!(one, two);
    }

    #[test]
    fn two_jobs_run_at_the_same_time() {
        let started = std::sync::atomic::AtomicUsize::new(0);
        let max_seen = std::sync::atomic::AtomicUsize::new(0);
        map_jobs(&[0, 1], 2, |_| {
            let now = started.fetch_add(1, std::sync::atomic::Ordering::SeqCst) + 1;
            max_seen.fetch_max(now, std::sync::atomic::Ordering::SeqCst);
            std::thread::sleep(std::time::Duration::from_millis(200));
        })
        .unwrap();
        assert_eq!(max_seen.load(std::sync::atomic::Ordering::SeqCst), 2);
    }

    #[test]
    fn the_jobs_flag_takes_positive_whole_numbers_only() {
        assert_eq!(parse_jobs("3"), Ok(3));
        for bad in ["0", "-1", "1.5", "", "two"] {
            assert!(parse_jobs(bad).unwrap_err().contains("expected a whole number of jobs"), "{bad}");
        }
    }
}
