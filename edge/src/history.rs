//! Per-object state histories: the forecast inputs, kept from the estimator's causal output.

use dynotraj_core::estimate::PoseEstimate;
use dynotraj_core::geometry::{BevState, Point2};
use dynotraj_core::limits::{MAX_HISTORY, MAX_OBJECTS, PRIOR_STATES};
use dynotraj_core::wire::ObjectClass;

/// States kept whole per object: the history the network reads plus the current frame.
pub const HISTORY_LEN: usize = MAX_HISTORY + 1;
/// Older positions kept per object for the motion prior's long memory. The prior reads positions
/// only, so a state older than the network's window keeps its position alone (8 bytes instead
/// of 16: the long memory costs 1.8 KiB for 16 objects, not 3.6).
pub const OLDER_LEN: usize = PRIOR_STATES - HISTORY_LEN;

// The lengths are kept as bytes (they index arrays this short).
const _: () = assert!(HISTORY_LEN <= u8::MAX as usize);
const _: () = assert!(OLDER_LEN <= u8::MAX as usize);

/// One object's consecutive causal states, oldest first.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct History {
    /// The object.
    pub object_id: u16,
    /// What it is: which agent type's model forecasts it.
    pub class: ObjectClass,
    /// The estimator's segment of the object frame: a re-orientation restarts the history,
    /// since headings before and after do not belong to one frame.
    segment: u16,
    /// Frame of the newest state.
    last_frame: u32,
    /// States in use.
    len: u8,
    /// `states[..len]`, oldest first.
    states: [BevState; HISTORY_LEN],
    /// Older positions in use.
    older_len: u8,
    /// `older[..older_len]`, oldest first: the positions of the states that left `states`.
    older: [Point2; OLDER_LEN],
}

impl History {
    const EMPTY: Self = Self {
        object_id: 0,
        class: ObjectClass::Background,
        segment: 0,
        last_frame: 0,
        len: 0,
        states: [BevState { x: 0.0, y: 0.0, heading: 0.0, speed: 0.0 }; HISTORY_LEN],
        older_len: 0,
        older: [Point2 { x: 0.0, y: 0.0 }; OLDER_LEN],
    };

    /// The states, oldest first, current last.
    #[must_use]
    pub fn states(&self) -> &[BevState] {
        self.states.get(..usize::from(self.len)).unwrap_or(&[])
    }

    /// The long history the motion prior reads, written to `buf`, oldest first: the older
    /// positions (heading and speed 0: the prior reads positions only, the network only the
    /// newest [`HISTORY_LEN`] states), then [`History::states`].
    pub fn long_states<'b>(&self, buf: &'b mut [BevState; PRIOR_STATES]) -> &'b [BevState] {
        let older = self.older.get(..usize::from(self.older_len)).unwrap_or(&[]);
        let states = self.states();
        for (b, p) in buf.iter_mut().zip(older) {
            *b = BevState { x: p.x, y: p.y, heading: 0.0, speed: 0.0 };
        }
        for (b, s) in buf.iter_mut().skip(older.len()).zip(states) {
            *b = *s;
        }
        buf.get(..older.len() + states.len()).unwrap_or(&[])
    }

    fn push(&mut self, state: BevState) {
        if usize::from(self.len) == HISTORY_LEN {
            if let Some(oldest) = self.states.first().map(BevState::position) {
                if usize::from(self.older_len) == OLDER_LEN {
                    self.older.rotate_left(1);
                    self.older_len -= 1;
                }
                if let Some(o) = self.older.get_mut(usize::from(self.older_len)) {
                    *o = oldest;
                    self.older_len += 1;
                }
            }
            self.states.rotate_left(1);
            self.len -= 1;
        }
        if let Some(s) = self.states.get_mut(usize::from(self.len)) {
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
    /// In place: slot i is brought to hold the estimate's i-th object by swapping, so no second
    /// table (5.6 KiB) is ever on the stack.
    pub fn update(&mut self, estimate: &PoseEstimate) {
        // needed[k]: old slot k holds a history some object of this frame will claim.
        let mut needed = [false; MAX_OBJECTS];
        for (flag, h) in needed.iter_mut().zip(self.current()) {
            *flag = estimate.objects.iter().any(|o| o.object_id == h.object_id);
        }
        // Slots i..pending hold old histories not yet claimed; slots past it are free.
        let mut pending = self.used;
        let mut n = 0;
        for (i, o) in estimate.objects.iter().enumerate().take(MAX_OBJECTS) {
            let claimed = (i..pending).find(|&j| self.slots.get(j).is_some_and(|h| h.object_id == o.object_id));
            let continues = match claimed {
                Some(j) => {
                    self.swap(i, j, &mut needed);
                    self.slots
                        .get(i)
                        .is_some_and(|h| h.segment == o.segment && h.last_frame.wrapping_add(1) == estimate.frame)
                }
                None => {
                    // A new object: a history a later object claims moves to a free slot first
                    // (one exists: fewer objects are left than slots).
                    if i < pending && needed.get(i).copied().unwrap_or(false) {
                        let free =
                            (i + 1..pending).find(|&j| !needed.get(j).copied().unwrap_or(true)).unwrap_or(pending);
                        if free == pending {
                            pending += 1;
                        }
                        self.swap(i, free, &mut needed);
                    }
                    false
                }
            };
            if let Some(flag) = needed.get_mut(i) {
                *flag = false;
            }
            let Some(slot) = self.slots.get_mut(i) else { break };
            if !continues {
                *slot = History { object_id: o.object_id, class: o.class, segment: o.segment, ..History::EMPTY };
            }
            slot.last_frame = estimate.frame;
            slot.push(o.bev);
            n = i + 1;
        }
        self.used = n;
    }

    /// Swaps slots `a` and `b` and their flags (nothing when either is out of range).
    fn swap(&mut self, a: usize, b: usize, needed: &mut [bool; MAX_OBJECTS]) {
        if a < MAX_OBJECTS && b < MAX_OBJECTS {
            self.slots.swap(a, b);
            needed.swap(a, b);
        }
    }

    /// The histories of the newest frame's objects, in the estimate's order.
    #[must_use]
    pub fn current(&self) -> &[History] {
        self.slots.get(..self.used).unwrap_or(&[])
    }
}
