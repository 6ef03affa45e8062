//! Temporal coherence, measured: occluders that are themselves hidden waste the
//! triangle budget, so a walk can select the objects it saw at its previous pose first
//! (`plan_preferring`). For each scene and budget, short walks (from sampled street-level
//! poses: 10 steps of 0.1 m forward, turning 2° a step) are culled with HOM as served
//! (refined) with plain nearest-first selection and with the previous pose's visible set
//! preferred; every pose after the first is scored against the exact oracle.
//!
//! Run: `cargo run --release --example temporal_occluders [-- SCENES_DIR]` (default
//! `../shared/scenes`; the demo city is always included).

use std::path::PathBuf;
use std::sync::Arc;

use glam::{Quat, Vec3};
use homcull::core::camera::Camera;
use homcull::core::engine::Engine;
use homcull::core::occluders::OccluderParams;
use homcull::core::sampler::PoseSampler;
use homcull::core::scene::Scene;
use homcull_proto::{CullOptions, Method, Pose};

const WALKS: usize = 32;
const STEPS: usize = 10;
const STEP_M: f32 = 0.1;
const TURN_DEG: f32 = 2.0;
const BUDGETS: [u32; 4] = [1_000, 5_000, 20_000, 100_000];

fn main() -> anyhow::Result<()> {
    let dir = PathBuf::from(
        std::env::args()
            .nth(1)
            .unwrap_or_else(|| "../shared/scenes".into()),
    );
    let gpu = homcull::core::gpu::open_gpu()?.map(Arc::new);
    let mut scenes = vec![homcull::core::scene::demo_city()];
    let mut paths: Vec<_> = std::fs::read_dir(&dir)
        .map(|d| d.filter_map(|e| e.ok().map(|e| e.path())).collect())
        .unwrap_or_default();
    paths.retain(|p| p.extension().is_some_and(|x| x == "glb"));
    paths.sort();
    for p in paths {
        scenes.push(homcull::core::scene::load_path(&p)?);
    }
    println!(
        "| scene | budget | efficiency nearest first | efficiency previous-visible first | occluder triangles per pose (nearest / previous) | false culls |"
    );
    println!("|---|---:|---:|---:|---:|---:|");
    for scene in scenes {
        let walks = walks(&scene)?;
        for budget in BUDGETS {
            let params = OccluderParams {
                budget_triangles: budget,
                ..Default::default()
            };
            let mut engine = Engine::new(scene.clone(), params, gpu.clone());
            let row = measure(&mut engine, &walks)?;
            println!(
                "| {} | {budget} | {:.3} | {:.3} | {:.0} / {:.0} | {} |",
                scene.name,
                row.efficiency[0],
                row.efficiency[1],
                row.triangles[0],
                row.triangles[1],
                row.false_culls
            );
        }
    }
    Ok(())
}

/// `WALKS` walks of `STEPS` cameras each.
fn walks(scene: &Scene) -> anyhow::Result<Vec<Vec<Camera>>> {
    let sampler = PoseSampler::new(scene);
    let starts = sampler.sample(WALKS, 7, [960, 540], &|_| true).poses;
    starts
        .iter()
        .map(|p| {
            let q = Quat::from_array(p.rotation.unwrap_or([0.0, 0.0, 0.0, 1.0]));
            let mut fwd = q * Vec3::NEG_Z;
            fwd.y = 0.0;
            let fwd = fwd.normalize_or_zero();
            (0..STEPS)
                .map(|k| {
                    let turn = Quat::from_rotation_y((TURN_DEG * k as f32).to_radians());
                    let pose = Pose {
                        position: (Vec3::from_array(p.position) + fwd * STEP_M * k as f32)
                            .to_array(),
                        rotation: Some((turn * q).to_array()),
                        look_at: None,
                        ..p.clone()
                    };
                    Ok(Camera::new(&pose)?)
                })
                .collect()
        })
        .collect()
}

struct Row {
    /// [nearest first, previous-visible first]
    efficiency: [f64; 2],
    triangles: [f64; 2],
    false_culls: u64,
}

fn measure(engine: &mut Engine, walks: &[Vec<Camera>]) -> anyhow::Result<Row> {
    let hom = engine.settings(CullOptions::default());
    let exact = engine.settings(CullOptions {
        method: Method::Exact,
        ..Default::default()
    });
    let mut row = Row {
        efficiency: [0.0; 2],
        triangles: [0.0; 2],
        false_culls: 0,
    };
    for (mode, prefer_previous) in [false, true].into_iter().enumerate() {
        let (mut hidden, mut culled, mut triangles, mut poses) = (0u64, 0u64, 0u64, 0u64);
        let mut previous: Vec<Vec<u32>> = vec![Vec::new(); walks.len()];
        for step in 0..STEPS {
            // Step `step` of every walk in one batch.
            let cams: Vec<Camera> = walks.iter().map(|w| w[step].clone()).collect();
            let prefer: Vec<&[u32]> = if prefer_previous {
                previous.iter().map(Vec::as_slice).collect()
            } else {
                Vec::new()
            };
            let got = engine.cull_preferring(&cams, &hom, &prefer)?;
            if step > 0 {
                let oracle = engine.cull(&cams, &exact)?;
                for (g, o) in got.iter().zip(&oracle) {
                    let seen: std::collections::HashSet<u32> = o.visible.iter().copied().collect();
                    let kept: std::collections::HashSet<u32> = g.visible.iter().copied().collect();
                    row.false_culls += seen.difference(&kept).count() as u64;
                    hidden += (o.stats.candidates as usize - o.visible.len()) as u64;
                    culled += g.stats.culled_by_occlusion as u64;
                    triangles += g.stats.occluder_triangles as u64;
                    poses += 1;
                }
            }
            previous = got.into_iter().map(|r| r.visible).collect();
        }
        row.efficiency[mode] = culled as f64 / hidden.max(1) as f64;
        row.triangles[mode] = triangles as f64 / poses.max(1) as f64;
    }
    Ok(row)
}
