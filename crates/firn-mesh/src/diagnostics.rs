//! What is wrong with a mesh, counted, and what that means for filling it.

use crate::TriangleMesh;

/// Counts of the defects that matter for filling a mesh or using it as a
/// collider, so a scene can warn about them: scanned meshes routinely have
/// holes, and exported ones stray triangles or flipped faces.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct MeshDiagnostics {
    /// Edges used by exactly one triangle: the rims of holes.
    pub boundary_edges: usize,
    /// Edges used by three or more triangles.
    pub non_manifold_edges: usize,
    /// Triangles of zero area (repeated or collinear vertices).
    pub degenerate_triangles: usize,
    /// Edges shared by two triangles that traverse it in the same direction,
    /// so one of the two faces the wrong way.
    pub inconsistently_oriented_edges: usize,
    /// Connected parts (triangles sharing vertices), over the vertices that
    /// triangles use.
    pub components: usize,
}

impl MeshDiagnostics {
    /// Examines the mesh. Panics if a triangle refers to a missing vertex.
    pub fn of(mesh: &TriangleMesh) -> MeshDiagnostics {
        let mut diagnostics = MeshDiagnostics {
            degenerate_triangles: mesh
                .triangles
                .iter()
                .filter(|t| is_degenerate(mesh, t))
                .count(),
            components: components(mesh),
            ..MeshDiagnostics::default()
        };
        diagnostics.count_edges(mesh);
        diagnostics
    }

    /// One plain sentence per defect found, saying what it means for the
    /// fill; empty for a clean closed manifold in one piece.
    pub fn warnings(&self) -> Vec<String> {
        let mut warnings = Vec::new();
        if self.boundary_edges > 0 {
            warnings.push(format!(
                "the mesh has {} boundary edges (holes); its inside is taken from its generalized \
                 winding number, which closes small holes",
                self.boundary_edges
            ));
        }
        if self.non_manifold_edges > 0 {
            warnings.push(format!(
                "the mesh has {} non-manifold edges (shared by three or more triangles); check it \
                 for duplicated or intersecting parts",
                self.non_manifold_edges
            ));
        }
        if self.degenerate_triangles > 0 {
            warnings.push(format!(
                "the mesh has {} degenerate (zero-area) triangles; they add nothing to the fill",
                self.degenerate_triangles
            ));
        }
        if self.inconsistently_oriented_edges > 0 {
            warnings.push(format!(
                "the mesh has {} edges between triangles facing opposite ways; inside and outside \
                 are unreliable there, so orient its faces consistently (MeshLab: Filters > \
                 Normals > Re-Orient all faces coherently)",
                self.inconsistently_oriented_edges
            ));
        }
        if self.components > 1 {
            warnings.push(format!(
                "the mesh has {} separate parts; all of them are filled",
                self.components
            ));
        }
        warnings
    }

    /// Sorts the undirected edges and classifies each by its users.
    fn count_edges(&mut self, mesh: &TriangleMesh) {
        let mut edges: Vec<(u32, u32, bool)> = mesh
            .triangles
            .iter()
            .flat_map(|&[a, b, c]| [(a, b), (b, c), (c, a)])
            .filter(|(a, b)| a != b)
            .map(|(a, b)| (a.min(b), a.max(b), a < b))
            .collect();
        edges.sort_unstable();
        for users in edges.chunk_by(|x, y| (x.0, x.1) == (y.0, y.1)) {
            let forward = users.iter().filter(|e| e.2).count();
            match users.len() {
                1 => self.boundary_edges += 1,
                2 if forward != 1 => self.inconsistently_oriented_edges += 1,
                2 => {}
                _ => self.non_manifold_edges += 1,
            }
        }
    }
}

fn is_degenerate(mesh: &TriangleMesh, &[a, b, c]: &[u32; 3]) -> bool {
    let [a, b, c] = [a, b, c].map(|i| mesh.vertices[i as usize]);
    (b - a).cross(c - a) == glam::Vec3::ZERO
}

/// Connected parts by union-find over the vertices the triangles use.
fn components(mesh: &TriangleMesh) -> usize {
    let mut parent: Vec<u32> = (0..mesh.vertices.len() as u32).collect();
    let mut used = vec![false; mesh.vertices.len()];
    for &[a, b, c] in &mesh.triangles {
        union(&mut parent, a, b);
        union(&mut parent, a, c);
        for v in [a, b, c] {
            used[v as usize] = true;
        }
    }
    (0..parent.len())
        .filter(|&v| used[v] && find(&mut parent, v as u32) == v as u32)
        .count()
}

fn find(parent: &mut [u32], mut v: u32) -> u32 {
    while parent[v as usize] != v {
        let grandparent = parent[parent[v as usize] as usize];
        parent[v as usize] = grandparent;
        v = grandparent;
    }
    v
}

fn union(parent: &mut [u32], a: u32, b: u32) {
    let (ra, rb) = (find(parent, a), find(parent, b));
    if ra != rb {
        parent[ra.max(rb) as usize] = ra.min(rb);
    }
}
