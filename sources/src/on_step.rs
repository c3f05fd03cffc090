//! A callback that a long loop of the library calls after each step (a frame rendered, tracked
//! or sent), so that a command can show its progress: the library itself knows no terminal.

use std::fmt;
use std::sync::Arc;

/// Called with the number of steps done so far.
#[derive(Clone)]
pub struct OnStep(Arc<dyn Fn(u64) + Send + Sync>);

impl OnStep {
    /// A hook calling `f`.
    pub fn new(f: impl Fn(u64) + Send + Sync + 'static) -> Self {
        Self(Arc::new(f))
    }

    /// The hook as a plain function, for the crates below the host (the front-end) that take
    /// one.
    pub fn as_fn(&self) -> &(dyn Fn(u64) + Send + Sync) {
        &*self.0
    }

    /// The hook as a shared function, for options that keep one (the link client's).
    #[must_use]
    pub fn shared(&self) -> std::sync::Arc<dyn Fn(u64) + Send + Sync> {
        std::sync::Arc::clone(&self.0)
    }

    /// Says that `done` steps are done.
    pub fn step(&self, done: u64) {
        (self.0)(done);
    }
}

impl fmt::Debug for OnStep {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str("OnStep(..)")
    }
}

/// Calls `hook` (if any) with `done`.
pub fn step(hook: Option<&OnStep>, done: u64) {
    if let Some(h) = hook {
        h.step(done);
    }
}
