// The flow's noise coordinate q_c = x / L + ε_c / L + t w_c of component c
// at a stage of the substep (seed eq. 1): the host forms the offsets of each
// stage's time in f64, as firn_flow::FlowField does.
fn noise_point(x: vec3<f32>, stage: u32, c: u32) -> vec3<f32> {
    return x * field_constants.inv_length + substep.offsets[3u * stage + c].xyz;
}
