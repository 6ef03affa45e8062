//! What a scene file may cost before anything is decoded.
//!
//! A glTF file describes its geometry by counts (accessor counts, sparse counts, node
//! trees that instance meshes), so a few hundred bytes can ask for gigabytes or never
//! finish: a node that is its own child, an accessor of 2⁶² elements, a thousand
//! primitives sharing one huge index accessor, thirty thousand instances of one mesh.
//! [`check`] walks the node trees and every accessor a triangle primitive reads, and
//! refuses the file, naming what is over, before the loader allocates for it:
//!
//! - node trees: no node is its own ancestor, nesting at most [`LoadLimits::max_depth`],
//!   at most [`LoadLimits::max_nodes`] node visits counted through instancing;
//! - accessors: each fits its buffer view and the view its buffer (sparse indices and
//!   values too), and a sparse count is at most its accessor's count;
//! - totals over every instance: triangles at most [`LoadLimits::max_triangles`], and the
//!   decoded positions and indices at most [`LoadLimits::max_decoded_bytes`].

use gltf::accessor::sparse::IndexType;
use gltf::mesh::Mode;

/// Bounds on what loading one scene may take.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct LoadLimits {
    /// Most triangles, counted over every instance of every mesh.
    pub max_triangles: u64,
    /// Most bytes of decoded geometry (12 per vertex, 12 per triangle, per instance).
    pub max_decoded_bytes: u64,
    /// Deepest node nesting below a scene root.
    pub max_depth: usize,
    /// Most node visits when the trees are walked (instances count once each).
    pub max_nodes: u64,
}

impl Default for LoadLimits {
    fn default() -> Self {
        LoadLimits {
            max_triangles: 8_000_000,
            max_decoded_bytes: 1 << 30,
            max_depth: 64,
            max_nodes: 1_000_000,
        }
    }
}

/// What [`check`] counted.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Cost {
    pub nodes: u64,
    pub triangles: u64,
    pub decoded_bytes: u64,
}

/// Checks `doc`'s default scene (or its first) against `limits` without decoding.
pub fn check(doc: &gltf::Document, limits: &LoadLimits) -> Result<Cost, String> {
    let Some(scene) = doc.default_scene().or_else(|| doc.scenes().next()) else {
        return Ok(Cost::default());
    };
    let mesh_costs = doc
        .meshes()
        .map(|m| mesh_cost(&m, limits))
        .collect::<Result<Vec<_>, _>>()?;
    let mut cost = Cost::default();
    let mut on_path = vec![false; doc.nodes().len()];
    // (node, depth, leaving): an explicit stack, so a deep file cannot overflow ours.
    let mut stack: Vec<(gltf::Node, usize, bool)> = scene.nodes().map(|n| (n, 1, false)).collect();
    while let Some((node, depth, leaving)) = stack.pop() {
        let i = node.index();
        if leaving {
            on_path[i] = false;
            continue;
        }
        if on_path[i] {
            return Err(format!(
                "node {i} is its own ancestor (a cycle in the node tree)"
            ));
        }
        if depth > limits.max_depth {
            return Err(format!(
                "nodes nest deeper than {} levels (node {i})",
                limits.max_depth
            ));
        }
        cost.nodes += 1;
        if cost.nodes > limits.max_nodes {
            return Err(format!(
                "the node trees expand to more than {} node instances",
                limits.max_nodes
            ));
        }
        if let Some(m) = node.mesh() {
            let (triangles, bytes) = mesh_costs[m.index()];
            cost.triangles = cost.triangles.saturating_add(triangles);
            cost.decoded_bytes = cost.decoded_bytes.saturating_add(bytes);
            if cost.triangles > limits.max_triangles {
                return Err(format!(
                    "more than {} triangles (the limit of one scene)",
                    limits.max_triangles
                ));
            }
            if cost.decoded_bytes > limits.max_decoded_bytes {
                return Err(format!(
                    "decoded geometry over {} bytes (the limit of one scene)",
                    limits.max_decoded_bytes
                ));
            }
        }
        on_path[i] = true;
        stack.push((node.clone(), depth, true));
        for child in node.children() {
            stack.push((child, depth + 1, false));
        }
    }
    Ok(cost)
}

/// Triangles and decoded bytes of one instance of `mesh`, with every accessor its
/// triangle primitives read checked against its buffer.
fn mesh_cost(mesh: &gltf::Mesh, limits: &LoadLimits) -> Result<(u64, u64), String> {
    let (mut triangles, mut bytes) = (0u64, 0u64);
    for prim in mesh.primitives() {
        let mode = prim.mode();
        if !matches!(
            mode,
            Mode::Triangles | Mode::TriangleStrip | Mode::TriangleFan
        ) {
            continue;
        }
        let at = |what: &str| format!("mesh {} primitive {} {what}", mesh.index(), prim.index());
        let Some(pos) = prim.get(&gltf::Semantic::Positions) else {
            continue;
        };
        let vertices = accessor_count(&pos, limits).map_err(|e| at(&format!("POSITION: {e}")))?;
        let corners = match prim.indices() {
            Some(ix) => accessor_count(&ix, limits).map_err(|e| at(&format!("indices: {e}")))?,
            None => vertices,
        };
        #[allow(
            clippy::wildcard_enum_match_arm,
            reason = "gltf's Mode; strips and fans"
        )]
        let t = match mode {
            Mode::Triangles => corners / 3,
            _ => corners.saturating_sub(2),
        };
        triangles = triangles.saturating_add(t);
        bytes = bytes
            .saturating_add(vertices.saturating_mul(12))
            .saturating_add(t.saturating_mul(12));
    }
    Ok((triangles, bytes))
}

/// The element count of `acc`, once its data is known to fit where it points.
fn accessor_count(acc: &gltf::Accessor, limits: &LoadLimits) -> Result<u64, String> {
    let count = acc.count() as u64;
    let elem = acc.size() as u64;
    if count.saturating_mul(elem) > limits.max_decoded_bytes {
        return Err(format!("{count} elements are over the decoded-bytes limit"));
    }
    if let Some(view) = acc.view() {
        let stride = view.stride().map_or(elem, |s| s as u64);
        fits(&view, acc.offset() as u64, count, stride, elem)?;
    }
    if let Some(sparse) = acc.sparse() {
        let n = sparse.count() as u64;
        if n > count {
            return Err(format!("sparse count {n} exceeds the accessor's {count}"));
        }
        let ix = sparse.indices();
        let ix_size = match ix.index_type() {
            IndexType::U8 => 1,
            IndexType::U16 => 2,
            IndexType::U32 => 4,
        };
        fits(&ix.view(), ix.offset() as u64, n, ix_size, ix_size)?;
        let values = sparse.values();
        fits(&values.view(), values.offset() as u64, n, elem, elem)?;
    }
    Ok(count)
}

/// Whether `count` elements of `elem` bytes, `stride` apart from `offset`, lie in `view`
/// and the view in its buffer.
fn fits(
    view: &gltf::buffer::View,
    offset: u64,
    count: u64,
    stride: u64,
    elem: u64,
) -> Result<(), String> {
    let (view_offset, view_len) = (view.offset() as u64, view.length() as u64);
    if view_offset.saturating_add(view_len) > view.buffer().length() as u64 {
        return Err(format!("buffer view {} exceeds its buffer", view.index()));
    }
    if count == 0 {
        return Ok(());
    }
    let end = stride
        .checked_mul(count - 1)
        .and_then(|s| s.checked_add(offset))
        .and_then(|s| s.checked_add(elem));
    match end {
        Some(end) if end <= view_len => Ok(()),
        _ => Err(format!(
            "{count} elements exceed buffer view {} ({view_len} bytes)",
            view.index()
        )),
    }
}
