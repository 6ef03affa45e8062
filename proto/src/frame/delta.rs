//! Deltas between visible sets: computing them on the server, applying them on clients.

use super::codec::{check_ascending, check_disjoint};
use super::*;

/// Applies `delta` to the strictly ascending visible set `set`, keeping it ascending.
///
/// Fails, leaving `set` untouched, if a removed ID is not in the set, an added ID already
/// is, an ID is in both lists, or `set` or one of the lists is not strictly ascending.
pub fn apply_delta(set: &mut Vec<u32>, delta: &VisibleDelta) -> Result<(), FrameError> {
    check_ascending("set", set)?;
    check_ascending("added", &delta.added)?;
    check_ascending("removed", &delta.removed)?;
    check_disjoint(&delta.added, &delta.removed)?;
    let (added, removed) = (&delta.added[..], &delta.removed[..]);
    let mut out = Vec::with_capacity((set.len() + added.len()).saturating_sub(removed.len()));
    let (mut a, mut r) = (0, 0);
    for &id in set.iter() {
        while let Some(&x) = added.get(a) {
            if x > id {
                break;
            }
            if x == id {
                return Err(FrameError::AddedPresent { id });
            }
            out.push(x);
            a += 1;
        }
        match removed.get(r) {
            Some(&x) if x < id => return Err(FrameError::RemovedAbsent { id: x }),
            Some(&x) if x == id => r += 1,
            _ => out.push(id),
        }
    }
    if let Some(&x) = removed.get(r) {
        return Err(FrameError::RemovedAbsent { id: x });
    }
    out.extend_from_slice(added.get(a..).unwrap_or_default());
    *set = out;
    Ok(())
}

/// The delta from `old` to `new` as `(added, removed)`, both strictly ascending.
///
/// Both inputs must be strictly ascending (otherwise the result is meaningless, though
/// this never panics). `apply_delta` of the result to `old` gives `new`.
pub fn diff(old: &[u32], new: &[u32]) -> (Vec<u32>, Vec<u32>) {
    let (mut added, mut removed) = (Vec::new(), Vec::new());
    let (mut i, mut j) = (0, 0);
    loop {
        match (old.get(i), new.get(j)) {
            (Some(&o), Some(&n)) => {
                if o < n {
                    removed.push(o);
                    i += 1;
                } else if n < o {
                    added.push(n);
                    j += 1;
                } else {
                    i += 1;
                    j += 1;
                }
            }
            (Some(&o), None) => {
                removed.push(o);
                i += 1;
            }
            (None, Some(&n)) => {
                added.push(n);
                j += 1;
            }
            (None, None) => break,
        }
    }
    (added, removed)
}
