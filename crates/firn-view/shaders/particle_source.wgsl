// A frame's particles (group 1): positions in a strided storage array (a
// GPU simulation's own buffer, or the renderer's upload of host positions),
// and one colour value per particle. Prepended to the particle shaders,
// after frame.wgsl.

struct Source {
    count: u32,
    position_stride: u32,
    position_offset: u32,
    _pad: u32,
}

@group(1) @binding(0) var<uniform> source: Source;
@group(1) @binding(1) var<storage, read> positions: array<f32>;
@group(1) @binding(2) var<storage, read> values: array<f32>;

fn particle_position(i: u32) -> vec3<f32> {
    let base = i * source.position_stride + source.position_offset;
    return vec3<f32>(positions[base], positions[base + 1u], positions[base + 2u]);
}

// Seed 002's colour by position, like firn_render::ramp::position_color.
fn position_color(position: vec3<f32>) -> vec3<f32> {
    let coloring = frame.coloring;
    let center = 0.5 * (coloring.box_min + coloring.box_max);
    let half_extent = max(0.5 * (coloring.box_max - coloring.box_min), vec3<f32>(1e-12));
    let t = clamp(abs(position - center) / half_extent, vec3<f32>(0.0), vec3<f32>(1.0));
    return vec3<f32>(0.08) + t * 0.92;
}

// Where a value lies on the ramp, like firn_render::ramp::ValueRange::normalize.
fn normalize_value(value: f32) -> f32 {
    let span = frame.coloring.range_high - frame.coloring.range_low;
    // f32::EPSILON, as on the host.
    if abs(span) < 1.1920929e-7 {
        return 0.5;
    }
    return clamp((value - frame.coloring.range_low) / span, 0.0, 1.0);
}

// Linear colour of particle `i` at `position`.
fn particle_color(i: u32, position: vec3<f32>) -> vec3<f32> {
    switch frame.coloring.mode {
        case COLOR_BY_VALUE: {
            return ramp(normalize_value(values[i]));
        }
        case COLOR_BY_POSITION: {
            return position_color(position);
        }
        case COLOR_UNIFORM, default: {
            return frame.coloring.uniform_color;
        }
    }
}
