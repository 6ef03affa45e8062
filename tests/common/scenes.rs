//! Scenes and settings the culling tests build: random box fields and the settings of
//! one method.

use glam::Vec3;
use homcull::core::cull::{CullSettings, PreparedScene};
use homcull::core::scene::{Scene, SceneBuilder};
use homcull_proto::{CullOptions, DebVariant, Method};

/// Settings for `method` at threshold 1.0 with the given DEB and refinement.
pub fn settings(
    prep: &PreparedScene,
    method: Method,
    deb: DebVariant,
    refine: bool,
) -> CullSettings {
    CullSettings::new(
        CullOptions {
            method,
            threshold: 1.0,
            deb,
            refine,
            lod: None,
        },
        prep,
    )
}

/// A random scene: a ground quad and boxes `(x, z, size x, size y, size z)` standing
/// on it, every face counter-clockwise seen from outside (glTF's front).
pub fn random_scene(boxes: &[(f32, f32, f32, f32, f32)]) -> Scene {
    let mut b = SceneBuilder::default();
    let g = [
        Vec3::new(-60.0, 0.0, -60.0),
        Vec3::new(60.0, 0.0, -60.0),
        Vec3::new(60.0, 0.0, 60.0),
        Vec3::new(-60.0, 0.0, 60.0),
    ];
    b.push("ground".into(), &g, &[0, 2, 1, 0, 3, 2], None);
    for (i, &(x, z, sx, sy, sz)) in boxes.iter().enumerate() {
        let (lo, hi) = (Vec3::new(x, 0.0, z), Vec3::new(x + sx, sy, z + sz));
        let c: Vec<Vec3> = (0..8)
            .map(|k| {
                Vec3::new(
                    if k & 1 == 0 { lo.x } else { hi.x },
                    if k & 2 == 0 { lo.y } else { hi.y },
                    if k & 4 == 0 { lo.z } else { hi.z },
                )
            })
            .collect();
        let idx = [
            0, 2, 1, 1, 2, 3, 4, 5, 6, 5, 7, 6, 0, 1, 4, 1, 5, 4, 2, 6, 3, 3, 6, 7, 0, 4, 2, 2, 4,
            6, 1, 3, 5, 3, 7, 5,
        ];
        b.push(format!("box_{i}"), &c, &idx, None);
    }
    b.build("random")
}

/// The shared real scenes every whole-scene test runs on, by name.
pub const SHARED_SCENES: [&str; 6] = [
    "munich",
    "etoile",
    "oa_shouse",
    "oa_dm1",
    "godot_room",
    "fzk_haus",
];

/// The demo city, then each of [`SHARED_SCENES`] where the scenes directory exists.
pub fn demo_and_shared() -> Vec<(String, Scene)> {
    let mut out = vec![("demo".to_string(), homcull::core::scene::demo_city())];
    if let Some(dir) = super::scenes_dir() {
        for name in SHARED_SCENES {
            let path = dir.join(format!("{name}.glb"));
            let scene = homcull::core::scene::load_path(&path)
                .unwrap_or_else(|e| panic!("{}: {e}", path.display()));
            out.push((name.to_string(), scene));
        }
    }
    out
}
