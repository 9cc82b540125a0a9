// Particles as camera-facing quads, one instance each: `points` shades each
// quad as a small sphere (firn_render::points), `billboards` adds a soft
// round sprite (firn_render::billboards).

struct SpriteOut {
    @builtin(position) clip: vec4<f32>,
    // Position on the sprite: the unit disc spans [-1, 1]².
    @location(0) disc: vec2<f32>,
    @location(1) @interpolate(flat) center: vec3<f32>,
    @location(2) @interpolate(flat) world_radius: f32,
    @location(3) @interpolate(flat) color: vec3<f32>,
}

// Corners of a quad as two triangles.
fn quad_corner(index: u32) -> vec2<f32> {
    var corners = array<vec2<f32>, 6>(
        vec2<f32>(-1.0, -1.0), vec2<f32>(1.0, -1.0), vec2<f32>(1.0, 1.0),
        vec2<f32>(-1.0, -1.0), vec2<f32>(1.0, 1.0), vec2<f32>(-1.0, 1.0),
    );
    return corners[index];
}

@vertex
fn vertex_sprite(@builtin(vertex_index) vertex: u32, @builtin(instance_index) particle: u32) -> SpriteOut {
    let camera = frame.camera;
    let center = particle_position(particle);
    let depth = dot(center - camera.eye, camera.forward);
    // Far particles stay at least a few pixels wide so they do not vanish.
    let min_radius = frame.sprites.min_radius_pixels * camera.pixel_size * max(depth, 0.0);
    let radius = max(frame.sprites.radius, min_radius);
    let disc = quad_corner(vertex);
    let world = center + (disc.x * camera.right + disc.y * camera.up) * radius;
    var output: SpriteOut;
    output.clip = camera.view_projection * vec4<f32>(world, 1.0);
    output.disc = disc;
    output.center = center;
    output.world_radius = radius;
    output.color = particle_color(particle, center);
    return output;
}

struct PointOut {
    @location(0) color: vec4<f32>,
    @builtin(frag_depth) depth: f32,
}

// Lambert plus a soft Blinn-Phong highlight lit by the key light and the
// sky, like firn_render::points::shade_sphere.
fn shade_sphere(albedo: vec3<f32>, normal: vec3<f32>) -> vec3<f32> {
    let light = frame.light;
    let half_vector = normalize(light.direction - frame.camera.forward);
    let diffuse = max(dot(normal, light.direction), 0.0);
    // The ambient term wraps with the normal so sprites read as round in shade.
    let sky_light = 0.6 + 0.4 * normal.y;
    let specular = pow(max(dot(normal, half_vector), 0.0), 24.0) * 0.18;
    return albedo * (light.ambient * sky_light * 1.6 + light.color * diffuse * 0.85) + light.color * specular;
}

@fragment
fn fragment_point(input: SpriteOut) -> PointOut {
    let r2 = dot(input.disc, input.disc);
    if r2 > 1.0 {
        discard;
    }
    let camera = frame.camera;
    let nz = sqrt(1.0 - r2);
    let normal = input.disc.x * camera.right + input.disc.y * camera.up - nz * camera.forward;
    let surface = input.center + normal * input.world_radius;
    return PointOut(target_color(shade_sphere(input.color, normal)), depth_of(surface));
}

@fragment
fn fragment_billboard(input: SpriteOut) -> @location(0) vec4<f32> {
    let r2 = dot(input.disc, input.disc);
    if r2 > 1.0 {
        discard;
    }
    let falloff = (1.0 - r2) * (1.0 - r2);
    return target_color(input.color * (frame.sprites.intensity * falloff));
}
