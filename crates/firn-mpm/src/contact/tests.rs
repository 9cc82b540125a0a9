use super::*;

const UP: Vec3 = Vec3::Y;

fn contact(mode: ContactMode, friction: f32) -> Contact {
    Contact { mode, friction }
}

fn close(a: Vec3, b: Vec3) -> bool {
    (a - b).length() < 1e-6
}

#[test]
fn sticking_when_friction_wins() {
    // v_n = −2, |v_t| = 1 ≤ μ·2 with μ = 0.6: the snow sticks.
    let v = apply_contact(
        Vec3::new(1.0, -2.0, 0.0),
        Vec3::ZERO,
        UP,
        contact(ContactMode::Separate, 0.6),
    );
    assert!(close(v, Vec3::ZERO), "{v}");
}

#[test]
fn sliding_loses_mu_times_normal_speed() {
    // v_n = −1, v_t = (3, 0, 4) with |v_t| = 5, μ = 0.5: |v_t| becomes 4.5.
    let v = apply_contact(
        Vec3::new(3.0, -1.0, 4.0),
        Vec3::ZERO,
        UP,
        contact(ContactMode::Separate, 0.5),
    );
    assert!(close(v, Vec3::new(2.7, 0.0, 3.6)), "{v}");
}

#[test]
fn separating_snow_is_untouched_by_the_thesis_law() {
    let v = Vec3::new(1.0, 2.0, 0.0);
    assert_eq!(
        apply_contact(v, Vec3::ZERO, UP, contact(ContactMode::Separate, 0.5)),
        v
    );
    // Slip removes the normal part but not the tangential one.
    let slip = apply_contact(v, Vec3::ZERO, UP, contact(ContactMode::Slip, 0.5));
    assert!(close(slip, Vec3::new(1.0, 0.0, 0.0)), "{slip}");
}

#[test]
fn frictionless_contact_keeps_the_tangential_velocity() {
    let v = apply_contact(
        Vec3::new(1.0, -3.0, 0.0),
        Vec3::ZERO,
        UP,
        contact(ContactMode::Separate, 0.0),
    );
    assert!(close(v, Vec3::new(1.0, 0.0, 0.0)), "{v}");
}

#[test]
fn moving_collider_works_in_its_own_frame() {
    // A floor rising at 1 m/s; snow falling at 1 m/s and sliding at 2 m/s.
    // Relative: v_n = −2, v_t = 2; μ = 0.25 removes 0.5 → v_t = 1.5.
    let floor_velocity = Vec3::new(0.0, 1.0, 0.0);
    let v = apply_contact(
        Vec3::new(2.0, -1.0, 0.0),
        floor_velocity,
        UP,
        contact(ContactMode::Separate, 0.25),
    );
    assert!(close(v, Vec3::new(1.5, 1.0, 0.0)), "{v}");
    // Snow resting on it (relative velocity zero) moves with it.
    let rest = apply_contact(
        floor_velocity,
        floor_velocity,
        UP,
        contact(ContactMode::Separate, 0.25),
    );
    assert!(close(rest, floor_velocity));
    // A sticky collider imposes its velocity.
    let sticky = apply_contact(
        Vec3::new(5.0, -5.0, 1.0),
        floor_velocity,
        UP,
        contact(ContactMode::Sticky, 0.0),
    );
    assert!(close(sticky, floor_velocity));
}

#[test]
fn a_turned_collider_reads_its_distance_through_its_turn() {
    // A flat box turned a quarter about z stands up: it is the tall box.
    let center = Vec3::new(0.5, 0.5, 0.5);
    let quarter = Quat::from_rotation_z(std::f32::consts::FRAC_PI_2);
    let placed = |size: Vec3, rotation: Quat| PlacedCollider {
        geometry: ColliderGeometry::Box { center, size },
        velocity: Vec3::ZERO,
        contact: contact(ContactMode::Sticky, 0.0),
        spin: (rotation != Quat::IDENTITY).then(|| Spin {
            center,
            rotation,
            inverse: rotation.inverse(),
            angular_velocity: Vec3::ZERO,
        }),
        surface: None,
    };
    let turned = placed(Vec3::new(0.6, 0.1, 0.4), quarter);
    let tall = placed(Vec3::new(0.1, 0.6, 0.4), Quat::IDENTITY);
    for point in [
        Vec3::new(0.52, 0.78, 0.5),
        Vec3::new(0.8, 0.52, 0.45),
        Vec3::new(0.53, 0.3, 0.6),
        Vec3::new(0.9, 0.9, 0.1),
    ] {
        let spin = turned.spin.as_ref().expect("turned");
        let a = turned_distance(&turned.geometry, spin, point);
        let b = tall.geometry.signed_distance(point);
        assert!(
            (a.0 - b.0).abs() < 1e-6 && close(a.1, b.1),
            "at {point}: {a:?} vs {b:?}"
        );
        assert_eq!(turned.signed_distance(point), a.0);
    }
}

#[test]
fn only_points_inside_a_collider_are_affected() {
    let ball = PlacedCollider {
        geometry: ColliderGeometry::Sphere {
            center: Vec3::ZERO,
            radius: 1.0,
        },
        velocity: Vec3::ZERO,
        contact: contact(ContactMode::Separate, 0.0),
        spin: None,
        surface: None,
    };
    let towards_centre = Vec3::new(-1.0, 0.0, 0.0);
    assert_eq!(
        ball.collide(Vec3::new(1.5, 0.0, 0.0), towards_centre),
        towards_centre
    );
    assert!(close(
        ball.collide(Vec3::new(0.9, 0.0, 0.0), towards_centre),
        Vec3::ZERO
    ));
}

#[test]
fn contacts_report_the_components_they_fix() {
    let response = |velocity: Vec3, mode, friction| {
        contact_response(velocity, Vec3::ZERO, UP, contact(mode, friction)).1
    };
    let sliding = Vec3::new(3.0, -1.0, 0.0);
    let stuck = Vec3::new(0.1, -1.0, 0.0);
    let leaving = Vec3::new(1.0, 1.0, 0.0);
    assert_eq!(
        response(sliding, ContactMode::Sticky, 0.5),
        Constraint::Fixed
    );
    assert_eq!(
        response(sliding, ContactMode::Separate, 0.5),
        Constraint::Normal(UP)
    );
    assert_eq!(
        response(stuck, ContactMode::Separate, 0.5),
        Constraint::Fixed
    );
    assert_eq!(
        response(leaving, ContactMode::Separate, 0.5),
        Constraint::Free
    );
    assert_eq!(
        response(leaving, ContactMode::Slip, 0.5),
        Constraint::Normal(UP)
    );
}

#[test]
fn constraints_combine_into_the_remaining_free_directions() {
    let floor = Constraint::Normal(Vec3::Y);
    let wall = Constraint::Normal(Vec3::X);
    let v = Vec3::new(1.0, 2.0, 3.0);
    assert_eq!(floor.project(v), Vec3::new(1.0, 0.0, 3.0));
    // A floor and a wall leave the line along their edge.
    let corner = floor.and(wall);
    assert!(
        close(corner.project(v), Vec3::new(0.0, 0.0, 3.0)),
        "{corner:?}"
    );
    // The same plane twice fixes nothing more; a third plane fixes all.
    assert_eq!(floor.and(Constraint::Normal(Vec3::Y)), floor);
    assert_eq!(corner.and(Constraint::Normal(Vec3::Z)), Constraint::Fixed);
    assert_eq!(Constraint::Free.and(floor), floor);
    assert_eq!(floor.and(Constraint::Fixed).project(v), Vec3::ZERO);
}

#[test]
fn skipping_clear_walls_gives_the_bits_of_applying_every_collider() {
    let domain = Domain {
        min: Vec3::ZERO,
        max: Vec3::new(1.0, 2.0, 1.0),
        cell_size: 0.1,
        walls: contact(ContactMode::Separate, 0.3),
    };
    let scene = [
        Collider::sphere(Vec3::splat(0.5), 0.2)
            .moving(Vec3::new(0.0, -1.0, 0.0))
            .contact(contact(ContactMode::Sticky, 0.0)),
        // A scene floor above the domain's own, and a tilted plane that
        // is never skipped.
        Collider::plane(Vec3::new(0.0, 0.25, 0.0), Vec3::Y)
            .contact(contact(ContactMode::Slip, 0.5)),
        Collider::new(ColliderGeometry::HalfPlane {
            point: Vec3::new(0.9, 0.0, 0.0),
            normal: Vec3::new(-1.0, -1.0, 0.0).normalize(),
        })
        .contact(contact(ContactMode::Separate, 0.4)),
    ];
    let placed = ColliderSet::new(&domain, &scene).placed_at(0.5);
    let colliders = Colliders::new(&placed);
    assert_eq!(colliders.others.len(), 2, "the sphere and the tilted plane");
    assert_eq!(colliders.clear_above, Vec3A::new(0.0, 0.25, 0.0));
    assert_eq!(colliders.clear_below, Vec3A::from(domain.max));

    let mut state = 12345_u32;
    let mut next = move || {
        state = state.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
        (state >> 8) as f32 / (1 << 24) as f32
    };
    let mut points = vec![
        Vec3::new(0.0, 0.5, 0.5),
        Vec3::new(1.0, 0.5, 0.5),
        Vec3::new(0.5, 0.25, 0.5),
        Vec3::new(0.5, 2.0, -0.0),
        Vec3::new(f32::NAN, 0.5, 0.5),
        Vec3::new(0.5, f32::INFINITY, 0.5),
        Vec3::new(0.5, 0.5, f32::MAX),
    ];
    points.extend((0..4000).map(|_| Vec3::new(next(), next(), next()) * 1.2 - 0.1));
    let mut touched = 0;
    for point in points {
        let velocity = Vec3::new(next(), next(), next()) * 4.0 - 2.0;
        let expected = collide_all(&placed, point, velocity);
        let got = colliders.collide(point, velocity);
        assert_eq!(
            got.to_array().map(f32::to_bits),
            expected.to_array().map(f32::to_bits),
            "at {point}"
        );
        touched += usize::from(expected != velocity);
    }
    assert!(touched > 500, "only {touched} points met a collider");
}
