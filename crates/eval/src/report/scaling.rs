//! Sections 4 and 5: time per pose against viewport size and batch size (4) and
//! against object count (5).

use std::fmt::Write as _;
use std::time::Instant;

use anyhow::Result;
use homcull_proto::{CullOptions, Method};

use super::context::{Report, progress, spec};
use super::plot::{Chart, Series, loglog_slope};
use super::scenes::Loaded;
use super::targets::Target;
use crate::{MethodSpec, evaluate};
use homcull_engine::engine::Backend;
use homcull_engine::occluders::OccluderParams;
use homcull_engine::scene::{demo_city, demo_city_sized};

/// HOM as served by default: raster DEB with the per-pixel refinement.
fn refined() -> Result<MethodSpec> {
    MethodSpec::with_defaults("hom-refine").map_err(anyhow::Error::msg)
}

fn slope_text(points: &[(f64, f64)]) -> String {
    loglog_slope(points).map_or("–".into(), |s| format!("{s:.2}"))
}

/// Each method's log-log slope as "name slope, …", and its points as a plot series.
fn slopes_and_series(names: &[&str], pts: Vec<Vec<(f64, f64)>>) -> (String, Vec<Series>) {
    let slopes: Vec<String> = names
        .iter()
        .zip(&pts)
        .map(|(n, p)| format!("{n} {}", slope_text(p)))
        .collect();
    let series = names
        .iter()
        .zip(pts)
        .map(|(n, points)| Series {
            label: n.to_string(),
            points,
        })
        .collect();
    (slopes.join(", "), series)
}

/// Time per pose of hom, hzb and the exact oracle on the demo city per viewport.
pub(super) fn viewport(r: &mut Report) -> Result<()> {
    let p = r.plan.clone();
    let city = Loaded::new(demo_city());
    let methods = [
        refined()?,
        spec("hom-raster", 1.0),
        MethodSpec::with_defaults("hzb").map_err(anyhow::Error::msg)?,
    ];
    let _ = writeln!(
        r.md,
        "\n## 4. Scaling\n\n### Viewport size\n\n\
         Demo city, {} poses per viewport (the same eye positions: seed {}), batch {}, \
         budget {} triangles. Time per pose p50.\n\n\
         | viewport | pixels | hom-refine ms | hom-raster ms | hzb ms | exact ms | hom-refine efficiency | hom-raster efficiency |\n\
         |---|---:|---:|---:|---:|---:|---:|---:|",
        p.viewport_poses,
        super::context::SEED,
        p.batch.min(16),
        OccluderParams::default().budget_triangles
    );
    let names = ["hom-refine", "hom-raster", "hzb", "exact"];
    let mut pts: Vec<Vec<(f64, f64)>> = vec![Vec::new(); names.len()];
    for (i, &vp) in p.viewports.iter().enumerate() {
        progress(
            "viewport",
            i,
            p.viewports.len(),
            &format!("{}x{}", vp[0], vp[1]),
        );
        let cams = city.cams(p.viewport_poses, vp)?;
        let mut engine = r.engine(
            city.scene.clone(),
            OccluderParams::default().budget_triangles,
        );
        let e = evaluate(&mut engine, &cams, &methods, p.batch.min(16), None, false)?;
        let px = vp[0] as f64 * vp[1] as f64;
        let ms: Vec<f64> = names
            .iter()
            .map(|n| e.methods[*n].ms_per_pose.p50)
            .collect();
        for (k, m) in ms.iter().enumerate() {
            pts[k].push((px, *m));
        }
        let _ = writeln!(
            r.md,
            "| {}×{} | {} | {:.2} | {:.2} | {:.2} | {:.2} | {:.3} | {:.3} |",
            vp[0],
            vp[1],
            px,
            ms[0],
            ms[1],
            ms[2],
            ms[3],
            e.methods["hom-refine"].efficiency,
            e.methods["hom-raster"].efficiency
        );
    }
    let (slopes, series) = slopes_and_series(&names, pts);
    let _ = writeln!(
        r.md,
        "\nLog-log slope of time per pose against pixel count (1 = linear in pixels, \
         0 = independent of resolution): {slopes}."
    );
    r.plot(
        "viewport.png",
        &Chart {
            title: "time per pose vs viewport (demo city)",
            x_label: "pixels",
            y_label: "ms per pose (p50)",
            log_x: true,
            log_y: true,
        },
        &series,
    )
}

/// Throughput of HOM on the demo city against the number of poses per submission.
pub(super) fn batch(r: &mut Report) -> Result<()> {
    let p = r.plan.clone();
    let city = Loaded::new(demo_city());
    let most = *p.batches.iter().max().unwrap_or(&1);
    let all = city.cams(most.max(64), p.viewport)?;
    let mut engine = r.engine(
        city.scene.clone(),
        OccluderParams::default().budget_triangles,
    );
    let settings = engine.settings(CullOptions {
        method: Method::Hom,
        ..Default::default()
    });
    engine.cull(&all[..1], &settings)?; // warm-up: pipelines and targets
    let _ = writeln!(
        r.md,
        "\n### Batch size\n\n\
         HOM as served (raster DEB, refined) on the demo city at {}×{}; each batch size runs \
         max(4 × batch, 64) poses (at most {}) in batches of that size; time per pose is \
         total wall time ÷ poses.\n\n\
         | batch | poses | ms/pose | poses/s |\n|---:|---:|---:|---:|",
        p.viewport[0],
        p.viewport[1],
        all.len()
    );
    let mut pts = Vec::new();
    for (i, &b) in p.batches.iter().enumerate() {
        progress("batch", i, p.batches.len(), &format!("batch {b}"));
        let n = (4 * b).max(64).min(all.len());
        let t = Instant::now();
        for chunk in all[..n].chunks(b) {
            engine.cull(chunk, &settings)?;
        }
        let ms = t.elapsed().as_secs_f64() * 1e3 / n as f64;
        let _ = writeln!(r.md, "| {b} | {n} | {ms:.2} | {:.0} |", 1e3 / ms);
        pts.push((b as f64, ms));
    }
    let ms_at = |b: f64| pts.iter().find(|p| p.0 == b).map(|p| p.1);
    if let (Some(single), Some(batched)) = (ms_at(1.0), ms_at(64.0)) {
        r.targets.push(Target::bound(
            3,
            "throughput of batches of 64 ÷ single poses (demo city)",
            single / batched,
            5.0,
            true,
            "×",
        ));
    }
    let _ = writeln!(
        r.md,
        "\nLog-log slope of time per pose against batch size: {} (0 = batching buys \
         nothing, −1 = a fixed cost per submission dominates).",
        slope_text(&pts)
    );
    r.plot(
        "batch.png",
        &Chart {
            title: "HOM time per pose vs batch size (demo city)",
            x_label: "poses per batch",
            y_label: "ms per pose",
            log_x: true,
            log_y: true,
        },
        &[Series {
            label: "hom".into(),
            points: pts,
        }],
    )
}

const GIB: f64 = (1u64 << 30) as f64;

/// Peak memory of one sized city's run: measured 5.8 GB for 186×186 blocks (982k
/// objects, 17.8M triangles) on lavapipe, where GPU buffers are host memory too;
/// about 29 objects per block, 7 KB per object with a margin.
fn city_bytes_estimate(blocks: usize) -> u64 {
    (blocks * blocks * 29 * 7_000) as u64
}

/// `MemAvailable` of `/proc/meminfo`, bytes (None where there is no such file).
fn mem_available_bytes() -> Option<u64> {
    let info = std::fs::read_to_string("/proc/meminfo").ok()?;
    let line = info.lines().find(|l| l.starts_with("MemAvailable:"))?;
    let kb: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kb * 1024)
}

/// Time per pose and per object against object count (sized demo cities); a city
/// that would not fit in the available memory is skipped and the report says so.
pub(super) fn objects(r: &mut Report) -> Result<()> {
    let p = r.plan.clone();
    // Beside a GPU adapter, the native CPU backend runs the same poses too.
    let beside_cpu = r.backend.gpu().is_some();
    let methods = [
        refined()?,
        spec("hom-raster", 1.0),
        MethodSpec::with_defaults("frustum").map_err(anyhow::Error::msg)?,
    ];
    let _ = writeln!(
        r.md,
        "\n## 5. Object count\n\n\
         Synthetic cities from the demo generator (`scene::demo_city_sized`, N×N blocks), \
         {} poses each at {}×{}, batch {}, budget {} triangles. Time per pose p50; \
         ns/object = time per pose ÷ objects in the scene. {}\n\n\
         | blocks | objects | triangles | hom-refine ms | hom-raster ms | exact ms | frustum ms | hom-refine cpu ms | hom-raster ns/object | hom-refine efficiency | hom-raster efficiency | false culls |\n\
         |---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|",
        p.city_poses,
        p.viewport[0],
        p.viewport[1],
        p.batch.min(16),
        OccluderParams::default().budget_triangles,
        if beside_cpu {
            format!(
                "hom-refine cpu: the same poses on {}; its false culls are counted with \
                 the adapter's.",
                Backend::Native.describe()
            )
        } else {
            "hom-refine cpu: run only beside a GPU adapter (here the report's own backend \
             is the CPU one)."
                .into()
        }
    );
    let names = [
        "hom-refine",
        "hom-raster",
        "exact",
        "frustum",
        "hom-refine (cpu)",
    ];
    let mut pts: Vec<Vec<(f64, f64)>> = vec![Vec::new(); names.len()];
    let mut skipped = Vec::new();
    for (i, &blocks) in p.city_blocks.iter().enumerate() {
        progress(
            "object count",
            i,
            p.city_blocks.len(),
            &format!("{blocks}×{blocks} blocks"),
        );
        let need = city_bytes_estimate(blocks);
        if let Some(avail) = mem_available_bytes().filter(|&a| a < need) {
            let why = format!(
                "{blocks}×{blocks} blocks skipped: needs about {:.1} GiB, {:.1} GiB available",
                need as f64 / GIB,
                avail as f64 / GIB
            );
            eprintln!("[report] {why}");
            skipped.push(why);
            continue;
        }
        let city = Loaded::new(demo_city_sized(blocks));
        let objects = city.scene.objects.len() as f64;
        let cams = city.cams(p.city_poses, p.viewport)?;
        let mut engine = r.engine(
            city.scene.clone(),
            OccluderParams::default().budget_triangles,
        );
        let e = evaluate(&mut engine, &cams, &methods, p.batch.min(16), None, false)?;
        drop(engine);
        let cpu = if beside_cpu {
            let mut engine = r.engine_on(
                city.scene.clone(),
                OccluderParams::default().budget_triangles,
                Backend::Native,
            );
            let e = evaluate(
                &mut engine,
                &cams,
                &methods[..1],
                p.batch.min(16),
                None,
                false,
            )?;
            Some(e.methods["hom-refine"].clone())
        } else {
            None
        };
        let mut ms: Vec<f64> = names[..4]
            .iter()
            .map(|n| e.methods[*n].ms_per_pose.p50)
            .collect();
        for (k, m) in ms.iter().enumerate() {
            pts[k].push((objects, *m));
        }
        if let Some(c) = &cpu {
            ms.push(c.ms_per_pose.p50);
            pts[4].push((objects, c.ms_per_pose.p50));
        }
        let (refine, boxes) = (&e.methods["hom-refine"], &e.methods["hom-raster"]);
        let _ = writeln!(
            r.md,
            "| {blocks}×{blocks} | {} | {} | {:.2} | {:.2} | {:.2} | {:.3} | {} | {:.0} | {:.3} | {:.3} | {} |",
            e.objects,
            e.triangles,
            ms[0],
            ms[1],
            ms[2],
            ms[3],
            cpu.as_ref()
                .map_or("–".into(), |c| format!("{:.2}", c.ms_per_pose.p50)),
            ms[1] * 1e6 / objects,
            refine.efficiency,
            boxes.efficiency,
            refine.false_culls + boxes.false_culls + cpu.map_or(0, |c| c.false_culls)
        );
    }
    let shown = if beside_cpu {
        names.len()
    } else {
        names.len() - 1
    };
    pts.truncate(shown);
    let (slopes, series) = slopes_and_series(&names[..shown], pts);
    let _ = writeln!(
        r.md,
        "\nLog-log slope of time per pose against object count: {slopes}.{}",
        if skipped.is_empty() {
            String::new()
        } else {
            format!(" {}.", skipped.join("; "))
        }
    );
    r.plot(
        "objects.png",
        &Chart {
            title: "time per pose vs object count (sized demo cities)",
            x_label: "objects",
            y_label: "ms per pose (p50)",
            log_x: true,
            log_y: true,
        },
        &series,
    )
}
