//! The per-object tests: HOM overlap + depth test, and the HZB test.
//!
//! WGSL twin: `gpu/shaders/test.wgsl` (same traversal, same comparisons).
//!
//! HOM: start at the level whose texels are at least as large as
//! the rect (so it touches at most 2×2 of them); a texel passes if its opacity reaches
//! that level's threshold and, for the raster DEB, its max occluder depth lies in front
//! of the object; a texel that fails is refined one level down, only where it overlaps
//! the rect; a failing level-0 texel, or any texel with opacity 0, means visible. For
//! the box-based DEBs the depth test is done once up front, against every tile the
//! rect touches.
//!
//! HZB (baseline): the same occluders as a max-depth pyramid in which any uncovered
//! pixel counts as infinitely far; one level, chosen so the rect touches at most 2×2
//! texels; culled if all of them lie in front. No refinement: that is the classic HZB.

use homcull_proto::DebVariant;

use super::pyramid::LevelLayout;
use crate::camera::ScreenRect;
use crate::cull::deb::DepthEstimationBuffer;
use crate::cull::deb::in_front;

/// Deepest traversal stack: 4 start texels + 3 per level below.
pub const STACK_SIZE: usize = 4 + 3 * super::MAX_LEVELS;

/// The level at which a rect spans at most 2×2 texels.
pub fn start_level(r: &ScreenRect, levels: usize) -> usize {
    let m = r.width().max(r.height()).max(1);
    let k = (32 - (m - 1).leading_zeros()) as usize; // ceil(log2(m))
    k.min(levels - 1)
}

/// Read-only view of one pose's pyramid.
pub struct PyramidView<'a> {
    pub layout: &'a LevelLayout,
    pub opacity: &'a [f32],
    pub depth: &'a [f32],
}

/// True if HOM proves the rect hidden.
pub fn hom_occluded(
    r: &ScreenRect,
    p: &PyramidView,
    thresholds: &[f32],
    variant: DebVariant,
    deb: &DepthEstimationBuffer,
) -> bool {
    if variant != DebVariant::Raster && !deb.all_in_front(r, r.near) {
        return false;
    }
    let raster = variant == DebVariant::Raster;
    let k = start_level(r, p.layout.levels());
    let mut stack = [(0u32, 0u32, 0u32); STACK_SIZE];
    let mut top = 0;
    for ty in (r.y0 >> k)..=((r.y1 - 1) >> k) {
        for tx in (r.x0 >> k)..=((r.x1 - 1) >> k) {
            stack[top] = (k as u32, tx, ty);
            top += 1;
        }
    }
    while top > 0 {
        top -= 1;
        let (l, tx, ty) = stack[top];
        let l = l as usize;
        let i = p.layout.index(l, tx, ty);
        let o = p.opacity[i];
        if o >= thresholds[l] && (!raster || in_front(p.depth[i], r.near)) {
            continue;
        }
        if l == 0 || o == 0.0 {
            return false;
        }
        let c = l - 1;
        let cx0 = (2 * tx).max(r.x0 >> c);
        let cx1 = (2 * tx + 1).min((r.x1 - 1) >> c);
        let cy0 = (2 * ty).max(r.y0 >> c);
        let cy1 = (2 * ty + 1).min((r.y1 - 1) >> c);
        for cy in cy0..=cy1 {
            for cx in cx0..=cx1 {
                stack[top] = (c as u32, cx, cy);
                top += 1;
            }
        }
    }
    true
}

/// True if the classic HZB test proves the rect hidden.
pub fn hzb_occluded(r: &ScreenRect, p: &PyramidView) -> bool {
    let k = start_level(r, p.layout.levels());
    for ty in (r.y0 >> k)..=((r.y1 - 1) >> k) {
        for tx in (r.x0 >> k)..=((r.x1 - 1) >> k) {
            let i = p.layout.index(k, tx, ty);
            let d = if p.opacity[i] >= 1.0 {
                p.depth[i]
            } else {
                f32::INFINITY
            };
            if !in_front(d, r.near) {
                return false;
            }
        }
    }
    true
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::reference::{level_thresholds, pyramid};

    fn rect(x0: u32, y0: u32, x1: u32, y1: u32, near: f32) -> ScreenRect {
        ScreenRect {
            x0,
            y0,
            x1,
            y1,
            near,
            far: near + 1.0,
        }
    }

    /// Brute force: every pixel of the rect covered by an occluder in front.
    fn brute(r: &ScreenRect, w: u32, depth0: &[f32]) -> bool {
        (r.y0..r.y1).all(|y| {
            (r.x0..r.x1).all(|x| {
                let d = depth0[(y * w + x) as usize];
                d > 0.0 && in_front(d, r.near)
            })
        })
    }

    #[test]
    fn conservative_hom_equals_brute_force() {
        let (w, h) = (37u32, 23u32);
        // A blobby occlusion map with varying depth.
        let depth0: Vec<f32> = (0..w * h)
            .map(|i| {
                let (x, y) = ((i % w) as i32, (i / w) as i32);
                if (x - 15).pow(2) + (y - 11).pow(2) < 90 || (x > 28 && y < 15) {
                    5.0 + (x % 4) as f32
                } else {
                    0.0
                }
            })
            .collect();
        let layout = LevelLayout::new(w, h);
        let (opacity, depth) = pyramid::build(&layout, &depth0);
        let view = PyramidView {
            layout: &layout,
            opacity: &opacity,
            depth: &depth,
        };
        let thr = level_thresholds(1.0, layout.levels());
        let deb = DepthEstimationBuffer {
            tile: 64,
            cols: 1,
            rows: 1,
            depth: vec![0.0],
        };
        let mut culled = 0;
        for x0 in 0..w {
            for y0 in (0..h).step_by(3) {
                for (dw, dh) in [(1, 1), (3, 2), (7, 5), (12, 9), (30, 20)] {
                    let (x1, y1) = ((x0 + dw).min(w), (y0 + dh).min(h));
                    for near in [4.0, 7.0, 9.5] {
                        let r = rect(x0, y0, x1, y1, near);
                        let want = brute(&r, w, &depth0);
                        assert_eq!(
                            hom_occluded(&r, &view, &thr, DebVariant::Raster, &deb),
                            want,
                            "{r:?}"
                        );
                        culled += want as u32;
                        if hzb_occluded(&r, &view) {
                            assert!(want, "hzb culled a visible rect {r:?}");
                        }
                    }
                }
            }
        }
        assert!(culled > 50);
    }

    #[test]
    fn box_deb_gates_the_overlap_test() {
        let layout = LevelLayout::new(8, 8);
        let (opacity, depth) = pyramid::build(&layout, &[3.0; 64]);
        let view = PyramidView {
            layout: &layout,
            opacity: &opacity,
            depth: &depth,
        };
        let thr = level_thresholds(1.0, layout.levels());
        let deb = DepthEstimationBuffer {
            tile: 4,
            cols: 2,
            rows: 2,
            depth: vec![3.0, 3.0, 3.0, 10.0],
        };
        assert!(hom_occluded(
            &rect(0, 0, 4, 4, 5.0),
            &view,
            &thr,
            DebVariant::Tiles,
            &deb
        ));
        assert!(!hom_occluded(
            &rect(2, 2, 6, 6, 5.0),
            &view,
            &thr,
            DebVariant::Tiles,
            &deb
        ));
    }
}
