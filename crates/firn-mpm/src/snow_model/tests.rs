use super::*;
use firn_core::math::svd::svd3;
use glam::{Mat3, Vec3};
use proptest::prelude::*;

fn thesis_constants() -> MaterialConstants {
    MaterialConstants::new(&Material::preset("thesis").unwrap())
}

fn matrix(values: [f32; 9]) -> Mat3 {
    Mat3::from_cols_array(&values)
}

fn one(m: Mat3) -> Mat3s<1> {
    Mat3s::splat(m)
}

/// The factor that multiplies F_P: F_P_new = V Σc⁻¹ Σ Vᵀ F_P_old (eq. 43),
/// so that F_E_new F_P_new = F̂_E F_P_old.
fn plastic_increment(projection: &PlasticProjection<1>) -> Mat3 {
    let v = projection.trial.v.lane(0);
    let ratio = projection.trial.sigma.lane(0) / projection.clamped.lane(0);
    v * Mat3::from_diagonal(ratio) * v.transpose()
}

proptest! {
    #[test]
    fn plasticity_clamps_and_preserves_the_total_gradient(
        noise in proptest::array::uniform9(-0.2f32..0.2),
        plastic_noise in proptest::array::uniform9(-0.05f32..0.05),
    ) {
        let constants = thesis_constants();
        let trial = Mat3::IDENTITY + matrix(noise);
        let plastic_old = Mat3::IDENTITY + matrix(plastic_noise);
        let projection = PlasticProjection::new(&one(trial), &MaterialLanes::splat(&constants));
        let elastic = projection.elastic().lane(0);
        let sigma = svd3(elastic).sigma;
        for s in sigma.to_array() {
            prop_assert!(s >= constants.min_stretch - 1e-5 && s <= constants.max_stretch + 1e-5,
                "singular value {s} outside [{}, {}]", constants.min_stretch, constants.max_stretch);
        }
        let plastic_new = plastic_increment(&projection) * plastic_old;
        let total_before = trial * plastic_old;
        let total_after = elastic * plastic_new;
        prop_assert!((total_after - total_before).abs().to_cols_array().iter().all(|e| *e < 2e-5),
            "F_E F_P changed: {total_before} vs {total_after}");
        let expected_j = plastic_new.determinant() / plastic_old.determinant();
        let ratio = projection.plastic_j_ratio().lane(0);
        prop_assert!((ratio - expected_j).abs() < 1e-4 * expected_j.abs().max(1.0));
    }
}

/// U diag(σ) Vᵀ with rotations about the axes `left` and `right`.
fn stretched(left: [f32; 3], right: [f32; 3], sigma: Vec3) -> Mat3 {
    let rotation = |axis: [f32; 3]| {
        let axis = Vec3::from(axis);
        Mat3::from_quat(glam::Quat::from_scaled_axis(axis))
    };
    rotation(left) * Mat3::from_diagonal(sigma) * rotation(right).transpose()
}

proptest! {
    /// The Sylvester test agrees with the singular values: inside means
    /// every σ in (1 − θc, 1 + θs) and det > 0. Singular values are kept
    /// 1e-4 from the bounds, where rounding cannot decide.
    #[test]
    fn within_yield_surface_agrees_with_the_singular_values(
        left in proptest::array::uniform3(-2.0f32..2.0),
        right in proptest::array::uniform3(-2.0f32..2.0),
        sigma in proptest::array::uniform3(0.95f32..1.02),
        flip in proptest::bool::ANY,
    ) {
        let constants = thesis_constants();
        let away = |s: f32| (s - constants.min_stretch).abs() > 1e-4
            && (s - constants.max_stretch).abs() > 1e-4;
        prop_assume!(sigma.iter().all(|&s| away(s)));
        let sign = if flip { -1.0 } else { 1.0 };
        let trial = stretched(left, right, Vec3::new(sigma[0], sigma[1], sign * sigma[2]));
        let inside = sigma.iter().all(|&s| s > constants.min_stretch && s < constants.max_stretch) && !flip;
        let mask = MaterialLanes::splat(&constants).within_yield_surface(&one(trial));
        prop_assert_eq!(mask.all(), inside, "σ = {:?}, inverted: {}", sigma, flip);
    }

    /// Inside the yield surface F_E and J_P keep their bits, and the
    /// stress from Newton's rotation matches the one through the SVD.
    #[test]
    fn unclamped_update_keeps_the_trial_and_matches_the_svd_stress(
        left in proptest::array::uniform3(-2.0f32..2.0),
        right in proptest::array::uniform3(-2.0f32..2.0),
        sigma in proptest::array::uniform3(0.976f32..1.0074),
        plastic_j in 0.5f32..1.5,
    ) {
        let trial = stretched(left, right, Vec3::from(sigma));
        let materials = MaterialLanes::splat(&thesis_constants());
        prop_assume!(materials.within_yield_surface(&one(trial)).all());
        let update = ElasticUpdate::new(&one(trial), F32s([plastic_j]), F32s([1.0]), &materials);
        prop_assert_eq!(update.elastic.lane(0).to_cols_array().map(f32::to_bits), trial.to_cols_array().map(f32::to_bits));
        prop_assert_eq!(update.plastic_j.lane(0).to_bits(), plastic_j.to_bits());

        let through_svd = ElasticState::projected(&one(trial), F32s([plastic_j]), &materials);
        let (svd_stress, factor) = through_svd.hardened_stress(&materials);
        let svd_stress = svd_stress.lane(0);
        let scale = materials.mu0.lane(0) * factor.lane(0);
        let difference = (update.stress.lane(0) - svd_stress).abs().to_cols_array().into_iter().fold(0.0, f32::max);
        prop_assert!(difference < 2e-5 * scale, "stress {} vs {svd_stress}", update.stress.lane(0));
    }
}

/// In a batch that mixes clamped and unclamped particles each lane gets
/// the bits it gets alone, so a particle's path does not depend on its
/// neighbours.
#[test]
fn mixed_batches_give_each_lane_its_own_bits() {
    let constants = thesis_constants();
    let trials = [
        stretched(
            [0.3, -0.2, 0.1],
            [0.0, 0.5, 0.2],
            Vec3::new(1.004, 0.99, 0.98),
        ),
        stretched(
            [0.1, 0.2, 0.3],
            [0.4, 0.0, -0.1],
            Vec3::new(1.03, 0.99, 0.9),
        ),
        Mat3::IDENTITY,
        stretched(
            [-0.5, 0.0, 0.7],
            [0.1, 0.1, 0.1],
            Vec3::new(1.0, 0.97, 0.96),
        ),
    ];
    let plastic_j = F32s([1.0, 0.9, 1.1, 0.95]);
    let mut batch = Mat3s::<4>::splat(Mat3::ZERO);
    for (lane, trial) in trials.iter().enumerate() {
        batch.set_lane(lane, *trial);
    }
    let materials = MaterialLanes::splat(&constants);
    let inside = materials.within_yield_surface(&batch);
    assert_eq!(inside.0.map(|m| m != 0), [true, false, true, false]);
    let together = ElasticUpdate::new(&batch, plastic_j, F32s::splat(2.0), &materials);
    for (lane, trial) in trials.iter().enumerate() {
        let alone = ElasticUpdate::new(
            &one(*trial),
            F32s([plastic_j.lane(lane)]),
            F32s([2.0]),
            &MaterialLanes::splat(&constants),
        );
        let bits = |m: Mat3| m.to_cols_array().map(f32::to_bits);
        assert_eq!(
            bits(together.elastic.lane(lane)),
            bits(alone.elastic.lane(0))
        );
        assert_eq!(bits(together.stress.lane(lane)), bits(alone.stress.lane(0)));
        assert_eq!(
            together.plastic_j.lane(lane).to_bits(),
            alone.plastic_j.lane(0).to_bits()
        );
    }
}

fn update(trial: Mat3, plastic_j: f32) -> ElasticUpdate<1> {
    let materials = MaterialLanes::splat(&thesis_constants());
    ElasticUpdate::new(&one(trial), F32s([plastic_j]), F32s([1.0]), &materials)
}

#[test]
fn undeformed_snow_has_no_stress() {
    let stress = update(Mat3::IDENTITY, 1.0).stress.lane(0);
    assert!(stress.abs().to_cols_array().iter().all(|e| *e < 1e-3));
}

#[test]
fn compression_gives_pressure_and_hardening_stiffens() {
    let constants = thesis_constants();
    let squeeze = Mat3::from_diagonal(Vec3::splat(0.99));
    let soft = update(squeeze, 1.0);
    let hard = update(squeeze, 0.5);
    let (soft_stress, hard_stress) = (soft.stress.lane(0), hard.stress.lane(0));
    // Compressed: negative normal stress, no shear.
    assert!(soft_stress.x_axis.x < 0.0);
    assert!(soft_stress.y_axis.x.abs() < 1e-2 * soft_stress.x_axis.x.abs());
    // Hardening by e^{ξ(1 − J_P)} with J_P = 0.5.
    let factor = (constants.hardening * 0.5).exp();
    assert_eq!(
        hard.hardening_factor.lane(0),
        constants.hardening_factor(0.5)
    );
    assert!((hard_stress.x_axis.x / soft_stress.x_axis.x - factor).abs() < 1e-4);
}
