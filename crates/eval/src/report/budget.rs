//! Section 3: HOM efficiency and time per pose against the occluder budget.

use std::fmt::Write as _;

use anyhow::Result;

use super::context::{Report, over, progress, spec};
use super::plot::{Chart, Series};
use super::scenes::Loaded;
use crate::evaluate;

/// Section 3: HOM efficiency and time per pose against the occluder budget.
pub(super) fn section(r: &mut Report, scenes: &[Loaded]) -> Result<()> {
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
