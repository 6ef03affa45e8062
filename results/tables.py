#!/usr/bin/env python3
"""The tables README.md and docs/performance.md quote, made from the run directories
under results/ (never typed by hand).

Each generated table sits between two marker lines in its document,
`<!-- NAME:begin -->` and `<!-- NAME:end -->`:

- `results` (README.md): the headline table, homcull's native CPU backend against the
  exact oracle, frustum-only culling and Intel's Masked Occlusion Culling (MOC).
- `native` (docs/performance.md): every scene of the native run, every method.

Usage: `python3 results/tables.py` rewrites the tables; `--check` exits 1 when a
document differs from what the runs give (tests/repo/results.rs runs it).
"""

import json
import sys
from pathlib import Path

RESULTS = Path(__file__).resolve().parent
REPO = RESULTS.parent

# The run the tables quote: the native CPU backend, one thread, eval JSON per scene.
NATIVE_RUN = "2026-12-06-xeon-2core"
MOC_RUN = "2026-12-02-moc-epyc"
HEADLINE_SCENES = ["munich", "etoile", "oa_shouse", "oa_dm1"]


def load_native():
    run = RESULTS / NATIVE_RUN
    meta = json.loads((run / "run.json").read_text())
    scenes = {}
    for name in meta["scenes"]:
        scenes[name] = json.loads((run / "eval" / f"{name}.json").read_text())
    return meta, scenes


def load_moc():
    return json.loads((RESULTS / MOC_RUN / "moc.json").read_text())


def ms(m):
    return f"{m['ms_per_pose']['p50']:.2f}"


def ratio(m):
    return f"{m['kept_triangles'] / m['oracle_triangles']:.2f}"


def headline(meta, scenes, moc):
    cols = HEADLINE_SCENES
    rows = [
        ("objects the exact oracle sees that homcull culled",
         lambda s: str(scenes[s]["methods"]["hom"]["false_culls"])),
        ("share of the hidden in-frustum objects homcull culls",
         lambda s: f"**{scenes[s]['methods']['hom']['efficiency']:.3f}**"),
        ("the same for MOC",
         lambda s: f"{moc['scenes'][s]['efficiency']:.2f}"),
        ("triangles kept ÷ triangles the oracle sees: homcull / frustum only",
         lambda s: f"{ratio(scenes[s]['methods']['hom'])} / {ratio(scenes[s]['methods']['frustum'])}"),
        ("ms per pose, one thread: homcull / exact oracle / frustum only",
         lambda s: f"{ms(scenes[s]['methods']['hom'])} / {ms(scenes[s]['methods']['exact'])} / "
                   f"{ms(scenes[s]['methods']['frustum'])}"),
        ("ms per pose of MOC, one thread",
         lambda s: f"{moc['scenes'][s]['ms_per_pose']:.2f}"),
    ]
    out = ["| | " + " | ".join(cols) + " |", "|---|" + "---:|" * len(cols)]
    for label, cell in rows:
        out.append(f"| {label} | " + " | ".join(cell(s) for s in cols) + " |")
    out.append("")
    out.append(
        f"homcull: {meta['backend']}, {meta['poses']} random street-level poses per scene "
        f"at {meta['viewport']}, {meta['machine']} ([`results/{NATIVE_RUN}/`](results/{NATIVE_RUN}/)); "
        f"MOC: {moc['machine']}, {moc['threads']} thread ([`results/{MOC_RUN}/`](results/{MOC_RUN}/)). "
        "Times are p50 over batches, planning included."
    )
    return "\n".join(out) + "\n"


def native_table(meta, scenes):
    out = [
        f"`{meta['command']}` per scene, {meta['machine']} "
        f"([`results/{NATIVE_RUN}/`](../results/{NATIVE_RUN}/)).",
        "",
        "| scene | objects | triangles | method | false culls | efficiency | kept ÷ oracle triangles "
        "| ms/pose p50 | ms/pose p95 |",
        "|---|---:|---:|---|---:|---:|---:|---:|---:|",
    ]
    for name, r in scenes.items():
        for method, m in r["methods"].items():
            out.append(
                f"| {name} | {r['objects']} | {r['triangles']} | {method} | {m['false_culls']} "
                f"| {m['efficiency']:.4f} | {ratio(m)} | {ms(m)} | {m['ms_per_pose']['p95']:.2f} |"
            )
    return "\n".join(out) + "\n"


def bar_chart(meta, scenes, moc):
    """Two panels of grouped bars per headline scene as SVG: the share of hidden objects
    culled (homcull, MOC) and ms per pose (homcull, MOC, the exact oracle)."""
    series_eff = [
        ("homcull", "#1f77b4", lambda s: scenes[s]["methods"]["hom"]["efficiency"]),
        ("MOC", "#ff7f0e", lambda s: moc["scenes"][s]["efficiency"]),
    ]
    series_ms = [
        ("homcull", "#1f77b4", lambda s: scenes[s]["methods"]["hom"]["ms_per_pose"]["p50"]),
        ("MOC", "#ff7f0e", lambda s: moc["scenes"][s]["ms_per_pose"]),
        ("exact oracle", "#7f7f7f", lambda s: scenes[s]["methods"]["exact"]["ms_per_pose"]["p50"]),
    ]
    w, h, pad, top = 360, 220, 40, 30
    out = [f'<svg xmlns="http://www.w3.org/2000/svg" width="{2 * w}" height="{h + 40}" '
           f'font-family="DejaVu Sans, sans-serif" font-size="11">',
           f'<rect width="{2 * w}" height="{h + 40}" fill="white"/>']

    def panel(x0, title, series, vmax, fmt):
        out.append(f'<text x="{x0 + w / 2}" y="16" text-anchor="middle" font-size="13">{title}</text>')
        base = h - 10
        span = base - top
        out.append(f'<line x1="{x0 + pad}" y1="{base}" x2="{x0 + w - 10}" y2="{base}" stroke="black"/>')
        group = (w - pad - 20) / len(HEADLINE_SCENES)
        bar = group / (len(series) + 1)
        for g, scene in enumerate(HEADLINE_SCENES):
            gx = x0 + pad + g * group
            out.append(f'<text x="{gx + group / 2:.1f}" y="{base + 14}" text-anchor="middle">{scene}</text>')
            for k, (_, color, value) in enumerate(series):
                v = value(scene)
                bh = span * v / vmax
                bx = gx + bar / 2 + k * bar
                out.append(f'<rect x="{bx:.1f}" y="{base - bh:.1f}" width="{bar * 0.9:.1f}" '
                           f'height="{bh:.1f}" fill="{color}"/>')
                out.append(f'<text x="{bx + bar * 0.45:.1f}" y="{base - bh - 3:.1f}" '
                           f'text-anchor="middle" font-size="9">{fmt(v)}</text>')
        for k, (label, color, _) in enumerate(series):
            lx = x0 + pad + k * 95
            out.append(f'<rect x="{lx}" y="{h + 18}" width="10" height="10" fill="{color}"/>')
            out.append(f'<text x="{lx + 14}" y="{h + 27}">{label}</text>')

    panel(0, "share of hidden objects culled", series_eff, 1.0, lambda v: f"{v:.2f}")
    vmax = max(v(s) for _, _, v in series_ms for s in HEADLINE_SCENES) * 1.1
    panel(w, "ms per pose, one thread", series_ms, vmax, lambda v: f"{v:.2f}")
    out.append("</svg>")
    return "\n".join(out) + "\n"


def splice(text, name, table, where):
    begin, end = f"<!-- {name}:begin -->\n", f"<!-- {name}:end -->"
    i = text.find(begin)
    j = text.find(end, i + 1)
    if i < 0 or j < 0:
        raise SystemExit(f"{where} has no {begin.strip()} … {end} markers")
    return text[: i + len(begin)] + table + text[j:]


def main():
    check = "--check" in sys.argv[1:]
    meta, scenes = load_native()
    moc = load_moc()
    docs = [
        (REPO / "README.md", "results", headline(meta, scenes, moc)),
        (REPO / "docs" / "performance.md", "native", native_table(meta, scenes)),
    ]
    stale = []
    chart = RESULTS / NATIVE_RUN / "headline.svg"
    svg = bar_chart(meta, scenes, moc)
    if not chart.is_file() or chart.read_text() != svg:
        if check:
            stale.append(str(chart.relative_to(REPO)))
        else:
            chart.write_text(svg)
    for path, name, table in docs:
        text = path.read_text()
        new = splice(text, name, table, path.name)
        if new != text:
            if check:
                stale.append(f"{path.relative_to(REPO)} ({name})")
            else:
                path.write_text(new)
    if stale:
        print("stale tables, run `python3 results/tables.py`: " + ", ".join(stale))
        sys.exit(1)


if __name__ == "__main__":
    main()
