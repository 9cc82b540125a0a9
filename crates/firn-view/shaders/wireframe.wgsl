// The container's edges as a line list, pulled slightly towards the eye so
// they win against surfaces they lie on (like firn_render::wireframe).

// Fraction of its distance to the eye an edge point keeps.
const PULL_TOWARDS_EYE: f32 = 0.999;

@vertex
fn vertex_edge(@location(0) position: vec3<f32>) -> @builtin(position) vec4<f32> {
    let eye = frame.camera.eye;
    let pulled = eye + (position - eye) * PULL_TOWARDS_EYE;
    return frame.camera.view_projection * vec4<f32>(pulled, 1.0);
}

@fragment
fn fragment_edge() -> @location(0) vec4<f32> {
    return target_color(frame.backdrop.edge_color);
}
