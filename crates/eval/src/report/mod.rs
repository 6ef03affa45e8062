//! `homcull report`: quality and speed of every method on every scene, in one run,
//! written as `DIR/report.md` plus PNG plots.
//!
//! Sections, each measured side by side on the same adapter in the same run:
//! 1. quality per scene and method against the exact oracle (threshold 1.0), and where
//!    HOM's efficiency is lost (in [`losses`]); beside a GPU adapter, the native CPU
//!    backend on the same poses (in [`backends`]);
//! 2. the HOM threshold curve (1.0 … 0.8) with the pixel error each threshold allows;
//! 3. the occluder budget sweep (demo city, munich);
//! 4. time per pose against viewport size and batch size, with log-log slopes;
//! 5. time per pose against object count (sized demo cities);
//! 6. the server under 1…N WebSocket clients, batching on and off (in [`server`]);
//! 7. visibility from a region: false culls at eyes sampled in each region, and kept
//!    triangles per drawn frame against radius and turn (in [`regions`]).
//!
//! And, after section 3, section 3b: moving objects, efficiency against the motion
//! horizon (in [`motion`]).
//!
//! The report names the adapter and the CPU and says whether the adapter is a CPU
//! (lavapipe/llvmpipe, wgpu `DeviceType::Cpu`, or homcull's own CPU fallback), in
//! which case every time in it is CPU time. `report.md` is rewritten after each
//! section, so an interrupted run leaves what it measured.

mod backends;
mod budget;
mod context;
mod losses;
mod motion;
mod passes;
pub mod plot;
mod quality;
mod regions;
mod scaling;
mod scenes;
mod server;
mod targets;
mod thresholds;

pub use context::{QUALITY_METHODS, SEED, THRESHOLDS};
pub use thresholds::allowed_pixels;

use std::fmt::Write as _;
use std::path::PathBuf;
use std::time::Instant;

use anyhow::{Context, Result};

use context::{Plan, Report, adapter_kind, cpu_name};
use homcull_engine::engine::Backend;

/// A section that needs no shared scenes.
type SectionFn = fn(&mut Report) -> Result<()>;

/// A section of the report.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Section {
    /// Quality against the oracle, losses, GPU time per pass, the threshold curve.
    Quality,
    Budget,
    Viewport,
    Batch,
    Objects,
    Server,
    /// Efficiency with moving objects against the horizon.
    Motion,
    /// Region answers against the oracle at eyes of the region.
    Regions,
}

/// What a report run measures and where it writes.
#[derive(Debug, Clone)]
pub struct ReportOptions {
    /// Where report.md and the plots go (created if missing).
    pub out: PathBuf,
    /// A small, fast version: a smoke test.
    pub quick: bool,
    /// The scenes to report on: every .glb in it, plus the demo city.
    pub scenes_dir: PathBuf,
    /// The sections to run; empty: all.
    pub sections: Vec<Section>,
}

/// Runs the whole report on `backend`.
pub fn run(a: &ReportOptions, backend: Backend) -> Result<()> {
    std::fs::create_dir_all(&a.out).with_context(|| format!("creating {}", a.out.display()))?;
    let (adapter, is_cpu) = adapter_kind(&backend);
    let cpu = cpu_name();
    eprintln!("[report] adapter: {adapter}; CPU: {cpu}");
    let plan = Plan::new(a.quick);
    let mut r = Report {
        out: a.out.clone(),
        plan,
        backend,
        md: String::new(),
        started: Instant::now(),
        targets: Vec::new(),
    };
    let mut flags = String::from(if a.quick { " --quick" } else { "" });
    if !a.sections.is_empty() {
        let names: Vec<String> = a
            .sections
            .iter()
            .map(|s| format!("{s:?}").to_lowercase())
            .collect();
        flags += &format!(" --sections {}", names.join(","));
    }
    let _ = writeln!(
        r.md,
        "# homcull report{}\n\n\
         - adapter: **{adapter}** — {}\n- CPU: {cpu}\n- command: `homcull report{} --out {}`\n\
         - poses: random street-level poses from `PoseSampler`, seed {SEED}\n",
        if a.quick { " (quick)" } else { "" },
        if is_cpu {
            "**a CPU rasterizer (e.g. lavapipe): every time below is CPU time, not GPU time**"
        } else {
            "a real GPU"
        },
        flags,
        a.out.display()
    );
    let run = |s: Section| a.sections.is_empty() || a.sections.contains(&s);
    let on_scenes = [
        Section::Quality,
        Section::Budget,
        Section::Motion,
        Section::Regions,
    ];
    let scenes = if on_scenes.into_iter().any(run) {
        scenes::load_scenes(&a.scenes_dir)?
    } else {
        Vec::new()
    };
    if !scenes.is_empty() {
        r.save()?;
        if run(Section::Quality) {
            let evals = quality::section(&mut r, &scenes)?;
            r.save()?;
            backends::section(&mut r, &scenes, &evals)?;
            r.save()?;
            losses::section(&mut r, &scenes)?;
            r.save()?;
            passes::section(&mut r, &scenes)?;
            r.save()?;
            thresholds::section(&mut r, &evals)?;
            r.save()?;
        }
        if run(Section::Budget) {
            budget::section(&mut r, &scenes)?;
            r.save()?;
        }
        if run(Section::Motion) {
            motion::section(&mut r, &scenes)?;
            r.save()?;
        }
    }
    let scaling: [(Section, SectionFn); 4] = [
        (Section::Viewport, scaling::viewport),
        (Section::Batch, scaling::batch),
        (Section::Objects, scaling::objects),
        (Section::Server, server::section),
    ];
    for (section, f) in scaling {
        if run(section) {
            f(&mut r)?;
            r.save()?;
        }
    }
    if run(Section::Regions) {
        regions::section(&mut r, &scenes)?;
        r.save()?;
    }
    targets::section(&mut r.md, &r.targets, &adapter);
    let secs = r.started.elapsed().as_secs_f64();
    let _ = writeln!(r.md, "\n---\nReport generated in {secs:.0} s.");
    r.save()?;
    eprintln!(
        "[report] done in {secs:.0} s: {}",
        r.out.join("report.md").display()
    );
    Ok(())
}
