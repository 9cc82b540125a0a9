// Two-way coupling with rigid bodies (as firn_mpm::coupling, the impulse
// exchange of Hu et al. 2018): in the grid update, after the colliders,
// every body meets the node as a collider placed where rapier has it at the
// substep's start (the host uploads rigid_bodies before each substep).
// Where a body changes a node's velocity from v to v', the node's snow
// gains dp = m (v' - v); dp and its moment (x - c) x dp about the body's
// centre of mass c go into the body's sums in body_sums, 64-bit fixed point
// at firn_mpm::coupling::FIXED_SCALE units per N s, added with integer
// atomics, so the sums do not depend on the order the nodes run in. The
// host reads them back after the substep and gives the body the opposite.

// Fixed-point units per N s (firn_mpm::coupling::FIXED_SCALE, 2^32).
const BODY_FIXED_SCALE: f32 = 4294967296.0;
// Words of one body's sums: the snow's momentum gain x, y, z, then its
// moment x, y, z, each a low word and a high word.
const BODY_SUM_WORDS: u32 = 12u;

// round(value 2^32) as the (high, low) words of a 64-bit two's complement
// integer (to_fixed).
fn body_fixed(value: f32) -> vec2<u32> {
    return to_fixed(value * BODY_FIXED_SCALE);
}

// Adds value (N s or N m s) into the 64-bit sum at body_sums[word] (low)
// and body_sums[word + 1] (high). Like firn_mpm's wrapping i64 sums it
// does not check the range, ±2^31 N s.
fn add_to_body_sum(word: u32, value: f32) {
    let words = body_fixed(value);
    let c = carry(atomicAdd(&body_sums[word], words.y), words.y);
    atomicAdd(&body_sums[word + 1u], words.x + c);
}

// Adds a node's exchange with body b: the snow's gain `momentum` at `arm`
// from the body's centre of mass (firn_mpm::coupling::ImpulseSum::add).
fn add_to_body(b: u32, momentum: vec3<f32>, arm: vec3<f32>) {
    let moment = cross(arm, momentum);
    let first = b * BODY_SUM_WORDS;
    for (var axis = 0u; axis < 3u; axis++) {
        add_to_body_sum(first + 2u * axis, momentum[axis]);
        add_to_body_sum(first + 6u + 2u * axis, moment[axis]);
    }
}

// The most rigid bodies a scene has (firn_core::scene::format::
// MAX_RIGID_BODIES), and the words of a mask with a bit for each.
const MAX_RIGID_BODIES: u32 = 10000u;
const BODY_MASK_WORDS: u32 = (MAX_RIGID_BODIES + 31u) / 32u;

// The bodies that may touch a node of the workgroup's block, a bit each.
var<workgroup> near_bodies: array<atomic<u32>, BODY_MASK_WORDS>;

// Marks in near_bodies the bodies that may touch a node of the block whose
// first node is `first` (firn_mpm::coupling::BodyContacts::near): those
// whose ball of reach around the reference point meets the box of the
// block's nodes. Every invocation of the workgroup calls it before any
// other work (its barriers need them all), `local` its index.
fn mark_near_bodies(first: u32, local: u32) {
    let count = arrayLength(&rigid_bodies);
    for (var word = local; word < (count + 31u) / 32u; word += BLOCK_NODES) {
        atomicStore(&near_bodies[word], 0u);
    }
    workgroupBarrier();
    if updates_node(first) {
        let cell = node_cell(first);
        let h = params.origin.w;
        let low = params.origin.xyz + vec3<f32>(cell) * h;
        let high = params.origin.xyz + vec3<f32>(cell + vec3<u32>(BLOCK_WIDTH - 1u)) * h;
        for (var b = local; b < count; b += BLOCK_NODES) {
            let center = rigid_bodies[b].pose.position.xyz;
            let reach = rigid_bodies[b].center_of_mass.w;
            let gap = clamp(center, low, high) - center;
            if dot(gap, gap) <= reach * reach {
                atomicOr(&near_bodies[b / 32u], 1u << (b % 32u));
            }
        }
    }
    workgroupBarrier();
}

// Applies the bodies near the block (mark_near_bodies) in body order to
// the velocity of a node at `point` with snow mass `mass`, summing each
// body's exchange with it (firn_mpm::coupling::BodyContacts::collide).
fn collide_bodies(point: vec3<f32>, mass: f32, velocity_in: vec3<f32>) -> vec3<f32> {
    var velocity = velocity_in;
    let words = (arrayLength(&rigid_bodies) + 31u) / 32u;
    for (var word = 0u; word < words; word++) {
        var bits = atomicLoad(&near_bodies[word]);
        while bits != 0u {
            let b = word * 32u + countTrailingZeros(bits);
            bits &= bits - 1u;
            let body = rigid_bodies[b];
            let collided = collide(body.collider, unpacked_pose(body.pose), point, velocity);
            if any(collided != velocity) {
                add_to_body(b, mass * (collided - velocity), point - body.center_of_mass.xyz);
                velocity = collided;
            }
        }
    }
    return velocity;
}
