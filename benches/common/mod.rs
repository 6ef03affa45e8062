//! What the benches share: the scenes they run on, by name.

use homcull::core::scene::{Scene, demo_city, load_path};

/// The demo city, or `NAME.glb` of the shared scenes (`HOMCULL_SCENES`, default
/// `../shared/scenes`); panics with the path when a file cannot be loaded.
pub fn scene_named(name: &str) -> Scene {
    if name == "demo" {
        return demo_city();
    }
    let dir = std::env::var("HOMCULL_SCENES").unwrap_or_else(|_| "../shared/scenes".into());
    let path = std::path::Path::new(&dir).join(format!("{name}.glb"));
    load_path(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}
