//! Per-pose visibility bitmasks: bit `id` of a pose's words is set when object `id`
//! may be visible. Every backend answers in this form.

/// Words of a per-pose visibility bitmask.
pub fn words_per_pose(objects: usize) -> usize {
    objects.div_ceil(32).max(1)
}

/// An all-clear mask for a scene of `objects` objects.
pub fn empty_mask(objects: usize) -> Vec<u32> {
    vec![0; words_per_pose(objects)]
}

pub fn set_bit(mask: &mut [u32], id: u32) {
    mask[id as usize / 32] |= 1 << (id % 32);
}

pub fn clear_bit(mask: &mut [u32], id: u32) {
    mask[id as usize / 32] &= !(1 << (id % 32));
}

pub fn has_bit(mask: &[u32], id: u32) -> bool {
    mask[id as usize / 32] & (1 << (id % 32)) != 0
}

/// Sorted union of two ascending ID lists.
pub fn union(a: &[u32], b: &[u32]) -> Vec<u32> {
    let mut out = Vec::with_capacity(a.len().max(b.len()));
    let (mut i, mut j) = (0, 0);
    while i < a.len() && j < b.len() {
        match a[i].cmp(&b[j]) {
            std::cmp::Ordering::Less => {
                out.push(a[i]);
                i += 1;
            }
            std::cmp::Ordering::Greater => {
                out.push(b[j]);
                j += 1;
            }
            std::cmp::Ordering::Equal => {
                out.push(a[i]);
                i += 1;
                j += 1;
            }
        }
    }
    out.extend_from_slice(&a[i..]);
    out.extend_from_slice(&b[j..]);
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bits_round_trip() {
        let mut m = empty_mask(70);
        assert_eq!(m.len(), 3);
        set_bit(&mut m, 69);
        set_bit(&mut m, 0);
        assert!(has_bit(&m, 69) && has_bit(&m, 0) && !has_bit(&m, 1));
        clear_bit(&mut m, 69);
        assert!(!has_bit(&m, 69));
        assert_eq!(words_per_pose(0), 1);
    }

    #[test]
    fn union_merges_sorted_lists() {
        assert_eq!(union(&[1, 3, 5], &[2, 3, 6, 7]), [1, 2, 3, 5, 6, 7]);
        assert_eq!(union(&[], &[4]), [4]);
        assert_eq!(union(&[4], &[]), [4]);
    }
}
