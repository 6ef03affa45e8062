//! Where moved objects are, for streams that ask (`?placements=true`): a thin client
//! draws the scene file, so it must also learn where the server's writers moved what
//! it draws. Before the frame answering a pose the stream sends a JSON text message
//!
//! ```json
//! {"placements": {"version": 7, "objects": [{"id": 12, "matrix": [16 numbers]}]}}
//! ```
//!
//! naming the scene version the answer was culled at, with the placement (column-major
//! 4×4, relative to the loaded scene; the identity for an object back home) of every
//! object in the streamed set whose placement the client has not been told yet. It is
//! sent when that list is not empty or the version changed; the binary frames are
//! unchanged.

use std::collections::HashMap;

use glam::Mat4;

use homcull_engine::cull::PoseResult;

const IDENTITY: [f32; 16] = Mat4::IDENTITY.to_cols_array();

/// What one client has been told.
#[derive(Default)]
pub(super) struct Told {
    version: Option<u64>,
    /// Placements sent, of objects not back home.
    matrices: HashMap<u32, [f32; 16]>,
}

impl Told {
    /// The message to send before the frame answering `r`, if any.
    pub(super) fn message(&mut self, r: &PoseResult) -> Option<String> {
        let version = r.stats.scene_version;
        let placed = r.placed.as_deref().unwrap_or(&[]);
        let mut objects = Vec::new();
        for &id in &r.visible {
            let now = match placed.binary_search_by_key(&id, |&(i, _)| i) {
                Ok(k) => placed[k].1,
                Err(_) => IDENTITY,
            };
            let told = self.matrices.get(&id).copied().unwrap_or(IDENTITY);
            if now != told {
                if now == IDENTITY {
                    self.matrices.remove(&id);
                } else {
                    self.matrices.insert(id, now);
                }
                objects.push(serde_json::json!({"id": id, "matrix": now}));
            }
        }
        if objects.is_empty() && self.version == Some(version) {
            return None;
        }
        self.version = Some(version);
        let msg = serde_json::json!({"placements": {"version": version, "objects": objects}});
        Some(msg.to_string())
    }
}

#[cfg(test)]
mod tests {
    use std::sync::Arc;

    use super::*;

    fn answer(version: u64, visible: &[u32], placed: &[(u32, [f32; 16])]) -> PoseResult {
        let mut r = PoseResult {
            visible: visible.to_vec(),
            candidates: visible.to_vec(),
            stats: Default::default(),
            placed: (!placed.is_empty()).then(|| Arc::from(placed)),
        };
        r.stats.scene_version = version;
        r
    }

    fn ids(msg: &str) -> Vec<u64> {
        let v: serde_json::Value = serde_json::from_str(msg).unwrap();
        let objects = v["placements"]["objects"].as_array().unwrap();
        objects.iter().map(|o| o["id"].as_u64().unwrap()).collect()
    }

    #[test]
    fn each_visible_placement_is_told_once_and_again_when_it_changes() {
        let mut told = Told::default();
        let moved = Mat4::from_translation(glam::Vec3::X).to_cols_array();
        let first = told
            .message(&answer(0, &[1, 2], &[]))
            .expect("the first names v0");
        assert!(ids(&first).is_empty());
        assert_eq!(told.message(&answer(0, &[1, 2], &[])), None, "nothing new");
        // Object 3 moved but is not visible: not told; object 2 is.
        let m = told
            .message(&answer(1, &[1, 2], &[(2, moved), (3, moved)]))
            .unwrap();
        assert_eq!(ids(&m), [2]);
        assert!(m.contains("\"version\":1"));
        assert_eq!(
            told.message(&answer(1, &[1, 2], &[(2, moved), (3, moved)])),
            None
        );
        // Object 3 comes into view: told now.
        let m = told
            .message(&answer(1, &[2, 3], &[(2, moved), (3, moved)]))
            .unwrap();
        assert_eq!(ids(&m), [3]);
        // Object 2 back home: told the identity.
        let m = told.message(&answer(2, &[2, 3], &[(3, moved)])).unwrap();
        assert_eq!(ids(&m), [2]);
        assert!(m.contains("[1.0,0.0,0.0,0.0,0.0,1.0"));
    }
}
