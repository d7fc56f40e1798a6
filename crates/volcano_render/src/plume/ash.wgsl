// Ash renderer (volcano_render::plume): camera-facing quads, one per instance.
// kind in [0,1): detail sphere (s2/s3) drawn as a lit sphere impostor.
// kind in [1,2): s1/umbrella smoke puff: a procedural smoke texture (value-noise fBm), turned
//                by the spin projected on the screen (thesis §3.7.1), lit as a soft sphere.
// Shade 0 = dense dark ash at the vent, 1 = diluted light ash aloft; coverage thins the puff.
//
// Only the parents are uploaded (volcano_plume::view::AshParent, with the prefix sum of their
// instance counts); the vertex shader expands instance i into the parent's billboard or one of
// its s2/s3 children, with the CPU enumeration's 32-bit arithmetic
// (volcano_plume::model::spheres::detail_spheres).

#import bevy_pbr::mesh_view_bindings::{view, lights}

// BEGIN expansion: compiled on its own (group 3 renamed) by tests/gpu_expansion.rs, which
// compares it with the CPU enumeration. Keep it free of Bevy imports.

// Mirrors volcano_plume::view::AshParent (64 bytes).
struct AshParent {
    center_radius: vec4<f32>,
    rotation: vec4<f32>,  // unit quaternion x, y, z, w
    look: vec4<f32>,      // billboard angle, shade, coverage, texture variant
    key: u32,             // parent_key(seed, parent id)
    flags: u32,           // bit 0: billboard first; bits 8-15: s3 per s2
    billboard_radius: f32,
    pad: u32,
};

@group(3) @binding(0) var<storage, read> parents: array<AshParent>;
// parents + 1 entries: parent p owns instances starts[p] .. starts[p + 1].
@group(3) @binding(1) var<storage, read> starts: array<u32>;

const CHILD_RATIO: f32 = 0.2;          // SphereParams::CHILD_RATIO
const DIRECTION_BITS: u32 = 14u;       // spheres::DIRECTION_BITS
const GOLDEN_TURN: u32 = 0x61c88647u;  // spheres::GOLDEN_TURN
const CHILD_STRIDE: u32 = 0x9e3779b9u; // spheres::CHILD_STRIDE
const TAU: f32 = 6.283185307179586;

// spheres::hash32: pcg_hash (Jarzynski & Olano 2020); u32 arithmetic wraps in WGSL.
fn hash32(x: u32) -> u32 {
    let state = x * 747796405u + 2891336453u;
    let word = ((state >> ((state >> 28u) + 4u)) ^ state) * 277803737u;
    return (word >> 22u) ^ word;
}

// spheres::lattice_direction of the top DIRECTION_BITS of a key.
fn key_direction(key: u32) -> vec3<f32> {
    let i = key >> (32u - DIRECTION_BITS);
    let z = 1.0 - f32(2u * i + 1u) / f32(1u << DIRECTION_BITS);
    let s = sqrt(max(1.0 - z * z, 0.0));
    // The azimuth's top 24 bits (exact in f32), taken in [-1/2, 1/2) turn: GPU sin/cos are
    // only specified on [-pi, pi].
    var turn = f32((i * GOLDEN_TURN) >> 8u) / 16777216.0;
    if (turn >= 0.5) {
        turn = turn - 1.0;
    }
    let phi = TAU * turn;
    return vec3<f32>(s * cos(phi), s * sin(phi), z);
}

fn rotate(q: vec4<f32>, v: vec3<f32>) -> vec3<f32> {
    let t = 2.0 * cross(q.xyz, v);
    return v + q.w * t + cross(q.xyz, t);
}

// One instance as the fragment stage needs it (same order as volcano_plume::AshInstance).
struct Expanded {
    center_radius: vec4<f32>,
    params: vec4<f32>, // angle, shade, coverage, kind
};

fn expand(index: u32) -> Expanded {
    // Last parent whose start is <= index: starts[lo] <= index < starts[hi].
    var lo = 0u;
    var hi = arrayLength(&parents);
    loop {
        if (hi - lo <= 1u) {
            break;
        }
        let mid = (lo + hi) / 2u;
        if (starts[mid] <= index) {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    let a = parents[lo];
    let local = index - starts[lo];
    let billboard = (a.flags & 1u) != 0u;
    var out: Expanded;
    if (billboard && local == 0u) {
        out.center_radius = vec4<f32>(a.center_radius.xyz, a.billboard_radius);
        out.params = vec4<f32>(a.look.x, a.look.y, a.look.z, 1.0 + a.look.w);
        return out;
    }
    // Child c of the enumeration: s2 child k, then its s3 children j = 1..n3.
    let child = local - select(0u, 1u, billboard);
    let group = 1u + ((a.flags >> 8u) & 0xffu);
    let k = child / group;
    let j = child % group;
    let radius = a.center_radius.w;
    let key2 = hash32(a.key ^ (k * CHILD_STRIDE));
    var center = a.center_radius.xyz + rotate(a.rotation, key_direction(key2) * radius);
    var r = radius * CHILD_RATIO;
    var level = 2.0;
    if (j > 0u) {
        // spheres::s3_key(key2, j - 1).
        center = center + rotate(a.rotation, key_direction(hash32(key2 ^ j)) * r);
        r = r * CHILD_RATIO;
        level = 3.0;
    }
    out.center_radius = vec4<f32>(center, r);
    out.params = vec4<f32>(0.0, min(a.look.y + 0.08 * (level - 1.0), 1.0), a.look.z, a.look.w);
    return out;
}

// END expansion

struct Vertex {
    @builtin(instance_index) instance: u32,
    @location(0) position: vec3<f32>,
};

struct VertexOutput {
    @builtin(position) clip_position: vec4<f32>,
    @location(0) uv: vec2<f32>,
    @location(1) params: vec4<f32>,
};

@vertex
fn vertex(v: Vertex) -> VertexOutput {
    let e = expand(v.instance);
    let right = view.world_from_view[0].xyz;
    let up = view.world_from_view[1].xyz;
    let corner = v.position.xy * 2.0; // unit quad corners → [-1, 1]
    let world = e.center_radius.xyz + (right * corner.x + up * corner.y) * e.center_radius.w;
    var out: VertexOutput;
    out.clip_position = view.clip_from_world * vec4<f32>(world, 1.0);
    out.uv = corner;
    out.params = e.params;
    return out;
}

fn hash2(p: vec2<f32>) -> f32 {
    let q = fract(p * vec2<f32>(0.1031, 0.1030));
    let r = q + dot(q, q.yx + 33.33);
    return fract((r.x + r.y) * r.x);
}

fn value_noise(p: vec2<f32>) -> f32 {
    let i = floor(p);
    let f = fract(p);
    let u = f * f * (3.0 - 2.0 * f);
    let a = hash2(i);
    let b = hash2(i + vec2<f32>(1.0, 0.0));
    let c = hash2(i + vec2<f32>(0.0, 1.0));
    let d = hash2(i + vec2<f32>(1.0, 1.0));
    return mix(mix(a, b, u.x), mix(c, d, u.x), u.y);
}

fn fbm(p: vec2<f32>) -> f32 {
    var sum = 0.0;
    var amp = 0.5;
    var q = p;
    for (var i = 0; i < 4; i = i + 1) {
        sum = sum + amp * value_noise(q);
        q = q * 2.03 + vec2<f32>(17.1, 5.3);
        amp = amp * 0.5;
    }
    return sum;
}

fn sun_direction() -> vec3<f32> {
    if (lights.n_directional_lights > 0u) {
        return normalize(lights.directional_lights[0].direction_to_light);
    }
    return normalize(vec3<f32>(0.3, 1.0, 0.2));
}

@fragment
fn fragment(in: VertexOutput) -> @location(0) vec4<f32> {
    let r2 = dot(in.uv, in.uv);
    if (r2 > 1.0) {
        discard;
    }
    let angle = in.params.x;
    let shade = in.params.y;
    let coverage = in.params.z;
    let kind = in.params.w;
    var uv = in.uv;
    var bump = 0.0;
    if (kind >= 1.0) {
        // Smoke texture in the puff's own frame, turned by the projected spin.
        let c = cos(angle);
        let s = sin(angle);
        let p = vec2<f32>(c * uv.x - s * uv.y, s * uv.x + c * uv.y);
        let variant = fract(kind) * 37.0;
        let n = fbm(p * 2.2 + vec2<f32>(variant, 2.0 * variant));
        let body = (1.0 - r2) + (n - 0.5) * 1.1;
        if (body < 0.55 - 0.45 * coverage) {
            discard;
        }
        bump = n - 0.5;
    }
    // Sphere-impostor normal in view space, bent by the smoke texture.
    let nz = sqrt(max(1.0 - r2, 0.0));
    let n_view = normalize(vec3<f32>(uv.x + bump * 0.6, uv.y + bump * 0.6, nz + 0.15));
    let n_world = normalize(
        view.world_from_view[0].xyz * n_view.x + view.world_from_view[1].xyz * n_view.y
            + view.world_from_view[2].xyz * n_view.z,
    );
    let l = sun_direction();
    // Wrapped diffuse: ash scatters, so the shadow side is not black.
    let diffuse = clamp((dot(n_world, l) + 0.35) / 1.35, 0.0, 1.0);
    let dark = vec3<f32>(0.05, 0.045, 0.042);
    let light = vec3<f32>(0.50, 0.485, 0.46);
    let base = mix(dark, light, shade);
    let sky = vec3<f32>(0.30, 0.36, 0.46) * (0.5 + 0.5 * n_world.y);
    let colour = base * (0.22 + 0.62 * diffuse) + base * sky * 0.35;
    return vec4<f32>(colour, 1.0);
}
