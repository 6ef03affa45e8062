//! `homcull cull`: one pose on one scene, the answer as JSON on stdout.

use anyhow::{Context, Result};
use homcull_proto::{CullResponse, Pose};

use super::args::CullArgs;
use super::{load_scene, open_backend};
use crate::core::camera::stereo;
use crate::core::cull::PoseResult;
use crate::core::lod;
use crate::core::resident::{Residency, ResidentScene};

pub fn run(a: CullArgs) -> Result<()> {
    let pose: Pose = serde_json::from_str(&a.pose).context("parsing --pose")?;
    let eyes = stereo::eyes(&pose)?;
    let options = a.params.options(a.method, a.lod_px.clone())?;
    options.validate()?;
    let scene = load_scene(&a.scene)?;
    let mut resident = ResidentScene::assemble(
        scene,
        Residency::evaluation(a.params.occluder_params()),
        open_backend(&a.backend)?,
    );
    let settings = resident.engine.settings(options);
    let results = resident.engine.cull(&eyes, &settings)?;
    let r = PoseResult::union_of(results).context("a pose has at least one eye")?;
    let lod = options.lod.map(|t| {
        let objects = &resident.engine.prepared.scene.objects;
        lod::levels(&eyes, &r.visible, |id| objects[id as usize].aabb, &t)
    });
    let out = CullResponse {
        visible: r.visible,
        lod,
        stats: r.stats,
    };
    println!("{}", serde_json::to_string(&out)?);
    Ok(())
}
