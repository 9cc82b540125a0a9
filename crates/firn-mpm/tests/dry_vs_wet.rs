//! The bundled dry-vs-wet scene tells its story in numbers: after the two
//! snowballs hit the wall, the dry one has burst into many separate pieces
//! while the wet one is still one lump.

use std::collections::HashMap;
use std::path::Path;

use firn_core::Scene;
use firn_mpm::Simulation;
use glam::{IVec3, Vec3};

/// Union-find over particle indices, with path halving.
struct Pieces {
    parent: Vec<usize>,
}

impl Pieces {
    fn new(count: usize) -> Pieces {
        Pieces {
            parent: (0..count).collect(),
        }
    }

    fn root(&mut self, mut index: usize) -> usize {
        while self.parent[index] != index {
            self.parent[index] = self.parent[self.parent[index]];
            index = self.parent[index];
        }
        index
    }

    fn join(&mut self, a: usize, b: usize) {
        let (a, b) = (self.root(a), self.root(b));
        if a != b {
            self.parent[a] = b;
        }
    }
}

/// Sizes of the connected pieces of a point cloud, largest first: two
/// particles belong to one piece when a chain of particles, each closer
/// than `link` to the next, joins them.
fn piece_sizes(points: &[Vec3], link: f32) -> Vec<usize> {
    let cell_of = |p: Vec3| (p / link).floor().as_ivec3();
    let mut cells: HashMap<IVec3, Vec<usize>> = HashMap::new();
    for (index, &point) in points.iter().enumerate() {
        cells.entry(cell_of(point)).or_default().push(index);
    }
    let mut pieces = Pieces::new(points.len());
    for (index, &point) in points.iter().enumerate() {
        let cell = cell_of(point);
        for dz in -1..=1 {
            for dy in -1..=1 {
                for dx in -1..=1 {
                    let Some(neighbours) = cells.get(&(cell + IVec3::new(dx, dy, dz))) else {
                        continue;
                    };
                    for &other in neighbours {
                        if other > index && point.distance(points[other]) < link {
                            pieces.join(index, other);
                        }
                    }
                }
            }
        }
    }
    let mut sizes: HashMap<usize, usize> = HashMap::new();
    for index in 0..points.len() {
        *sizes.entry(pieces.root(index)).or_default() += 1;
    }
    let mut sizes: Vec<usize> = sizes.into_values().collect();
    sizes.sort_unstable_by(|a, b| b.cmp(a));
    sizes
}

#[test]
fn piece_counting_finds_separate_lumps() {
    let lump = |center: Vec3| {
        (0..27).map(move |i| {
            center + 0.01 * Vec3::new((i % 3) as f32, (i / 3 % 3) as f32, (i / 9) as f32)
        })
    };
    let points: Vec<Vec3> = lump(Vec3::ZERO)
        .chain(lump(Vec3::new(0.5, 0.0, 0.0)))
        .chain(std::iter::once(Vec3::new(0.0, 0.5, 0.0)))
        .collect();
    assert_eq!(piece_sizes(&points, 0.015), vec![27, 27, 1]);
    assert_eq!(piece_sizes(&points, 0.6), vec![55]);
}

/// Pieces of at least this many particles count; single crumbs do not.
const MIN_PIECE: usize = 10;

#[test]
fn after_impact_the_dry_snowball_has_burst_and_the_wet_one_is_whole() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes/dry-vs-wet.toml");
    let scene = Scene::load(&path).expect("the bundled scene loads");
    let dry = scene
        .materials
        .iter()
        .position(|m| m.name == "dry")
        .unwrap() as u16;
    let wet = scene
        .materials
        .iter()
        .position(|m| m.name == "wet")
        .unwrap() as u16;
    let link = scene.domain.cell_size;
    let mut simulation = Simulation::new(scene).unwrap();
    // The balls reach the wall at about 0.13 s.
    simulation.advance_to(0.3).unwrap();
    let particles = simulation.particles();
    let pieces_of = |material: u16| {
        let points: Vec<Vec3> = particles
            .position
            .iter()
            .zip(&particles.material)
            .filter(|(_, m)| **m == material)
            .map(|(p, _)| *p)
            .collect();
        let sizes = piece_sizes(&points, link);
        let pieces = sizes.iter().filter(|&&size| size >= MIN_PIECE).count();
        (pieces, sizes)
    };
    let (dry_pieces, dry_sizes) = pieces_of(dry);
    let (wet_pieces, wet_sizes) = pieces_of(wet);
    assert_eq!(
        wet_pieces,
        1,
        "the wet snowball should stay one lump: {:?}",
        &wet_sizes[..wet_sizes.len().min(8)]
    );
    assert!(
        dry_pieces >= 5,
        "the dry snowball should burst into many pieces of {MIN_PIECE} or more particles, \
         got {dry_pieces}: {:?}",
        &dry_sizes[..dry_sizes.len().min(8)]
    );
}
