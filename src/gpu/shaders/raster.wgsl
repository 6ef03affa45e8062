// Occluder raster and exact-oracle ID raster: one vertex stage for both, so their
// coverage is identical (`@invariant` position, same matrix, same vertices).
// CPU twin: `hom/raster.rs`.

@group(0) @binding(0) var<uniform> pose: PoseUniform;

struct VsOut {
    @invariant @builtin(position) clip: vec4<f32>,
    // View depth: clip w of a perspective projection, interpolated perspective-correctly.
    @location(0) depth: f32,
    @location(1) @interpolate(flat) id: u32,
}

@vertex
fn vs(@location(0) p: vec3<f32>, @builtin(instance_index) id: u32) -> VsOut {
    var out: VsOut;
    out.clip = pose.view_proj * vec4<f32>(p, 1.0);
    out.depth = out.clip.w;
    out.id = id;
    return out;
}

@fragment
fn fs_depth(in: VsOut) -> @location(0) f32 {
    return in.depth;
}

@fragment
fn fs_id(in: VsOut) -> @location(0) u32 {
    return in.id;
}
