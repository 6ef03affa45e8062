//! Poses, projections and screen rects: the ONE place homcull's conventions live.
//!
//! - Units metres, Y up, right-handed (glTF). The camera looks along its local −Z.
//! - Projection is reversed-Z (depth 1 at near, 0 at far) for depth precision in the
//!   oracle; clip-space w equals view depth.
//! - Depth used by culling is *view depth*: distance along the view direction,
//!   positive in front of the camera. Never NDC z.
//! - Pixel (0,0) is the top-left pixel; pixel `i` covers `[i, i+1)` and is sampled at its
//!   centre `i + 0.5`, as GPU rasterizers do.
//! - Screen rects round outward (floor of min, ceil of max, after a 1e-3 px widening
//!   against float noise) and are clamped to the viewport. Every pixel centre that a
//!   point of the box projects to lies in its rect.
//!
//! The WGSL twin of [`Camera::project_box`] is `project_box` in
//! `gpu/shaders/common.wgsl`; they must stay the same algorithm. Its AVX twin,
//! `avx.rs`, must stay the same operations as `project_box_in_front`.

use std::sync::Arc;

use glam::{Mat4, Quat, Vec3, Vec4};
use homcull_proto::Pose;

use crate::geom::{Aabb, Plane};

#[cfg(target_arch = "x86_64")]
mod avx;
mod frustum;
pub mod region;
pub mod stereo;

pub use frustum::FrustumPlanes;
pub use region::Region;

/// Largest accepted viewport side in pixels.
pub const MAX_VIEWPORT_SIDE: u32 = 8192;
/// How far outward a projected rect is widened before rounding, in pixels.
pub const RECT_EPSILON_PX: f32 = 1e-3;
/// Frustum planes reject a box only if it is this far (metres) outside.
pub const FRUSTUM_EPSILON: f32 = 1e-4;

/// Why a pose cannot be used.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum PoseError {
    #[error("pose field `{0}` must be finite")]
    NotFinite(&'static str),
    #[error("fov_y_deg must be in (0, 179], got {0}")]
    Fov(f32),
    #[error("viewport must be between 1x1 and {max}x{max} pixels, got {w}x{h}", max = MAX_VIEWPORT_SIDE)]
    Viewport { w: u32, h: u32 },
    #[error("near must be > 0 and far > near (with far/near ≤ 1e7), got near {near}, far {far}")]
    Planes { near: f32, far: f32 },
    #[error("rotation must be a non-zero quaternion of finite length")]
    Rotation,
    #[error("give either rotation or look_at, not both")]
    BothOrientations,
    #[error("look_at must differ from position and not be parallel to up")]
    LookAt,
    #[error("stereo.ipd_m must be in (0, {max}] metres, got {0}", max = stereo::MAX_IPD_M)]
    Ipd(f32),
    #[error("stereo.convergence_m must be finite and beyond near ({near}), got {convergence}")]
    Convergence { convergence: f32, near: f32 },
    /// A region field out of its range (`region::Region::of`).
    #[error("{field} {why}")]
    Region { field: &'static str, why: String },
}

/// A validated pose with its matrices and frustum.
#[derive(Debug, Clone, PartialEq)]
pub struct Camera {
    pub position: Vec3,
    /// World → view.
    pub view: Mat4,
    /// View → clip, reversed-Z.
    pub proj: Mat4,
    pub view_proj: Mat4,
    pub width: u32,
    pub height: u32,
    pub near: f32,
    pub far: f32,
    /// `proj[0][0]` and `proj[1][1]`: NDC per unit of view x/y at depth 1.
    pub scale: [f32; 2],
    /// Horizontal shift of the frustum in NDC (0 but for a stereo eye converging at a
    /// finite depth, see [`stereo`]): a view point projects to NDC x
    /// `x · scale[0] / depth + shift`.
    pub shift: f32,
    /// Left, right, bottom, top, near, far; inner side positive.
    pub planes: [Plane; 6],
    /// The camera whose frustum chooses this camera's occluders, shared by the cameras
    /// that hold the same one (the eyes of a stereo pose: a frustum enclosing both,
    /// [`stereo::eyes`]); `None`: this camera's own frustum. Which occluders are drawn
    /// never decides whether culling is conservative, only how much it culls.
    pub selection: Option<Arc<Camera>>,
    /// The region of eyes and directions the answer must hold for (`core::region`
    /// culls such a camera); `None`: this camera's eye and view only.
    pub region: Option<Region>,
}

fn finite(name: &'static str, v: &[f32]) -> Result<(), PoseError> {
    if v.iter().all(|x| x.is_finite()) {
        Ok(())
    } else {
        Err(PoseError::NotFinite(name))
    }
}

impl Camera {
    /// Whether this camera and `other` share one occluder selection camera: the eyes
    /// of one stereo pose ([`Camera::selection`]).
    pub fn shares_selection(&self, other: &Camera) -> bool {
        matches!((&self.selection, &other.selection),
            (Some(a), Some(b)) if Arc::ptr_eq(a, b))
    }

    /// Validates a wire pose and builds its camera.
    pub fn new(pose: &Pose) -> Result<Self, PoseError> {
        finite("position", &pose.position)?;
        finite("fov_y_deg", &[pose.fov_y_deg])?;
        finite("near", &[pose.near])?;
        finite("far", &[pose.far])?;
        if !(pose.fov_y_deg > 0.0 && pose.fov_y_deg <= 179.0) {
            return Err(PoseError::Fov(pose.fov_y_deg));
        }
        let [w, h] = pose.viewport;
        if w == 0 || h == 0 || w > MAX_VIEWPORT_SIDE || h > MAX_VIEWPORT_SIDE {
            return Err(PoseError::Viewport { w, h });
        }
        if !(pose.near > 0.0 && pose.far > pose.near && pose.far / pose.near <= 1e7) {
            return Err(PoseError::Planes {
                near: pose.near,
                far: pose.far,
            });
        }
        let eye = Vec3::from(pose.position);
        let view = match (pose.rotation, pose.look_at) {
            (Some(_), Some(_)) => return Err(PoseError::BothOrientations),
            (Some(q), None) => {
                finite("rotation", &q)?;
                let q = Quat::from_array(q);
                // Huge finite components overflow the length to infinity, which would
                // normalize to NaNs: such a quaternion is refused like a zero one.
                if !q.length().is_finite() || q.length() <= 1e-6 {
                    return Err(PoseError::Rotation);
                }
                Mat4::from_rotation_translation(q.normalize(), eye).inverse()
            }
            (None, Some(target)) => {
                finite("look_at", &target)?;
                let up = Vec3::from(pose.up.unwrap_or([0.0, 1.0, 0.0]));
                finite("up", &up.to_array())?;
                let dir = Vec3::from(target) - eye;
                if dir.length() < 1e-6
                    || up.length() < 1e-6
                    || dir.normalize().cross(up.normalize()).length() < 1e-4
                {
                    return Err(PoseError::LookAt);
                }
                look_at_rh(eye, Vec3::from(target), up.normalize())
            }
            (None, None) => Mat4::from_translation(-eye),
        };
        let region = Region::of(pose)?;
        Ok(Camera {
            region,
            ..Camera::from_view(eye, view, pose.fov_y_deg, w, h, pose.near, pose.far)
        })
    }

    /// Builds a camera from an already valid view matrix.
    pub fn from_view(
        position: Vec3,
        view: Mat4,
        fov_y_deg: f32,
        width: u32,
        height: u32,
        near: f32,
        far: f32,
    ) -> Self {
        Self::from_view_shifted(position, view, fov_y_deg, width, height, near, far, 0.0)
    }

    /// [`Camera::from_view`] with the frustum shifted by `shift` in NDC x (an off-axis
    /// frustum: the window moves sideways, the eye and its optical axis stay).
    #[allow(clippy::too_many_arguments)]
    pub fn from_view_shifted(
        position: Vec3,
        view: Mat4,
        fov_y_deg: f32,
        width: u32,
        height: u32,
        near: f32,
        far: f32,
        shift: f32,
    ) -> Self {
        let aspect = width as f32 / height as f32;
        let mut proj = perspective_reversed_z(fov_y_deg.to_radians(), aspect, near, far);
        // Clip w is the view depth d = −z, so x_ndc = scale·x/d − proj.z_axis.x.
        if shift != 0.0 {
            proj.z_axis.x = -shift;
        }
        let view_proj = proj * view;
        let r = |i: usize| view_proj.row(i);
        let planes = [
            Plane::normalized(r(3) + r(0)),
            Plane::normalized(r(3) - r(0)),
            Plane::normalized(r(3) + r(1)),
            Plane::normalized(r(3) - r(1)),
            Plane::normalized(r(3) - r(2)), // z ≤ w: depth ≥ near
            Plane::normalized(r(2)),        // z ≥ 0: depth ≤ far
        ];
        Camera {
            position,
            view,
            proj,
            view_proj,
            width,
            height,
            near,
            far,
            scale: [proj.x_axis.x, proj.y_axis.y],
            shift,
            planes,
            selection: None,
            region: None,
        }
    }

    /// The unit direction the camera looks along.
    pub fn forward(&self) -> Vec3 {
        -self.view.row(2).truncate().normalize()
    }

    /// The view's up direction in world space (unit).
    pub fn up(&self) -> Vec3 {
        self.view.row(1).truncate().normalize()
    }

    /// Conservative frustum test: false only if the box lies wholly outside one plane.
    /// (Many boxes against one camera: [`Camera::frustum_planes`], the same answers.)
    pub fn intersects(&self, b: &Aabb) -> bool {
        self.planes
            .iter()
            .all(|p| p.max_distance(b) >= -FRUSTUM_EPSILON)
    }

    /// The frustum planes lane by lane, for testing many boxes: the same answers as
    /// [`Camera::intersects`], in one pass of lane arithmetic inlined into the caller.
    pub fn frustum_planes(&self) -> FrustumPlanes {
        FrustumPlanes::new(self)
    }

    /// View depth of a world point (positive in front of the camera).
    pub fn depth_of(&self, p: Vec3) -> f32 {
        -(self.view * p.extend(1.0)).z
    }

    /// The world point seen through the centre of pixel `(x, y)` at view depth `depth`
    /// (the inverse of rasterizing a point: what an ID buffer's depth says was hit).
    pub fn unproject_pixel(&self, x: u32, y: u32, depth: f32) -> Vec3 {
        self.unprojector()(x, y, depth)
    }

    /// [`Camera::unproject_pixel`] for many pixels: the view matrix is inverted once.
    pub fn unprojector(&self) -> impl Fn(u32, u32, f32) -> Vec3 + '_ {
        let to_world = self.view.inverse();
        move |x, y, depth| {
            let ndc_x = (x as f32 + 0.5) / self.width as f32 * 2.0 - 1.0;
            let ndc_y = 1.0 - (y as f32 + 0.5) / self.height as f32 * 2.0;
            let view = Vec4::new(
                (ndc_x - self.shift) * depth / self.scale[0],
                ndc_y * depth / self.scale[1],
                -depth,
                1.0,
            );
            (to_world * view).truncate()
        }
    }

    /// Projects a box to its pixel rect and depth range, clipping it at the near plane
    /// (the clipped part has depth ≥ near, so its nearest depth is then `near`).
    /// `None` if no part of the box is in front of the near plane or its rect is off
    /// screen: then the box covers no pixel centre.
    #[inline(always)]
    pub fn project_box(&self, b: &Aabb) -> Option<ScreenRect> {
        self.project_box_in_front(b)
            .unwrap_or_else(|| self.project_box_clipped(b))
    }

    /// [`Camera::project_box`] for a box wholly in front of the near plane (None
    /// otherwise: then the box needs clipping). The same arithmetic as the general
    /// path, operation for operation (glam's `Mat4 * Vec4` sums the columns in order;
    /// `w = 1` multiplies exactly), laid out as eight corners side by side so that
    /// the divisions and the min/max run lane-wise: the same rect, several times
    /// faster (the box test's most frequent call).
    #[inline(always)]
    fn project_box_in_front(&self, b: &Aabb) -> Option<Option<ScreenRect>> {
        let m = &self.view;
        // (LLVM sees each product below take two values and keeps most of this
        // scalar, however the corners are spelled: 8-wide lanes need explicit SIMD.)
        let (mut x, mut y, mut d) = ([0.0f32; 8], [0.0f32; 8], [0.0f32; 8]);
        for i in 0..8 {
            let cx = if i & 1 == 0 { b.min.x } else { b.max.x };
            let cy = if i & 2 == 0 { b.min.y } else { b.max.y };
            let cz = if i & 4 == 0 { b.min.z } else { b.max.z };
            x[i] = m.x_axis.x * cx + m.y_axis.x * cy + m.z_axis.x * cz + m.w_axis.x;
            y[i] = m.x_axis.y * cx + m.y_axis.y * cy + m.z_axis.y * cz + m.w_axis.y;
            d[i] = -(m.x_axis.z * cx + m.y_axis.z * cy + m.z_axis.z * cz + m.w_axis.z);
        }
        if d.iter().fold(false, |nan, v| nan | v.is_nan()) {
            return None; // a corner is not a number: the general path
        }
        let (nearest, farthest) = (least(&d), greatest(&d));
        if nearest < self.near || !farthest.is_finite() {
            return None; // clipping needed (or an infinite corner: the general path)
        }
        let (w, h) = (self.width as f32, self.height as f32);
        let (mut sx, mut sy) = ([0.0f32; 8], [0.0f32; 8]);
        for i in 0..8 {
            sx[i] = ((x[i] * self.scale[0] / d[i] + self.shift) * 0.5 + 0.5) * w;
            sy[i] = (0.5 - y[i] * self.scale[1] / d[i] * 0.5) * h;
        }
        Some(ScreenRect::from_bounds(
            [least(&sx), least(&sy)],
            [greatest(&sx), greatest(&sy)],
            self.width,
            self.height,
            nearest,
            farthest,
        ))
    }

    /// [`Camera::project_box`], corner by corner, clipping at the near plane.
    fn project_box_clipped(&self, b: &Aabb) -> Option<ScreenRect> {
        let (lo, hi, nearest, farthest) = self.clipped_bounds(b)?;
        ScreenRect::from_bounds(lo, hi, self.width, self.height, nearest, farthest)
    }

    /// The float pixel bounds `(lo, hi)` of a box's projection, clipped at the near
    /// plane and clamped to the viewport; `None` when no part of it is in front of the
    /// near plane or on screen. What level-of-detail hints measure.
    pub fn projected_bounds(&self, b: &Aabb) -> Option<([f32; 2], [f32; 2])> {
        let (lo, hi, _, _) = self.clipped_bounds(b)?;
        let (w, h) = (self.width as f32, self.height as f32);
        let lo = [lo[0].clamp(0.0, w), lo[1].clamp(0.0, h)];
        let hi = [hi[0].clamp(0.0, w), hi[1].clamp(0.0, h)];
        (lo[0] < hi[0] && lo[1] < hi[1]).then_some((lo, hi))
    }

    /// Pixel bounds (not rounded or clamped) and view-depth range of a box's part in
    /// front of the near plane: its corners there, and where its edges cross the plane.
    fn clipped_bounds(&self, b: &Aabb) -> Option<([f32; 2], [f32; 2], f32, f32)> {
        let corners = b.corners().map(|c| (self.view * c.extend(1.0)).truncate());
        let mut lo = [f32::INFINITY; 2];
        let mut hi = [f32::NEG_INFINITY; 2];
        let mut nearest = f32::INFINITY;
        let mut farthest = f32::NEG_INFINITY;
        let mut add = |v: Vec3| {
            let d = -v.z;
            let sx = ((v.x * self.scale[0] / d + self.shift) * 0.5 + 0.5) * self.width as f32;
            let sy = (0.5 - v.y * self.scale[1] / d * 0.5) * self.height as f32;
            lo = [lo[0].min(sx), lo[1].min(sy)];
            hi = [hi[0].max(sx), hi[1].max(sy)];
        };
        for v in corners {
            let d = -v.z;
            if d >= self.near {
                add(v);
                nearest = nearest.min(d);
                farthest = farthest.max(d);
            }
        }
        if farthest < self.near {
            return None;
        }
        if corners.iter().any(|v| -v.z < self.near) {
            nearest = self.near;
            for (a, c) in BOX_EDGES {
                let (va, vc) = (corners[a], corners[c]);
                let (da, dc) = (-va.z, -vc.z);
                if (da < self.near) != (dc < self.near) {
                    let t = (self.near - da) / (dc - da);
                    let mut p = va + (vc - va) * t;
                    p.z = -self.near;
                    add(p);
                }
            }
        }
        Some((lo, hi, nearest, farthest))
    }
}

/// Right-handed view matrix looking from `eye` at `target`.
pub fn look_at_rh(eye: Vec3, target: Vec3, up: Vec3) -> Mat4 {
    let f = (target - eye).normalize();
    let s = f.cross(up).normalize();
    let u = s.cross(f);
    Mat4::from_cols(
        Vec4::new(s.x, u.x, -f.x, 0.0),
        Vec4::new(s.y, u.y, -f.y, 0.0),
        Vec4::new(s.z, u.z, -f.z, 0.0),
        Vec4::new(-s.dot(eye), -u.dot(eye), f.dot(eye), 1.0),
    )
}

/// Right-handed perspective projection with reversed-Z into wgpu's [0, 1] depth range:
/// depth `near` → 1, `far` → 0, and clip w = view depth.
pub fn perspective_reversed_z(fov_y: f32, aspect: f32, near: f32, far: f32) -> Mat4 {
    let f = 1.0 / (0.5 * fov_y).tan();
    let a = near / (far - near);
    Mat4::from_cols(
        Vec4::new(f / aspect, 0.0, 0.0, 0.0),
        Vec4::new(0.0, f, 0.0, 0.0),
        Vec4::new(0.0, 0.0, a, -1.0),
        Vec4::new(0.0, 0.0, far * a, 0.0),
    )
}

/// The twelve edges of a box, as pairs of [`Aabb::corners`] indices.
pub const BOX_EDGES: [(usize, usize); 12] = [
    (0, 1),
    (2, 3),
    (4, 5),
    (6, 7),
    (0, 2),
    (1, 3),
    (4, 6),
    (5, 7),
    (0, 4),
    (1, 5),
    (2, 6),
    (3, 7),
];

/// A projected box: pixels `[x0, x1) × [y0, y1)` and its view-depth range.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ScreenRect {
    pub x0: u32,
    pub y0: u32,
    pub x1: u32,
    pub y1: u32,
    /// Nearest view depth of the (near-clipped) box.
    pub near: f32,
    /// Farthest view depth of the box.
    pub far: f32,
}

impl ScreenRect {
    /// Rounds float pixel bounds outward and clamps them to the viewport.
    pub fn from_bounds(
        lo: [f32; 2],
        hi: [f32; 2],
        w: u32,
        h: u32,
        near: f32,
        far: f32,
    ) -> Option<Self> {
        let clamp = |v: f32, max: u32| v.clamp(0.0, max as f32) as u32;
        let x0 = clamp((lo[0] - RECT_EPSILON_PX).floor(), w);
        let y0 = clamp((lo[1] - RECT_EPSILON_PX).floor(), h);
        let x1 = clamp((hi[0] + RECT_EPSILON_PX).ceil(), w);
        let y1 = clamp((hi[1] + RECT_EPSILON_PX).ceil(), h);
        (x0 < x1 && y0 < y1).then_some(ScreenRect {
            x0,
            y0,
            x1,
            y1,
            near,
            far,
        })
    }

    pub fn width(&self) -> u32 {
        self.x1 - self.x0
    }

    pub fn height(&self) -> u32 {
        self.y1 - self.y0
    }
}

/// The least of eight numbers, none NaN, as a tree of compare-and-selects (one
/// `minps` a level, where `f32::min`'s NaN rule kept the folds one after another);
/// the same value as folding with `f32::min` (of equal values, a zero's sign may
/// differ, which no caller tells apart: they round the bounds to pixels).
#[inline(always)]
fn least(v: &[f32; 8]) -> f32 {
    tree_of_eight(v, |a, b| if b < a { b } else { a })
}

/// The greatest of eight numbers, none NaN, as [`least`].
#[inline(always)]
fn greatest(v: &[f32; 8]) -> f32 {
    tree_of_eight(v, |a, b| if b > a { b } else { a })
}

/// `pick` folded over eight numbers as a tree: halves, then quarters, then the pair.
#[inline(always)]
fn tree_of_eight(v: &[f32; 8], pick: impl Fn(f32, f32) -> f32) -> f32 {
    let q = [
        pick(v[0], v[4]),
        pick(v[1], v[5]),
        pick(v[2], v[6]),
        pick(v[3], v[7]),
    ];
    pick(pick(q[0], q[2]), pick(q[1], q[3]))
}

/// GPU copy of a camera: one 256-byte slot, so the same buffer serves as a storage array
/// and as dynamic-offset uniforms. Mirrors `PoseUniform` in `common.wgsl`.
#[repr(C)]
#[derive(Debug, Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
pub struct PoseUniform {
    pub view_proj: [[f32; 4]; 4],
    pub view: [[f32; 4]; 4],
    /// `[scale_x, scale_y, width, height]`.
    pub scale_viewport: [f32; 4],
    /// `[near, far, deb_plane_depth, shift]` (`shift`: [`Camera::shift`]).
    pub near_far: [f32; 4],
    pub _pad: [f32; 24],
}
const _: () = assert!(std::mem::size_of::<PoseUniform>() == 256);

impl PoseUniform {
    pub fn new(cam: &Camera, deb_plane_depth: f32) -> Self {
        PoseUniform {
            view_proj: cam.view_proj.to_cols_array_2d(),
            view: cam.view.to_cols_array_2d(),
            scale_viewport: [
                cam.scale[0],
                cam.scale[1],
                cam.width as f32,
                cam.height as f32,
            ],
            near_far: [cam.near, cam.far, deb_plane_depth, cam.shift],
            _pad: [0.0; 24],
        }
    }
}

/// Helper for tests and tools: a camera at `eye` looking at `target`.
pub fn look_at(eye: Vec3, target: Vec3, width: u32, height: u32) -> Camera {
    let mut pose = Pose::looking_at(eye.to_array(), target.to_array());
    pose.viewport = [width, height];
    Camera::new(&pose).expect("valid look_at pose")
}

/// Homogeneous helper used by tests: world point → pixel coordinates and depth.
pub fn project_point(cam: &Camera, p: Vec3) -> (f32, f32, f32) {
    let c: Vec4 = cam.view_proj * p.extend(1.0);
    let sx = (c.x / c.w * 0.5 + 0.5) * cam.width as f32;
    let sy = (0.5 - c.y / c.w * 0.5) * cam.height as f32;
    (sx, sy, c.w)
}

#[cfg(test)]
mod tests;
