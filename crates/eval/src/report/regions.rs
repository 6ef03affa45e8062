//! Section 7: visibility from a region on every scene.
//!
//! At street-level poses, regions of every radius and turn of the plan: each answer
//! (`hom` with the pose's `region`, as a REST pose or a region stream asks; region
//! answers run on the CPU whatever the backend) is checked against the native exact
//! oracle at eyes sampled in the region ([`crate::region_eyes`]): an object some eye
//! sees that the answer lacks is a false cull. Beside it, what a region costs the
//! client that draws its set: kept ÷ the oracle's triangles at the eye of each drawn
//! frame (the region's eyes, averaged), against radius and turn, with the point
//! answer at the region's centre for scale.

use std::fmt::Write as _;
use std::time::Instant;

use anyhow::Result;
use homcull_engine::camera::Camera;
use homcull_engine::engine::Backend;
use homcull_engine::occluders::OccluderParams;
use homcull_engine::scene::Scene;
use homcull_proto::{CullOptions, Method, Pose};

use super::context::{Report, progress};
use super::plot::{Chart, Series};
use super::scenes::Loaded;
use super::targets::Target;
use crate::percentiles::Percentiles;
use crate::region_eyes::{Xorshift, ball_region, eyes_in_ball};

/// What the regions of one radius and turn on one scene gave.
#[derive(Debug, Clone, Default)]
struct Cell {
    regions: usize,
    eyes: usize,
    /// Objects some eye's oracle sees that the region answer lacks (a false cull).
    missed: usize,
    /// Σ over drawn frames (eyes) of the region answer's triangles.
    kept: u64,
    /// Σ over drawn frames of the triangles the oracle sees at that eye.
    seen: u64,
    /// Σ over regions of the point answer's triangles at the centre, and of the
    /// oracle's there.
    point_kept: u64,
    point_seen: u64,
    /// One-thread time of each region answer, ms.
    ms: Vec<f64>,
}

impl Cell {
    /// The cells summed (one scene's regions of every radius and turn).
    fn total(cells: &[Cell]) -> Cell {
        cells.iter().fold(Cell::default(), |mut a, c| {
            a.regions += c.regions;
            a.eyes += c.eyes;
            a.missed += c.missed;
            (a.kept, a.seen) = (a.kept + c.kept, a.seen + c.seen);
            a.point_kept += c.point_kept;
            a.point_seen += c.point_seen;
            a.ms.extend(&c.ms);
            a
        })
    }

    fn per_frame(&self) -> f64 {
        self.kept as f64 / self.seen.max(1) as f64
    }

    fn point(&self) -> f64 {
        self.point_kept as f64 / self.point_seen.max(1) as f64
    }
}

/// Section 7.
pub(super) fn section(r: &mut Report, scenes: &[Loaded]) -> Result<()> {
    let p = r.plan.clone();
    let combos: Vec<(f32, f32)> = p
        .region_radii
        .iter()
        .flat_map(|&radius| p.region_turns.iter().map(move |&turn| (radius, turn)))
        .collect();
    let n = combos.len() * p.region_poses;
    let _ = writeln!(
        r.md,
        "\n## 7. Visibility from a region\n\n\
         {n} regions per scene ({} street-level poses for each radius of {:?} m and turn \
         of {:?}°) at {}×{}; each answer (`hom`, region answers run on the CPU on every \
         backend) checked against the native exact oracle at {} eyes of its region: the \
         centre looking along the pose, then points of the ball's surface and interior \
         looking across the cone (every fourth on its rim). *Missed*: objects an eye sees \
         that the answer lacks (false culls). *Per drawn frame*: the answer's triangles ÷ \
         the triangles the oracle sees at the eye drawing it, over the region's eyes; \
         *point*: the point answer at the centre ÷ the oracle there.\n\n\
         | scene | regions | eyes | missed | kept ÷ seen per drawn frame | point | ms per region p50 / max |\n\
         |---|---:|---:|---:|---:|---:|---:|",
        p.region_poses, p.region_radii, p.region_turns, p.viewport[0], p.viewport[1], p.region_eyes
    );
    let mut per_scene: Vec<(String, Vec<Cell>)> = Vec::new();
    // Each scene's cells summed, in the same order.
    let mut totals: Vec<Cell> = Vec::new();
    for (si, l) in scenes.iter().enumerate() {
        progress("regions", si, scenes.len(), &l.scene.name);
        let cells = scene_cells(r, &l.scene, &l.poses(n, p.viewport), &combos)?;
        let all = Cell::total(&cells);
        let ms = Percentiles::of(all.ms.clone());
        let _ = writeln!(
            r.md,
            "| {} | {} | {} | {} | {:.2} | {:.2} | {:.0} / {:.0} |",
            l.scene.name,
            all.regions,
            all.eyes,
            all.missed,
            all.per_frame(),
            all.point(),
            ms.p50,
            ms.max
        );
        totals.push(all);
        per_scene.push((l.scene.name.clone(), cells));
    }
    let missed: usize = totals.iter().map(|t| t.missed).sum();
    let least = totals.iter().map(|t| t.regions).min().unwrap_or(0);
    r.targets.push(Target::bound(
        47,
        &format!(
            "objects an eye of a region sees that its answer lacks ({least}+ regions × {} eyes \
             per scene)",
            p.region_eyes
        ),
        missed as f64,
        0.0,
        false,
        "",
    ));
    sweep_table(r, &per_scene, &totals, &combos);
    sweep_plot(r, &per_scene, &combos)
}

/// The regions of `poses` (taken in turn by the radius and turn of `combos`) on
/// `scene`, one [`Cell`] per combo.
fn scene_cells(
    r: &Report,
    scene: &Scene,
    poses: &[Pose],
    combos: &[(f32, f32)],
) -> Result<Vec<Cell>> {
    let p = &r.plan;
    let budget = OccluderParams::default().budget_triangles;
    let mut engine = r.engine(scene.clone(), budget);
    let mut oracle = r.engine_on(scene.clone(), budget, Backend::Native);
    let hom = engine.settings(CullOptions::default());
    let exact = oracle.settings(CullOptions {
        method: Method::Exact,
        ..CullOptions::default()
    });
    let tris = |ids: &[u32]| -> u64 {
        ids.iter()
            .map(|&id| scene.objects[id as usize].triangles() as u64)
            .sum()
    };
    let mut rng = Xorshift::new(super::context::SEED);
    let mut cells = vec![Cell::default(); combos.len()];
    for (i, pose) in poses.iter().enumerate() {
        let (radius, turn) = combos[i % combos.len()];
        let cell = &mut cells[i % combos.len()];
        let point = Camera::new(pose)?;
        let asked = ball_region(pose, radius, turn);
        let started = Instant::now();
        let answer = engine
            .cull(&[Camera::new(&asked)?], &hom)?
            .remove(0)
            .visible;
        cell.ms.push(started.elapsed().as_secs_f64() * 1e3);
        let eyes = eyes_in_ball(&mut rng, pose, point.forward(), radius, turn, p.region_eyes)
            .iter()
            .map(Camera::new)
            .collect::<Result<Vec<_>, _>>()?;
        let seen = oracle.cull(&eyes, &exact)?;
        for s in &seen {
            cell.missed += s
                .visible
                .iter()
                .filter(|id| answer.binary_search(id).is_err())
                .count();
            cell.seen += tris(&s.visible);
        }
        cell.kept += tris(&answer) * eyes.len() as u64;
        cell.point_kept += tris(&engine.cull(&[point], &hom)?.remove(0).visible);
        cell.point_seen += tris(&seen[0].visible);
        cell.regions += 1;
        cell.eyes += eyes.len();
    }
    Ok(cells)
}

/// kept ÷ seen per drawn frame for every radius and turn, a column per scene.
fn sweep_table(
    r: &mut Report,
    per_scene: &[(String, Vec<Cell>)],
    totals: &[Cell],
    combos: &[(f32, f32)],
) {
    let names: Vec<&str> = per_scene.iter().map(|(n, _)| n.as_str()).collect();
    let _ = writeln!(
        r.md,
        "\nKept ÷ seen triangles per drawn frame by radius and turn (a larger region is \
         culled less often and holds more; the point answer's row for scale):\n\n\
         | radius m | turn ° | {} |\n|---:|---:|{}",
        names.join(" | "),
        "---:|".repeat(names.len())
    );
    for (k, (radius, turn)) in combos.iter().enumerate() {
        let row: Vec<String> = per_scene
            .iter()
            .map(|(_, cells)| format!("{:.2}", cells[k].per_frame()))
            .collect();
        let _ = writeln!(r.md, "| {radius} | {turn} | {} |", row.join(" | "));
    }
    let point: Vec<String> = totals.iter().map(|t| format!("{:.2}", t.point())).collect();
    let _ = writeln!(r.md, "| point | – | {} |", point.join(" | "));
}

/// The plot: per turn, the geometric mean over scenes of kept ÷ seen per drawn frame
/// against radius.
fn sweep_plot(
    r: &mut Report,
    per_scene: &[(String, Vec<Cell>)],
    combos: &[(f32, f32)],
) -> Result<()> {
    if per_scene.is_empty() {
        return Ok(());
    }
    let mut turns: Vec<f32> = combos.iter().map(|c| c.1).collect();
    turns.sort_by(f32::total_cmp);
    turns.dedup();
    let series: Vec<Series> = turns
        .iter()
        .map(|&turn| Series {
            label: format!("turn {turn}°"),
            points: combos
                .iter()
                .enumerate()
                .filter(|(_, c)| c.1 == turn)
                .map(|(k, c)| {
                    let logs: f64 = per_scene
                        .iter()
                        .map(|(_, cells)| cells[k].per_frame().max(1e-9).ln())
                        .sum();
                    (f64::from(c.0), (logs / per_scene.len() as f64).exp())
                })
                .collect(),
        })
        .collect();
    r.plot(
        "region_kept.png",
        &Chart {
            title: "Region answers: kept ÷ seen triangles per drawn frame",
            x_label: "region radius (m)",
            y_label: "kept ÷ seen per frame (geometric mean over scenes)",
            log_x: true,
            log_y: true,
        },
        &series,
    )
}
