//! Where HOM's efficiency is lost: of the in-frustum objects the exact
//! oracle sees as hidden, which does HOM keep, and why.
//!
//! Every object the oracle hides but HOM keeps falls in one of two classes, decided by
//! an *ideal per-pixel test*: rasterize the object's own triangles and check that every
//! pixel it covers lies behind the occluders HOM selected for the pose (their level-0
//! depth map, compared without a margin as the refinement does).
//!
//! - **boxes**: the ideal test hides it, so the occluders were enough and the loss is the
//!   test's bounding boxes (a box's screen rect covers pixels the object does not: gaps
//!   between occluders, the sky above a low wall, the screen edge). Tighter bounds win
//!   these back.
//! - **occluders**: some pixel of the object is not behind a selected occluder: it is
//!   hidden by objects that are not occluders (too small or too complex for the occluder
//!   database, or beyond the triangle budget), or only by geometry at exactly the same
//!   depth. A larger or different occluder set wins these back.
//!
//! Everything runs on the CPU reference, which the tests prove equal to the GPU passes.

use rayon::prelude::*;

use homcull_engine::camera::Camera;
use homcull_engine::cull::{CullSettings, PreparedScene, has_bit, plan};
use homcull_engine::reference::ReferenceBackend;
use homcull_engine::reference::pyramid::{self, LevelLayout};
use homcull_engine::reference::refine::hidden_per_pixel;

/// Object counts summed over poses.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, serde::Serialize)]
pub struct EfficiencyLoss {
    pub poses: u64,
    /// In-frustum objects the oracle sees as hidden.
    pub oracle_hidden: u64,
    /// Of those, culled by HOM.
    pub culled: u64,
    /// Kept by HOM although every pixel of the object is behind the selected occluders.
    pub lost_to_boxes: u64,
    /// Kept by HOM, and not hidden by the selected occluders alone.
    pub lost_to_occluders: u64,
}

impl EfficiencyLoss {
    pub fn efficiency(&self) -> f64 {
        ratio(self.culled, self.oracle_hidden)
    }

    /// Efficiency of the ideal per-pixel test with the same occluders: the ceiling of
    /// any tighter bound.
    pub fn with_exact_bounds(&self) -> f64 {
        ratio(self.culled + self.lost_to_boxes, self.oracle_hidden)
    }

    fn add(self, o: Self) -> Self {
        EfficiencyLoss {
            poses: self.poses + o.poses,
            oracle_hidden: self.oracle_hidden + o.oracle_hidden,
            culled: self.culled + o.culled,
            lost_to_boxes: self.lost_to_boxes + o.lost_to_boxes,
            lost_to_occluders: self.lost_to_occluders + o.lost_to_occluders,
        }
    }
}

fn ratio(a: u64, b: u64) -> f64 {
    if b == 0 { 1.0 } else { a as f64 / b as f64 }
}

/// Classifies, for every pose, the oracle-hidden objects HOM's box test keeps
/// (settings `s`, which must be HOM's; `refine` is ignored: this measures what the
/// refinement can win back).
pub fn efficiency_loss(prep: &PreparedScene, cams: &[Camera], s: &CullSettings) -> EfficiencyLoss {
    cams.par_iter()
        .map(|cam| {
            let scene = &prep.scene;
            let p = plan(prep, cam, s);
            let occluders = ReferenceBackend::occluder_depth(scene, &p);
            let layout = LevelLayout::new(cam.width, cam.height);
            let (opacity, depth) = pyramid::build(&layout, &occluders);
            let kept = ReferenceBackend::test_boxes(scene, &p, s, &layout, &opacity, &depth);
            let seen = ReferenceBackend::exact(scene, &p);
            let mut l = EfficiencyLoss {
                poses: 1,
                ..Default::default()
            };
            for &c in p.candidates.iter().filter(|&&c| !has_bit(&seen, c)) {
                l.oracle_hidden += 1;
                if !has_bit(&kept, c) {
                    l.culled += 1;
                } else if hidden_per_pixel(scene, cam, &occluders, c) {
                    l.lost_to_boxes += 1;
                } else {
                    l.lost_to_occluders += 1;
                }
            }
            l
        })
        .reduce(EfficiencyLoss::default, EfficiencyLoss::add)
}

#[cfg(test)]
mod tests {
    use homcull_proto::CullOptions;

    use super::*;
    use homcull_engine::camera::look_at;
    use homcull_engine::cull::Culler;
    use homcull_engine::occluders::OccluderParams;
    use homcull_engine::scene::demo_city;

    #[test]
    fn the_classes_add_up_and_culled_matches_the_cpu_culler() {
        let prep = PreparedScene::new(demo_city(), OccluderParams::default());
        let s = CullSettings::new(
            CullOptions {
                refine: false,
                ..Default::default()
            },
            &prep,
        );
        let cams: Vec<Camera> = (0..4)
            .map(|i| {
                let eye = glam::Vec3::new(-60.0 + 30.0 * i as f32, 1.7, 0.0);
                look_at(eye, eye + glam::Vec3::new(1.0, 0.0, 0.3), 320, 180)
            })
            .collect();
        let l = efficiency_loss(&prep, &cams, &s);
        assert_eq!(l.poses, 4);
        assert!(l.oracle_hidden > 100, "street poses hide much: {l:?}");
        assert_eq!(
            l.culled + l.lost_to_boxes + l.lost_to_occluders,
            l.oracle_hidden
        );
        // `culled` is HOM's count: the same as the CPU culler's answer.
        let mut cpu = ReferenceBackend;
        let exact_s = CullSettings::new(
            CullOptions {
                method: homcull_proto::Method::Exact,
                ..Default::default()
            },
            &prep,
        );
        let hom = cpu.cull(&prep, &cams, &s).unwrap();
        let exact = cpu.cull(&prep, &cams, &exact_s).unwrap();
        let kept_hidden: u64 = hom
            .iter()
            .zip(&exact)
            .map(|(h, e)| {
                (e.stats.candidates - e.visible.len() as u32 - h.stats.culled_by_occlusion) as u64
            })
            .sum();
        assert_eq!(
            l.oracle_hidden - l.culled,
            kept_hidden,
            "kept but hidden, both ways"
        );
        assert!(l.with_exact_bounds() >= l.efficiency());
    }
}
