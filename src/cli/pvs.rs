//! `homcull pvs`: a view-cell PVS of one scene, written as JSON (docs/pvs.md).
//!
//! Cells and boxes come from `core::viewcells`; each box is answered once as a box
//! region of every direction, on every core, with a progress line on stderr.

use std::io::Write;
use std::sync::Mutex;
use std::time::{Duration, Instant};

use anyhow::{Context, Result, bail, ensure};
use homcull_proto::Method;
use serde_json::json;

use super::args::{CellsBy, PvsArgs};
use super::load_scene;
use crate::core::camera::region::MAX_BOX_DIAGONAL_M;
use crate::core::cull::{CullSettings, PreparedScene};
use crate::core::resident::{accepts_eye, parse_pvs};
use crate::core::sampler::{MIN_FAR, PoseSampler};
use crate::core::viewcells::{self, ViewCells};

/// The file format's name and version, first in every file.
pub const FORMAT: &str = "homcull-pvs";
pub const FORMAT_VERSION: u32 = 1;

/// How often the progress line is printed.
const PROGRESS_EVERY: Duration = Duration::from_secs(5);

pub fn run(a: PvsArgs) -> Result<()> {
    let most = MAX_BOX_DIAGONAL_M / 3f32.sqrt();
    ensure!(
        a.cell_m.is_finite() && a.cell_m > 0.0 && a.cell_m <= most,
        "--cell-m must be in (0, {most:.2}] metres (a box's diagonal at most {MAX_BOX_DIAGONAL_M} m), got {}",
        a.cell_m
    );
    ensure!(
        a.method != Method::Exact,
        "--method exact answers no region: give hom, hzb or frustum"
    );
    ensure!(
        a.clusters.is_none() || a.cells == CellsBy::Clusters,
        "--clusters needs --cells clusters"
    );
    if a.threads > 0 {
        rayon::ThreadPoolBuilder::new()
            .num_threads(a.threads)
            .build_global()
            .context("starting the CPU thread pool")?;
    }
    let options = a.params.options(a.method, None)?;
    options.validate()?;
    let scene = load_scene(&a.scene)?;
    let pvs = parse_pvs(&scene);
    let bounds = scene.bounds;
    let far = (2.0 * bounds.diagonal()).max(MIN_FAR);
    let cells = match a.cells {
        CellsBy::Grid => {
            let sampler = PoseSampler::new(&scene);
            let accept = |p| accepts_eye(pvs.as_ref(), p);
            viewcells::grid_cells(&sampler, &bounds, a.cell_m, &accept)
        }
        CellsBy::Clusters => {
            let Some(pvs) = &pvs else {
                bail!(
                    "{} carries no PVS of its own: `--cells clusters` needs a map that ships one (use --cells grid)",
                    scene.name
                );
            };
            viewcells::cluster_cells(pvs, &bounds, a.cell_m, a.clusters.as_deref())
        }
    };
    ensure!(
        !cells.cells.is_empty(),
        "no cell found: no standing eye on a grid of {} m (or no such cluster)",
        a.cell_m
    );
    let name = scene.name.clone();
    let objects = scene.objects.len();
    let prep = PreparedScene::new(scene, a.params.occluder_params());
    let settings = CullSettings::new(options, &prep);
    eprintln!(
        "pvs: {} cells covered by {} boxes of {} m, {} objects",
        cells.cells.len(),
        cells.boxes.len(),
        a.cell_m,
        objects
    );
    let answers = answer(&prep, &cells, a.viewport, a.fov_y_deg, far, &settings)?;
    let doc = json!({
        "format": FORMAT,
        "version": FORMAT_VERSION,
        "scene": name,
        "objects": objects,
        "cells_by": match a.cells { CellsBy::Grid => "grid", CellsBy::Clusters => "clusters" },
        "cell_m": a.cell_m,
        "method": a.method.name(),
        "viewport": a.viewport,
        "fov_y_deg": a.fov_y_deg,
        "boxes": cells.boxes.iter().map(|b| [b.min.to_array(), b.max.to_array()]).collect::<Vec<_>>(),
        "cells": cells.cells.iter().map(|c| {
            let set = viewcells::cell_set(c, &answers);
            let mut cell = json!({
                "name": c.name,
                "boxes": c.boxes,
                "count": set.len(),
                "visible": viewcells::ranges(&set),
            });
            if let Some(k) = c.cluster {
                cell["cluster"] = json!(k);
            }
            cell
        }).collect::<Vec<_>>(),
    });
    write_atomically(&a.out, &serde_json::to_vec(&doc)?)?;
    eprintln!("pvs: wrote {}", a.out.display());
    Ok(())
}

/// Every box's answer, with a progress line every [`PROGRESS_EVERY`].
fn answer(
    prep: &PreparedScene,
    cells: &ViewCells,
    viewport: [u32; 2],
    fov_y_deg: f32,
    far: f32,
    settings: &CullSettings,
) -> Result<Vec<Vec<u32>>> {
    let total = cells.boxes.len();
    let started = Instant::now();
    let last = Mutex::new(started);
    let progress = |done: usize| {
        let Ok(mut last) = last.lock() else { return };
        if done < total && last.elapsed() < PROGRESS_EVERY {
            return;
        }
        *last = Instant::now();
        let spent = started.elapsed().as_secs_f64();
        let left = spent / done as f64 * (total - done) as f64;
        eprintln!(
            "pvs: {done}/{total} boxes ({:.0} %), {spent:.0} s, about {left:.0} s left",
            100.0 * done as f64 / total as f64
        );
    };
    let answers = viewcells::answer_boxes(
        prep,
        &cells.boxes,
        viewport,
        fov_y_deg,
        far,
        settings,
        &progress,
    )
    .map_err(anyhow::Error::msg)?;
    Ok(answers)
}

/// Writes `bytes` to `path` through a temporary file beside it, so that an
/// interrupted run leaves the old file (or none), never half a new one.
fn write_atomically(path: &std::path::Path, bytes: &[u8]) -> Result<()> {
    let tmp = path.with_extension("tmp");
    let mut f =
        std::fs::File::create(&tmp).with_context(|| format!("creating {}", tmp.display()))?;
    f.write_all(bytes)
        .and_then(|()| f.sync_all())
        .with_context(|| format!("writing {}", tmp.display()))?;
    std::fs::rename(&tmp, path).with_context(|| format!("renaming to {}", path.display()))?;
    Ok(())
}
