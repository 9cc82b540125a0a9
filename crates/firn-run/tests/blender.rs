//! A snow frame in Blender (Debian's `blender`, 3.4): the frame's VDB
//! imported as a volume object and its surface mesh (PLY) as a mesh,
//! rendered with Cycles by `scripts/blender/render_frame.py` from firn's
//! camera. The snow must cover the part of the picture that firn's own
//! `surface` picture covers. Skipped where `blender` is missing, unless
//! `FIRN_REQUIRE_BLENDER=1` (as `.ci/run` sets it).

use std::path::{Path, PathBuf};
use std::process::Command;

use firn_core::Scene;
use firn_core::scene::CacheFormat;
use firn_io::PvdCollection;
use firn_render::scene_view::scene_camera;
use firn_render::{ParticleLayer, Picture, RenderStyle, Stage, render};
use firn_run::caches::write_frame;
use firn_run::simulation::HostState;
use firn_run::surface::scene_surface;
use firn_run::{Placement, RunDirectory, Solver};
use glam::Vec3;

/// A ball of snow landing on the floor, seen from the front and above.
const SCENE: &str = r#"
format = 1
name = "blender-ball"

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
center = [0.45, 0.2, 0.5]
radius = 0.18
material = "snow"

[camera]
position = [0.75, 0.65, 1.5]
look_at = [0.45, 0.18, 0.5]
fov = 40

[render]
enabled = false

[output]
formats = ["vdb", "mesh"]
vdb = { voxel_size = 0.02 }
mesh = { voxel_size = 0.02 }
"#;

/// The picture's size: small, so Cycles renders it in a second or two.
const SIZE: [u32; 2] = [160, 120];

/// Whether `blender` runs; panics where it must (`FIRN_REQUIRE_BLENDER=1`)
/// and does not.
fn blender_available() -> bool {
    let runs = Command::new("blender")
        .arg("--version")
        .output()
        .is_ok_and(|output| output.status.success());
    if !runs && std::env::var("FIRN_REQUIRE_BLENDER").as_deref() == Ok("1") {
        panic!("FIRN_REQUIRE_BLENDER=1 but `blender --version` does not run");
    }
    if !runs {
        eprintln!("skipped: blender is not on PATH (apt-get install blender)");
    }
    runs
}

/// The script that imports and renders a frame.
fn script() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scripts/blender/render_frame.py")
}

/// Whether each pixel shows snow in firn's own `surface` picture of `mesh`
/// (on a bare stage: a pixel is snow where it differs from the empty one).
fn firn_coverage(scene: &Scene, time: f64, mesh: &firn_mesh::TriangleMesh) -> Vec<bool> {
    let picture = |surface| Picture {
        camera: scene_camera(scene, time, SIZE[0], SIZE[1]),
        style: RenderStyle::Surface,
        stage: Stage::default(),
        particles: ParticleLayer {
            positions: &[],
            masses: Vec::new().into(),
            coloring: firn_render::Coloring::Uniform(Vec3::ONE),
            radius: 0.01,
            look: firn_render::SnowLook::for_density(400.0, 0.01),
            trails: None,
            smooth_trails: false,
            surface,
        },
        legend: None,
        drift: None,
    };
    let empty = render(&picture(None));
    let snow = render(&picture(Some(mesh)));
    empty
        .pixels()
        .zip(snow.pixels())
        .map(|(bare, drawn)| bare != drawn)
        .collect()
}

#[test]
fn blender_renders_the_snow_where_firn_sees_it() {
    if !blender_available() {
        return;
    }
    let scene = Scene::from_toml_str(SCENE, "blender-ball.toml").expect("the scene is valid");
    let folder = tempfile::tempdir().unwrap();
    let run = RunDirectory::new(folder.path());
    run.create(&scene).unwrap();
    let mut solver = Solver::new(scene.clone(), &Placement::Cpu).unwrap();
    solver.advance_frame().unwrap();
    let files = write_frame(solver.host().unwrap(), 1, &run, &mut PvdCollection::new())
        .unwrap()
        .files;
    let HostState::Snow(simulation) = solver.host().unwrap() else {
        panic!("a snow scene");
    };
    let time = simulation.time();
    let particles = simulation.particles();
    let mesh = scene_surface(&scene, &particles.position, &particles.mass);

    let camera = scene_camera(&scene, time, SIZE[0], SIZE[1]);
    let look_at = camera.eye + camera.forward;
    let numbers = |v: Vec3| v.to_array().map(|c| c.to_string());
    let picture = folder.path().join("blender.png");
    let vdb = run
        .path()
        .join(RunDirectory::cache_name(CacheFormat::Vdb, 1));
    let ply = run
        .path()
        .join(RunDirectory::cache_name(CacheFormat::Mesh, 1));
    assert!(files.contains(&RunDirectory::cache_name(CacheFormat::Mesh, 1)));
    let started = std::time::Instant::now();
    let output = Command::new("blender")
        .args(["-b", "--factory-startup", "--python"])
        .arg(script())
        .arg("--")
        .arg("--vdb")
        .arg(&vdb)
        .arg("--mesh")
        .arg(&ply)
        .arg("--eye")
        .args(numbers(camera.eye))
        .arg("--look-at")
        .args(numbers(look_at))
        .args(["--fov", &scene.camera.fov_degrees.to_string()])
        .args(["--size", &SIZE[0].to_string(), &SIZE[1].to_string()])
        .args(["--samples", "8", "--out"])
        .arg(&picture)
        .output()
        .expect("blender runs");
    let log = String::from_utf8_lossy(&output.stdout);
    let said: Vec<&str> = log
        .lines()
        .filter(|line| line.starts_with("firn:"))
        .collect();
    eprintln!(
        "blender took {:.1} s: {said:#?}",
        started.elapsed().as_secs_f64()
    );
    assert!(
        output.status.success() && picture.exists(),
        "blender failed:\n{log}\n{}",
        String::from_utf8_lossy(&output.stderr)
    );
    assert!(
        said.iter().any(|line| line.contains("grids ['density']")),
        "the VDB's density grid did not load: {said:?}"
    );
    let faces = format!("faces {}", mesh.triangles.len());
    assert!(
        said.iter().any(|line| line.contains(&faces)),
        "the mesh did not load with its {} triangles: {said:?}",
        mesh.triangles.len()
    );

    let image = image::open(&picture).expect("a PNG").to_rgba8();
    assert_eq!(image.dimensions(), (SIZE[0], SIZE[1]));
    // The surface is opaque; the volume's haze where the snow thins out
    // past it lets some of the (transparent) background through.
    let blender: Vec<bool> = image.pixels().map(|pixel| pixel.0[3] > 250).collect();
    let firn = firn_coverage(&scene, time, &mesh);
    let both = blender
        .iter()
        .zip(&firn)
        .filter(|(b, f)| **b && **f)
        .count();
    let either = blender
        .iter()
        .zip(&firn)
        .filter(|(b, f)| **b || **f)
        .count();
    let overlap = both as f64 / either as f64;
    let counts = (
        blender.iter().filter(|b| **b).count(),
        firn.iter().filter(|f| **f).count(),
    );
    eprintln!(
        "snow pixels: blender {}, firn {}; overlap {overlap:.3}",
        counts.0, counts.1
    );
    assert!(
        counts.1 > 1500,
        "firn's snow covers only {} pixels",
        counts.1
    );
    assert!(
        overlap > 0.93,
        "Blender's snow ({} pixels) and firn's ({} pixels) overlap by {overlap:.3} only",
        counts.0,
        counts.1
    );
}
