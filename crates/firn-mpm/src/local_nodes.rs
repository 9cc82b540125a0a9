//! Dense copies of the grid nodes around one block, which the transfers
//! work in instead of the sparse grid: the scatter sums a block's particles
//! into one and adds it to the grid once; the gather copies the nodes once
//! and reads every particle of the block from the copy. Particles reach
//! their nodes at fixed offsets from their stencil's corner, with no
//! page-table lookups and one bounds check per particle.

use glam::{IVec3, Vec4};

use crate::disjoint::NodeWriter;
use crate::grid::{BLOCK_NODES, BLOCK_WIDTH, Node, PageTable};

/// Nodes per axis that the particles of one block reach: from one before
/// the block to two past it (see [`crate::binning`]).
pub(crate) const REACH: i32 = BLOCK_WIDTH + 3;

/// Nodes in a copy: [`REACH`]³.
const VOLUME: usize = (REACH * REACH * REACH) as usize;

/// Nodes of a copy from an `n`-wide stencil's first node to its last:
/// (n − 1) steps along each axis.
pub(crate) const fn span(n: usize) -> usize {
    let reach = REACH as usize;
    (n - 1) * (reach * reach + reach + 1) + 1
}

/// [`span`] of the quadratic stencil.
pub(crate) const QUADRATIC_SPAN: usize = span(3);
/// [`span`] of the cubic stencil.
pub(crate) const CUBIC_SPAN: usize = span(4);

/// Index of stencil node (i, j, k) in a [`LocalNodes::window`].
#[inline(always)]
pub(crate) const fn at(i: usize, j: usize, k: usize) -> usize {
    (i * REACH as usize + j) * REACH as usize + k
}

/// The nodes around one block, x-major, each a `T`: a whole [`Node`], or
/// one of its vectors where a transfer needs no more (APIC sums momentum
/// and mass only, and reads v_i^{n+1} only). Nodes along z are adjacent, so
/// a stencil's three nodes along z are 48 bytes in a row for a `Vec4`.
pub(crate) struct LocalNodes<T> {
    /// Grid coordinate of `nodes[0]`.
    first_node: IVec3,
    /// The copy.
    nodes: [T; VOLUME],
}

impl<T: Copy + Default> LocalNodes<T> {
    /// Zeroed nodes around `block`.
    pub(crate) fn around(block: IVec3) -> LocalNodes<T> {
        LocalNodes {
            first_node: block * BLOCK_WIDTH - IVec3::ONE,
            nodes: [T::default(); VOLUME],
        }
    }

    /// A copy for the gather to fill block by block.
    pub(crate) fn for_gather() -> LocalNodes<T> {
        LocalNodes::around(IVec3::ZERO)
    }

    /// Index in the copy of an `N`-wide stencil's first node `base`. Binning
    /// puts the stencil of every particle of the block inside (panics
    /// otherwise).
    #[inline(always)]
    fn corner<const N: usize>(&self, base: IVec3) -> usize {
        let corner = base - self.first_node;
        assert!(
            corner.cmpge(IVec3::ZERO).all() && corner.cmple(IVec3::splat(REACH - N as i32)).all(),
            "a particle's stencil at {base} leaves the reach of its block"
        );
        ((corner.x * REACH + corner.y) * REACH + corner.z) as usize
    }

    /// The nodes from an `N`-wide stencil's first node `base` to its last,
    /// `SPAN` = [`span`]`(N)` of them: checked once here, so that the
    /// stencil's nodes ([`at`]) need no further bounds checks.
    #[inline(always)]
    pub(crate) fn window<const N: usize, const SPAN: usize>(&self, base: IVec3) -> &[T; SPAN] {
        const { assert!(SPAN == span(N)) };
        let corner = self.corner::<N>(base);
        self.nodes[corner..corner + SPAN]
            .try_into()
            .expect("a window has its span")
    }

    /// [`LocalNodes::window`], to add to.
    #[inline(always)]
    pub(crate) fn window_mut<const N: usize, const SPAN: usize>(
        &mut self,
        base: IVec3,
    ) -> &mut [T; SPAN] {
        const { assert!(SPAN == span(N)) };
        let corner = self.corner::<N>(base);
        (&mut self.nodes[corner..corner + SPAN])
            .try_into()
            .expect("a window has its span")
    }

    /// Overwrites the copy with `part` of the grid's nodes around `block`;
    /// nodes outside the grid (which no particle's stencil reaches) are
    /// zero. The copy is made run by run ([`runs`]) and reused from block
    /// to block, so it is never cleared or moved whole.
    pub(crate) fn copy_from(
        &mut self,
        table: &PageTable,
        grid: &[Node],
        block: IVec3,
        part: impl Fn(&Node) -> T,
    ) {
        self.first_node = block * BLOCK_WIDTH - IVec3::ONE;
        runs(self.first_node, table, |to, from, len| {
            let run = &mut self.nodes[to..to + len];
            match from {
                Some(from) => {
                    for (copy, node) in run.iter_mut().zip(&grid[from..from + len]) {
                        *copy = part(node);
                    }
                }
                None => run.fill(T::default()),
            }
        });
    }

    /// Adds the sums into the grid's nodes, run by run ([`runs`]): those a
    /// particle reached ([`NodeSum::reached`]), which are sure to exist.
    pub(crate) fn add_sums_to(&self, table: &PageTable, writer: &NodeWriter<Node>)
    where
        T: NodeSum,
    {
        runs(self.first_node, table, |to, from, len| {
            for (n, sum) in self.nodes[to..to + len].iter().enumerate() {
                if !sum.reached() {
                    continue;
                }
                let from = from.expect("a reached node lies inside the grid");
                writer.update(from + n, |node| sum.add_into(node));
            }
        });
    }

    /// The block these nodes are around.
    pub(crate) fn block(&self) -> IVec3 {
        (self.first_node + IVec3::ONE) / BLOCK_WIDTH
    }

    /// Appends the sums as words, to send to another part of a split run:
    /// a bit per node saying whether a particle reached it
    /// ([`MASK_WORDS`] words), then the reached nodes' sums.
    pub(crate) fn push_words(&self, words: &mut Vec<u32>)
    where
        T: NodeSum,
    {
        let mask_start = words.len();
        words.resize(mask_start + MASK_WORDS, 0);
        for (n, sum) in self.nodes.iter().enumerate() {
            if sum.reached() {
                words[mask_start + n / 32] |= 1 << (n % 32);
                sum.push_words(words);
            }
        }
    }

    /// The sums around `block` from the front of `words`, as
    /// [`LocalNodes::push_words`] wrote them; returns them and the words
    /// read. The nodes no particle reached are zero.
    pub(crate) fn from_words(block: IVec3, words: &[u32]) -> (Box<LocalNodes<T>>, usize)
    where
        T: NodeSum,
    {
        let mut sums = Box::new(LocalNodes::around(block));
        let (mask, mut rest) = words.split_at(MASK_WORDS);
        for (n, sum) in sums.nodes.iter_mut().enumerate() {
            if mask[n / 32] & (1 << (n % 32)) != 0 {
                *sum = T::from_words(&rest[..T::WORDS]);
                rest = &rest[T::WORDS..];
            }
        }
        (sums, words.len() - rest.len())
    }
}

/// Words of the bit mask of a block's reached nodes in
/// [`LocalNodes::push_words`].
const MASK_WORDS: usize = VOLUME.div_ceil(32);

/// What a block sums per node in a [`LocalNodes`] during the scatter.
pub(crate) trait NodeSum: Copy + Default + Send + Sync {
    /// Words per node in [`LocalNodes::push_words`].
    const WORDS: usize;
    /// Whether a particle reached the node: its mass is not zero (every
    /// reached node gets a positive weight of a positive mass).
    fn reached(&self) -> bool;
    /// Adds the sum into a grid node.
    fn add_into(&self, node: &mut Node);
    /// Appends the sum's bits, [`NodeSum::WORDS`] words.
    fn push_words(&self, words: &mut Vec<u32>);
    /// The sum of [`NodeSum::push_words`].
    fn from_words(words: &[u32]) -> Self;
}

/// Whole nodes, for PIC/FLIP: mass, momentum and force summed and read.
impl NodeSum for Node {
    /// Momentum and mass, then the force: the force's fourth lane is not
    /// sent, as it only ever adds ±0 to a grid node's +0 (which stays +0).
    const WORDS: usize = 7;

    fn reached(&self) -> bool {
        self.mass() != 0.0
    }

    fn add_into(&self, node: &mut Node) {
        node.velocity_mass += self.velocity_mass;
        node.velocity_new += self.velocity_new;
    }

    fn push_words(&self, words: &mut Vec<u32>) {
        words.extend(self.velocity_mass.to_array().map(f32::to_bits));
        words.extend(self.velocity_new.truncate().to_array().map(f32::to_bits));
    }

    fn from_words(words: &[u32]) -> Node {
        let float = |i: usize| f32::from_bits(words[i]);
        Node {
            velocity_mass: Vec4::new(float(0), float(1), float(2), float(3)),
            velocity_new: Vec4::new(float(4), float(5), float(6), 0.0),
        }
    }
}

/// One vector per node, for APIC: momentum and mass while scattering
/// (and v_i^{n+1} while gathering).
impl NodeSum for Vec4 {
    const WORDS: usize = 4;

    fn reached(&self) -> bool {
        self.w != 0.0
    }

    fn add_into(&self, node: &mut Node) {
        node.velocity_mass += *self;
    }

    fn push_words(&self, words: &mut Vec<u32>) {
        words.extend(self.to_array().map(f32::to_bits));
    }

    fn from_words(words: &[u32]) -> Vec4 {
        Vec4::new(
            f32::from_bits(words[0]),
            f32::from_bits(words[1]),
            f32::from_bits(words[2]),
            f32::from_bits(words[3]),
        )
    }
}

/// Calls `run(to, from, len)` for each run of the nodes around a block
/// (the first at `first_node`) that is contiguous along z both in the copy
/// and in the grid: copy nodes `to..to + len` are the grid's nodes
/// `from..from + len`, or lie outside the grid where `from` is `None`.
/// Every block within one block of an occupied one has storage (see
/// [`crate::binning`]), so one slot lookup per neighbouring block finds all.
fn runs(first_node: IVec3, table: &PageTable, mut run: impl FnMut(usize, Option<usize>, usize)) {
    /// Per axis, in three parts: the neighbouring block (−1, 0, +1), the
    /// first node taken from it, the first place here and the number of
    /// nodes.
    const PARTS: [(i32, usize, usize, usize); 3] = [(-1, 3, 0, 1), (0, 0, 1, 4), (1, 0, 5, 2)];
    const WIDTH: usize = BLOCK_WIDTH as usize;
    let block = (first_node + IVec3::ONE) / BLOCK_WIDTH;
    let blocks = table.layout.blocks.as_ivec3();
    for (dx, from_x, to_x, len_x) in PARTS {
        for (dy, from_y, to_y, len_y) in PARTS {
            for (dz, from_z, to_z, len_z) in PARTS {
                let neighbour = block + IVec3::new(dx, dy, dz);
                let inside = neighbour.cmpge(IVec3::ZERO).all() && neighbour.cmplt(blocks).all();
                let first = inside.then(|| {
                    let slot = table
                        .slot(table.layout.block_index(neighbour))
                        .expect("the blocks around an occupied block have storage");
                    slot * BLOCK_NODES
                });
                for x in 0..len_x {
                    for y in 0..len_y {
                        let to = ((to_x + x) * REACH as usize + to_y + y) * REACH as usize + to_z;
                        let from = first.map(|first| {
                            first + ((from_x + x) * WIDTH + from_y + y) * WIDTH + from_z
                        });
                        run(to, from, len_z);
                    }
                }
            }
        }
    }
}
