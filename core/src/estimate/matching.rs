//! Matching by track id: a linear merge of two id-sorted lists.

use super::frame::Obs;

/// Anything with a track id.
pub trait Tracked {
    /// The track id.
    fn track_id(&self) -> u32;
}

impl Tracked for Obs {
    fn track_id(&self) -> u32 {
        self.track_id
    }
}

/// Calls `f(previous, current)` for every track id present in both sorted lists, in id order.
pub fn for_each_match<A: Tracked, B: Tracked>(previous: &[A], current: &[B], mut f: impl FnMut(&A, &B)) {
    let mut p = previous.iter().peekable();
    let mut c = current.iter().peekable();
    while let (Some(a), Some(b)) = (p.peek(), c.peek()) {
        match a.track_id().cmp(&b.track_id()) {
            core::cmp::Ordering::Less => {
                p.next();
            }
            core::cmp::Ordering::Greater => {
                c.next();
            }
            core::cmp::Ordering::Equal => {
                f(a, b);
                p.next();
                c.next();
            }
        }
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;

    #[test]
    fn merges_common_ids() {
        let obs = |ids: &[u32]| -> heapless::Vec<Obs, 8> {
            ids.iter().map(|&i| Obs::new(i, 1.0, 1.0, 1.0).unwrap()).collect()
        };
        let (a, b) = (obs(&[1, 3, 4, 9, 12]), obs(&[0, 3, 9, 10, 12, 13]));
        let mut got = heapless::Vec::<u32, 8>::new();
        for_each_match(&a, &b, |x, y| {
            assert_eq!(x.track_id, y.track_id);
            got.push(x.track_id).unwrap();
        });
        assert_eq!(&got[..], &[3, 9, 12]);
    }
}
