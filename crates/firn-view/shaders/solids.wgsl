// Colliders as shaded triangles: unit geometry (a sphere, a box, a
// cylinder) or a mesh, scaled, moved and turned per instance, lit with Blinn-Phong like
// firn_render::stage.

struct SolidIn {
    @location(0) position: vec3<f32>,
    @location(1) normal: vec3<f32>,
    @location(2) offset: vec3<f32>,
    @location(3) scale: vec3<f32>,
    @location(4) albedo: vec3<f32>,
    @location(5) shininess: f32,
    @location(6) rotation: vec4<f32>,
    @location(7) pivot: vec3<f32>,
}

struct SolidOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) world: vec3<f32>,
    @location(1) normal: vec3<f32>,
    @location(2) albedo: vec3<f32>,
    @location(3) shininess: f32,
}

// The vector v turned by the unit quaternion q = (x, y, z, w).
fn turn(q: vec4<f32>, v: vec3<f32>) -> vec3<f32> {
    let t = 2.0 * cross(q.xyz, v);
    return v + q.w * t + cross(q.xyz, t);
}

@vertex
fn vertex_solid(input: SolidIn) -> SolidOut {
    let placed = input.position * input.scale + input.offset;
    let world = input.pivot + turn(input.rotation, placed - input.pivot);
    var output: SolidOut;
    output.clip = frame.camera.view_projection * vec4<f32>(world, 1.0);
    output.world = world;
    // Normals of a scaled surface scale inversely.
    output.normal = turn(input.rotation, input.normal / input.scale);
    output.albedo = input.albedo;
    output.shininess = input.shininess;
    return output;
}

@fragment
fn fragment_solid(input: SolidOut) -> @location(0) vec4<f32> {
    let view_direction = normalize(input.world - frame.camera.eye);
    let color = shade_surface(input.albedo, normalize(input.normal), view_direction, input.shininess);
    return target_color(color);
}
