//! The state of one report run and the helpers every section shares: the plan of
//! sizes (full or `--quick`), the markdown being written, plots, progress lines, and
//! the method specs the sections run.

use std::fmt::Write as _;
use std::path::PathBuf;
use std::time::Instant;

use anyhow::{Context, Result};
use homcull_proto::{CullOptions, DebVariant, Method};

use super::plot::{Chart, Series, line_chart};
use super::targets;
use crate::{MethodReport, MethodSpec};
use homcull_engine::engine::{Backend, Engine};
use homcull_engine::occluders::OccluderParams;
use homcull_engine::resident::{Residency, ResidentScene};
use homcull_engine::scene::Scene;

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

/// The city and game-map scenes whose efficiency the quality targets name.
pub(super) const TARGET_SCENES: [&str; 4] = ["munich", "etoile", "oa_shouse", "oa_dm1"];

/// Sizes of one run: full or `--quick`.
#[derive(Debug, Clone)]
pub(super) struct Plan {
    pub(super) poses: usize,
    pub(super) viewport: [u32; 2],
    pub(super) batch: usize,
    pub(super) budgets: Vec<u32>,
    pub(super) budget_poses: usize,
    pub(super) viewports: Vec<[u32; 2]>,
    pub(super) viewport_poses: usize,
    pub(super) batches: Vec<usize>,
    /// Blocks per side of the sized demo cities (about 29 objects per block).
    pub(super) city_blocks: Vec<usize>,
    pub(super) city_poses: usize,
    pub(super) clients: Vec<usize>,
    pub(super) load_seconds: f64,
    /// Regions (section 7): the radii (m) and turns (°) swept, the poses of each pair
    /// on every scene, and the eyes each answer is checked at.
    pub(super) region_radii: Vec<f32>,
    pub(super) region_turns: Vec<f32>,
    pub(super) region_poses: usize,
    pub(super) region_eyes: usize,
}

impl Plan {
    pub(super) fn new(quick: bool) -> Self {
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
                region_radii: vec![0.1, 0.5, 2.0],
                region_turns: vec![0.0, 30.0],
                region_poses: 1,
                region_eyes: 16,
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
                region_radii: vec![0.1, 0.25, 0.5, 1.0, 2.0],
                region_turns: vec![0.0, 10.0, 30.0],
                region_poses: 7,
                region_eyes: 64,
            }
        }
    }
}

/// State of one report run.
pub(super) struct Report {
    pub(super) out: PathBuf,
    pub(super) plan: Plan,
    pub(super) backend: Backend,
    pub(super) md: String,
    pub(super) started: Instant,
    /// The issues' targets the sections measured, for the closing table.
    pub(super) targets: Vec<targets::Target>,
}

impl Report {
    /// An engine over `scene` with an occluder budget of `budget` triangles.
    pub(super) fn engine(&self, scene: Scene, budget: u32) -> Engine {
        self.engine_on(scene, budget, self.backend.clone())
    }

    /// [`Report::engine`] on another backend (the native CPU one beside a GPU).
    pub(super) fn engine_on(&self, scene: Scene, budget: u32, backend: Backend) -> Engine {
        ResidentScene::assemble(scene, residency(budget), backend).engine
    }

    /// [`Report::engine`] whose occluders are `ids` (a subset of what it would choose).
    pub(super) fn engine_occluding(&self, scene: Scene, budget: u32, ids: Vec<u32>) -> Engine {
        let mut how = residency(budget);
        how.cached_occluders = Some(ids);
        ResidentScene::assemble(scene, how, self.backend.clone()).engine
    }

    pub(super) fn save(&self) -> Result<()> {
        let path = self.out.join("report.md");
        std::fs::write(&path, &self.md).with_context(|| format!("writing {}", path.display()))
    }

    /// Draws a chart into `DIR/file` and links it from the report with its ranges.
    pub(super) fn plot(&mut self, file: &str, chart: &Chart, series: &[Series]) -> Result<()> {
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

pub(super) fn progress(section: &str, i: usize, n: usize, what: &str) {
    eprintln!("[report] {section} {}/{n}: {what}", i + 1);
}

/// The CPU's model name from `/proc/cpuinfo`, and the logical cores.
pub(super) fn cpu_name() -> String {
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
pub(super) fn adapter_kind(backend: &Backend) -> (String, bool) {
    match backend.gpu() {
        Some(g) => (g.describe(), g.info.device_type == wgpu::DeviceType::Cpu),
        None => (backend.describe(), true),
    }
}

pub(super) fn spec(name: &str, threshold: f32) -> MethodSpec {
    MethodSpec {
        name: name.to_string(),
        options: CullOptions {
            method: Method::Hom,
            threshold,
            deb: DebVariant::Raster,
            refine: false,
            lod: None,
        },
    }
}

/// Name of the HOM (raster DEB) run at threshold `t`; 1.0 is the quality table's.
pub(super) fn threshold_name(t: f32) -> String {
    if t == 1.0 {
        "hom-raster".into()
    } else {
        format!("hom@{t}")
    }
}

/// kept ÷ oracle triangles.
pub(super) fn over(m: &MethodReport) -> f64 {
    if m.oracle_triangles > 0 {
        m.kept_triangles as f64 / m.oracle_triangles as f64
    } else {
        1.0
    }
}

/// How the report's engines hold a scene: for evaluation, `budget` occluder triangles.
fn residency(budget: u32) -> Residency {
    Residency::evaluation(OccluderParams {
        budget_triangles: budget,
        ..Default::default()
    })
}
