//! `homcull pvs` as a process: bad flags are clear errors, and a run writes the
//! documented file (docs/pvs.md).

use std::process::Command;

use crate::common;

fn pvs(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_homcull"))
        .arg("pvs")
        .args(args)
        .output()
        .expect("the binary runs")
}

#[test]
fn bad_pvs_flags_are_clear_errors() {
    let out = tempfile::tempdir().unwrap();
    let file = out.path().join("x.json");
    let file = file.to_str().unwrap();
    for (args, says) in [
        (
            vec!["--demo", "--cell-m", "0", "--out", file],
            "--cell-m must be in",
        ),
        (
            vec!["--demo", "--cell-m", "9", "--out", file],
            "--cell-m must be in",
        ),
        (
            vec!["--demo", "--method", "exact", "--out", file],
            "--method exact answers no region",
        ),
        (
            vec!["--demo", "--clusters", "1", "--out", file],
            "--clusters needs --cells clusters",
        ),
        (
            vec!["--demo", "--cells", "clusters", "--out", file],
            "carries no PVS of its own",
        ),
    ] {
        let o = pvs(&args);
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(!o.status.success(), "{args:?} succeeded");
        assert!(err.contains(says), "{args:?}: {err}");
    }
    assert!(
        !out.path().join("x.json").exists(),
        "no file from a refused run"
    );
}

#[test]
fn a_cluster_pvs_file_is_as_documented() {
    let Some(dir) = common::scenes_dir() else {
        return;
    };
    let out = tempfile::tempdir().unwrap();
    let file = out.path().join("dm1.pvs.json");
    let scene = dir.join("oa_dm1.glb");
    let o = pvs(&[
        "--scene",
        scene.to_str().unwrap(),
        "--cells",
        "clusters",
        "--clusters",
        "100",
        "--viewport",
        "320x180",
        "--out",
        file.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let doc: serde_json::Value = serde_json::from_slice(&std::fs::read(&file).unwrap()).unwrap();
    assert_eq!(doc["format"], "homcull-pvs");
    assert_eq!(doc["version"], 1);
    assert_eq!(doc["cells_by"], "clusters");
    let objects = doc["objects"].as_u64().unwrap();
    let boxes = doc["boxes"].as_array().unwrap().len();
    let cells = doc["cells"].as_array().unwrap();
    assert_eq!(cells.len(), 1);
    let cell = &cells[0];
    assert_eq!(cell["cluster"], 100);
    for b in cell["boxes"].as_array().unwrap() {
        assert!((b.as_u64().unwrap() as usize) < boxes);
    }
    // Sorted, disjoint, inclusive ranges of real IDs, as many as `count` says.
    let (mut count, mut after) = (0, None::<u64>);
    for r in cell["visible"].as_array().unwrap() {
        let (a, b) = (r[0].as_u64().unwrap(), r[1].as_u64().unwrap());
        assert!(
            a <= b && b < objects && after.is_none_or(|p| a > p + 1),
            "{r}"
        );
        count += b - a + 1;
        after = Some(b);
    }
    assert_eq!(count, cell["count"].as_u64().unwrap());
    assert!(count > 0);
}
