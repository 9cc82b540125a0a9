//! The background grid: nodes stored block by block so that the stencil of a
//! particle touches a few contiguous 2 KiB blocks, and so that clearing and
//! updating visit only the blocks near snow.

use glam::{IVec3, UVec3, Vec3};

/// Nodes per block edge. Particle blocks use the same width; it must be at
/// least 3 so that blocks of one colour never share a stencil node (see
/// [`crate::binning`]).
pub const BLOCK_WIDTH: i32 = 4;
/// Nodes in one block.
pub const BLOCK_NODES: usize = (BLOCK_WIDTH * BLOCK_WIDTH * BLOCK_WIDTH) as usize;
/// Empty nodes kept around the domain on every side, so that the widest
/// stencil of a particle slightly outside the domain still lands on the grid.
pub const PADDING_NODES: i32 = 3;

/// One grid node (thesis Tabelle 4). The two vectors change meaning during a
/// step: after the scatter they hold momentum and force sums; after the grid
/// update they hold the velocities before (v_i) and after (v_i^{n+1}) forces.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[repr(C)]
pub struct Node {
    /// m_i.
    pub mass: f32,
    /// Σ m_p v_p w_ip, then v_i.
    pub velocity: Vec3,
    /// f_i (PIC/FLIP) or unused (APIC), then v_i^{n+1}.
    pub velocity_new: Vec3,
    /// Pads the node to 32 bytes.
    pub padding: f32,
}

/// Where the grid lies and how its nodes are numbered; small and `Copy`, so
/// that passes can read it while they write the nodes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GridLayout {
    /// World position of node (0, 0, 0).
    pub origin: Vec3,
    /// Grid spacing h.
    pub cell_size: f32,
    /// Number of blocks along each axis.
    pub blocks: UVec3,
}

impl GridLayout {
    /// A layout covering `[min, max]` with spacing `cell_size`, plus padding.
    pub fn new(min: Vec3, max: Vec3, cell_size: f32) -> GridLayout {
        let origin = min - Vec3::splat(PADDING_NODES as f32 * cell_size);
        let cells = ((max - min) / cell_size - Vec3::splat(1e-4))
            .ceil()
            .max(Vec3::ONE);
        let nodes_needed = cells.as_ivec3() + IVec3::splat(1 + 2 * PADDING_NODES);
        let blocks = ((nodes_needed + IVec3::splat(BLOCK_WIDTH - 1)) / BLOCK_WIDTH).as_uvec3();
        GridLayout {
            origin,
            cell_size,
            blocks,
        }
    }

    /// Grid coordinate of a world position (in cells, from node 0).
    #[inline(always)]
    pub fn to_grid(&self, position: Vec3) -> Vec3 {
        (position - self.origin) / self.cell_size
    }

    /// World position of a node.
    #[inline(always)]
    pub fn node_position(&self, node: IVec3) -> Vec3 {
        self.origin + node.as_vec3() * self.cell_size
    }

    /// Number of nodes along each axis.
    pub fn node_dims(&self) -> UVec3 {
        self.blocks * BLOCK_WIDTH as u32
    }

    /// Total number of nodes.
    pub fn node_count(&self) -> usize {
        self.block_count() * BLOCK_NODES
    }

    /// Total number of blocks.
    pub fn block_count(&self) -> usize {
        (self.blocks.x * self.blocks.y * self.blocks.z) as usize
    }

    /// Linear index of a block from its block coordinate.
    #[inline(always)]
    pub fn block_index(&self, block: IVec3) -> usize {
        ((block.x as u32 * self.blocks.y + block.y as u32) * self.blocks.z + block.z as u32)
            as usize
    }

    /// Block coordinate of a linear block index.
    pub fn block_coord(&self, index: usize) -> IVec3 {
        let index = index as u32;
        let z = index % self.blocks.z;
        let y = (index / self.blocks.z) % self.blocks.y;
        let x = index / (self.blocks.z * self.blocks.y);
        IVec3::new(x as i32, y as i32, z as i32)
    }

    /// Linear index of node `node` in [`Grid::nodes`].
    #[inline(always)]
    pub fn node_index(&self, node: IVec3) -> usize {
        let block = node >> 2;
        let local = node & IVec3::splat(BLOCK_WIDTH - 1);
        self.block_index(block) * BLOCK_NODES
            + (local.x * BLOCK_WIDTH * BLOCK_WIDTH + local.y * BLOCK_WIDTH + local.z) as usize
    }

    /// Grid coordinate of node number `local` (0..64) of block `block`.
    #[inline(always)]
    pub fn node_in_block(block: IVec3, local: usize) -> IVec3 {
        let local = local as i32;
        block * BLOCK_WIDTH
            + IVec3::new(
                local / (BLOCK_WIDTH * BLOCK_WIDTH),
                (local / BLOCK_WIDTH) % BLOCK_WIDTH,
                local % BLOCK_WIDTH,
            )
    }
}

/// A dense grid over the domain plus padding, stored in blocks of 4³ nodes.
#[derive(Clone, Debug)]
pub struct Grid {
    /// Geometry and numbering.
    pub layout: GridLayout,
    /// Nodes, block after block (x-major block order, x-major inside a block).
    pub nodes: Vec<Node>,
}

impl Grid {
    /// An empty grid covering `[min, max]` with spacing `cell_size`, plus padding.
    pub fn new(min: Vec3, max: Vec3, cell_size: f32) -> Grid {
        let layout = GridLayout::new(min, max, cell_size);
        Grid {
            layout,
            nodes: vec![Node::default(); layout.node_count()],
        }
    }

    /// Bytes held by the node array.
    pub fn memory_bytes(&self) -> usize {
        self.nodes.len() * std::mem::size_of::<Node>()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn node_indices_are_a_bijection() {
        let grid = GridLayout::new(Vec3::ZERO, Vec3::new(0.5, 0.3, 0.2), 0.05);
        let dims = grid.node_dims().as_ivec3();
        let mut seen = vec![false; grid.node_count()];
        for x in 0..dims.x {
            for y in 0..dims.y {
                for z in 0..dims.z {
                    let index = grid.node_index(IVec3::new(x, y, z));
                    assert!(!seen[index]);
                    seen[index] = true;
                    let block = IVec3::new(x, y, z) >> 2;
                    let local = index % BLOCK_NODES;
                    assert_eq!(GridLayout::node_in_block(block, local), IVec3::new(x, y, z));
                    assert_eq!(grid.block_coord(grid.block_index(block)), block);
                }
            }
        }
        assert!(seen.iter().all(|&s| s));
    }

    #[test]
    fn domain_and_padding_fit_in_the_grid() {
        let grid = GridLayout::new(Vec3::ZERO, Vec3::ONE, 1.0 / 64.0);
        let far_corner = grid.to_grid(Vec3::ONE).ceil().as_ivec3() + IVec3::splat(2);
        assert!(far_corner.cmplt(grid.node_dims().as_ivec3()).all());
        assert!(grid.to_grid(Vec3::ZERO).cmpge(Vec3::splat(2.0)).all());
    }
}
