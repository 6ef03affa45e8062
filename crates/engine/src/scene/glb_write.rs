//! Writes a scene as a GLB that thin clients can draw (the demo city has no file).
//!
//! One root node per object, in ID order, each with its own mesh (positions and
//! `u32` indices only; clients pick their own materials). Since object IDs are the
//! depth-first order of mesh-bearing nodes, loading the written file gives back the
//! same IDs, names and triangles.

use serde_json::json;

use super::Scene;

const GLB_MAGIC: u32 = 0x4654_6C67;
const CHUNK_JSON: u32 = 0x4E4F_534A;
const CHUNK_BIN: u32 = 0x004E_4942;

/// Encodes `scene` as a binary glTF 2.0 file.
pub fn write_glb(scene: &Scene) -> Vec<u8> {
    let mut bin: Vec<u8> = Vec::new();
    let (mut views, mut accessors, mut meshes, mut nodes) = (vec![], vec![], vec![], vec![]);
    for o in &scene.objects {
        let tris = scene.triangles_of(o);
        // Local vertex list: the object's vertices in first-use order.
        let mut remap = std::collections::HashMap::new();
        let mut local: Vec<glam::Vec3> = Vec::new();
        let indices: Vec<u32> = tris
            .iter()
            .map(|&i| {
                *remap.entry(i).or_insert_with(|| {
                    local.push(scene.positions[i as usize]);
                    (local.len() - 1) as u32
                })
            })
            .collect();
        let mesh = meshes.len();
        if !local.is_empty() {
            let (lo, hi) = local.iter().fold(
                (glam::Vec3::splat(f32::MAX), glam::Vec3::splat(f32::MIN)),
                |(a, b), &p| (a.min(p), b.max(p)),
            );
            let pos_view = views.len();
            views.push(json!({"buffer": 0, "byteOffset": bin.len(), "byteLength": local.len() * 12, "target": 34962}));
            bin.extend_from_slice(bytemuck::cast_slice(&local));
            let idx_view = views.len();
            views.push(json!({"buffer": 0, "byteOffset": bin.len(), "byteLength": indices.len() * 4, "target": 34963}));
            bin.extend_from_slice(bytemuck::cast_slice(&indices));
            let pos_acc = accessors.len();
            accessors.push(
                json!({"bufferView": pos_view, "componentType": 5126, "count": local.len(),
                "type": "VEC3", "min": lo.to_array(), "max": hi.to_array()}),
            );
            accessors.push(json!({"bufferView": idx_view, "componentType": 5125, "count": indices.len(), "type": "SCALAR"}));
            meshes.push(json!({"name": o.name, "primitives": [{"attributes": {"POSITION": pos_acc}, "indices": pos_acc + 1}]}));
        } else {
            // An object without triangles still needs a mesh to keep its ID.
            meshes.push(json!({"name": o.name, "primitives": []}));
        }
        let mut extras = json!({"homcull_id": o.id});
        if o.dynamic {
            extras["homcull"] = json!({"dynamic": true});
        }
        nodes.push(json!({"name": o.name, "mesh": mesh, "extras": extras}));
    }
    let doc = json!({
        "asset": {"version": "2.0", "generator": "homcull"},
        "scene": 0,
        "scenes": [{"name": scene.name, "nodes": (0..nodes.len()).collect::<Vec<_>>()}],
        "nodes": nodes,
        "meshes": meshes,
        "accessors": accessors,
        "bufferViews": views,
        "buffers": [{"byteLength": bin.len()}],
    });
    glb_container(&doc, bin)
}

/// A GLB file around a glTF JSON document and its binary chunk (both padded to 4
/// bytes as the format asks). `write_glb` uses it, and so do tests that craft files.
pub fn glb_container(doc: &serde_json::Value, mut bin: Vec<u8>) -> Vec<u8> {
    let mut json_bytes = serde_json::to_vec(doc).expect("JSON of plain values");
    while !json_bytes.len().is_multiple_of(4) {
        json_bytes.push(b' ');
    }
    while !bin.len().is_multiple_of(4) {
        bin.push(0);
    }
    let total = 12 + 8 + json_bytes.len() + 8 + bin.len();
    let mut out = Vec::with_capacity(total);
    for w in [
        GLB_MAGIC,
        2,
        total as u32,
        json_bytes.len() as u32,
        CHUNK_JSON,
    ] {
        out.extend_from_slice(&w.to_le_bytes());
    }
    out.extend_from_slice(&json_bytes);
    for w in [bin.len() as u32, CHUNK_BIN] {
        out.extend_from_slice(&w.to_le_bytes());
    }
    out.extend_from_slice(&bin);
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::{demo_city, load_glb_bytes};

    #[test]
    fn demo_city_round_trips_with_the_same_ids_names_and_triangles() {
        let scene = demo_city();
        let glb = write_glb(&scene);
        let back = load_glb_bytes(&glb, "demo").unwrap();
        assert_eq!(back.objects.len(), scene.objects.len());
        for (a, b) in scene.objects.iter().zip(&back.objects) {
            assert_eq!(
                (a.id, &a.name, a.triangles()),
                (b.id, &b.name, b.triangles())
            );
            assert!((a.aabb.min - b.aabb.min).abs().max_element() < 1e-4);
            assert!((a.aabb.max - b.aabb.max).abs().max_element() < 1e-4);
        }
    }
}
