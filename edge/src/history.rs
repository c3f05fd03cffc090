//! Per-object state histories: the forecast inputs, kept from the estimator's causal output.

use dynotraj_core::estimate::PoseEstimate;
use dynotraj_core::geometry::BevState;
use dynotraj_core::limits::{MAX_HISTORY, MAX_OBJECTS};

/// States kept per object: the history the predictor reads plus the current frame.
pub const HISTORY_LEN: usize = MAX_HISTORY + 1;

/// One object's consecutive causal states, oldest first.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct History {
    /// The object.
    pub object_id: u16,
    /// The estimator's segment of the object frame: a re-orientation restarts the history,
    /// since headings before and after do not belong to one frame.
    segment: u16,
    /// Frame of the newest state.
    last_frame: u32,
    /// States in use.
    len: usize,
    /// `states[..len]`, oldest first.
    states: [BevState; HISTORY_LEN],
}

impl History {
    const EMPTY: Self = Self {
        object_id: 0,
        segment: 0,
        last_frame: 0,
        len: 0,
        states: [BevState { x: 0.0, y: 0.0, heading: 0.0, speed: 0.0 }; HISTORY_LEN],
    };

    /// The states, oldest first, current last.
    #[must_use]
    pub fn states(&self) -> &[BevState] {
        self.states.get(..self.len).unwrap_or(&[])
    }

    fn push(&mut self, state: BevState) {
        if self.len == HISTORY_LEN {
            self.states.rotate_left(1);
            self.len -= 1;
        }
        if let Some(s) = self.states.get_mut(self.len) {
            *s = state;
            self.len += 1;
        }
    }
}

/// The histories of the objects at the newest frame, one slot per object the estimator can
/// track, so no object is ever refused a slot.
#[derive(Debug, Clone)]
pub struct Histories {
    slots: [History; MAX_OBJECTS],
    used: usize,
}

impl Default for Histories {
    fn default() -> Self {
        Self::new()
    }
}

impl Histories {
    /// No objects.
    #[must_use]
    pub const fn new() -> Self {
        Self { slots: [History::EMPTY; MAX_OBJECTS], used: 0 }
    }

    /// Takes the causal estimate of a frame: an object seen at the previous frame in the same
    /// segment extends its history, any other starts a new one; objects not in `estimate`
    /// are forgotten (their run ended, or a frame was lost).
    ///
    /// Never inlined: the new table (2 KiB) is built on the stack, which then holds it only
    /// here, not under the estimator's deepest calls.
    #[inline(never)]
    pub fn update(&mut self, estimate: &PoseEstimate) {
        let mut next = [History::EMPTY; MAX_OBJECTS];
        let mut n = 0;
        for (o, slot) in estimate.objects.iter().zip(next.iter_mut()) {
            let old = self.current().iter().find(|h| h.object_id == o.object_id);
            *slot = match old {
                Some(h) if h.segment == o.segment && h.last_frame.wrapping_add(1) == estimate.frame => *h,
                _ => History { object_id: o.object_id, segment: o.segment, ..History::EMPTY },
            };
            slot.last_frame = estimate.frame;
            slot.push(o.bev);
            n += 1;
        }
        self.slots = next;
        self.used = n;
    }

    /// The histories of the newest frame's objects, in the estimate's order.
    #[must_use]
    pub fn current(&self) -> &[History] {
        self.slots.get(..self.used).unwrap_or(&[])
    }
}
