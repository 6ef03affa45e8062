//! The report's last section: every measurable target of the issues, with the value
//! this run measured and whether it is met, gathered from the sections that measure
//! them (a section that did not run leaves its targets out).

use std::fmt::Write as _;

/// One target and what this run measured for it.
#[derive(Debug, Clone)]
pub(super) struct Target {
    /// Issue number.
    pub issue: u32,
    /// What must hold, e.g. "hom ÷ exact time per pose, batch 64, munich ≤ 0.5×".
    pub what: String,
    /// The measured value, as text.
    pub measured: String,
    pub met: bool,
}

impl Target {
    /// A target "value ≤ bound" (or ≥ with `at_least`), measured as `value`.
    pub fn bound(
        issue: u32,
        what: &str,
        value: f64,
        bound: f64,
        at_least: bool,
        unit: &str,
    ) -> Self {
        Target {
            issue,
            what: format!("{what} {} {bound}{unit}", if at_least { "≥" } else { "≤" }),
            measured: format!("{value:.3}{unit}"),
            met: if at_least {
                value >= bound
            } else {
                value <= bound
            },
        }
    }
}

/// Writes the targets table.
pub(super) fn section(md: &mut String, targets: &[Target], adapter: &str) {
    if targets.is_empty() {
        return;
    }
    let _ = writeln!(
        md,
        "\n## Targets\n\n\
         Every target of the issues that this report measures, on **{adapter}** (targets \
         on time are meant for a GPU; on a CPU rasterizer they say where it stands, not \
         whether a GPU meets them).\n\n\
         | issue | target | measured | met |\n|---:|---|---:|---|"
    );
    for t in targets {
        let _ = writeln!(
            md,
            "| {} | {} | {} | {} |",
            t.issue,
            t.what,
            t.measured,
            if t.met { "yes" } else { "**no**" }
        );
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bounds_read_both_ways() {
        assert!(Target::bound(3, "x", 0.4, 0.5, false, "×").met);
        assert!(!Target::bound(3, "x", 0.6, 0.5, false, "×").met);
        assert!(Target::bound(3, "x", 0.95, 0.9, true, "").met);
        assert!(!Target::bound(3, "x", 0.85, 0.9, true, "").met);
        let t = Target::bound(4, "p50", 0.25, 0.5, false, " ms");
        assert_eq!(t.what, "p50 ≤ 0.5 ms");
        assert_eq!(t.measured, "0.250 ms");
        let mut md = String::new();
        section(&mut md, &[t], "some adapter");
        assert!(md.contains("| 4 | p50 ≤ 0.5 ms | 0.250 ms | yes |"), "{md}");
    }
}
