// Robust 3x3 SVD F = U diag(sigma) V^T with U, V proper rotations, the same
// algorithm and operation order as firn_core::math::svd::svd3 (after
// McAdams et al. 2011): exact power-of-two normalisation, four cyclic
// Jacobi sweeps on F^T F, columns of B = F V sorted by norm, one one-sided
// Jacobi rotation of the trailing columns, and a Givens QR of B. Singular
// values come sorted, x >= y >= |z|, and z carries the sign of det F.

const JACOBI_SWEEPS: i32 = 4;
const JACOBI_SKIP: f32 = 1.0e-12;
const SVD_TINY: f32 = 1.0e-18;

struct Svd {
    u: mat3x3<f32>,
    sigma: vec3<f32>,
    v: mat3x3<f32>,
}

// A plane rotation: its cosine, sine and (for the Jacobi steps) tangent.
struct Rotation {
    c: f32,
    s: f32,
    t: f32,
}

// Two columns after a plane rotation.
struct RotatedPair {
    a: vec3<f32>,
    b: vec3<f32>,
}

// A column of B = F V, the matching column of V, and its squared norm.
struct SvdColumn {
    b: vec3<f32>,
    v: vec3<f32>,
    norm2: f32,
}

struct OrderedColumns {
    first: SvdColumn,
    second: SvdColumn,
}

// copysign(1, x): +1 for +0, -1 for -0.
fn sign_of(x: f32) -> f32 {
    return bitcast<f32>(bitcast<u32>(1.0) | (bitcast<u32>(x) & 0x80000000u));
}

// (scale, 1 / scale), powers of two with max_abs * scale in [1, 2).
fn power_of_two_scale(max_abs: f32) -> vec2<f32> {
    let exponent = i32((bitcast<u32>(max_abs) >> 23u) & 0xffu);
    let biased = u32(clamp(254 - exponent, 1, 253));
    return vec2<f32>(bitcast<f32>(biased << 23u), bitcast<f32>((254u - biased) << 23u));
}

// The rotation by |theta| <= pi/4 zeroing the off-diagonal entry of
// [[app, apq], [apq, aqq]]; the identity when |apq| < skip.
fn jacobi_rotation(app: f32, aqq: f32, apq: f32, skip: f32) -> Rotation {
    let d = app - aqq;
    let x0 = abs(d);
    let y = 2.0 * apq * sign_of(d);
    let r0 = sqrt(x0 * x0 + y * y);
    let x1 = x0 + r0;
    let inv_len = 1.0 / sqrt(2.0 * r0 * x1);
    if abs(apq) < skip {
        return Rotation(1.0, 0.0, 0.0);
    }
    return Rotation(x1 * inv_len, y * inv_len, y * (2.0 * r0) * (inv_len * inv_len));
}

// (c a + s b, c b - s a).
fn rotate_pair(a: vec3<f32>, b: vec3<f32>, c: f32, s: f32) -> RotatedPair {
    return RotatedPair(a * c + b * s, b * c - a * s);
}

// Givens rotation with c a + s b = hypot and c b - s a = 0.
fn givens(a: f32, b: f32, hypot: f32) -> Rotation {
    let inv = 1.0 / max(hypot, SVD_TINY);
    if hypot < SVD_TINY {
        return Rotation(1.0, 0.0, 0.0);
    }
    return Rotation(a * inv, b * inv, 0.0);
}

// Orders two columns by decreasing norm; a swap negates the one moving back.
fn order_columns(x: SvdColumn, y: SvdColumn) -> OrderedColumns {
    if x.norm2 < y.norm2 {
        return OrderedColumns(y, SvdColumn(-x.b, -x.v, x.norm2));
    }
    return OrderedColumns(x, y);
}

fn max_abs_entry(f: mat3x3<f32>) -> f32 {
    let a = abs(f[0]);
    let b = abs(f[1]);
    let c = abs(f[2]);
    return max(max(max(a.x, a.y), a.z), max(max(max(b.x, b.y), b.z), max(max(c.x, c.y), c.z)));
}

fn svd_column(f: mat3x3<f32>, v: vec3<f32>) -> SvdColumn {
    let b = f * v;
    return SvdColumn(b, v, dot(b, b));
}

fn svd3(input: mat3x3<f32>) -> Svd {
    // 1. Exact power-of-two normalisation.
    let scales = power_of_two_scale(max_abs_entry(input));
    let f = input * scales.x;

    // 2. Jacobi eigen-analysis of A = F^T F; d: diagonal, off[k]: the entry
    // coupling the two axes other than k. V collects the rotations.
    var d = array<f32, 3>(dot(f[0], f[0]), dot(f[1], f[1]), dot(f[2], f[2]));
    var off = array<f32, 3>(dot(f[1], f[2]), dot(f[2], f[0]), dot(f[0], f[1]));
    var v = array<vec3<f32>, 3>(vec3<f32>(1.0, 0.0, 0.0), vec3<f32>(0.0, 1.0, 0.0), vec3<f32>(0.0, 0.0, 1.0));
    for (var sweep = 0; sweep < JACOBI_SWEEPS; sweep++) {
        for (var plane = 0; plane < 3; plane++) {
            let p = plane;
            let q = (plane + 1) % 3;
            let k = 3 - p - q;
            let pp = d[p];
            let qq = d[q];
            let pq = off[k];
            let pk = off[q];
            let qk = off[p];
            let r = jacobi_rotation(pp, qq, pq, JACOBI_SKIP);
            d[p] = pp + r.t * pq;
            d[q] = qq - r.t * pq;
            off[k] = 0.0;
            off[q] = r.c * pk + r.s * qk;
            off[p] = r.c * qk - r.s * pk;
            let turned = rotate_pair(v[p], v[q], r.c, r.s);
            v[p] = turned.a;
            v[q] = turned.b;
        }
    }

    // 3. B = F V with its columns sorted by decreasing norm.
    var k0 = svd_column(f, v[0]);
    var k1 = svd_column(f, v[1]);
    var k2 = svd_column(f, v[2]);
    var ordered = order_columns(k0, k1);
    k0 = ordered.first;
    k1 = ordered.second;
    ordered = order_columns(k0, k2);
    k0 = ordered.first;
    k2 = ordered.second;
    ordered = order_columns(k1, k2);
    k1 = ordered.first;
    k2 = ordered.second;

    // 4. One-sided Jacobi rotation decoupling the trailing columns.
    let r = jacobi_rotation(dot(k1.b, k1.b), dot(k2.b, k2.b), dot(k1.b, k2.b), SVD_TINY);
    let bs = rotate_pair(k1.b, k2.b, r.c, r.s);
    let vs = rotate_pair(k1.v, k2.v, r.c, r.s);

    // 5. Givens QR of B acting on its rows; U accumulates the transposes.
    let b0 = k0.b;
    let b1 = bs.a;
    let b2 = bs.b;
    var r0 = vec3<f32>(b0.x, b1.x, b2.x);
    var r1 = vec3<f32>(b0.y, b1.y, b2.y);
    var r2 = vec3<f32>(b0.z, b1.z, b2.z);
    var u0 = vec3<f32>(1.0, 0.0, 0.0);
    var u1 = vec3<f32>(0.0, 1.0, 0.0);
    var u2 = vec3<f32>(0.0, 0.0, 1.0);
    let rho = sqrt(b0.x * b0.x + b0.y * b0.y);
    let norm0 = sqrt(dot(b0, b0));
    var g = givens(b0.x, b0.y, rho);
    var rows = rotate_pair(r0, r1, g.c, g.s);
    r0 = rows.a;
    r1 = rows.b;
    var us = rotate_pair(u0, u1, g.c, g.s);
    u0 = us.a;
    u1 = us.b;
    g = givens(rho, b0.z, norm0);
    rows = rotate_pair(r0, r2, g.c, g.s);
    r2 = rows.b;
    us = rotate_pair(u0, u2, g.c, g.s);
    u0 = us.a;
    u2 = us.b;
    let rho1 = sqrt(r1.y * r1.y + r2.y * r2.y);
    g = givens(r1.y, r2.y, rho1);
    rows = rotate_pair(r1, r2, g.c, g.s);
    r2 = rows.b;
    us = rotate_pair(u1, u2, g.c, g.s);
    u1 = us.a;
    u2 = us.b;

    let sigma_z = r2.z;
    let sigma_y = max(rho1, abs(sigma_z));
    let sigma_x = max(norm0, sigma_y);
    return Svd(mat3x3<f32>(u0, u1, u2), vec3<f32>(sigma_x, sigma_y, sigma_z) * scales.y, mat3x3<f32>(k0.v, vs.a, vs.b));
}
