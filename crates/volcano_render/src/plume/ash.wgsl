// Ash renderer (volcano_render::plume): camera-facing quads, one per instance, blended
// back to front (premultiplied alpha; the parents are sorted far to near on the CPU, and an
// instanced draw blends its instances in order).
// kind in [0,1): detail sphere (s2/s3) drawn as a soft lit sphere impostor.
// kind in [1,2): s1/umbrella/pyroclastic puff: a procedural smoke texture (value-noise fBm),
//                turned by the spin projected on the screen (thesis §3.7.1), lit as a soft sphere.
// Shade 0 = dense dark ash at the vent, 1 = diluted light ash aloft; coverage thins the puff.
//
// Lighting (docs/RENDERING.md, "How ash is lit"): each parent carries the sun and sky
// transmittance through the other parents (volcano_plume::view::light_parents, Beer–Lambert
// on a coarse grid); a detail sphere is also shadowed by its own parent's body (the chord
// toward the sun); each fragment has a sphere normal bent by the smoke texture, so every puff
// has a sun side and a shadow side. The shadow side keeps a multiple-scattering floor and the
// sky's ambient (occluded by the ash above); dense ash near the vent glows.
//
// Only the parents are uploaded (volcano_render::plume::layout::AshParent, with the prefix sum
// of their instance counts); the vertex shader expands instance i into the parent's billboard or
// one of its s2/s3 children, with the CPU enumeration's 32-bit arithmetic
// (volcano_plume::view::detail_spheres).

#import bevy_pbr::mesh_view_bindings::{view, lights}
#import bevy_pbr::view_transformations::{position_ndc_to_world, frag_coord_to_uv, uv_to_ndc}

// BEGIN expansion: compiled on its own (group 3 renamed) by tests/gpu_expansion.rs, which
// compares it with the CPU enumeration. Keep it free of Bevy imports.

// Mirrors volcano_render::plume::layout::AshParent (64 bytes).
struct AshParent {
    center_radius: vec4<f32>,
    rotation: vec4<f32>,  // unit quaternion x, y, z, w
    look: vec4<f32>,      // billboard angle, shade, coverage, texture variant
    key: u32,             // parent_key(seed, parent id)
    flags: u32,           // bit 0: billboard first; bits 8-15: s3 per s2
    billboard_radius: f32,
    light: u32,           // unpack4x8unorm: x sun transmittance, y sky transmittance
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

// One instance as the fragment stage needs it (same order as volcano_plume::view::AshInstance).
struct Expanded {
    center_radius: vec4<f32>,
    params: vec4<f32>, // angle, shade, coverage, kind
};

fn expand(index: u32) -> Expanded {
    return expand_in(find_parent(index), index);
}

// Last parent whose start is <= index: starts[lo] <= index < starts[hi].
fn find_parent(index: u32) -> u32 {
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
    return lo;
}

// Instance `index` of parent `p`.
fn expand_in(p: u32, index: u32) -> Expanded {
    let a = parents[p];
    let local = index - starts[p];
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

const FLOW: u32 = 2u; // AshParent::FLOW
const PI: f32 = 3.141592653589793;

struct Vertex {
    @builtin(instance_index) instance: u32,
    @location(0) position: vec3<f32>,
};

struct VertexOutput {
    @builtin(position) clip_position: vec4<f32>,
    @location(0) uv: vec2<f32>,
    @location(1) params: vec4<f32>,
    // x: sun transmittance (grid × own parent's body), y: sky transmittance, z: glow,
    // w: 1 for a pyroclastic-current puff.
    @location(2) light: vec4<f32>,
    // xyz: a detail sphere's centre relative to its parent's (parent radii), zero for puffs;
    // w: light from the incandescent vent (1 at the vent, half at AshLightSettings::vent_reach_m).
    @location(3) place: vec4<f32>,
    // Transmittance of the parent's body between a detail sphere and the eye (1 for puffs).
    @location(4) body: f32,
    // The billboard's world radius (m): the ash-depth pass places each fragment on the
    // sphere's near surface rather than on the quad through its centre.
    @location(5) radius: f32,
};

fn sun_direction() -> vec3<f32> {
    if (lights.n_directional_lights > 0u) {
        return normalize(lights.directional_lights[0].direction_to_light);
    }
    return normalize(vec3<f32>(0.3, 1.0, 0.2));
}

@vertex
fn vertex(v: Vertex) -> VertexOutput {
    let p = find_parent(v.instance);
    let a = parents[p];
    var e = expand_in(p, v.instance);
    let flow = (a.flags & FLOW) != 0u;
    let packed = unpack4x8unorm(a.light);
    var shade = e.params.y;
    var radius = e.center_radius.w;
    // A detail sphere's place on its parent (parent radii), for its self-shadow in the
    // fragment stage (the lights are not bound in the vertex stage).
    var place = vec3<f32>(0.0);
    if (e.params.w < 1.0) {
        place = (e.center_radius.xyz - a.center_radius.xyz) / max(a.center_radius.w, 1e-3);
    }
    if (flow) {
        // Pyroclastic currents: denser and darker than the column at the same density, puffs
        // of varied size (turbulence), flattened onto the ground.
        shade = shade * 0.45;
        radius = radius * (0.8 + 0.8 * fract(a.look.w * 7.31));
    }
    // Dense ash near the vent is incandescent (shade < 0.1: within a few hundred metres).
    let glow = select(smoothstep(0.1, 0.0, shade), 0.0, flow);
    let right = view.world_from_view[0].xyz;
    let up = view.world_from_view[1].xyz;
    let corner = v.position.xy * 2.0; // unit quad corners → [-1, 1]
    var offset = (right * corner.x + up * corner.y) * radius;
    if (flow) {
        offset = vec3<f32>(offset.x * 1.35, offset.y * 0.55, offset.z * 1.35);
    }
    // A detail sphere on the far side of its parent from the eye is seen through the parent's
    // body: Beer–Lambert over the chord toward the eye, as toward the sun in the fragment
    // stage. Children are not sorted within their parent, so without this the shadowed back
    // children would be blended over the lit front ones (dark discs ringed with light).
    let to_eye = normalize(view.world_position - a.center_radius.xyz);
    let view_chord = max(-dot(place, to_eye), 0.0) * 2.0;
    var out: VertexOutput;
    out.body = exp(-view_chord * mix(3.0, 0.8, shade));
    out.radius = radius;
    out.clip_position = view.clip_from_world * vec4<f32>(e.center_radius.xyz + offset, 1.0);
    out.uv = corner;
    out.params = vec4<f32>(e.params.x, shade, e.params.z, e.params.w);
    out.light = vec4<f32>(packed.x, packed.y, glow, select(0.0, 1.0, flow));
    out.place = vec4<f32>(place, packed.z);
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

// Linear albedo: sRGB (60, 52, 46), dense brown-grey ash, to 0.9 × sRGB (190, 186, 180),
// diluted light grey (0.9: the sun-side highlights otherwise saturate under ACES).
const ASH_DENSE: vec3<f32> = vec3<f32>(0.045, 0.034, 0.027);
// Light of the incandescent vent on the ash (nits before the falloff, warm; red channel a
// quarter of the lava's 40,000-nit emissive, volcano_render::lava): the jet is a cloud of hot
// fragments seen through ash rather than an open melt surface. A rendering choice, tuned on
// `volcano render --scene eruption_night`.
const VENT_GLOW: vec3<f32> = vec3<f32>(9000.0, 3300.0, 900.0);
const ASH_DILUTE: vec3<f32> = vec3<f32>(0.464, 0.442, 0.410);

// Opacity of a fragment (x; 0 outside the quad's disc) and the smoke texture's bump (y): the
// soft edge of the radial profile, the smoke texture for puffs, thinner for diluted ash, and a
// detail sphere behind its parent's centre seen only through the parent's body. Shared by the
// colour pass and the ash-depth pass (volcano_render::plume::depth).
fn coverage(in: VertexOutput) -> vec2<f32> {
    let r2 = dot(in.uv, in.uv);
    if (r2 > 1.0) {
        return vec2<f32>(0.0);
    }
    let angle = in.params.x;
    let shade = in.params.y;
    let cov = in.params.z;
    let kind = in.params.w;
    var bump = 0.0;
    var alpha = smoothstep(0.0, 0.5, 1.0 - r2);
    if (kind >= 1.0) {
        // Smoke texture in the puff's own frame, turned by the projected spin.
        let c = cos(angle);
        let s = sin(angle);
        let p = vec2<f32>(c * in.uv.x - s * in.uv.y, s * in.uv.x + c * in.uv.y);
        let variant = fract(kind) * 37.0;
        let n = fbm(p * 2.2 + vec2<f32>(variant, 2.0 * variant));
        let body = (1.0 - r2) + (n - 0.5) * 1.1;
        let edge = 0.55 - 0.45 * cov;
        alpha = smoothstep(edge - 0.1, edge + 0.35, body);
        bump = n - 0.5;
    }
    // Dense ash is opaque, diluted ash lets the background through.
    alpha = alpha * mix(1.0, 0.6, shade * shade) * in.body;
    return vec2<f32>(alpha, bump);
}

// Fragments at least this opaque mark where the ash begins along a view ray (the ash-depth
// pass). Low, so that a puff's soft fringe behind a cloud is not drawn over the cloud (with
// 0.35 the fringe shows as a dark outline through a cloud in front of the puff); the price is
// that a cloud behind a faint veil of ash and in front of dense ash is drawn under both.
const DEPTH_ALPHA: f32 = 0.03;

// The ash-depth pass (volcano_render::plume::depth): the distance (km) from the eye to each
// fragment at least DEPTH_ALPHA opaque, in r; g = 0 marks "ash here". Blended with min into a
// target cleared to (65504, 1), so each pixel keeps the nearest such fragment. The cloud pass
// reads it to draw the clouds behind the ash before it and those in front after it.
@fragment
fn fragment_depth(in: VertexOutput) -> @location(0) vec2<f32> {
    if (coverage(in).x < DEPTH_ALPHA) {
        discard;
    }
    let ndc = vec3<f32>(uv_to_ndc(frag_coord_to_uv(in.clip_position.xy)), in.clip_position.z);
    let world = position_ndc_to_world(ndc);
    // The quad passes through the sphere's centre; its near surface is nearer by the height of
    // the impostor at this fragment.
    let near = in.radius * sqrt(max(1.0 - dot(in.uv, in.uv), 0.0));
    return vec2<f32>(max(distance(world, view.world_position) - near, 0.0) * 0.001, 0.0);
}

@fragment
fn fragment(in: VertexOutput) -> @location(0) vec4<f32> {
    let cover = coverage(in);
    let alpha = cover.x;
    if (alpha < 0.004) {
        discard;
    }
    let uv = in.uv;
    let r2 = dot(uv, uv);
    let shade = in.params.y;
    let bump = cover.y;
    // Sphere-impostor normal in view space, bent by the smoke texture.
    let nz = sqrt(max(1.0 - r2, 0.0));
    let n_view = normalize(vec3<f32>(uv.x + bump * 0.8, uv.y + bump * 0.8, nz + 0.1));
    let n_world = normalize(
        view.world_from_view[0].xyz * n_view.x + view.world_from_view[1].xyz * n_view.y
            + view.world_from_view[2].xyz * n_view.z,
    );
    let l = sun_direction();
    var sun = vec3<f32>(3.0);
    if (lights.n_directional_lights > 0u) {
        sun = lights.directional_lights[0].color.rgb * view.exposure;
    }
    let ndl = dot(n_world, l);
    // A detail sphere on the far side of its parent from the sun looks through the parent's
    // body: Beer–Lambert over the chord (≈ 2 × depth behind the centre plane), darker for
    // denser ash (shade 0).
    let chord = max(-dot(in.place.xyz, l), 0.0) * 2.0;
    let t_sun = in.light.x * exp(-chord * mix(3.0, 0.8, shade));
    let t_sky = in.light.y;
    // Sun side: Lambert; shadow side: a multiple-scattering floor (dense ash scatters less
    // light round to its back).
    // Light scattered round into the shade still mostly comes from the sun, but also reaches
    // parents the grid puts in shadow (multiple scattering through the column).
    let scatter = mix(0.08, 0.25, shade) * (0.35 + 0.65 * t_sun) * (0.5 + 0.5 * ndl);
    let direct = sun * 0.6 * (t_sun * max(ndl, 0.0) + scatter) / PI;
    // Sky: ambient light, occluded by the ash above and by the puff's own density.
    let occlusion = t_sky * mix(0.45, 1.0, shade) * (0.6 + 0.4 * max(n_world.y, 0.0));
    let ambient = lights.ambient_color.rgb * view.exposure * occlusion;
    let albedo = mix(ASH_DENSE, ASH_DILUTE, shade);
    // The vent's incandescence lights the column's base from below and inside: a warm light
    // in nits, scaled by the exposure like the sun (a faint warmth by day, the glow of the
    // column's base at night).
    let from_vent = VENT_GLOW * view.exposure * in.place.w * (0.6 + 0.4 * max(-n_world.y, 0.0));
    var colour = albedo * (direct + ambient + from_vent);
    // Incandescent base: orange emission, stronger in the puff's core (seen at any exposure).
    colour = colour + vec3<f32>(1.0, 0.33, 0.07) * (in.light.z * 1.2 * (0.2 + 0.8 * nz));
    return vec4<f32>(colour * alpha, alpha);
}
