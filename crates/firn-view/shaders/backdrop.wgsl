// The sky gradient and the ground's checkerboard, ray-cast per pixel over
// the whole target like firn_render::stage, writing the ground's depth (the
// sky lies at the far plane).

struct BackdropOut {
    @location(0) color: vec4<f32>,
    @builtin(frag_depth) depth: f32,
}

// A triangle covering the whole viewport.
@vertex
fn vertex_fullscreen(@builtin(vertex_index) index: u32) -> @builtin(position) vec4<f32> {
    let corner = vec2<f32>(f32((index << 1u) & 2u), f32(index & 2u));
    return vec4<f32>(corner * 2.0 - 1.0, 1.0, 1.0);
}

fn unproject(ndc: vec2<f32>, depth: f32) -> vec3<f32> {
    let point = frame.camera.inverse_view_projection * vec4<f32>(ndc, depth, 1.0);
    return point.xyz / point.w;
}

// The fraction of a pixel's footprint on the checkerboard that the odd
// tiles cover: `cells` is the position in tiles, `footprint` its change
// across the pixel. Box-filtering the checker analytically (after Inigo
// Quilez) keeps far tiles from shimmering; they blend into the mean tone as
// in the supersampled CPU renderer.
fn odd_tile_coverage(cells: vec2<f32>, footprint: vec2<f32>) -> f32 {
    let width = footprint + vec2<f32>(1e-3);
    let triangle_start = abs(fract((cells - 0.5 * width) * 0.5) - 0.5);
    let triangle_end = abs(fract((cells + 0.5 * width) * 0.5) - 0.5);
    let even_odd = 2.0 * (triangle_start - triangle_end) / width;
    return 0.5 - 0.5 * even_odd.x * even_odd.y;
}

@fragment
fn fragment_backdrop(@builtin(position) pixel: vec4<f32>) -> BackdropOut {
    let camera = frame.camera;
    let backdrop = frame.backdrop;
    let ndc = vec2<f32>(
        pixel.x / camera.viewport_width * 2.0 - 1.0,
        1.0 - pixel.y / camera.viewport_height * 2.0,
    );
    let direction = normalize(unproject(ndc, 0.5) - camera.eye);
    let background = sky(pixel.y);
    let distance = (backdrop.ground_height - camera.eye.y) / direction.y;
    let hit = camera.eye + direction * distance;
    // Derivatives need uniform control flow: take them before branching.
    let cells = hit.xz / max(backdrop.ground_tile, 1e-6);
    let odd = odd_tile_coverage(cells, fwidth(cells));
    if backdrop.ground_tile <= 0.0 || !(distance > 0.0) {
        return BackdropOut(target_color(background), 1.0);
    }
    let depth = depth_of(hit);
    if depth >= 1.0 {
        return BackdropOut(target_color(background), 1.0);
    }
    let albedo = mix(backdrop.ground_albedo.x, backdrop.ground_albedo.y, odd);
    let lit = shade_surface(vec3<f32>(albedo), vec3<f32>(0.0, 1.0, 0.0), direction, 0.0);
    let haze = clamp((distance - backdrop.fog_start) / backdrop.fog_span, 0.0, 1.0);
    return BackdropOut(target_color(mix(lit, background, haze)), depth);
}
