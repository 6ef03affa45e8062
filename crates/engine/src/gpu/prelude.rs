//! The constants the kernels share with Rust, written into every shader's prelude from
//! the Rust constants themselves, so that the two can never disagree: the box test's
//! margins, the pyramid's level limit, the method and DEB codes, the cleared object ID
//! and the workgroup sizes the dispatches are counted in.

use homcull_proto::DebVariant;

use crate::camera::RECT_EPSILON_PX;
use crate::cull::BoxTest;
use crate::cull::deb::DEPTH_MARGIN;
use crate::reference::MAX_LEVELS;

/// Threads per workgroup of the one-dimensional kernels (box test, refinement filter).
pub const LINEAR_WORKGROUP: u32 = 64;
/// Threads per side of the 8×8 workgroups of the per-pixel kernels (pyramid, collect).
pub const GRID_WORKGROUP: u32 = 8;
/// Cleared ID: no object at this pixel.
pub const NO_OBJECT: u32 = u32::MAX;
/// Set in a refinement pair's object ID: a moving object, which the box test alone
/// judges (object IDs stay below it: scenes are bounded far lower).
pub const MOVING_OBJECT: u32 = 1 << 31;

/// How far, in pixels of its own screen-space gradient, a fragment's interpolated view
/// depth may stray from the exact depth of its surface at the pixel centre. The GPU
/// rasterizes from vertices snapped to its sub-pixel grid and may interpolate a
/// varying elsewhere in the pixel than its centre; on a face seen nearly edge-on
/// (depth changing by metres per pixel) that moves the depth by far more than the
/// relative `DEPTH_MARGIN` (measured on lavapipe: 0.17 m at 485 m, 3.5e-4, on the side
/// of a building of the demo city, which then hid itself: 0.001 px of its gradient,
/// where vertices snap by up to 1/32 px on the coarsest sub-pixel grid Vulkan allows
/// (4 bits; lavapipe and NVIDIA use 8), which moves a point's depth by a step or two of
/// the gradient; 1/16 px covers that, and costs a facing surface at 45° ~4e-4 of its
/// depth at 320×180, 1.3e-4 at 960×540). So the occlusion map keeps
/// each fragment's depth pushed back by this many pixels of its gradient, and the
/// refinement's direct comparison pulls an object's fragment forward by as much: both
/// only ever err towards "visible". Facing surfaces, whose gradient is tiny, lose
/// nothing measurable.
pub const DEPTH_SLACK_PX: f32 = 0.0625;

/// The box test's code (`TestConfig::method`).
pub fn test_code(test: BoxTest) -> u32 {
    match test {
        BoxTest::Hom => 0,
        BoxTest::Hzb => 1,
    }
}

/// The box test's DEB code (`TestConfig::deb`).
pub fn deb_code(deb: DebVariant) -> u32 {
    match deb {
        DebVariant::Plane => 0,
        DebVariant::Tiles => 1,
        DebVariant::Raster => 2,
    }
}

/// WGSL `const` declarations of every shared constant.
pub fn wgsl() -> String {
    // `{:?}` prints the shortest decimal that reads back as the same f32.
    format!(
        "// Generated from the Rust constants (gpu/prelude.rs).\n\
         const RECT_EPSILON_PX: f32 = {RECT_EPSILON_PX:?};\n\
         const DEPTH_MARGIN: f32 = {DEPTH_MARGIN:?};\n\
         const DEPTH_SLACK_PX: f32 = {DEPTH_SLACK_PX:?};\n\
         const MAX_LEVELS: u32 = {MAX_LEVELS}u;\n\
         const METHOD_HOM: u32 = {}u;\n\
         const METHOD_HZB: u32 = {}u;\n\
         const DEB_PLANE: u32 = {}u;\n\
         const DEB_TILES: u32 = {}u;\n\
         const DEB_RASTER: u32 = {}u;\n\
         const NO_OBJECT: u32 = {NO_OBJECT}u;\n\
         const MOVING_OBJECT: u32 = {MOVING_OBJECT}u;\n\
         const LINEAR_WORKGROUP: u32 = {LINEAR_WORKGROUP}u;\n\
         const GRID_WORKGROUP: u32 = {GRID_WORKGROUP}u;\n",
        test_code(BoxTest::Hom),
        test_code(BoxTest::Hzb),
        deb_code(DebVariant::Plane),
        deb_code(DebVariant::Tiles),
        deb_code(DebVariant::Raster),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn floats_read_back_exactly() {
        let text = wgsl();
        let value = |name: &str| -> f32 {
            let line = text.lines().find(|l| l.contains(name)).unwrap();
            line.rsplit("= ")
                .next()
                .unwrap()
                .trim_end_matches(';')
                .parse()
                .unwrap()
        };
        assert_eq!(value("RECT_EPSILON_PX"), RECT_EPSILON_PX);
        assert_eq!(value("DEPTH_MARGIN"), DEPTH_MARGIN);
        assert_eq!(value("DEPTH_SLACK_PX"), DEPTH_SLACK_PX);
    }

    #[test]
    fn no_kernel_declares_a_shared_constant_itself() {
        let kernels = [
            include_str!("shaders/common.wgsl"),
            include_str!("shaders/raster.wgsl"),
            include_str!("shaders/refine.wgsl"),
            include_str!("shaders/refine_early.wgsl"),
            include_str!("shaders/pyramid.wgsl"),
            include_str!("shaders/test.wgsl"),
            include_str!("shaders/oracle.wgsl"),
        ];
        let prelude = wgsl();
        let shared: Vec<&str> = prelude
            .lines()
            .filter_map(|l| l.strip_prefix("const "))
            .map(|l| l.split(':').next().unwrap())
            .collect();
        assert_eq!(shared.len(), 13);
        for k in kernels {
            for name in &shared {
                assert!(!k.contains(&format!("const {name}")), "{name} is generated");
            }
            // Workgroup sizes come from the prelude, never as literals.
            for l in k.lines().filter(|l| l.contains("@workgroup_size")) {
                assert!(l.contains("_WORKGROUP"), "{l}");
            }
        }
    }
}
