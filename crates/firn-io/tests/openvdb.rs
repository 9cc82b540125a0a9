//! The VDB writer read back by OpenVDB itself (Debian's `python3-openvdb`,
//! the `pyopenvdb` module of the system python). Skipped where the module is
//! missing, unless `FIRN_REQUIRE_OPENVDB=1` (as `.ci/run` sets it).

use std::path::Path;

use firn_io::vdb::voxel_of;
use firn_io::{FloatGrid, GridClass, Leaf, write_vdb};

#[path = "support/openvdb.rs"]
mod support;

use support::{openvdb_available, run_openvdb};

/// Runs `script` with `path` as `sys.argv[1]` and returns its standard output.
fn read_with_openvdb(path: &Path, script: &str) -> String {
    run_openvdb(script, path, &[])
}

/// A fog volume over leaves on both sides of every axis' zero, in three
/// upper nodes, with a recognisable value per voxel.
fn spread_fog() -> FloatGrid {
    let mut grid = FloatGrid::new("density", GridClass::FogVolume, 0.25, [1.0, -2.0, 0.5], 0.0);
    for ijk in [
        [-3, 4, 5],
        [0, 0, 0],
        [7, 8, -9],
        [200, -5000, 17],
        [4100, 1, 1],
    ] {
        let origin = FloatGrid::leaf_origin(ijk);
        let local = [0, 1, 2].map(|axis| ijk[axis] - origin[axis]);
        let value = (ijk[0] + 2 * ijk[1] + 3 * ijk[2]) as f32;
        grid.leaf_mut(ijk).add(Leaf::offset(local), value);
    }
    grid
}

#[test]
fn openvdb_reads_a_sparse_fog_volume() {
    if !openvdb_available() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("fog.vdb");
    let grid = spread_fog();
    write_vdb(&path, std::slice::from_ref(&grid)).unwrap();
    let script = "
import sys, pyopenvdb as vdb
g = vdb.read(sys.argv[1], 'density')
print(g.gridClass, g.transform.voxelSize()[0], g.activeVoxelCount(), g.leafCount())
print(*g.transform.indexToWorld((0, 0, 0)))
for ijk in [(-3, 4, 5), (0, 0, 0), (7, 8, -9), (200, -5000, 17), (4100, 1, 1), (1, 1, 1)]:
    print(g.getConstAccessor().getValue(ijk))
";
    let output = read_with_openvdb(&path, script);
    let lines: Vec<&str> = output.lines().collect();
    assert_eq!(lines[0], "fog volume 0.25 5 5", "{output}");
    assert_eq!(lines[1], "1.0 -2.0 0.5", "{output}");
    let values: Vec<f32> = lines[2..].iter().map(|v| v.parse().unwrap()).collect();
    assert_eq!(values, [20.0, 0.0, -4.0, -9749.0, 4105.0, 0.0]);
}

/// A level set of a ball: distances in a narrow band, −background tiles in
/// the leaves deep inside, +background outside.
fn ball_level_set(radius: f32, band: f32) -> FloatGrid {
    let mut grid = FloatGrid::new("surface", GridClass::LevelSet, 1.0, [0.0; 3], band);
    let reach = 8 * ((radius + band) as i32 / 8 + 1);
    for x in (-reach..reach).step_by(8) {
        for y in (-reach..reach).step_by(8) {
            for z in (-reach..reach).step_by(8) {
                fill_ball_leaf(&mut grid, [x, y, z], radius, band);
            }
        }
    }
    grid
}

fn fill_ball_leaf(grid: &mut FloatGrid, origin: [i32; 3], radius: f32, band: f32) {
    let mut leaf = Leaf::filled(band);
    for offset in 0..512 {
        let [x, y, z] = voxel_of(origin, offset).map(|c| c as f32);
        let distance = (x * x + y * y + z * z).sqrt() - radius;
        let clamped = distance.clamp(-band, band);
        leaf.set(offset, clamped, distance.abs() < band);
    }
    if leaf.active_count() > 0 {
        *grid.leaf_mut(origin) = leaf;
    } else if leaf.value(0) < 0.0 {
        grid.set_tile(origin, -band);
    }
}

#[test]
fn openvdb_reads_a_level_set_with_its_inside() {
    if !openvdb_available() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("ball.vdb");
    let grid = ball_level_set(20.0, 3.0);
    write_vdb(&path, std::slice::from_ref(&grid)).unwrap();
    let script = "
import sys, pyopenvdb as vdb
g = vdb.read(sys.argv[1], 'surface')
a = g.getConstAccessor()
print(g.gridClass, g.background, g.activeVoxelCount())
print(a.getValue((0, 0, 0)), a.getValue((15, 0, 0)), a.getValue((19, 0, 0)), a.getValue((40, 0, 0)))
wrong = 0
for voxel in g.citerOnValues():
    x, y, z = voxel.min
    wrong += abs(voxel.value - ((x * x + y * y + z * z) ** 0.5 - 20.0)) > 1e-4
print(wrong)
";
    let output = read_with_openvdb(&path, script);
    let lines: Vec<&str> = output.lines().collect();
    assert_eq!(
        lines[0],
        format!("level set 3.0 {}", grid.active_voxel_count()),
        "{output}"
    );
    let values: Vec<f32> = lines[1]
        .split(' ')
        .map(|value| value.parse().unwrap())
        .collect();
    assert_eq!(values, [-3.0, -3.0, -1.0, 3.0], "{output}");
    assert_eq!(
        lines[2], "0",
        "active voxels away from the ball's distance: {output}"
    );
}
