//! Deltas between visible sets: computing them on the server, applying them on clients.

use super::codec::{check_ascending, check_changed, check_disjoint, check_levels};
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

/// The levels-of-detail part of the delta from `(old, old_levels)` to `(new,
/// new_levels)` (sets strictly ascending, one level per ID): the levels of the IDs
/// [`diff`] adds, and the IDs in both sets whose level changed.
pub fn diff_levels(old: &[u32], old_levels: &[u8], new: &[u32], new_levels: &[u8]) -> LodChanges {
    let mut lod = LodChanges::default();
    let mut i = 0;
    for (j, &id) in new.iter().enumerate() {
        while old.get(i).is_some_and(|&o| o < id) {
            i += 1;
        }
        let level = new_levels[j];
        if old.get(i) == Some(&id) {
            if old_levels[i] != level {
                lod.changed.push(id);
                lod.changed_levels.push(level);
            }
        } else {
            lod.added.push(level);
        }
    }
    lod
}

/// Applies `delta` to a visible set and its levels of detail (one per ID, in the
/// set's order), as [`apply_delta`] does to the set: added IDs and changed ones take the
/// levels the delta carries, the others keep theirs.
///
/// Fails, leaving both untouched, where [`apply_delta`] would, where the levels are not
/// one per ID (a delta without levels adds none), or where a changed ID is not in the
/// set or is also added or removed.
pub fn apply_delta_with_levels(
    set: &mut Vec<u32>,
    levels: &mut Vec<u8>,
    delta: &VisibleDelta,
) -> Result<(), FrameError> {
    let none = LodChanges::default();
    let lod = delta.lod.as_ref().unwrap_or(&none);
    check_levels(set.len(), levels)?;
    check_levels(delta.added.len(), &lod.added)?;
    check_levels(lod.changed.len(), &lod.changed_levels)?;
    check_ascending("changed", &lod.changed)?;
    check_changed(&lod.changed, &delta.added, &delta.removed)?;
    if let Some(&id) = lod.changed.iter().find(|id| set.binary_search(id).is_err()) {
        return Err(FrameError::ChangedNotKept { id });
    }
    let mut after = set.clone();
    apply_delta(&mut after, delta)?;
    let new_levels = after
        .iter()
        .map(|id| {
            if let Ok(k) = delta.added.binary_search(id) {
                lod.added[k]
            } else if let Ok(k) = lod.changed.binary_search(id) {
                lod.changed_levels[k]
            } else {
                // Kept: in the old set (apply_delta checked it).
                levels[set.binary_search(id).unwrap_or_default()]
            }
        })
        .collect();
    *set = after;
    *levels = new_levels;
    Ok(())
}
