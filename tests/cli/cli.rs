//! The binary's adapter choice from the command line: a `WGPU_ADAPTER_NAME` that matches
//! no adapter is a clear error under `HOMCULL_REQUIRE_GPU=1` and a CPU fallback with a
//! warning otherwise, never a panic.

use std::process::Command;

fn cull_demo(require_gpu: bool) -> std::process::Output {
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_homcull"));
    cmd.args([
        "cull",
        "--demo",
        "--pose",
        r#"{"position":[0,1.7,3],"look_at":[40,1.7,10],"viewport":[64,36]}"#,
    ])
    .env("WGPU_ADAPTER_NAME", "no adapter is called this")
    .env_remove("HOMCULL_REQUIRE_GPU");
    if require_gpu {
        cmd.env("HOMCULL_REQUIRE_GPU", "1");
    }
    cmd.output().expect("the binary runs")
}

#[test]
fn an_unknown_adapter_name_is_an_error_or_the_cpu_fallback() {
    let strict = cull_demo(true);
    let err = String::from_utf8_lossy(&strict.stderr);
    assert!(!strict.status.success(), "HOMCULL_REQUIRE_GPU=1 must fail");
    assert!(
        !err.contains("panicked"),
        "a panic instead of an error: {err}"
    );
    assert!(
        err.contains("WGPU_ADAPTER_NAME") && err.contains("matches none"),
        "the error names the variable: {err}"
    );

    let lenient = cull_demo(false);
    let err = String::from_utf8_lossy(&lenient.stderr);
    assert!(lenient.status.success(), "falls back to the CPU: {err}");
    assert!(err.contains("native CPU"), "says so: {err}");
    let out: serde_json::Value = serde_json::from_slice(&lenient.stdout).expect("JSON");
    assert!(!out["visible"].as_array().expect("visible IDs").is_empty());
}

#[test]
fn eval_on_the_native_backend_names_it_and_culls_conservatively() {
    let out = Command::new(env!("CARGO_BIN_EXE_homcull"))
        .args([
            "eval",
            "--demo",
            "--random",
            "6",
            "--viewport",
            "320x180",
            "--backend",
            "cpu",
            "--threads",
            "1",
            "--methods",
            "hom-refine,hom-raster",
            "--json",
        ])
        .output()
        .expect("the binary runs");
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{err}");
    assert!(err.contains("backend: cpu"), "names the backend: {err}");
    let report: serde_json::Value = serde_json::from_slice(&out.stdout).expect("JSON");
    assert!(
        report["adapter"].as_str().unwrap().contains("native CPU (")
            && report["adapter"].as_str().unwrap().contains("1 threads"),
        "{}",
        report["adapter"]
    );
    for m in ["hom-refine", "hom-raster"] {
        assert_eq!(report["methods"][m]["false_culls"], 0, "{m}");
    }
    assert!(
        report["methods"]["hom-refine"]["efficiency"]
            .as_f64()
            .unwrap()
            > 0.5
    );
    assert!(
        report["methods"]["hom-refine"]["ms_per_pose"]["p50"]
            .as_f64()
            .unwrap()
            > 0.0
    );
}

#[test]
fn an_unknown_backend_is_a_clear_error() {
    let out = Command::new(env!("CARGO_BIN_EXE_homcull"))
        .args(["eval", "--demo", "--random", "1", "--backend", "tpu"])
        .output()
        .expect("the binary runs");
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success());
    assert!(err.contains("unknown backend `tpu`"), "{err}");
}

/// README.md's "Command line" tables, between `<!-- flags:begin -->` and
/// `<!-- flags:end -->`, are what `homcull::cli::flags_table` makes from the clap
/// definitions; `HOMCULL_BLESS=1` writes them there.
#[test]
fn the_readme_lists_every_flag_as_help_has_it() {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("README.md");
    let readme = std::fs::read_to_string(&path).unwrap();
    let (begin, end) = ("<!-- flags:begin -->\n", "<!-- flags:end -->");
    let start = readme
        .find(begin)
        .expect("README.md has <!-- flags:begin -->")
        + begin.len();
    let stop = readme[start..]
        .find(end)
        .expect("README.md has <!-- flags:end -->")
        + start;
    let table = homcull::cli::flags_table();
    if std::env::var_os("HOMCULL_BLESS").is_some() {
        let blessed = format!("{}{}{}", &readme[..start], table, &readme[stop..]);
        std::fs::write(&path, blessed).unwrap();
        return;
    }
    assert!(
        readme[start..stop] == table,
        "README.md's flag tables are stale: run `HOMCULL_BLESS=1 cargo test --release --test cli`"
    );

    // And against what `--help` prints: every long flag of every subcommand's help has
    // a row in that subcommand's table, and every row's flag is in its help.
    let bin = env!("CARGO_BIN_EXE_homcull");
    let help = |args: &[&str]| {
        let out = Command::new(bin)
            .args(args)
            .output()
            .expect("the binary runs");
        assert!(out.status.success(), "{args:?} exits 0");
        String::from_utf8(out.stdout).unwrap()
    };
    let top = help(&["--help"]);
    let subcommands: Vec<String> = top
        .split("Commands:")
        .nth(1)
        .expect("--help lists commands")
        .lines()
        .skip(1) // the rest of the `Commands:` line
        .take_while(|l| !l.trim().is_empty())
        .filter(|l| !l.starts_with("   ")) // a wrapped description
        .filter_map(|l| l.split_whitespace().next())
        .filter(|s| *s != "help")
        .map(str::to_string)
        .collect();
    assert!(subcommands.iter().any(|s| s == "serve"), "{subcommands:?}");
    let sections: Vec<&str> = table.split("#### `homcull ").skip(1).collect();
    assert_eq!(
        sections.len(),
        subcommands.len(),
        "one table per subcommand"
    );
    for sub in &subcommands {
        let section = sections
            .iter()
            .find(|s| s.starts_with(&format!("{sub}`")))
            .unwrap_or_else(|| panic!("README has no table for `homcull {sub}`"));
        let rows: Vec<&str> = section.lines().filter(|l| l.starts_with("| `--")).collect();
        let in_help: Vec<String> = help(&[sub, "--help"])
            .lines()
            .filter_map(|l| {
                // An option's line is indented by at most 6 (`  -h, --help`,
                // `      --addr <ADDR>`); its wrapped description, deeper.
                let indent = l.len() - l.trim_start().len();
                if indent > 6 {
                    return None;
                }
                let l = l.trim_start();
                let l = l
                    .strip_prefix("-")
                    .filter(|r| !r.starts_with('-'))
                    .map_or(l, |r| r.split_once(", ").map_or(l, |(_, rest)| rest));
                let flag = l.strip_prefix("--")?.split([' ', '=', '\t']).next()?;
                (!flag.is_empty() && flag != "help").then(|| flag.to_string())
            })
            .collect();
        for flag in &in_help {
            assert!(
                rows.iter().any(|r| r.starts_with(&format!("| `--{flag}`"))),
                "`homcull {sub} --help` has --{flag}, README's table does not"
            );
        }
        for row in &rows {
            let flag = row["| `--".len()..].split('`').next().unwrap();
            assert!(
                in_help.iter().any(|f| f == flag),
                "README's table for `homcull {sub}` lists --{flag}, its --help does not"
            );
        }
    }
}
