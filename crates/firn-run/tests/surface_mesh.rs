//! The `mesh` format: a snow frame's surface as binary PLY and OBJ. The
//! mesh is closed and outward (every edge used once in each direction), it
//! encloses the snow's volume (mass over rest density), both files read
//! back as the same mesh, and a run writes the same bytes every time and on
//! any number of threads. A scene's rigid bodies are written beside it,
//! one OBJ a frame, each body at its pose.

mod common;

use std::path::Path;

use firn_core::Scene;
use firn_core::scene::CacheFormat;
use firn_io::PvdCollection;
use firn_mesh::{MeshDiagnostics, TriangleMesh, load_mesh};
use firn_run::caches::write_frame;
use firn_run::simulation::HostState;
use firn_run::surface::scene_surface;
use firn_run::{Placement, RunDirectory, Solver};

/// A ball of snow resting on the floor, cached as surface meshes only.
const SCENE: &str = r#"
format = 1
name = "mesh-ball"

[domain]
min = [0.0, 0.0, 0.0]
max = [1.0, 1.0, 1.0]
cell_size = 0.04

[time]
duration = 0.1
fps = 20

[materials.snow]
preset = "thesis"

[[bodies]]
shape = "sphere"
center = [0.5, 0.2, 0.5]
radius = 0.18
material = "snow"

[render]
enabled = false

[output]
formats = ["mesh"]
mesh = { voxel_size = 0.02, smoothing = 1, iso = 0.5 }
"#;

fn scene() -> Scene {
    Scene::from_toml_str(SCENE, "mesh-ball.toml").expect("the scene is valid")
}

/// Asserts every edge of `mesh` is used by exactly two triangles, once in
/// each direction: closed, manifold and consistently oriented.
fn assert_closed(mesh: &TriangleMesh, what: &str) {
    let diagnostics = MeshDiagnostics::of(mesh);
    let open = diagnostics.boundary_edges
        + diagnostics.non_manifold_edges
        + diagnostics.inconsistently_oriented_edges;
    assert_eq!(
        open, 0,
        "{what}: edges not shared once each way: {diagnostics:?}"
    );
}

/// The surface of `solver`'s snow now, and the volume its mass fills at
/// rest density.
fn surface_and_rest_volume(solver: &mut Solver) -> (TriangleMesh, f64) {
    let HostState::Snow(simulation) = solver.host().unwrap() else {
        panic!("a snow scene");
    };
    let particles = simulation.particles();
    let mass: f64 = particles.mass.iter().map(|&m| f64::from(m)).sum();
    let rest_density = f64::from(simulation.scene().materials[0].density);
    let mesh = scene_surface(simulation.scene(), &particles.position, &particles.mass);
    (mesh, mass / rest_density)
}

#[test]
fn the_surface_is_closed_outward_and_holds_the_snows_volume() {
    let mut solver = Solver::new(scene(), &Placement::Cpu).unwrap();
    for frame in 0..=2 {
        if frame > 0 {
            solver.advance_frame().unwrap();
        }
        let (mesh, rest_volume) = surface_and_rest_volume(&mut solver);
        assert!(
            mesh.triangles.len() > 1000,
            "{} triangles",
            mesh.triangles.len()
        );
        assert_closed(&mesh, &format!("frame {frame}"));
        let diagnostics = MeshDiagnostics::of(&mesh);
        assert_eq!(diagnostics.components, 1, "{diagnostics:?}");
        let volume = mesh.signed_volume();
        let error = volume / rest_volume - 1.0;
        eprintln!(
            "frame {frame}: {} triangles, volume {volume:.5} m3 vs mass/density {rest_volume:.5} \
             m3 ({:+.2}%)",
            mesh.triangles.len(),
            100.0 * error
        );
        assert!(error.abs() < 0.05, "frame {frame}: volume off by {error}");
    }
}

/// Writes frame 1 of the scene, simulated on `threads` threads, into a new
/// folder; returns the PLY and OBJ bytes and the paths they were read from.
fn frame_files(threads: usize) -> (Vec<Vec<u8>>, tempfile::TempDir) {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap();
    pool.install(|| {
        let scene = scene();
        let folder = tempfile::tempdir().unwrap();
        let run = RunDirectory::new(folder.path());
        run.create(&scene).unwrap();
        let mut solver = Solver::new(scene, &Placement::Cpu).unwrap();
        solver.advance_frame().unwrap();
        let files = write_frame(solver.host().unwrap(), 1, &run, &mut PvdCollection::new())
            .unwrap()
            .files;
        assert_eq!(
            files,
            [
                RunDirectory::cache_name(CacheFormat::Mesh, 1),
                RunDirectory::mesh_obj_name(1)
            ]
        );
        let bytes = files
            .iter()
            .map(|file| std::fs::read(run.path().join(file)).unwrap())
            .collect();
        (bytes, folder)
    })
}

#[test]
fn the_mesh_files_are_the_same_bytes_on_any_thread_count() {
    let (one, _) = frame_files(1);
    let (again, _) = frame_files(1);
    let (two, _) = frame_files(2);
    assert!(one[0].len() > 10_000 && one[1].len() > 10_000);
    assert!(one == again, "two runs wrote different meshes");
    assert!(one == two, "one and two threads wrote different meshes");
}

#[test]
fn ply_and_obj_read_back_as_the_written_mesh() {
    let (_, folder) = frame_files(2);
    let load = |name: String| load_mesh(&folder.path().join(name)).expect("the file parses");
    let ply = load(RunDirectory::cache_name(CacheFormat::Mesh, 1));
    let obj = load(RunDirectory::mesh_obj_name(1));
    let mut solver = Solver::new(scene(), &Placement::Cpu).unwrap();
    solver.advance_frame().unwrap();
    let (ours, _) = surface_and_rest_volume(&mut solver);
    assert_eq!(ply.mesh, ours);
    assert_eq!(obj.mesh, ours);
    let clean = MeshDiagnostics {
        components: 1,
        ..MeshDiagnostics::default()
    };
    assert_eq!(ply.diagnostics, clean);
    assert!(Path::new(&folder.path().join("mesh")).is_dir());
}

#[test]
fn a_surface_picture_shows_the_snow_where_the_points_picture_does() {
    let mut scene = scene();
    scene.render.styles = vec![
        firn_core::scene::RenderStyle::Points,
        firn_core::scene::RenderStyle::Surface,
    ];
    scene.render.size = [96, 64];
    scene.render.color_by = firn_core::scene::ColorBy::Uniform;
    let (folder, bare) = (tempfile::tempdir().unwrap(), tempfile::tempdir().unwrap());
    for path in [folder.path(), bare.path()] {
        RunDirectory::new(path)
            .create_image_folders(&scene)
            .unwrap();
    }
    let mut solver = Solver::new(scene.clone(), &Placement::Cpu).unwrap();
    let HostState::Snow(simulation) = solver.host().unwrap() else {
        panic!("a snow scene");
    };
    let particles = simulation.particles();
    let frame = firn_render::scene_view::FrameParticles {
        positions: &particles.position,
        masses: Some(&particles.mass),
        values: None,
        trails: None,
        surface: None,
        drift: None,
        rigid_bodies: &[],
    };
    let names = firn_run::pictures::render_frame(&scene, folder.path(), 0, 0.0, frame).unwrap();
    let empty = firn_render::scene_view::FrameParticles {
        positions: &[],
        masses: Some(&[]),
        values: None,
        trails: None,
        surface: None,
        drift: None,
        rigid_bodies: &[],
    };
    firn_run::pictures::render_frame(&scene, bare.path(), 0, 0.0, empty).unwrap();
    let covered = |name: &String| -> Vec<bool> {
        let drawn = image::open(folder.path().join(name)).unwrap().to_rgb8();
        let stage = image::open(bare.path().join(name)).unwrap().to_rgb8();
        drawn
            .pixels()
            .zip(stage.pixels())
            .map(|(a, b)| a != b)
            .collect()
    };
    let (points, surface) = (covered(&names[0]), covered(&names[1]));
    let both = points
        .iter()
        .zip(&surface)
        .filter(|(p, s)| **p && **s)
        .count();
    let either = points
        .iter()
        .zip(&surface)
        .filter(|(p, s)| **p || **s)
        .count();
    let overlap = both as f64 / either as f64;
    assert!(both > 100, "the snow covers {both} pixels in both pictures");
    assert!(overlap > 0.8, "points and surface overlap by {overlap:.3}");
}

#[test]
fn the_rigid_bodies_are_written_beside_the_surface_at_their_poses() {
    let mut scene = common::box_on_slab();
    scene.output.formats = vec![CacheFormat::Mesh];
    let size = match scene.rigid_bodies[0].geometry {
        firn_core::scene::ColliderGeometry::Box { size, .. } => size,
        _ => unreachable!("the body is a box"),
    };
    let folder = tempfile::tempdir().unwrap();
    let run = RunDirectory::new(folder.path());
    run.create(&scene).unwrap();
    let mut solver = Solver::new(scene, &Placement::Cpu).unwrap();
    solver.advance_frame().unwrap();
    let host = solver.host().unwrap();
    let files = write_frame(host, 1, &run, &mut PvdCollection::new())
        .unwrap()
        .files;
    let name = RunDirectory::bodies_obj_name(1);
    assert_eq!(name, "mesh/bodies_00001.obj");
    assert!(files.contains(&name), "{files:?}");
    let [pose] = host.body_poses()[..] else {
        panic!("one body")
    };
    let (position, rotation) = (
        glam::Vec3::from_array(pose.position),
        glam::Quat::from_array(pose.rotation),
    );
    assert!(position.y < 0.39, "the box has fallen: {pose:?}");
    let mesh = load_mesh(&run.path().join(&name)).unwrap().mesh;
    assert_closed(&mesh, "the box");
    assert_eq!(mesh.vertices.len(), 8);
    for vertex in &mesh.vertices {
        let local = rotation.inverse() * (*vertex - position);
        let corner = (local.abs() - 0.5 * size).abs().max_element();
        assert!(corner < 1e-5, "{vertex} is no corner of the posed box");
    }
}
