//! Section 2: the HOM threshold curve (1.0 … 0.8), with the pixel error each threshold
//! allows.

use std::fmt::Write as _;

use anyhow::Result;

use super::context::{Report, THRESHOLDS, threshold_name};
use super::plot::{Chart, Series};
use crate::EvalReport;

/// Uncovered level-0 pixels a texel at level `k` may hold and still pass at `O_0 = t`:
/// `(1 − O_k)·4^k`, with `O_k` from [`homcull_engine::reference::level_thresholds`].
pub fn allowed_pixels(t: f32, k: usize) -> f64 {
    let o = homcull_engine::reference::level_thresholds(t, k + 1)[k] as f64;
    (1.0 - o) * 4f64.powi(k as i32)
}

/// Section 2: efficiency and false culls of HOM over thresholds, per scene.
pub(super) fn section(r: &mut Report, evals: &[EvalReport]) -> Result<()> {
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
         (`reference::level_thresholds`), so 1 − O_k = (1 − O_0) / 4^k: a texel at level k \
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
