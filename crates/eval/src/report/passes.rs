//! Section 1c: where the GPU time of each method goes, pass by pass
//! ([`homcull_engine::gpu::profile`]), on every scene, beside the method's wall time per pose.

use std::fmt::Write as _;

use anyhow::Result;

use super::context::{Report, progress};
use super::scenes::Loaded;
use crate::{MethodSpec, evaluate};
use homcull_engine::cull::Pass;
use homcull_engine::occluders::OccluderParams;

/// Poses per scene: enough for stable means, and each method runs twice.
const MAX_POSES: usize = 64;
const METHODS: [&str; 3] = ["hom-refine", "hom-raster", "hzb"];

pub(super) fn section(r: &mut Report, scenes: &[Loaded]) -> Result<()> {
    let p = r.plan.clone();
    let poses = p.poses.min(MAX_POSES);
    let heading = "\n### GPU time per pass\n";
    if !r.backend.gpu().is_some_and(|g| g.timestamps) {
        let _ = writeln!(
            r.md,
            "{heading}\nNot measured: the adapter writes no timestamps between passes \
             (`TIMESTAMP_QUERY_INSIDE_ENCODERS`)."
        );
        return Ok(());
    }
    let _ = writeln!(
        r.md,
        "{heading}\n{poses} poses per scene at {}×{}, batch {}: the same batches run again \
         with GPU timestamps written between the passes (`homcull eval --profile`); \
         mean GPU ms per pose of each pass, their sum, and the wall time per pose of the \
         unprofiled run (p50; it adds planning on the CPU, submission and readback). \
         The raster DEB is the depth half of the pyramid. On a GPU that overlaps \
         consecutive passes the split is approximate.\n\n\
         | scene | method | occluder raster | pyramid | box test | refine | id raster | collect | GPU sum | wall |\n\
         |---|---|---:|---:|---:|---:|---:|---:|---:|---:|",
        p.viewport[0], p.viewport[1], p.batch
    );
    let methods = METHODS
        .iter()
        .map(|m| MethodSpec::with_defaults(m).map_err(anyhow::Error::msg))
        .collect::<Result<Vec<_>>>()?;
    for (i, l) in scenes.iter().enumerate() {
        progress("GPU passes", i, scenes.len(), &l.scene.name);
        let cams = l.cams(poses, p.viewport)?;
        let mut engine = r.engine(l.scene.clone(), OccluderParams::default().budget_triangles);
        let e = evaluate(&mut engine, &cams, &methods, p.batch, None, true)?;
        for name in METHODS.iter().copied().chain(["exact"]) {
            let m = &e.methods[name];
            let Some(passes) = &m.gpu_ms_per_pass else {
                continue;
            };
            let cell = |pass: Pass| {
                passes
                    .0
                    .iter()
                    .find(|(n, _)| *n == pass.name())
                    .map_or("–".to_string(), |(_, ms)| format!("{ms:.2}"))
            };
            let sum: f64 = passes.0.iter().map(|(_, ms)| ms).sum();
            let _ = writeln!(
                r.md,
                "| {} | {name} | {} | {} | {} | {} | {} | {} | {sum:.2} | {:.2} |",
                e.scene,
                cell(Pass::OccluderRaster),
                cell(Pass::Pyramid),
                cell(Pass::BoxTest),
                cell(Pass::Refine),
                cell(Pass::IdRaster),
                cell(Pass::Collect),
                m.ms_per_pose.p50
            );
        }
    }
    Ok(())
}
