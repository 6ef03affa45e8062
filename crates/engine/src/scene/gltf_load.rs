//! glTF / GLB loading, geometry only.
//!
//! Images and textures are never read: a file whose images are missing or broken
//! still loads. Objects are the mesh-bearing nodes of the default scene in depth-first
//! order (the ID convention in ARCHITECTURE.md); vertices are transformed to world space at load, so every
//! later stage works in one space. Triangle strips and fans are converted to lists;
//! points and lines are skipped with a counted warning.
//!
//! Nothing is decoded before [`super::limits::check`] has bounded what the file asks
//! for (cycles, nesting, instancing, accessor sizes, triangle and byte totals); a scene
//! with no triangles at all is refused.

use std::path::Path;

use base64::Engine;
use glam::{Mat4, Vec3};
use gltf::mesh::Mode;

use super::limits::{LoadLimits, check};
use super::{Scene, SceneBuilder};

/// Why a scene file could not be loaded.
#[derive(Debug, thiserror::Error)]
pub enum LoadError {
    #[error("cannot read {path}: {source}")]
    Io {
        path: String,
        source: std::io::Error,
    },
    #[error("not a valid glTF/GLB file: {0}")]
    Gltf(#[from] gltf::Error),
    #[error("buffer {index}: {reason}")]
    Buffer { index: usize, reason: String },
    #[error("the file has no scene with mesh nodes")]
    NoObjects,
    #[error("the file's meshes hold no triangles")]
    NoTriangles,
    #[error("refused before decoding: {0}")]
    OverLimit(String),
    #[error("mesh {mesh} primitive {primitive}: {reason}")]
    Primitive {
        mesh: usize,
        primitive: usize,
        reason: String,
    },
}

/// Loads a `.glb` or `.gltf` file within the default [`LoadLimits`]; external buffers
/// are resolved next to it.
pub fn load_path(path: &Path) -> Result<Scene, LoadError> {
    load_path_within(path, &LoadLimits::default())
}

/// [`load_path`] within `limits`.
pub fn load_path_within(path: &Path, limits: &LoadLimits) -> Result<Scene, LoadError> {
    let bytes = std::fs::read(path).map_err(|source| LoadError::Io {
        path: path.display().to_string(),
        source,
    })?;
    let name = path
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| "scene".into());
    load(&bytes, &name, path.parent(), limits)
}

/// Loads a self-contained GLB (or glTF with data URIs) from memory within the default
/// [`LoadLimits`].
pub fn load_glb_bytes(bytes: &[u8], name: &str) -> Result<Scene, LoadError> {
    load_glb_bytes_within(bytes, name, &LoadLimits::default())
}

/// [`load_glb_bytes`] within `limits`.
pub fn load_glb_bytes_within(
    bytes: &[u8],
    name: &str,
    limits: &LoadLimits,
) -> Result<Scene, LoadError> {
    load(bytes, name, None, limits)
}

fn load(
    bytes: &[u8],
    name: &str,
    base: Option<&Path>,
    limits: &LoadLimits,
) -> Result<Scene, LoadError> {
    let gltf = gltf::Gltf::from_slice(bytes)?;
    check(&gltf, limits).map_err(LoadError::OverLimit)?;
    let buffers = read_buffers(&gltf, base)?;
    let scene = gltf
        .default_scene()
        .or_else(|| gltf.scenes().next())
        .ok_or(LoadError::NoObjects)?;

    let mut builder = SceneBuilder::default();
    let mut warnings = Vec::new();
    let mut stack: Vec<(gltf::Node, Mat4)> = scene.nodes().map(|n| (n, Mat4::IDENTITY)).collect();
    stack.reverse();
    while let Some((node, parent)) = stack.pop() {
        let world = parent * Mat4::from_cols_array_2d(&node.transform().matrix());
        if let Some(mesh) = node.mesh() {
            let (vertices, indices) = mesh_triangles(&mesh, world, &buffers, &mut warnings)?;
            let id = builder.objects.len();
            let name = node
                .name()
                .or(mesh.name())
                .map(str::to_owned)
                .unwrap_or_else(|| format!("object_{id}"));
            let extras = node
                .extras()
                .as_ref()
                .and_then(|raw| serde_json::from_str(raw.get()).ok());
            builder.push(name, &vertices, &indices, extras);
        }
        // Children go on the stack in reverse so the first child is visited first.
        for child in node.children().collect::<Vec<_>>().into_iter().rev() {
            stack.push((child, world));
        }
    }
    if builder.objects.is_empty() {
        return Err(LoadError::NoObjects);
    }
    let mut out = builder.build(name);
    if out.triangle_count() == 0 {
        return Err(LoadError::NoTriangles);
    }
    out.extras = scene
        .extras()
        .as_ref()
        .and_then(|raw| serde_json::from_str(raw.get()).ok());
    out.warnings = warnings;
    for w in &out.warnings {
        tracing::warn!(scene = name, "{w}");
    }
    Ok(out)
}

fn read_buffers(gltf: &gltf::Gltf, base: Option<&Path>) -> Result<Vec<Vec<u8>>, LoadError> {
    gltf.buffers()
        .map(|buffer| {
            let index = buffer.index();
            let err = |reason: String| LoadError::Buffer { index, reason };
            let data = match buffer.source() {
                gltf::buffer::Source::Bin => gltf
                    .blob
                    .clone()
                    .ok_or_else(|| err("GLB has no BIN chunk".into()))?,
                gltf::buffer::Source::Uri(uri) => {
                    if let Some(rest) = uri.strip_prefix("data:") {
                        let (_, payload) = rest
                            .split_once(";base64,")
                            .ok_or_else(|| err("data URI is not base64".into()))?;
                        base64::engine::general_purpose::STANDARD
                            .decode(payload)
                            .map_err(|e| err(format!("bad base64: {e}")))?
                    } else {
                        let base = base.ok_or_else(|| {
                            err(format!("external buffer `{uri}` needs a file path"))
                        })?;
                        if uri.contains("..") || uri.starts_with('/') {
                            return Err(err(format!(
                                "refusing buffer path `{uri}` outside the scene folder"
                            )));
                        }
                        std::fs::read(base.join(uri))
                            .map_err(|e| err(format!("cannot read `{uri}`: {e}")))?
                    }
                }
            };
            if data.len() < buffer.length() {
                return Err(err(format!(
                    "holds {} bytes, declares {}",
                    data.len(),
                    buffer.length()
                )));
            }
            Ok(data)
        })
        .collect()
}

/// World-space vertices and a triangle list for all triangle primitives of a mesh.
fn mesh_triangles(
    mesh: &gltf::Mesh,
    world: Mat4,
    buffers: &[Vec<u8>],
    warnings: &mut Vec<String>,
) -> Result<(Vec<Vec3>, Vec<u32>), LoadError> {
    let mut vertices = Vec::new();
    let mut indices = Vec::new();
    for prim in mesh.primitives() {
        let perr = |reason: &str| LoadError::Primitive {
            mesh: mesh.index(),
            primitive: prim.index(),
            reason: reason.into(),
        };
        let mode = prim.mode();
        if !matches!(
            mode,
            Mode::Triangles | Mode::TriangleStrip | Mode::TriangleFan
        ) {
            warnings.push(format!(
                "mesh {} primitive {}: {:?} primitives are not triangles, skipped",
                mesh.index(),
                prim.index(),
                mode
            ));
            continue;
        }
        let reader = prim.reader(|b| buffers.get(b.index()).map(|d| d.as_slice()));
        let Some(positions) = reader.read_positions() else {
            warnings.push(format!(
                "mesh {} primitive {}: no POSITION, skipped",
                mesh.index(),
                prim.index()
            ));
            continue;
        };
        let base = vertices.len() as u32;
        vertices.extend(positions.map(|p| world.transform_point3(Vec3::from(p))));
        let count = vertices.len() as u32 - base;
        if vertices[base as usize..].iter().any(|v| !v.is_finite()) {
            return Err(perr("non-finite vertex position"));
        }
        let local: Vec<u32> = match reader.read_indices() {
            Some(ix) => ix.into_u32().collect(),
            None => (0..count).collect(),
        };
        if local.iter().any(|&i| i >= count) {
            return Err(perr("index out of range"));
        }
        // Other modes were skipped above: what is left is a fan.
        #[allow(
            clippy::wildcard_enum_match_arm,
            reason = "gltf's Mode; only fans are left"
        )]
        let list = match mode {
            Mode::Triangles => local,
            Mode::TriangleStrip => (2..local.len())
                .flat_map(|i| {
                    if i % 2 == 0 {
                        [local[i - 2], local[i - 1], local[i]]
                    } else {
                        [local[i - 1], local[i - 2], local[i]]
                    }
                })
                .collect(),
            _ => (2..local.len())
                .flat_map(|i| [local[0], local[i - 1], local[i]])
                .collect(),
        };
        // A negative-determinant transform mirrors the mesh: flip winding to keep
        // counter-clockwise front faces.
        let flip = world.determinant() < 0.0;
        for t in list.chunks_exact(3) {
            if flip {
                indices.extend([base + t[0], base + t[2], base + t[1]]);
            } else {
                indices.extend([base + t[0], base + t[1], base + t[2]]);
            }
        }
    }
    Ok((vertices, indices))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn broken_input_is_an_error_not_a_panic() {
        assert!(load_glb_bytes(b"", "x").is_err());
        assert!(load_glb_bytes(b"glTF\x02\x00\x00\x00garbage", "x").is_err());
        assert!(load_glb_bytes(br#"{"asset":{"version":"2.0"}}"#, "x").is_err());
    }

    #[test]
    fn gltf_with_data_uri_and_missing_image_loads() {
        // One triangle, node translated by +10 in x, plus an image that does not exist.
        let verts: [f32; 9] = [0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0];
        let bytes: Vec<u8> = verts.iter().flat_map(|v| v.to_le_bytes()).collect();
        let b64 = base64::engine::general_purpose::STANDARD.encode(&bytes);
        let json = format!(
            r#"{{"asset":{{"version":"2.0"}},"scene":0,"scenes":[{{"nodes":[0]}}],
            "nodes":[{{"mesh":0,"translation":[10,0,0],"name":"tri"}}],
            "meshes":[{{"primitives":[{{"attributes":{{"POSITION":0}}}}]}}],
            "accessors":[{{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3","min":[0,0,0],"max":[1,1,0]}}],
            "bufferViews":[{{"buffer":0,"byteLength":36}}],
            "buffers":[{{"byteLength":36,"uri":"data:application/octet-stream;base64,{b64}"}}],
            "images":[{{"uri":"missing.png"}}]}}"#
        );
        let s = load_glb_bytes(json.as_bytes(), "t").unwrap();
        assert_eq!(s.objects.len(), 1);
        assert_eq!(s.objects[0].name, "tri");
        assert_eq!(s.objects[0].triangles(), 1);
        assert_eq!(s.objects[0].aabb.min, Vec3::new(10.0, 0.0, 0.0));
    }
}
