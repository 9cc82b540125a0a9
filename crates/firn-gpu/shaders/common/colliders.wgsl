// Rigid colliders and the domain walls (thesis section 3.4 steps 5 and 9,
// Quellcode 12), as in firn_mpm::contact: placed at a time from their
// motion (firn_core::scene::motion), then the contact law applied relative
// to the collider's velocity at the point. A turned collider's geometry is
// read in its own frame: a world point x is its point c + R^-1 (x - c), and
// it moves there at v + omega x (x - c). The colliders are placed once a
// substep (place_colliders, into collider_poses), so the trigonometry of
// their turns stays out of the kernels' per-node and per-particle work.
// Deforming meshes (SHAPE_SEQUENCE) are in deforming.wgsl.

const SHAPE_HALF_PLANE: u32 = 0u;
const SHAPE_SPHERE: u32 = 1u;
const SHAPE_BOX: u32 = 2u;
const SHAPE_MESH: u32 = 3u;
const SHAPE_CYLINDER: u32 = 4u;
const SHAPE_SEQUENCE: u32 = 5u;
const SHAPE_CAPSULE: u32 = 6u;

const CONTACT_STICKY: u32 = 0u;
const CONTACT_SEPARATE: u32 = 1u;
const CONTACT_SLIP: u32 = 2u;

const MOTION_STATIC: u32 = 0u;
const MOTION_LINEAR: u32 = 1u;
const MOTION_KEYFRAMED: u32 = 2u;

const PATH_LINEAR: u32 = 0u;
const PATH_CATMULL_ROM: u32 = 1u;

// The quaternion (xyzw) that does not turn.
const QUAT_IDENTITY: vec4<f32> = vec4<f32>(0.0, 0.0, 0.0, 1.0);

struct Collider {
    shape: u32,
    contact: u32,
    friction: f32,
    motion: u32,
    // Keyframed motion: the index of the first key in collider_keys (two
    // vectors a key) and the number of keys.
    first_key: u32,
    key_count: u32,
    // 1 when the collider is ever turned or turning; 0 keeps the unturned
    // arithmetic (and its bits).
    turns: u32,
    // How keyframed positions go from key to key (PATH_*).
    path: u32,
    // Plane point or centre at t = 0; w: sphere radius.
    reference: vec4<f32>,
    // Plane normal (out of the solid), box edge lengths or cylinder radius
    // (x) and height (y); a sequence's start time (x) and mesh frames per
    // second (y).
    extent: vec4<f32>,
    // Velocity of linear motion.
    velocity: vec4<f32>,
    // Angular velocity of linear motion (xyz, rad/s).
    angular_velocity: vec4<f32>,
    // Orientation (a unit quaternion, xyzw) while the motion gives none.
    rotation: vec4<f32>,
    // Meshes: the signed distance grid's first point at the time-zero
    // placement (xyz) and its spacing (w); extent.xyz is then the time-zero
    // centre.
    sdf_origin: vec4<f32>,
    // Meshes: grid points per axis (xyz) and the index of the first sample
    // in collider_fields (w); sequences: the last mesh frame's index (x)
    // and the first word of the collider's region (w, deforming.wgsl).
    sdf_dims: vec4<u32>,
}

// Where a collider's reference point is at one instant, how fast it moves,
// and how it is turned (firn_core::scene::Pose).
struct Placement {
    position: vec3<f32>,
    velocity: vec3<f32>,
    // From the collider's frame to the world's, about the reference point.
    rotation: vec4<f32>,
    angular_velocity: vec3<f32>,
    // Whether the geometry is read through the rotation and the contact
    // velocity has its omega x r (Pose::turns).
    turned: bool,
    // A sequence's interval between mesh frames (SequenceInterval's code)
    // and how far along it.
    interval: u32,
    fraction: f32,
}

// Signed distance (negative inside) and outward unit normal.
struct SurfacePoint {
    distance: f32,
    normal: vec3<f32>,
}

// A point on a path and its velocity.
struct PathPoint {
    position: vec3<f32>,
    velocity: vec3<f32>,
}

// The Hamilton product a b: the turn b, then a.
fn quat_mul(a: vec4<f32>, b: vec4<f32>) -> vec4<f32> {
    return vec4<f32>(
        a.w * b.x + a.x * b.w + a.y * b.z - a.z * b.y,
        a.w * b.y - a.x * b.z + a.y * b.w + a.z * b.x,
        a.w * b.z + a.x * b.y - a.y * b.x + a.z * b.w,
        a.w * b.w - a.x * b.x - a.y * b.y - a.z * b.z,
    );
}

// The inverse of a unit quaternion.
fn quat_conjugate(q: vec4<f32>) -> vec4<f32> {
    return vec4<f32>(-q.xyz, q.w);
}

// v turned by the unit quaternion q, with u its vector part:
// (w^2 - u.u) v + 2 (u.v) u + 2 w (u x v).
fn quat_rotate(q: vec4<f32>, v: vec3<f32>) -> vec3<f32> {
    let u = q.xyz;
    return v * (q.w * q.w - dot(u, u)) + u * (dot(v, u) * 2.0) + cross(u, v) * (q.w * 2.0);
}

// The turn by the angle |v| about v's direction (none for v = 0).
fn quat_from_scaled_axis(v: vec3<f32>) -> vec4<f32> {
    let angle = length(v);
    if angle == 0.0 {
        return QUAT_IDENTITY;
    }
    let half = angle * 0.5;
    return vec4<f32>(v / angle * sin(half), cos(half));
}

// The axis of the unit quaternion q's turn scaled by its angle.
fn quat_to_scaled_axis(q: vec4<f32>) -> vec3<f32> {
    let length = length(q.xyz);
    if length < 1.0e-8 {
        return vec3<f32>(0.0);
    }
    return q.xyz / length * (2.0 * atan2(length, q.w));
}

// The spherical interpolation from a to b at fraction s, the short way
// round; nearly equal turns interpolate linearly and normalise.
fn quat_slerp(a: vec4<f32>, b_in: vec4<f32>, s: f32) -> vec4<f32> {
    var b = b_in;
    var cosine = dot(a, b);
    if cosine < 0.0 {
        b = -b;
        cosine = -cosine;
    }
    // 1 - f32::EPSILON.
    if cosine > 1.0 - 1.1920929e-7 {
        return normalize(a * (1.0 - s) + b * s);
    }
    let theta = acos(cosine);
    return (a * sin(theta * (1.0 - s)) + b * sin(theta * s)) / sin(theta);
}

// The constant angular velocity of a slerp from `start` to `end` over
// `span` seconds, the short way round.
fn rotation_rate(start: vec4<f32>, end: vec4<f32>, span: f32) -> vec3<f32> {
    var turn = quat_mul(end, quat_conjugate(start));
    if turn.w < 0.0 {
        turn = -turn;
    }
    return quat_to_scaled_axis(turn) / span;
}

// Key k of collider_keys: position (xyz) and time (w).
fn key_point(k: u32) -> vec4<f32> {
    return collider_keys[2u * k];
}

// Key k's orientation (a unit quaternion).
fn key_rotation(k: u32) -> vec4<f32> {
    return collider_keys[2u * k + 1u];
}

// The Catmull-Rom tangent at key k: the finite difference of the keys
// around it in time (one-sided at the first and last key).
fn catmull_rom_tangent(first: u32, count: u32, k: u32) -> vec3<f32> {
    let before = key_point(max(k, first + 1u) - 1u);
    let after = key_point(min(k + 1u, first + count - 1u));
    return (after.xyz - before.xyz) / (after.w - before.w);
}

// Position and velocity at fraction s of the segment from key `index` to
// the next on the Catmull-Rom curve through the keys: a cubic Hermite
// segment with the keys' finite-difference tangents.
fn catmull_rom(first: u32, count: u32, index: u32, s: f32) -> PathPoint {
    let a = key_point(index);
    let b = key_point(index + 1u);
    let span = b.w - a.w;
    let ta = catmull_rom_tangent(first, count, index) * span;
    let tb = catmull_rom_tangent(first, count, index + 1u) * span;
    let s2 = s * s;
    let s3 = s * s * s;
    let position = a.xyz * (2.0 * s3 - 3.0 * s2 + 1.0)
        + ta * (s3 - 2.0 * s2 + s)
        + b.xyz * (-2.0 * s3 + 3.0 * s2)
        + tb * (s3 - s2);
    let slope = a.xyz * (6.0 * s2 - 6.0 * s)
        + ta * (3.0 * s2 - 4.0 * s + 1.0)
        + b.xyz * (-6.0 * s2 + 6.0 * s)
        + tb * (3.0 * s2 - 2.0 * s);
    return PathPoint(position, slope / span);
}

// A segment of a collider's keys: from key `index` to the next, at
// fraction s of it, which lasts `span` seconds (0: resting at key `index`).
struct KeySegment {
    index: u32,
    s: f32,
    span: f32,
}

// Where time t falls among the `count` keys from `first`: resting at the
// first key before its time and at the last after it.
fn key_segment(first: u32, count: u32, t: f32) -> KeySegment {
    let last = first + count - 1u;
    if t <= key_point(first).w {
        return KeySegment(first, 0.0, 0.0);
    }
    if t >= key_point(last).w {
        return KeySegment(last, 0.0, 0.0);
    }
    var next = first + 1u;
    while key_point(next).w <= t {
        next++;
    }
    let start = key_point(next - 1u).w;
    let span = key_point(next).w - start;
    return KeySegment(next - 1u, (t - start) / span, span);
}

// A keyframed collider's position and velocity: straight from key to key
// or along a Catmull-Rom curve; at rest at the first and last key outside
// their times.
fn keyframe_path(collider: Collider, t: f32) -> PathPoint {
    let segment = key_segment(collider.first_key, collider.key_count, t);
    let start = key_point(segment.index);
    if segment.span == 0.0 {
        return PathPoint(start.xyz, vec3<f32>(0.0));
    }
    if collider.path == PATH_CATMULL_ROM {
        return catmull_rom(collider.first_key, collider.key_count, segment.index, segment.s);
    }
    let end = key_point(segment.index + 1u);
    return PathPoint(mix(start.xyz, end.xyz, segment.s), (end.xyz - start.xyz) / segment.span);
}

// An orientation and the angular velocity it turns at.
struct Turn {
    rotation: vec4<f32>,
    angular_velocity: vec3<f32>,
}

// A keyframed collider's turn: by slerp at a constant rate from key to
// key; still at the first and last key outside their times.
fn keyframe_turn(collider: Collider, t: f32) -> Turn {
    let segment = key_segment(collider.first_key, collider.key_count, t);
    let start = key_rotation(segment.index);
    if segment.span == 0.0 {
        return Turn(start, vec3<f32>(0.0));
    }
    let end = key_rotation(segment.index + 1u);
    if all(start == end) {
        return Turn(start, vec3<f32>(0.0));
    }
    return Turn(quat_slerp(start, end, segment.s), rotation_rate(start, end, segment.span));
}

// The turn by angular_velocity over t seconds (none at rest).
fn turned_by(angular_velocity: vec3<f32>, t: f32) -> vec4<f32> {
    if all(angular_velocity == vec3<f32>(0.0)) {
        return QUAT_IDENTITY;
    }
    return quat_from_scaled_axis(angular_velocity * t);
}

// A turning collider's turn at time t: its own orientation when static;
// exp(omega t) R0 with linear motion; the keys' otherwise.
fn collider_turn(collider: Collider, t: f32) -> Turn {
    switch collider.motion {
        case MOTION_LINEAR: {
            let omega = collider.angular_velocity.xyz;
            return Turn(quat_mul(turned_by(omega, t), collider.rotation), omega);
        }
        case MOTION_KEYFRAMED: {
            return keyframe_turn(collider, t);
        }
        default: {
            return Turn(collider.rotation, vec3<f32>(0.0));
        }
    }
}

// The collider's pose at time t (firn_core::scene::Collider::pose_at).
fn placement(collider: Collider, t: f32) -> Placement {
    var placed = Placement(collider.reference.xyz, vec3<f32>(0.0), QUAT_IDENTITY, vec3<f32>(0.0), false, 0u, 0.0);
    switch collider.motion {
        case MOTION_LINEAR: {
            placed.position = collider.reference.xyz + collider.velocity.xyz * t;
            placed.velocity = collider.velocity.xyz;
        }
        case MOTION_KEYFRAMED: {
            let path = keyframe_path(collider, t);
            placed.position = path.position;
            placed.velocity = path.velocity;
        }
        default: {}
    }
    if collider.turns != 0u {
        let turn = collider_turn(collider, t);
        placed.rotation = turn.rotation;
        placed.angular_velocity = turn.angular_velocity;
        placed.turned = any(turn.rotation != QUAT_IDENTITY) || any(turn.angular_velocity != vec3<f32>(0.0));
    }
    if collider.shape == SHAPE_SEQUENCE {
        let interval = sequence_interval(collider, t);
        placed.interval = interval.code;
        placed.fraction = interval.fraction;
    }
    return placed;
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

// Signed distance and outward normal of a cylinder centred at the origin,
// its axis along y, of `radius` and half length `half_height`.
fn cylinder_surface(p: vec3<f32>, radius: f32, half_height: f32) -> SurfacePoint {
    let across = sqrt(p.x * p.x + p.z * p.z);
    var outward = vec3<f32>(1.0, 0.0, 0.0);
    if across > 0.0 {
        outward = vec3<f32>(p.x / across, 0.0, p.z / across);
    }
    let along = select(vec3<f32>(0.0, -1.0, 0.0), vec3<f32>(0.0, 1.0, 0.0), p.y >= 0.0);
    let side = across - radius;
    let cap = abs(p.y) - half_height;
    if side > 0.0 || cap > 0.0 {
        let side_out = max(side, 0.0);
        let cap_out = max(cap, 0.0);
        let length = sqrt(side_out * side_out + cap_out * cap_out);
        return SurfacePoint(length, (outward * side_out + along * cap_out) / length);
    }
    if side >= cap {
        return SurfacePoint(side, outward);
    }
    return SurfacePoint(cap, along);
}

fn sdf_sample(collider: Collider, point: vec3<u32>) -> f32 {
    let dims = collider.sdf_dims.xyz;
    return bitcast<f32>(collider_fields[collider.sdf_dims.w + (point.z * dims.y + point.y) * dims.x + point.x]);
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

// A capsule about the origin whose axis segment runs along y from
// -half_segment to half_segment, as ColliderGeometry::Capsule.
fn capsule_surface(p: vec3<f32>, radius: f32, half_segment: f32) -> SurfacePoint {
    let offset = p - vec3<f32>(0.0, clamp(p.y, -half_segment, half_segment), 0.0);
    let length = length(offset);
    var normal = vec3<f32>(1.0, 0.0, 0.0);
    if length > 0.0 {
        normal = offset / length;
    }
    return SurfacePoint(length - radius, normal);
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
        case SHAPE_CYLINDER: {
            return cylinder_surface(point - at, collider.extent.x, 0.5 * collider.extent.y);
        }
        case SHAPE_CAPSULE: {
            return capsule_surface(point - at, collider.extent.x, 0.5 * collider.extent.y - collider.extent.x);
        }
        default: {
            return SurfacePoint(dot(point - at, collider.extent.xyz), collider.extent.xyz);
        }
    }
}

// A Placement as collider_poses stores it; position.w is 1 for a turned
// collider; a sequence's fraction is velocity.w, its interval's code
// angular_velocity.w.
struct ColliderPose {
    position: vec4<f32>,
    velocity: vec4<f32>,
    rotation: vec4<f32>,
    angular_velocity: vec4<f32>,
}

// Places every collider at time t into collider_poses, for the contacts of
// one substep (one invocation).
fn place_colliders(t: f32) {
    let count = arrayLength(&colliders);
    for (var c = 0u; c < count; c++) {
        let placed = placement(colliders[c], t);
        collider_poses[c] = ColliderPose(
            vec4<f32>(placed.position, select(0.0, 1.0, placed.turned)),
            vec4<f32>(placed.velocity, placed.fraction),
            placed.rotation,
            vec4<f32>(placed.angular_velocity, f32(placed.interval)),
        );
    }
}

// The Placement a ColliderPose stores.
fn unpacked_pose(pose: ColliderPose) -> Placement {
    return Placement(pose.position.xyz, pose.velocity.xyz, pose.rotation, pose.angular_velocity.xyz, pose.position.w != 0.0, u32(pose.angular_velocity.w), pose.velocity.w);
}

// Collider c as place_colliders placed it.
fn posed(c: u32) -> Placement {
    return unpacked_pose(collider_poses[c]);
}

// The collider's surface at `point` as placed: a turned collider's distance
// is read in its own frame at c + R^-1 (x - c) and its normal turned back
// by R (firn_mpm::contact::PlacedCollider::signed_distance).
fn placed_surface(collider: Collider, placed: Placement, point: vec3<f32>) -> SurfacePoint {
    if DEFORMING && collider.shape == SHAPE_SEQUENCE {
        let surface = deforming_surface(collider, placed.fraction, point);
        return SurfacePoint(surface.distance, surface.normal);
    }
    // One surface_point for both cases: the shape's code is the bulk of a
    // kernel, and a software adapter (lavapipe) runs both sides of a
    // branch.
    var own = point;
    if placed.turned {
        own = placed.position + quat_rotate(quat_conjugate(placed.rotation), point - placed.position);
    }
    var surface = surface_point(collider, placed.position, own);
    if placed.turned {
        surface.normal = quat_rotate(placed.rotation, surface.normal);
    }
    return surface;
}

// How fast the placed collider's surface moves at `point`: v + omega x (x - c).
fn surface_velocity(placed: Placement, point: vec3<f32>) -> vec3<f32> {
    if !placed.turned {
        return placed.velocity;
    }
    return placed.velocity + cross(placed.angular_velocity, point - placed.position);
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

// The placed collider's surface at `point` and how fast it moves there; a
// deforming one's normal and velocity only where the point touches it.
fn moving_surface(collider: Collider, placed: Placement, point: vec3<f32>) -> MovingSurface {
    if DEFORMING && collider.shape == SHAPE_SEQUENCE {
        return deforming_contact(collider, placed.fraction, point);
    }
    let surface = placed_surface(collider, placed, point);
    return MovingSurface(surface.distance, surface.normal, surface_velocity(placed, point));
}

// Applies one collider, placed, to a velocity at point
// (firn_mpm::contact::PlacedCollider::collide).
fn collide(collider: Collider, placed: Placement, point: vec3<f32>, velocity: vec3<f32>) -> vec3<f32> {
    let surface = moving_surface(collider, placed, point);
    if surface.distance <= 0.0 {
        return contact_response(velocity, surface.velocity, surface.normal, collider.contact, collider.friction);
    }
    return velocity;
}

// Applies every collider in turn, as placed for this substep, to a
// velocity at point.
fn collide_all(point: vec3<f32>, velocity_in: vec3<f32>) -> vec3<f32> {
    var velocity = velocity_in;
    let count = arrayLength(&colliders);
    for (var c = 0u; c < count; c++) {
        velocity = collide(colliders[c], posed(c), point, velocity);
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
fn collide_all_constrained(point: vec3<f32>, velocity_in: vec3<f32>) -> Constrained {
    var result = Constrained(velocity_in, vec4<f32>(0.0, 0.0, 0.0, CONSTRAINT_FREE));
    let count = arrayLength(&colliders);
    for (var c = 0u; c < count; c++) {
        let collider = colliders[c];
        let surface = moving_surface(collider, posed(c), point);
        if surface.distance <= 0.0 {
            let response = constrained_response(result.velocity, surface.velocity, surface.normal, collider.contact, collider.friction);
            result = Constrained(response.velocity, constraint_and(result.constraint, response.constraint));
        }
    }
    return result;
}
