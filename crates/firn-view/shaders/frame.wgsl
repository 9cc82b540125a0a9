// What every drawing pass of a frame shares (group 0): the camera, the
// light, the backdrop, the particle colouring and the ramp table. Prepended
// to the other drawing shaders.

struct Camera {
    view_projection: mat4x4<f32>,
    inverse_view_projection: mat4x4<f32>,
    eye: vec3<f32>,
    // World size of one pixel at unit distance in front of the eye.
    pixel_size: f32,
    right: vec3<f32>,
    viewport_width: f32,
    up: vec3<f32>,
    viewport_height: f32,
    forward: vec3<f32>,
    _pad: f32,
}

struct Light {
    // Unit direction from the scene towards the light.
    direction: vec3<f32>,
    _pad0: f32,
    color: vec3<f32>,
    _pad1: f32,
    ambient: vec3<f32>,
    _pad2: f32,
}

struct Backdrop {
    sky_top: vec3<f32>,
    ground_height: f32,
    sky_bottom: vec3<f32>,
    // Edge of the ground's checker tiles; 0 when there is no ground.
    ground_tile: f32,
    ground_albedo: vec2<f32>,
    // Distance from the eye where the ground starts fading into the sky,
    // and over what distance it fades.
    fog_start: f32,
    fog_span: f32,
    edge_color: vec3<f32>,
    _pad: f32,
}

// Colour modes of particles.
const COLOR_BY_VALUE: u32 = 0u;
const COLOR_BY_POSITION: u32 = 1u;
const COLOR_UNIFORM: u32 = 2u;

struct Coloring {
    uniform_color: vec3<f32>,
    mode: u32,
    box_min: vec3<f32>,
    range_low: f32,
    box_max: vec3<f32>,
    range_high: f32,
}

struct Sprites {
    // Sprite radius in metres.
    radius: f32,
    // Smallest sprite radius in pixels.
    min_radius_pixels: f32,
    // Brightness an additive sprite or ribbon adds at its centre.
    intensity: f32,
    ribbon_width_pixels: f32,
}

struct Frame {
    camera: Camera,
    light: Light,
    backdrop: Backdrop,
    coloring: Coloring,
    sprites: Sprites,
}

// Samples of the ramp, evenly spaced from 0 to 1 (linear RGB).
const RAMP_SAMPLES: u32 = 65u;

@group(0) @binding(0) var<uniform> frame: Frame;
@group(0) @binding(1) var<uniform> ramp_table: array<vec4<f32>, RAMP_SAMPLES>;

// Whether the target stores linear values that must be sRGB-encoded here
// (a non-sRGB format); sRGB formats encode on store.
override ENCODE_SRGB: bool = false;

fn encode_srgb(linear: vec3<f32>) -> vec3<f32> {
    let c = clamp(linear, vec3<f32>(0.0), vec3<f32>(1.0));
    let low = c * 12.92;
    let high = 1.055 * pow(c, vec3<f32>(1.0 / 2.4)) - 0.055;
    return select(high, low, c <= vec3<f32>(0.0031308));
}

// The fragment output for a linear colour.
fn target_color(linear: vec3<f32>) -> vec4<f32> {
    if ENCODE_SRGB {
        return vec4<f32>(encode_srgb(linear), 1.0);
    }
    return vec4<f32>(linear, 1.0);
}

// The ramp colour at t in [0, 1] (clamped), like firn_render::ramp::ramp.
fn ramp(t: f32) -> vec3<f32> {
    let scaled = clamp(t, 0.0, 1.0) * f32(RAMP_SAMPLES - 1u);
    let index = min(u32(floor(scaled)), RAMP_SAMPLES - 2u);
    let s = scaled - f32(index);
    return mix(ramp_table[index].rgb, ramp_table[index + 1u].rgb, s);
}

// Sky colour at a framebuffer row (y from the top, in pixels).
fn sky(pixel_y: f32) -> vec3<f32> {
    let t = clamp(pixel_y / frame.camera.viewport_height, 0.0, 1.0);
    return mix(frame.backdrop.sky_top, frame.backdrop.sky_bottom, t);
}

// Depth in the target's 0..1 range of a world point.
fn depth_of(world: vec3<f32>) -> f32 {
    let clip = frame.camera.view_projection * vec4<f32>(world, 1.0);
    return clamp(clip.z / clip.w, 0.0, 1.0);
}

// Blinn-Phong of a solid surface seen along `view_direction` (from the eye),
// like firn_render::stage: ambient + diffuse + specular, either side lit.
fn shade_surface(albedo: vec3<f32>, surface_normal: vec3<f32>, view_direction: vec3<f32>, shininess: f32) -> vec3<f32> {
    let light = frame.light;
    let normal = select(surface_normal, -surface_normal, dot(surface_normal, view_direction) > 0.0);
    let diffuse = max(dot(normal, light.direction), 0.0);
    var color = albedo * (light.ambient + light.color * diffuse);
    if shininess > 0.0 && diffuse > 0.0 {
        let half_vector = normalize(light.direction - view_direction);
        let specular = pow(max(dot(normal, half_vector), 0.0), shininess);
        color += light.color * (0.35 * specular);
    }
    return color;
}
