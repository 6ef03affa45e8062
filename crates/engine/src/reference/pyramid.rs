//! The occlusion pyramid: level layout and the 2×2 reduction.
//!
//! Level 0 is the occlusion map at viewport resolution: opacity 1 where an occluder
//! covers the pixel centre, else 0, and the nearest occluder's view depth there (0
//! where uncovered). Level k+1 has `ceil(w/2) × ceil(h/2)` texels; each averages the
//! opacity of its 2×2 children and takes the max of their depth. Children outside
//! the level count as transparent (opacity 0), never opaque, so a texel is fully
//! opaque only if every pixel under it is covered.
//!
//! All levels live in one flat array per pose; [`LevelLayout`] gives the offsets, the
//! same on CPU and GPU. WGSL twin: `gpu/shaders/pyramid.wgsl`.

use super::MAX_LEVELS;

/// Sizes and offsets of the levels of a pyramid for one viewport.
#[derive(Debug, Clone, PartialEq)]
pub struct LevelLayout {
    pub dims: Vec<(u32, u32)>,
    pub offsets: Vec<u32>,
    /// Texels in all levels together (the per-pose stride).
    pub total: u32,
}

impl LevelLayout {
    pub fn new(width: u32, height: u32) -> Self {
        let (mut w, mut h) = (width.max(1), height.max(1));
        let mut dims = vec![(w, h)];
        while (w > 1 || h > 1) && dims.len() < MAX_LEVELS {
            w = w.div_ceil(2);
            h = h.div_ceil(2);
            dims.push((w, h));
        }
        let mut offsets = Vec::with_capacity(dims.len());
        let mut total = 0;
        for &(w, h) in &dims {
            offsets.push(total);
            total += w * h;
        }
        LevelLayout {
            dims,
            offsets,
            total,
        }
    }

    pub fn levels(&self) -> usize {
        self.dims.len()
    }

    #[inline]
    pub fn index(&self, level: usize, x: u32, y: u32) -> usize {
        (self.offsets[level] + y * self.dims[level].0 + x) as usize
    }
}

/// Fills levels 1.. of `opacity` and `depth` (laid out by `layout`) from level 0.
pub fn reduce(layout: &LevelLayout, opacity: &mut [f32], depth: &mut [f32]) {
    for l in 1..layout.levels() {
        let (w, h) = layout.dims[l];
        let (sw, sh) = layout.dims[l - 1];
        for y in 0..h {
            for x in 0..w {
                let (o, d) = reduce_texel(layout, l, x, y, sw, sh, opacity, depth);
                let i = layout.index(l, x, y);
                opacity[i] = o;
                depth[i] = d;
            }
        }
    }
}

#[allow(clippy::too_many_arguments)]
#[inline]
fn reduce_texel(
    layout: &LevelLayout,
    l: usize,
    x: u32,
    y: u32,
    sw: u32,
    sh: u32,
    opacity: &[f32],
    depth: &[f32],
) -> (f32, f32) {
    let mut sum = 0.0f32;
    let mut max_d = 0.0f32;
    for (dx, dy) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
        let (cx, cy) = (2 * x + dx, 2 * y + dy);
        if cx < sw && cy < sh {
            let j = layout.index(l - 1, cx, cy);
            sum += opacity[j];
            max_d = max_d.max(depth[j]);
        }
    }
    (sum * 0.25, max_d)
}

/// Builds the level-0 opacity from a depth map (0 = uncovered) and reduces all levels.
pub fn build(layout: &LevelLayout, level0_depth: &[f32]) -> (Vec<f32>, Vec<f32>) {
    let n = layout.total as usize;
    let mut opacity = vec![0.0; n];
    let mut depth = vec![0.0; n];
    for (i, &d) in level0_depth.iter().enumerate() {
        opacity[i] = if d > 0.0 { 1.0 } else { 0.0 };
        depth[i] = d;
    }
    reduce(layout, &mut opacity, &mut depth);
    (opacity, depth)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn layout_of_odd_sizes() {
        let l = LevelLayout::new(5, 3);
        assert_eq!(l.dims, vec![(5, 3), (3, 2), (2, 1), (1, 1)]);
        assert_eq!(l.offsets, vec![0, 15, 21, 23]);
        assert_eq!(l.total, 24);
    }

    #[test]
    fn odd_edges_are_never_opaque() {
        let l = LevelLayout::new(3, 3);
        let (o, d) = build(&l, &[2.0; 9]);
        // Level 1 texel (0,0) has 4 covered children; (1,0) only 2 in range.
        assert_eq!(o[l.index(1, 0, 0)], 1.0);
        assert_eq!(o[l.index(1, 1, 0)], 0.5);
        assert_eq!(o[l.index(1, 1, 1)], 0.25);
        assert_eq!(d[l.index(2, 0, 0)], 2.0);
        assert!(o[l.index(2, 0, 0)] < 1.0);
    }
}
