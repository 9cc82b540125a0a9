// Deforming mesh colliders (mesh sequences), as firn_mpm::contact's
// DeformingSurface. Between mesh frames k and k + 1, a fraction s of the
// way, the signed distance and its gradient are (1 - s) phi_k + s phi_k+1,
// each phi trilinear in the samples of its frame's narrow band
// (firn_mesh::NarrowBandField), and the surface's velocity is blended the
// same way from each frame's closest surface points, where it is the
// barycentric mix of the triangle's vertex velocities.
//
// The host builds the two frames' bands and uploads them into the
// collider's region of collider_fields (src/snow/sequences.rs) when the run
// enters a new interval between mesh frames; begin_step waits for it
// (sequences_ready). All words are u32; floats are their bits.

// Whether the kernels run deforming colliders: the snow step compiles them
// in only for scenes that have one (src/snow/program.rs), since a software
// adapter (lavapipe) runs both sides of a branch and would pay for them at
// every node and particle against every collider.
override DEFORMING: bool = true;

// Table entries of bricks without samples (firn_mesh::OUTSIDE_BRICK and
// INSIDE_BRICK); every smaller entry is the slot of the brick's samples.
const BAND_OUTSIDE: u32 = 0xffffffffu;
const BAND_INSIDE: u32 = 0xfffffffeu;

// Samples along a brick's edge, and per brick (firn_mesh::BRICK_SIDE).
const BRICK_SIDE: u32 = 4u;
const SAMPLES_PER_BRICK: u32 = 64u;

// Words of a region's header: the mesh frames the slots hold for the
// current interval (from, to), the offsets of their slots, the mean vertex
// velocity (the velocity deep inside), and the offsets of the vertex
// velocities and the triangles (three words each).
const REGION_FROM: u32 = 0u;
const REGION_TO: u32 = 1u;
const REGION_FROM_SLOT: u32 = 2u;
const REGION_TO_SLOT: u32 = 3u;
const REGION_MEAN_VELOCITY: u32 = 4u;
const REGION_VELOCITIES: u32 = 7u;
const REGION_TRIANGLES: u32 = 8u;

// Words of a slot's header: the lattice origin (3) and spacing, bricks per
// axis (3) and the band, the mesh's centre (3), and the offsets of the
// table, the samples (two words each: distance, triangle) and the frame's
// vertex positions (three words each).
const SLOT_ORIGIN: u32 = 0u;
const SLOT_SPACING: u32 = 3u;
const SLOT_BRICKS: u32 = 4u;
const SLOT_BAND: u32 = 7u;
const SLOT_CENTRE: u32 = 8u;
const SLOT_TABLE: u32 = 11u;
const SLOT_SAMPLES: u32 = 12u;
const SLOT_VERTICES: u32 = 13u;

// The largest finite f32.
const F32_MAX: f32 = 3.40282347e38;

fn field_float(word: u32) -> f32 {
    return bitcast<f32>(collider_fields[word]);
}

fn field_vec3(word: u32) -> vec3<f32> {
    return vec3<f32>(field_float(word), field_float(word + 1u), field_float(word + 2u));
}

// One mesh frame's narrow band, as its slot's header describes it.
struct Band {
    origin: vec3<f32>,
    spacing: f32,
    bricks: vec3<u32>,
    band: f32,
    centre: vec3<f32>,
    table: u32,
    samples: u32,
    vertices: u32,
}

fn band_in(slot: u32) -> Band {
    let bricks = vec3<u32>(
        collider_fields[slot + SLOT_BRICKS],
        collider_fields[slot + SLOT_BRICKS + 1u],
        collider_fields[slot + SLOT_BRICKS + 2u],
    );
    return Band(
        field_vec3(slot + SLOT_ORIGIN),
        field_float(slot + SLOT_SPACING),
        bricks,
        field_float(slot + SLOT_BAND),
        field_vec3(slot + SLOT_CENTRE),
        collider_fields[slot + SLOT_TABLE],
        collider_fields[slot + SLOT_SAMPLES],
        collider_fields[slot + SLOT_VERTICES],
    );
}

// The table entry of the brick that holds lattice point `at`.
fn band_entry(band: Band, at: vec3<u32>) -> u32 {
    let brick = at / BRICK_SIDE;
    let index = (brick.z * band.bricks.y + brick.y) * band.bricks.x + brick.x;
    return collider_fields[band.table + index];
}

// The first word of the sample at lattice point `at`, in the brick of
// table entry `entry` (x fastest within the brick).
fn band_sample_word(band: Band, entry: u32, at: vec3<u32>) -> u32 {
    let local = at % BRICK_SIDE;
    let index = entry * SAMPLES_PER_BRICK + (local.z * BRICK_SIDE + local.y) * BRICK_SIDE + local.x;
    return band.samples + 2u * index;
}

// What a query finds in a band's table: the cell around the point and how
// far along its edges (near), or else the entry of a brick without samples
// that a corner of the cell falls in (BAND_OUTSIDE off the table).
struct BandLookup {
    near: bool,
    entry: u32,
    cell: vec3<u32>,
    t: vec3<f32>,
}

// The lattice offset of cell corner `corner` (bit 0: x, 1: y, 2: z).
fn corner_offset(corner: u32) -> vec3<u32> {
    return vec3<u32>(corner & 1u, (corner >> 1u) & 1u, corner >> 2u);
}

// The trilinear weights of the corner at `offset`, t of the way.
fn corner_weights(offset: vec3<u32>, t: vec3<f32>) -> vec3<f32> {
    return select(vec3<f32>(1.0) - t, t, offset == vec3<u32>(1u));
}

fn band_lookup(band: Band, point: vec3<f32>) -> BandLookup {
    let g = (point - band.origin) / band.spacing;
    let points = vec3<f32>(band.bricks * BRICK_SIDE);
    let off_table = BandLookup(false, BAND_OUTSIDE, vec3<u32>(0u), vec3<f32>(0.0));
    if !(all(g >= vec3<f32>(0.0)) && all(g < points - vec3<f32>(1.0))) {
        return off_table;
    }
    let cell = vec3<u32>(floor(g));
    for (var corner = 0u; corner < 8u; corner++) {
        let entry = band_entry(band, cell + corner_offset(corner));
        if entry >= BAND_INSIDE {
            return BandLookup(false, entry, cell, vec3<f32>(0.0));
        }
    }
    let t = clamp(g - vec3<f32>(cell), vec3<f32>(0.0), vec3<f32>(1.0));
    return BandLookup(true, 0u, cell, t);
}

// The band's signed distance at `point`: trilinear in the samples near the
// surface, +- the band away from it (NarrowBandField::distance).
fn band_distance(band: Band, point: vec3<f32>) -> f32 {
    let found = band_lookup(band, point);
    if !found.near {
        return select(band.band, -band.band, found.entry == BAND_INSIDE);
    }
    var distance = 0.0;
    for (var corner = 0u; corner < 8u; corner++) {
        let offset = corner_offset(corner);
        let w = corner_weights(offset, found.t);
        let at = found.cell + offset;
        let value = field_float(band_sample_word(band, band_entry(band, at), at));
        distance += w.x * w.y * w.z * value;
    }
    return distance;
}

// A closest point on a triangle and its barycentric weights.
struct ClosestPoint {
    point: vec3<f32>,
    weights: vec3<f32>,
}

// The point of segment ab closest to p (xyz) and its parameter (w).
fn closest_on_segment(p: vec3<f32>, a: vec3<f32>, b: vec3<f32>) -> vec4<f32> {
    let ab = b - a;
    let length_squared = dot(ab, ab);
    if length_squared == 0.0 {
        return vec4<f32>(a, 0.0);
    }
    let s = clamp(dot(p - a, ab) / length_squared, 0.0, 1.0);
    return vec4<f32>(a + ab * s, s);
}

// The closest point of a zero-area triangle: the nearest of its edges' (the
// first of equals).
fn closest_on_edges(p: vec3<f32>, a: vec3<f32>, b: vec3<f32>, c: vec3<f32>) -> ClosestPoint {
    let on_ab = closest_on_segment(p, a, b);
    let on_bc = closest_on_segment(p, b, c);
    let on_ca = closest_on_segment(p, c, a);
    var best = ClosestPoint(on_ab.xyz, vec3<f32>(1.0 - on_ab.w, on_ab.w, 0.0));
    var nearest = dot(on_ab.xyz - p, on_ab.xyz - p);
    if dot(on_bc.xyz - p, on_bc.xyz - p) < nearest {
        best = ClosestPoint(on_bc.xyz, vec3<f32>(0.0, 1.0 - on_bc.w, on_bc.w));
        nearest = dot(on_bc.xyz - p, on_bc.xyz - p);
    }
    if dot(on_ca.xyz - p, on_ca.xyz - p) < nearest {
        best = ClosestPoint(on_ca.xyz, vec3<f32>(on_ca.w, 0.0, 1.0 - on_ca.w));
    }
    return best;
}

// The point of triangle (a, b, c) closest to p by the Voronoi-region walk
// of Ericson ("Real-Time Collision Detection", 5.1.5), as firn_mesh's
// closest_on_triangle.
fn closest_by_regions(p: vec3<f32>, a: vec3<f32>, b: vec3<f32>, c: vec3<f32>) -> ClosestPoint {
    let ab = b - a;
    let ac = c - a;
    let d1 = dot(ab, p - a);
    let d2 = dot(ac, p - a);
    if d1 <= 0.0 && d2 <= 0.0 {
        return ClosestPoint(a, vec3<f32>(1.0, 0.0, 0.0));
    }
    let d3 = dot(ab, p - b);
    let d4 = dot(ac, p - b);
    if d3 >= 0.0 && d4 <= d3 {
        return ClosestPoint(b, vec3<f32>(0.0, 1.0, 0.0));
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        let s = d1 / (d1 - d3);
        return ClosestPoint(a + ab * s, vec3<f32>(1.0 - s, s, 0.0));
    }
    let d5 = dot(ab, p - c);
    let d6 = dot(ac, p - c);
    if d6 >= 0.0 && d5 <= d6 {
        return ClosestPoint(c, vec3<f32>(0.0, 0.0, 1.0));
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        let s = d2 / (d2 - d6);
        return ClosestPoint(a + ac * s, vec3<f32>(1.0 - s, 0.0, s));
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && d4 - d3 >= 0.0 && d5 - d6 >= 0.0 {
        let s = (d4 - d3) / ((d4 - d3) + (d5 - d6));
        return ClosestPoint(b + (c - b) * s, vec3<f32>(0.0, 1.0 - s, s));
    }
    let scale = 1.0 / (va + vb + vc);
    let v = vb * scale;
    let w = vc * scale;
    return ClosestPoint(a + ab * v + ac * w, vec3<f32>(1.0 - v - w, v, w));
}

// The barycentric weights of the point of triangle (a, b, c) closest to p;
// zero-area triangles use their edges.
fn closest_weights(p: vec3<f32>, a: vec3<f32>, b: vec3<f32>, c: vec3<f32>) -> vec3<f32> {
    if all(cross(b - a, c - a) == vec3<f32>(0.0)) {
        return closest_on_edges(p, a, b, c).weights;
    }
    let closest = closest_by_regions(p, a, b, c);
    if all(abs(closest.point) <= vec3<f32>(F32_MAX)) {
        return closest.weights;
    }
    return closest_on_edges(p, a, b, c).weights;
}

// The vertex velocities read at the point of `triangle` (of the band's
// frame) closest to `sample_point`.
fn surface_velocity_at(band: Band, region: u32, triangle: u32, sample_point: vec3<f32>) -> vec3<f32> {
    let triangles = collider_fields[region + REGION_TRIANGLES] + 3u * triangle;
    let corners = vec3<u32>(
        collider_fields[triangles],
        collider_fields[triangles + 1u],
        collider_fields[triangles + 2u],
    );
    let a = field_vec3(band.vertices + 3u * corners.x);
    let b = field_vec3(band.vertices + 3u * corners.y);
    let c = field_vec3(band.vertices + 3u * corners.z);
    let weights = closest_weights(sample_point, a, b, c);
    let velocities = collider_fields[region + REGION_VELOCITIES];
    let va = field_vec3(velocities + 3u * corners.x);
    let vb = field_vec3(velocities + 3u * corners.y);
    let vc = field_vec3(velocities + 3u * corners.z);
    return va * weights.x + vb * weights.y + vc * weights.z;
}

// What a band says at a point: the distance, its gradient and the
// surface's velocity (NarrowBandField::sample's SurfaceSample).
struct BandSample {
    distance: f32,
    gradient: vec3<f32>,
    velocity: vec3<f32>,
}

// `v` scaled to unit length, or `fallback` where its length has no finite
// reciprocal (glam's try_normalize).
fn normalized_or(v: vec3<f32>, fallback: vec3<f32>) -> vec3<f32> {
    let length = length(v);
    if length > 0.0 && length <= F32_MAX {
        let reciprocal = 1.0 / length;
        if reciprocal <= F32_MAX {
            return v * reciprocal;
        }
    }
    return fallback;
}

// The band's distance, gradient and surface velocity at `point`; away from
// the band the distance is +- the band, the gradient zero outside and away
// from the mesh's centre inside, and the velocity `far_velocity`.
fn band_sample(band: Band, region: u32, point: vec3<f32>, far_velocity: vec3<f32>) -> BandSample {
    let found = band_lookup(band, point);
    if !found.near {
        if found.entry == BAND_INSIDE {
            return BandSample(-band.band, normalized_or(point - band.centre, vec3<f32>(0.0)), far_velocity);
        }
        return BandSample(band.band, vec3<f32>(0.0), far_velocity);
    }
    var distance = 0.0;
    var gradient = vec3<f32>(0.0);
    var velocity = vec3<f32>(0.0);
    for (var corner = 0u; corner < 8u; corner++) {
        let offset = corner_offset(corner);
        let w = corner_weights(offset, found.t);
        let slope = select(vec3<f32>(-1.0), vec3<f32>(1.0), offset == vec3<u32>(1u));
        let at = found.cell + offset;
        let word = band_sample_word(band, band_entry(band, at), at);
        let value = field_float(word);
        let sample_point = band.origin + vec3<f32>(at) * band.spacing;
        distance += w.x * w.y * w.z * value;
        gradient += value * vec3<f32>(slope.x * w.y * w.z, w.x * slope.y * w.z, w.x * w.y * slope.z);
        velocity += w.x * w.y * w.z * surface_velocity_at(band, region, collider_fields[word + 1u], sample_point);
    }
    return BandSample(distance, gradient / band.spacing, velocity);
}

// A surface at a point: signed distance (negative inside), outward unit
// normal and the velocity it moves with there.
struct MovingSurface {
    distance: f32,
    normal: vec3<f32>,
    velocity: vec3<f32>,
}

// The deforming collider's signed distance at `point`, `fraction` of the
// way between its two mesh frames (DeformingSurface::distance).
fn deforming_distance(collider: Collider, fraction: f32, point: vec3<f32>) -> f32 {
    let region = collider.sdf_dims.w;
    let a = band_distance(band_in(collider_fields[region + REGION_FROM_SLOT]), point);
    let b = band_distance(band_in(collider_fields[region + REGION_TO_SLOT]), point);
    return a + (b - a) * fraction;
}

// The deforming collider's distance, normal and velocity at `point`
// (DeformingSurface::sample): the two frames' blended by `fraction`, the
// normal the blended gradient's direction (up where it vanishes).
fn deforming_surface(collider: Collider, fraction: f32, point: vec3<f32>) -> MovingSurface {
    let region = collider.sdf_dims.w;
    let far_velocity = field_vec3(region + REGION_MEAN_VELOCITY);
    let a = band_sample(band_in(collider_fields[region + REGION_FROM_SLOT]), region, point, far_velocity);
    let b = band_sample(band_in(collider_fields[region + REGION_TO_SLOT]), region, point, far_velocity);
    let s = fraction;
    let distance = a.distance + (b.distance - a.distance) * s;
    let gradient = a.gradient * (1.0 - s) + b.gradient * s;
    let velocity = a.velocity * (1.0 - s) + b.velocity * s;
    return MovingSurface(distance, normalized_or(gradient, vec3<f32>(0.0, 1.0, 0.0)), velocity);
}

// The deforming collider's surface where `point` touches it: the cheap
// distance first, the normal and velocity only inside
// (PlacedCollider::collide_deforming).
fn deforming_contact(collider: Collider, fraction: f32, point: vec3<f32>) -> MovingSurface {
    let distance = deforming_distance(collider, fraction, point);
    if distance > 0.0 {
        return MovingSurface(distance, vec3<f32>(0.0, 1.0, 0.0), vec3<f32>(0.0));
    }
    return deforming_surface(collider, fraction, point);
}

// Where time t falls between a sequence's mesh frames: before its start
// at the first frame, after its last at the last
// (MeshSequenceCollider::interval_at); `code` is 2 from + (to - from).
struct SequenceInterval {
    code: u32,
    fraction: f32,
}

fn sequence_interval(collider: Collider, t: f32) -> SequenceInterval {
    let last = collider.sdf_dims.x;
    let position = (t - collider.extent.x) * collider.extent.y;
    if !(position > 0.0) {
        return SequenceInterval(0u, 0.0);
    }
    let before = floor(position);
    if before >= f32(last) {
        return SequenceInterval(2u * last, 0.0);
    }
    return SequenceInterval(2u * u32(before) + 1u, position - before);
}

// Whether every deforming collider's region holds the mesh frames of the
// interval its pose (placed by place_colliders) wants.
fn sequences_ready() -> bool {
    let count = arrayLength(&colliders);
    for (var c = 0u; c < count; c++) {
        let collider = colliders[c];
        if collider.shape == SHAPE_SEQUENCE {
            let code = u32(collider_poses[c].angular_velocity.w);
            let region = collider.sdf_dims.w;
            let first = code / 2u;
            let second = first + code % 2u;
            if collider_fields[region + REGION_FROM] != first || collider_fields[region + REGION_TO] != second {
                return false;
            }
        }
    }
    return true;
}
