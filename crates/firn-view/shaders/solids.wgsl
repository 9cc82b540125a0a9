// Colliders as shaded triangles: unit geometry (a sphere, a box) or a mesh,
// scaled and moved per instance, lit with Blinn-Phong like
// firn_render::stage.

struct SolidIn {
    @location(0) position: vec3<f32>,
    @location(1) normal: vec3<f32>,
    @location(2) offset: vec3<f32>,
    @location(3) scale: vec3<f32>,
    @location(4) albedo: vec3<f32>,
    @location(5) shininess: f32,
}

struct SolidOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) world: vec3<f32>,
    @location(1) normal: vec3<f32>,
    @location(2) albedo: vec3<f32>,
    @location(3) shininess: f32,
}

@vertex
fn vertex_solid(input: SolidIn) -> SolidOut {
    let world = input.position * input.scale + input.offset;
    var output: SolidOut;
    output.clip = frame.camera.view_projection * vec4<f32>(world, 1.0);
    output.world = world;
    // Normals of a scaled surface scale inversely.
    output.normal = input.normal / input.scale;
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
