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
}
