//! Section 1b: the native CPU backend beside the report's GPU adapter, on the same
//! scenes and poses: quality against the exact oracle and time per pose, so that a
//! reader without a GPU sees what the CPU backend gives up (nothing, or how much) and
//! what it costs. Runs only when the report's backend is a wgpu adapter (on the native
//! backend, section 1 is this comparison's other half).
//!
//! Each backend is measured against its own exact oracle (the GPU's ID buffer, or the
//! native ID buffer, which equals the CPU oracle twin pixel for pixel); the two
//! oracles can differ by a few objects per scene where the GPU's fixed-point raster
//! and the f64 twin decide a pixel centre on an edge differently.

use std::fmt::Write as _;

use anyhow::Result;

use super::context::{Report, TARGET_SCENES, over, progress};
use super::scenes::Loaded;
use super::targets::Target;
use crate::{EvalReport, MethodSpec, evaluate};
use homcull_engine::engine::Backend;
use homcull_engine::occluders::OccluderParams;

/// Section 1b, from section 1's runs (`evals`, in the order of `scenes`).
pub(super) fn section(r: &mut Report, scenes: &[Loaded], evals: &[EvalReport]) -> Result<()> {
    if r.backend.gpu().is_none() {
        return Ok(());
    }
    let p = r.plan.clone();
    let refined = MethodSpec::with_defaults("hom-refine").map_err(anyhow::Error::msg)?;
    let native = Backend::Native;
    let mut rows = Vec::new();
    for (i, l) in scenes.iter().enumerate() {
        progress("cpu backend", i, scenes.len(), &l.scene.name);
        let cams = l.cams(p.poses, p.viewport)?;
        let budget = OccluderParams::default().budget_triangles;
        let mut engine = r.engine_on(l.scene.clone(), budget, native.clone());
        let e = evaluate(
            &mut engine,
            &cams,
            std::slice::from_ref(&refined),
            p.batch,
            None,
            false,
        )?;
        rows.push(e);
    }
    let _ = writeln!(
        r.md,
        "\n### 1b. The native CPU backend beside the adapter\n\n\
         The same poses as section 1, refined HOM (`hom-refine`) on **{}** and on the \
         report's adapter, each against its own exact oracle; batch {}. ms/pose p50 over \
         batches, the whole query (planning, raster, tests, refinement).\n\n\
         | scene | backend | false culls | efficiency | kept/oracle | hom-refine ms/pose | exact ms/pose |\n\
         |---|---|---:|---:|---:|---:|---:|",
        native.describe(),
        p.batch
    );
    for (gpu, cpu) in evals.iter().zip(&rows) {
        for (name, e) in [("adapter", gpu), ("cpu", cpu)] {
            let (m, exact) = (&e.methods["hom-refine"], &e.methods["exact"]);
            let _ = writeln!(
                r.md,
                "| {} | {name} | {} | {:.4} | {:.3} | {:.2} | {:.2} |",
                e.scene,
                m.false_culls,
                m.efficiency,
                over(m),
                m.ms_per_pose.p50,
                exact.ms_per_pose.p50
            );
        }
    }
    targets(r, &rows);
    Ok(())
}

/// The CPU backend's quality targets: no false culls, refined efficiency and kept
/// triangles on the shared scenes.
fn targets(r: &mut Report, rows: &[EvalReport]) {
    let false_culls: u64 = rows
        .iter()
        .map(|e| e.methods["hom-refine"].false_culls)
        .sum();
    let poses: u64 = rows.iter().map(|e| e.poses).sum();
    r.targets.push(Target {
        issue: 17,
        what: "false culls of the CPU backend (hom-refine) against its exact oracle = 0".into(),
        measured: format!("{false_culls} in {poses} poses on {} scenes", rows.len()),
        met: false_culls == 0,
    });
    let shared: Vec<&EvalReport> = rows
        .iter()
        .filter(|e| TARGET_SCENES.contains(&e.scene.as_str()))
        .collect();
    let worst = |key: fn(&EvalReport) -> f64, lowest: bool| {
        shared
            .iter()
            .map(|e| (e.scene.as_str(), key(e)))
            .reduce(|a, b| if (b.1 < a.1) == lowest { b } else { a })
    };
    if let Some((scene, eff)) = worst(|e| e.methods["hom-refine"].efficiency, true) {
        r.targets.push(Target::bound(
            17,
            &format!("CPU backend refined efficiency on the shared scenes (worst: {scene})"),
            eff,
            0.99,
            true,
            "",
        ));
    }
    if let Some((scene, kept)) = worst(|e| over(&e.methods["hom-refine"]), false) {
        r.targets.push(Target::bound(
            17,
            &format!("CPU backend kept ÷ oracle triangles on the shared scenes (worst: {scene})"),
            kept,
            1.02,
            false,
            "×",
        ));
    }
}
