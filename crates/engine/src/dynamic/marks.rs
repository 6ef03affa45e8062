//! Objects marked dynamic in advance: by the file (glTF node extras
//! `"homcull": {"dynamic": true}`) or by the upload (`?dynamic=car_*,door_1`).
//!
//! Any object may receive a transform, marked or not; a mark says ahead of time which
//! ones will, so that it is checked once at load instead of at the first update, and
//! so that clients can keep those objects out of what they cache as static (merged
//! draw batches, baked lighting): the objects list and the scene's info report it.
//!
//! homcull itself keeps nothing a move would make stale. Each scene version is built
//! from the loaded geometry (`snapshot::advance`), the object and occluder BVHs are
//! refitted or rebuilt, the GPU's placement matrices and test boxes are rewritten,
//! and the stored occluder list (`occluders.json`, a qualification by size and
//! triangle count) holds whatever rigid motion does to an object; a scaled object
//! that no longer qualifies only costs culling, never correctness. So a mark changes
//! no answer: a marked object that has not moved is culled, refined and occludes as
//! any other.
//!
//! What is checked: an object that shares vertices with another cannot move alone
//! (`TransformError::SharedVertices` at the update); a marked one is refused at
//! load, naming it. Patterns name objects exactly, or by a prefix ending in `*`; each
//! must match some object.

use crate::cull::has_bit;
use crate::scene::Scene;

use super::snapshot::shared_vertices;

/// Most patterns one upload may carry.
pub const MAX_PATTERNS: usize = 1024;
/// Longest pattern, in characters.
pub const MAX_PATTERN_CHARS: usize = 200;

/// Why a dynamic mark cannot be applied.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum MarkError {
    #[error(
        "dynamic: empty pattern (give object names or prefixes ending in `*`, comma-separated)"
    )]
    Empty,
    #[error("dynamic: more than {MAX_PATTERNS} patterns")]
    TooMany,
    #[error(
        "dynamic: pattern `{0}` is longer than {MAX_PATTERN_CHARS} characters or holds a control character"
    )]
    BadPattern(String),
    #[error("dynamic: `*` may only end a pattern (`{0}`)")]
    Wildcard(String),
    #[error("dynamic: pattern `{0}` matches no object")]
    NoMatch(String),
    #[error(
        "object {id} (`{name}`) is marked dynamic but shares vertices with another object, \
         so it could never move alone; give it its own vertices (its own glTF mesh)"
    )]
    SharedVertices { id: u32, name: String },
}

/// The patterns of an upload's `dynamic` parameter: comma-separated object names,
/// or prefixes ending in `*`.
pub fn parse_patterns(list: &str) -> Result<Vec<String>, MarkError> {
    let patterns: Vec<String> = list.split(',').map(|p| p.trim().to_owned()).collect();
    if patterns.len() > MAX_PATTERNS {
        return Err(MarkError::TooMany);
    }
    for p in &patterns {
        if p.is_empty() {
            return Err(MarkError::Empty);
        }
        if p.chars().count() > MAX_PATTERN_CHARS || p.chars().any(char::is_control) {
            return Err(MarkError::BadPattern(p.chars().take(40).collect()));
        }
        if p.trim_end_matches('*').contains('*') || p.ends_with("**") {
            return Err(MarkError::Wildcard(p.clone()));
        }
    }
    Ok(patterns)
}

/// Whether `name` matches `pattern` (exactly, or by the prefix before a final `*`).
fn matches(pattern: &str, name: &str) -> bool {
    match pattern.strip_suffix('*') {
        Some(prefix) => name.starts_with(prefix),
        None => name == pattern,
    }
}

/// Marks the objects that `patterns` name dynamic (besides those their file marks),
/// then checks every marked object can move alone. Answers the number marked.
pub fn mark(scene: &mut Scene, patterns: &[String]) -> Result<usize, MarkError> {
    for p in patterns {
        let mut any = false;
        for o in scene.objects.iter_mut().filter(|o| matches(p, &o.name)) {
            o.dynamic = true;
            any = true;
        }
        if !any {
            return Err(MarkError::NoMatch(p.clone()));
        }
    }
    check_movable(scene)?;
    Ok(scene.objects.iter().filter(|o| o.dynamic).count())
}

/// Refuses a scene in which a marked object shares vertices with another.
pub fn check_movable(scene: &Scene) -> Result<(), MarkError> {
    if !scene.objects.iter().any(|o| o.dynamic) {
        return Ok(());
    }
    let shared = shared_vertices(scene);
    match scene
        .objects
        .iter()
        .find(|o| o.dynamic && has_bit(&shared, o.id))
    {
        Some(o) => Err(MarkError::SharedVertices {
            id: o.id,
            name: o.name.clone(),
        }),
        None => Ok(()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::SceneBuilder;
    use glam::Vec3;
    use serde_json::json;

    fn quad(x: f32) -> Vec<Vec3> {
        [(0.0, 0.0), (1.0, 0.0), (1.0, 1.0), (0.0, 1.0)]
            .map(|(a, b)| Vec3::new(x + a, b, 0.0))
            .to_vec()
    }

    fn scene() -> Scene {
        let mut b = SceneBuilder::default();
        let q = [0, 1, 2, 0, 2, 3];
        b.push("car_0".into(), &quad(0.0), &q, None);
        b.push("car_1".into(), &quad(2.0), &q, None);
        let door = json!({"homcull": {"dynamic": true}});
        b.push("door".into(), &quad(4.0), &q, Some(door));
        b.push(
            "wall".into(),
            &quad(6.0),
            &q,
            Some(json!({"homcull": {"dynamic": "yes"}})),
        );
        b.build("t")
    }

    #[test]
    fn extras_and_patterns_mark_objects() {
        let mut s = scene();
        fn marked(s: &Scene) -> Vec<&str> {
            (s.objects.iter().filter(|o| o.dynamic))
                .map(|o| o.name.as_str())
                .collect()
        }
        // Only a JSON `true` in the extras marks.
        assert_eq!(marked(&s), ["door"]);
        let n = mark(&mut s, &parse_patterns("car_*, wall").unwrap()).unwrap();
        assert_eq!(n, 4);
        assert_eq!(marked(&s), ["car_0", "car_1", "door", "wall"]);
    }

    #[test]
    fn bad_patterns_are_refused_with_what_is_wrong() {
        assert_eq!(parse_patterns("a,,b"), Err(MarkError::Empty));
        assert_eq!(parse_patterns(""), Err(MarkError::Empty));
        assert_eq!(
            parse_patterns("c*r"),
            Err(MarkError::Wildcard("c*r".into()))
        );
        assert_eq!(
            parse_patterns("car**"),
            Err(MarkError::Wildcard("car**".into()))
        );
        assert!(matches!(
            parse_patterns("a\u{7}"),
            Err(MarkError::BadPattern(_))
        ));
        let many = vec!["x"; MAX_PATTERNS + 1].join(",");
        assert_eq!(parse_patterns(&many), Err(MarkError::TooMany));
        let mut s = scene();
        let err = mark(&mut s, &["bus_*".into()]).unwrap_err();
        assert_eq!(err, MarkError::NoMatch("bus_*".into()));
        assert!(err.to_string().contains("bus_*"));
        // A whole-name pattern does not match a longer name.
        assert_eq!(
            mark(&mut s, &["car_".into()]),
            Err(MarkError::NoMatch("car_".into()))
        );
    }

    #[test]
    fn a_marked_object_sharing_vertices_is_refused_naming_it() {
        let mut b = SceneBuilder::default();
        let v = quad(0.0);
        // Two objects over one vertex range: triangles of each index all four.
        b.push("a".into(), &v, &[0, 1, 2, 0, 2, 3], None);
        let mut s = b.build("t");
        let half = s.objects[0].index_count / 2;
        let mut second = s.objects[0].clone();
        s.objects[0].index_count = half;
        second.id = 1;
        second.name = "b".into();
        second.first_index += half;
        second.index_count = half;
        s.objects.push(second);
        assert_eq!(check_movable(&s), Ok(()), "nothing marked");
        let err = mark(&mut s, &["b".into()]).unwrap_err();
        assert!(
            matches!(&err, MarkError::SharedVertices { id: 1, name } if name == "b"),
            "{err}"
        );
    }
}
