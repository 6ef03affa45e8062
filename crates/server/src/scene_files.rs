//! Scenes the operator names at start (`--scene FILE`, `HOMCULL_SCENES`): served
//! read-only beside the demo and the uploads, under the file's name.
//!
//! They are parsed before the server listens, so a missing or broken file stops it with
//! a clear message instead of leaving a scene silently absent; their GPU upload and
//! occluder database are built in the background like the demo's (`/readyz` waits).
//! They never enter the data dir: deleting one is refused, and rescans leave them be.

use std::path::{Path, PathBuf};

use super::store::valid_id;
use homcull_engine::scene::{LoadLimits, Scene, load_path_within, write_glb};

/// Longest id derived from a file name.
const MAX_ID_LEN: usize = 64;

/// A parsed `--scene` file.
pub struct SceneFile {
    /// The file name without its extension, e.g. `munich` for `scenes/munich.glb`.
    pub id: String,
    pub path: PathBuf,
    pub scene: Scene,
    /// What clients download (`GET /v1/scenes/{id}/glb`).
    pub glb: Glb,
}

/// A binary glTF is served from its file; a JSON glTF (whose buffers may be other
/// files) is served as a GLB written from the parsed scene, held in memory: one node
/// per object in ID order, so object IDs still name the same meshes.
pub enum Glb {
    File { bytes: u64 },
    Written(Vec<u8>),
}

/// Parses every file, or says which one cannot be served and why.
pub fn load_all(paths: &[PathBuf], limits: &LoadLimits) -> Result<Vec<SceneFile>, String> {
    let mut files: Vec<SceneFile> = Vec::with_capacity(paths.len());
    for path in paths {
        let id = id_of(path)?;
        if let Some(other) = files.iter().find(|f| f.id == id) {
            return Err(format!(
                "--scene {} and {} would both be served as `{id}`: rename one",
                other.path.display(),
                path.display()
            ));
        }
        let bytes = std::fs::metadata(path)
            .map_err(|e| format!("--scene {}: {e}", path.display()))?
            .len();
        let scene = load_path_within(path, limits)
            .map_err(|e| format!("--scene {}: {e}", path.display()))?;
        let glb = if is_glb(path) {
            Glb::File { bytes }
        } else {
            Glb::Written(write_glb(&scene))
        };
        files.push(SceneFile {
            id,
            path: path.clone(),
            scene,
            glb,
        });
    }
    Ok(files)
}

/// Whether the file starts with the binary glTF magic.
fn is_glb(path: &Path) -> bool {
    let mut magic = [0u8; 4];
    std::fs::File::open(path)
        .and_then(|mut f| std::io::Read::read_exact(&mut f, &mut magic))
        .is_ok_and(|()| &magic == b"glTF")
}

/// The scene id a file is served under: its name without the extension, which must be
/// lowercase letters, digits, `_` or `-`, and must not look like an upload's id.
pub fn id_of(path: &Path) -> Result<String, String> {
    let stem = path
        .file_stem()
        .and_then(|s| s.to_str())
        .unwrap_or_default();
    let allowed = |b: u8| b.is_ascii_lowercase() || b.is_ascii_digit() || b == b'_' || b == b'-';
    if stem.is_empty() || stem.len() > MAX_ID_LEN || !stem.bytes().all(allowed) {
        return Err(format!(
            "--scene {}: the file name (without extension) is the scene id and must be 1–{MAX_ID_LEN} \
             of a–z, 0–9, `_`, `-`",
            path.display()
        ));
    }
    if stem == "demo" || valid_id(stem) {
        return Err(format!(
            "--scene {}: `{stem}` is reserved (the demo, or an upload's id): rename the file",
            path.display()
        ));
    }
    Ok(stem.to_string())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ids_come_from_file_names() {
        assert_eq!(id_of(Path::new("../scenes/munich.glb")).unwrap(), "munich");
        assert_eq!(id_of(Path::new("oa_dm1.gltf")).unwrap(), "oa_dm1");
        assert_eq!(id_of(Path::new("a-b_2")).unwrap(), "a-b_2");
        for bad in [
            "Munich.glb",
            "my scene.glb",
            "demo.glb",
            "0123456789abcdef.glb",
            ".glb",
        ] {
            assert!(id_of(Path::new(bad)).is_err(), "{bad} accepted");
        }
        assert!(id_of(Path::new(&format!("{}.glb", "a".repeat(65)))).is_err());
    }

    #[test]
    fn bad_files_are_named() {
        let dir = tempfile::tempdir().unwrap();
        let missing = dir.path().join("gone.glb");
        let err = load_all(&[missing], &LoadLimits::default()).err().unwrap();
        assert!(err.contains("gone.glb"), "{err}");

        let broken = dir.path().join("broken.glb");
        std::fs::write(&broken, b"not a glb").unwrap();
        let err = load_all(&[broken], &LoadLimits::default()).err().unwrap();
        assert!(err.contains("broken.glb"), "{err}");

        let glb = homcull_engine::scene::write_glb(&homcull_engine::scene::demo_city_sized(2));
        let (a, b) = (dir.path().join("x/city.glb"), dir.path().join("y/city.glb"));
        for p in [&a, &b] {
            std::fs::create_dir_all(p.parent().unwrap()).unwrap();
            std::fs::write(p, &glb).unwrap();
        }
        let one = load_all(std::slice::from_ref(&a), &LoadLimits::default()).unwrap();
        assert_eq!(one[0].id, "city");
        assert!(matches!(one[0].glb, Glb::File { bytes } if bytes == glb.len() as u64));
        let err = load_all(&[a, b], &LoadLimits::default()).err().unwrap();
        assert!(err.contains("both be served as `city`"), "{err}");
    }

    /// A JSON glTF with its buffer inline: one triangle, one mesh node.
    const TRIANGLE_GLTF: &str = r#"{
        "asset": {"version": "2.0"},
        "scene": 0, "scenes": [{"nodes": [0]}],
        "nodes": [{"name": "tri", "mesh": 0}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0}}]}],
        "accessors": [{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3",
                       "min": [0, 0, 0], "max": [1, 1, 0]}],
        "bufferViews": [{"buffer": 0, "byteLength": 36}],
        "buffers": [{"byteLength": 36,
            "uri": "data:application/octet-stream;base64,AAAAAAAAAAAAAAAAAACAPwAAAAAAAAAAAAAAAAAAgD8AAAAA"}]
    }"#;

    #[test]
    fn json_gltf_is_served_as_a_written_glb() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("tri.gltf");
        std::fs::write(&path, TRIANGLE_GLTF).unwrap();
        let files = load_all(&[path], &LoadLimits::default()).unwrap();
        assert_eq!(
            (files[0].id.as_str(), files[0].scene.objects.len()),
            ("tri", 1)
        );
        let Glb::Written(bytes) = &files[0].glb else {
            panic!("a JSON glTF must be re-encoded");
        };
        assert_eq!(&bytes[..4], b"glTF");
        let again = homcull_engine::scene::load_glb_bytes(bytes, "tri").unwrap();
        assert_eq!(again.objects.len(), 1);
        assert_eq!(again.triangle_count(), 1);
    }
}
