//! `homcull report`: quality and speed of every method on every scene, in one run,
//! written as `DIR/report.md` plus PNG plots (issue 6).
//!
//! Sections, each measured side by side on the same adapter in the same run:
//! 1. quality per scene and method against the exact oracle (threshold 1.0), and where
//!    HOM's efficiency is lost (in [`losses`]);
//! 2. the HOM threshold curve (1.0 … 0.8) with the pixel error each threshold allows;
//! 3. the occluder budget sweep (demo city, munich);
//! 4. time per pose against viewport size and batch size, with log-log slopes;
//! 5. time per pose against object count (sized demo cities);
//! 6. the server under 1…N WebSocket clients, batching on and off (in [`server`]).
//!
//! The report names the adapter and the CPU and says whether the adapter is a CPU
//! (lavapipe/llvmpipe, wgpu `DeviceType::Cpu`, or homcull's own CPU fallback), in
//! which case every time in it is CPU time. `report.md` is rewritten after each
//! section, so an interrupted run leaves what it measured.

mod losses;
mod passes;
pub mod plot;
mod scaling;
mod server;
mod targets;

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use std::time::Instant;

use anyhow::{Context, Result};
use homcull_proto::{CullOptions, DebVariant, Method};

use crate::core::camera::Camera;
use crate::core::engine::Backend;
use crate::core::engine::Engine;
use crate::core::occluders::OccluderParams;
use crate::core::pvs::Pvs;
use crate::core::sampler::PoseSampler;
use crate::core::scene::{Scene, demo_city, load_path};
use crate::eval::pvs_audit::audit_pixels;
use crate::eval::{EvalReport, MethodReport, MethodSpec, evaluate};
use plot::{Chart, Series, line_chart};

/// Seed of every pose sample in the report.
pub const SEED: u64 = 7;
/// Thresholds of the HOM curve (section 2).
pub const THRESHOLDS: [f32; 5] = [1.0, 0.99, 0.95, 0.9, 0.8];
/// The methods of the quality table, as reported (`exact` is added by `evaluate`).
pub const QUALITY_METHODS: [&str; 6] = [
    "hom-refine",
    "hom-raster",
    "hom-tiles",
    "hom-plane",
    "hzb",
    "frustum",
];

/// A section that needs no shared scenes.
type SectionFn = fn(&mut Report) -> Result<()>;

/// Sizes of one run: full or `--quick`.
#[derive(Debug, Clone)]
struct Plan {
    poses: usize,
    viewport: [u32; 2],
    batch: usize,
    budgets: Vec<u32>,
    budget_poses: usize,
    viewports: Vec<[u32; 2]>,
    viewport_poses: usize,
    batches: Vec<usize>,
    /// Blocks per side of the sized demo cities (about 29 objects per block).
    city_blocks: Vec<usize>,
    city_poses: usize,
    clients: Vec<usize>,
    load_seconds: f64,
}

impl Plan {
    fn new(quick: bool) -> Self {
        if quick {
            Plan {
                poses: 16,
                viewport: [480, 270],
                batch: 16,
                budgets: vec![1_000, 20_000, 100_000],
                budget_poses: 8,
                viewports: vec![[480, 270], [960, 540]],
                viewport_poses: 8,
                batches: vec![1, 16, 64],
                city_blocks: vec![6, 19],
                city_poses: 8,
                clients: vec![1, 4],
                load_seconds: 1.0,
            }
        } else {
            Plan {
                poses: 200,
                viewport: [960, 540],
                batch: 64,
                budgets: vec![1_000, 5_000, 20_000, 50_000, 100_000, 200_000],
                budget_poses: 64,
                viewports: vec![[640, 360], [960, 540], [1920, 1080], [3840, 2160]],
                viewport_poses: 32,
                batches: vec![1, 4, 16, 64, 256, 1024],
                city_blocks: vec![6, 19, 59, 186],
                city_poses: 32,
                clients: vec![1, 10, 32, 50, 100, 250, 500],
                load_seconds: 4.0,
            }
        }
    }
}

/// One scene of the report with its PVS (OpenArena maps) when it has one.
struct Loaded {
    scene: Scene,
    pvs: Option<Pvs>,
}

impl Loaded {
    fn new(scene: Scene) -> Self {
        let pvs = match Pvs::from_scene(&scene) {
            Some(Ok(p)) => Some(p),
            Some(Err(e)) => {
                eprintln!("warning: {}: unusable PVS data: {e}", scene.name);
                None
            }
            None => None,
        };
        Loaded { scene, pvs }
    }

    /// `n` random street-level poses (eyes inside a PVS cluster where there is a PVS).
    fn cams(&self, n: usize, viewport: [u32; 2]) -> Result<Vec<Camera>> {
        let sampler = PoseSampler::new(&self.scene);
        let accept = |p: glam::Vec3| self.pvs.as_ref().is_none_or(|v| v.cluster_at(p) >= 0);
        let res = sampler.sample(n, SEED, viewport, &accept);
        if res.poses.len() < n {
            eprintln!(
                "warning: {}: only {} of {n} poses found",
                self.scene.name,
                res.poses.len()
            );
        }
        res.poses
            .iter()
            .map(|p| Camera::new(p).map_err(anyhow::Error::from))
            .collect()
    }
}

/// State of one report run.
struct Report {
    out: PathBuf,
    plan: Plan,
    backend: Backend,
    md: String,
    started: Instant,
    /// The issues' targets the sections measured, for the closing table.
    targets: Vec<targets::Target>,
}

impl Report {
    fn engine(&self, scene: Scene, budget: u32) -> Engine {
        let params = OccluderParams {
            budget_triangles: budget,
            ..Default::default()
        };
        Engine::new(scene, params, self.backend.clone())
    }

    fn save(&self) -> Result<()> {
        let path = self.out.join("report.md");
        std::fs::write(&path, &self.md).with_context(|| format!("writing {}", path.display()))
    }

    /// Draws a chart into `DIR/file` and links it from the report with its ranges.
    fn plot(&mut self, file: &str, chart: &Chart, series: &[Series]) -> Result<()> {
        line_chart(&self.out.join(file), chart, series)?;
        let _ = writeln!(
            self.md,
            "\n![{}]({file})\n\n*{}: {} against {}{}.*\n",
            chart.title,
            file,
            chart.y_label,
            chart.x_label,
            match (chart.log_x, chart.log_y) {
                (true, true) => ", log-log axes",
                (true, false) => ", log x axis",
                (false, true) => ", log y axis",
                _ => "",
            }
        );
        Ok(())
    }
}

fn progress(section: &str, i: usize, n: usize, what: &str) {
    eprintln!("[report] {section} {}/{n}: {what}", i + 1);
}

/// The CPU's model name from `/proc/cpuinfo`, and the logical cores.
fn cpu_name() -> String {
    let model = std::fs::read_to_string("/proc/cpuinfo")
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("model name"))
                .and_then(|l| l.split_once(':'))
                .map(|(_, v)| v.trim().to_string())
        })
        .unwrap_or_else(|| "unknown CPU".into());
    let cores = std::thread::available_parallelism().map_or(0, |n| n.get());
    format!("{model}, {cores} logical cores")
}

/// The adapter in words and whether it is a CPU.
fn adapter_kind(backend: &Backend) -> (String, bool) {
    match backend.gpu() {
        Some(g) => (g.describe(), g.info.device_type == wgpu::DeviceType::Cpu),
        None => ("CPU reference implementation (no GPU adapter)".into(), true),
    }
}

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
    if run(Section::Quality) || run(Section::Budget) {
        let scenes = load_scenes(&a.scenes_dir)?;
        r.save()?;
        if run(Section::Quality) {
            let evals = quality(&mut r, &scenes)?;
            r.save()?;
            losses::section(&mut r, &scenes)?;
            r.save()?;
            passes::section(&mut r, &scenes)?;
            r.save()?;
            thresholds(&mut r, &evals)?;
            r.save()?;
        }
        if run(Section::Budget) {
            budget(&mut r, &scenes)?;
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

/// The demo city and every `.glb` of `dir` (sorted by name).
fn load_scenes(dir: &Path) -> Result<Vec<Loaded>> {
    let mut files: Vec<PathBuf> = match std::fs::read_dir(dir) {
        Ok(rd) => rd
            .filter_map(|e| e.ok().map(|e| e.path()))
            .filter(|p| p.extension().is_some_and(|e| e.eq_ignore_ascii_case("glb")))
            .collect(),
        Err(e) => {
            eprintln!(
                "warning: scenes dir {}: {e}; only the demo city is reported",
                dir.display()
            );
            Vec::new()
        }
    };
    files.sort();
    let n = files.len() + 1;
    progress("loading scenes", 0, n, "demo city");
    let mut scenes = vec![Loaded::new(demo_city())];
    for (i, f) in files.iter().enumerate() {
        progress("loading scenes", i + 1, n, &f.display().to_string());
        let scene = load_path(f).with_context(|| format!("loading {}", f.display()))?;
        scenes.push(Loaded::new(scene));
    }
    Ok(scenes)
}

fn spec(name: &str, threshold: f32) -> MethodSpec {
    MethodSpec {
        name: name.to_string(),
        options: CullOptions {
            method: Method::Hom,
            threshold,
            deb: DebVariant::Raster,
            refine: false,
        },
    }
}

/// Name of the HOM (raster DEB) run at threshold `t`; 1.0 is the quality table's.
fn threshold_name(t: f32) -> String {
    if t == 1.0 {
        "hom-raster".into()
    } else {
        format!("hom@{t}")
    }
}

/// kept ÷ oracle triangles.
pub(crate) fn over(m: &MethodReport) -> f64 {
    if m.oracle_triangles > 0 {
        m.kept_triangles as f64 / m.oracle_triangles as f64
    } else {
        1.0
    }
}

/// Section 1 (and the runs of section 2): every method and threshold on every scene.
fn quality(r: &mut Report, scenes: &[Loaded]) -> Result<Vec<EvalReport>> {
    let p = r.plan.clone();
    let mut methods = QUALITY_METHODS
        .iter()
        .map(|m| MethodSpec::parse(m, 1.0, DebVariant::Raster, true).map_err(anyhow::Error::msg))
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

/// Issue 3's quality and speed targets from section 1.
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
    let shared = ["munich", "etoile", "oa_shouse", "oa_dm1"];
    let worst = evals
        .iter()
        .filter(|e| shared.contains(&e.scene.as_str()))
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

/// Uncovered level-0 pixels a texel at level `k` may hold and still pass at `O_0 = t`:
/// `(1 − O_k)·4^k`, with `O_k` from [`crate::core::hom::level_thresholds`].
pub fn allowed_pixels(t: f32, k: usize) -> f64 {
    let o = crate::core::hom::level_thresholds(t, k + 1)[k] as f64;
    (1.0 - o) * 4f64.powi(k as i32)
}

/// Section 2: efficiency and false culls of HOM over thresholds, per scene.
fn thresholds(r: &mut Report, evals: &[EvalReport]) -> Result<()> {
    let bounds: Vec<String> = THRESHOLDS
        .iter()
        .map(|&t| {
            let worst = (0..8).map(|k| allowed_pixels(t, k)).fold(0.0, f64::max);
            format!("O_0 = {t}: ≤ {worst:.3} px")
        })
        .collect();
    let _ = writeln!(
        r.md,
        "\n## 2. HOM threshold curve (approximate culling)\n\n\
         HOM with the raster DEB at opacity thresholds {:?}, same poses as section 1. \
         The seed's per-level thresholds are O_k = (3 + O_(k−1)) / 4 \
         (`hom::level_thresholds`), so 1 − O_k = (1 − O_0) / 4^k: a texel at level k \
         covers 4^k pixels and passes with at most (1 − O_k)·4^k = 1 − O_0 of them \
         uncovered, at every level. Bound per texel (largest over levels 0–7, computed \
         in f32 as the passes do): {}. Level-0 opacity is binary (a pixel is covered or \
         not), so a bound below one pixel means **no uncovered pixel is ever accepted**: \
         with this formula thresholds below 1 can only differ from 1.0 by rounding. \
         Over an object's whole screen rect the error is at most (1 − O_0) pixels per \
         texel tested.\n\n\
         | scene | threshold | px per texel allowed | efficiency | false culls | ms/pose p50 |\n\
         |---|---:|---:|---:|---:|---:|",
        THRESHOLDS,
        bounds.join("; ")
    );
    let mut series = Vec::new();
    for e in evals {
        let mut pts = Vec::new();
        for &t in &THRESHOLDS {
            let m = &e.methods[&threshold_name(t)];
            let _ = writeln!(
                r.md,
                "| {} | {t} | {:.3} | {:.3} | {} | {:.2} |",
                e.scene,
                1.0 - t,
                m.efficiency,
                m.false_culls,
                m.ms_per_pose.p50
            );
            pts.push((t as f64, m.efficiency));
        }
        series.push(Series {
            label: e.scene.clone(),
            points: pts,
        });
    }
    r.plot(
        "threshold.png",
        &Chart {
            title: "HOM efficiency vs opacity threshold",
            x_label: "threshold O_0",
            y_label: "efficiency",
            log_x: false,
            log_y: false,
        },
        &series,
    )
}

/// Section 3: HOM efficiency and time per pose against the occluder budget.
fn budget(r: &mut Report, scenes: &[Loaded]) -> Result<()> {
    let p = r.plan.clone();
    let picked: Vec<&Loaded> = scenes
        .iter()
        .filter(|l| l.scene.name == "demo" || l.scene.name == "munich")
        .collect();
    let _ = writeln!(
        r.md,
        "\n## 3. Occluder budget\n\n\
         HOM's box test alone (raster DEB, threshold 1.0) with occluder budgets {:?} triangles per pose, {} \
         poses at {}×{}, batch {}.\n\n\
         | scene | budget | efficiency | false culls | kept/oracle | ms/pose p50 | exact ms/pose p50 |\n\
         |---|---:|---:|---:|---:|---:|---:|",
        p.budgets, p.budget_poses, p.viewport[0], p.viewport[1], p.batch
    );
    let hom = [spec("hom-raster", 1.0)];
    let (mut eff, mut ms) = (Vec::new(), Vec::new());
    let n = picked.len() * p.budgets.len();
    for (si, l) in picked.iter().enumerate() {
        let cams = l.cams(p.budget_poses, p.viewport)?;
        let (mut e_pts, mut m_pts) = (Vec::new(), Vec::new());
        for (bi, &b) in p.budgets.iter().enumerate() {
            progress(
                "budget",
                si * p.budgets.len() + bi,
                n,
                &format!("{} budget {b}", l.scene.name),
            );
            let mut engine = r.engine(l.scene.clone(), b);
            let e = evaluate(&mut engine, &cams, &hom, p.batch, None, false)?;
            let m = &e.methods["hom-raster"];
            let _ = writeln!(
                r.md,
                "| {} | {b} | {:.3} | {} | {:.2} | {:.2} | {:.2} |",
                e.scene,
                m.efficiency,
                m.false_culls,
                over(m),
                m.ms_per_pose.p50,
                e.methods["exact"].ms_per_pose.p50
            );
            e_pts.push((b as f64, m.efficiency));
            m_pts.push((b as f64, m.ms_per_pose.p50));
        }
        let label = l.scene.name.clone();
        eff.push(Series {
            label: label.clone(),
            points: e_pts,
        });
        ms.push(Series {
            label,
            points: m_pts,
        });
    }
    if picked.is_empty() {
        return Ok(());
    }
    r.plot(
        "budget_efficiency.png",
        &Chart {
            title: "HOM efficiency vs occluder budget",
            x_label: "budget (triangles per pose)",
            y_label: "efficiency",
            log_x: true,
            log_y: false,
        },
        &eff,
    )?;
    r.plot(
        "budget_time.png",
        &Chart {
            title: "HOM time per pose vs occluder budget",
            x_label: "budget (triangles per pose)",
            y_label: "ms per pose (p50)",
            log_x: true,
            log_y: false,
        },
        &ms,
    )
}
