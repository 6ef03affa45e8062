//! The exact oracle on the CPU (twin of `gpu/oracle.rs`): every in-frustum object is
//! rasterized into an ID buffer with a depth test, and an object is visible exactly
//! when it owns at least one pixel. Ground truth for every method.

use super::raster::raster_ids;
use crate::cull::{PosePlan, empty_mask, set_bit};
use crate::scene::Scene;

/// The visibility bitmask of the objects owning at least one pixel of the ID buffer.
pub fn exact(scene: &Scene, p: &PosePlan) -> Vec<u32> {
    let n = (p.cam.width * p.cam.height) as usize;
    let mut ids = vec![u32::MAX; n];
    let mut depth = vec![0.0; n];
    raster_ids(
        &p.cam,
        super::triangles_of(scene, &p.candidates),
        &mut ids,
        &mut depth,
    );
    let mut mask = empty_mask(scene.objects.len());
    for id in ids.into_iter().filter(|&id| id != u32::MAX) {
        set_bit(&mut mask, id);
    }
    mask
}
