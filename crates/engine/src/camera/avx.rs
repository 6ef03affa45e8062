//! [`Camera::project_box`] with a box's eight corners in one AVX register per
//! coordinate: the box test's most frequent call, about half of it when written with
//! arrays (LLVM sees that each product takes only two values and keeps the corners
//! scalar however they are spelled, so the lanes are written out here).
//!
//! The same operations as the array path in the same order (glam's `Mat4 * Vec4` sums
//! the columns in order; no fused multiply-add, which would round differently), so
//! the rects are equal bit for bit wherever no corner coordinate is a NaN (only
//! boxes near f32's range make one; this path then takes the clipped one):
//! `camera/tests.rs` checks it on random boxes.
//! Callers reach it from code compiled for AVX (a multiversioned function's AVX2
//! clone) and keep [`Camera::project_box`] for every other CPU.

use std::arch::x86_64::*;

use super::{Camera, RECT_EPSILON_PX, ScreenRect};
use crate::geom::Aabb;

impl Camera {
    /// [`Camera::project_box`], the same rect, with the corners side by side in AVX
    /// lanes where the box lies wholly in front of the near plane.
    ///
    /// # Safety
    ///
    /// The CPU must have AVX. It is a safe call from code compiled with AVX enabled
    /// (a multiversioned function's AVX2 clone); elsewhere, check
    /// `is_x86_feature_detected!("avx")` first.
    #[target_feature(enable = "avx")]
    #[inline]
    pub fn project_box_avx(&self, b: &Aabb) -> Option<ScreenRect> {
        match self.project_box_in_front_avx(b) {
            Some(r) => r,
            None => self.project_box_clipped(b),
        }
    }

    /// `Camera::project_box_in_front` in AVX lanes: `None` when the box needs the
    /// general path (clipping, a corner at infinity or not a number).
    #[target_feature(enable = "avx")]
    #[inline]
    fn project_box_in_front_avx(&self, b: &Aabb) -> Option<Option<ScreenRect>> {
        let m = &self.view;
        let (lo, hi) = (b.min, b.max);
        // Corner i takes max along x when bit 0 is set, y bit 1, z bit 2 (as
        // `Aabb::corners` orders them; the bounds do not depend on the order).
        let cx = _mm256_setr_ps(lo.x, hi.x, lo.x, hi.x, lo.x, hi.x, lo.x, hi.x);
        let cy = _mm256_setr_ps(lo.y, lo.y, hi.y, hi.y, lo.y, lo.y, hi.y, hi.y);
        let cz = _mm256_setr_ps(lo.z, lo.z, lo.z, lo.z, hi.z, hi.z, hi.z, hi.z);
        let row = |i: usize| {
            let [a, b, c, w] = [m.x_axis[i], m.y_axis[i], m.z_axis[i], m.w_axis[i]];
            affine([a, b, c, w], cx, cy, cz)
        };
        let (x, y) = (row(0), row(1));
        let d = _mm256_xor_ps(row(2), _mm256_set1_ps(-0.0)); // −z, as `-(…)` is
        if any_nan(d) {
            return None;
        }
        let (nearest, farthest) = (least(d), greatest(d));
        if nearest < self.near || !farthest.is_finite() {
            return None;
        }
        let half = _mm256_set1_ps(0.5);
        let (s0, s1) = (_mm256_set1_ps(self.scale[0]), _mm256_set1_ps(self.scale[1]));
        let (w, h) = (self.width as f32, self.height as f32);
        // ((x·s0 / d + shift)·0.5 + 0.5)·w and (0.5 − y·s1 / d·0.5)·h, as the array path.
        let sx = _mm256_div_ps(_mm256_mul_ps(x, s0), d);
        let sx = _mm256_add_ps(sx, _mm256_set1_ps(self.shift));
        let sx = _mm256_add_ps(_mm256_mul_ps(sx, half), half);
        let sx = _mm256_mul_ps(sx, _mm256_set1_ps(w));
        let sy = _mm256_mul_ps(_mm256_div_ps(_mm256_mul_ps(y, s1), d), half);
        let sy = _mm256_mul_ps(_mm256_sub_ps(half, sy), _mm256_set1_ps(h));
        if any_nan(_mm256_cmp_ps::<_CMP_UNORD_Q>(sx, sy)) {
            return None; // inf − inf or 0·inf in a corner's x or y: the general path
        }
        Some(rect_from_bounds(
            sx,
            sy,
            self.width,
            self.height,
            nearest,
            farthest,
        ))
    }
}

/// [`ScreenRect::from_bounds`] of the corners' pixel coordinates `sx`, `sy` (none
/// NaN), its four roundings in one register: `[lo_x, lo_y, hi_x, hi_y]` widened,
/// then floored, the `hi` lanes as `−floor(−v)`, which is `ceil(v)` exactly; clamped
/// and truncated to integers as the scalar `clamp(…) as u32` does for these values.
#[target_feature(enable = "avx")]
#[inline]
fn rect_from_bounds(
    sx: __m256,
    sy: __m256,
    w: u32,
    h: u32,
    near: f32,
    far: f32,
) -> Option<ScreenRect> {
    // Halves, then [x, y] pairs: lanes 0 and 1 of `lo` end as the least x and y.
    let halves = |pick: &dyn Fn(__m128, __m128) -> __m128| {
        let x = pick(_mm256_castps256_ps128(sx), _mm256_extractf128_ps::<1>(sx));
        let y = pick(_mm256_castps256_ps128(sy), _mm256_extractf128_ps::<1>(sy));
        let v = pick(_mm_unpacklo_ps(x, y), _mm_unpackhi_ps(x, y));
        pick(v, _mm_movehl_ps(v, v))
    };
    let lo = halves(&|a, b| _mm_min_ps(a, b));
    let hi = halves(&|a, b| _mm_max_ps(a, b));
    let bounds = _mm_movelh_ps(lo, hi);
    let eps = RECT_EPSILON_PX;
    let widened = _mm_add_ps(bounds, _mm_setr_ps(-eps, -eps, eps, eps));
    let sign_hi = _mm_setr_ps(0.0, 0.0, -0.0, -0.0);
    let rounded = _mm_xor_ps(_mm_floor_ps(_mm_xor_ps(widened, sign_hi)), sign_hi);
    let (wf, hf) = (w as f32, h as f32);
    let clamped = _mm_min_ps(
        _mm_max_ps(rounded, _mm_setzero_ps()),
        _mm_setr_ps(wf, hf, wf, hf),
    );
    let px = _mm_cvttps_epi32(clamped);
    let [x0, y0, x1, y1] = [
        _mm_extract_epi32::<0>(px),
        _mm_extract_epi32::<1>(px),
        _mm_extract_epi32::<2>(px),
        _mm_extract_epi32::<3>(px),
    ]
    .map(|v| v as u32);
    (x0 < x1 && y0 < y1).then_some(ScreenRect {
        x0,
        y0,
        x1,
        y1,
        near,
        far,
    })
}

/// `((a·cx + b·cy) + c·cz) + w` lane-wise: one row of the view matrix at each corner.
#[target_feature(enable = "avx")]
#[inline]
fn affine([a, b, c, w]: [f32; 4], cx: __m256, cy: __m256, cz: __m256) -> __m256 {
    let v = _mm256_add_ps(
        _mm256_mul_ps(_mm256_set1_ps(a), cx),
        _mm256_mul_ps(_mm256_set1_ps(b), cy),
    );
    let v = _mm256_add_ps(v, _mm256_mul_ps(_mm256_set1_ps(c), cz));
    _mm256_add_ps(v, _mm256_set1_ps(w))
}

/// Whether any lane is a NaN, or (after an unordered compare) has all bits set.
#[target_feature(enable = "avx")]
#[inline]
fn any_nan(v: __m256) -> bool {
    _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_UNORD_Q>(v, v)) != 0
}

/// The least lane, none NaN (halves, then pairs, then the last two).
#[target_feature(enable = "avx")]
#[inline]
fn least(v: __m256) -> f32 {
    let q: __m128 = _mm_min_ps(_mm256_castps256_ps128(v), _mm256_extractf128_ps::<1>(v));
    let p = _mm_min_ps(q, _mm_movehl_ps(q, q));
    _mm_cvtss_f32(_mm_min_ss(p, _mm_shuffle_ps::<1>(p, p)))
}

/// The greatest lane, none NaN, as [`least`].
#[target_feature(enable = "avx")]
#[inline]
fn greatest(v: __m256) -> f32 {
    let q: __m128 = _mm_max_ps(_mm256_castps256_ps128(v), _mm256_extractf128_ps::<1>(v));
    let p = _mm_max_ps(q, _mm_movehl_ps(q, q));
    _mm_cvtss_f32(_mm_max_ss(p, _mm_shuffle_ps::<1>(p, p)))
}
