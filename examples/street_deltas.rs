//! Delta ÷ full frame bytes along the whole street of the demo city at walking speed
//! (1.4 m/s, 60 frames/s: 13,043 poses over 300 m), without and with the stream
//! smoothing of `server/motion.rs` (the viewer's default: 150 ms lookahead, 300 ms hold),
//! each without and with the viewer's levels of detail (`lod_px=256,64,16`).
//!
//! Run: `cargo run --release --example street_deltas [-- WIDTHxHEIGHT]` (default
//! 480x270). The culls run on the engine directly in batches; time is the walk's own
//! 60 Hz clock, so the lookahead pose is the pose 150 ms further along the street and
//! the hold counts frames of that clock, as a client walking at that pace would see.

use std::sync::Arc;
use std::time::{Duration, Instant};

use homcull::core::camera::Camera;
use homcull::core::cull::union;
use homcull::core::engine::Engine;
use homcull::core::lod;
use homcull::core::occluders::OccluderParams;
use homcull::eval::loadgen::street_pose;
use homcull::server::motion::HeldSet;
use homcull_proto::frame::{Frame, VisibleDelta, VisibleFull, diff, diff_levels};
use homcull_proto::{CullOptions, LodThresholds};

const FPS: f32 = 60.0;
const SPEED: f32 = 1.4;
const LOOKAHEAD_MS: f32 = 150.0;
const HOLD_MS: u64 = 300;

fn main() -> anyhow::Result<()> {
    let viewport = match std::env::args().nth(1) {
        Some(a) => {
            let (w, h) = a
                .split_once('x')
                .ok_or_else(|| anyhow::anyhow!("WIDTHxHEIGHT"))?;
            [w.parse()?, h.parse()?]
        }
        None => [480, 270],
    };
    let gpu = homcull::core::gpu::open_gpu()?.map(Arc::new);
    let mut engine = Engine::new(
        homcull::core::scene::demo_city(),
        OccluderParams::default(),
        gpu,
    );
    eprintln!("adapter: {}", engine.adapter());
    // What a stream culls by default: HOM's box test without the per-pixel refinement.
    let settings = engine.settings(CullOptions {
        refine: false,
        ..Default::default()
    });
    let step = SPEED / FPS;
    let ahead = (LOOKAHEAD_MS / 1000.0 * FPS).round() as usize;
    let n = (300.0 / step) as usize;
    // Culls of the walk and of `ahead` poses past its end (for the last lookaheads).
    let cams: Vec<Camera> = (0..n + ahead)
        .map(|i| {
            let x = -150.0 + step * i as f32;
            Camera::new(&street_pose([x, 1.7, 0.0], x + 150.0, viewport)).expect("valid pose")
        })
        .collect();
    let t = Instant::now();
    let mut sets = Vec::with_capacity(cams.len());
    for (k, chunk) in cams.chunks(64).enumerate() {
        sets.extend(
            engine
                .cull(chunk, &settings)?
                .into_iter()
                .map(|r| r.visible),
        );
        if k % 20 == 0 {
            eprintln!("culled {} of {} poses", sets.len(), cams.len());
        }
    }
    eprintln!(
        "{} culls in {:.1} s at {}x{}",
        sets.len(),
        t.elapsed().as_secs_f64(),
        viewport[0],
        viewport[1]
    );

    let start = Instant::now();
    let mut held = HeldSet::new(Duration::from_millis(HOLD_MS));
    let plain: Vec<Vec<u32>> = sets[..n].to_vec();
    let smooth: Vec<Vec<u32>> = (0..n)
        .map(|i| {
            let now = start + Duration::from_secs_f32(i as f32 / FPS);
            held.update(now, union(&sets[i], &sets[i + ahead]))
        })
        .collect();
    let objects = &engine.prepared.scene.objects;
    let viewer_lod = LodThresholds::new(&[256.0, 64.0, 16.0])?;
    for (what, seq) in [("plain", &plain), ("lookahead + hold", &smooth)] {
        for lod in [None, Some(viewer_lod)] {
            // Levels of each streamed set at its own pose, as the server computes them.
            let levels: Option<Vec<Vec<u8>>> = lod.map(|t| {
                seq.iter()
                    .zip(&cams)
                    .map(|(ids, cam)| {
                        let eyes = std::slice::from_ref(cam);
                        lod::levels(eyes, ids, |id| objects[id as usize].aabb, &t)
                    })
                    .collect()
            });
            let level = |k: usize| levels.as_ref().map(|l| l[k].clone());
            let (mut delta, mut full, mut changed) = (0usize, 0usize, 0usize);
            for k in 1..seq.len() {
                let (added, removed) = diff(&seq[k - 1], &seq[k]);
                changed += added.len() + removed.len();
                let lod = levels
                    .as_ref()
                    .map(|l| diff_levels(&seq[k - 1], &l[k - 1], &seq[k], &l[k]));
                delta += Frame::Delta(VisibleDelta {
                    added,
                    removed,
                    lod,
                    ..Default::default()
                })
                .encoded_len();
                full += Frame::Full(VisibleFull {
                    ids: seq[k].clone(),
                    levels: level(k),
                    ..Default::default()
                })
                .encoded_len();
            }
            let frames = (seq.len() - 1) as f64;
            let mean: f64 = seq.iter().map(|s| s.len() as f64).sum::<f64>() / seq.len() as f64;
            let with = if lod.is_some() {
                ", levels 256,64,16 px"
            } else {
                ""
            };
            println!(
                "{what}{with}: delta/full {:.3} ({:.1} B vs {:.1} B per frame, {:.2} IDs \
                 changed per frame, {mean:.1} objects in the set)",
                delta as f64 / full as f64,
                delta as f64 / frames,
                full as f64 / frames,
                changed as f64 / frames
            );
        }
    }
    Ok(())
}
