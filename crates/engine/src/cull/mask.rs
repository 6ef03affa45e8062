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

/// The IDs whose bits are set, ascending: a bit per object and one pass over the
/// words, where sorting the IDs a query found in tree order cost a tenth of a plan.
pub fn set_bits(mask: &[u32]) -> impl Iterator<Item = u32> + '_ {
    mask.iter().enumerate().flat_map(|(w, &bits)| {
        let base = w as u32 * 32;
        std::iter::successors((bits != 0).then_some(bits), |&b| {
            let rest = b & (b - 1);
            (rest != 0).then_some(rest)
        })
        .map(move |b| base + b.trailing_zeros())
    })
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

    #[test]
    fn set_bits_lists_each_set_bit_ascending() {
        let ids = [0, 1, 31, 32, 33, 63, 64, 95, 200];
        let mut m = empty_mask(201);
        for &i in &ids {
            set_bit(&mut m, i);
        }
        assert_eq!(set_bits(&m).collect::<Vec<_>>(), ids);
        assert_eq!(set_bits(&empty_mask(100)).count(), 0);
        assert_eq!(set_bits(&[!0]).count(), 32);
    }
}
