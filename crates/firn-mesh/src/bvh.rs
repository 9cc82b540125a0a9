//! A bounding volume hierarchy over a mesh's triangles, shared by the
//! winding number and the distance queries.
//!
//! Median splits along the longest axis of the triangle centroids keep the
//! tree balanced (depth at most 32 for any `u32` triangle count) and its
//! construction deterministic. Every node, leaf or not, covers a contiguous
//! range of the reordered triangles.

use glam::Vec3;

use crate::TriangleMesh;
use crate::geometry::closest_point_on_triangle;

/// At most this many triangles per leaf.
const LEAF_SIZE: usize = 4;

/// Deep enough for a depth-first walk of any tree [`Bvh::new`] builds.
pub(crate) const STACK_DEPTH: usize = 64;

/// One tree node: its box and its range of triangles.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Node {
    pub min: Vec3,
    pub max: Vec3,
    pub first: u32,
    pub count: u32,
    /// Index of the left child (the right one follows it); 0 for a leaf,
    /// since the root is nobody's child.
    pub left: u32,
}

impl Node {
    pub fn is_leaf(&self) -> bool {
        self.left == 0
    }

    pub fn range(&self) -> std::ops::Range<usize> {
        self.first as usize..(self.first + self.count) as usize
    }

    fn distance_squared(&self, p: Vec3) -> f32 {
        (self.min - p)
            .max(p - self.max)
            .max(Vec3::ZERO)
            .length_squared()
    }
}

/// The tree: nodes (the root first), the triangle corners in tree order,
/// and each of those triangles' index in the mesh.
pub(crate) struct Bvh {
    pub nodes: Vec<Node>,
    pub triangles: Vec<[Vec3; 3]>,
    pub sources: Vec<u32>,
}

/// A triangle's corners and its index in the mesh, sorted into tree order
/// together.
type Placed = ([Vec3; 3], u32);

impl Bvh {
    /// Builds the tree; panics if a triangle refers to a missing vertex.
    pub fn new(mesh: &TriangleMesh) -> Bvh {
        let mut placed: Vec<Placed> = mesh
            .triangles
            .iter()
            .zip(0..)
            .map(|(t, source)| (t.map(|i| mesh.vertices[i as usize]), source))
            .collect();
        let mut nodes = Vec::new();
        if !placed.is_empty() {
            nodes.push(placeholder());
            split(&mut nodes, &mut placed, 0, 0);
        }
        let (triangles, sources) = placed.into_iter().unzip();
        Bvh {
            nodes,
            triangles,
            sources,
        }
    }

    /// The squared distance from `p` to the nearest triangle and that
    /// triangle's index in tree order, or `None` without triangles. `hint`,
    /// a triangle likely to be near (the previous answer for a neighbouring
    /// point), only speeds the search up.
    pub fn closest(&self, p: Vec3, hint: Option<u32>) -> Option<(f32, u32)> {
        let root = self.nodes.first()?;
        let mut best = hint.map_or((f32::INFINITY, 0), |t| (self.distance_squared(p, t), t));
        let mut stack = [0u32; STACK_DEPTH];
        let mut len = usize::from(root.distance_squared(p) < best.0);
        while len > 0 {
            len -= 1;
            let node = &self.nodes[stack[len] as usize];
            if node.distance_squared(p) >= best.0 {
                continue;
            }
            if node.is_leaf() {
                best = self.closest_in_leaf(node, p, best);
                continue;
            }
            let (near, far) = self.children_by_distance(node, p);
            for (child, d) in [far, near] {
                if d < best.0 {
                    stack[len] = child;
                    len += 1;
                }
            }
        }
        Some(best)
    }

    fn closest_in_leaf(&self, leaf: &Node, p: Vec3, mut best: (f32, u32)) -> (f32, u32) {
        for t in leaf.range() {
            let d = self.distance_squared(p, t as u32);
            if d < best.0 {
                best = (d, t as u32);
            }
        }
        best
    }

    fn children_by_distance(&self, node: &Node, p: Vec3) -> ((u32, f32), (u32, f32)) {
        let left = (
            node.left,
            self.nodes[node.left as usize].distance_squared(p),
        );
        let right = (
            node.left + 1,
            self.nodes[node.left as usize + 1].distance_squared(p),
        );
        if right.1 < left.1 {
            (right, left)
        } else {
            (left, right)
        }
    }

    fn distance_squared(&self, p: Vec3, triangle: u32) -> f32 {
        let [a, b, c] = self.triangles[triangle as usize];
        closest_point_on_triangle(p, a, b, c).distance_squared(p)
    }
}

fn placeholder() -> Node {
    Node {
        min: Vec3::ZERO,
        max: Vec3::ZERO,
        first: 0,
        count: 0,
        left: 0,
    }
}

/// Fills node `index` with `triangles`, which start at `first` in tree
/// order, and recurses into its two halves.
fn split(nodes: &mut Vec<Node>, triangles: &mut [Placed], index: usize, first: usize) {
    let (min, max) = corner_bounds(triangles);
    let count = triangles.len();
    let mut node = Node {
        min,
        max,
        first: first as u32,
        count: count as u32,
        left: 0,
    };
    if count > LEAF_SIZE {
        let axis = longest_centroid_axis(triangles);
        let middle = count / 2;
        triangles.select_nth_unstable_by(middle, |a, b| {
            centroid_sum(&a.0)[axis].total_cmp(&centroid_sum(&b.0)[axis])
        });
        node.left = nodes.len() as u32;
        nodes.extend([placeholder(), placeholder()]);
        let (low, high) = triangles.split_at_mut(middle);
        split(nodes, low, node.left as usize, first);
        split(nodes, high, node.left as usize + 1, first + middle);
    }
    nodes[index] = node;
}

fn corner_bounds(triangles: &[Placed]) -> (Vec3, Vec3) {
    triangles
        .iter()
        .flat_map(|(corners, _)| corners)
        .fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), &v| {
            (lo.min(v), hi.max(v))
        })
}

/// Three times the centroid; only compared, so the division is skipped.
fn centroid_sum(t: &[Vec3; 3]) -> Vec3 {
    t[0] + t[1] + t[2]
}

fn longest_centroid_axis(triangles: &[Placed]) -> usize {
    let (lo, hi) = triangles
        .iter()
        .map(|(corners, _)| centroid_sum(corners))
        .fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), c| {
            (lo.min(c), hi.max(c))
        });
    let extent = hi - lo;
    if extent.x >= extent.y && extent.x >= extent.z {
        0
    } else if extent.y >= extent.z {
        1
    } else {
        2
    }
}
