// Ash renderer (volcano_render::plume): camera-facing quads, one per instance.
// kind in [0,1): detail sphere (s2/s3) drawn as a lit sphere impostor.
// kind in [1,2): s1/umbrella smoke puff: a procedural smoke texture (value-noise fBm), turned
//                by the spin projected on the screen (thesis §3.7.1), lit as a soft sphere.
// Shade 0 = dense dark ash at the vent, 1 = diluted light ash aloft; coverage thins the puff.

#import bevy_pbr::mesh_view_bindings::{view, lights}

struct Vertex {
    @location(0) position: vec3<f32>,
    @location(3) center_radius: vec4<f32>,
    @location(4) params: vec4<f32>, // angle, shade, coverage, kind
};

struct VertexOutput {
    @builtin(position) clip_position: vec4<f32>,
    @location(0) uv: vec2<f32>,
    @location(1) params: vec4<f32>,
};

@vertex
fn vertex(v: Vertex) -> VertexOutput {
    let right = view.world_from_view[0].xyz;
    let up = view.world_from_view[1].xyz;
    let corner = v.position.xy * 2.0; // unit quad corners → [-1, 1]
    let world = v.center_radius.xyz + (right * corner.x + up * corner.y) * v.center_radius.w;
    var out: VertexOutput;
    out.clip_position = view.clip_from_world * vec4<f32>(world, 1.0);
    out.uv = corner;
    out.params = v.params;
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
