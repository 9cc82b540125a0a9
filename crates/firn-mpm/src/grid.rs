//! The background grid: nodes stored block by block so that the stencil of a
//! particle touches a few contiguous 2 KiB blocks, and sparsely, so that memory
//! follows the snow rather than the domain box.
//!
//! A page table maps every block of the box to a slot in a pool of 64-node
//! blocks, or to [`ABSENT`]. Each substep, after binning, [`Grid::allocate`]
//! gives storage to exactly the blocks the particles' stencils reach, slot
//! after slot in increasing block index, and takes it from all others. The
//! slots therefore depend only on the particle positions (not on threads or on
//! history), the pool stays in the same order a dense grid would have, and a
//! 1024³-cell box costs a 64 MiB page table plus the blocks near the snow.

use firn_core::math::isa::PairLanes;
use glam::{IVec3, UVec3, Vec3, Vec4};
use rayon::prelude::*;

/// Nodes per block edge. Particle blocks use the same width; it must be at
/// least 3 so that blocks of one colour never share a stencil node (see
/// [`crate::binning`]).
pub const BLOCK_WIDTH: i32 = 4;
/// Nodes in one block.
pub const BLOCK_NODES: usize = (BLOCK_WIDTH * BLOCK_WIDTH * BLOCK_WIDTH) as usize;
/// Page-table entry of a block without storage.
pub const ABSENT: u32 = u32::MAX;
/// Empty nodes kept around the domain on every side, so that the widest
/// stencil of a particle slightly outside the domain still lands on the grid.
pub const PADDING_NODES: i32 = 3;

/// One grid node (thesis Tabelle 4). The two vectors change meaning during a
/// step: after the scatter they hold momentum and force sums; after the grid
/// update they hold the velocities before (v_i) and after (v_i^{n+1}) forces.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[repr(C)]
pub struct Node {
    /// xyz: Σ m_p v_p w_ip, then v_i; w: m_i. Momentum and mass share one
    /// SIMD register, so the scatter adds both with one instruction.
    pub velocity_mass: Vec4,
    /// xyz: f_i (PIC/FLIP) or zero (APIC), then v_i^{n+1}; w: always zero,
    /// so the gather can weight all four lanes at once.
    pub velocity_new: Vec4,
}

impl Node {
    /// m_i.
    #[inline(always)]
    pub fn mass(&self) -> f32 {
        self.velocity_mass.w
    }

    /// The momentum sum, or v_i after the grid update.
    #[inline(always)]
    pub fn velocity(&self) -> Vec3 {
        self.velocity_mass.truncate()
    }

    /// The force sum, or v_i^{n+1} after the grid update.
    #[inline(always)]
    pub fn velocity_new(&self) -> Vec3 {
        self.velocity_new.truncate()
    }

    /// Stores v_i^{n+1}.
    #[inline(always)]
    pub fn set_velocity_new(&mut self, velocity: Vec3) {
        self.velocity_new = velocity.extend(0.0);
    }

    /// Both vectors as one pair, `velocity_mass` low: the PIC/FLIP
    /// transfers weight them together, in one 256-bit register where the
    /// instruction set has them.
    #[inline(always)]
    pub fn pair<P: PairLanes>(&self, lanes: P) -> P::Pair {
        lanes.pair(self.velocity_mass, self.velocity_new)
    }

    /// Adds `terms` laid out as [`Node::pair`].
    #[inline(always)]
    pub fn add_pair<P: PairLanes>(&mut self, lanes: P, terms: P::Pair) {
        [self.velocity_mass, self.velocity_new] = lanes.halves(self.pair(lanes) + terms);
    }
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

    /// Number (0..64) of node `node` inside its block.
    #[inline(always)]
    pub fn local_index(node: IVec3) -> usize {
        let local = node & IVec3::splat(BLOCK_WIDTH - 1);
        (local.x * BLOCK_WIDTH * BLOCK_WIDTH + local.y * BLOCK_WIDTH + local.z) as usize
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

/// Where each block's nodes live: the layout plus the page table, borrowed
/// apart from the node pool so that passes can look nodes up while they write
/// them.
#[derive(Clone, Copy, Debug)]
pub struct PageTable<'a> {
    /// Geometry and numbering.
    pub layout: GridLayout,
    /// Block index → slot, [`ABSENT`] for blocks without storage.
    slots: &'a [u32],
    /// Per slot: the slots of the blocks at offsets {0, 1}³, as in [`Grid`].
    neighbours: &'a [[u32; 8]],
}

impl PageTable<'_> {
    /// Index in [`Grid::nodes`] of node `node`. The block must have storage:
    /// an absent block maps far past the end of the pool, so that any access
    /// through the index panics instead of reading or writing another block.
    #[inline(always)]
    pub fn node_index(&self, node: IVec3) -> usize {
        let slot = self.slots[self.layout.block_index(node >> 2)] as usize;
        slot * BLOCK_NODES + GridLayout::local_index(node)
    }

    /// Node indices of the stencil whose first node is `base`. A stencil
    /// spans at most 2 blocks per axis, and the block of its first node is
    /// resident for every binned particle (panics otherwise), so one
    /// page-table read and one read of that block's [`Grid`] neighbour list
    /// find every node; a per-node page-table read made the scatter a quarter
    /// slower.
    #[inline(always)]
    pub fn stencil(&self, base: IVec3) -> StencilIndex {
        let first_block = base >> 2;
        let slot = self.slots[self.layout.block_index(first_block)];
        StencilIndex {
            base,
            first_block,
            slots: self.neighbours[slot as usize],
        }
    }

    /// Slot of block `block` (a linear block index), `None` without storage.
    pub fn slot(&self, block: usize) -> Option<usize> {
        let slot = self.slots[block];
        (slot != ABSENT).then_some(slot as usize)
    }
}

/// Node indices of one particle's stencil, from [`PageTable::stencil`].
#[derive(Clone, Copy, Debug)]
pub struct StencilIndex {
    /// The stencil's first node.
    base: IVec3,
    /// The block of `base`.
    first_block: IVec3,
    /// Slots of the blocks at offsets x, y, z ∈ {0, 1} from `first_block`,
    /// at `4 x + 2 y + z`.
    slots: [u32; 8],
}

impl StencilIndex {
    /// Index in [`Grid::nodes`] of stencil node (i, j, k).
    #[inline(always)]
    pub fn index(&self, i: usize, j: usize, k: usize) -> usize {
        let node = self.base + IVec3::new(i as i32, j as i32, k as i32);
        let block: IVec3 = (node >> 2) - self.first_block;
        // `& 7` keeps the index provably in bounds; the offsets are 0 or 1.
        let slot = self.slots[((block.x * 4 + block.y * 2 + block.z) & 7) as usize];
        slot as usize * BLOCK_NODES + GridLayout::local_index(node)
    }

    /// Calls `visit(i, j, k, index)` for every node of the `N`³ stencil in
    /// the order i, j, k (k fastest), `index` as in [`Self::index`]; the
    /// per-axis part of the arithmetic is done once per axis, not per node.
    #[inline(always)]
    pub fn for_each_index<const N: usize>(
        &self,
        mut visit: impl FnMut(usize, usize, usize, usize),
    ) {
        let width = BLOCK_WIDTH as usize;
        let mut block_bits = [[0usize; N]; 3];
        let mut local = [[0usize; N]; 3];
        let weights = [width * width, width, 1];
        for axis in 0..3 {
            for a in 0..N {
                let node = self.base[axis] + a as i32;
                let block = ((node >> 2) - self.first_block[axis]) as usize;
                block_bits[axis][a] = block << (2 - axis);
                local[axis][a] = (node & (BLOCK_WIDTH - 1)) as usize * weights[axis];
            }
        }
        for i in 0..N {
            for j in 0..N {
                let (bits_ij, local_ij) = (
                    block_bits[0][i] + block_bits[1][j],
                    local[0][i] + local[1][j],
                );
                for k in 0..N {
                    let block = (bits_ij + block_bits[2][k]) & 7;
                    let index = self.slots[block] as usize * BLOCK_NODES + local_ij + local[2][k];
                    visit(i, j, k, index);
                }
            }
        }
    }
}

/// A sparse grid over the domain plus padding, stored in blocks of 4³ nodes;
/// only the blocks given to [`Grid::allocate`] have storage.
#[derive(Clone, Debug)]
pub struct Grid {
    /// Geometry and numbering.
    pub layout: GridLayout,
    /// Block index → slot, [`ABSENT`] for blocks without storage.
    slots: Vec<u32>,
    /// Linear index of the block in each slot, increasing.
    resident: Vec<u32>,
    /// Per slot: the slots of the blocks at offsets x, y, z ∈ {0, 1} (at
    /// `4 x + 2 y + z`), [`ABSENT`] where absent or outside the box; what a
    /// stencil starting in the block needs (see [`PageTable::stencil`]).
    neighbours: Vec<[u32; 8]>,
    /// Nodes of the resident blocks, slot after slot (x-major inside a block).
    /// Between substeps every node is zero.
    pub nodes: Vec<Node>,
}

impl Grid {
    /// An empty grid covering `[min, max]` with spacing `cell_size`, plus
    /// padding; no block has storage yet.
    pub fn new(min: Vec3, max: Vec3, cell_size: f32) -> Grid {
        let layout = GridLayout::new(min, max, cell_size);
        Grid {
            layout,
            slots: vec![ABSENT; layout.block_count()],
            resident: Vec::new(),
            neighbours: Vec::new(),
            nodes: Vec::new(),
        }
    }

    /// Gives storage to exactly `blocks` (linear indices, strictly
    /// increasing): block `blocks[s]` gets slot `s`, all others none. Every
    /// node must be zero (as [`crate::grid_update::clear_grid`] leaves them), so
    /// the new slots start zeroed whichever block held them before. The pool
    /// keeps its capacity unless it shrinks below a quarter of it.
    pub fn allocate(&mut self, blocks: &[u32]) {
        debug_assert!(blocks.windows(2).all(|pair| pair[0] < pair[1]));
        for &block in &self.resident {
            self.slots[block as usize] = ABSENT;
        }
        for (slot, &block) in blocks.iter().enumerate() {
            self.slots[block as usize] = slot as u32;
        }
        self.resident.clear();
        self.resident.extend_from_slice(blocks);
        let layout = self.layout;
        let slots = &self.slots;
        self.neighbours.clear();
        self.neighbours.extend(blocks.iter().map(|&block| {
            let coord = layout.block_coord(block as usize);
            std::array::from_fn(|offset| {
                let offset = offset as i32;
                let neighbour = coord + IVec3::new(offset >> 2, (offset >> 1) & 1, offset & 1);
                if neighbour.cmplt(layout.blocks.as_ivec3()).all() {
                    slots[layout.block_index(neighbour)]
                } else {
                    ABSENT
                }
            })
        }));
        let len = blocks.len() * BLOCK_NODES;
        self.nodes.resize(len, Node::default());
        if self.nodes.capacity() > 4 * len {
            self.nodes.shrink_to(2 * len);
        }
    }

    /// The mass at node `node`: 0 outside the grid and where its block has
    /// no storage.
    pub fn node_mass(&self, node: IVec3) -> f32 {
        let layout = &self.layout;
        let block: IVec3 = node >> 2;
        if block.cmplt(IVec3::ZERO).any() || block.cmpge(layout.blocks.as_ivec3()).any() {
            return 0.0;
        }
        match self.page_table().slot(layout.block_index(block)) {
            Some(slot) => self.nodes[slot * BLOCK_NODES + GridLayout::local_index(node)].mass(),
            None => 0.0,
        }
    }

    /// The page table, for looking nodes up.
    pub fn page_table(&self) -> PageTable<'_> {
        PageTable {
            layout: self.layout,
            slots: &self.slots,
            neighbours: &self.neighbours,
        }
    }

    /// The page table and the node pool at once, for passes that look nodes
    /// up while they write them.
    pub fn parts_mut(&mut self) -> (PageTable<'_>, &mut [Node]) {
        let table = PageTable {
            layout: self.layout,
            slots: &self.slots,
            neighbours: &self.neighbours,
        };
        (table, &mut self.nodes)
    }

    /// Linear indices of the blocks with storage, in slot order.
    pub fn resident_blocks(&self) -> &[u32] {
        &self.resident
    }

    /// The resident blocks in slot order, each with its coordinate and its 64
    /// nodes, for parallel passes over every node with storage.
    pub fn par_blocks_mut(
        &mut self,
    ) -> impl IndexedParallelIterator<Item = (IVec3, &mut [Node])> + '_ {
        let layout = self.layout;
        self.nodes
            .par_chunks_mut(BLOCK_NODES)
            .zip(self.resident.par_iter())
            .map(move |(nodes, &block)| (layout.block_coord(block as usize), nodes))
    }

    /// The resident blocks in slot order, each with its coordinate and nodes.
    pub fn blocks(&self) -> impl Iterator<Item = (IVec3, &[Node])> + '_ {
        self.nodes
            .chunks(BLOCK_NODES)
            .zip(&self.resident)
            .map(|(nodes, &block)| (self.layout.block_coord(block as usize), nodes))
    }

    /// Bytes allocated: page table, lists of resident blocks and their
    /// neighbours, and node pool.
    pub fn memory_bytes(&self) -> usize {
        self.slots.capacity() * std::mem::size_of::<u32>()
            + self.resident.capacity() * std::mem::size_of::<u32>()
            + self.neighbours.capacity() * std::mem::size_of::<[u32; 8]>()
            + self.nodes.capacity() * std::mem::size_of::<Node>()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn node_indices_are_a_bijection() {
        let mut grid = Grid::new(Vec3::ZERO, Vec3::new(0.5, 0.3, 0.2), 0.05);
        let all: Vec<u32> = (0..grid.layout.block_count() as u32).collect();
        grid.allocate(&all);
        let layout = grid.layout;
        let table = grid.page_table();
        let dims = layout.node_dims().as_ivec3();
        let mut seen = vec![false; layout.node_count()];
        for x in 0..dims.x {
            for y in 0..dims.y {
                for z in 0..dims.z {
                    let index = table.node_index(IVec3::new(x, y, z));
                    assert!(!seen[index]);
                    seen[index] = true;
                    let block = IVec3::new(x, y, z) >> 2;
                    let local = index % BLOCK_NODES;
                    assert_eq!(GridLayout::node_in_block(block, local), IVec3::new(x, y, z));
                    assert_eq!(layout.block_coord(layout.block_index(block)), block);
                }
            }
        }
        assert!(seen.iter().all(|&s| s));
    }

    #[test]
    fn stencils_agree_with_single_node_lookups() {
        let mut grid = Grid::new(Vec3::ZERO, Vec3::ONE, 1.0 / 32.0);
        let all: Vec<u32> = (0..grid.layout.block_count() as u32).collect();
        grid.allocate(&all);
        let table = grid.page_table();
        for base in [
            IVec3::new(1, 2, 3),
            IVec3::new(3, 7, 4),
            IVec3::new(6, 5, 2),
        ] {
            let stencil = table.stencil(base);
            let mut visited = 0;
            stencil.for_each_index::<4>(|i, j, k, index| {
                let node = base + IVec3::new(i as i32, j as i32, k as i32);
                assert_eq!((i, j, k), (visited / 16, visited / 4 % 4, visited % 4));
                assert_eq!(stencil.index(i, j, k), table.node_index(node));
                assert_eq!(index, table.node_index(node));
                visited += 1;
            });
            assert_eq!(visited, 64);
        }
    }

    #[test]
    fn allocation_follows_the_given_blocks_and_frees_the_rest() {
        let mut grid = Grid::new(Vec3::ZERO, Vec3::ONE, 1.0 / 64.0);
        grid.allocate(&[3, 9, 40]);
        assert_eq!(grid.page_table().slot(9), Some(1));
        assert_eq!(grid.nodes.len(), 3 * BLOCK_NODES);
        grid.allocate(&[9, 41]);
        let table = grid.page_table();
        assert_eq!(
            [3, 9, 40, 41].map(|block| table.slot(block)),
            [None, Some(0), None, Some(1)]
        );
        assert_eq!(grid.resident_blocks(), &[9, 41]);
        assert_eq!(grid.nodes.len(), 2 * BLOCK_NODES);
    }

    #[test]
    fn domain_and_padding_fit_in_the_grid() {
        let grid = GridLayout::new(Vec3::ZERO, Vec3::ONE, 1.0 / 64.0);
        let far_corner = grid.to_grid(Vec3::ONE).ceil().as_ivec3() + IVec3::splat(2);
        assert!(far_corner.cmplt(grid.node_dims().as_ivec3()).all());
        assert!(grid.to_grid(Vec3::ZERO).cmpge(Vec3::splat(2.0)).all());
    }
}
