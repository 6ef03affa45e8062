//! Section 1b: where HOM's efficiency is lost on each scene ([`crate::loss`]).

use std::fmt::Write as _;

use anyhow::Result;
use homcull_proto::CullOptions;

use super::context::{Report, progress};
use super::scenes::Loaded;
use crate::loss::efficiency_loss;
use homcull_engine::cull::{CullSettings, PreparedScene};
use homcull_engine::occluders::OccluderParams;

/// Poses per scene: the CPU reference runs every pass, so fewer than section 1.
const MAX_POSES: usize = 50;

pub(super) fn section(r: &mut Report, scenes: &[Loaded]) -> Result<()> {
    let p = r.plan.clone();
    let poses = p.poses.min(MAX_POSES);
    let _ = writeln!(
        r.md,
        "\n### Where HOM's efficiency is lost\n\n\
         HOM (raster DEB, threshold 1.0, default budget), {poses} poses per scene at {}×{} \
         (seed 7), on the CPU reference (equal to the GPU passes by \
         test). Every in-frustum object the oracle hides but HOM keeps is classed by an \
         ideal per-pixel test: rasterize the object itself and check that each pixel lies \
         behind the occluders HOM selected. **boxes**: it does, so the occluders sufficed \
         and the test's bounding boxes lost it (their rects cover pixels the object does \
         not). **occluders**: it does not: hidden only by objects that are not occluders \
         (size and complexity rules, budget) or by geometry at the same depth. The ceiling \
         is the efficiency of the ideal per-pixel test with the same occluders.\n\n\
         | scene | oracle-hidden | culled | efficiency | lost to boxes | lost to occluders | ceiling with exact bounds |\n\
         |---|---:|---:|---:|---:|---:|---:|",
        p.viewport[0], p.viewport[1],
    );
    for (i, l) in scenes.iter().enumerate() {
        progress("efficiency loss", i, scenes.len(), &l.scene.name);
        let cams = l.cams(poses, p.viewport)?;
        let prep = PreparedScene::new(l.scene.clone(), OccluderParams::default());
        let s = CullSettings::new(
            CullOptions {
                refine: false,
                ..Default::default()
            },
            &prep,
        );
        let loss = efficiency_loss(&prep, &cams, &s);
        let share = |n: u64| 100.0 * n as f64 / loss.oracle_hidden.max(1) as f64;
        let _ = writeln!(
            r.md,
            "| {} | {} | {} | {:.3} | {} ({:.1} %) | {} ({:.1} %) | {:.3} |",
            l.scene.name,
            loss.oracle_hidden,
            loss.culled,
            loss.efficiency(),
            loss.lost_to_boxes,
            share(loss.lost_to_boxes),
            loss.lost_to_occluders,
            share(loss.lost_to_occluders),
            loss.with_exact_bounds()
        );
    }
    Ok(())
}
