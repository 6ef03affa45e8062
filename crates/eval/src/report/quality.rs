//! Section 1: every method and threshold on every scene against the exact oracle, the
//! OpenArena maps' PVS pixel audit, and the quality targets.

use std::fmt::Write as _;

use anyhow::Result;

use super::context::{
    QUALITY_METHODS, Report, TARGET_SCENES, THRESHOLDS, over, progress, spec, threshold_name,
};
use super::scenes::Loaded;
use super::targets;
use crate::pvs_audit::audit_pixels;
use crate::{EvalReport, MethodSpec, evaluate};
use homcull_engine::camera::Camera;
use homcull_engine::occluders::OccluderParams;
use homcull_engine::pvs::Pvs;
use homcull_engine::scene::Scene;

/// Section 1 (and the runs of section 2): every method and threshold on every scene.
pub(super) fn section(r: &mut Report, scenes: &[Loaded]) -> Result<Vec<EvalReport>> {
    let p = r.plan.clone();
    let mut methods = QUALITY_METHODS
        .iter()
        .map(|m| MethodSpec::with_defaults(m).map_err(anyhow::Error::msg))
        .collect::<Result<Vec<_>>>()?;
    methods.extend(THRESHOLDS[1..].iter().map(|&t| spec(&threshold_name(t), t)));
    let mut evals = Vec::new();
    let mut audits = Vec::new();
    for (i, l) in scenes.iter().enumerate() {
        progress("quality", i, scenes.len(), &l.scene.name);
        let cams = l.cams(p.poses, p.viewport)?;
        if let Some(pvs) = &l.pvs {
            audits.push((l.scene.name.clone(), audit_poses(pvs, &l.scene, &cams)));
        }
        let mut engine = r.engine(l.scene.clone(), OccluderParams::default().budget_triangles);
        evals.push(evaluate(
            &mut engine,
            &cams,
            &methods,
            p.batch,
            l.pvs.as_ref(),
            false,
        )?);
    }
    let _ = writeln!(
        r.md,
        "## 1. Quality against the exact oracle\n\n\
         {} poses per scene at {}×{}, batch {}, threshold 1.0, occluder budget {} triangles. \
         False culls: objects the oracle sees that the method culled (summed over poses; \
         must be 0 for hom and hzb). Efficiency: share of the in-frustum objects the oracle \
         sees as hidden that the method culls. kept/oracle: triangles of the kept objects ÷ \
         triangles of the objects the oracle sees. ms/pose: wall time per pose of whole \
         batches (planning, GPU, readback), p50 / p95 over batches.\n\n\
         | scene | objects | triangles | method | false culls | efficiency | kept/oracle | ms/pose p50 | ms/pose p95 |\n\
         |---|---:|---:|---|---:|---:|---:|---:|---:|",
        p.poses,
        p.viewport[0],
        p.viewport[1],
        p.batch,
        OccluderParams::default().budget_triangles
    );
    for e in &evals {
        for name in QUALITY_METHODS.iter().copied().chain(["exact"]) {
            let m = &e.methods[name];
            let _ = writeln!(
                r.md,
                "| {} | {} | {} | {name} | {} | {:.3} | {:.2} | {:.2} | {:.2} |",
                e.scene,
                e.objects,
                e.triangles,
                m.false_culls,
                m.efficiency,
                over(m),
                m.ms_per_pose.p50,
                m.ms_per_pose.p95
            );
        }
    }
    let pvs: Vec<String> = evals
        .iter()
        .filter_map(|e| {
            e.pvs.as_ref().map(|c| {
                format!(
                    "{}: {} of {} poses in a cluster, {}",
                    e.scene,
                    c.poses_checked,
                    e.poses,
                    c.summary()
                )
            })
        })
        .collect();
    if !pvs.is_empty() {
        let _ = writeln!(r.md, "\nPVS check (OpenArena maps): {}.", pvs.join("; "));
    }
    if !audits.is_empty() {
        let lines: Vec<String> = audits
            .iter()
            .map(|(scene, a)| {
                format!(
                    "{scene}: {} of {} pixels outside ({} unresolved, in solid)",
                    a.outside, a.pixels, a.solid
                )
            })
            .collect();
        let _ = writeln!(
            r.md,
            "\nPixel audit of the oracle's CPU twin against the PVS (`pvs::audit`: the point \
             each pixel shows, stepped 5 cm towards the eye, must lie in a cluster the \
             camera's PVS row lists): {}.",
            lines.join("; ")
        );
        let (outside, pixels) = audits
            .iter()
            .fold((0, 0), |(o, p), (_, a)| (o + a.outside, p + a.pixels));
        r.targets.push(targets::Target {
            issue: 3,
            what: "pixels the oracle shows where the map's PVS says nothing can be seen = 0".into(),
            measured: format!("{outside} of {pixels} on {} PVS maps", audits.len()),
            met: outside == 0,
        });
    }
    quality_targets(r, &evals);
    Ok(evals)
}

/// Pixel counts of `pvs::audit_pixels` over many poses.
#[derive(Debug, Clone, Copy, Default)]
struct AuditSum {
    pixels: u64,
    outside: u64,
    solid: u64,
}

/// The pixel audit of every pose whose eye is in a cluster, summed.
fn audit_poses(pvs: &Pvs, scene: &Scene, cams: &[Camera]) -> AuditSum {
    use rayon::prelude::*;
    cams.par_iter()
        .filter_map(|c| audit_pixels(pvs, scene, c))
        .map(|a| AuditSum {
            pixels: a.pixels,
            outside: a.outside,
            solid: a.solid,
        })
        .reduce(AuditSum::default, |a, b| AuditSum {
            pixels: a.pixels + b.pixels,
            outside: a.outside + b.outside,
            solid: a.solid + b.solid,
        })
}

/// The quality and speed targets from section 1.
fn quality_targets(r: &mut Report, evals: &[EvalReport]) {
    let conservative = ["hom-refine", "hom-raster", "hom-tiles", "hom-plane", "hzb"];
    let false_culls: u64 = evals
        .iter()
        .flat_map(|e| conservative.iter().filter_map(|m| e.methods.get(*m)))
        .map(|m| m.false_culls)
        .sum();
    let poses: u64 = evals.iter().map(|e| e.poses).sum();
    r.targets.push(targets::Target {
        issue: 3,
        what: "false culls of every HOM variant and HZB at threshold 1.0 = 0".into(),
        measured: format!("{false_culls} in {poses} poses on {} scenes", evals.len()),
        met: false_culls == 0,
    });
    let checks: Vec<_> = evals.iter().filter_map(|e| e.pvs.as_ref()).collect();
    if !checks.is_empty() {
        let unexplained: u64 = checks.iter().map(|c| c.unexplained).sum();
        let outside: u64 = checks.iter().map(|c| c.oracle_outside_pvs).sum();
        r.targets.push(targets::Target {
            issue: 3,
            what: "objects the oracle sees that the map's PVS rules out, unexplained = 0".into(),
            measured: format!(
                "{unexplained} of {outside} sightings on {} PVS maps",
                checks.len()
            ),
            met: unexplained == 0,
        });
    }
    let worst = evals
        .iter()
        .filter(|e| TARGET_SCENES.contains(&e.scene.as_str()))
        .filter_map(|e| Some((e.scene.as_str(), e.methods.get("hom-refine")?.efficiency)))
        .min_by(|a, b| a.1.total_cmp(&b.1));
    if let Some((scene, eff)) = worst {
        r.targets.push(targets::Target::bound(
            3,
            &format!("hom efficiency on the city and game-map scenes (worst: {scene})"),
            eff,
            0.9,
            true,
            "",
        ));
    }
    let ratio = |e: &EvalReport| -> Option<f64> {
        let hom = e.methods.get("hom-refine")?.ms_per_pose.p50;
        let exact = e.methods.get("exact")?.ms_per_pose.p50;
        (exact > 0.0).then(|| hom / exact)
    };
    if let Some(v) = evals.iter().find(|e| e.scene == "munich").and_then(ratio) {
        r.targets.push(targets::Target::bound(
            3,
            &format!(
                "hom ÷ exact time per pose, batch {}, munich (most objects)",
                r.plan.batch
            ),
            v,
            0.5,
            false,
            "×",
        ));
    }
}
