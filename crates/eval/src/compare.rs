//! Evaluation: every method against the exact oracle on the same poses.
//!
//! Counts are summed over poses: false culls are objects the oracle
//! sees that a method culled; efficiency is the share of the oracle-hidden in-frustum
//! objects a method culls; kept/oracle triangles is the over-draw. Timing is wall time
//! per pose of whole batches (planning + GPU + readback), as p50/p95 over batches.

use std::collections::BTreeMap;
use std::time::Instant;

use homcull_proto::{CullOptions, DebVariant, Method, Surface};
use serde::Serialize;

use crate::percentiles::Percentiles;
use crate::pvs_audit::{PixelAudit, audit_pixels, brush_model_copies};
use homcull_engine::camera::Camera;
use homcull_engine::cull::CullError;
use homcull_engine::cull::PassMsPerPose;
use homcull_engine::engine::Engine;
use homcull_engine::pvs::Pvs;
use homcull_engine::scene::Scene;

/// One method to evaluate, with the name it is reported under.
#[derive(Debug, Clone, PartialEq)]
pub struct MethodSpec {
    pub name: String,
    pub options: CullOptions,
}

impl MethodSpec {
    /// Parses `hom`, `hom-refine`, `hom-plane`, `hom-tiles`, `hom-raster`, `hzb`,
    /// `frustum`, `exact`. `hom-DEB` is the box test alone with that DEB, `hom-refine` the
    /// raster DEB with per-pixel refinement; plain `hom` and the others take `base`'s
    /// threshold, DEB and refinement.
    pub fn parse(s: &str, base: CullOptions) -> Result<Self, String> {
        let (method, deb, refine) = match s.split_once('-') {
            Some(("hom", "refine")) => (Method::Hom, DebVariant::Raster, true),
            Some(("hom", v)) => (Method::Hom, v.parse::<DebVariant>()?, false),
            Some(_) => return Err(format!("unknown method `{s}`")),
            None => (s.parse::<Method>()?, base.deb, base.refine),
        };
        Ok(MethodSpec {
            name: s.to_string(),
            options: CullOptions {
                method,
                deb,
                refine,
                lod: None,
                ..base
            },
        })
    }

    /// [`MethodSpec::parse`] over the command line's defaults
    /// (`CullOptions::defaults(Surface::Cli)`).
    pub fn with_defaults(s: &str) -> Result<Self, String> {
        Self::parse(s, CullOptions::defaults(Surface::Cli))
    }
}

/// Quality and speed of one method, summed over poses.
#[derive(Debug, Clone, Default, Serialize, PartialEq)]
pub struct MethodReport {
    pub false_culls: u64,
    pub in_frustum: u64,
    pub oracle_visible: u64,
    pub oracle_hidden: u64,
    pub culled_hidden: u64,
    pub efficiency: f64,
    pub kept_triangles: u64,
    pub oracle_triangles: u64,
    pub ms_per_pose: Percentiles,
    /// GPU milliseconds per pose of each pass (`--profile`, adapters with timestamp
    /// queries), from a second run over the same poses.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub gpu_ms_per_pass: Option<PassMsPerPose>,
    /// Objects kept that the scene's own PVS proves hidden (OpenArena maps only).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub kept_pvs_hidden: Option<u64>,
}

/// The oracle checked against the map's own PVS.
#[derive(Debug, Clone, Default, Serialize, PartialEq)]
pub struct PvsCheck {
    /// Poses whose eye lies in a non-solid cluster (the only ones checked).
    pub poses_checked: u64,
    /// Objects the oracle saw that the PVS says cannot be seen, summed over poses.
    pub oracle_outside_pvs: u64,
    /// Of those: objects holding copies of brush-model faces, which their PVS data
    /// cannot cover (`pvs::brush_model_copies`).
    pub brush_model_copies: u64,
    /// Of those: objects the exact-arithmetic CPU twin of the oracle does not see at
    /// that pose, i.e. seen through a crack the GPU left between nearer triangles.
    pub cracks: u64,
    /// The rest: sightings nothing above explains. Must be 0.
    pub unexplained: u64,
    /// Each sighting: which pose, from which cluster, which object, and why.
    pub sightings: Vec<PvsSighting>,
}

impl PvsCheck {
    /// "N oracle-visible objects outside the PVS (a brush-model copies, b through GPU
    /// cracks, c unexplained)".
    pub fn summary(&self) -> String {
        format!(
            "{} oracle-visible objects outside the PVS ({} brush-model copies, {} through GPU \
             cracks, {} unexplained)",
            self.oracle_outside_pvs, self.brush_model_copies, self.cracks, self.unexplained
        )
    }
}

/// An object the oracle saw from a cluster whose PVS row rules it out.
#[derive(Debug, Clone, Copy, Serialize, PartialEq)]
pub struct PvsSighting {
    pub pose: usize,
    pub cluster: i32,
    pub object: u32,
    pub cause: SightingCause,
}

/// Why the oracle saw an object its PVS rules out (`PvsCheck`).
#[derive(Debug, Clone, Copy, Serialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum SightingCause {
    BrushModelCopy,
    Crack,
    Unexplained,
}

#[derive(Debug, Clone, Serialize)]
pub struct EvalReport {
    pub scene: String,
    pub objects: u64,
    pub triangles: u64,
    pub viewport: [u32; 2],
    pub adapter: String,
    pub poses: u64,
    pub batch: usize,
    pub methods: BTreeMap<String, MethodReport>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub pvs: Option<PvsCheck>,
}

/// Runs the oracle and every method on `cams` in batches of `batch`. With `profile`,
/// each GPU method runs a second time with timestamps between its passes (kept apart
/// so that the profiling's extra readback does not enter `ms_per_pose`).
pub fn evaluate(
    engine: &mut Engine,
    cams: &[Camera],
    methods: &[MethodSpec],
    batch: usize,
    pvs: Option<&Pvs>,
    profile: bool,
) -> Result<EvalReport, CullError> {
    let batch = batch.max(1);
    let exact = MethodSpec {
        name: "exact".into(),
        options: CullOptions {
            method: Method::Exact,
            ..Default::default()
        },
    };
    let run =
        |engine: &mut Engine, spec: &MethodSpec| -> Result<(Vec<Vec<u32>>, Vec<f64>), CullError> {
            let settings = engine.settings(spec.options);
            let mut visible = Vec::with_capacity(cams.len());
            let mut ms = Vec::new();
            for chunk in cams.chunks(batch) {
                let t = Instant::now();
                let res = engine.cull(chunk, &settings)?;
                ms.push(t.elapsed().as_secs_f64() * 1e3 / chunk.len() as f64);
                visible.extend(res.into_iter().map(|r| r.visible));
            }
            Ok((visible, ms))
        };
    // Warm-up: the first batch pays for pipeline and target creation.
    if let Some(c) = cams.first() {
        let s = engine.settings(CullOptions::default());
        engine.cull(std::slice::from_ref(c), &s)?;
    }
    let (oracle, oracle_ms) = run(engine, &exact)?;
    let frustum_spec = MethodSpec {
        name: "frustum".into(),
        options: CullOptions {
            method: Method::Frustum,
            ..Default::default()
        },
    };
    let (in_frustum, frustum_ms) = run(engine, &frustum_spec)?;

    let clusters: Vec<i32> = cams
        .iter()
        .map(|c| pvs.map_or(-1, |p| p.cluster_at(c.position)))
        .collect();

    let mut reports = BTreeMap::new();
    let mut all = methods.to_vec();
    if !all.iter().any(|m| m.name == "exact") {
        all.push(exact.clone());
    }
    for spec in &all {
        // The oracle and frustum runs above are the reference sets; reuse them.
        let (visible, ms) = match spec.options.method {
            Method::Exact => (oracle.clone(), oracle_ms.clone()),
            Method::Frustum => (in_frustum.clone(), frustum_ms.clone()),
            Method::Hom | Method::Hzb => run(engine, spec)?,
        };
        let mut gpu_ms_per_pass = None;
        if profile && spec.options.method != Method::Frustum && engine.set_profiling(true) {
            run(engine, spec)?;
            gpu_ms_per_pass = engine.take_pass_times().map(|t| t.per_pose());
            engine.set_profiling(false);
        }
        let scene = &engine.prepared.scene;
        let tri = |ids: &[u32]| -> u64 {
            ids.iter()
                .map(|&i| scene.objects[i as usize].triangles() as u64)
                .sum()
        };
        let mut r = MethodReport {
            ms_per_pose: Percentiles::of(ms),
            ..Default::default()
        };
        r.gpu_ms_per_pass = gpu_ms_per_pass;
        let mut kept_pvs_hidden = 0;
        for k in 0..cams.len() {
            let (o, v, f) = (&oracle[k], &visible[k], &in_frustum[k]);
            let kept: std::collections::HashSet<u32> = v.iter().copied().collect();
            let missed: Vec<u32> = o.iter().copied().filter(|id| !kept.contains(id)).collect();
            if !missed.is_empty() {
                tracing::debug!(method = %spec.name, pose = k, ?missed, "false culls");
            }
            r.false_culls += missed.len() as u64;
            r.in_frustum += f.len() as u64;
            r.oracle_visible += o.len() as u64;
            let hidden = f.len() - o.len();
            r.oracle_hidden += hidden as u64;
            // Culled hidden: in-frustum, not seen by the oracle, not kept.
            let seen: std::collections::HashSet<u32> = o.iter().copied().collect();
            r.culled_hidden += f
                .iter()
                .filter(|id| !seen.contains(id) && !kept.contains(id))
                .count() as u64;
            r.kept_triangles += tri(v);
            r.oracle_triangles += tri(o);
            if let (Some(p), c) = (pvs, clusters[k])
                && c >= 0
            {
                kept_pvs_hidden += v.iter().filter(|&&id| !p.may_see(c, id)).count() as u64;
            }
        }
        r.efficiency = if r.oracle_hidden > 0 {
            r.culled_hidden as f64 / r.oracle_hidden as f64
        } else {
            1.0
        };
        if pvs.is_some() {
            r.kept_pvs_hidden = Some(kept_pvs_hidden);
        }
        reports.insert(spec.name.clone(), r);
    }
    let scene = &engine.prepared.scene;
    let pvs_check = pvs.map(|p| check_against_pvs(p, scene, cams, &clusters, &oracle));
    Ok(EvalReport {
        scene: scene.name.clone(),
        objects: scene.objects.len() as u64,
        triangles: scene.triangle_count(),
        viewport: cams.first().map_or([0, 0], |c| [c.width, c.height]),
        adapter: engine.adapter(),
        poses: cams.len() as u64,
        batch,
        methods: reports,
        pvs: pvs_check,
    })
}

/// The oracle's visible sets against the map's PVS, each sighting outside it explained
/// where it can be (`pvs::audit`).
fn check_against_pvs(
    pvs: &Pvs,
    scene: &Scene,
    cams: &[Camera],
    clusters: &[i32],
    oracle: &[Vec<u32>],
) -> PvsCheck {
    let copies = brush_model_copies(scene);
    let mut check = PvsCheck::default();
    for (k, &c) in clusters.iter().enumerate() {
        if c < 0 {
            continue;
        }
        check.poses_checked += 1;
        // The exact-arithmetic twin of the oracle, rendered once per pose if needed.
        let mut cpu: Option<Option<PixelAudit>> = None;
        for &object in oracle[k].iter().filter(|&&id| !pvs.may_see(c, id)) {
            let cause = if copies.contains(&object) {
                SightingCause::BrushModelCopy
            } else {
                let audit = cpu.get_or_insert_with(|| audit_pixels(pvs, scene, &cams[k]));
                match audit {
                    Some(a) if !a.visible.contains(&object) => SightingCause::Crack,
                    _ => SightingCause::Unexplained,
                }
            };
            tracing::debug!(
                pose = k,
                cluster = c,
                object,
                ?cause,
                "oracle sees an object outside the PVS"
            );
            match cause {
                SightingCause::BrushModelCopy => check.brush_model_copies += 1,
                SightingCause::Crack => check.cracks += 1,
                SightingCause::Unexplained => check.unexplained += 1,
            }
            check.sightings.push(PvsSighting {
                pose: k,
                cluster: c,
                object,
                cause,
            });
        }
    }
    check.oracle_outside_pvs = check.sightings.len() as u64;
    check
}

/// A readable table of a report.
pub fn table(r: &EvalReport) -> String {
    let mut s = format!(
        "scene {} — {} objects, {} triangles, {}x{}, {} poses (batch {}), adapter: {}\n",
        r.scene, r.objects, r.triangles, r.viewport[0], r.viewport[1], r.poses, r.batch, r.adapter
    );
    s += &format!(
        "{:<12} {:>11} {:>10} {:>10} {:>12} {:>10} {:>10}\n",
        "method", "false culls", "efficiency", "kept/orcl", "in frustum", "ms p50", "ms p95"
    );
    for (name, m) in &r.methods {
        let over = if m.oracle_triangles > 0 {
            m.kept_triangles as f64 / m.oracle_triangles as f64
        } else {
            1.0
        };
        s += &format!(
            "{:<12} {:>11} {:>10.3} {:>10.2} {:>12} {:>10.2} {:>10.2}\n",
            name,
            m.false_culls,
            m.efficiency,
            over,
            m.in_frustum,
            m.ms_per_pose.p50,
            m.ms_per_pose.p95
        );
    }
    for (name, m) in &r.methods {
        if let Some(passes) = &m.gpu_ms_per_pass {
            s += &format!("{name} GPU ms per pose:");
            for (pass, ms) in &passes.0 {
                s += &format!(" {pass} {ms:.3}");
            }
            s += "\n";
        }
    }
    if let Some(p) = &r.pvs {
        s += &format!(
            "PVS check: {} poses in a cluster, {}\n",
            p.poses_checked,
            p.summary()
        );
    }
    s
}
