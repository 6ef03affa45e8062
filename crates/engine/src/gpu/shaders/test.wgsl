// Per-object test: one invocation per (pose, test box); a box that may be visible
// sets its object's bit. CPU twin: `hom/test.rs` (same traversal and comparisons).

const STACK_SIZE: u32 = 4u + 3u * MAX_LEVELS;

struct TestConfig {
    levels: u32,
    method: u32,
    deb: u32,
    deb_tile: u32,
    deb_cols: u32,
    deb_rows: u32,
    words_per_pose: u32,
    slot_stride: u32,
    atlas_cols: u32, // slots per atlas row
    _a: u32,
    _b: u32,
    _c: u32,
    // x: width, y: height, z: offset of each level
    dims: array<vec4<u32>, 16>,
    // x: opacity threshold of each level
    thresholds: array<vec4<f32>, 16>,
}

struct TestGroup {
    cand_start: u32,
    cand_count: u32,
    first_pose: u32,
    _pad: u32,
}

struct TestBox {
    min_obj: vec4<f32>, // xyz min, w: object id (bits)
    max: vec4<f32>,
}

@group(0) @binding(0) var<uniform> cfg: TestConfig;
@group(0) @binding(1) var<uniform> grp: TestGroup;
@group(0) @binding(2) var<storage, read> poses: array<PoseUniform>;
@group(0) @binding(3) var<storage, read> boxes: array<TestBox>;
@group(0) @binding(4) var<storage, read> candidates: array<vec2<u32>>;
@group(0) @binding(5) var<storage, read> deb_tiles: array<f32>;
@group(0) @binding(6) var<storage, read> opacity: array<f32>;
@group(0) @binding(7) var<storage, read> depth: array<f32>;
@group(0) @binding(8) var<storage, read_write> mask: array<atomic<u32>>;
// Level 0 is the occluder atlas itself (the pyramid buffers start at level 1).
@group(0) @binding(9) var raster: texture_2d<f32>;

// Texel (x, y) of level l as (opacity, depth).
fn texel(slot: u32, l: u32, x: u32, y: u32) -> vec2<f32> {
    if l == 0u {
        let at = slot_origin(slot, cfg.atlas_cols, cfg.dims[0].xy) + vec2<u32>(x, y);
        let d = textureLoad(raster, at, 0).r;
        return vec2<f32>(select(0.0, 1.0, d > 0.0), d);
    }
    let i = slot * cfg.slot_stride + cfg.dims[l].z + y * cfg.dims[l].x + x;
    return vec2<f32>(opacity[i], depth[i]);
}

fn start_level(r: ScreenRect) -> u32 {
    let m = max(max(r.x1 - r.x0, r.y1 - r.y0), 1u);
    let k = 32u - countLeadingZeros(m - 1u);
    return min(k, cfg.levels - 1u);
}

fn deb_all_in_front(pose: u32, r: ScreenRect) -> bool {
    let t = cfg.deb_tile;
    let base = pose * cfg.deb_cols * cfg.deb_rows;
    for (var ty = r.y0 / t; ty <= (r.y1 - 1u) / t; ty++) {
        for (var tx = r.x0 / t; tx <= (r.x1 - 1u) / t; tx++) {
            if !in_front(deb_tiles[base + ty * cfg.deb_cols + tx], r.near) {
                return false;
            }
        }
    }
    return true;
}

fn hom_occluded(r: ScreenRect, slot: u32, pose: u32) -> bool {
    if cfg.deb != DEB_RASTER && !deb_all_in_front(pose, r) {
        return false;
    }
    let raster_deb = cfg.deb == DEB_RASTER;
    let k = start_level(r);
    var stack: array<vec3<u32>, STACK_SIZE>;
    var top = 0u;
    for (var ty = r.y0 >> k; ty <= (r.y1 - 1u) >> k; ty++) {
        for (var tx = r.x0 >> k; tx <= (r.x1 - 1u) >> k; tx++) {
            stack[top] = vec3<u32>(k, tx, ty);
            top++;
        }
    }
    while top > 0u {
        top--;
        let e = stack[top];
        let l = e.x;
        let t = texel(slot, l, e.y, e.z);
        let o = t.x;
        if o >= cfg.thresholds[l].x && (!raster_deb || in_front(t.y, r.near)) {
            continue;
        }
        if l == 0u || o == 0.0 {
            return false;
        }
        let c = l - 1u;
        let cx0 = max(2u * e.y, r.x0 >> c);
        let cx1 = min(2u * e.y + 1u, (r.x1 - 1u) >> c);
        let cy0 = max(2u * e.z, r.y0 >> c);
        let cy1 = min(2u * e.z + 1u, (r.y1 - 1u) >> c);
        for (var cy = cy0; cy <= cy1; cy++) {
            for (var cx = cx0; cx <= cx1; cx++) {
                stack[top] = vec3<u32>(c, cx, cy);
                top++;
            }
        }
    }
    return true;
}

fn hzb_occluded(r: ScreenRect, slot: u32) -> bool {
    let k = start_level(r);
    for (var ty = r.y0 >> k; ty <= (r.y1 - 1u) >> k; ty++) {
        for (var tx = r.x0 >> k; tx <= (r.x1 - 1u) >> k; tx++) {
            let t = texel(slot, k, tx, ty);
            let d = select(1e30, t.y, t.x >= 1.0);
            if !in_front(d, r.near) {
                return false;
            }
        }
    }
    return true;
}

@compute @workgroup_size(LINEAR_WORKGROUP, 1, 1)
fn main(@builtin(global_invocation_id) g: vec3<u32>, @builtin(num_workgroups) n: vec3<u32>) {
    let idx = g.x + g.y * n.x * LINEAR_WORKGROUP;
    if idx >= grp.cand_count {
        return;
    }
    let cand = candidates[grp.cand_start + idx];
    let pose = cand.x;
    let b = boxes[cand.y];
    let obj = bitcast<u32>(b.min_obj.w);
    let r = project_box(poses[pose], b.min_obj.xyz, b.max.xyz);
    if !r.valid {
        return; // covers no pixel centre
    }
    let slot = pose - grp.first_pose;
    var hidden: bool;
    if cfg.method == METHOD_HZB {
        hidden = hzb_occluded(r, slot);
    } else {
        hidden = hom_occluded(r, slot, pose);
    }
    if !hidden {
        atomicOr(&mask[pose * cfg.words_per_pose + obj / 32u], 1u << (obj % 32u));
    }
}
