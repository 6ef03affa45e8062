#!/usr/bin/env python3
"""The tables README.md and docs/performance.md quote, made from the run directories
under results/ (never typed by hand).

Each generated table sits between two marker lines in its document,
`<!-- NAME:begin -->` and `<!-- NAME:end -->`:

- `results` (README.md): the headline table, homcull's native CPU backend against the
  exact oracle, frustum-only culling and Intel's Masked Occlusion Culling (MOC).
- `methods` (README.md): one figure per method, munich in the native run.
- `native` (docs/performance.md): every scene of the native run, every method.
- `pose_time`, `stereo`, `dynamic`, `server`, `deltas`, `walk`, `walkers` (docs/performance.md) and
  `masked` (docs/experiments.md): the parts of the run `EXTRA_RUN`, one folder each.

Usage: `python3 results/tables.py` rewrites the tables; `--check` exits 1 when a
document differs from what the runs give (tests/repo/results.rs runs it).
"""

import json
import re
import sys
from pathlib import Path

RESULTS = Path(__file__).resolve().parent
REPO = RESULTS.parent

# The run the tables quote: the native CPU backend, one thread, eval JSON per scene.
NATIVE_RUN = "2026-12-06-xeon-2core"
MOC_RUN = "2026-12-02-moc-epyc"
HEADLINE_SCENES = ["munich", "etoile", "oa_shouse", "oa_dm1"]
# The run of the smaller figures docs/ quotes (bench, examples, loadgen).
EXTRA_RUN = "2026-12-07-xeon-2core"
# Region answers and region streams.
REGION_RUN = "2026-12-07-epyc-2core"
# The delayed walks of the demo street and munich.
WALK_RUN = "2026-12-08-xeon-2core"
UNITS_MS = {"ns": 1e-6, "µs": 1e-3, "us": 1e-3, "ms": 1.0, "s": 1e3}


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


def methods_table(scenes):
    """README's methods: what each does, when to use it, one figure from munich."""
    m = scenes["munich"]["methods"]
    culled = lambda k: f"{m[k]['efficiency']:.4f}".rstrip("0")
    rows = [
        ("`hom` (default)",
         "HOM box test of each object's sub-bounds against the occluders' occlusion map and "
         "depth, then the survivors' own triangles tested per pixel (`refine`, on by default "
         "for REST)",
         "the answer to draw: culls nearly every hidden object, never a visible one",
         f"{culled('hom')} of hidden objects culled, {ms(m['hom'])} ms"),
        ("`hom` with `refine: false`",
         "the box test alone (`deb`: `raster` per-pixel depth, `tiles`, `plane`)",
         "streams while the client moves: a box's slack covers what a round trip reveals",
         f"{m['hom-raster']['efficiency']:.2f} culled, {ms(m['hom-raster'])} ms"),
        ("`hzb`", "a hierarchical z-buffer of the same occluders", "a baseline",
         f"{m['hzb']['efficiency']:.2f} culled"),
        ("`frustum`", "the view frustum alone (BVH)", "no occlusion needed, or as a bound",
         f"keeps {m['frustum']['kept_triangles'] / m['frustum']['oracle_triangles']:.1f}× the "
         f"oracle's triangles, {ms(m['frustum'])} ms"),
        ("`exact`", "the ID-buffer oracle: every in-frustum object drawn with a depth test",
         "ground truth; offline precomputation", f"{m['exact']['ms_per_pose']['p50']:.1f} ms"),
    ]
    out = [
        "| method | what it does | when to use it | one figure (munich, "
        f"{scenes['munich']['poses']} poses, native CPU) |",
        "|---|---|---|---|",
    ]
    out += [f"| {a} | {b} | {c} | {d} |" for a, b, c, d in rows]
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


def divan_rounds(path):
    """Fastest time in ms of every bench row of a divan text output, per round:
    {(round, which): {row path: ms}}, a row path the names from the bench down to the
    row, joined by `/` (`pose_hom_refined/demo`); rounds are `== round N WHICH` lines
    (a file without them is one round, `(1, "")`)."""
    rounds, key, stack = {}, (1, ""), []
    node = re.compile(r"[├╰]─ (.+?)\s+(?:([\d.]+) (ns|µs|us|ms|s)\s+)?│")
    for line in path.read_text().splitlines():
        m = re.match(r"== round (\d+) (\w+)", line)
        if m:
            key, stack = (int(m[1]), m[2]), []
            continue
        m = node.search(line)
        if not m:
            continue
        col = m.start()
        stack = [(c, n) for c, n in stack if c < col]
        if m[2] is None:
            stack.append((col, m[1]))  # a group: its rows follow, indented
            continue
        name = "/".join([n for _, n in stack] + [m[1]])
        rounds.setdefault(key, {})[name] = float(m[2]) * UNITS_MS[m[3]]
    return rounds


def pose_time_table():
    """Whole refined poses, the bench binary before and after one type per culling
    method, fastest of 25 samples of 32 poses, per round and over all rounds."""
    run = RESULTS / EXTRA_RUN / "method_trait"
    rounds = divan_rounds(run / "pose.txt")
    n = max(r for r, _ in rounds)
    out = [
        f"`cargo bench --bench native -- pose_hom_refined --sample-count 25`, the bench "
        f"binaries before and after one type per culling method alternated, {n} rounds, "
        f"one core; ms per pose, fastest sample of each binary over all rounds "
        f"([`results/{EXTRA_RUN}/method_trait/`](../results/{EXTRA_RUN}/method_trait/)).",
        "",
        "| scene | before | after | after ÷ before | after ÷ before, per round |",
        "|---|---:|---:|---:|---|",
    ]
    rows = sorted({k for d in rounds.values() for k in d if k.startswith("pose_hom_refined/")})
    for key in rows:
        old = [rounds[(r, "old")][key] for r in range(1, n + 1)]
        new = [rounds[(r, "new")][key] for r in range(1, n + 1)]
        per = [b / a for a, b in zip(old, new)]
        out.append(
            f"| {key.split('/')[1]} | {min(old) / 32:.3f} | {min(new) / 32:.3f} | {min(new) / min(old):.2f} "
            f"| {min(per):.2f}–{max(per):.2f} |"
        )
    return "\n".join(out) + "\n"


def stereo_table():
    """Stereo against mono from the same bench run (the binary after the change)."""
    run = RESULTS / EXTRA_RUN / "method_trait"
    rounds = divan_rounds(run / "pose.txt")
    new = [d for (r, which), d in rounds.items() if which == "new"]
    best = lambda key: min(d[key] for d in new) / 32
    out = [
        "`cargo bench --bench native -- pose_hom_refined pose_stereo_refined`, one core, "
        "32 street-level poses at 960×540 through the culler, ms per pose, fastest of "
        f"every sample ([`results/{EXTRA_RUN}/method_trait/`](../results/{EXTRA_RUN}/method_trait/)).",
        "",
        "| scene | mono | stereo | stereo ÷ mono |",
        "|---|---:|---:|---:|",
    ]
    scenes = sorted({k.split("/")[1] for d in new for k in d if k.startswith("pose_hom_refined/")})
    for sc in scenes:
        mono, st = best(f"pose_hom_refined/{sc}"), best(f"pose_stereo_refined/{sc}")
        out.append(f"| {sc} | {mono:.3f} | {st:.3f} | {st / mono:.2f} |")
    return "\n".join(out) + "\n"


def dynamic_table():
    """`cargo bench --bench dynamic`: recording an update, and the next version."""
    run = RESULTS / EXTRA_RUN / "dynamic"
    (times,) = divan_rounds(run / "bench.txt").values()
    scenes = ["demo", "munich"]  # the bench's scene indices 0 and 1
    out = [
        "`cargo bench --bench dynamic`, one thread, fastest of 100 samples, "
        f"{(run / 'machine.txt').read_text().strip()} "
        f"([`results/{EXTRA_RUN}/dynamic/`](../results/{EXTRA_RUN}/dynamic/)): `apply` records "
        "an update of N objects, `advance` builds the next version with them moved on "
        "(paid once by the first cull after an update).",
        "",
        "| scene | objects moved | apply, µs | advance, ms |",
        "|---|---:|---:|---:|",
    ]
    for k, sc in enumerate(scenes):
        for n in (1, 16, 256):
            out.append(
                f"| {sc} | {n} | {times[f'apply/({k}, {n})'] * 1e3:.2f} "
                f"| {times[f'advance/({k}, {n})']:.2f} |"
            )
    return "\n".join(out) + "\n"


def server_table():
    """`homcull loadgen` against `homcull serve --backend cpu` on loopback."""
    run = RESULTS / EXTRA_RUN / "server"
    ready = json.loads((run / "readyz.json").read_text())
    rows = [
        ("WebSocket, 32 clients", "ws32.json"),
        ("REST batches of 64, 4 clients", "batch64x4.json"),
        ("WebSocket, 32 clients, a writer moving 10,000 objects/s", "ws32_transforms10k.json"),
    ]
    out = [
        "`homcull serve --backend cpu` on loopback, the demo city, driven by `homcull "
        "loadgen --seconds 8` (street-level poses at 960×540, the stream's box test, REST's "
        f"refined HOM); {ready['adapter']} on the {(run / 'machine.txt').read_text().strip()} "
        "that runs the load generator too "
        f"([`results/{EXTRA_RUN}/server/`](../results/{EXTRA_RUN}/server/), `run.sh server`).",
        "",
        "| load | poses/s | round trip p50, ms | p99, ms | errors | update to visible p50 / p99, ms |",
        "|---|---:|---:|---:|---:|---|",
    ]
    for what, name in rows:
        r = json.loads((run / name).read_text())
        u = r.get("update_to_visible_ms")
        uv = f"{u['p50']:.1f} / {u['p99']:.1f}" if u else "—"
        out.append(
            f"| {what} | {r['poses_per_s']:,.0f} | {r['rtt_ms']['p50']:.1f} | {r['rtt_ms']['p99']:.1f} "
            f"| {r['errors']} | {uv} |"
        )
    return "\n".join(out) + "\n"


def deltas_table():
    """`cargo run --release --example street_deltas`: delta ÷ full along the street."""
    run = RESULTS / EXTRA_RUN / "street_deltas"
    text = (run / "out.txt").read_text()
    adapter = re.search(r"^adapter: (.+)$", text, re.M)[1]
    line = re.compile(
        r"^(plain|lookahead \+ hold)(, levels [\d,]+ px)?: delta/full ([\d.]+) \(([\d.]+) B vs "
        r"([\d.]+) B per frame, ([\d.]+) IDs changed per frame, ([\d.]+) objects", re.M)
    poses = re.search(r"^(\d+) culls", text, re.M)[1]
    out = [
        f"{poses} poses, {adapter}, "
        f"{(run / 'machine.txt').read_text().strip()} "
        f"([`results/{EXTRA_RUN}/street_deltas/`](../results/{EXTRA_RUN}/street_deltas/)).",
        "",
        "| stream | levels | delta ÷ full | delta, B per frame | full, B per frame "
        "| IDs changed per frame | objects in the set |",
        "|---|---|---:|---:|---:|---:|---:|",
    ]
    for m in line.finditer(text):
        what = "as culled" if m[1] == "plain" else "smoothed"
        out.append(f"| {what} | {'256,64,16' if m[2] else '—'} | {m[3]} | {m[4]} | {m[5]} "
                   f"| {m[6]} | {m[7]} |")
    return "\n".join(out) + "\n"


def walk_table():
    """`homcull loadgen --mode walk`: region streams beside point streams, delayed."""
    run = RESULTS / WALK_RUN / "walk"
    rows = [json.loads(line) for line in (run / "walk.jsonl").read_text().splitlines() if line]
    names = {
        "": "point",
        "?lookahead_ms=150&hold_ms=300": "point, smoothed (150 ms ahead, 300 ms hold)",
    }
    out = [
        "`homcull loadgen --mode walk --seconds 4` against `homcull serve --backend cpu` on "
        "loopback: the demo street, and munich from its walk start, at 1.4 m/s, the view "
        "swinging up to 30°/s, 60 frames/s at 960×540, each message delayed each way; every "
        "drawn frame checked against the exact oracle at its pose "
        f"({(run / 'machine.txt').read_text().strip()}, "
        f"[`results/{WALK_RUN}/walk/`](../results/{WALK_RUN}/walk/), `run.sh walk`).",
        "",
        "| scene | stream | delay each way, ms | late objects per s | frames outside their region | culls per s | objects held ÷ seen |",
        "|---|---|---:|---:|---:|---:|---:|",
    ]
    for r in rows:
        q = r["query"]
        name = names.get(q)
        if name is None:
            m = re.match(r"\?region_m=([0-9.]+)&turn_deg=([0-9.]+)$", q)
            name = f"region {m.group(1)} m, {m.group(2)}°" if m else q
        counted = r["frames"] - r["waiting"]
        outside = f"{r['outside_region']} of {counted}" if q.startswith("?region") else "—"
        out.append(
            f"| {r.get('scene', 'demo')} | {name} | {r['delay_ms']} | {r['late_per_s']:.1f} | {outside} "
            f"| {r['culls_per_s']:.2f} | {r['held_over_seen']:.1f} |"
        )
    return "\n".join(out) + "\n"


def walkers_table():
    """`homcull loadgen --mode walkers`: open-loop streams against a one-core server."""
    run = RESULTS / REGION_RUN / "walkers"
    rows = [json.loads(line) for line in (run / "walkers.jsonl").read_text().splitlines() if line]
    out = [
        "`homcull loadgen --mode walkers --seconds 5` (each client sends 60 poses/s along "
        "the demo street, whatever the answers) against `homcull serve --backend cpu "
        "--threads 1`, the server pinned to one core and the walkers to the other "
        f"({(run / 'machine.txt').read_text().strip()}, "
        f"[`results/{REGION_RUN}/walkers/`](../results/{REGION_RUN}/walkers/), `run.sh walkers`).",
        "",
        "| stream | clients | poses answered | answer ms p50 / p99 | culls per client-second "
        "| frames inside their region | served at 60 Hz |",
        "|---|---:|---:|---:|---:|---:|---|",
    ]
    for r in rows:
        q = r["query"]
        m = re.match(r"\?region_m=([0-9.]+)&turn_deg=([0-9.]+)$", q)
        name = f"region {m.group(1)} m, {m.group(2)}°" if m else (q or "point")
        inside = f"{100 * r['inside_share']:.1f} %" if m else "—"
        p = r["answer_ms"]
        out.append(
            f"| {name} | {r['clients']} | {100 * r['answered_share']:.1f} % "
            f"| {p['p50']:.1f} / {p['p99']:.1f} | {r['culls_per_client_s']:.2f} | {inside} "
            f"| {'yes' if r['served'] else 'no'} |"
        )
    return "\n".join(out) + "\n"


def masked_table():
    """`cargo run --release --features experimental --example masked_vs_per_pixel`."""
    run = RESULTS / EXTRA_RUN / "masked"
    row = re.compile(
        r"^(\w+)\s+\| ([\d.]+) ([\d.]+) ([\d.]+) = ([\d.]+) ms \| ([\d.]+) ms \| (\d+) \| "
        r"([\d.]+) \| ([\d.]+) / ([\d.]+)$", re.M)
    out = [
        f"{(run / 'machine.txt').read_text().strip()}, ms per pose:",
        "",
        "| scene | masked: draw + box test + refinement = pose | per-pixel pose | false culls "
        "| refined efficiency (both) | box test alone: masked / per-pixel |",
        "|---|---|---:|---:|---:|---|",
    ]
    for m in row.finditer((run / "out.txt").read_text()):
        out.append(f"| {m[1]} | {m[2]} + {m[3]} + {m[4]} = {m[5]} | {m[6]} | {m[7]} | {m[8]} "
                   f"| {m[9]} / {m[10]} |")
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
        (REPO / "README.md", "methods", methods_table(scenes)),
        (REPO / "docs" / "performance.md", "native", native_table(meta, scenes)),
        (REPO / "docs" / "performance.md", "pose_time", pose_time_table()),
        (REPO / "docs" / "performance.md", "stereo", stereo_table()),
        (REPO / "docs" / "performance.md", "dynamic", dynamic_table()),
        (REPO / "docs" / "performance.md", "server", server_table()),
        (REPO / "docs" / "performance.md", "deltas", deltas_table()),
        (REPO / "docs" / "performance.md", "walk", walk_table()),
        (REPO / "docs" / "performance.md", "walkers", walkers_table()),
        (REPO / "docs" / "experiments.md", "masked", masked_table()),
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
