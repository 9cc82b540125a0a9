// The start of every substep, before thesis §3.4 step 1: the substep's Δt
// and the stop conditions, as firn_mpm::Simulation::next_dt and
// Simulation::advance_to. Δt = CFL h / (max |v_p| + max c_p), capped, or the
// fixed Δt, from the maxima the last gather reduced; clipped to the frame's
// end. With the semi-implicit integrator (implicit.wgsl) elastic waves do
// not limit the step: dt = CFL h / max |v_p|.

// Seconds within which a frame counts as reached (the CPU's 1e-9 s).
const FRAME_END_TOLERANCE: f32 = 1.0e-9;
// StepState.waiting: for the bands of a deforming collider's mesh frames,
// or for a grid with room for more blocks.
const WAITING_FOR_MESH_FRAMES: u32 = 1u;
const WAITING_FOR_GRID_BLOCKS: u32 = 2u;

// Dt = CFL h / (max |v_p| + max c_p), capped, or the fixed dt; the
// maxima come from the last gather, max |v_p| raised to the rigid bodies'
// fastest material speed where that is faster (as
// firn_mpm::Simulation::next_dt).
fn next_dt(speed_squared: f32, wave_speed_squared: f32) -> f32 {
    if params.stepping.z > 0.0 {
        return params.stepping.z;
    }
    var speed = sqrt(speed_squared);
    if params.stepping.w > speed {
        speed = params.stepping.w;
    }
    if params.flags.z == 0u {
        speed += sqrt(wave_speed_squared);
    }
    if speed > 0.0 {
        return min(params.stepping.x * params.origin.w / speed, params.stepping.y);
    }
    return params.stepping.y;
}

// One invocation: stops the frame when it is done or a particle is in
// trouble, else chooses dt, clipped to the frame's end, places the
// colliders at the substep's end and resets the maxima for this substep's
// gather. When the particles reach more grid blocks than the grid has room
// for (blocks.wgsl), or a deforming collider's pose there wants mesh frames
// that are not uploaded, it stops the batch before the substep instead,
// waiting for the host.
@compute @workgroup_size(1)
fn begin_step() {
    if state.running == 0u {
        return;
    }
    let trouble = atomicLoad(&state.non_finite) != NO_PARTICLE
        || atomicLoad(&state.left_domain) != NO_PARTICLE
        || atomicLoad(&state.overflow) != 0u;
    let remaining = params.upper.w - state.elapsed;
    if trouble || remaining <= FRAME_END_TOLERANCE {
        state.running = 0u;
        return;
    }
    if state.grid_blocks > params.flags.w {
        state.running = 0u;
        state.waiting = WAITING_FOR_GRID_BLOCKS;
        return;
    }
    let speed_squared = bitcast<f32>(atomicLoad(&state.max_speed_bits));
    let wave_speed_squared = bitcast<f32>(atomicLoad(&state.max_wave_bits));
    let dt = min(next_dt(speed_squared, wave_speed_squared), remaining);
    var elapsed = state.elapsed + dt;
    if dt >= remaining {
        elapsed = params.upper.w;
    }
    // simulated_time() once the substep is taken.
    place_colliders(params.lower.w + elapsed);
    if !sequences_ready() {
        state.running = 0u;
        state.waiting = WAITING_FOR_MESH_FRAMES;
        return;
    }
    state.dt = dt;
    state.speed_squared = speed_squared;
    state.wave_speed_squared = wave_speed_squared;
    state.elapsed = elapsed;
    state.steps = state.steps + 1u;
    atomicStore(&state.max_speed_bits, 0u);
    atomicStore(&state.max_wave_bits, 0u);
}
