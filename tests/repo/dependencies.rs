//! The crates' dependency trees, as `cargo tree` lists them: the engine has no async
//! runtime, HTTP or command line; the server no evaluation, plotting or HTTP client,
//! and WebSocket framing only through axum (what the server image carries); the wire
//! crate no other layer. `tests/repo/architecture.rs` checks the module graph.

const ROOT: &str = env!("CARGO_MANIFEST_DIR");

/// `cargo tree` of one workspace crate, its normal dependencies only, one package a
/// line as `DEPTH NAME`.
fn normal_dependencies(package: &str) -> Vec<(usize, String)> {
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    let out = std::process::Command::new(cargo)
        .args([
            "tree",
            "--offline",
            "-e",
            "normal",
            "--prefix",
            "depth",
            "--format",
            "{p}",
        ])
        .args(["-p", package])
        .current_dir(ROOT)
        .output()
        .expect("cargo tree runs");
    assert!(
        out.status.success(),
        "cargo tree -p {package}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8(out.stdout)
        .unwrap()
        .lines()
        .filter_map(|l| {
            let digits = l.chars().take_while(char::is_ascii_digit).count();
            let depth = l[..digits].parse().ok()?;
            let name = l[digits..].split_whitespace().next()?.to_string();
            Some((depth, name))
        })
        .collect()
}

/// For each package named `name` in a `cargo tree` listing, the names of the packages
/// on its path from the root.
fn ancestors_of(tree: &[(usize, String)], name: &str) -> Vec<Vec<String>> {
    let mut path: Vec<String> = Vec::new();
    let mut found = Vec::new();
    for (depth, n) in tree {
        path.truncate(*depth);
        if n == name {
            found.push(path.clone());
        }
        path.push(n.clone());
    }
    found
}

#[test]
fn the_engine_has_no_runtime_http_or_command_line_and_the_server_no_evaluation() {
    let engine = normal_dependencies("homcull-engine");
    assert!(
        engine.len() > 20,
        "cargo tree lists the engine's dependencies"
    );
    for banned in [
        "tokio",
        "axum",
        "hyper",
        "clap",
        "homcull-server",
        "homcull-eval",
        "reqwest",
        "plotters",
    ] {
        assert!(
            engine.iter().all(|(_, n)| n != banned),
            "homcull-engine depends on {banned}: {:?}",
            ancestors_of(&engine, banned)
        );
    }
    let server = normal_dependencies("homcull-server");
    assert!(server.iter().any(|(_, n)| n == "homcull-engine"));
    for banned in ["homcull-eval", "reqwest", "plotters", "clap"] {
        assert!(
            server.iter().all(|(_, n)| n != banned),
            "homcull-server depends on {banned}: {:?}",
            ancestors_of(&server, banned)
        );
    }
    // WebSocket framing only through axum's `ws` feature.
    for path in ancestors_of(&server, "tungstenite") {
        assert!(
            path.iter().any(|n| n == "axum"),
            "homcull-server reaches tungstenite other than through axum: {path:?}"
        );
    }
    let proto = normal_dependencies("homcull-proto");
    assert!(
        proto
            .iter()
            .all(|(_, n)| !n.starts_with("homcull-") || n == "homcull-proto"),
        "the wire crate depends on no other layer"
    );
}
