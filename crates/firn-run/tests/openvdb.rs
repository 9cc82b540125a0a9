//! A snow frame's `vdb` cache read by OpenVDB itself (Debian's
//! `python3-openvdb`, the `pyopenvdb` module of the system python): grid
//! names, classes, voxel size, active voxels and total mass against ours.
//! Skipped where the module is missing, unless `FIRN_REQUIRE_OPENVDB=1` (as
//! `.ci/run` sets it).

mod common;

use std::path::Path;

use firn_core::Scene;
use firn_core::scene::CacheFormat;
use firn_io::PvdCollection;
use firn_run::caches::write_frame;
use firn_run::simulation::HostState;
use firn_run::volumes::snow_volumes;
use firn_run::{Placement, RunDirectory, Solver};
use glam::Vec3;

#[path = "../../firn-io/tests/support/openvdb.rs"]
mod support;

use support::{openvdb_available, run_openvdb};

/// A slab of snow falling onto the floor, cached as VDB volumes only.
const SCENE: &str = r#"
format = 1
name = "vdb-slab"

[domain]
min = [0.0, 0.0, 0.0]
max = [1.0, 1.0, 1.0]
cell_size = 0.05

[time]
duration = 0.1
fps = 20

[[bodies]]
shape = "box"
center = [0.5, 0.3, 0.5]
size = [0.4, 0.2, 0.3]
velocity = [0.0, -1.0, 0.0]

[render]
enabled = false

[output]
formats = ["vdb"]
vdb = { voxel_size = 0.025, level_set = true }
"#;

/// Reads the file named by `sys.argv[1]`: per grid its name, class, voxel
/// size, active voxels, Σ value·voxel³ and the largest |value|; then the
/// surface at `sys.argv[2:]` (0 without a surface).
const READ: &str = "
import sys, pyopenvdb as vdb
grids, _ = vdb.readAll(sys.argv[1])
for g in grids:
    size = g.transform.voxelSize()[0]
    total = sum(v.value * v.count for v in g.citerOnValues()) * size ** 3
    largest = max(abs(v.value) for v in g.citerOnValues())
    print(g.name, g.gridClass.replace(' ', '-'), size, g.activeVoxelCount(), total, largest)
surface = [g for g in grids if g.name == 'surface']
print(surface[0].getConstAccessor().getValue(tuple(int(c) for c in sys.argv[2:5])) if surface else 0.0)
";

/// What OpenVDB says of one grid.
#[derive(Debug)]
struct GridReport {
    name: String,
    class: String,
    voxel_size: f64,
    active: u64,
    total: f64,
    largest: f32,
}

fn read_with_openvdb(path: &Path, probe: [i32; 3]) -> (Vec<GridReport>, f32) {
    let args = probe.map(|c| c.to_string());
    let text = run_openvdb(READ, path, &args);
    let mut lines: Vec<&str> = text.lines().collect();
    let probed = lines.pop().unwrap().parse().unwrap();
    let grids = lines
        .iter()
        .map(|line| {
            let fields: Vec<&str> = line.split(' ').collect();
            GridReport {
                name: fields[0].to_string(),
                class: fields[1].to_string(),
                voxel_size: fields[2].parse().unwrap(),
                active: fields[3].parse().unwrap(),
                total: fields[4].parse().unwrap(),
                largest: fields[5].parse().unwrap(),
            }
        })
        .collect();
    (grids, probed)
}

#[test]
fn openvdb_reads_a_snow_frame_with_its_mass_and_inside() {
    if !openvdb_available() {
        return;
    }
    let scene = Scene::from_toml_str(SCENE, "vdb-slab.toml").expect("the scene is valid");
    let folder = tempfile::tempdir().unwrap();
    let run = RunDirectory::new(folder.path());
    run.create(&scene).unwrap();
    let mut solver = Solver::new(scene, &Placement::Cpu).unwrap();
    solver.advance_frame().unwrap();
    let HostState::Snow(simulation) = solver.host().unwrap() else {
        panic!("a snow scene");
    };
    let particles = simulation.particles();
    let mass: f64 = particles.mass.iter().map(|&m| f64::from(m)).sum();
    let ours = snow_volumes(
        &particles.position,
        &particles.mass,
        Vec3::ZERO,
        0.025,
        Some(400.0),
    );
    let centre = particles.position.iter().sum::<Vec3>() / particles.position.len() as f32;
    let probe = ((centre / 0.025) - 0.5).round().as_ivec3().to_array();

    let files = write_frame(solver.host().unwrap(), 1, &run, &mut PvdCollection::new())
        .unwrap()
        .files;
    assert_eq!(files, [RunDirectory::cache_name(CacheFormat::Vdb, 1)]);
    let (grids, inside) = read_with_openvdb(&run.path().join(&files[0]), probe);

    let names: Vec<&str> = grids.iter().map(|grid| grid.name.as_str()).collect();
    assert_eq!(names, ["density", "surface"]);
    assert_eq!(grids[0].class, "fog-volume");
    assert_eq!(grids[1].class, "level-set");
    for (grid, ours) in grids.iter().zip(&ours) {
        assert_eq!(grid.voxel_size, 0.025, "{grid:?}");
        assert_eq!(grid.active, ours.active_voxel_count(), "{grid:?}");
    }
    eprintln!("OpenVDB read {grids:?}; surface at the snow's centre {inside}; mass {mass} kg");
    let error = (grids[0].total / mass - 1.0).abs();
    assert!(
        error < 0.01,
        "OpenVDB's mass {} vs {mass} kg",
        grids[0].total
    );
    assert!(inside < 0.0, "the surface at the snow's centre is {inside}");
    let band = ours[1].background;
    assert!(
        grids[1].largest <= band,
        "a surface value past the band of {band} m: {}",
        grids[1].largest
    );
}

#[test]
fn a_frame_gives_the_same_vdb_bytes_twice() {
    let scene = Scene::from_toml_str(SCENE, "vdb-slab.toml").unwrap();
    let folders = [tempfile::tempdir().unwrap(), tempfile::tempdir().unwrap()];
    let mut solver = Solver::new(scene.clone(), &Placement::Cpu).unwrap();
    let bytes: Vec<Vec<u8>> = folders
        .iter()
        .map(|folder| {
            let run = RunDirectory::new(folder.path());
            run.create(&scene).unwrap();
            let files = write_frame(solver.host().unwrap(), 0, &run, &mut PvdCollection::new());
            std::fs::read(run.path().join(&files.unwrap().files[0])).unwrap()
        })
        .collect();
    assert!(bytes[0].len() > 1000);
    assert_eq!(bytes[0], bytes[1]);
}

#[test]
fn openvdb_reads_the_drift_as_a_grid_beside_the_snow() {
    if !openvdb_available() {
        return;
    }
    let mut scene = common::drift_slab();
    scene.output.formats = vec![CacheFormat::Vdb];
    let folder = tempfile::tempdir().unwrap();
    let run = RunDirectory::new(folder.path());
    run.create(&scene).unwrap();
    let mut solver = Solver::new(scene, &Placement::Cpu).unwrap();
    solver.advance_to(0.04).unwrap();
    let HostState::Snow(simulation) = solver.host().unwrap() else {
        panic!("a snow scene");
    };
    let total = |masses: &[f32]| masses.iter().map(|&m| f64::from(m)).sum::<f64>();
    let (snow, drift) = (
        total(&simulation.particles().mass),
        total(&simulation.drift().mass),
    );
    assert!(drift > 0.0, "the wind lifts drift");

    let files = write_frame(solver.host().unwrap(), 2, &run, &mut PvdCollection::new())
        .unwrap()
        .files;
    let (grids, _) = read_with_openvdb(&run.path().join(&files[0]), [0, 0, 0]);
    let names: Vec<&str> = grids.iter().map(|grid| grid.name.as_str()).collect();
    assert_eq!(names, ["density", "drift"]);
    assert_eq!(grids[1].class, "fog-volume");
    assert_eq!(grids[1].voxel_size, grids[0].voxel_size);
    eprintln!("OpenVDB read {grids:?}; snow {snow} kg, drift {drift} kg");
    for (grid, mass) in grids.iter().zip([snow, drift]) {
        let error = (grid.total / mass - 1.0).abs();
        assert!(
            error < 0.01,
            "OpenVDB's {} {} vs {mass} kg",
            grid.name,
            grid.total
        );
    }
}
