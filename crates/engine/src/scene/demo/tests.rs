//! The demo city's own checks: determinism, layout, meshes, and the sized variants.

mod city {
    use crate::scene::demo::mesh::*;
    use crate::scene::demo::*;
    use glam::{Vec3, Vec3Swizzles};

    fn layout() -> (AxisLayout, AxisLayout) {
        city_layout(&mut ChaCha8Rng::seed_from_u64(SEED), BLOCKS_PER_SIDE)
    }

    fn normal(v: &[Vec3], tri: &[u32]) -> Vec3 {
        let [a, b, c] = [0, 1, 2].map(|k| v[tri[k] as usize]);
        (b - a).cross(c - a)
    }

    #[test]
    fn deterministic() {
        let a = demo_city();
        let b = demo_city();
        assert_eq!(a.objects.len(), b.objects.len());
        assert_eq!(a.triangle_count(), b.triangle_count());
        for (oa, ob) in a.objects.iter().zip(&b.objects) {
            assert_eq!(oa.name, ob.name);
            assert_eq!(oa.aabb, ob.aabb);
        }
        assert_eq!(a.name, "demo");
    }

    #[test]
    fn size_is_in_budget() {
        let city = demo_city();
        let count = |prefix: &str| {
            city.objects
                .iter()
                .filter(|o| o.name.starts_with(prefix))
                .count()
        };
        eprintln!(
            "demo city: {} objects ({} buildings, {} ground tiles, {} cars, {} trees, {} benches), {} triangles",
            city.objects.len(),
            count("building_"),
            count("ground_"),
            count("car_"),
            count("tree_"),
            count("bench_"),
            city.triangle_count()
        );
        assert!((2_500..=5_000).contains(&city.objects.len()));
        assert!(city.triangle_count() < 150_000);
        assert!(count("building_") > 500 && count("car_") > 300 && count("tree_") > 500);
    }

    #[test]
    fn every_object_has_triangles_and_finite_bounds() {
        let city = demo_city();
        for o in &city.objects {
            assert!(o.triangles() >= 1, "{} has no triangle", o.name);
            assert!(!o.aabb.is_empty(), "{}", o.name);
            assert!(
                o.aabb.min.is_finite() && o.aabb.max.is_finite(),
                "{}",
                o.name
            );
        }
        let heights = city
            .objects
            .iter()
            .filter(|o| o.name.starts_with("building_"))
            .map(|o| o.aabb.max.y);
        assert!(
            heights
                .clone()
                .all(|h| (BUILDING_HEIGHT.0..=TOWER_HEIGHT.1).contains(&h))
        );
    }

    #[test]
    fn buildings_stay_off_street_centre_lines() {
        let city = demo_city();
        let (xs, zs) = layout();
        for o in city
            .objects
            .iter()
            .filter(|o| o.name.starts_with("building_"))
        {
            for s in &xs.streets {
                let x = s.mid();
                assert!(
                    !(o.aabb.min.x < x && x < o.aabb.max.x),
                    "{} crosses street x = {x}",
                    o.name
                );
            }
            for s in &zs.streets {
                let z = s.mid();
                assert!(
                    !(o.aabb.min.z < z && z < o.aabb.max.z),
                    "{} crosses street z = {z}",
                    o.name
                );
            }
            // Stronger: every building stands inside one block, back from the sidewalk.
            let inside_a_block = xs.blocks.iter().any(|bx| {
                zs.blocks.iter().any(|bz| {
                    let inner = Rect::from_spans(*bx, *bz).shrunk(SIDEWALK - 1e-3);
                    o.aabb.min.x >= inner.x0
                        && o.aabb.max.x <= inner.x1
                        && o.aabb.min.z >= inner.z0
                        && o.aabb.max.z <= inner.z1
                })
            });
            assert!(inside_a_block, "{} leaves its block", o.name);
        }
    }

    #[test]
    fn grid_centre_is_open_street() {
        let city = demo_city();
        let eye = Vec3::new(0.0, 1.7, 0.0);
        let blocking: Vec<_> = city
            .objects
            .iter()
            .filter(|o| !o.name.starts_with("ground_"))
            .filter(|o| {
                let nearest = eye.xz().clamp(o.aabb.min.xz(), o.aabb.max.xz());
                nearest.distance(eye.xz()) < 5.0
            })
            .map(|o| o.name.clone())
            .collect();
        assert!(blocking.is_empty(), "{blocking:?}");
    }

    #[test]
    fn closed_shapes_face_outward() {
        let mut mesh = Mesh::default();
        mesh.add_box(Vec3::new(1.0, 2.0, 3.0), Vec3::new(2.0, 4.0, 7.0));
        let centre = Vec3::new(1.5, 3.0, 5.0);
        let mut octa = Mesh::default();
        octa.add_octahedron(centre, Vec3::new(1.0, 2.0, 1.0));
        for m in [&mesh, &octa] {
            for tri in m.indices.chunks_exact(3) {
                let n = normal(&m.vertices, tri);
                let to_face = m.vertices[tri[0] as usize] - centre;
                assert!(n.dot(to_face) > 0.0, "inward triangle {tri:?}");
            }
        }
        assert_eq!(mesh.indices.len(), 36);
        assert_eq!(octa.indices.len(), 24);
        let mut ground = Mesh::default();
        ground.add_ground_quad(Rect::around(0.0, 0.0, 1.0));
        for tri in ground.indices.chunks_exact(3) {
            assert!(normal(&ground.vertices, tri).y > 0.0);
        }
    }
}

mod sized {
    use crate::scene::demo::*;

    #[test]
    fn sized_12_is_the_demo_city() {
        let (a, b) = (demo_city(), demo_city_sized(12));
        assert_eq!(a.objects.len(), b.objects.len());
        assert!(
            a.objects
                .iter()
                .zip(&b.objects)
                .all(|(x, y)| x.name == y.name && x.aabb == y.aabb)
        );
        assert!(demo_city_sized(2).objects.len() < a.objects.len());
    }
}
