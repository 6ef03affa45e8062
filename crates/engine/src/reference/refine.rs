//! The refinement of the box test (CPU twin of `gpu/refine.rs`): an object that passed
//! the box test is re-tested per pixel of its own triangles against the occluders'
//! level-0 depth map, and is hidden only if every one of its pixels is.

use super::raster::raster_triangle;
use crate::camera::Camera;
use crate::cull::{PosePlan, PreparedScene, clear_bit, has_bit};
use crate::scene::Scene;

/// True if every pixel centre the object covers lies strictly behind the occluder
/// depth map `occluders` (level 0, 0 = uncovered). No depth margin: the map holds
/// the same rasterizer's depths of a subset of the oracle's fragments, so a pixel
/// the oracle gives to the object is at or in front of the map there (the GPU's
/// early depth test makes the same comparison on its own depths).
pub fn hidden_per_pixel(scene: &Scene, cam: &Camera, occluders: &[f32], id: u32) -> bool {
    let o = &scene.objects[id as usize];
    scene.corners_of(o).all(|tri| {
        let mut hidden = true;
        raster_triangle(cam, tri, |x, y, d| {
            let occ = occluders[(y * cam.width + x) as usize];
            hidden &= occ > 0.0 && occ < d;
        });
        hidden
    })
}

/// Clears the bit of every candidate that passed the box test but is hidden at each of
/// its own pixels; moving objects are left as the box test left them (their boxes bound
/// a motion, their triangles do not). GPU twin: `fs_refine` in
/// `gpu/shaders/raster.wgsl`.
pub fn refine(prep: &PreparedScene, p: &PosePlan, occluders: &[f32], mask: &mut [u32]) {
    let scene = &prep.scene;
    for &c in &p.candidates {
        if has_bit(mask, c) && !prep.is_moving(c) && hidden_per_pixel(scene, &p.cam, occluders, c) {
            clear_bit(mask, c);
        }
    }
}
