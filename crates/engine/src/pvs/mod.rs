//! The OpenArena potentially-visible set: a second, independent visibility oracle.
//!
//! Quake III maps ship a precomputed PVS: the map is cut into vis-clusters by a BSP
//! tree, and for each cluster a row lists the clusters that may be seen from it. The
//! OpenArena maps among the real test scenes (`oa_shouse.glb`, `oa_dm1.glb`) carry that
//! data in their glTF extras. It answers "may object o
//! be visible from point p?" conservatively and without rendering, which makes it
//! useful twice: to keep sampled cameras inside the playable space (a point in solid
//! has cluster −1), and as a cross-check of the exact oracle and of HOM (an object the
//! PVS rules out must never be seen).
//!
//! Every index in the data is checked once at parse time, so the queries never panic,
//! whatever the file held.

use glam::Vec3;
use serde_json::Value;

use crate::geom::Aabb;
use crate::scene::Scene;

/// Most clusters accepted; real Quake III maps have a few thousand at most. Bounds the
/// memory a malformed file can make us allocate.
pub const MAX_CLUSTERS: u64 = 1 << 16;

/// Why the PVS data of a scene cannot be used.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum PvsError {
    #[error("`{0}` is missing")]
    Missing(String),
    #[error("`{field}` must be {expected}")]
    Type {
        field: String,
        expected: &'static str,
    },
    #[error("`{field}` = {value} is out of range (allowed: {allowed})")]
    OutOfRange {
        field: String,
        value: i64,
        allowed: String,
    },
    #[error("num_clusters {0} exceeds the limit of {MAX_CLUSTERS}")]
    TooManyClusters(u64),
    #[error("the BSP tree has no nodes")]
    NoNodes,
    #[error("BSP node {0} is its own descendant (the tree has a cycle)")]
    Cycle(usize),
}

/// Where a BSP branch leads.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Child {
    Node(usize),
    Leaf(usize),
}

#[derive(Debug, Clone, Copy, PartialEq)]
struct BspNode {
    plane: usize,
    front: Child,
    back: Child,
}

/// What an object's visibility depends on.
#[derive(Debug, Clone, PartialEq)]
enum ObjectClusters {
    /// Visible from cluster c iff one of these (sorted) clusters is in c's row.
    Any(Vec<u32>),
    /// No usable cluster information: conservatively visible from everywhere.
    Unknown,
}

/// A map's BSP tree (to find a point's cluster) and PVS rows (what a cluster may see),
/// with each scene object's clusters.
#[derive(Debug, Clone, PartialEq)]
pub struct Pvs {
    /// Plane normal and distance: a point p is in front iff `n·p − d ≥ 0`.
    planes: Vec<(Vec3, f32)>,
    nodes: Vec<BspNode>,
    /// Cluster of each leaf, −1 for solid.
    leaf_cluster: Vec<i32>,
    /// Row c: the sorted clusters visible from cluster c; `None` if the file had no row
    /// for c (then c conservatively sees everything).
    visible: Vec<Option<Vec<u32>>>,
    /// Indexed by object ID.
    objects: Vec<ObjectClusters>,
}

impl Pvs {
    /// Parses the PVS from `scene.extras.pvs` and `scene.extras.bsp` plus each object's
    /// extras. `None` if the scene carries no PVS; an error if it carries a broken one.
    pub fn from_scene(scene: &Scene) -> Option<Result<Pvs, PvsError>> {
        let extras = scene.extras.as_ref()?;
        let pvs = extras.get("pvs")?;
        Some(Self::parse(pvs, extras.get("bsp"), scene))
    }

    fn parse(pvs: &Value, bsp: Option<&Value>, scene: &Scene) -> Result<Pvs, PvsError> {
        let bsp = bsp.ok_or_else(|| PvsError::Missing("bsp".into()))?;
        let num_clusters = parse_num_clusters(pvs)?;
        let visible = parse_rows(pvs, num_clusters)?;
        let planes = parse_planes(bsp)?;
        let leaf_cluster = parse_leaf_clusters(bsp, num_clusters)?;
        let nodes = parse_nodes(bsp, planes.len(), leaf_cluster.len())?;
        check_acyclic(&nodes)?;
        let objects = scene
            .objects
            .iter()
            .map(|o| parse_object(o.extras.as_ref(), &o.name, num_clusters))
            .collect::<Result<_, _>>()?;
        Ok(Pvs {
            planes,
            nodes,
            leaf_cluster,
            visible,
            objects,
        })
    }

    /// Number of clusters of the map (rows of the PVS).
    pub fn num_clusters(&self) -> usize {
        self.visible.len()
    }

    /// The vis-cluster containing `p`, or −1 if `p` is in solid space (outside the
    /// playable volume).
    pub fn cluster_at(&self, p: Vec3) -> i32 {
        let mut node = 0;
        // Parsing rejected cycles, so a walk takes at most `nodes.len()` steps; the
        // bound only keeps this loop obviously finite.
        for _ in 0..self.nodes.len() {
            let Some(n) = self.nodes.get(node) else {
                return -1;
            };
            let Some(&(normal, d)) = self.planes.get(n.plane) else {
                return -1;
            };
            let child = if normal.dot(p) - d >= 0.0 {
                n.front
            } else {
                n.back
            };
            match child {
                Child::Node(next) => node = next,
                Child::Leaf(leaf) => return self.leaf_cluster.get(leaf).copied().unwrap_or(-1),
            }
        }
        -1
    }

    /// The clusters of every leaf that box `b` may reach, ascending, solid left out:
    /// the tree walked with the box, both ways where it straddles a plane. A superset
    /// of the clusters of the points in `b` (a point's path is one of those walked);
    /// empty when the box lies in solid only.
    pub fn clusters_touching(&self, b: &Aabb) -> Vec<i32> {
        let (centre, half) = (b.center(), b.extent() * 0.5);
        let mut found = Vec::new();
        let mut stack = vec![(0usize, 0usize)];
        while let Some((node, depth)) = stack.pop() {
            // Parsing rejected cycles; the depth bound only keeps this obviously finite.
            let (Some(n), true) = (self.nodes.get(node), depth <= self.nodes.len()) else {
                continue;
            };
            let Some(&(normal, d)) = self.planes.get(n.plane) else {
                continue;
            };
            let (at, reach) = (normal.dot(centre) - d, normal.abs().dot(half));
            let sides = [(n.front, at + reach >= 0.0), (n.back, at - reach < 0.0)];
            for (child, reached) in sides {
                match (child, reached) {
                    (Child::Node(next), true) => stack.push((next, depth + 1)),
                    (Child::Leaf(leaf), true) => {
                        if let Some(&c) = self.leaf_cluster.get(leaf).filter(|&&c| c >= 0) {
                            found.push(c);
                        }
                    }
                    _ => {}
                }
            }
        }
        found.sort_unstable();
        found.dedup();
        found
    }

    /// Whether `object` may be visible from a camera in `cluster`. False from solid
    /// (cluster < 0); true whenever the data cannot rule it out (object without
    /// cluster information, unknown object or cluster, missing PVS row).
    pub fn may_see(&self, cluster: i32, object: u32) -> bool {
        let Ok(cluster) = usize::try_from(cluster) else {
            return false;
        };
        let Some(Some(row)) = self.visible.get(cluster) else {
            return true;
        };
        match self.objects.get(object as usize) {
            Some(ObjectClusters::Any(clusters)) => {
                clusters.iter().any(|c| row.binary_search(c).is_ok())
            }
            Some(ObjectClusters::Unknown) | None => true,
        }
    }

    /// Whether cluster `to` is in the PVS row of cluster `from`: false from solid, true
    /// for a point in solid (`to` < 0: geometry surfaces sit on solid boundaries) and
    /// whenever the data cannot rule it out (missing row, unknown cluster).
    pub fn cluster_may_see(&self, from: i32, to: i32) -> bool {
        let Ok(from) = usize::try_from(from) else {
            return false;
        };
        let Ok(to) = u32::try_from(to) else {
            return true;
        };
        match self.visible.get(from) {
            Some(Some(row)) => row.binary_search(&to).is_ok(),
            _ => true,
        }
    }

    /// IDs of the objects that may be visible from `cluster`, ascending.
    pub fn visible_objects(&self, cluster: i32) -> Vec<u32> {
        (0..self.objects.len() as u32)
            .filter(|&o| self.may_see(cluster, o))
            .collect()
    }
}

/// `pvs.num_clusters`, bounded.
fn parse_num_clusters(pvs: &Value) -> Result<usize, PvsError> {
    let n = field(pvs, "num_clusters", "pvs.num_clusters")?;
    let n = n
        .as_u64()
        .ok_or_else(|| type_error("pvs.num_clusters", "a non-negative integer"))?;
    if n > MAX_CLUSTERS {
        return Err(PvsError::TooManyClusters(n));
    }
    Ok(n as usize)
}

/// `pvs.visible`: `{"<c>": [cluster ids]}` into sorted rows indexed by cluster.
fn parse_rows(pvs: &Value, num_clusters: usize) -> Result<Vec<Option<Vec<u32>>>, PvsError> {
    let rows = field(pvs, "visible", "pvs.visible")?;
    let rows = rows
        .as_object()
        .ok_or_else(|| type_error("pvs.visible", "an object"))?;
    let mut visible = vec![None; num_clusters];
    for (key, list) in rows {
        let path = format!("pvs.visible.{key}");
        let c: i64 = key
            .parse()
            .map_err(|_| type_error(&path, "keyed by an integer cluster id"))?;
        let c = cluster_index(c, num_clusters, &path)?;
        let mut row = cluster_list(list, num_clusters, &path)?;
        row.sort_unstable();
        row.dedup();
        visible[c as usize] = Some(row);
    }
    Ok(visible)
}

/// `bsp.planes`: `[[nx, ny, nz, d]]`, finite.
fn parse_planes(bsp: &Value) -> Result<Vec<(Vec3, f32)>, PvsError> {
    let planes = array(field(bsp, "planes", "bsp.planes")?, "bsp.planes")?;
    planes
        .iter()
        .enumerate()
        .map(|(i, plane)| {
            let path = format!("bsp.planes[{i}]");
            let v = array(plane, &path)?;
            let numbers: Option<Vec<f32>> =
                v.iter().map(|x| x.as_f64().map(|x| x as f32)).collect();
            match numbers.as_deref() {
                Some(&[nx, ny, nz, d]) if [nx, ny, nz, d].iter().all(|x| x.is_finite()) => {
                    Ok((Vec3::new(nx, ny, nz), d))
                }
                _ => Err(type_error(&path, "[nx, ny, nz, d] of finite numbers")),
            }
        })
        .collect()
}

/// `bsp.leaf_cluster`: each −1 (solid) or a cluster id.
fn parse_leaf_clusters(bsp: &Value, num_clusters: usize) -> Result<Vec<i32>, PvsError> {
    let leaves = array(
        field(bsp, "leaf_cluster", "bsp.leaf_cluster")?,
        "bsp.leaf_cluster",
    )?;
    leaves
        .iter()
        .enumerate()
        .map(|(i, c)| {
            let path = format!("bsp.leaf_cluster[{i}]");
            match integer(c, &path)? {
                -1 => Ok(-1),
                c => cluster_index(c, num_clusters, &path).map(|c| c as i32),
            }
        })
        .collect()
}

/// `bsp.nodes`: `[[plane, front, back]]` with every reference in range.
fn parse_nodes(
    bsp: &Value,
    num_planes: usize,
    num_leaves: usize,
) -> Result<Vec<BspNode>, PvsError> {
    let nodes = array(field(bsp, "nodes", "bsp.nodes")?, "bsp.nodes")?;
    if nodes.is_empty() {
        return Err(PvsError::NoNodes);
    }
    let num_nodes = nodes.len();
    nodes
        .iter()
        .enumerate()
        .map(|(i, node)| {
            let path = format!("bsp.nodes[{i}]");
            let [plane, front, back] = array(node, &path)?.as_slice() else {
                return Err(type_error(&path, "[plane, front, back]"));
            };
            let plane = integer(plane, &format!("{path}[0]"))?;
            let plane = usize::try_from(plane)
                .ok()
                .filter(|&p| p < num_planes)
                .ok_or_else(|| {
                    out_of_range(&format!("{path}[0]"), plane, format!("0..{num_planes}"))
                })?;
            let child = |v: &Value, slot: usize| {
                parse_child(v, &format!("{path}[{slot}]"), num_nodes, num_leaves)
            };
            Ok(BspNode {
                plane,
                front: child(front, 1)?,
                back: child(back, 2)?,
            })
        })
        .collect()
}

/// A node child: `c ≥ 0` is node c, `c < 0` is leaf −(c+1).
fn parse_child(
    v: &Value,
    path: &str,
    num_nodes: usize,
    num_leaves: usize,
) -> Result<Child, PvsError> {
    let c = integer(v, path)?;
    let allowed = || format!("-{num_leaves}..{num_nodes}");
    if c >= 0 {
        let node = c as usize;
        return if c < num_nodes as i64 {
            Ok(Child::Node(node))
        } else {
            Err(out_of_range(path, c, allowed()))
        };
    }
    let leaf = -(c + 1);
    if leaf < num_leaves as i64 {
        Ok(Child::Leaf(leaf as usize))
    } else {
        Err(out_of_range(path, c, allowed()))
    }
}

/// Rejects a tree in which some node can reach itself (a walk would never end).
fn check_acyclic(nodes: &[BspNode]) -> Result<(), PvsError> {
    const UNSEEN: u8 = 0;
    const ON_PATH: u8 = 1;
    const DONE: u8 = 2;
    let mut state = vec![UNSEEN; nodes.len()];
    // Depth-first from the root; each entry is a node and how many children were visited.
    let mut stack = vec![(0usize, 0usize)];
    state[0] = ON_PATH;
    while let Some(top) = stack.last_mut() {
        let (node, visited) = *top;
        let children = [nodes[node].front, nodes[node].back];
        let Some(&child) = children.get(visited) else {
            state[node] = DONE;
            stack.pop();
            continue;
        };
        top.1 += 1;
        if let Child::Node(c) = child {
            match state[c] {
                ON_PATH => return Err(PvsError::Cycle(c)),
                UNSEEN => {
                    state[c] = ON_PATH;
                    stack.push((c, 0));
                }
                _ => {}
            }
        }
    }
    Ok(())
}

/// An object's clusters from its node extras: `ref_clusters` if non-empty, else
/// `cluster` (brush models); neither, or cluster −1, means unknown.
fn parse_object(
    extras: Option<&Value>,
    name: &str,
    num_clusters: usize,
) -> Result<ObjectClusters, PvsError> {
    let Some(extras) = extras else {
        return Ok(ObjectClusters::Unknown);
    };
    if let Some(refs) = extras.get("ref_clusters") {
        let mut refs = cluster_list(refs, num_clusters, &format!("{name}.ref_clusters"))?;
        if !refs.is_empty() {
            refs.sort_unstable();
            refs.dedup();
            return Ok(ObjectClusters::Any(refs));
        }
    }
    let Some(cluster) = extras.get("cluster") else {
        return Ok(ObjectClusters::Unknown);
    };
    let path = format!("{name}.cluster");
    match integer(cluster, &path)? {
        -1 => Ok(ObjectClusters::Unknown),
        c => Ok(ObjectClusters::Any(vec![cluster_index(
            c,
            num_clusters,
            &path,
        )?])),
    }
}

/// A JSON array of cluster ids, each in `0..num_clusters`.
fn cluster_list(v: &Value, num_clusters: usize, path: &str) -> Result<Vec<u32>, PvsError> {
    array(v, path)?
        .iter()
        .enumerate()
        .map(|(i, c)| {
            let item = format!("{path}[{i}]");
            cluster_index(integer(c, &item)?, num_clusters, &item)
        })
        .collect()
}

fn cluster_index(c: i64, num_clusters: usize, path: &str) -> Result<u32, PvsError> {
    if (0..num_clusters as i64).contains(&c) {
        Ok(c as u32)
    } else {
        Err(out_of_range(path, c, format!("0..{num_clusters}")))
    }
}

fn field<'a>(v: &'a Value, key: &str, path: &str) -> Result<&'a Value, PvsError> {
    v.get(key)
        .ok_or_else(|| PvsError::Missing(path.to_string()))
}

fn array<'a>(v: &'a Value, path: &str) -> Result<&'a Vec<Value>, PvsError> {
    v.as_array().ok_or_else(|| type_error(path, "an array"))
}

fn integer(v: &Value, path: &str) -> Result<i64, PvsError> {
    v.as_i64().ok_or_else(|| type_error(path, "an integer"))
}

fn type_error(path: &str, expected: &'static str) -> PvsError {
    PvsError::Type {
        field: path.to_string(),
        expected,
    }
}

fn out_of_range(path: &str, value: i64, allowed: String) -> PvsError {
    PvsError::OutOfRange {
        field: path.to_string(),
        value,
        allowed,
    }
}

#[cfg(test)]
mod tests;
