//! Section 3b: what motion costs. The same poses and the same placements, with the
//! movers (the demo city's cars, the OpenArena maps' brush models) given a velocity
//! and culled over horizons from 1 ms to 800 ms, against the same scene static: a
//! moving object is tested as its temporal bounding volume, by the box test alone,
//! and does not occlude (`core::dynamic`). 1 ms isolates those two rules (its sweep
//! is millimetres); longer horizons add the sweep. One more row prices the occluder
//! rule alone: the static scene with the movers left out of the occluders (the rest
//! of the 1 ms row's loss is the refinement they no longer get). Each row is against
//! the exact oracle at its own version (false culls must stay 0).

use std::fmt::Write as _;

use anyhow::Result;
use homcull_proto::{ObjectTransform, TransformsRequest};

use super::context::{Report, over, progress};
use super::plot::{Chart, Series};
use super::scenes::Loaded;
use crate::MethodSpec;
use crate::evaluate;
use homcull_engine::scene::Scene;

/// The scenes with movers, what moves and how fast (m/s), and along which axis
/// (oa_shouse has no brush models).
const MOVERS: [(&str, &str, f32, usize); 2] = [
    ("demo", "car_", 10.0, usize::MAX), // along the long horizontal side
    ("oa_dm1", "model_", 2.0, 1),       // up and down
];

/// Section 3b.
pub(super) fn section(r: &mut Report, scenes: &[Loaded]) -> Result<()> {
    let p = r.plan.clone();
    let horizons: Vec<Option<f64>> = if r.plan.poses <= 16 {
        vec![None, Some(1.0), Some(100.0), Some(400.0)]
    } else {
        vec![
            None,
            Some(1.0),
            Some(50.0),
            Some(100.0),
            Some(200.0),
            Some(400.0),
            Some(800.0),
        ]
    };
    let _ = writeln!(
        r.md,
        "\n## 3b. Moving objects\n\n\
         Refined HOM on {} street-level poses at {}×{} per scene with its movers (the demo \
         city's cars at 10 m/s along their street, the maps' brush models at 2 m/s up) \
         given a velocity, culled as temporal bounding volumes over each horizon, against \
         the same placements static. Efficiency is over the objects the exact oracle at \
         the same version finds hidden.\n\n\
         | scene | movers | horizon | efficiency | false culls | kept/oracle | ms/pose p50 |\n\
         |---|---:|---:|---:|---:|---:|---:|",
        p.budget_poses, p.viewport[0], p.viewport[1]
    );
    let refined = MethodSpec::with_defaults("hom-refine").map_err(anyhow::Error::msg)?;
    let mut series = Vec::new();
    let picked: Vec<_> = MOVERS
        .iter()
        .filter_map(|m| scenes.iter().find(|l| l.scene.name == m.0).map(|l| (l, m)))
        .collect();
    let n = picked.len() * horizons.len();
    for (si, &(l, &(_, prefix, speed, axis))) in picked.iter().enumerate() {
        let cams = l.cams(p.budget_poses, p.viewport)?;
        let moves = movers(&l.scene, prefix, speed, axis);
        let mut points = Vec::new();
        for (hi, &h) in horizons.iter().enumerate() {
            let label = h.map_or("static".to_string(), |h| format!("{h} ms"));
            progress(
                "motion",
                si * horizons.len() + hi,
                n,
                &format!("{} {label}", l.scene.name),
            );
            let mut engine = r.engine(l.scene.clone(), 100_000);
            let static_ids = engine.prepared.occluders.ids.clone();
            let objects = match h {
                Some(_) => moves.clone(),
                None => Vec::new(),
            };
            let req = TransformsRequest {
                objects,
                horizon_ms: h,
            };
            engine
                .dynamics()
                .lock()
                .unwrap_or_else(|e| e.into_inner())
                .apply(&req, usize::MAX)?;
            let refine = |engine: &mut homcull_engine::engine::Engine| {
                evaluate(
                    engine,
                    &cams,
                    std::slice::from_ref(&refined),
                    p.batch,
                    None,
                    false,
                )
            };
            let e = refine(&mut engine)?;
            row(r, &e, moves.len(), &label);
            if h.is_none() {
                let kept = static_ids
                    .iter()
                    .copied()
                    .filter(|id| !moves.iter().any(|m| m.id == *id));
                let mut still = r.engine_occluding(l.scene.clone(), 100_000, kept.collect());
                let alone = refine(&mut still)?;
                row(r, &alone, moves.len(), "static, movers not occluding");
            }
            if h != Some(1.0) {
                points.push((h.unwrap_or(0.0), e.methods["hom-refine"].efficiency));
            }
        }
        series.push(Series {
            label: l.scene.name.clone(),
            points,
        });
    }
    if series.is_empty() {
        return Ok(());
    }
    r.plot(
        "motion_efficiency.png",
        &Chart {
            title: "Refined HOM efficiency vs motion horizon",
            x_label: "horizon (ms; 0 = static)",
            y_label: "efficiency",
            log_x: false,
            log_y: false,
        },
        &series,
    )?;
    Ok(())
}

/// One row of the table.
fn row(r: &mut Report, e: &crate::EvalReport, movers: usize, label: &str) {
    let m = &e.methods["hom-refine"];
    let _ = writeln!(
        r.md,
        "| {} | {movers} | {label} | {:.3} | {} | {:.3} | {:.2} |",
        e.scene,
        m.efficiency,
        m.false_culls,
        over(m),
        m.ms_per_pose.p50
    );
}

/// Every object of `scene` named `prefix…` with triangles, at its loaded place, moving
/// at `speed` along `axis` (1 = up; otherwise its longer horizontal side).
fn movers(scene: &Scene, prefix: &str, speed: f32, axis: usize) -> Vec<ObjectTransform> {
    scene
        .objects
        .iter()
        .filter(|o| o.name.starts_with(prefix) && o.index_count > 0)
        .map(|o| {
            let e = o.aabb.extent();
            let along = if axis == 1 {
                [0.0, speed, 0.0]
            } else if e.x >= e.z {
                [speed, 0.0, 0.0]
            } else {
                [0.0, 0.0, speed]
            };
            ObjectTransform {
                id: o.id,
                velocity: Some(along),
                ..Default::default()
            }
        })
        .collect()
}
