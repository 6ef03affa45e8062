//! The browser client in `web/`: its JavaScript unit tests (`npm test`), the end-to-end
//! test of the viewer in headless Chromium against this crate's server binary
//! (`npm run e2e`), and a check that the committed `web/dist` is what the sources build to.
//!
//! They need Node.js and npm, `web/node_modules` (`npm ci` in `web/`) and, for the
//! end-to-end test, Chromium at `/usr/bin/chromium` (or `HOMCULL_CHROMIUM`). Without
//! them each test is skipped with a message, unless `CI` is set: then it fails.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn web_dir() -> PathBuf {
    PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/web"))
}

fn chromium() -> PathBuf {
    std::env::var_os("HOMCULL_CHROMIUM")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from("/usr/bin/chromium"))
}

fn runs(program: &str) -> bool {
    Command::new(program)
        .arg("--version")
        .output()
        .is_ok_and(|o| o.status.success())
}

/// Whether what the test needs is there; if not, skips (returns false) or, with `CI`
/// set, fails.
fn prerequisites(test: &str, need_chromium: bool) -> bool {
    let mut missing = Vec::new();
    if !runs("node") {
        missing.push("node (Node.js >= 20)".to_string());
    }
    if !runs("npm") {
        missing.push("npm".to_string());
    }
    if !web_dir().join("node_modules").is_dir() {
        missing.push("web/node_modules (run `npm ci` in web/)".to_string());
    }
    if need_chromium && !chromium().exists() {
        missing.push(format!(
            "{} (apt-get install chromium, or set HOMCULL_CHROMIUM)",
            chromium().display()
        ));
    }
    if missing.is_empty() {
        return true;
    }
    let msg = format!("{test}: missing {}", missing.join(", "));
    assert!(std::env::var_os("CI").is_none(), "CI is set but {msg}");
    eprintln!("SKIP: {msg}; set CI=1 to make this a failure");
    false
}

fn npm(args: &[&str], envs: &[(&str, &str)]) -> Output {
    let mut cmd = Command::new("npm");
    cmd.args(args).current_dir(web_dir());
    for (k, v) in envs {
        cmd.env(k, v);
    }
    let out = cmd
        .output()
        .unwrap_or_else(|e| panic!("cannot run npm {args:?}: {e}"));
    println!("{}", String::from_utf8_lossy(&out.stdout));
    eprintln!("{}", String::from_utf8_lossy(&out.stderr));
    out
}

#[test]
fn web_unit_tests() {
    if !prerequisites("web_unit_tests", false) {
        return;
    }
    let out = npm(&["test"], &[]);
    assert!(out.status.success(), "npm test failed: {}", out.status);
}

#[test]
fn web_e2e_in_chromium() {
    if !prerequisites("web_e2e_in_chromium", true) {
        return;
    }
    let out = npm(
        &["run", "e2e"],
        &[("HOMCULL_BIN", env!("CARGO_BIN_EXE_homcull"))],
    );
    assert!(
        out.status.success(),
        "npm run e2e failed: {} (screenshots and server log in web/test-artifacts)",
        out.status
    );
}

fn files(dir: &Path) -> Vec<(String, Vec<u8>)> {
    let mut out: Vec<_> = std::fs::read_dir(dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .map(|e| e.unwrap().path())
        .filter(|p| p.is_file())
        .map(|p| {
            let name = p.file_name().unwrap().to_string_lossy().into_owned();
            (name, std::fs::read(&p).unwrap())
        })
        .collect();
    out.sort();
    out
}

#[test]
fn web_dist_is_up_to_date() {
    if !prerequisites("web_dist_is_up_to_date", false) {
        return;
    }
    let tmp = std::env::temp_dir().join(format!("homcull-web-dist-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&tmp);
    let out = npm(
        &["run", "build", "--", "--outdir", tmp.to_str().unwrap()],
        &[],
    );
    assert!(out.status.success(), "npm run build failed: {}", out.status);
    let built = files(&tmp);
    let committed = files(&web_dir().join("dist"));
    let _ = std::fs::remove_dir_all(&tmp);
    let names = |v: &[(String, Vec<u8>)]| v.iter().map(|(n, _)| n.clone()).collect::<Vec<_>>();
    assert_eq!(
        names(&committed),
        names(&built),
        "web/dist has other files than a build gives: run `npm run build` in web/ and commit web/dist"
    );
    for ((name, a), (_, b)) in committed.iter().zip(&built) {
        assert!(
            a == b,
            "web/dist/{name} is stale: run `npm run build` in web/ and commit web/dist"
        );
    }
}
