//! A run's `usd` stage opened by Pixar's USD (`usd-core` from PyPI, the
//! `pxr` module): the prim type, time codes and rate, and several frames'
//! points against the run's PLY caches, a turning wheel's transform against
//! its pose, a deforming mesh collider's bounds at three frames; and a
//! resumed run's stage against an uninterrupted one's. The python is
//! `FIRN_USD_PYTHON`, else `python3`; the pxr tests are skipped where `pxr`
//! is missing, unless `FIRN_REQUIRE_USD=1` (as `.ci/run` sets it).

mod common;

use std::path::Path;
use std::process::Command;

use firn_core::Scene;
use firn_core::scene::CacheFormat;
use firn_io::{PlyValues, read_ply};
use firn_run::recording::Observer;
use firn_run::{Placement, Recording, RunDirectory, Solver};

/// A slab of snow falling past a moving ball and a turning wheel onto a
/// floor plane: 5 frames.
const SCENE: &str = r#"
format = 1
name = "usd-slab"

[domain]
max = [1.0, 1.0, 1.0]
cell_size = 0.1

[time]
duration = 0.2
fps = 20

[[bodies]]
shape = "box"
center = [0.5, 0.4, 0.5]
size = [0.3, 0.2, 0.3]
velocity = [0.0, -1.0, 0.0]

[[colliders]]
shape = "plane"
point = [0.0, 0.1, 0.0]
normal = [0.0, 1.0, 0.0]

[[colliders]]
shape = "sphere"
center = [0.2, 0.7, 0.2]
radius = 0.1
velocity = [1.0, 0.0, 0.0]

[[colliders]]
shape = "cylinder"
center = [0.8, 0.8, 0.8]
radius = 0.1
height = 0.1
rotation = [90.0, 0.0, 0.0]
velocity = [-0.5, 0.0, 0.0]
angular_velocity = [0.0, 0.0, 4.0]

[render]
enabled = false

[output]
formats = ["ply", "usd"]
attributes = ["velocity", "plastic-j", "density"]
checkpoint_every = 1
"#;

/// Opens the stage `sys.argv[1]`; prints the prim type, the time codes and
/// rate, the primvars, the points' sample times; the ball's transform ops
/// and translate at 2; the wheel's transform ops and its local-to-world
/// matrix at 2 (row by row); then per frame of `sys.argv[2:]` its index,
/// point count and points.
const READ: &str = "
import sys
from pxr import Usd, UsdGeom
stage = Usd.Stage.Open(sys.argv[1])
prim = stage.GetPrimAtPath('/World/Snow')
points = UsdGeom.Points(prim)
names = sorted(p.GetPrimvarName() for p in UsdGeom.PrimvarsAPI(prim).GetAuthoredPrimvars())
print(prim.GetTypeName(), stage.GetStartTimeCode(), stage.GetEndTimeCode(),
      stage.GetTimeCodesPerSecond(), UsdGeom.GetStageUpAxis(stage),
      UsdGeom.GetStageMetersPerUnit(stage), ','.join(names),
      *points.GetPointsAttr().GetTimeSamples())
ball = UsdGeom.Xformable(stage.GetPrimAtPath('/World/Collider1'))
ops = ','.join(op.GetOpName() for op in ball.GetOrderedXformOps())
print(ball.GetPrim().GetTypeName(), ops, *ball.ComputeLocalToWorldTransform(2).ExtractTranslation())
wheel = UsdGeom.Xformable(stage.GetPrimAtPath('/World/Collider2'))
ops = ','.join(op.GetOpName() for op in wheel.GetOrderedXformOps())
matrix = wheel.ComputeLocalToWorldTransform(2)
print(wheel.GetPrim().GetTypeName(), ops, *(matrix[i][j] for i in range(4) for j in range(4)))
for frame in sys.argv[2:]:
    t = float(frame)
    xyz = [repr(c) for p in points.GetPointsAttr().Get(t) for c in p]
    velocities = len(points.GetVelocitiesAttr().Get(t))
    print(frame, len(xyz) // 3, velocities, *xyz)
";

/// The frames compared with the PLY caches.
const FRAMES: [u32; 3] = [0, 2, 4];

/// The python to run `pxr` with.
fn python() -> String {
    std::env::var("FIRN_USD_PYTHON").unwrap_or_else(|_| "python3".to_string())
}

/// Whether `pxr` imports; panics where it must and does not.
fn usd_available() -> bool {
    let imports = Command::new(python())
        .args(["-c", "from pxr import Usd"])
        .output()
        .is_ok_and(|output| output.status.success());
    if !imports && std::env::var("FIRN_REQUIRE_USD").as_deref() == Ok("1") {
        panic!("FIRN_REQUIRE_USD=1 but {} cannot import pxr", python());
    }
    if !imports {
        eprintln!(
            "skipped: {} cannot import pxr (pip install usd-core)",
            python()
        );
    }
    imports
}

/// An observer that draws nothing and never stops the run.
struct Quiet;

impl Observer for Quiet {}

/// Records `scene` into `path` up to frame `last`.
fn record(scene: &Scene, path: &Path, last: u32) {
    let run = RunDirectory::new(path);
    run.create(scene).unwrap();
    let solver = Solver::new(scene.clone(), &Placement::Cpu).unwrap();
    let mut recording = Recording::start(solver, run, None, &mut Quiet).unwrap();
    recording.run_to(last, &mut Quiet).unwrap();
}

/// The positions of a PLY cache as x, y, z in a row.
fn ply_positions(path: &Path) -> Vec<f32> {
    let cloud = read_ply(path).unwrap();
    let column = |name| match cloud.column(name) {
        Some(PlyValues::Float(values)) => values.clone(),
        _ => panic!("{name} missing from {}", path.display()),
    };
    let (x, y, z) = (column("x"), column("y"), column("z"));
    (0..x.len()).flat_map(|i| [x[i], y[i], z[i]]).collect()
}

fn scene() -> Scene {
    Scene::from_toml_str(SCENE, "usd-slab.toml").expect("the scene is valid")
}

#[test]
fn pixar_usd_reads_the_frames_of_the_ply_caches() {
    if !usd_available() {
        return;
    }
    let scene = scene();
    let last = scene.time.frame_count();
    assert_eq!(last, 4);
    let folder = tempfile::tempdir().unwrap();
    record(&scene, folder.path(), last);
    let output = Command::new(python())
        .args(["-c", READ])
        .arg(folder.path().join("particles.usda"))
        .args(FRAMES.map(|frame| frame.to_string()))
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(output.status.success(), "pxr failed:\n{stderr}");
    assert!(stderr.is_empty(), "pxr warned:\n{stderr}");
    let text = String::from_utf8(output.stdout).unwrap();
    let lines: Vec<&str> = text.lines().collect();
    assert_eq!(
        lines[0],
        "Points 0.0 4.0 20.0 Y 1.0 density,plastic_j 0.0 1.0 2.0 3.0 4.0"
    );
    assert_eq!(
        lines[1], "Sphere xformOp:translate 0.3 0.7 0.2",
        "the ball at frame 2 (0.1 s), unturned"
    );
    the_wheel_is_posed_as_at(&scene, lines[2], 0.1);
    for (line, frame) in lines[3..].iter().zip(FRAMES) {
        let fields: Vec<&str> = line.split(' ').collect();
        let ply = ply_positions(&folder.path().join(format!("ply/frame_{frame:05}.ply")));
        assert_eq!(fields[0], frame.to_string());
        assert_eq!(
            fields[1].parse::<usize>().unwrap() * 3,
            ply.len(),
            "frame {frame}"
        );
        assert_eq!(fields[2], fields[1], "velocities at frame {frame}");
        let usd: Vec<f32> = fields[3..].iter().map(|f| f.parse().unwrap()).collect();
        assert!(
            usd == ply,
            "frame {frame}: pxr's points differ from the PLY's"
        );
        eprintln!(
            "frame {frame}: pxr read {} points equal to the PLY's",
            fields[1]
        );
    }
    assert_eq!(lines.len(), 3 + FRAMES.len());
}

/// Checks pxr's line for the wheel (the third collider): its prim type,
/// transform ops, and a local-to-world matrix that is the wheel's pose at
/// `time` (translate after orient; USD's rows are glam's columns).
fn the_wheel_is_posed_as_at(scene: &Scene, line: &str, time: f64) {
    let fields: Vec<&str> = line.split(' ').collect();
    assert_eq!(
        fields[..2],
        ["Cylinder", "xformOp:translate,xformOp:orient"]
    );
    let pose = scene.colliders[2].pose_at(time);
    let expected = glam::Mat4::from_rotation_translation(pose.rotation, pose.position);
    let matrix: Vec<f32> = fields[2..].iter().map(|f| f.parse().unwrap()).collect();
    assert_eq!(matrix.len(), 16, "{line}");
    for (got, want) in matrix.iter().zip(expected.to_cols_array()) {
        assert!(
            (got - want).abs() < 1e-6,
            "pxr's wheel transform {matrix:?}, its pose {expected:?}"
        );
    }
    eprintln!("pxr turned the wheel as its pose at {time} s: {matrix:?}");
}

#[test]
fn a_resumed_run_writes_the_same_stage_as_an_uninterrupted_one() {
    let scene = scene();
    let last = scene.time.frame_count();
    let (whole, parts) = (tempfile::tempdir().unwrap(), tempfile::tempdir().unwrap());
    record(&scene, whole.path(), last);
    record(&scene, parts.path(), 2);
    let mut resumed =
        Recording::resume(scene, RunDirectory::new(parts.path()), &Placement::Cpu).unwrap();
    assert_eq!(resumed.frame(), 2);
    resumed.run_to(last, &mut Quiet).unwrap();
    let mut files = vec![
        "particles.usda".to_string(),
        "usd/manifest.usda".to_string(),
    ];
    files.extend((0..=last).map(|frame| format!("usd/frame.{frame:05}.usda")));
    for file in files {
        let read = |folder: &Path| std::fs::read(folder.join(&file)).unwrap();
        assert!(read(whole.path()) == read(parts.path()), "{file} differs");
    }
}

/// A unit cube as OBJ quads (the mesh collider's file).
const CUBE_OBJ: &str = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nv 1 0 1\nv 1 1 1\nv 0 1 1\n\
     f 1 4 3 2\nf 5 6 7 8\nf 1 2 6 5\nf 4 8 7 3\nf 1 5 8 4\nf 2 3 7 6\n";

/// Snow falling onto a moving mesh collider (the cube above, scaled).
const MESH_SCENE: &str = r#"
format = 1
name = "usd-mesh-collider"

[domain]
max = [1.0, 1.0, 1.0]
cell_size = 0.1

[time]
duration = 0.1
fps = 20

[[bodies]]
shape = "box"
center = [0.5, 0.6, 0.5]
size = [0.3, 0.2, 0.3]

[[colliders]]
shape = "mesh"
mesh = "cube.obj"
scale = [0.4, 0.2, 0.3]
center = [0.4, 0.2, 0.5]
velocity = [1.0, 0.0, 0.0]

[render]
enabled = false

[output]
formats = ["usd"]
"#;

/// Prints the mesh collider's prim type, point and face counts, and its
/// world bounds at time code 2.
const READ_MESH: &str = "
import sys
from pxr import Usd, UsdGeom
stage = Usd.Stage.Open(sys.argv[1])
prim = stage.GetPrimAtPath('/World/Collider0')
mesh = UsdGeom.Mesh(prim)
bounds = UsdGeom.BBoxCache(2, ['default']).ComputeWorldBound(prim).ComputeAlignedRange()
print(prim.GetTypeName(), len(mesh.GetPointsAttr().Get()), list(mesh.GetFaceVertexCountsAttr().Get()).count(3),
      *bounds.GetMin(), *bounds.GetMax())
";

#[test]
fn pixar_usd_reads_a_mesh_collider_as_a_moving_mesh() {
    if !usd_available() {
        return;
    }
    let folder = tempfile::tempdir().unwrap();
    std::fs::write(folder.path().join("cube.obj"), CUBE_OBJ).unwrap();
    let scene_file = folder.path().join("scene.toml").display().to_string();
    let scene = Scene::from_toml_str(MESH_SCENE, &scene_file).expect("the scene is valid");
    let run = folder.path().join("run");
    record(&scene, &run, scene.time.frame_count());
    let output = Command::new(python())
        .args(["-c", READ_MESH])
        .arg(run.join("particles.usda"))
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(output.status.success(), "pxr failed:\n{stderr}");
    let text = String::from_utf8(output.stdout).unwrap();
    let fields: Vec<&str> = text.split_whitespace().collect();
    assert_eq!(fields[..3], ["Mesh", "8", "12"], "{text}");
    let bounds: Vec<f32> = fields[3..].iter().map(|f| f.parse().unwrap()).collect();
    // At frame 2 (0.1 s) the cube has moved 0.1 m along x.
    let expected = [0.3, 0.1, 0.35, 0.7, 0.3, 0.65];
    for (got, want) in bounds.iter().zip(expected) {
        assert!(
            (got - want).abs() < 1e-5,
            "bounds {bounds:?}, expected {expected:?}"
        );
    }
}

/// The unit cube of [`CUBE_OBJ`] with its top raised to y = 2: the second
/// file of a deforming sequence (same vertices and faces).
const TALL_CUBE_OBJ: &str = "v 0 0 0\nv 1 0 0\nv 1 2 0\nv 0 2 0\nv 0 0 1\nv 1 0 1\nv 1 2 1\nv 0 2 1\n\
     f 1 4 3 2\nf 5 6 7 8\nf 1 2 6 5\nf 4 8 7 3\nf 1 5 8 4\nf 2 3 7 6\n";

/// Snow over a deforming mesh collider: the cube, scaled to 0.2 m, whose
/// top rises 0.2 m between its two files (0 s and 0.1 s).
const SEQUENCE_SCENE: &str = r#"
format = 1
name = "usd-deforming-collider"

[domain]
max = [1.0, 1.0, 1.0]
cell_size = 0.1

[time]
duration = 0.1
fps = 20

[[bodies]]
shape = "box"
center = [0.5, 0.7, 0.5]
size = [0.3, 0.2, 0.3]

[[colliders]]
shape = "mesh"
sequence = "cube_####.obj"
frame_rate = 10
scale = 0.2
center = [0.4, 0.2, 0.5]

[render]
enabled = false

[output]
formats = ["usd"]
"#;

/// Prints the deforming collider's points' sample times, then per time
/// code of `sys.argv[2:]` its world bounds.
const READ_SEQUENCE: &str = "
import sys
from pxr import Usd, UsdGeom
stage = Usd.Stage.Open(sys.argv[1])
prim = stage.GetPrimAtPath('/World/Collider0')
print(prim.GetTypeName(), *UsdGeom.Mesh(prim).GetPointsAttr().GetTimeSamples())
for code in sys.argv[2:]:
    bounds = UsdGeom.BBoxCache(float(code), ['default']).ComputeWorldBound(prim).ComputeAlignedRange()
    print(*bounds.GetMin(), *bounds.GetMax())
";

#[test]
fn pixar_usd_reads_a_deforming_collider_as_each_frame_shapes_it() {
    if !usd_available() {
        return;
    }
    let folder = tempfile::tempdir().unwrap();
    std::fs::write(folder.path().join("cube_0001.obj"), CUBE_OBJ).unwrap();
    std::fs::write(folder.path().join("cube_0002.obj"), TALL_CUBE_OBJ).unwrap();
    let scene_file = folder.path().join("scene.toml").display().to_string();
    let scene = Scene::from_toml_str(SEQUENCE_SCENE, &scene_file).expect("the scene is valid");
    let run = folder.path().join("run");
    record(&scene, &run, scene.time.frame_count());
    let output = Command::new(python())
        .args([
            "-c",
            READ_SEQUENCE,
            &run.join("particles.usda").display().to_string(),
        ])
        .args(["0", "1", "2"])
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(output.status.success(), "pxr failed:\n{stderr}");
    assert!(stderr.is_empty(), "pxr warned:\n{stderr}");
    let text = String::from_utf8(output.stdout).unwrap();
    let lines: Vec<&str> = text.lines().collect();
    assert_eq!(lines[0], "Mesh 0.0 1.0 2.0", "{text}");
    // The top is at 0.3 m in the first file, 0.5 m in the second (frame 2,
    // 0.1 s), and halfway between them at frame 1.
    for (line, top) in lines[1..].iter().zip([0.3, 0.4, 0.5]) {
        let bounds: Vec<f32> = line.split(' ').map(|f| f.parse().unwrap()).collect();
        let expected = [0.3, 0.1, 0.4, 0.5, top, 0.6];
        for (got, want) in bounds.iter().zip(expected) {
            assert!(
                (got - want).abs() < 1e-5,
                "bounds {bounds:?}, expected {expected:?}"
            );
        }
    }
    assert_eq!(lines.len(), 4, "{text}");
}

/// Opens the stage `sys.argv[1]`; prints the drift prim's type, its
/// primvars, then per frame of `sys.argv[2:]` its snow and drift point
/// counts and the drift's points.
const READ_DRIFT: &str = "
import sys
from pxr import Usd, UsdGeom
stage = Usd.Stage.Open(sys.argv[1])
snow = UsdGeom.Points(stage.GetPrimAtPath('/World/Snow'))
prim = stage.GetPrimAtPath('/World/Drift')
drift = UsdGeom.Points(prim)
names = sorted(p.GetPrimvarName() for p in UsdGeom.PrimvarsAPI(prim).GetAuthoredPrimvars())
print(prim.GetTypeName(), ','.join(names))
for frame in sys.argv[2:]:
    t = float(frame)
    xyz = [repr(c) for p in drift.GetPointsAttr().Get(t) for c in p]
    print(frame, len(snow.GetPointsAttr().Get(t)), len(xyz) // 3, *xyz)
";

#[test]
fn pixar_usd_reads_the_drift_beside_the_snow() {
    if !usd_available() {
        return;
    }
    let mut scene = common::drift_slab();
    scene.time.duration = 0.06;
    scene.time.fps = 50.0;
    scene.output.formats = vec![CacheFormat::Ply, CacheFormat::Usd];
    let last = scene.time.frame_count();
    let folder = tempfile::tempdir().unwrap();
    record(&scene, folder.path(), last);
    let output = Command::new(python())
        .args(["-c", READ_DRIFT])
        .arg(folder.path().join("particles.usda"))
        .args((0..=last).map(|frame| frame.to_string()))
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(output.status.success(), "pxr failed:\n{stderr}");
    assert!(stderr.is_empty(), "pxr warned:\n{stderr}");
    let text = String::from_utf8(output.stdout).unwrap();
    let lines: Vec<&str> = text.lines().collect();
    assert_eq!(lines[0], "Points mass");
    let mut lifted = 0;
    for (line, frame) in lines[1..].iter().zip(0..=last) {
        let fields: Vec<&str> = line.split(' ').collect();
        let snow = ply_positions(&folder.path().join(format!("ply/frame_{frame:05}.ply")));
        let drift = ply_positions(&folder.path().join(format!("drift/frame_{frame:05}.ply")));
        assert_eq!(fields[0], frame.to_string());
        assert_eq!(fields[1].parse::<usize>().unwrap() * 3, snow.len());
        assert_eq!(fields[2].parse::<usize>().unwrap() * 3, drift.len());
        let usd: Vec<f32> = fields[3..].iter().map(|f| f.parse().unwrap()).collect();
        assert!(
            usd == drift,
            "frame {frame}: pxr's drift differs from the PLY's"
        );
        lifted = lifted.max(drift.len() / 3);
    }
    assert_eq!(lines.len(), 2 + last as usize);
    assert!(lifted > 0, "the wind lifts drift");
    eprintln!("pxr read up to {lifted} drift points equal to the drift PLY's");
}

/// A bar 0.1 m thick and 0.3 m long along x, centred at the origin, as OBJ
/// quads (the mesh body's file).
const BAR_OBJ: &str = "v -0.15 -0.05 -0.05\nv 0.15 -0.05 -0.05\nv 0.15 0.05 -0.05\n\
     v -0.15 0.05 -0.05\nv -0.15 -0.05 0.05\nv 0.15 -0.05 0.05\nv 0.15 0.05 0.05\n\
     v -0.15 0.05 0.05\nf 1 4 3 2\nf 5 6 7 8\nf 1 2 6 5\nf 4 8 7 3\nf 1 5 8 4\nf 2 3 7 6\n";

/// A turned, spinning box and the bar above stood upright, both dropped
/// onto a thin slab of snow: two frames.
const BODIES_SCENE: &str = r#"
format = 1
name = "usd-bodies"

[domain]
max = [1.0, 1.0, 1.0]
cell_size = 0.0625

[time]
duration = 0.0834
fps = 24

[[bodies]]
shape = "box"
center = [0.5, 0.1, 0.5]
size = [0.8, 0.08, 0.8]

[[rigid_bodies]]
shape = "box"
center = [0.4, 0.4, 0.5]
size = [0.3, 0.16, 0.2]
rotation = [0.0, 0.0, 30.0]
velocity = [0.4, -1.0, 0.0]
angular_velocity = [0.0, 4.0, 0.0]

[[rigid_bodies]]
shape = "mesh"
mesh = "bar.obj"
center = [0.8, 0.4, 0.25]
rotation = [0.0, 0.0, 90.0]

[render]
enabled = false

[output]
formats = ["usd"]
"#;

/// Prints per body prim its type and transform ops, its local-to-world
/// matrix at each time code of `sys.argv[2:]` (row by row), then the
/// second body's world bounds at time code 0.
const READ_BODIES: &str = "
import sys
from pxr import Usd, UsdGeom
stage = Usd.Stage.Open(sys.argv[1])
for name in ['Body0', 'Body1']:
    body = UsdGeom.Xformable(stage.GetPrimAtPath('/World/' + name))
    ops = ','.join(op.GetOpName() for op in body.GetOrderedXformOps())
    print(body.GetPrim().GetTypeName(), ops)
    for code in sys.argv[2:]:
        matrix = body.ComputeLocalToWorldTransform(float(code))
        print(*(matrix[i][j] for i in range(4) for j in range(4)))
prim = stage.GetPrimAtPath('/World/Body1')
bounds = UsdGeom.BBoxCache(0, ['default']).ComputeWorldBound(prim).ComputeAlignedRange()
print(*bounds.GetMin(), *bounds.GetMax())
";

#[test]
fn pixar_usd_reads_the_rigid_bodies_moved_and_turned_as_the_manifest_says() {
    if !usd_available() {
        return;
    }
    let folder = tempfile::tempdir().unwrap();
    std::fs::write(folder.path().join("bar.obj"), BAR_OBJ).unwrap();
    let scene_file = folder.path().join("scene.toml").display().to_string();
    let scene = Scene::from_toml_str(BODIES_SCENE, &scene_file).expect("the scene is valid");
    let run = folder.path().join("run");
    record(&scene, &run, 2);
    let output = Command::new(python())
        .args(["-c", READ_BODIES])
        .arg(run.join("particles.usda"))
        .args(["0", "1", "2"])
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(output.status.success(), "pxr failed:\n{stderr}");
    assert!(stderr.is_empty(), "pxr warned:\n{stderr}");
    let text = String::from_utf8(output.stdout).unwrap();
    let lines: Vec<&str> = text.lines().collect();
    assert_eq!(lines.len(), 9, "{text}");
    assert_eq!(
        lines[0],
        "Cube xformOp:translate,xformOp:orient,xformOp:scale"
    );
    assert_eq!(lines[4], "Mesh xformOp:translate,xformOp:orient");
    let manifest = RunDirectory::new(&run).read().unwrap().manifest;
    let numbers =
        |line: &str| -> Vec<f32> { line.split(' ').map(|f| f.parse().unwrap()).collect() };
    for (body, first_line) in [(0, 1), (1, 5)] {
        // The mesh's placed points carry its starting rotation already.
        let baked = scene.rigid_bodies[body].baked_rotation();
        for (frame, line) in manifest
            .frames
            .iter()
            .zip(&lines[first_line..first_line + 3])
        {
            let pose = frame.rigid_bodies[body];
            let turn = glam::Quat::from_array(pose.rotation) * baked.inverse();
            let placed =
                glam::Mat4::from_rotation_translation(turn, glam::Vec3::from_array(pose.position));
            // The box prim is a unit cube scaled to the body's size.
            let scale = if body == 0 {
                glam::Vec3::new(0.3, 0.16, 0.2)
            } else {
                glam::Vec3::ONE
            };
            let expected = placed * glam::Mat4::from_scale(scale);
            let matrix = numbers(line);
            // pxr takes a quatf's angle from acos of its real part, which
            // drops turns below some 1e-4 rad (w rounds to 1 in f32).
            for (got, want) in matrix.iter().zip(expected.to_cols_array()) {
                assert!(
                    (got - want).abs() < 1e-4,
                    "body {body} at frame {}: pxr's {matrix:?}, its pose {expected:?}",
                    frame.index
                );
            }
        }
        let moved = manifest.frames[2].rigid_bodies[body].position[1]
            < manifest.frames[0].rigid_bodies[body].position[1] - 0.02;
        assert!(moved, "body {body} falls: {:?}", manifest.frames);
    }
    // Standing upright at the start, as the scene placed it.
    let bounds = numbers(lines[8]);
    let expected = [0.75, 0.25, 0.2, 0.85, 0.55, 0.3];
    for (got, want) in bounds.iter().zip(expected) {
        assert!(
            (got - want).abs() < 1e-5,
            "bounds {bounds:?}, expected {expected:?}"
        );
    }
}
