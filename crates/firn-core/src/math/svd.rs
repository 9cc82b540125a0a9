//! Robust 3x3 singular value and polar decompositions.
//!
//! [`svd3`] factors a deformation gradient as `F = U Σ Vᵀ` with `U` and `V` proper
//! rotations (det +1). The singular values are sorted by decreasing magnitude and the
//! last one carries the sign of `det F`, so an inverted (reflected) element shows up as
//! `sigma.z < 0` rather than as a reflection hidden in `U` or `V`. That is the
//! convention the snow constitutive model needs: clamping the singular values and
//! forming `R = U Vᵀ` always gives a rotation. [`polar`] builds `F = R S` on top of it.
//!
//! # Algorithm
//!
//! The structure follows McAdams et al. 2011, "Computing the singular value
//! decomposition of 3x3 matrices with minimal branching and elementary floating point
//! operations":
//!
//! 1. `F` is multiplied by an exact power of two that brings its largest entry into
//!    `[1, 2)`. This loses no precision and keeps `FᵀF` and every intermediate far from
//!    overflow and underflow whatever the scale of the input; all thresholds below are
//!    relative to this normalised matrix.
//! 2. Cyclic Jacobi eigen-analysis of the symmetric `A = FᵀF`: four sweeps over the
//!    planes (x,y), (y,z), (z,x). Each step applies the exact Jacobi rotation (inner
//!    angle, |θ| <= π/4) that zeroes the plane's off-diagonal entry, and applies the
//!    same rotation to two columns of `V`. Each step takes two square roots and one
//!    division (its tangent comes from the same quantities, not from a second
//!    division). Steps whose off-diagonal entry is already below 1e-12 are skipped;
//!    this keeps converged entries from decaying into denormals, which are very slow
//!    on x86.
//! 3. `B = F V` has (nearly) orthogonal columns whose norms are the singular values.
//!    The columns are sorted by decreasing norm; each swap negates one of the two
//!    columns (of `B` and of `V`) so that `V` stays a proper rotation.
//! 4. One one-sided Jacobi rotation of the two trailing columns of `B` (and `V`), with
//!    the angle taken from dot products of those columns rather than from `FᵀF`.
//!    Forming `FᵀF` squares the condition number: when the second singular value is
//!    much smaller than the first, the eigenvectors of step 2 leave the trailing columns
//!    coupled at the level `ε σ₁² / σ₂`, which measured as relative reconstruction
//!    errors up to 2e-4 for matrices like `Q₁ diag(1, 3e-4, 1e-4) Q₂`. This single extra
//!    rotation brings those cases back to the 1e-6 level of all others.
//! 5. QR factorisation of `B` by three Givens rotations. Their product is `U` (a
//!    rotation) and the diagonal of the triangular factor holds the singular values.
//!    Since `U` and `V` have det +1, the sign of `det F` ends up in the last one.
//!
//! The code is straight-line with a fixed operation count: no allocation, no loops
//! that depend on the data, and the few data-dependent choices (skips, swaps, zero
//! guards) are simple selects. It is written once, over `N` lanes
//! ([`svd3_lanes`] on [`F32s`]): [`svd3`] is the one-lane case, and the solver
//! decomposes 16 matrices per call in SIMD registers, each lane getting exactly the
//! bits it would get alone. Zero pivots are guarded, so rank-deficient and zero
//! matrices give finite singular values and proper rotations, and no finite input can
//! produce a NaN.
//!
//! # Accuracy and cost
//!
//! Over random, graded, rank-deficient, clustered, near-identity and rescaled (1e-30
//! to 1e30) matrices (the property tests below), the relative reconstruction error
//! `|U Σ Vᵀ − F| / |F|` (Frobenius) stays below 2e-6 and `U`, `V` are orthonormal to
//! 4e-6. Three sweeps leave a tail of errors near 1e-5; a fifth sweep changes nothing
//! measurable. The singular values are accurate to about 1e-6 `|F|` in absolute terms
//! (tiny ones are not accurate relative to themselves, as with any method that
//! works on `FᵀF`). One matrix alone takes about 0.3 µs on an x86-64 server core,
//! bound by the latency of the square roots and divisions through the twelve
//! dependent Jacobi steps; a batch of sixteen in SIMD lanes shares that latency:
//! `cargo run --release -p firn-core --example svd_throughput` measures about 36 ns
//! per matrix with AVX2 (two 8-lane chains) and 58 to 60 ns with portable SSE2
//! code, on one core of the 2-core Xeon of docs/benchmarks.md.

use glam::{Mat3, Vec3};

use crate::math::lanes::{F32s, Mat3s, U32s, Vec3s};

/// U Σ Vᵀ with U, V proper rotations (det +1).
#[derive(Clone, Copy, Debug)]
pub struct Svd3 {
    /// Left singular vectors as columns; a proper rotation.
    pub u: Mat3,
    /// Singular values, `x >= y >= |z|`; `z` is negative when det F < 0.
    pub sigma: Vec3,
    /// Right singular vectors as columns; a proper rotation.
    pub v: Mat3,
}

impl Svd3 {
    /// Rebuilds the decomposed matrix, U diag(sigma) Vᵀ.
    pub fn reconstruct(&self) -> Mat3 {
        self.u * Mat3::from_diagonal(self.sigma) * self.v.transpose()
    }
}

/// [`Svd3`] of `N` matrices at once, lane by lane.
#[derive(Clone, Copy, Debug)]
pub struct Svd3s<const N: usize> {
    /// Left singular vectors as columns.
    pub u: Mat3s<N>,
    /// Singular values, sorted and signed as in [`Svd3`].
    pub sigma: Vec3s<N>,
    /// Right singular vectors as columns.
    pub v: Mat3s<N>,
}

/// Number of cyclic Jacobi sweeps over FᵀF (three rotations each).
const JACOBI_SWEEPS: usize = 4;

/// Off-diagonal entries of the normalised FᵀF (whose largest diagonal entry is at
/// least 1) below this are left alone: they are far below the rounding error of
/// forming FᵀF.
const JACOBI_SKIP: f32 = 1.0e-12;

/// Magnitudes below this, relative to the normalised input, are treated as zero. Its
/// square is still a normal `f32`.
const TINY: f32 = 1.0e-18;

/// Singular values sorted by decreasing absolute value; sigma.x >= sigma.y >= |sigma.z|; sigma.z carries the sign of det F (negative for inverted/reflected F). u and v are rotations.
pub fn svd3(f: Mat3) -> Svd3 {
    let mut lanes = Mat3s::<1>::splat(Mat3::ZERO);
    lanes.set_lane(0, f);
    let svd = svd3_lanes(&lanes);
    Svd3 {
        u: svd.u.lane(0),
        sigma: svd.sigma.lane(0),
        v: svd.v.lane(0),
    }
}

/// [`svd3`] of `N` matrices at once. Each lane gets exactly the bits [`svd3`]
/// gives for its matrix alone.
#[inline(always)]
pub fn svd3_lanes<const N: usize>(f: &Mat3s<N>) -> Svd3s<N> {
    // 1. Exact power-of-two normalisation.
    let max_abs = f.max_abs();
    let scale = max_abs.map(|m| power_of_two_scale(m).0);
    let unscale = max_abs.map(|m| power_of_two_scale(m).1);
    let f = f.scale(scale);

    // 2. Jacobi eigen-analysis of the symmetric A = FᵀF; V collects the rotations.
    let (f0, f1, f2) = (f.x_axis, f.y_axis, f.z_axis);
    let mut a = Symmetric {
        d: [f0.dot(f0), f1.dot(f1), f2.dot(f2)],
        off: [f1.dot(f2), f2.dot(f0), f0.dot(f1)],
    };
    let mut v = [
        Vec3s::splat(Vec3::X),
        Vec3s::splat(Vec3::Y),
        Vec3s::splat(Vec3::Z),
    ];
    for _ in 0..JACOBI_SWEEPS {
        for (p, q) in [(0, 1), (1, 2), (2, 0)] {
            let (c, s) = a.jacobi_step(p, q);
            let (vp, vq) = rotate(v[p], v[q], c, s);
            (v[p], v[q]) = (vp, vq);
        }
    }

    // 3. B = F V, with its columns sorted by decreasing norm.
    let column = |v: Vec3s<N>| {
        let b = f.mul_vec(v);
        Column {
            b,
            v,
            norm2: b.length_squared(),
        }
    };
    let (mut k0, mut k1, mut k2) = (column(v[0]), column(v[1]), column(v[2]));
    order(&mut k0, &mut k1);
    order(&mut k0, &mut k2);
    order(&mut k1, &mut k2);

    // 4. One-sided Jacobi rotation decoupling the two trailing columns of B.
    let (c, s, _) = jacobi_rotation(
        k1.b.length_squared(),
        k2.b.length_squared(),
        k1.b.dot(k2.b),
        TINY,
    );
    (k1.b, k2.b) = rotate(k1.b, k2.b, c, s);
    (k1.v, k2.v) = rotate(k1.v, k2.v, c, s);

    // 5. QR of B by Givens rotations acting on its rows; U accumulates their
    // transposes, which act on its columns the same way.
    let (b0, b1, b2) = (k0.b, k1.b, k2.b);
    let mut r0 = Vec3s::new(b0.x, b1.x, b2.x);
    let mut r1 = Vec3s::new(b0.y, b1.y, b2.y);
    let mut r2 = Vec3s::new(b0.z, b1.z, b2.z);
    let (mut u0, mut u1, mut u2) = (
        Vec3s::splat(Vec3::X),
        Vec3s::splat(Vec3::Y),
        Vec3s::splat(Vec3::Z),
    );
    // The two rotations clearing the first column only depend on b0, so both are
    // computed up front.
    let rho = (b0.x * b0.x + b0.y * b0.y).sqrt();
    let norm0 = b0.length_squared().sqrt();
    let (c, s) = givens(b0.x, b0.y, rho);
    (r0, r1) = rotate(r0, r1, c, s);
    (u0, u1) = rotate(u0, u1, c, s);
    let (c, s) = givens(rho, b0.z, norm0);
    (_, r2) = rotate(r0, r2, c, s);
    (u0, u2) = rotate(u0, u2, c, s);
    let rho1 = (r1.y * r1.y + r2.y * r2.y).sqrt();
    let (c, s) = givens(r1.y, r2.y, rho1);
    (_, r2) = rotate(r1, r2, c, s);
    (u1, u2) = rotate(u1, u2, c, s);

    // The diagonal of R. The first two are the norms the rotations produce (the
    // rotated entries equal them up to rounding); the last one is signed. The sorted
    // columns give the ordering up to rounding; the maxima make it exact.
    let sigma_z = r2.z;
    let sigma_y = rho1.max(sigma_z.abs());
    let sigma_x = norm0.max(sigma_y);
    Svd3s {
        u: Mat3s::from_cols(u0, u1, u2),
        sigma: Vec3s::new(sigma_x, sigma_y, sigma_z).scale(unscale),
        v: Mat3s::from_cols(k0.v, k1.v, k2.v),
    }
}

/// Polar decomposition F = R S, R = U Vᵀ a rotation, S = V Σ Vᵀ symmetric. Returns (R, S).
pub fn polar(f: Mat3) -> (Mat3, Mat3) {
    let Svd3 { u, sigma, v } = svd3(f);
    let r = u * v.transpose();
    // S = Σₖ σₖ vₖ vₖᵀ. Entries (i, j) and (j, i) go through the same operations, so S
    // is exactly symmetric.
    let outer = |c: Vec3| Mat3::from_cols(c * c.x, c * c.y, c * c.z);
    let s = outer(v.x_axis) * sigma.x + outer(v.y_axis) * sigma.y + outer(v.z_axis) * sigma.z;
    (r, s)
}

/// Powers of two `(scale, 1 / scale)` with `max_abs * scale` in `[1, 2)`, read off the
/// exponent bits so that scaling is exact. The exponent is clamped so both factors are
/// normal numbers; then tiny (subnormal) input lands below 1 and huge input in `[2, 4)`.
#[inline(always)]
fn power_of_two_scale(max_abs: f32) -> (f32, f32) {
    let exponent = (max_abs.to_bits() >> 23) & 0xff;
    let biased = (254 - exponent as i32).clamp(1, 253) as u32;
    (
        f32::from_bits(biased << 23),
        f32::from_bits((254 - biased) << 23),
    )
}

/// The symmetric A = FᵀF during the Jacobi sweeps: its diagonal, and its
/// off-diagonal entries indexed by the axis they do not involve (`off[k]`
/// couples the other two axes).
struct Symmetric<const N: usize> {
    d: [F32s<N>; 3],
    off: [F32s<N>; 3],
}

impl<const N: usize> Symmetric<N> {
    /// One Jacobi step A ← Gᵀ A G in the plane (p, q) that zeroes A_pq; returns
    /// the rotation `(cos θ, sin θ)` turning axis p towards axis q.
    #[inline(always)]
    fn jacobi_step(&mut self, p: usize, q: usize) -> (F32s<N>, F32s<N>) {
        let k = 3 - p - q;
        let (pp, qq, pq) = (self.d[p], self.d[q], self.off[k]);
        let (pk, qk) = (self.off[q], self.off[p]);
        let (c, s, t) = jacobi_rotation(pp, qq, pq, JACOBI_SKIP);
        self.d[p] = pp + t * pq;
        self.d[q] = qq - t * pq;
        self.off[k] = F32s::splat(0.0);
        self.off[q] = c * pk + s * qk;
        self.off[p] = c * qk - s * pk;
        (c, s)
    }
}

/// The Jacobi rotation for the symmetric block `[[app, apq], [apq, aqq]]`:
/// `(cos θ, sin θ, tan θ)` of the angle, |θ| <= π/4, by which turning axis p towards
/// axis q zeroes the off-diagonal entry. The identity when `|apq| < skip`. Two
/// square roots and one division: the throughput limit of the batched SVD.
#[inline(always)]
fn jacobi_rotation<const N: usize>(
    app: F32s<N>,
    aqq: F32s<N>,
    apq: F32s<N>,
    skip: f32,
) -> (F32s<N>, F32s<N>, F32s<N>) {
    // tan 2θ = 2 apq / (app − aqq). The vector (|d|, 2 apq sgn d) points along 2θ;
    // adding its length to the first component halves the angle: (x1, y) points
    // along θ.
    let two = F32s::splat(2.0);
    let d = app - aqq;
    let x0 = d.abs();
    let y = two * apq * d.sign();
    let r0 = (x0 * x0 + y * y).sqrt();
    let x1 = x0 + r0;
    // |(x1, y)|² = x1² + y² = 2 r0 x1, so 1 / x1 = 2 r0 / |(x1, y)|².
    let inv_len = F32s::splat(1.0) / (two * r0 * x1).sqrt();
    let skipped = apq.abs().lt(F32s::splat(skip));
    let zero = F32s::splat(0.0);
    (
        F32s::select(skipped, F32s::splat(1.0), x1 * inv_len),
        F32s::select(skipped, zero, y * inv_len),
        F32s::select(skipped, zero, y * (two * r0) * (inv_len * inv_len)),
    )
}

/// `(c a + s b, c b − s a)`: a plane rotation applied to a pair of columns of B, V
/// or U, or of rows of R.
#[inline(always)]
fn rotate<const N: usize>(
    a: Vec3s<N>,
    b: Vec3s<N>,
    c: F32s<N>,
    s: F32s<N>,
) -> (Vec3s<N>, Vec3s<N>) {
    (a.scale(c) + b.scale(s), b.scale(c) - a.scale(s))
}

/// Givens rotation `(c, s)` with `c a + s b = hypot` and `c b − s a = 0`, given
/// `hypot = √(a² + b²)`; the identity when `(a, b)` is negligible.
#[inline(always)]
fn givens<const N: usize>(a: F32s<N>, b: F32s<N>, hypot: F32s<N>) -> (F32s<N>, F32s<N>) {
    let tiny = F32s::splat(TINY);
    let inv = F32s::splat(1.0) / hypot.max(tiny);
    let negligible = hypot.lt(tiny);
    (
        F32s::select(negligible, F32s::splat(1.0), a * inv),
        F32s::select(negligible, F32s::splat(0.0), b * inv),
    )
}

/// A column of B = F V, the matching column of V, and its squared norm.
#[derive(Clone, Copy)]
struct Column<const N: usize> {
    b: Vec3s<N>,
    v: Vec3s<N>,
    norm2: F32s<N>,
}

/// Orders two columns by decreasing norm. A swap negates the column that moves back,
/// so V keeps det +1 (and B = F V stays consistent).
#[inline(always)]
fn order<const N: usize>(first: &mut Column<N>, second: &mut Column<N>) {
    let (x, y) = (*first, *second);
    let swap: U32s<N> = x.norm2.lt(y.norm2);
    *first = Column {
        b: Vec3s::select(swap, y.b, x.b),
        v: Vec3s::select(swap, y.v, x.v),
        norm2: F32s::select(swap, y.norm2, x.norm2),
    };
    *second = Column {
        b: Vec3s::select(swap, -x.b, y.b),
        v: Vec3s::select(swap, -x.v, y.v),
        norm2: F32s::select(swap, x.norm2, y.norm2),
    };
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Quat;
    use proptest::prelude::*;
    use proptest::test_runner::TestCaseError;

    /// Relative reconstruction tolerance for U Σ Vᵀ; the worst case measured over
    /// millions of random matrices is 8e-7.
    const RECONSTRUCTION_TOL: f64 = 2e-6;
    /// Relative tolerance for R S, which rounds twice more (worst measured 1.6e-6).
    const POLAR_TOL: f64 = 4e-6;
    /// Orthonormality and determinant tolerance for U, V and R.
    const ROTATION_TOL: f64 = 4e-6;

    fn entries(m: Mat3) -> [f64; 9] {
        m.to_cols_array().map(f64::from)
    }

    fn frobenius(m: Mat3) -> f64 {
        entries(m).iter().map(|e| e * e).sum::<f64>().sqrt()
    }

    fn distance(a: Mat3, b: Mat3) -> f64 {
        let (a, b) = (entries(a), entries(b));
        a.iter()
            .zip(&b)
            .map(|(x, y)| (x - y) * (x - y))
            .sum::<f64>()
            .sqrt()
    }

    /// Determinant in f64 of the f32 entries.
    fn det(m: Mat3) -> f64 {
        let [a, b, c, d, e, f, g, h, i] = entries(m);
        a * (e * i - f * h) - d * (b * i - c * h) + g * (b * f - c * e)
    }

    fn diag(x: f32, y: f32, z: f32) -> Mat3 {
        Mat3::from_diagonal(Vec3::new(x, y, z))
    }

    fn check_rotation(name: &str, m: Mat3) -> Result<(), TestCaseError> {
        prop_assert!(m.is_finite(), "{name} not finite: {m}");
        let gram = m.transpose() * m;
        let off = distance(gram, Mat3::IDENTITY);
        prop_assert!(
            off <= ROTATION_TOL,
            "{name}ᵀ{name} − I = {off:e} for {name} = {m}"
        );
        let d = det(m);
        prop_assert!(
            (d - 1.0).abs() <= ROTATION_TOL,
            "det {name} = {d} for {name} = {m}"
        );
        Ok(())
    }

    /// Every property of `svd3` that needs no reference answer.
    fn check_svd(f: Mat3) -> Result<Svd3, TestCaseError> {
        let svd = svd3(f);
        let Svd3 { u, sigma, v } = svd;
        prop_assert!(sigma.is_finite(), "sigma {sigma} for F = {f}");
        check_rotation("U", u)?;
        check_rotation("V", v)?;
        prop_assert!(
            sigma.x >= sigma.y && sigma.y >= sigma.z.abs(),
            "unordered sigma {sigma} for F = {f}"
        );

        let norm = frobenius(f);
        let error = distance(svd.reconstruct(), f);
        prop_assert!(
            error <= RECONSTRUCTION_TOL * norm,
            "|UΣVᵀ − F| = {error:e}, |F| = {norm:e}, relative {:e}, F = {f}, svd = {svd:?}",
            error / norm
        );

        // Invariants: Σσ² = |F|², Πσ = det F.
        let s = sigma.to_array().map(f64::from);
        let sum_sq = s.iter().map(|x| x * x).sum::<f64>();
        prop_assert!((sum_sq - norm * norm).abs() <= 1e-5 * norm * norm);
        let d = det(f);
        prop_assert!((s[0] * s[1] * s[2] - d).abs() <= 1e-5 * norm.powi(3));
        // The sign rule, for clearly non-singular F.
        if d.abs() > 1e-4 * norm.powi(3) {
            prop_assert!(
                (sigma.z < 0.0) == (d < 0.0),
                "sigma.z = {} but det F = {d} for F = {f}",
                sigma.z
            );
        }
        Ok(svd)
    }

    /// The singular values match `expected` (unordered, signed; the sign rule moves
    /// all signs onto the last one).
    fn check_values(f: Mat3, sigma: Vec3, expected: [f32; 3]) -> Result<(), TestCaseError> {
        let mut want = expected.map(|e| f64::from(e.abs()));
        want.sort_by(|a, b| b.total_cmp(a));
        if expected.iter().filter(|e| **e < 0.0).count() % 2 == 1 {
            want[2] = -want[2];
        }
        let tol = 4e-6 * frobenius(f) + 1e-30;
        for (got, want) in sigma.to_array().into_iter().zip(want) {
            prop_assert!(
                (f64::from(got) - want).abs() <= tol,
                "sigma {sigma}, expected {expected:?}, F = {f}"
            );
        }
        Ok(())
    }

    /// S is positive semi-definite up to `tol`: the Cholesky factorisation of
    /// S + tol I succeeds.
    fn positive_semidefinite(s: Mat3, tol: f64) -> bool {
        let e = entries(s);
        let a = |i: usize, j: usize| e[3 * j + i] + if i == j { tol } else { 0.0 };
        let l00 = a(0, 0);
        if l00 <= 0.0 {
            return false;
        }
        let l00 = l00.sqrt();
        let (l10, l20) = (a(1, 0) / l00, a(2, 0) / l00);
        let l11 = a(1, 1) - l10 * l10;
        if l11 <= 0.0 {
            return false;
        }
        let l11 = l11.sqrt();
        let l21 = (a(2, 1) - l20 * l10) / l11;
        a(2, 2) - l20 * l20 - l21 * l21 > 0.0
    }

    fn check_polar(f: Mat3) -> Result<(Mat3, Mat3), TestCaseError> {
        let (r, s) = polar(f);
        check_rotation("R", r)?;
        prop_assert!(s.is_finite());
        prop_assert!(s == s.transpose(), "S not symmetric: {s}");
        let norm = frobenius(f);
        let error = distance(r * s, f);
        prop_assert!(
            error <= POLAR_TOL * norm,
            "|RS − F| = {error:e}, |F| = {norm:e}, F = {f}"
        );
        if det(f) > 0.0 {
            prop_assert!(
                positive_semidefinite(s, 1e-5 * norm),
                "S = {s} not PSD for F = {f}"
            );
        }
        Ok((r, s))
    }

    fn check_all(f: Mat3) -> Result<Svd3, TestCaseError> {
        check_polar(f)?;
        check_svd(f)
    }

    // Strategies.

    fn matrix(range: std::ops::Range<f32>) -> impl Strategy<Value = Mat3> {
        prop::array::uniform9(range).prop_map(|e| Mat3::from_cols_array(&e))
    }

    fn rotation() -> impl Strategy<Value = Mat3> {
        prop::array::uniform4(-1.0f32..1.0)
            .prop_filter("quaternion too short to normalise", |q| {
                q.iter().map(|x| x * x).sum::<f32>() > 0.01
            })
            .prop_map(|q| Mat3::from_quat(Quat::from_array(q).normalize()))
    }

    fn config(cases: u32) -> ProptestConfig {
        ProptestConfig {
            cases,
            ..ProptestConfig::default()
        }
    }

    proptest! {
        #![proptest_config(config(4000))]

        #[test]
        fn random_matrices(f in matrix(-10.0..10.0)) {
            check_all(f)?;
        }

        #[test]
        fn random_matrices_at_any_scale(f in matrix(-1.0..1.0), exponent in -6i32..=6) {
            check_all(f * 10f32.powi(exponent))?;
        }

        #[test]
        fn near_identity(noise in matrix(-1e-3..1e-3)) {
            let f = Mat3::IDENTITY + noise;
            let svd = check_all(f)?;
            prop_assert!(svd.sigma.z > 0.0);
        }

        #[test]
        fn rotations_times_diagonals_with_repeated_values(
            u in rotation(),
            v in rotation(),
            a in 0.1f32..5.0,
            b in 0.1f32..5.0,
            pattern in 0usize..4,
            flip in 0usize..4,
        ) {
            let mut d = [[a, a, b], [a, b, b], [a, b, a], [a, a, a]][pattern];
            // Optionally negate one entry: an inverted element.
            if flip < 3 {
                d[flip] = -d[flip];
            }
            let f = u * diag(d[0], d[1], d[2]) * v.transpose();
            let svd = check_all(f)?;
            check_values(f, svd.sigma, d)?;
        }

        #[test]
        fn rank_deficient(
            u in rotation(),
            v in rotation(),
            a in 0.0f32..10.0,
            b in 0.0f32..10.0,
            rank_one in any::<bool>(),
        ) {
            let d = if rank_one { [a, 0.0, 0.0] } else { [a, b, 0.0] };
            let f = u * diag(d[0], d[1], d[2]) * v.transpose();
            let svd = check_all(f)?;
            check_values(f, svd.sigma, d)?;
        }

        #[test]
        fn graded_singular_values(
            u in rotation(),
            v in rotation(),
            p in 0.0f32..4.0,
            q in 0.0f32..4.0,
            negative in any::<bool>(),
            exponent in -6i32..=6,
        ) {
            // Singular values 1, 10^-p, ±10^-(p+q): condition numbers up to 1e8.
            let (s1, s2) = (10f32.powf(-p), 10f32.powf(-p - q));
            let d = [1.0, s1, if negative { -s2 } else { s2 }];
            let f = u * diag(d[0], d[1], d[2]) * v.transpose() * 10f32.powi(exponent);
            let svd = check_all(f)?;
            check_values(f, svd.sigma, d.map(|x| x * 10f32.powi(exponent)))?;
        }

        #[test]
        fn rotation_has_trivial_polar_decomposition(r0 in rotation()) {
            let (r, s) = check_polar(r0)?;
            prop_assert!(distance(r, r0) <= 1e-5, "R = {r} for F = {r0}");
            prop_assert!(distance(s, Mat3::IDENTITY) <= 1e-5, "S = {s} for F = {r0}");
        }

        #[test]
        fn polar_recovers_rotation_and_stretch(
            r0 in rotation(),
            q in rotation(),
            d in prop::array::uniform3(0.2f32..5.0),
        ) {
            let s0 = q * diag(d[0], d[1], d[2]) * q.transpose();
            let f = r0 * s0;
            let (r, s) = check_polar(f)?;
            prop_assert!(distance(r, r0) <= 1e-5, "R = {r}, expected {r0}");
            prop_assert!(distance(s, s0) <= 1e-5 * frobenius(s0), "S = {s}, expected {s0}");
        }
    }

    #[test]
    fn special_matrices() {
        let shear = Mat3::from_cols(Vec3::X, Vec3::new(1e3, 1.0, 0.0), Vec3::Z);
        let outer = |a: Vec3, b: Vec3| Mat3::from_cols(a * b.x, a * b.y, a * b.z);
        let cases = [
            // (F, expected singular values if known)
            (Mat3::IDENTITY, Some([1.0, 1.0, 1.0])),
            (Mat3::ZERO, Some([0.0, 0.0, 0.0])),
            (-Mat3::IDENTITY, Some([-1.0, -1.0, -1.0])),
            (diag(2.0, 2.0, 0.5), Some([2.0, 2.0, 0.5])),
            (diag(0.5, 2.0, 2.0), Some([0.5, 2.0, 2.0])),
            (diag(1.0, 2.0, 3.0), Some([1.0, 2.0, 3.0])),
            (diag(-1.0, 1.0, 1.0), Some([-1.0, 1.0, 1.0])),
            (diag(1.0, -3.0, 2.0), Some([1.0, -3.0, 2.0])),
            (diag(1.0, 1.0, 0.0), Some([1.0, 1.0, 0.0])),
            (diag(0.0, 0.0, 1.0), Some([0.0, 0.0, 1.0])),
            (diag(0.0, 1e-7, 0.0), Some([0.0, 1e-7, 0.0])),
            (diag(1.0, 1.0, 1e-7), Some([1.0, 1.0, 1e-7])),
            (diag(1.0, 1.0, -1e-7), Some([1.0, 1.0, -1e-7])),
            (
                diag(1.0, 1.0 + 1e-7, 1.0 - 1e-7),
                Some([1.0, 1.0 + 1e-7, 1.0 - 1e-7]),
            ),
            (diag(1e-6, 1e-6, 1e-6), Some([1e-6, 1e-6, 1e-6])),
            (diag(1e6, 1e6, -1e6), Some([1e6, 1e6, -1e6])),
            (diag(1e30, 1.0, 1e-30), Some([1e30, 1.0, 1e-30])),
            (diag(3e38, 3e38, 3e38), Some([3e38, 3e38, 3e38])),
            // Permutations, even and odd.
            (
                Mat3::from_cols(Vec3::Y, Vec3::Z, Vec3::X),
                Some([1.0, 1.0, 1.0]),
            ),
            (
                Mat3::from_cols(Vec3::Y, Vec3::X, Vec3::Z),
                Some([1.0, 1.0, -1.0]),
            ),
            // Rotations by 90° and 180°.
            (
                Mat3::from_rotation_z(std::f32::consts::FRAC_PI_2),
                Some([1.0, 1.0, 1.0]),
            ),
            (
                Mat3::from_rotation_x(std::f32::consts::PI),
                Some([1.0, 1.0, 1.0]),
            ),
            (
                Mat3::from_axis_angle(Vec3::ONE.normalize(), 2.0),
                Some([1.0, 1.0, 1.0]),
            ),
            // Rank one, all entries equal.
            (
                Mat3::from_cols(Vec3::ONE, Vec3::ONE, Vec3::ONE),
                Some([3.0, 0.0, 0.0]),
            ),
            (
                outer(Vec3::new(1.0, -2.0, 3.0), Vec3::new(0.5, 4.0, -1.0)),
                None,
            ),
            // Rank two, nearly singular, badly conditioned.
            (Mat3::from_cols(Vec3::X, Vec3::Y, Vec3::X + Vec3::Y), None),
            (
                Mat3::from_cols(Vec3::X, Vec3::Y, Vec3::new(1.0, 1.0, 1e-6)),
                None,
            ),
            (shear, None),
            (shear.transpose() * 1e-5, None),
            (-shear, None),
        ];
        for (f, expected) in cases {
            let svd = check_all(f).unwrap();
            if let Some(expected) = expected {
                check_values(f, svd.sigma, expected).unwrap();
            }
        }
    }

    #[test]
    fn extreme_inputs_stay_finite() {
        // Scales at the edges of f32 (beyond the accuracy tests) and subnormal entries.
        const BIG: f32 = f32::MAX / 4.0;
        let huge = Mat3::from_cols_array(&[BIG, -BIG, 1.0, 0.0, BIG, 0.0, 1.0, 2.0, 3.0]);
        let cases = [
            huge,
            Mat3::from_cols_array(&[1e-40, 0.0, 3e-41, 1e-45, 2e-39, 0.0, 0.0, 0.0, -5e-42]),
            diag(f32::MIN_POSITIVE, 1e-45, 0.0),
            diag(BIG, f32::MIN_POSITIVE, -1e-45),
        ];
        for f in cases {
            let svd = svd3(f);
            assert!(svd.sigma.is_finite(), "sigma {} for F = {f}", svd.sigma);
            check_rotation("U", svd.u).unwrap();
            check_rotation("V", svd.v).unwrap();
            assert!(svd.sigma.x >= svd.sigma.y && svd.sigma.y >= svd.sigma.z.abs());
            let (r, s) = polar(f);
            check_rotation("R", r).unwrap();
            assert!(s.is_finite());
        }
        // FᵀF alone would overflow here; the power-of-two scaling keeps full accuracy.
        let svd = svd3(huge);
        assert!(distance(svd.reconstruct(), huge) <= RECONSTRUCTION_TOL * frobenius(huge));
        // A largest singular value beyond f32::MAX can only be infinite, but nothing
        // else breaks: no NaN, U and V still rotations.
        let f =
            Mat3::from_cols_array(&[f32::MAX, -f32::MAX, 1.0, 0.0, f32::MAX, 0.0, 1.0, 2.0, 3.0]);
        let svd = svd3(f);
        assert!(!svd.sigma.is_nan() && svd.sigma.y.is_finite() && svd.sigma.z.is_finite());
        check_rotation("U", svd.u).unwrap();
        check_rotation("V", svd.v).unwrap();
    }

    #[test]
    fn inverted_element() {
        // A rotated, squashed and mirrored element, as a collision may produce.
        let q = Mat3::from_axis_angle(Vec3::new(1.0, 2.0, 3.0).normalize(), 0.7);
        let p = Mat3::from_axis_angle(Vec3::new(-2.0, 0.5, 1.0).normalize(), -1.9);
        let f = q * diag(1.2, 0.9, -0.3) * p.transpose();
        let svd = check_all(f).unwrap();
        check_values(f, svd.sigma, [1.2, 0.9, -0.3]).unwrap();
        // The polar rotation is U Vᵀ, a proper rotation; S carries the inversion.
        let (r, s) = polar(f);
        assert!(distance(r, q * p.transpose()) <= 1e-5);
        assert!(det(s) < 0.0);
    }

    proptest! {
        #![proptest_config(config(200))]
        #[test]
        fn a_batch_gives_each_lane_the_scalar_bits(
            entries in prop::collection::vec(-4.0f32..4.0, 16 * 9),
        ) {
            let matrices: Vec<Mat3> = entries.chunks(9).map(Mat3::from_cols_slice).collect();
            let mut batch = Mat3s::<16>::splat(Mat3::ZERO);
            for (lane, m) in matrices.iter().enumerate() {
                batch.set_lane(lane, *m);
            }
            let svd = svd3_lanes(&batch);
            for (lane, m) in matrices.iter().enumerate() {
                let alone = svd3(*m);
                prop_assert_eq!(svd.u.lane(lane).to_cols_array().map(f32::to_bits), alone.u.to_cols_array().map(f32::to_bits));
                prop_assert_eq!(svd.sigma.lane(lane).to_array().map(f32::to_bits), alone.sigma.to_array().map(f32::to_bits));
                prop_assert_eq!(svd.v.lane(lane).to_cols_array().map(f32::to_bits), alone.v.to_cols_array().map(f32::to_bits));
            }
        }
    }
}
