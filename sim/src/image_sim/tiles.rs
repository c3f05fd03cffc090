//! Rows of an image shared out over threads in small tiles.

use std::sync::{Mutex, PoisonError};

/// Rows drawn by one thread at a time. Rows differ in cost several times over (sky above,
/// the finely textured near ground below), so the threads take small tiles in turn rather
/// than one band each, and finish within a tile of each other.
pub(super) const TILE_ROWS: usize = 8;

/// Runs `work` on every tile of `tiles` over `threads` threads, each with its own `scratch`.
/// Which thread takes a tile does not matter: a tile's result depends on the tile alone.
pub(super) fn in_tiles<T, S>(
    tiles: impl Iterator<Item = T> + Send,
    threads: usize,
    scratch: impl Fn() -> S + Sync,
    work: impl Fn(T, &mut S) + Sync,
) {
    let queue = Mutex::new(tiles);
    let run = || {
        let mut s = scratch();
        // A worker that panicked holds no tile; the panic reaches the caller through the scope.
        while let Some(t) = queue.lock().unwrap_or_else(PoisonError::into_inner).next() {
            work(t, &mut s);
        }
    };
    if threads <= 1 {
        run();
        return;
    }
    std::thread::scope(|scope| {
        for _ in 1..threads {
            scope.spawn(run);
        }
        run();
    });
}
