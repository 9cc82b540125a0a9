// Trails (group 2): every particle's ring of recent positions drawn as a
// ribbon of constant width on screen, one quad per segment, fading with the
// square of the age towards the oldest end and added onto the picture
// (firn_render::trails). One instance per particle.

struct Rings {
    // Points kept per ring.
    capacity: u32,
    // Ring slot of every particle's newest point, or NEWEST_LAST when each
    // ring is stored oldest first (its newest point at slot length − 1).
    head: u32,
    _pad0: u32,
    _pad1: u32,
}

const NEWEST_LAST: u32 = 0xffffffffu;

@group(2) @binding(0) var<uniform> rings: Rings;
@group(2) @binding(1) var<storage, read> ring_points: array<f32>;
@group(2) @binding(2) var<storage, read> ring_lengths: array<u32>;

struct RibbonOut {
    @builtin(position) clip: vec4<f32>,
    // Across the ribbon: -1 at one edge, 1 at the other.
    @location(0) across: f32,
    @location(1) color: vec3<f32>,
}

// Point `j` (0 is the oldest) of particle `particle`'s ring of `length` points.
fn ring_point(particle: u32, j: u32, length: u32) -> vec3<f32> {
    let newest = select(rings.head, length - 1u, rings.head == NEWEST_LAST);
    let slot = (newest + rings.capacity - (length - 1u - j)) % rings.capacity;
    let base = 3u * (particle * rings.capacity + slot);
    return vec3<f32>(ring_points[base], ring_points[base + 1u], ring_points[base + 2u]);
}

fn to_pixels(clip: vec4<f32>) -> vec2<f32> {
    let camera = frame.camera;
    return clip.xy / clip.w * vec2<f32>(camera.viewport_width, camera.viewport_height) * 0.5;
}

// Nothing: a vertex of a degenerate triangle.
fn no_ribbon() -> RibbonOut {
    return RibbonOut(vec4<f32>(0.0, 0.0, 0.0, 1.0), 0.0, vec3<f32>(0.0));
}

@vertex
fn vertex_ribbon(@builtin(vertex_index) vertex: u32, @builtin(instance_index) particle: u32) -> RibbonOut {
    let length = ring_lengths[particle];
    let segment = vertex / 6u;
    if segment + 1u >= length {
        return no_ribbon();
    }
    // Corners (end, side) of the segment's quad as two triangles.
    var ends = array<u32, 6>(0u, 1u, 1u, 0u, 1u, 0u);
    var sides = array<f32, 6>(-1.0, -1.0, 1.0, -1.0, 1.0, 1.0);
    let corner = vertex % 6u;
    let end = ends[corner];
    let camera = frame.camera;
    let clip_a = camera.view_projection * vec4<f32>(ring_point(particle, segment, length), 1.0);
    let clip_b = camera.view_projection * vec4<f32>(ring_point(particle, segment + 1u, length), 1.0);
    // Segments reaching behind the eye are left out.
    if min(clip_a.w, clip_b.w) <= 1e-4 {
        return no_ribbon();
    }
    let along = to_pixels(clip_b) - to_pixels(clip_a);
    let direction = select(vec2<f32>(1.0, 0.0), normalize(along), dot(along, along) > 1e-12);
    let across = vec2<f32>(-direction.y, direction.x) * sides[corner];
    let half_width = 0.5 * frame.sprites.ribbon_width_pixels;
    var clip = select(clip_a, clip_b, end == 1u);
    let pixel_to_ndc = 2.0 / vec2<f32>(camera.viewport_width, camera.viewport_height);
    clip = vec4<f32>(clip.xy + across * half_width * pixel_to_ndc * clip.w, clip.zw);
    let newest = ring_point(particle, length - 1u, length);
    // Older parts fade out with the square of their age fraction.
    let age_fraction = f32(segment + end) / f32(length - 1u);
    let color = particle_color(particle, newest) * (frame.sprites.intensity * age_fraction * age_fraction);
    return RibbonOut(clip, sides[corner], color);
}

@fragment
fn fragment_ribbon(input: RibbonOut) -> @location(0) vec4<f32> {
    let edge = 1.0 - input.across * input.across;
    return target_color(input.color * edge);
}
