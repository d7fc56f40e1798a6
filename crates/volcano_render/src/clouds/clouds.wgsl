// Lit volumetric clouds (module `clouds::material`), and with a tint the ash fall
// (module `ash_fall`): the back faces of a box around the atmosphere's density volume, drawn without a depth test, march the view ray through
// the 3D density texture from the camera (or the box's entry) to the box's exit or the opaque
// scene (depth prepass, when the camera has one). Per sample: a short march toward the sun
// (Beer–Lambert), three octaves of approximated multiple scattering, a two-lobe
// Henyey–Greenstein phase (forward lobe: silver lining), a powder term, and ambient sky light
// dimmed by the cloud above the sample; lumps from a noise (`sigma_detailed`). Where the view
// ray meets the opaque scene, a second sun march from that point gives the cloud's shadow,
// applied by darkening what is behind through the blend (premultiplied alpha: out = cloud +
// scene · T_view · shadow).
// Each box is drawn twice (volcano_render::clouds::split): the part of each ray behind the
// viewer's ash before the ash, the part in front of it after; both keep the whole ray's step
// length (a short part at least 16 steps), so the pair costs about one march.

#import bevy_pbr::forward_io::VertexOutput
#import bevy_pbr::mesh_view_bindings::{view, lights, fog}
#import bevy_pbr::view_transformations::{position_ndc_to_world, frag_coord_to_uv, uv_to_ndc}
#import bevy_pbr::pbr_functions::apply_fog
#import bevy_pbr::prepass_utils

#ifdef TONEMAP_IN_SHADER
#import bevy_core_pipeline::tonemapping::tone_mapping
#endif

struct CloudUniform {
    // Density volume (world, metres) and extinction per g/m³ of condensed water (1/m).
    volume_min: vec3<f32>,
    extinction: f32,
    volume_max: vec3<f32>,
    // Condensed water (g/m³) at which a texel reaches 1 − 1/e (the image's encoding).
    density_scale: f32,
    // x forward HG g, y backward HG g, z backward weight, w powder strength.
    phase: vec4<f32>,
    // x view steps, y sun steps, z sun march length (m), w shadow strength on the ground.
    march: vec4<f32>,
    // x sun gain, y ambient gain, z single-scattering albedo, w powder length (m).
    light: vec4<f32>,
    // Colour of the scattered light (linear RGB; white for cloud water, brown grey for ash).
    tint: vec4<f32>,
    // x density-noise strength (0: none), y 1 / noise feature size (1/m), z displacement (m).
    detail: vec4<f32>,
    // 0: the part of each ray behind the ash (all of it where there is none), drawn before the
    // ash; 1: the part in front of the ash, drawn after it (volcano_render::clouds::split).
    segment: u32,
    // Density samples per view step (1–8).
    substeps: u32,
    // 1: skip steps whose stretch of the volume is empty (the maximum levels); 0: march all.
    skip_empty: u32,
}

@group(#{MATERIAL_BIND_GROUP}) @binding(0) var<uniform> cloud: CloudUniform;
@group(#{MATERIAL_BIND_GROUP}) @binding(1) var density_texture: texture_3d<f32>;
@group(#{MATERIAL_BIND_GROUP}) @binding(2) var density_sampler: sampler;
// The viewer's ash depth (volcano_render::plume::depth): r the distance (km) to where the ash
// begins along the ray (the nearest ash at least 3 % opaque), g = 0 where there is ash.
@group(#{MATERIAL_BIND_GROUP}) @binding(3) var ash_depth_texture: texture_2d<f32>;

const PI: f32 = 3.141592653589793;

// Ray–box intersection: (t_near, t_far); empty when t_near > t_far.
fn box_hit(o: vec3<f32>, d: vec3<f32>, lo: vec3<f32>, hi: vec3<f32>) -> vec2<f32> {
    let inv = 1.0 / select(d, vec3(1e-9), abs(d) < vec3(1e-9));
    let a = (lo - o) * inv;
    let b = (hi - o) * inv;
    let t0 = min(a, b);
    let t1 = max(a, b);
    return vec2(max(max(t0.x, t0.y), t0.z), min(min(t1.x, t1.y), t1.z));
}

// Extinction (1/m) at a world position: the texel decoded back to g/m³ times the extinction
// per g/m³; zero outside the volume.
fn sigma_at(p: vec3<f32>) -> f32 {
    let uvw = volume_uvw(p);
    if outside(uvw) {
        return 0.0;
    }
    return sigma_of_texel(textureSampleLevel(density_texture, density_sampler, uvw, 0.0).r);
}

// Position in the volume (0–1 on each axis inside it).
fn volume_uvw(p: vec3<f32>) -> vec3<f32> {
    return (p - cloud.volume_min) / (cloud.volume_max - cloud.volume_min);
}

fn outside(uvw: vec3<f32>) -> bool {
    return any(uvw < vec3(0.0)) || any(uvw > vec3(1.0));
}

// Extinction (1/m) of a texel: decoded back to g/m³ times the extinction per g/m³.
fn sigma_of_texel(texel: f32) -> f32 {
    return -cloud.density_scale * log(1.0 - min(texel, 0.996)) * cloud.extinction;
}

// Hash of a lattice point to [0, 1] (integer mixing; any such hash would do).
fn lattice_hash(c: vec3<i32>) -> f32 {
    var h = (bitcast<u32>(c.x) * 73856093u) ^ (bitcast<u32>(c.y) * 19349663u) ^ (bitcast<u32>(c.z) * 83492791u);
    h = (h ^ (h >> 16u)) * 0x45d9f3bu;
    h = (h ^ (h >> 16u)) * 0x45d9f3bu;
    h = h ^ (h >> 16u);
    return f32(h) * (1.0 / 4294967295.0);
}

// Value noise in [0, 1]: the lattice hashes blended by a smoothstep.
fn value_noise(p: vec3<f32>) -> f32 {
    let i = vec3<i32>(floor(p));
    let f = fract(p);
    let u = f * f * (3.0 - 2.0 * f);
    let x00 = mix(lattice_hash(i), lattice_hash(i + vec3(1, 0, 0)), u.x);
    let x10 = mix(lattice_hash(i + vec3(0, 1, 0)), lattice_hash(i + vec3(1, 1, 0)), u.x);
    let x01 = mix(lattice_hash(i + vec3(0, 0, 1)), lattice_hash(i + vec3(1, 0, 1)), u.x);
    let x11 = mix(lattice_hash(i + vec3(0, 1, 1)), lattice_hash(i + vec3(1, 1, 1)), u.x);
    return mix(mix(x00, x10, u.y), mix(x01, x11, u.y), u.z);
}

// The density volume's voxels are ≈ 100 m and smoothed, so every cloud is a smooth rounded
// blob. Two look rules (after production cloud renderers; not physics; the ash fall uses
// neither) give it lumps: the volume is read at a position displaced by a noise vector of up
// to `detail.z` metres (its outline bulges out and in), and the density read there is
// multiplied by 1 + strength · (2n − 1) for a finer noise n in [0, 1] (mean 1: the clouds'
// amount is kept, a thin deck is textured rather than erased). Each octave fades out as the
// march's spacing `footprint` (m) grows from half its wavelength to all of it: a march with
// fewer than two samples per wavelength cannot show it, only alias it into per-pixel noise
// (as the ground detail fades with the pixel's footprint, `terrain/detail.wgsl`).
fn sigma_detailed(p: vec3<f32>, footprint: f32) -> f32 {
    return sigma_lumpy(p, lumps(p, footprint));
}

// The lumps at `p` (see `sigma_detailed`): xyz how far (m) the volume is read from `p`, w the
// density's factor (mean 1). None when the noise is off or faded out.
fn lumps(p: vec3<f32>, footprint: f32) -> vec4<f32> {
    let size = 1.0 / max(cloud.detail.y, 1e-9);
    // The coarsest octave fades last: when it is gone, so are the others.
    let k_warp = octave_keep(size, footprint);
    if cloud.detail.x <= 0.0 || k_warp <= 0.0 {
        return vec4(0.0, 0.0, 0.0, 1.0);
    }
    let q = p * cloud.detail.y;
    // Two octaves of displacement: bulges the size of the features, and lumps on them
    // 2.7 times smaller and displaced 0.4 times as far.
    var warp = k_warp * (vec3(
        value_noise(q + vec3(31.7, 0.0, 0.0)),
        value_noise(q + vec3(0.0, 47.3, 0.0)),
        value_noise(q + vec3(0.0, 0.0, 23.9)),
    ) - vec3(0.5));
    let k_lumps = octave_keep(size / 2.7, footprint);
    if k_lumps > 0.0 {
        let q2 = q * 2.7 + vec3(5.3, 1.9, 7.7);
        warp += 0.4 * k_lumps * (vec3(
            value_noise(q2 + vec3(11.1, 0.0, 0.0)),
            value_noise(q2 + vec3(0.0, 13.7, 0.0)),
            value_noise(q2 + vec3(0.0, 0.0, 19.3)),
        ) - vec3(0.5));
    }
    // The density noise in [0, 1] with mean ½, its octaves faded toward ½.
    var n = 0.5;
    let k_coarse = octave_keep(size / 1.9, footprint);
    if k_coarse > 0.0 {
        n += 0.6 * k_coarse * (value_noise(q * 1.9 + vec3(17.3, 5.1, 9.7)) - 0.5);
    }
    let k_fine = octave_keep(size / 4.3, footprint);
    if k_fine > 0.0 {
        n += 0.4 * k_fine * (value_noise(q * 4.3 + vec3(3.1, 8.2, 1.3)) - 0.5);
    }
    // Density times 1 + strength · (2n − 1): mean 1, so a thin deck is textured, not erased.
    return vec4(2.0 * cloud.detail.z * warp, max(1.0 + cloud.detail.x * (2.0 * n - 1.0), 0.0));
}

// Extinction (1/m) at `p` read through the lumps `d` (from `lumps`); zero outside the volume.
fn sigma_lumpy(p: vec3<f32>, d: vec4<f32>) -> f32 {
    if outside(volume_uvw(p)) {
        return 0.0;
    }
    // Kept inside the volume: a read displaced out of it would carve straight-walled holes
    // into clouds along the box's sides (seen in `skyscape` where the view enters the box).
    let r = clamp(p + d.xyz, cloud.volume_min, cloud.volume_max);
    let t = textureSampleLevel(density_texture, density_sampler, volume_uvw(r), 0.0).r;
    return sigma_of_texel(t) * d.w;
}

// How much of a noise octave of `wavelength` (m) a march with samples `footprint` m apart
// keeps: all up to half the wavelength, none from a whole one.
fn octave_keep(wavelength: f32, footprint: f32) -> f32 {
    return 1.0 - smoothstep(0.5 * wavelength, wavelength, footprint);
}

// Optical depth from `p` toward the sun `l`, up to the volume's exit or the march length;
// steps grow quadratically (fine near the sample, coarse far away), each sampled at its
// middle, not jittered per pixel: over the far steps, up to a kilometre long, a jitter turns
// the shaded parts of every deck and the clouds' shadows on the ground into a fine per-pixel
// hatch (`skyscape`'s decks: mean |ΔL| 0.71 at the middles, 3.04 jittered).
fn sun_depth(p: vec3<f32>, l: vec3<f32>) -> f32 {
    let hit = box_hit(p, l, cloud.volume_min, cloud.volume_max);
    let len = min(max(hit.y, 0.0), cloud.march.z);
    if len <= 0.0 || hit.x > hit.y {
        return 0.0;
    }
    let n = max(cloud.march.y, 1.0);
    var tau = 0.0;
    var prev = max(hit.x, 0.0);
    for (var i = 0.0; i < n; i += 1.0) {
        let t = len * ((i + 1.0) / n) * ((i + 1.0) / n);
        if t <= prev {
            continue;
        }
        let mid = 0.5 * (prev + t);
        let q = p + l * mid;
        var sigma = 0.0;
        if i < 2.0 {
            sigma = sigma_detailed(q, t - prev);
        } else {
            sigma = sigma_at(q);
        }
        tau += sigma * (t - prev);
        prev = t;
    }
    return tau;
}

fn henyey_greenstein(cos_theta: f32, g: f32) -> f32 {
    let g2 = g * g;
    let denom = max(1.0 + g2 - 2.0 * g * cos_theta, 1e-4);
    return (1.0 - g2) / (4.0 * PI * denom * sqrt(denom));
}

// Two lobes: forward (silver lining when looking toward the sun) and backward.
fn phase(cos_theta: f32, scale: f32) -> f32 {
    let f = henyey_greenstein(cos_theta, cloud.phase.x * scale);
    let b = henyey_greenstein(cos_theta, cloud.phase.y * scale);
    return mix(f, b, cloud.phase.z);
}

fn interleaved_gradient_noise(xy: vec2<f32>) -> f32 {
    return fract(52.9829189 * fract(dot(xy, vec2(0.06711056, 0.00583715))));
}

@fragment
fn fragment(in: VertexOutput) -> @location(0) vec4<f32> {
    let origin = view.world_position.xyz;
    let ray = normalize(in.world_position.xyz - origin);
    let hit = box_hit(origin, ray, cloud.volume_min, cloud.volume_max);
    var t0 = max(hit.x, 0.0);
    var t1 = hit.y;

    // The opaque scene behind this pixel, when the camera has a depth prepass.
    var surface = false;
    var surface_pos = vec3(0.0);
#ifdef DEPTH_PREPASS
    let depth = prepass_utils::prepass_depth(in.position, 0u);
    if depth > 0.0 {
        let ndc = vec3(uv_to_ndc(frag_coord_to_uv(in.position.xy)), depth);
        surface_pos = position_ndc_to_world(ndc);
        surface = true;
        t1 = min(t1, dot(surface_pos - origin, ray));
    }
#endif

    // The step length of the whole ray, kept for either part of it.
    let n_full = max(cloud.march.x, 1.0);
    let dt_full = max(t1 - t0, 0.0) / n_full;
    let dims = vec2<i32>(textureDimensions(ash_depth_texture));
    let texel = clamp(vec2<i32>(in.position.xy), vec2<i32>(0), dims - vec2<i32>(1));
    let ash = textureLoad(ash_depth_texture, texel, 0).rg;
    let has_ash = ash.g < 0.5;
    let t_ash = ash.r * 1000.0;
    let front = cloud.segment == 1u;
    if front {
        if !has_ash || t_ash <= t0 {
            discard;
        }
        t1 = min(t1, t_ash);
    } else if has_ash {
        t0 = max(t0, min(t_ash, t1));
    }

    let jitter = interleaved_gradient_noise(in.position.xy);
    var l = vec3(0.0, 1.0, 0.0);
    var sun = vec3(0.0);
    if lights.n_directional_lights > 0u {
        l = lights.directional_lights[0].direction_to_light;
        sun = lights.directional_lights[0].color.rgb * view.exposure * cloud.light.x;
    }
    let ambient = lights.ambient_color.rgb * view.exposure * cloud.light.y;
    let cos_theta = dot(ray, l);
    let albedo = cloud.light.z * cloud.tint.rgb;
    // Multiple scattering, three octaves (a, b, c = ½): light deeper in a cloud arrives
    // through less extinction and a broader phase, so dense cores are not black.
    let p0 = phase(cos_theta, 1.0);
    let p1 = phase(cos_theta, 0.5);
    let p2 = phase(cos_theta, 0.25);

    var transmittance = 1.0;
    var radiance = vec3(0.0);
    var weighted_t = 0.0;
    var weight = 0.0;
    if t1 > t0 && dt_full > 0.0 {
        // A short part keeps at least 16 steps (or all of them): with one or two jittered steps
        // the part in front of the ash shows as a per-pixel checker over it.
        let n = min(max(ceil((t1 - t0) / dt_full), 16.0), n_full);
        let dt = (t1 - t0) / n;
        // Density samples per step (at most 8: the size of `sig`). Fewer, from how many voxels
        // a ray crosses in a step (two samples per voxel crossed), bring `skyscape_island`'s
        // checker back (its band's |ΔL| 29.7 against 6.9 with 8).
        let m = f32(clamp(cloud.substeps, 1u, 8u));
        let ds = dt / m;
        // The occupancy level: the coarsest whose texels (maxima over themselves and their
        // neighbours, `density_volume::append_max_levels`) are wider than half a step plus the
        // lumps' displacement plus one voxel (a filtered read of the finest level weighs the
        // voxels whose centres lie within one voxel of it). The texel around the step's
        // middle, read unfiltered, then covers everything the step's samples can read: where
        // it is 0 the step holds no cloud. (The level is not read through the linear filter:
        // its 8-bit result rounds a faint texel's small share to 0, so faint puffs near the
        // edges of the coarse texels would be skipped. Stale levels, the other way to lose
        // cloud here, are avoided in `density_volume::density_image`.)
        let fine_dims = vec3<i32>(textureDimensions(density_texture));
        let voxel = (cloud.volume_max - cloud.volume_min) / vec3<f32>(fine_dims);
        let voxel_min = max(min(voxel.x, min(voxel.y, voxel.z)), 1e-3);
        let reach = 0.5 * dt + select(0.0, 1.4 * cloud.detail.z, cloud.detail.x > 0.0);
        let top_level = i32(textureNumLevels(density_texture)) - 1;
        let level = clamp(i32(ceil(log2(reach / voxel_min + 1.01))), 0, top_level);
        let level_dims = vec3<i32>(textureDimensions(density_texture, level));
        for (var i = 0.0; i < n; i += 1.0) {
            // The level's texel over the finest voxel at the step's middle (an odd axis's
            // leftover voxel belongs to its last texel, as `append_max_levels` groups them).
            let mid = volume_uvw(origin + ray * (t0 + (i + 0.5) * dt));
            let fine = clamp(vec3<i32>(floor(mid * vec3<f32>(fine_dims))), vec3(0), fine_dims - vec3(1));
            let texel = min(fine >> vec3<u32>(u32(level)), level_dims - vec3(1));
            if cloud.skip_empty != 0u && textureLoad(density_texture, texel, level).r <= 0.0 {
                continue;
            }
            // The step's density at `m` jittered points (a sheet thinner than a step is not
            // missed by every other pixel); its light once, at the first cloudy one (the
            // front of the step, which the eye sees through the least cloud).
            var sig: array<f32, 8>;
            var t_front = -1.0;
            // The lumps once per step, at its middle (the noise is the costly part of a
            // sample; its features are larger than a sub-step).
            let d = lumps(origin + ray * (t0 + (i + 0.5) * dt), ds);
            for (var j = 0u; j < u32(m); j++) {
                let tj = t0 + (i + (f32(j) + jitter) / m) * dt;
                let s = sigma_lumpy(origin + ray * tj, d);
                sig[j] = s;
                if s > 1e-7 && t_front < 0.0 {
                    t_front = tj;
                }
            }
            if t_front < 0.0 {
                continue;
            }
            let p = origin + ray * t_front;
            let tau = sun_depth(p, l);
            let direct = p0 * exp(-tau) + 0.5 * p1 * exp(-0.5 * tau) + 0.25 * p2 * exp(-0.25 * tau);
            // Sky light from above, dimmed by the cloud over the sample (two samples).
            let up = sigma_at(p + vec3(0.0, 150.0, 0.0)) * 300.0 + sigma_at(p + vec3(0.0, 600.0, 0.0)) * 600.0;
            let sky = ambient * mix(0.35, 1.0, exp(-up));
            // Powder: thin edges facing away from the sun have had little light scattered
            // into them; fades out toward the sun so the silver lining stays.
            let powder_on = cloud.phase.w * (0.5 - 0.5 * cos_theta);
            var done = false;
            for (var j = 0u; j < u32(m); j++) {
                let sigma = sig[j];
                if sigma <= 1e-7 {
                    continue;
                }
                let powder = mix(1.0, 1.0 - exp(-2.0 * sigma * cloud.light.w), powder_on);
                let source = albedo * (sun * direct * powder + sky);
                let step_t = exp(-sigma * ds);
                let gain = transmittance * (1.0 - step_t);
                // Energy-conserving step (the source integrated over the segment).
                radiance += source * gain;
                weighted_t += (t0 + (i + (f32(j) + 0.5) / m) * dt) * gain;
                weight += gain;
                transmittance *= step_t;
                if transmittance < 0.01 {
                    transmittance = 0.0;
                    done = true;
                    break;
                }
            }
            if done {
                break;
            }
        }
    }

    // Cloud shadow on the opaque scene behind the clouds (once: by the part behind the ash).
    var shade = 1.0;
    if surface && !front && l.y > 0.0 && transmittance > 0.0 {
        let tau = sun_depth(surface_pos + l * 2.0, l);
        shade = 1.0 - cloud.march.w * (1.0 - exp(-tau));
    }

    let alpha = 1.0 - transmittance;
    var color = vec3(0.0);
    if alpha > 1e-4 {
        var c = vec4(radiance / alpha, 1.0);
#ifdef DISTANCE_FOG
        let mean_pos = origin + ray * (weighted_t / max(weight, 1e-6));
        c = apply_fog(fog, c, mean_pos, origin, in.position.xy);
#endif
#ifdef TONEMAP_IN_SHADER
        c = tone_mapping(c, view.color_grading);
#endif
        color = c.rgb * alpha;
    }
    // Premultiplied blend: color + scene · (1 − a) = color + scene · T_view · shade.
    return vec4(color, 1.0 - transmittance * shade);
}
