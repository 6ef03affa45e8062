//! Helpers of the REST tests: error bodies, a small scene to upload, poses as JSON.

use homcull::core::scene::{SceneBuilder, write_glb};
use homcull_proto::ErrorBody;
use serde_json::Value;

pub async fn error_of(r: reqwest::Response) -> (u16, String) {
    let status = r.status().as_u16();
    let body: ErrorBody = r.json().await.expect("error bodies are JSON");
    assert!(!body.error.message.is_empty());
    (status, body.error.code)
}

/// A small scene to upload: a wall with a box behind it and one beside it.
pub fn small_glb() -> Vec<u8> {
    let mut b = SceneBuilder::default();
    let cube = |b: &mut SceneBuilder, name: &str, c: [f32; 3], h: [f32; 3]| {
        let v: Vec<glam::Vec3> = (0..8)
            .map(|i| {
                glam::Vec3::new(
                    c[0] + if i & 1 == 0 { -h[0] } else { h[0] },
                    c[1] + if i & 2 == 0 { -h[1] } else { h[1] },
                    c[2] + if i & 4 == 0 { -h[2] } else { h[2] },
                )
            })
            .collect();
        let idx = [
            0, 2, 1, 1, 2, 3, 4, 5, 6, 5, 7, 6, 0, 1, 4, 1, 5, 4, 2, 6, 3, 3, 6, 7, 0, 4, 2, 2, 4,
            6, 1, 3, 5, 3, 7, 5,
        ];
        b.push(name.into(), &v, &idx, None);
    };
    cube(&mut b, "wall", [0.0, 5.0, -10.0], [20.0, 5.0, 0.5]);
    cube(&mut b, "hidden", [0.0, 1.0, -20.0], [1.0, 1.0, 1.0]);
    cube(&mut b, "beside", [40.0, 1.0, -20.0], [1.0, 1.0, 1.0]);
    write_glb(&b.build("small"))
}

pub fn pose_json(p: &homcull_proto::Pose) -> Value {
    serde_json::to_value(p).unwrap()
}
