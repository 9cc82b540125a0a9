//! Bad scene files: every error names the right line, column and key, and
//! says how to fix it.

use std::path::Path;

use firn_core::{Scene, SceneError};

/// Parse `text`, which must fail.
fn error(text: &str) -> SceneError {
    match Scene::from_toml_str(text, "scenes/bad.toml") {
        Ok(_) => panic!("scene should not load:\n{text}"),
        Err(err) => err,
    }
}

/// Assert the location and key of an error, and that its hint mentions `hint`.
#[track_caller]
fn check(err: &SceneError, line: usize, column: usize, key: Option<&str>, hint: &str) {
    assert_eq!(err.file, "scenes/bad.toml", "{err}");
    assert_eq!(
        (err.line, err.column),
        (Some(line), Some(column)),
        "wrong place:\n{err}"
    );
    assert_eq!(err.key.as_deref(), key, "wrong key:\n{err}");
    assert!(
        err.hint.contains(hint),
        "hint should mention {hint:?}:\n{err}"
    );
    // One block: the located message, then the fix.
    let shown = err.to_string();
    let expected = format!(
        "error: scenes/bad.toml:{line}:{column}: {}\n  fix: {}",
        err.message, err.hint
    );
    assert_eq!(shown, expected);
}

/// The head of a valid scene, 8 lines long; bodies and more follow on line 9.
const HEAD: &str = "format = 1

[domain]
max = [2.0, 2.0, 2.0]
cell_size = 0.05

[time]
duration = 1.0
";

const SPHERE: &str = "[[bodies]]
shape = \"sphere\"
center = [1.0, 1.0, 1.0]
radius = 0.2
";

#[test]
fn head_and_sphere_are_valid() {
    Scene::from_toml_str(&format!("{HEAD}{SPHERE}"), "scenes/bad.toml").unwrap();
}

#[test]
fn unknown_key_lists_the_valid_keys() {
    let err = error(&format!(
        "{HEAD}[[bodies]]
shape = \"sphere\"
center = [1.0, 1.0, 1.0]
radus = 0.2
"
    ));
    check(
        &err,
        12,
        1,
        Some("bodies[0].radus"),
        "did you mean `radius`?",
    );
    assert_eq!(err.message, "unknown key `radus` in bodies[0]");
    assert!(
        err.hint
            .contains("expected one of shape, center, radius, size, height, axis, velocity"),
        "{err}"
    );
}

#[test]
fn unknown_table_is_an_unknown_key() {
    let err = error(&format!("{HEAD}{SPHERE}\n[soler]\nseed = 3\n"));
    check(&err, 14, 2, Some("soler"), "did you mean `solver`?");
    assert!(err.message.contains("at the top level"), "{err}");
}

#[test]
fn unknown_key_in_an_inline_table() {
    let err = error(&HEAD.replace(
        "cell_size = 0.05\n",
        "cell_size = 0.05\nwalls = { mode = \"slip\", fricton = 0.1 }\n",
    ));
    check(
        &err,
        6,
        26,
        Some("domain.walls.fricton"),
        "did you mean `friction`?",
    );
}

#[test]
fn wrong_type_names_the_expected_type() {
    let err = error(&format!(
        "{HEAD}[[bodies]]
shape = \"sphere\"
center = [1.0, 1.0, 1.0]
radius = \"big\"
"
    ));
    check(&err, 12, 10, Some("bodies[0].radius"), "radius = 0.1");
    assert_eq!(
        err.message,
        "bodies[0].radius must be a number, not the string \"big\""
    );

    let err = error(&HEAD.replace("cell_size = 0.05", "cell_size = \"0.05\""));
    check(&err, 5, 13, Some("domain.cell_size"), "cell_size = 0.02");
}

#[test]
fn vector_with_two_numbers() {
    let err = error(&format!(
        "{HEAD}[[bodies]]
shape = \"sphere\"
center = [1.0, 1.0]
radius = 0.2
"
    ));
    check(&err, 11, 10, Some("bodies[0].center"), "[x, y, z]");
    assert!(err.message.contains("2 elements"), "{err}");
}

#[test]
fn unknown_option_suggests_the_closest() {
    let err = error(&format!("{HEAD}{SPHERE}").replace("\"sphere\"", "\"sphear\""));
    check(
        &err,
        10,
        9,
        Some("bodies[0].shape"),
        "did you mean \"sphere\"?",
    );
    assert!(err.hint.contains("\"cylinder\""), "{err}");
}

#[test]
fn cell_size_must_be_positive() {
    for (value, column) in [("-0.1", 13), ("0", 13), ("0.0", 13)] {
        let err = error(&format!(
            "{}{SPHERE}",
            HEAD.replace("cell_size = 0.05", &format!("cell_size = {value}"))
        ));
        check(
            &err,
            5,
            column,
            Some("domain.cell_size"),
            "cell_size = 0.02",
        );
        assert!(err.message.contains("greater than 0"), "{err}");
    }
    let err = error(&format!(
        "{}{SPHERE}",
        HEAD.replace("cell_size = 0.05", "cell_size = -0.1")
    ));
    assert_eq!(
        err.to_string(),
        "error: scenes/bad.toml:5:13: domain.cell_size must be greater than 0 (got -0.1)\n  \
         fix: set cell_size to the grid spacing in metres, e.g. cell_size = 0.02"
    );
}

#[test]
fn grid_too_large_gives_the_cell_count() {
    let err = error(&format!(
        "{}{SPHERE}",
        HEAD.replace("cell_size = 0.05", "cell_size = 0.001")
    ));
    check(&err, 5, 13, Some("domain.cell_size"), "larger cell_size");
    assert!(err.message.contains("2000 cells along x"), "{err}");

    // 1000 cells per axis (10^9 in all) fit: the solver's grid is sparse,
    // so the total limit is the full 1024³ box.
    let text = format!(
        "{}{SPHERE}",
        HEAD.replace("cell_size = 0.05", "cell_size = 0.002")
    );
    assert!(Scene::from_toml_str(&text, "scenes/big.toml").is_ok());
}

#[test]
fn max_must_exceed_min() {
    let err = error(&format!(
        "{}{SPHERE}",
        HEAD.replace("max = [2.0, 2.0, 2.0]", "max = [2.0, 0.0, 2.0]")
    ));
    check(&err, 4, 7, Some("domain.max"), "max = [2.0, 2.0, 2.0]");
    assert!(err.message.contains("along y"), "{err}");
}

#[test]
fn poisson_ratio_of_one_half_or_more() {
    for value in ["0.5", "0.7"] {
        let err = error(&format!(
            "{HEAD}{SPHERE}material = \"stiff\"

[materials.stiff]
preset = \"icy\"
poisson_ratio = {value}
"
        ));
        check(
            &err,
            17,
            17,
            Some("materials.stiff.poisson_ratio"),
            "use a value like 0.3",
        );
        assert!(err.message.contains("less than 0.5"), "{err}");
        assert!(err.message.contains("infinite"), "{err}");
        assert!(err.message.contains("negative"), "{err}");
    }
}

#[test]
fn unused_materials_are_checked_too() {
    let err = error(&format!(
        "{HEAD}{SPHERE}
[materials.heavy]
density = -1.0
"
    ));
    check(
        &err,
        15,
        11,
        Some("materials.heavy.density"),
        "density = 400.0",
    );
}

#[test]
fn unknown_preset() {
    let err = error(&format!(
        "{HEAD}{SPHERE}
[materials.heavy]
preset = \"wett\"
"
    ));
    check(
        &err,
        15,
        10,
        Some("materials.heavy.preset"),
        "did you mean \"wet\"?",
    );
    assert!(
        err.hint.contains("snow, thesis, powder, wet, icy, slush"),
        "{err}"
    );
}

#[test]
fn body_outside_the_domain_names_body_and_axis() {
    let err = error(&format!(
        "{HEAD}{SPHERE}
[[bodies]]
shape = \"box\"
center = [1.0, 1.9, 1.0]
size = [0.4, 0.4, 0.4]
"
    ));
    check(
        &err,
        16,
        10,
        Some("bodies[1].center"),
        "inside domain.min .. domain.max",
    );
    assert!(
        err.message
            .starts_with("bodies[1] (box) sticks out of the domain along y"),
        "{err}"
    );
    assert!(err.message.contains("1.7 .. 2.1"), "{err}");
}

#[test]
fn scene_without_bodies_has_no_snow() {
    let err = error(HEAD);
    check(&err, 1, 1, Some("bodies"), "add a [[bodies]] table");
    assert!(err.message.contains("no snow"), "{err}");

    let err = error(&HEAD.replace("format = 1\n", "format = 1\nbodies = []\n"));
    check(&err, 2, 10, Some("bodies"), "add a [[bodies]] table");

    // Written after a table header, `bodies` belongs to that table.
    let err = error(&format!("{HEAD}bodies = []\n"));
    check(&err, 9, 1, Some("time.bodies"), "top-level key");
}

#[test]
fn body_too_small_for_any_particle() {
    let err = error(&format!(
        "{HEAD}{SPHERE}
[[bodies]]
shape = \"sphere\"
center = [0.5, 0.5, 0.5]
radius = 0.001
"
    ));
    check(&err, 14, 1, Some("bodies[1]"), "raise particles_per_cell");
    assert!(err.message.contains("gets no particles"), "{err}");
    assert!(err.message.contains("0.025 m"), "{err}");
}

#[test]
fn unknown_material_lists_known_names() {
    let err = error(&format!("{HEAD}{SPHERE}material = \"slushy\"\n"));
    check(
        &err,
        13,
        12,
        Some("bodies[0].material"),
        "did you mean \"slush\"?",
    );
    assert!(
        err.hint
            .contains("known materials: snow, thesis, powder, wet, icy, slush"),
        "{err}"
    );
    assert!(err.message.contains("\"slushy\""), "{err}");
}

#[test]
fn declared_materials_are_known_names() {
    let err = error(&format!(
        "{HEAD}{SPHERE}material = \"dusty\"

[materials.dust]
preset = \"powder\"
"
    ));
    check(
        &err,
        13,
        12,
        Some("bodies[0].material"),
        "did you mean \"dust\"?",
    );
    assert!(err.hint.contains("slush, dust"), "{err}");
}

#[test]
fn unknown_format_version() {
    let err = error(&format!(
        "{}{SPHERE}",
        HEAD.replace("format = 1", "format = 2")
    ));
    check(&err, 1, 10, Some("format"), "format = 1");
    assert!(err.message.starts_with("this firn reads format 1"), "{err}");

    // Checked before the keys: a newer file gets the version message.
    let err = error(&format!(
        "{}{SPHERE}snowiness = 3\n",
        HEAD.replace("format = 1", "format = 3")
    ));
    check(&err, 1, 10, Some("format"), "format = 1");

    let err = error(&format!(
        "{}{SPHERE}",
        HEAD.replace("format = 1", "format = \"1\"")
    ));
    check(&err, 1, 10, Some("format"), "format = 1");
}

#[test]
fn missing_format() {
    let err = error(&format!(
        "{}{SPHERE}",
        HEAD.replace("format = 1\n", "# no format\n")
    ));
    check(&err, 1, 1, Some("format"), "add `format = 1`");
}

#[test]
fn fixed_step_without_dt() {
    let err = error(&format!(
        "{}{SPHERE}",
        HEAD.replace("duration = 1.0\n", "duration = 1.0\nstep = \"fixed\"\n")
    ));
    check(&err, 9, 8, Some("time.dt"), "dt = 0.001");
    assert!(err.message.contains("\"fixed\""), "{err}");
}

#[test]
fn cfl_with_a_fixed_step() {
    let err = error(&format!(
        "{}{SPHERE}",
        HEAD.replace(
            "duration = 1.0\n",
            "duration = 1.0\nstep = \"fixed\"\ndt = 0.001\ncfl = 0.5\n"
        )
    ));
    check(&err, 11, 7, Some("time.cfl"), "remove cfl");
}

#[test]
fn dt_longer_than_a_frame() {
    let err = error(&format!(
        "{}{SPHERE}",
        HEAD.replace("duration = 1.0\n", "duration = 1.0\nfps = 100\ndt = 0.05\n")
    ));
    check(&err, 10, 6, Some("time.dt"), "dt = 0.001 or less");
}

const PLANE: &str = "
[[colliders]]
shape = \"plane\"
point = [0.0, 0.2, 0.0]
normal = [0.0, 1.0, 0.0]
";

#[test]
fn collider_with_velocity_and_keyframes() {
    let err = error(&format!(
        "{HEAD}{SPHERE}{PLANE}velocity = [0.0, 1.0, 0.0]
keyframes = [
  {{ time = 0.0, position = [0.0, 0.2, 0.0] }},
  {{ time = 1.0, position = [0.0, 0.5, 0.0] }},
]
"
    ));
    check(
        &err,
        19,
        13,
        Some("colliders[0].keyframes"),
        "remove one of the two",
    );
    assert!(err.message.contains("both velocity and keyframes"), "{err}");
}

#[test]
fn keyframes_must_increase() {
    let err = error(&format!(
        "{HEAD}{SPHERE}{PLANE}keyframes = [
  {{ time = 0.0, position = [0.0, 0.2, 0.0] }},
  {{ time = 1.0, position = [0.0, 0.5, 0.0] }},
  {{ time = 1.0, position = [0.0, 0.2, 0.0] }},
]
"
    ));
    check(
        &err,
        21,
        12,
        Some("colliders[0].keyframes[2].time"),
        "strictly increasing",
    );
    assert!(err.message.contains("(1 <= 1)"), "{err}");
}

#[test]
fn keyframes_need_two_keys() {
    let err = error(&format!(
        "{HEAD}{SPHERE}{PLANE}keyframes = [{{ time = 0.0, position = [0.0, 0.2, 0.0] }}]\n"
    ));
    check(
        &err,
        18,
        13,
        Some("colliders[0].keyframes"),
        "at least a start and an end",
    );
}

#[test]
fn zero_normal() {
    let err = error(
        &format!("{HEAD}{SPHERE}{PLANE}")
            .replace("normal = [0.0, 1.0, 0.0]", "normal = [0.0, 0.0, 0.0]"),
    );
    check(
        &err,
        17,
        10,
        Some("colliders[0].normal"),
        "normal = [0.0, 1.0, 0.0]",
    );
    assert!(err.message.contains("zero vector"), "{err}");
}

#[test]
fn key_that_does_not_fit_the_shape() {
    let err = error(&format!("{HEAD}{SPHERE}size = [0.1, 0.1, 0.1]\n"));
    check(
        &err,
        13,
        8,
        Some("bodies[0].size"),
        "a sphere takes center and radius",
    );
}

#[test]
fn missing_required_key_points_at_its_table() {
    let err = error(&format!(
        "{HEAD}[[bodies]]\nshape = \"box\"\ncenter = [1.0, 1.0, 1.0]\n"
    ));
    check(&err, 9, 1, Some("bodies[0].size"), "size = [0.2, 0.2, 0.2]");
    assert_eq!(err.message, "bodies[0] needs `size`");

    let err = error(&format!(
        "{}{SPHERE}",
        HEAD.replace("cell_size = 0.05\n", "")
    ));
    check(&err, 3, 1, Some("domain.cell_size"), "cell_size = 0.02");
}

#[test]
fn particles_per_cell_range() {
    let err = error(&format!("{HEAD}{SPHERE}particles_per_cell = 100\n"));
    check(
        &err,
        13,
        22,
        Some("bodies[0].particles_per_cell"),
        "particles_per_cell = 8",
    );
    assert!(err.message.contains("between 1 and 64"), "{err}");

    let err = error(&format!("{HEAD}{SPHERE}particles_per_cell = -1\n"));
    check(
        &err,
        13,
        22,
        Some("bodies[0].particles_per_cell"),
        "particles_per_cell = 8",
    );
}

#[test]
fn numbers_too_large_for_f32_are_too_large() {
    // 1e300 used to become an infinite f32, refused as too small.
    let err = error(&format!("{HEAD}{SPHERE}clumps = {{ size = 1e300 }}\n"));
    check(
        &err,
        13,
        19,
        Some("bodies[0].clumps.size"),
        "smaller number",
    );
    assert_eq!(
        err.message,
        "bodies[0].clumps.size is too large (got 1e300): it is kept as a 32-bit float, at \
         most 3.40282e38 in size"
    );
    // Vector elements and negative numbers alike.
    let err = error(&format!("{HEAD}{SPHERE}velocity = [0.0, -1e39, 0.0]\n"));
    check(
        &err,
        13,
        18,
        Some("bodies[0].velocity[1]"),
        "smaller number",
    );
    // The keys kept as f64 keep their own rules.
    let err = error(&format!(
        "{}{SPHERE}",
        HEAD.replace("duration = 1.0", "duration = 1e300")
    ));
    check(&err, 8, 12, Some("time.duration"), "at this frame rate");
}

#[test]
fn infinite_values_are_not_called_too_small() {
    let err = error(&format!("{HEAD}{SPHERE}clumps = {{ size = inf }}\n"));
    assert_eq!(
        err.message,
        "bodies[0].clumps.size must be a finite number, at least domain.cell_size (got inf)"
    );
    let err = error(&format!(
        "{}{SPHERE}",
        HEAD.replace("duration = 1.0", "duration = inf")
    ));
    assert_eq!(
        err.message,
        "time.duration must be a finite number greater than 0 (got inf)"
    );
    let err = error(&format!(
        "{HEAD}{SPHERE}material = \"stiff\"\n[materials.stiff]\npoisson_ratio = inf\n"
    ));
    assert!(err.message.contains("less than 0.5 (got inf)"), "{err}");
}

#[test]
fn duplicate_output_attribute() {
    let err = error(&format!(
        "{HEAD}{SPHERE}\n[output]\nattributes = [\"mass\", \"density\", \"mass\"]\n"
    ));
    check(
        &err,
        15,
        34,
        Some("output.attributes[2]"),
        "list each attribute once",
    );
}

#[test]
fn vdb_voxel_size_must_be_positive() {
    let err = error(&format!(
        "{HEAD}{SPHERE}\n[output]\nformats = [\"vdb\"]\nvdb = {{ voxel_size = -0.01 }}\n"
    ));
    check(
        &err,
        16,
        22,
        Some("output.vdb.voxel_size"),
        "voxel_size = 0.05",
    );
}

#[test]
fn vdb_voxels_finer_than_a_quarter_cell_are_refused() {
    let err = error(&format!(
        "{HEAD}{SPHERE}\n[output.vdb]\nvoxel_size = 0.01\nlevel_set = true\n"
    ));
    check(&err, 15, 14, Some("output.vdb.voxel_size"), "cell_size");
    assert!(
        err.message.contains("a quarter of domain.cell_size"),
        "{err}"
    );
}

#[test]
fn unknown_vdb_key_is_located() {
    let err = error(&format!("{HEAD}{SPHERE}\n[output.vdb]\nlevelset = true\n"));
    assert_eq!(err.line, Some(15), "{err}");
    assert!(err.message.contains("levelset"), "{err}");
}

#[test]
fn mesh_iso_must_be_a_share_of_the_rest_density() {
    let err = error(&format!(
        "{HEAD}{SPHERE}\n[output]\nformats = [\"mesh\"]\nmesh = {{ iso = 1.5 }}\n"
    ));
    check(&err, 16, 16, Some("output.mesh.iso"), "iso = 0.5");
    assert!(err.message.contains("between 0 and 1"), "{err}");
}

#[test]
fn mesh_smoothing_and_voxels_are_bounded() {
    let err = error(&format!("{HEAD}{SPHERE}\n[output.mesh]\nsmoothing = 40\n"));
    check(&err, 15, 13, Some("output.mesh.smoothing"), "smoothing = 1");
    let err = error(&format!(
        "{HEAD}{SPHERE}\n[output.mesh]\nvoxel_size = 0.0\n"
    ));
    check(&err, 15, 14, Some("output.mesh.voxel_size"), "cell_size");
    let err = error(&format!("{HEAD}{SPHERE}\n[output.mesh]\nisovalue = 0.5\n"));
    assert_eq!(err.line, Some(15), "{err}");
    assert!(err.message.contains("isovalue"), "{err}");
}

#[test]
fn syntax_error() {
    let err = error("format = 1\n[domain\nmax = [1.0, 1.0, 1.0]\n");
    check(&err, 2, 8, None, "TOML syntax");
    assert!(err.message.starts_with("invalid TOML"), "{err}");
}

#[test]
fn columns_count_characters() {
    // A value after a multi-byte character is placed by characters, not bytes.
    let err = error(&format!(
        "{HEAD}{SPHERE}material = \"é\"\n\n[materials]\n\"é\" = {{ density = 0.0 }}\n"
    ));
    check(
        &err,
        16,
        19,
        Some("materials.\"é\".density"),
        "density = 400.0",
    );
}

#[test]
fn unreadable_file() {
    let path = Path::new("/nonexistent/firn/scene.toml");
    let err = Scene::load(path).unwrap_err();
    assert_eq!(err.file, "/nonexistent/firn/scene.toml");
    assert_eq!(
        (err.line, err.column, err.key.as_deref()),
        (None, None, None)
    );
    assert_eq!(err.hint, "check the path");
    let shown = err.to_string();
    assert!(
        shown.starts_with("error: cannot read scene file '/nonexistent/firn/scene.toml': "),
        "{shown}"
    );
    assert!(shown.ends_with("\n  fix: check the path"), "{shown}");
}

#[test]
fn implicit_solver_keys_need_the_semi_implicit_integrator() {
    let err = error(&format!(
        "{HEAD}{SPHERE}\n[solver]\nsolver_tolerance = 1e-4\n"
    ));
    check(
        &err,
        15,
        20,
        Some("solver.solver_tolerance"),
        "integrator = \"semi-implicit\"",
    );
}

#[test]
fn implicit_beta_range() {
    let err = error(&format!(
        "{HEAD}{SPHERE}\n[solver]\nintegrator = \"semi-implicit\"\nimplicit_beta = 1.5\n"
    ));
    check(
        &err,
        16,
        17,
        Some("solver.implicit_beta"),
        "implicit_beta = 0.5",
    );
    assert!(err.message.contains("in [0, 1] (got 1.5)"), "{err}");
}

#[test]
fn misspelled_integrator() {
    let err = error(&format!(
        "{HEAD}{SPHERE}\n[solver]\nintegrator = \"semi_implicit\"\n"
    ));
    check(
        &err,
        15,
        14,
        Some("solver.integrator"),
        "did you mean \"semi-implicit\"?",
    );
}

#[test]
fn unknown_backend_lists_the_backends() {
    let err = error(&format!("{HEAD}{SPHERE}\n[compute]\nbackend = \"bogus\"\n"));
    check(
        &err,
        15,
        11,
        Some("compute.backend"),
        "compute.backend takes one of \"auto\", \"cpu\", \"gpu\"",
    );
    assert_eq!(err.message, "compute.backend has no option \"bogus\"");
    let typo = error(&format!("{HEAD}{SPHERE}\n[compute]\nbackend = \"gpuu\"\n"));
    assert!(typo.hint.starts_with("did you mean \"gpu\"?"), "{typo}");
}

#[test]
fn unknown_compute_key_suggests_backend() {
    let err = error(&format!("{HEAD}{SPHERE}\n[compute]\nbakend = \"gpu\"\n"));
    check(
        &err,
        15,
        1,
        Some("compute.bakend"),
        "did you mean `backend`?",
    );
}

#[test]
fn a_misplaced_compute_table_name_is_explained() {
    let err = error(&format!("{HEAD}{SPHERE}\n[compte]\nbackend = \"gpu\"\n"));
    check(&err, 14, 2, Some("compte"), "did you mean `compute`?");
}

/// Work past the limits is refused where the scene asks for it: the body
/// whose lattice passes 2^30 points (at its particles_per_cell, or at the
/// body when the key is not written), the body too fast for the first step,
/// the duration that makes too many frames.
#[test]
fn work_past_the_limits_is_located() {
    let dense = HEAD.replace("cell_size = 0.05", "cell_size = 0.002")
        + "[[bodies]]\nshape = \"box\"\ncenter = [1.0, 1.0, 1.0]\nsize = [1.9, 1.9, 1.9]\n\
           particles_per_cell = 27\n";
    let err = error(&dense);
    check(
        &err,
        13,
        22,
        Some("bodies[0].particles_per_cell"),
        "lower particles_per_cell to 1 (now 27), use cell_size = 0.00",
    );
    assert!(
        err.message
            .contains("is filled from 23149125000 lattice points"),
        "{err}"
    );

    let unwritten = dense.replace("particles_per_cell = 27\n", "");
    let err = error(&unwritten);
    check(
        &err,
        9,
        1,
        Some("bodies[0].particles_per_cell"),
        "lower particles_per_cell to 1 (now 8)",
    );

    let fast = format!("{HEAD}{SPHERE}velocity = [0.0, 0.0, 3.0e8]\n");
    let err = error(&fast);
    check(
        &err,
        13,
        12,
        Some("bodies[0].velocity"),
        "give it at most 59980.3 m/s",
    );
    assert!(
        err.message.starts_with("bodies[0].velocity is 3e8 m/s"),
        "{err}"
    );

    let long = HEAD.replace("duration = 1.0", "duration = 1.0e6") + SPHERE;
    let err = error(&long);
    check(
        &err,
        8,
        12,
        Some("time.duration"),
        "simulate at most 3333.3 s",
    );
}
