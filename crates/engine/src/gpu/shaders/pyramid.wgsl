// Occlusion pyramid, two levels per dispatch: each invocation reduces a 4×4 block of
// the source level to 2×2 texels of the next level and 1 of the one after. The first
// dispatch reads level 0 straight from the slot's rectangle of the occluder atlas (the pyramid buffers hold
// levels 1.. only: the test reads level 0 from the raster too); later ones read the
// last level written. Each 2×2 reduction averages opacity and takes the max depth; texels outside
// a level are transparent, never opaque. A texel outside its level comes out 0 (all
// its children are outside theirs), so only writes need bounds. CPU twin:
// `hom/pyramid.rs` (same order of additions, so equal bits).
//
// Measured on lavapipe: this is cheaper than one dispatch per level and than a
// five-level single-pass downsampler with workgroup barriers (which llvmpipe runs as
// coroutines).

struct Step {
    src_level: u32,
    _a: u32,
    _b: u32,
    _c: u32,
}

struct Levels {
    count: u32,
    slot_stride: u32,
    atlas_cols: u32, // slots per atlas row
    _pad: u32,
    // x: width, y: height, z: offset of each level
    dims: array<vec4<u32>, 16>,
}

@group(0) @binding(0) var<uniform> step: Step;
@group(0) @binding(1) var<storage, read_write> opacity: array<f32>;
@group(0) @binding(2) var<storage, read_write> depth: array<f32>;
@group(0) @binding(3) var raster: texture_2d<f32>;
@group(0) @binding(4) var<uniform> lv: Levels;

fn index(slot: u32, l: u32, x: u32, y: u32) -> u32 {
    let dim = lv.dims[l];
    return slot * lv.slot_stride + dim.z + y * dim.x + x;
}

fn level0(slot: u32, x: u32, y: u32) -> vec2<f32> {
    let at = slot_origin(slot, lv.atlas_cols, lv.dims[0].xy) + vec2<u32>(x, y);
    let d = textureLoad(raster, at, 0).r;
    return vec2<f32>(select(0.0, 1.0, d > 0.0), d);
}

// Texel (x, y) of the source level as (opacity, depth); transparent outside it.
fn source(slot: u32, x: u32, y: u32) -> vec2<f32> {
    let l = step.src_level;
    let dim = lv.dims[l];
    if x >= dim.x || y >= dim.y {
        return vec2<f32>(0.0, 0.0);
    }
    if l == 0u {
        return level0(slot, x, y);
    }
    let i = index(slot, l, x, y);
    return vec2<f32>(opacity[i], depth[i]);
}

// The 2×2 reduction of children in row-major order, as `reduce_texel` adds them.
fn combine(a: vec2<f32>, b: vec2<f32>, c: vec2<f32>, d: vec2<f32>) -> vec2<f32> {
    let sum = ((a.x + b.x) + c.x) + d.x;
    return vec2<f32>(sum * 0.25, max(max(max(a.y, b.y), c.y), d.y));
}

// Writes texel (x, y) of level `l` if the level and the texel exist.
fn store(slot: u32, l: u32, x: u32, y: u32, v: vec2<f32>) {
    if l >= lv.count {
        return;
    }
    let dim = lv.dims[l];
    if x < dim.x && y < dim.y {
        let i = index(slot, l, x, y);
        opacity[i] = v.x;
        depth[i] = v.y;
    }
}

@compute @workgroup_size(GRID_WORKGROUP, GRID_WORKGROUP, 1)
fn downsample(@builtin(global_invocation_id) g: vec3<u32>) {
    let slot = g.z;
    let l = step.src_level + 1u;
    // Level l: this invocation's 2×2 texels, each from 2×2 source texels.
    var q: array<vec2<f32>, 4>;
    for (var k = 0u; k < 4u; k++) {
        let x = 2u * g.x + (k & 1u);
        let y = 2u * g.y + (k >> 1u);
        let v = combine(
            source(slot, 2u * x, 2u * y),
            source(slot, 2u * x + 1u, 2u * y),
            source(slot, 2u * x, 2u * y + 1u),
            source(slot, 2u * x + 1u, 2u * y + 1u),
        );
        store(slot, l, x, y, v);
        q[k] = v;
    }
    // Level l + 1: one texel.
    store(slot, l + 1u, g.x, g.y, combine(q[0], q[1], q[2], q[3]));
}
