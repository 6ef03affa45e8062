// Occlusion pyramid: level 0 from the occluder raster, then 2×2 reductions
// (average opacity, max depth; out-of-range children are transparent).
// CPU twin: `hom/pyramid.rs`.

struct LevelParams {
    src_offset: u32,
    dst_offset: u32,
    src_w: u32,
    src_h: u32,
    dst_w: u32,
    dst_h: u32,
    slot_stride: u32,
    _pad: u32,
}

@group(0) @binding(0) var<uniform> lp: LevelParams;
@group(0) @binding(1) var<storage, read_write> opacity: array<f32>;
@group(0) @binding(2) var<storage, read_write> depth: array<f32>;
@group(0) @binding(3) var raster: texture_2d_array<f32>;

@compute @workgroup_size(8, 8, 1)
fn level0(@builtin(global_invocation_id) g: vec3<u32>) {
    if g.x >= lp.dst_w || g.y >= lp.dst_h {
        return;
    }
    let d = textureLoad(raster, vec2<u32>(g.x, g.y), g.z, 0).r;
    let i = g.z * lp.slot_stride + lp.dst_offset + g.y * lp.dst_w + g.x;
    opacity[i] = select(0.0, 1.0, d > 0.0);
    depth[i] = d;
}

@compute @workgroup_size(8, 8, 1)
fn reduce(@builtin(global_invocation_id) g: vec3<u32>) {
    if g.x >= lp.dst_w || g.y >= lp.dst_h {
        return;
    }
    let base = g.z * lp.slot_stride;
    var sum = 0.0;
    var max_d = 0.0;
    for (var k = 0u; k < 4u; k++) {
        let cx = 2u * g.x + (k & 1u);
        let cy = 2u * g.y + (k >> 1u);
        if cx < lp.src_w && cy < lp.src_h {
            let j = base + lp.src_offset + cy * lp.src_w + cx;
            sum += opacity[j];
            max_d = max(max_d, depth[j]);
        }
    }
    let i = base + lp.dst_offset + g.y * lp.dst_w + g.x;
    opacity[i] = sum * 0.25;
    depth[i] = max_d;
}
