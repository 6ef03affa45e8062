//! Crafted GLB files that ask a loader for far more than they hold: each is a few
//! hundred bytes to a few kilobytes, and each must be refused before anything is
//! decoded. Built here, from JSON and raw bytes, so the tests need no fixture files.

use homcull::core::scene::glb_container;
use serde_json::{Value, json};

/// One triangle's positions (3 × VEC3 f32 = 36 bytes) then its indices (3 × u32).
fn triangle_bin() -> Vec<u8> {
    let mut bin = Vec::new();
    for v in [[0.0f32, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]] {
        for c in v {
            bin.extend_from_slice(&c.to_le_bytes());
        }
    }
    for i in [0u32, 1, 2] {
        bin.extend_from_slice(&i.to_le_bytes());
    }
    bin
}

/// A document with one triangle mesh (accessor 0: positions, 1: indices), whose
/// `nodes`, `scene` roots and extra accessors/meshes the caller supplies.
fn with_triangle(nodes: Value, roots: Value, extra: impl FnOnce(&mut Value)) -> Vec<u8> {
    let bin = triangle_bin();
    let mut doc = json!({
        "asset": {"version": "2.0"},
        "scene": 0,
        "scenes": [{"nodes": roots}],
        "nodes": nodes,
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "indices": 1}]}],
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3",
             "min": [0.0, 0.0, 0.0], "max": [1.0, 1.0, 0.0]},
            {"bufferView": 1, "componentType": 5125, "count": 3, "type": "SCALAR"}
        ],
        "bufferViews": [
            {"buffer": 0, "byteOffset": 0, "byteLength": 36},
            {"buffer": 0, "byteOffset": 36, "byteLength": 12}
        ],
        "buffers": [{"byteLength": bin.len()}],
    });
    extra(&mut doc);
    glb_container(&doc, bin)
}

/// A valid one-triangle scene (the control: it must load).
pub fn one_triangle() -> Vec<u8> {
    with_triangle(json!([{"mesh": 0}]), json!([0]), |_| {})
}

/// A node that is its own child.
pub fn self_child() -> Vec<u8> {
    with_triangle(json!([{"mesh": 0, "children": [0]}]), json!([0]), |_| {})
}

/// Two nodes without meshes, each the other's child (a walk would never end).
pub fn cycle_without_mesh() -> Vec<u8> {
    with_triangle(
        json!([{"children": [1]}, {"children": [0]}, {"mesh": 0}]),
        json!([2, 0]),
        |_| {},
    )
}

/// Nodes nested `depth` deep, the innermost holding the mesh.
pub fn deep_nesting(depth: usize) -> Vec<u8> {
    let nodes: Vec<Value> = (0..depth)
        .map(|i| {
            if i + 1 < depth {
                json!({"children": [i + 1]})
            } else {
                json!({"mesh": 0})
            }
        })
        .collect();
    with_triangle(Value::Array(nodes), json!([0]), |_| {})
}

/// A position accessor of 3·10⁹ elements that is sparse (no buffer view: zeros, with
/// one element overridden): 36 GB if decoded.
pub fn huge_sparse_count() -> Vec<u8> {
    with_triangle(json!([{"mesh": 0}]), json!([0]), |doc| {
        doc["accessors"][0] = json!({
            "componentType": 5126, "count": 3_000_000_000u64, "type": "VEC3",
            "min": [0.0, 0.0, 0.0], "max": [1.0, 1.0, 0.0],
            "sparse": {"count": 1,
                       "indices": {"bufferView": 1, "componentType": 5125},
                       "values": {"bufferView": 0}}
        });
        doc["meshes"][0]["primitives"][0]
            .as_object_mut()
            .unwrap()
            .remove("indices");
    })
}

/// A position accessor declaring 2⁶² elements on a 36-byte buffer view.
pub fn accessor_count_2_pow_62() -> Vec<u8> {
    with_triangle(json!([{"mesh": 0}]), json!([0]), |doc| {
        doc["accessors"][0]["count"] = json!(1u64 << 62);
    })
}

/// An index accessor that claims more elements than its view holds.
pub fn accessor_past_its_view() -> Vec<u8> {
    with_triangle(json!([{"mesh": 0}]), json!([0]), |doc| {
        doc["accessors"][1]["count"] = json!(3_000);
    })
}

/// `primitives` primitives sharing one index accessor of `indices` indices: a
/// small file, `primitives × indices / 3` triangles.
pub fn shared_index_accessor(primitives: usize, indices: usize) -> Vec<u8> {
    let mut bin = triangle_bin();
    bin.truncate(36);
    let start = bin.len();
    for k in 0..indices {
        bin.extend_from_slice(&((k % 3) as u32).to_le_bytes());
    }
    let prims: Vec<Value> = (0..primitives)
        .map(|_| json!({"attributes": {"POSITION": 0}, "indices": 1}))
        .collect();
    let doc = json!({
        "asset": {"version": "2.0"},
        "scene": 0,
        "scenes": [{"nodes": [0]}],
        "nodes": [{"mesh": 0}],
        "meshes": [{"primitives": prims}],
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3",
             "min": [0.0, 0.0, 0.0], "max": [1.0, 1.0, 0.0]},
            {"bufferView": 1, "componentType": 5125, "count": indices, "type": "SCALAR"}
        ],
        "bufferViews": [
            {"buffer": 0, "byteOffset": 0, "byteLength": 36},
            {"buffer": 0, "byteOffset": start, "byteLength": indices * 4}
        ],
        "buffers": [{"byteLength": bin.len()}],
    });
    glb_container(&doc, bin)
}

/// One node with `children` children that all instance the triangle mesh.
pub fn many_instances(children: usize) -> Vec<u8> {
    let mut nodes = vec![json!({"children": (1..=children).collect::<Vec<_>>()})];
    nodes.extend((0..children).map(|_| json!({"mesh": 0})));
    with_triangle(Value::Array(nodes), json!([0]), |_| {})
}

/// A mesh of points only: objects, but no triangles.
pub fn no_triangles() -> Vec<u8> {
    with_triangle(json!([{"mesh": 0}]), json!([0]), |doc| {
        doc["meshes"][0]["primitives"][0]["mode"] = json!(0);
    })
}

/// Every file above that must be refused, by name.
pub fn all_refused() -> Vec<(&'static str, Vec<u8>)> {
    vec![
        ("self_child", self_child()),
        ("cycle_without_mesh", cycle_without_mesh()),
        ("deep_nesting", deep_nesting(200)),
        ("huge_sparse_count", huge_sparse_count()),
        ("accessor_count_2_pow_62", accessor_count_2_pow_62()),
        ("accessor_past_its_view", accessor_past_its_view()),
        (
            "shared_index_accessor",
            shared_index_accessor(1_000, 30_000),
        ),
        ("no_triangles", no_triangles()),
    ]
}
