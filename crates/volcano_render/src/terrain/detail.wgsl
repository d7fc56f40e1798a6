// Ground detail finer than the terrain mesh's vertices (see `detail.rs`): gradient noise of the
// world position (x, z) at seven wavelengths, 160 m down to 0.66 m, tilts the mesh normal and
// varies the brightness of the vertex colour. Each octave fades out as the pixel's footprint
// grows from a quarter to half its wavelength (never fewer than two samples per wavelength: no
// aliasing). The footprint is anisotropic: on a grazing view a pixel covers far more ground
// along the view than across it, so the fade follows the short side (at most MAX_ANISO times
// shorter than the long one) and each octave shorter than four long sides is averaged over
// taps spread along it. How much a pixel takes follows its vertex colour (none on water, less on
// vegetation and snow).

#import bevy_pbr::{
    pbr_fragment::pbr_input_from_standard_material,
    pbr_functions::alpha_discard,
}

#ifdef PREPASS_PIPELINE
#import bevy_pbr::{
    prepass_io::{VertexOutput, FragmentOutput},
    pbr_deferred_functions::deferred_output,
}
#else
#import bevy_pbr::{
    forward_io::{VertexOutput, FragmentOutput},
    pbr_functions::{apply_pbr_lighting, main_pass_post_lighting_processing},
    pbr_types::STANDARD_MATERIAL_FLAGS_UNLIT_BIT,
}
#endif

// x: albedo scale, y: relief scale (`GroundDetail`), z, w unused.
@group(#{MATERIAL_BIND_GROUP}) @binding(100) var<uniform> detail_scales: vec4<f32>;

const OCTAVES: u32 = 7u;
// Wavelength of the coarsest octave (m) and the ratio between octaves.
const COARSEST: f32 = 160.0;
const RATIO: f32 = 2.5;
const TAU: f32 = 6.283185307;
// Longest footprint, in multiples of the one the octaves fade by (and most taps along it).
const MAX_ANISO: f32 = 4.0;

fn hash_u32(x: u32) -> u32 {
    // PCG output permutation.
    let s = x * 747796405u + 2891336453u;
    let w = ((s >> ((s >> 28u) + 4u)) ^ s) * 277803737u;
    return (w >> 22u) ^ w;
}

// Unit gradient of lattice point `c` of octave `seed`.
fn gradient(c: vec2<i32>, seed: u32) -> vec2<f32> {
    let h = hash_u32(bitcast<u32>(c.x) ^ hash_u32(bitcast<u32>(c.y) ^ (seed * 0x9e3779b9u)));
    let a = f32(h >> 8u) * (TAU / 16777216.0);
    return vec2<f32>(cos(a), sin(a));
}

// Gradient noise at `p` (lattice units) and its derivatives: (value ≈ −0.7..0.7, d/dx, d/dy).
fn noise_d(p: vec2<f32>, seed: u32) -> vec3<f32> {
    let fl = floor(p);
    let i = vec2<i32>(fl);
    let f = p - fl;
    let u = f * f * f * (f * (f * 6.0 - 15.0) + 10.0);
    let du = 30.0 * f * f * (f * (f - 2.0) + 1.0);
    let ga = gradient(i, seed);
    let gb = gradient(i + vec2<i32>(1, 0), seed);
    let gc = gradient(i + vec2<i32>(0, 1), seed);
    let gd = gradient(i + vec2<i32>(1, 1), seed);
    let va = dot(ga, f);
    let vb = dot(gb, f - vec2<f32>(1.0, 0.0));
    let vc = dot(gc, f - vec2<f32>(0.0, 1.0));
    let vd = dot(gd, f - vec2<f32>(1.0, 1.0));
    let k = va - vb - vc + vd;
    let v = va + u.x * (vb - va) + u.y * (vc - va) + u.x * u.y * k;
    let d = ga + u.x * (gb - ga) + u.y * (gc - ga) + u.x * u.y * (ga - gb - gc + gd)
        + du * (u.yx * k + vec2<f32>(vb, vc) - va);
    return vec3<f32>(v, d);
}

@fragment
fn fragment(
    vertex_output: VertexOutput,
    @builtin(front_facing) is_front: bool,
) -> FragmentOutput {
    var in = vertex_output;
    // Derivatives first, in uniform control flow: the ground-plane steps (the noise is of x, z)
    // to the next pixel across and down; the longer is the footprint's long side.
    let wp = in.world_position.xyz;
    let step_x = dpdx(wp.xz);
    let step_y = dpdy(wp.xz);
    let len_x = length(step_x);
    let len_y = length(step_y);
    let long_side = select(step_y, step_x, len_x >= len_y);
    let long_len = max(len_x, len_y);
    // What the octaves fade by: the short side, but no less than a MAX_ANISO-th of the long one.
    let footprint = max(min(len_x, len_y), long_len / MAX_ANISO);
    // Taps along the long side, each covering about one `footprint` of it.
    let taps = u32(clamp(ceil(long_len / max(footprint, 1e-6) - 1e-3), 1.0, MAX_ANISO));

    var pbr_input = pbr_input_from_standard_material(in, is_front);
    pbr_input.material.base_color = alpha_discard(pbr_input.material, pbr_input.material.base_color);

    // How much detail this ground takes, from its colour (look rules).
    let c = max(pbr_input.material.base_color.rgb, vec3<f32>(0.0));
    let wet = smoothstep(0.15, 0.35, (c.b - c.r) / max(c.b, 1e-4));
    let green = smoothstep(0.05, 0.3, (c.g - max(c.r, c.b)) / max(c.g, 1e-4));
    let snow = smoothstep(0.35, 0.6, dot(c, vec3<f32>(0.2126, 0.7152, 0.0722)));
    let relief_w = detail_scales.y * (1.0 - wet) * mix(1.0, 0.35, green) * mix(1.0, 0.5, snow);
    let albedo_w = detail_scales.x * (1.0 - wet) * mix(1.0, 0.6, green) * mix(1.0, 0.4, snow);

    if relief_w > 0.0 || albedo_w > 0.0 {
        var lambda = COARSEST;
        var value = 0.0;
        var slope = vec2<f32>(0.0);
        for (var k = 0u; k < OCTAVES; k++) {
            let keep = 1.0 - smoothstep(0.25 * lambda, 0.5 * lambda, footprint);
            // Finer octaves fade sooner: none of them shows either.
            if keep <= 0.0 {
                break;
            }
            // An octave longer than four long sides takes one tap: the long side cannot alias it.
            var n = vec3<f32>(0.0);
            let octave_taps = select(1u, taps, lambda < 4.0 * long_len);
            for (var t = 0u; t < octave_taps; t++) {
                let along = (f32(t) + 0.5) / f32(octave_taps) - 0.5;
                n += noise_d((wp.xz + along * long_side) / lambda, k + 1u);
            }
            n = n / f32(octave_taps);
            // Equal weights: brightness patches at every scale.
            value += keep * n.x;
            // Height amplitude proportional to the wavelength: the slope of each octave is
            // about the same (the derivative in lattice units), a little less for the finest.
            slope += keep * (0.11 - 0.008 * f32(k)) * n.yz;
            lambda = lambda / RATIO;
        }
        // About ±20 % brightness at full weight.
        let shade = clamp(1.0 + albedo_w * 0.25 * value, 0.5, 1.5);
        pbr_input.material.base_color = vec4<f32>(
            pbr_input.material.base_color.rgb * shade,
            pbr_input.material.base_color.a,
        );
        // Tilt the normal by the detail height's surface gradient.
        let n0 = pbr_input.N;
        // At most a 31° tilt where the octaves' slopes add up (faces turned fully from a low
        // sun would go black).
        var g = vec3<f32>(slope.x, 0.0, slope.y) * relief_w;
        g = g * min(1.0, 0.6 / max(length(g), 1e-6));
        pbr_input.N = normalize(n0 - (g - n0 * dot(n0, g)));
    }

#ifdef PREPASS_PIPELINE
    let out = deferred_output(in, pbr_input);
#else
    var out: FragmentOutput;
    if (pbr_input.material.flags & STANDARD_MATERIAL_FLAGS_UNLIT_BIT) == 0u {
        out.color = apply_pbr_lighting(pbr_input);
    } else {
        out.color = pbr_input.material.base_color;
    }
    out.color = main_pass_post_lighting_processing(pbr_input, out.color);
#endif
    return out;
}
