//! The structure ARCHITECTURE.md describes, checked: the library's layers use only the
//! layers before them, the modules of `core/` likewise, no two modules of a folder use
//! each other (directly or around a circle), clap stays in `cli/`, `main.rs` stays a
//! dispatcher, no source file grows past 600 lines, and no comment points to documents
//! outside the repository.
//!
//! Module references are read from the source text: `crate::…` and `super::…` paths in
//! `use` statements and in code, resolved to the deepest module that exists. `pub use`
//! re-exports are not uses. A reference from a folder's `mod.rs` to its own children,
//! or from a child to its folder, is how Rust modules compose and is allowed; the rules
//! are about siblings and layers.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

const ROOT: &str = env!("CARGO_MANIFEST_DIR");

/// The library's layers, in order: each may use only itself and those before it.
const LAYERS: [&str; 5] = ["proto", "core", "server", "eval", "cli"];

/// The modules of `core/`, in order: each may use only itself and those before it.
const CORE: [&str; 15] = [
    "geom",
    "camera",
    "scene",
    "bvh",
    "occluders",
    "cull",
    "dynamic",
    "region",
    "reference",
    "native",
    "gpu",
    "engine",
    "pvs",
    "sampler",
    "resident",
];

const MAX_LINES: usize = 600;

/// A module path from the crate root, e.g. `["core", "cull", "plan"]`.
type ModPath = Vec<String>;

struct Source {
    path: PathBuf,
    module: ModPath,
    text: String,
}

fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return;
    };
    for e in entries.flatten() {
        let p = e.path();
        if p.is_dir() {
            rust_files(&p, out);
        } else if p.extension().is_some_and(|x| x == "rs") {
            out.push(p);
        }
    }
}

/// Each crate of the workspace as a layer: its source folder and its name among the
/// layers. The binary crate's own modules (`cli`) sit at the root.
const CRATES: [(&str, &str); 5] = [
    ("proto/src", "proto"),
    ("crates/engine/src", "core"),
    ("crates/server/src", "server"),
    ("crates/eval/src", "eval"),
    ("src", ""),
];

/// How each crate is named in code, and its layer.
const CRATE_NAMES: [(&str, &str); 4] = [
    ("homcull_proto::", "proto"),
    ("homcull_engine::", "core"),
    ("homcull_server::", "server"),
    ("homcull_eval::", "eval"),
];

/// Every library source file of the workspace as one tree of modules: a crate's
/// `crate::x` is read as `crate::LAYER::x`, and `homcull_engine::x` (and the other
/// crates' names) as `crate::core::x`, so that references across crates are edges
/// like those within one.
fn library() -> Vec<Source> {
    let mut out = Vec::new();
    for (dir, layer) in CRATES {
        let src = Path::new(ROOT).join(dir);
        let mut files = Vec::new();
        rust_files(&src, &mut files);
        files.sort();
        for path in files {
            if path.file_name().is_some_and(|n| n == "main.rs") {
                continue;
            }
            let rel = path.strip_prefix(&src).unwrap();
            let mut module: ModPath = if layer.is_empty() {
                Vec::new()
            } else {
                vec![layer.to_string()]
            };
            module.extend(
                rel.with_extension("")
                    .iter()
                    .map(|s| s.to_string_lossy().into_owned()),
            );
            if module.last().is_some_and(|m| m == "mod" || m == "lib") {
                module.pop();
            }
            let mut text = std::fs::read_to_string(&path).unwrap();
            if !layer.is_empty() {
                text = text.replace("crate::", &format!("crate::{layer}::"));
            }
            for (name, l) in CRATE_NAMES {
                text = text.replace(name, &format!("crate::{l}::"));
            }
            out.push(Source { path, module, text });
        }
    }
    out
}

/// The text without comments (line comments and doc comments; block comments are not
/// used here).
fn code_of(text: &str) -> String {
    text.lines()
        .map(|l| match l.trim_start().starts_with("//") {
            true => "",
            false => l,
        })
        .collect::<Vec<_>>()
        .join("\n")
}

/// The text without `pub use …;` statements (re-exports are not uses).
fn without_reexports(code: &str) -> String {
    let mut out = String::new();
    let mut rest = code;
    while let Some(i) = rest.find("pub use ") {
        out.push_str(&rest[..i]);
        let end = rest[i..].find(';').map_or(rest.len(), |j| i + j + 1);
        rest = &rest[end..];
    }
    out.push_str(rest);
    out
}

fn is_ident(c: char) -> bool {
    c.is_ascii_alphanumeric() || c == '_'
}

/// Every path that starts at `crate::` or `super::` in `code`, as module paths from the
/// crate root (braced groups expanded one level), for a file of module `module`.
fn referenced_paths(code: &str, module: &ModPath) -> Vec<ModPath> {
    let bytes: Vec<char> = code.chars().collect();
    let mut out = Vec::new();
    let mut i = 0;
    while i < bytes.len() {
        let starts = |word: &str| bytes[i..].iter().take(word.len()).copied().eq(word.chars());
        let boundary = i == 0 || !is_ident(bytes[i - 1]) && bytes[i - 1] != ':';
        if !(boundary && (starts("crate::") || starts("super::"))) {
            i += 1;
            continue;
        }
        // `super` is the parent of the file's module, whether the file is `a/b.rs` or
        // `a/b/mod.rs` (both are module `a::b`): one step up per `super`.
        let mut base: ModPath = Vec::new();
        if starts("super::") {
            base = module.clone();
            while bytes[i..].iter().take(7).copied().eq("super::".chars()) {
                base.pop();
                i += 7;
            }
        } else {
            i += 7;
        }
        let mut segs = base.clone();
        let mut word = String::new();
        loop {
            if i < bytes.len() && is_ident(bytes[i]) {
                word.push(bytes[i]);
                i += 1;
            } else if i + 1 < bytes.len() && bytes[i] == ':' && bytes[i + 1] == ':' {
                segs.push(std::mem::take(&mut word));
                i += 2;
                if i < bytes.len() && bytes[i] == '{' {
                    let end = bytes[i..]
                        .iter()
                        .position(|&c| c == '}')
                        .map_or(bytes.len(), |j| i + j);
                    let group: String = bytes[i + 1..end].iter().collect();
                    for item in group.split(',') {
                        let first = item.trim().split("::").next().unwrap_or("").trim();
                        if !first.is_empty() && first != "self" {
                            let mut p = segs.clone();
                            p.push(first.to_string());
                            out.push(p);
                        }
                    }
                    out.push(segs.clone());
                    i = end;
                    break;
                }
            } else {
                if !word.is_empty() {
                    segs.push(word);
                }
                out.push(segs);
                break;
            }
        }
    }
    out
}

/// The deepest prefix of `path` that is a module of the library.
fn resolve(path: &ModPath, modules: &BTreeSet<ModPath>) -> ModPath {
    (0..=path.len())
        .rev()
        .map(|n| path[..n].to_vec())
        .find(|p| modules.contains(p))
        .unwrap_or_default()
}

/// `(from module, to module)` for every reference between library modules.
fn edges(sources: &[Source]) -> Vec<(ModPath, ModPath, PathBuf)> {
    let modules: BTreeSet<ModPath> = sources.iter().map(|s| s.module.clone()).collect();
    let mut out = Vec::new();
    for s in sources {
        let code = without_reexports(&code_of(&s.text));
        for p in referenced_paths(&code, &s.module) {
            let to = resolve(&p, &modules);
            if to != s.module {
                out.push((s.module.clone(), to, s.path.clone()));
            }
        }
    }
    out
}

fn rank(list: &[&str], name: &str) -> Option<usize> {
    list.iter().position(|l| *l == name)
}

fn rel(p: &Path) -> String {
    p.strip_prefix(ROOT).unwrap_or(p).display().to_string()
}

#[test]
fn layers_use_only_the_layers_before_them() {
    let sources = library();
    assert!(sources.len() > 40, "found the library's files");
    let mut wrong = Vec::new();
    for (from, to, file) in edges(&sources) {
        let (Some(f), Some(t)) = (from.first(), to.first()) else {
            continue;
        };
        if let (Some(a), Some(b)) = (rank(&LAYERS, f), rank(&LAYERS, t)) {
            if b > a {
                wrong.push(format!("{} uses {}", rel(&file), to.join("::")));
            }
        }
        if f == "core" && t == "core" && from.len() > 1 && to.len() > 1 {
            if let (Some(a), Some(b)) = (rank(&CORE, &from[1]), rank(&CORE, &to[1])) {
                if b > a {
                    wrong.push(format!("{} uses {}", rel(&file), to.join("::")));
                }
            }
        }
    }
    for l in LAYERS {
        assert!(
            sources
                .iter()
                .any(|s| s.module.first().is_some_and(|m| m == l)),
            "layer {l} exists"
        );
    }
    for c in CORE {
        assert!(
            sources
                .iter()
                .any(|s| s.module.len() >= 2 && s.module[0] == "core" && s.module[1] == c),
            "core module {c} exists"
        );
    }
    assert!(wrong.is_empty(), "upward references:\n{}", wrong.join("\n"));
}

#[test]
fn no_two_sibling_modules_use_each_other() {
    let sources = library();
    // Folder → (child → children it uses), over every folder of the library.
    let mut graphs: BTreeMap<ModPath, BTreeMap<String, BTreeSet<String>>> = BTreeMap::new();
    for (from, to, _) in edges(&sources) {
        let common = from.iter().zip(&to).take_while(|(a, b)| a == b).count();
        // Siblings: both below the common folder, neither is the folder itself.
        if common < from.len() && common < to.len() {
            let folder = from[..common].to_vec();
            graphs
                .entry(folder)
                .or_default()
                .entry(from[common].clone())
                .or_default()
                .insert(to[common].clone());
        }
    }
    let mut circles = Vec::new();
    for (folder, g) in &graphs {
        // Depth-first search for a back edge.
        fn visit(
            n: &str,
            g: &BTreeMap<String, BTreeSet<String>>,
            state: &mut BTreeMap<String, u8>,
            stack: &mut Vec<String>,
            found: &mut Vec<Vec<String>>,
        ) {
            state.insert(n.to_string(), 1);
            stack.push(n.to_string());
            for m in g.get(n).into_iter().flatten() {
                match state.get(m.as_str()).copied().unwrap_or(0) {
                    0 => visit(m, g, state, stack, found),
                    1 => {
                        let at = stack.iter().position(|s| s == m).unwrap();
                        let mut c = stack[at..].to_vec();
                        c.push(m.clone());
                        found.push(c);
                    }
                    _ => {}
                }
            }
            stack.pop();
            state.insert(n.to_string(), 2);
        }
        let mut state = BTreeMap::new();
        let mut found = Vec::new();
        for n in g.keys() {
            if !state.contains_key(n.as_str()) {
                visit(n, g, &mut state, &mut Vec::new(), &mut found);
            }
        }
        for c in found {
            circles.push(format!("in {}: {}", folder.join("::"), c.join(" → ")));
        }
    }
    assert!(
        circles.is_empty(),
        "import circles:\n{}",
        circles.join("\n")
    );
}

#[test]
fn the_checker_sees_references() {
    // The rules above pass vacuously if the scanner finds nothing: pin a few edges.
    let e = edges(&library());
    let has = |from: &str, to: &str| {
        e.iter()
            .any(|(f, t, _)| f.join("::") == from && t.join("::") == to)
    };
    assert!(
        has("core::gpu::batch", "core::cull"),
        "batch.rs implements Culler"
    );
    assert!(
        has("core::reference::test", "core::cull::deb"),
        "the box test reads the DEB"
    );
    assert!(has("server::worker", "core::engine"), "jobs hold engines");
    assert!(
        has("core::gpu::batch", "core::gpu::inputs"),
        "super:: paths resolve"
    );
    let (g, s) = (
        ["core".to_string(), "gpu".to_string()].to_vec(),
        ["core".to_string(), "gpu".to_string(), "batch".to_string()].to_vec(),
    );
    assert!(
        referenced_paths("use super::refine::X;", &s)
            .contains(&[g.clone(), vec!["refine".into(), "X".into()]].concat())
    );
    assert!(referenced_paths("use super::Y;", &g).contains(&vec!["core".into(), "Y".into()]));
}

#[test]
fn clap_is_only_in_the_command_line_and_main_only_dispatches() {
    for s in library() {
        let outside_cli = s.module.first().is_none_or(|m| m != "cli");
        if outside_cli {
            assert!(
                !code_of(&s.text).contains("clap::"),
                "{} uses clap; only src/cli/ may",
                rel(&s.path)
            );
        }
    }
    let main = std::fs::read_to_string(Path::new(ROOT).join("src/main.rs")).unwrap();
    assert!(
        main.lines().count() <= 60,
        "src/main.rs is a thin dispatcher"
    );
}

/// Every Rust file of the library, its tests, benches, examples and the wire crate.
fn every_rust_file() -> Vec<PathBuf> {
    let mut files = Vec::new();
    for dir in [
        "src",
        "crates",
        "tests",
        "benches",
        "examples",
        "proto/src",
        "proto/tests",
    ] {
        rust_files(&Path::new(ROOT).join(dir), &mut files);
    }
    files
}

/// Every GPU buffer and bind group is created, every pass begun and every submission
/// made through the counting wrappers (`gpu/counted.rs`, `gpu/device.rs` of the engine),
/// so the counts the batch tests assert on are the whole truth.
#[test]
fn gpu_objects_are_created_only_through_the_counting_wrappers() {
    let raw = [
        ".create_buffer(",
        "create_buffer_init(",
        ".create_bind_group(",
        "begin_render_pass(",
        "begin_compute_pass(",
        "queue.submit(",
    ];
    let wrappers = ["counted.rs", "device.rs"];
    let mut files = Vec::new();
    rust_files(&Path::new(ROOT).join("crates/engine/src/gpu"), &mut files);
    assert!(files.len() > 15);
    let mut found = Vec::new();
    for f in &files {
        if wrappers.iter().any(|w| f.ends_with(w)) {
            continue;
        }
        let code = code_of(&std::fs::read_to_string(f).unwrap());
        for call in raw.iter().filter(|c| code.contains(*c)) {
            found.push(format!("{}: {call}", rel(f)));
        }
    }
    assert!(
        found.is_empty(),
        "use GpuDevice::buffer/bind_group/encoder/submit instead:\n{}",
        found.join("\n")
    );
}

#[test]
fn no_source_file_is_over_600_lines() {
    let files = every_rust_file();
    let long: Vec<String> = files
        .iter()
        .filter_map(|f| {
            let n = std::fs::read_to_string(f).ok()?.lines().count();
            (n > MAX_LINES).then(|| format!("{}: {n} lines", rel(f)))
        })
        .collect();
    assert!(files.len() > 60);
    assert!(long.is_empty(), "split these:\n{}", long.join("\n"));
}

#[test]
fn no_comment_points_outside_the_repository() {
    let mut files = every_rust_file();
    for doc in [
        "README.md",
        "ARCHITECTURE.md",
        "web/README.md",
        "deploy/README.md",
    ] {
        files.push(Path::new(ROOT).join(doc));
    }
    for doc in std::fs::read_dir(Path::new(ROOT).join("docs"))
        .unwrap()
        .flatten()
    {
        files.push(doc.path());
    }
    let design = ["DESIGN", ".md"].concat(); // not spelled out: this file would match
    let mut found = Vec::new();
    for f in &files {
        let text = std::fs::read_to_string(f).unwrap();
        for (n, line) in text.lines().enumerate() {
            let l = line.to_lowercase();
            let issue_number = l
                .match_indices("issue ")
                .any(|(i, _)| l[i + 6..].starts_with(|c: char| c.is_ascii_digit()));
            let seed_number = l
                .match_indices("seed 0")
                .any(|(i, _)| l[i + 5..].chars().take(3).all(|c| c.is_ascii_digit()));
            if line.contains(&design) || issue_number || seed_number {
                found.push(format!("{}:{}: {}", rel(f), n + 1, line.trim()));
            }
        }
    }
    assert!(
        found.is_empty(),
        "references a reader cannot follow:\n{}",
        found.join("\n")
    );
}
