// Shared by every homcull kernel: the pose layout and the box projection.
// Twin of `camera/mod.rs` (PoseUniform, Camera::project_box, ScreenRect::from_bounds)
// and `cull::deb::in_front`; keep the arithmetic identical.

struct PoseUniform {
    view_proj: mat4x4<f32>,
    view: mat4x4<f32>,
    scale_viewport: vec4<f32>, // scale x, scale y, width, height
    near_far: vec4<f32>,       // near, far, deb plane depth, shift (NDC x of an off-axis eye)
    pad: array<vec4<f32>, 6>,
}

// RECT_EPSILON_PX, DEPTH_MARGIN and the other shared constants come before this file,
// generated from the Rust ones (`gpu/prelude.rs`).

struct ScreenRect {
    valid: bool,
    x0: u32,
    y0: u32,
    x1: u32,
    y1: u32,
    near: f32,
}

// Top-left pixel of slot `slot` in an atlas of `cols` slots a row, each `size` pixels
// (`SlotTargets::origin`).
fn slot_origin(slot: u32, cols: u32, size: vec2<u32>) -> vec2<u32> {
    return vec2<u32>((slot % cols) * size.x, (slot / cols) * size.y);
}

fn in_front(occluder_depth: f32, object_near: f32) -> bool {
    return occluder_depth * (1.0 + DEPTH_MARGIN) < object_near;
}

fn box_corner(bmin: vec3<f32>, bmax: vec3<f32>, i: u32) -> vec3<f32> {
    return vec3<f32>(
        select(bmin.x, bmax.x, (i & 1u) != 0u),
        select(bmin.y, bmax.y, (i & 2u) != 0u),
        select(bmin.z, bmax.z, (i & 4u) != 0u),
    );
}

const BOX_EDGES = array<vec2<u32>, 12>(
    vec2<u32>(0u, 1u), vec2<u32>(2u, 3u), vec2<u32>(4u, 5u), vec2<u32>(6u, 7u),
    vec2<u32>(0u, 2u), vec2<u32>(1u, 3u), vec2<u32>(4u, 6u), vec2<u32>(5u, 7u),
    vec2<u32>(0u, 4u), vec2<u32>(1u, 5u), vec2<u32>(2u, 6u), vec2<u32>(3u, 7u),
);

fn project_box(pose: PoseUniform, bmin: vec3<f32>, bmax: vec3<f32>) -> ScreenRect {
    let near = pose.near_far.x;
    let shift = pose.near_far.w;
    let sc = pose.scale_viewport;
    var v: array<vec3<f32>, 8>;
    var lo = vec2<f32>(1e30, 1e30);
    var hi = vec2<f32>(-1e30, -1e30);
    var nearest = 1e30;
    var farthest = -1e30;
    var clipped = false;
    for (var i = 0u; i < 8u; i++) {
        v[i] = (pose.view * vec4<f32>(box_corner(bmin, bmax, i), 1.0)).xyz;
        let d = -v[i].z;
        clipped = clipped || d < near;
        if d >= near {
            let s = vec2<f32>(((v[i].x * sc.x / d + shift) * 0.5 + 0.5) * sc.z, (0.5 - v[i].y * sc.y / d * 0.5) * sc.w);
            lo = min(lo, s);
            hi = max(hi, s);
            nearest = min(nearest, d);
            farthest = max(farthest, d);
        }
    }
    var r: ScreenRect;
    r.valid = false;
    if farthest < near {
        return r;
    }
    if clipped {
        nearest = near;
        for (var e = 0u; e < 12u; e++) {
            let va = v[BOX_EDGES[e].x];
            let vc = v[BOX_EDGES[e].y];
            let da = -va.z;
            let dc = -vc.z;
            if (da < near) != (dc < near) {
                let t = (near - da) / (dc - da);
                var p = va + (vc - va) * t;
                p.z = -near;
                let s = vec2<f32>(((p.x * sc.x / near + shift) * 0.5 + 0.5) * sc.z, (0.5 - p.y * sc.y / near * 0.5) * sc.w);
                lo = min(lo, s);
                hi = max(hi, s);
            }
        }
    }
    let size = sc.zw;
    let a = clamp(floor(lo - vec2<f32>(RECT_EPSILON_PX)), vec2<f32>(0.0), size);
    let b = clamp(ceil(hi + vec2<f32>(RECT_EPSILON_PX)), vec2<f32>(0.0), size);
    r.x0 = u32(a.x);
    r.y0 = u32(a.y);
    r.x1 = u32(b.x);
    r.y1 = u32(b.y);
    r.near = nearest;
    r.valid = r.x0 < r.x1 && r.y0 < r.y1;
    return r;
}
