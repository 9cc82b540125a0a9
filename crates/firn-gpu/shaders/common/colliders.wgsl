// Rigid colliders and the domain walls (thesis section 3.4 steps 5 and 9,
// Quellcode 12), as in firn_mpm::contact: placed at a time from their
// motion, then the contact law applied in the collider's own frame.

const SHAPE_HALF_PLANE: u32 = 0u;
const SHAPE_SPHERE: u32 = 1u;
const SHAPE_BOX: u32 = 2u;
const SHAPE_MESH: u32 = 3u;

const CONTACT_STICKY: u32 = 0u;
const CONTACT_SEPARATE: u32 = 1u;
const CONTACT_SLIP: u32 = 2u;

const MOTION_STATIC: u32 = 0u;
const MOTION_LINEAR: u32 = 1u;
const MOTION_KEYFRAMED: u32 = 2u;

struct Collider {
    shape: u32,
    contact: u32,
    friction: f32,
    motion: u32,
    first_key: u32,
    key_count: u32,
    pad0: u32,
    pad1: u32,
    // Plane point or centre at t = 0; w: sphere radius.
    reference: vec4<f32>,
    // Plane normal (out of the solid) or box edge lengths.
    extent: vec4<f32>,
    // Velocity of linear motion.
    velocity: vec4<f32>,
    // Meshes: the signed distance grid's first point at the time-zero
    // placement (xyz) and its spacing (w); extent.xyz is then the time-zero
    // centre.
    sdf_origin: vec4<f32>,
    // Meshes: grid points per axis (xyz) and the index of the first sample
    // in collider_distances (w).
    sdf_dims: vec4<u32>,
}

// Where a collider's reference point is at one instant, and how fast it moves.
struct Placement {
    position: vec3<f32>,
    velocity: vec3<f32>,
}

// Signed distance (negative inside) and outward unit normal.
struct SurfacePoint {
    distance: f32,
    normal: vec3<f32>,
}

// Piecewise-linear motion through keys (xyz: position, w: time); rests at
// the first and last key outside their times.
fn keyframe_placement(first: u32, count: u32, t: f32) -> Placement {
    let a = collider_keys[first];
    let z = collider_keys[first + count - 1u];
    if t <= a.w {
        return Placement(a.xyz, vec3<f32>(0.0));
    }
    if t >= z.w {
        return Placement(z.xyz, vec3<f32>(0.0));
    }
    var next = first + 1u;
    while collider_keys[next].w <= t {
        next++;
    }
    let start = collider_keys[next - 1u];
    let end = collider_keys[next];
    let span = end.w - start.w;
    let s = (t - start.w) / span;
    return Placement(mix(start.xyz, end.xyz, s), (end.xyz - start.xyz) / span);
}

fn placement(collider: Collider, t: f32) -> Placement {
    switch collider.motion {
        case MOTION_LINEAR: {
            return Placement(collider.reference.xyz + collider.velocity.xyz * t, collider.velocity.xyz);
        }
        case MOTION_KEYFRAMED: {
            return keyframe_placement(collider.first_key, collider.key_count, t);
        }
        default: {
            return Placement(collider.reference.xyz, vec3<f32>(0.0));
        }
    }
}

fn box_surface(p: vec3<f32>, half: vec3<f32>) -> SurfacePoint {
    let q = abs(p) - half;
    let signs = vec3<f32>(sign_of(p.x), sign_of(p.y), sign_of(p.z));
    if max(max(q.x, q.y), q.z) > 0.0 {
        let outside = max(q, vec3<f32>(0.0));
        let length = length(outside);
        return SurfacePoint(length, outside * signs / length);
    }
    if q.x >= q.y && q.x >= q.z {
        return SurfacePoint(q.x, vec3<f32>(signs.x, 0.0, 0.0));
    }
    if q.y >= q.z {
        return SurfacePoint(q.y, vec3<f32>(0.0, signs.y, 0.0));
    }
    return SurfacePoint(q.z, vec3<f32>(0.0, 0.0, signs.z));
}

fn sdf_sample(collider: Collider, point: vec3<u32>) -> f32 {
    let dims = collider.sdf_dims.xyz;
    return collider_distances[collider.sdf_dims.w + (point.z * dims.y + point.y) * dims.x + point.x];
}

// A mesh collider's signed distance grid at q (in the time-zero placement),
// as firn_mesh::SignedDistanceField::sample: trilinear value and gradient
// inside the grid box; outside it the distance to the box is added and the
// gradient points away from the box.
fn mesh_surface(collider: Collider, q: vec3<f32>) -> SurfacePoint {
    let origin = collider.sdf_origin.xyz;
    let spacing = collider.sdf_origin.w;
    let dims = collider.sdf_dims.xyz;
    let high = origin + vec3<f32>(dims - vec3<u32>(1u)) * spacing;
    let clamped = clamp(q, origin, high);
    let g = (clamped - origin) / spacing;
    let cell = min(vec3<u32>(floor(g)), dims - vec3<u32>(2u));
    let t = clamp(g - vec3<f32>(cell), vec3<f32>(0.0), vec3<f32>(1.0));
    let c000 = sdf_sample(collider, cell);
    let c100 = sdf_sample(collider, cell + vec3<u32>(1u, 0u, 0u));
    let c010 = sdf_sample(collider, cell + vec3<u32>(0u, 1u, 0u));
    let c110 = sdf_sample(collider, cell + vec3<u32>(1u, 1u, 0u));
    let c001 = sdf_sample(collider, cell + vec3<u32>(0u, 0u, 1u));
    let c101 = sdf_sample(collider, cell + vec3<u32>(1u, 0u, 1u));
    let c011 = sdf_sample(collider, cell + vec3<u32>(0u, 1u, 1u));
    let c111 = sdf_sample(collider, cell + vec3<u32>(1u, 1u, 1u));
    let c00 = c000 + (c100 - c000) * t.x;
    let c10 = c010 + (c110 - c010) * t.x;
    let c01 = c001 + (c101 - c001) * t.x;
    let c11 = c011 + (c111 - c011) * t.x;
    let c0 = c00 + (c10 - c00) * t.y;
    let c1 = c01 + (c11 - c01) * t.y;
    let dx00 = c100 - c000;
    let dx10 = c110 - c010;
    let dx01 = c101 - c001;
    let dx11 = c111 - c011;
    let gx0 = dx00 + (dx10 - dx00) * t.y;
    let gx1 = dx01 + (dx11 - dx01) * t.y;
    let gy0 = c10 - c00;
    let gy1 = c11 - c01;
    var gradient = vec3<f32>(gx0 + (gx1 - gx0) * t.z, gy0 + (gy1 - gy0) * t.z, c1 - c0) / spacing;
    let value = c0 + (c1 - c0) * t.z;
    let outside = q - clamped;
    let gap = length(outside);
    if gap > 0.0 {
        gradient = select(gradient, outside / gap, outside != vec3<f32>(0.0));
    }
    var normal = vec3<f32>(0.0, 1.0, 0.0);
    let from_center = q - 0.5 * (origin + high);
    if length(gradient) > 0.0 {
        normal = normalize(gradient);
    } else if length(from_center) > 0.0 {
        normal = normalize(from_center);
    }
    return SurfacePoint(value + gap, normal);
}

fn surface_point(collider: Collider, at: vec3<f32>, point: vec3<f32>) -> SurfacePoint {
    switch collider.shape {
        case SHAPE_SPHERE: {
            let offset = point - at;
            let length = length(offset);
            var normal = vec3<f32>(0.0, 1.0, 0.0);
            if length > 0.0 {
                normal = offset / length;
            }
            return SurfacePoint(length - collider.reference.w, normal);
        }
        case SHAPE_BOX: {
            return box_surface(point - at, 0.5 * collider.extent.xyz);
        }
        case SHAPE_MESH: {
            return mesh_surface(collider, point - (at - collider.extent.xyz));
        }
        default: {
            return SurfacePoint(dot(point - at, collider.extent.xyz), collider.extent.xyz);
        }
    }
}

// The contact law relative to a collider moving with collider_velocity:
// sticky takes its velocity; separate (the thesis' law) stops approaching
// snow with Coulomb friction on the tangential part; slip also removes a
// separating normal velocity.
fn contact_response(velocity: vec3<f32>, collider_velocity: vec3<f32>, normal: vec3<f32>, contact: u32, friction: f32) -> vec3<f32> {
    let relative = velocity - collider_velocity;
    let normal_speed = dot(relative, normal);
    let tangential = relative - normal * normal_speed;
    if contact == CONTACT_STICKY {
        return collider_velocity;
    }
    if normal_speed >= 0.0 {
        if contact == CONTACT_SEPARATE {
            return velocity;
        }
        return collider_velocity + tangential;
    }
    let length = length(tangential);
    let limit = -friction * normal_speed;
    if length > limit {
        return collider_velocity + tangential * (1.0 - limit / length);
    }
    return collider_velocity;
}

// Applies every collider in turn to a velocity at point, at time t.
fn collide_all(point: vec3<f32>, velocity_in: vec3<f32>, t: f32) -> vec3<f32> {
    var velocity = velocity_in;
    let count = arrayLength(&colliders);
    for (var c = 0u; c < count; c++) {
        let collider = colliders[c];
        let placed = placement(collider, t);
        let surface = surface_point(collider, placed.position, point);
        if surface.distance <= 0.0 {
            velocity = contact_response(velocity, placed.velocity, surface.normal, collider.contact, collider.friction);
        }
    }
    return velocity;
}

// The velocity components of a grid node that contacts fix, as
// firn_mpm::contact::Constraint: w is the kind, xyz its unit direction (the
// fixed normal, or the one free line).
const CONSTRAINT_FREE: f32 = 0.0;
const CONSTRAINT_NORMAL: f32 = 1.0;
const CONSTRAINT_LINE: f32 = 2.0;
const CONSTRAINT_FIXED: f32 = 3.0;

// Directions closer than this (|sin| of the angle) count as the same.
const CONSTRAINT_PARALLEL: f32 = 1.0e-3;

// A velocity after the contacts, with the components they fixed.
struct Constrained {
    velocity: vec3<f32>,
    constraint: vec4<f32>,
}

// contact_response, plus which components the contact fixed
// (firn_mpm::contact::contact_response).
fn constrained_response(velocity: vec3<f32>, collider_velocity: vec3<f32>, normal: vec3<f32>, contact: u32, friction: f32) -> Constrained {
    let free = vec4<f32>(0.0, 0.0, 0.0, CONSTRAINT_FREE);
    let fixed = vec4<f32>(0.0, 0.0, 0.0, CONSTRAINT_FIXED);
    let along_normal = vec4<f32>(normal, CONSTRAINT_NORMAL);
    let relative = velocity - collider_velocity;
    let normal_speed = dot(relative, normal);
    let tangential = relative - normal * normal_speed;
    if contact == CONTACT_STICKY {
        return Constrained(collider_velocity, fixed);
    }
    if normal_speed >= 0.0 {
        if contact == CONTACT_SEPARATE {
            return Constrained(velocity, free);
        }
        return Constrained(collider_velocity + tangential, along_normal);
    }
    let length = length(tangential);
    let limit = -friction * normal_speed;
    if length > limit {
        return Constrained(collider_velocity + tangential * (1.0 - limit / length), along_normal);
    }
    return Constrained(collider_velocity, fixed);
}

// The constraint after a further contact fixes `other` as well
// (firn_mpm::contact::Constraint::and).
fn constraint_and(a: vec4<f32>, b: vec4<f32>) -> vec4<f32> {
    let fixed = vec4<f32>(0.0, 0.0, 0.0, CONSTRAINT_FIXED);
    if a.w == CONSTRAINT_FREE {
        return b;
    }
    if b.w == CONSTRAINT_FREE {
        return a;
    }
    if a.w == CONSTRAINT_FIXED || b.w == CONSTRAINT_FIXED {
        return fixed;
    }
    if a.w == CONSTRAINT_NORMAL && b.w == CONSTRAINT_NORMAL {
        let free = cross(a.xyz, b.xyz);
        let length = length(free);
        if length < CONSTRAINT_PARALLEL {
            return a;
        }
        return vec4<f32>(free / length, CONSTRAINT_LINE);
    }
    if a.w == CONSTRAINT_LINE && b.w == CONSTRAINT_LINE {
        return fixed;
    }
    // One line and one normal.
    var line = a.xyz;
    var normal = b.xyz;
    if a.w == CONSTRAINT_NORMAL {
        line = b.xyz;
        normal = a.xyz;
    }
    if abs(dot(line, normal)) < CONSTRAINT_PARALLEL {
        return vec4<f32>(line, CONSTRAINT_LINE);
    }
    return fixed;
}

// P v: `velocity` with its fixed components removed
// (firn_mpm::contact::Constraint::project).
fn project(constraint: vec4<f32>, velocity: vec3<f32>) -> vec3<f32> {
    let d = constraint.xyz;
    if constraint.w == CONSTRAINT_NORMAL {
        return velocity - d * dot(d, velocity);
    }
    if constraint.w == CONSTRAINT_LINE {
        return d * dot(d, velocity);
    }
    if constraint.w == CONSTRAINT_FIXED {
        return vec3<f32>(0.0);
    }
    return velocity;
}

// collide_all, plus the components the contacts fixed
// (firn_mpm::contact::collide_all_constrained).
fn collide_all_constrained(point: vec3<f32>, velocity_in: vec3<f32>, t: f32) -> Constrained {
    var result = Constrained(velocity_in, vec4<f32>(0.0, 0.0, 0.0, CONSTRAINT_FREE));
    let count = arrayLength(&colliders);
    for (var c = 0u; c < count; c++) {
        let collider = colliders[c];
        let placed = placement(collider, t);
        let surface = surface_point(collider, placed.position, point);
        if surface.distance <= 0.0 {
            let response = constrained_response(result.velocity, placed.velocity, surface.normal, collider.contact, collider.friction);
            result = Constrained(response.velocity, constraint_and(result.constraint, response.constraint));
        }
    }
    return result;
}
