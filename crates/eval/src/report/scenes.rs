//! The report's scenes: the demo city and every `.glb` of the scenes dir, each with its
//! PVS where it carries one, and the street-level poses the sections sample on them.

use std::path::{Path, PathBuf};

use anyhow::{Context, Result};

use super::context::{SEED, progress};
use homcull_engine::camera::Camera;
use homcull_engine::pvs::Pvs;
use homcull_engine::resident::{parse_pvs, sample_poses};
use homcull_engine::scene::{Scene, demo_city, load_path};
use homcull_proto::Pose;

/// One scene of the report with its PVS (OpenArena maps) when it has one.
pub(super) struct Loaded {
    pub(super) scene: Scene,
    pub(super) pvs: Option<Pvs>,
}

impl Loaded {
    pub(super) fn new(scene: Scene) -> Self {
        let pvs = parse_pvs(&scene);
        Loaded { scene, pvs }
    }

    /// `n` random street-level poses (eyes inside a PVS cluster where there is a PVS).
    pub(super) fn poses(&self, n: usize, viewport: [u32; 2]) -> Vec<Pose> {
        let res = sample_poses(&self.scene, self.pvs.as_ref(), n, SEED, viewport);
        if res.poses.len() < n {
            eprintln!(
                "warning: {}: only {} of {n} poses found",
                self.scene.name,
                res.poses.len()
            );
        }
        res.poses
    }

    /// The cameras of [`Loaded::poses`].
    pub(super) fn cams(&self, n: usize, viewport: [u32; 2]) -> Result<Vec<Camera>> {
        self.poses(n, viewport)
            .iter()
            .map(|p| Camera::new(p).map_err(anyhow::Error::from))
            .collect()
    }
}
/// The demo city and every `.glb` of `dir` (sorted by name).
pub(super) fn load_scenes(dir: &Path) -> Result<Vec<Loaded>> {
    let mut files: Vec<PathBuf> = match std::fs::read_dir(dir) {
        Ok(rd) => rd
            .filter_map(|e| e.ok().map(|e| e.path()))
            .filter(|p| p.extension().is_some_and(|e| e.eq_ignore_ascii_case("glb")))
            .collect(),
        Err(e) => {
            eprintln!(
                "warning: scenes dir {}: {e}; only the demo city is reported",
                dir.display()
            );
            Vec::new()
        }
    };
    files.sort();
    let n = files.len() + 1;
    progress("loading scenes", 0, n, "demo city");
    let mut scenes = vec![Loaded::new(demo_city())];
    for (i, f) in files.iter().enumerate() {
        progress("loading scenes", i + 1, n, &f.display().to_string());
        let scene = load_path(f).with_context(|| format!("loading {}", f.display()))?;
        scenes.push(Loaded::new(scene));
    }
    Ok(scenes)
}
