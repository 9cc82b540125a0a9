//! OpenVDB volumes (`.vdb`): sparse float grids that Blender, Houdini and
//! every other OpenVDB reader load as volumes.
//!
//! No maintained Rust crate writes VDB files, so this module writes the
//! format itself, from OpenVDB's documentation of its file layout: file
//! version 224 (what OpenVDB 10 writes, read by Blender 3.4 and later), float
//! grids in the standard `Tree_float_5_4_3` tree (a root table of 32³
//! internal nodes, each of 16³ internal nodes, each of 8³ leaves), full
//! 32-bit floats, a uniform scale-and-translate transform in metres, and
//! active-mask compression (a node stores its active values only, plus what
//! rebuilds its inactive ones: ±background, or all values where they are
//! anything else). No zip or blosc: the data are stored as is.
//!
//! A [`FloatGrid`] holds only occupied 8³ leaves, and constant inactive 8³
//! tiles (a level set's inside); the internal nodes are made while writing.
//! The bytes depend only on the grids, so a run writes the same file twice
//! (the file's uuid is a hash of its grids).

use std::collections::BTreeMap;
use std::path::Path;

use crate::{IoError, write_atomically};

/// The file format version written (OpenVDB 10's).
pub const FILE_VERSION: u32 = 224;
/// The OpenVDB library version the file claims to come from (major, minor).
const LIBRARY_VERSION: (u32, u32) = (10, 0);
/// The file's first eight bytes, as a little-endian integer.
const MAGIC: i64 = 0x5644_4220;
/// The per-grid compression flags: active-mask compression only.
const COMPRESS_ACTIVE_MASK: u32 = 0x2;
/// The tree type of a float grid with the standard configuration.
const TREE_TYPE: &str = "Tree_float_5_4_3";
/// The transform type: a uniform scale followed by a translation.
const MAP_TYPE: &str = "UniformScaleTranslateMap";

/// Voxels along each edge of a leaf.
pub const LEAF_DIM: i32 = 8;
/// Voxels in a leaf.
pub const LEAF_VOXELS: usize = 512;
/// log2 of the voxels spanned by a leaf, a lower and an upper internal node.
const LEAF_LOG2: u32 = 3;
const LOWER_LOG2: u32 = LEAF_LOG2 + 4;
const UPPER_LOG2: u32 = LOWER_LOG2 + 5;

/// How the inactive values of one node are rebuilt by the reader (OpenVDB's
/// per-node metadata byte).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Inactive {
    /// All are +background.
    Background = 0,
    /// All are −background.
    MinusBackground = 1,
    /// A selection mask picks +background (bit on) or −background.
    Signs = 3,
    /// Anything else: every value is stored.
    Stored = 6,
}

/// What a grid stands for, as OpenVDB's `class` metadata says it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum GridClass {
    /// A density-like field that is 0 outside (`fog volume`).
    FogVolume,
    /// A narrow-band signed distance, negative inside (`level set`).
    LevelSet,
}

impl GridClass {
    /// The name OpenVDB stores in the grid's `class` metadata.
    pub fn name(self) -> &'static str {
        match self {
            GridClass::FogVolume => "fog volume",
            GridClass::LevelSet => "level set",
        }
    }
}

/// One 8³ block of voxels: a value and an active flag per voxel.
#[derive(Clone, Debug, PartialEq)]
pub struct Leaf {
    values: [f32; LEAF_VOXELS],
    active: [u64; LEAF_VOXELS / 64],
}

impl Leaf {
    /// A leaf of inactive voxels that all hold `value`.
    pub fn filled(value: f32) -> Leaf {
        Leaf {
            values: [value; LEAF_VOXELS],
            active: [0; LEAF_VOXELS / 64],
        }
    }

    /// The index of the voxel at `local` (each in 0..8) inside a leaf, z
    /// fastest, as OpenVDB orders them.
    pub fn offset(local: [i32; 3]) -> usize {
        ((local[0] << 6) | (local[1] << 3) | local[2]) as usize
    }

    /// The value of voxel `offset`.
    pub fn value(&self, offset: usize) -> f32 {
        self.values[offset]
    }

    /// Whether voxel `offset` is active.
    pub fn is_active(&self, offset: usize) -> bool {
        bit(&self.active, offset)
    }

    /// Sets voxel `offset` to `value`, active or not.
    pub fn set(&mut self, offset: usize, value: f32, active: bool) {
        self.values[offset] = value;
        set_bit(&mut self.active, offset, active);
    }

    /// Adds `value` to voxel `offset` and makes it active.
    pub fn add(&mut self, offset: usize, value: f32) {
        self.values[offset] += value;
        set_bit(&mut self.active, offset, true);
    }

    /// Number of active voxels.
    pub fn active_count(&self) -> u32 {
        self.active.iter().map(|word| word.count_ones()).sum()
    }
}

/// A sparse grid of float voxels with its name, class and placement.
///
/// Voxel `(i, j, k)` is centred at `origin + (i, j, k) · voxel_size` in
/// metres; voxels outside the leaves and tiles hold `background`.
#[derive(Clone, Debug)]
pub struct FloatGrid {
    /// The grid's name (`density`, `surface`).
    pub name: String,
    /// What the values stand for.
    pub class: GridClass,
    /// Edge length of a voxel in metres.
    pub voxel_size: f64,
    /// World position of voxel (0, 0, 0)'s centre, in metres.
    pub origin: [f64; 3],
    /// The value of every voxel no leaf or tile holds (0 for a fog volume,
    /// the narrow band's half width in metres for a level set).
    pub background: f32,
    leaves: BTreeMap<[i32; 3], Box<Leaf>>,
    tiles: BTreeMap<[i32; 3], f32>,
}

impl FloatGrid {
    /// An empty grid.
    pub fn new(
        name: impl Into<String>,
        class: GridClass,
        voxel_size: f64,
        origin: [f64; 3],
        background: f32,
    ) -> FloatGrid {
        FloatGrid {
            name: name.into(),
            class,
            voxel_size,
            origin,
            background,
            leaves: BTreeMap::new(),
            tiles: BTreeMap::new(),
        }
    }

    /// The origin (lowest voxel) of the leaf that holds voxel `ijk`.
    pub fn leaf_origin(ijk: [i32; 3]) -> [i32; 3] {
        ijk.map(|c| c & !(LEAF_DIM - 1))
    }

    /// The leaf that holds voxel `ijk`, made (inactive, at the background
    /// value) if there is none; it replaces a tile there.
    pub fn leaf_mut(&mut self, ijk: [i32; 3]) -> &mut Leaf {
        let origin = FloatGrid::leaf_origin(ijk);
        self.tiles.remove(&origin);
        let background = self.background;
        self.leaves
            .entry(origin)
            .or_insert_with(|| Box::new(Leaf::filled(background)))
    }

    /// The leaf that holds voxel `ijk`, if there is one.
    pub fn leaf(&self, ijk: [i32; 3]) -> Option<&Leaf> {
        self.leaves
            .get(&FloatGrid::leaf_origin(ijk))
            .map(|leaf| &**leaf)
    }

    /// Makes the 8³ block that holds voxel `ijk` an inactive tile of
    /// `value`, in place of any leaf there.
    pub fn set_tile(&mut self, ijk: [i32; 3], value: f32) {
        let origin = FloatGrid::leaf_origin(ijk);
        self.leaves.remove(&origin);
        self.tiles.insert(origin, value);
    }

    /// Removes the leaf or tile that holds voxel `ijk`.
    pub fn clear_block(&mut self, ijk: [i32; 3]) {
        let origin = FloatGrid::leaf_origin(ijk);
        self.leaves.remove(&origin);
        self.tiles.remove(&origin);
    }

    /// The value of voxel `ijk`.
    pub fn value(&self, ijk: [i32; 3]) -> f32 {
        let origin = FloatGrid::leaf_origin(ijk);
        if let Some(leaf) = self.leaves.get(&origin) {
            let local = [0, 1, 2].map(|axis| ijk[axis] - origin[axis]);
            return leaf.value(Leaf::offset(local));
        }
        self.tiles.get(&origin).copied().unwrap_or(self.background)
    }

    /// The leaves by origin, in order.
    pub fn leaves(&self) -> impl Iterator<Item = ([i32; 3], &Leaf)> {
        self.leaves.iter().map(|(origin, leaf)| (*origin, &**leaf))
    }

    /// The origins of the leaves, in order.
    pub fn leaf_origins(&self) -> Vec<[i32; 3]> {
        self.leaves.keys().copied().collect()
    }

    /// Number of active voxels.
    pub fn active_voxel_count(&self) -> u64 {
        self.leaves
            .values()
            .map(|leaf| u64::from(leaf.active_count()))
            .sum()
    }

    /// The lowest and highest active voxel, if any is active.
    pub fn active_bounds(&self) -> Option<([i32; 3], [i32; 3])> {
        let mut bounds: Option<([i32; 3], [i32; 3])> = None;
        for (origin, leaf) in self.leaves() {
            for offset in (0..LEAF_VOXELS).filter(|&offset| leaf.is_active(offset)) {
                let ijk = voxel_of(origin, offset);
                let (low, high) = bounds.get_or_insert((ijk, ijk));
                for axis in 0..3 {
                    low[axis] = low[axis].min(ijk[axis]);
                    high[axis] = high[axis].max(ijk[axis]);
                }
            }
        }
        bounds
    }
}

/// The voxel at `offset` in the leaf whose origin is `origin`.
pub fn voxel_of(origin: [i32; 3], offset: usize) -> [i32; 3] {
    let offset = offset as i32;
    [
        origin[0] + (offset >> 6),
        origin[1] + ((offset >> 3) & 7),
        origin[2] + (offset & 7),
    ]
}

/// Writes `grids` as one `.vdb` file at `path`, atomically.
pub fn write_vdb(path: &Path, grids: &[FloatGrid]) -> Result<(), IoError> {
    let bytes = encode_vdb(grids);
    write_atomically(path, |out| out.write_all(&bytes))
}

/// The bytes of a `.vdb` file holding `grids`.
pub fn encode_vdb(grids: &[FloatGrid]) -> Vec<u8> {
    let mut out = Bytes::default();
    out.i64(MAGIC);
    out.u32(FILE_VERSION);
    out.u32(LIBRARY_VERSION.0);
    out.u32(LIBRARY_VERSION.1);
    out.0.push(1); // the grids' offsets follow their descriptors
    let uuid_at = out.0.len();
    out.0.extend_from_slice(&[b'0'; 36]);
    out.u32(0); // no file-level metadata
    out.u32(grids.len() as u32);
    let grids_at = out.0.len();
    for grid in grids {
        write_grid(&mut out, grid);
    }
    let uuid = uuid_of(&out.0[grids_at..]);
    out.0[uuid_at..uuid_at + 36].copy_from_slice(uuid.as_bytes());
    out.0
}

/// A uuid-shaped hash of `bytes` (two 64-bit FNV-1a hashes), so that the
/// same grids give the same file.
fn uuid_of(bytes: &[u8]) -> String {
    let fnv = |basis: u64| {
        bytes.iter().fold(basis, |hash, &byte| {
            (hash ^ u64::from(byte)).wrapping_mul(0x0000_0100_0000_01b3)
        })
    };
    let high = fnv(0xcbf2_9ce4_8422_2325);
    let low = fnv(0x84222325_cbf29ce4);
    let hex = format!("{high:016x}{low:016x}");
    format!(
        "{}-{}-{}-{}-{}",
        &hex[0..8],
        &hex[8..12],
        &hex[12..16],
        &hex[16..20],
        &hex[20..32]
    )
}

/// One grid: its descriptor, offsets, metadata, transform, topology and
/// voxel values.
fn write_grid(out: &mut Bytes, grid: &FloatGrid) {
    out.string(&grid.name);
    out.string(TREE_TYPE);
    out.string(""); // not an instance of another grid
    let offsets_at = out.0.len();
    out.0.extend_from_slice(&[0; 24]);
    let grid_pos = out.0.len();
    out.u32(COMPRESS_ACTIVE_MASK);
    write_metadata(out, grid);
    write_transform(out, grid);
    let root = Root::of(grid);
    root.write_topology(out, grid.background);
    let block_pos = out.0.len();
    root.write_buffers(out, grid.background);
    let end_pos = out.0.len();
    for (slot, position) in [grid_pos, block_pos, end_pos].into_iter().enumerate() {
        let at = offsets_at + 8 * slot;
        out.0[at..at + 8].copy_from_slice(&(position as i64).to_le_bytes());
    }
}

/// The grid's metadata, sorted by name as OpenVDB keeps it.
fn write_metadata(out: &mut Bytes, grid: &FloatGrid) {
    let bounds = grid.active_bounds();
    out.u32(if bounds.is_some() { 6 } else { 4 });
    out.meta_string("class", grid.class.name());
    out.meta_string("creator", "firn");
    if let Some((low, high)) = bounds {
        out.meta_vec3i("file_bbox_max", high);
        out.meta_vec3i("file_bbox_min", low);
    }
    out.meta_header("file_voxel_count", "int64", 8);
    out.i64(grid.active_voxel_count() as i64);
    out.meta_string("name", &grid.name);
}

/// Index to world: a uniform scale by the voxel size, then a translation to
/// the origin; the map stores its derived inverses too.
fn write_transform(out: &mut Bytes, grid: &FloatGrid) {
    out.string(MAP_TYPE);
    let scale = grid.voxel_size;
    let vectors = [
        grid.origin,
        [scale; 3],
        [scale; 3],
        [1.0 / scale; 3],
        [1.0 / (scale * scale); 3],
        [0.5 / scale; 3],
    ];
    for value in vectors.into_iter().flatten() {
        out.0.extend_from_slice(&value.to_le_bytes());
    }
}

/// What fills one slot of a lower internal node.
enum Slot<'a> {
    Leaf(&'a Leaf),
    Tile(f32),
}

/// A 16³ internal node of 8³ leaves and tiles, by slot.
#[derive(Default)]
struct Lower<'a>(BTreeMap<usize, Slot<'a>>);

/// A 32³ internal node of lower nodes, by slot.
#[derive(Default)]
struct Upper<'a>(BTreeMap<usize, Lower<'a>>);

/// The root table: upper nodes by origin, in OpenVDB's (x, y, z) order.
struct Root<'a>(BTreeMap<[i32; 3], Upper<'a>>);

/// The slot of the child at `ijk` in an internal node spanning 2^`log2`
/// voxels whose children span 2^`child_log2`.
fn slot(ijk: [i32; 3], log2: u32, child_log2: u32) -> usize {
    let per_axis = log2 - child_log2;
    let mask = (1 << log2) - 1;
    let [x, y, z] = ijk.map(|c| ((c & mask) >> child_log2) as usize);
    (x << (2 * per_axis)) | (y << per_axis) | z
}

impl<'a> Root<'a> {
    /// The tree of `grid`'s leaves and tiles.
    fn of(grid: &'a FloatGrid) -> Root<'a> {
        let mut root = Root(BTreeMap::new());
        let leaves = grid
            .leaves
            .iter()
            .map(|(origin, leaf)| (*origin, Slot::Leaf(leaf)));
        let tiles = grid
            .tiles
            .iter()
            .map(|(origin, value)| (*origin, Slot::Tile(*value)));
        for (origin, content) in leaves.chain(tiles) {
            let upper = root
                .0
                .entry(origin.map(|c| c & !((1 << UPPER_LOG2) - 1)))
                .or_default();
            let lower = upper
                .0
                .entry(slot(origin, UPPER_LOG2, LOWER_LOG2))
                .or_default();
            lower.0.insert(slot(origin, LOWER_LOG2, LEAF_LOG2), content);
        }
        root
    }

    /// The tree's structure: the background, the root table, each internal
    /// node's masks and tile values, each leaf's active mask.
    fn write_topology(&self, out: &mut Bytes, background: f32) {
        out.i32(1); // one value buffer per leaf
        out.f32(background);
        out.u32(0); // no root tiles
        out.u32(self.0.len() as u32);
        for (origin, upper) in &self.0 {
            origin.iter().for_each(|&c| out.i32(c));
            upper.write_topology(out, background);
        }
    }

    /// Every leaf's active mask and values, in tree order.
    fn write_buffers(&self, out: &mut Bytes, background: f32) {
        let leaves = self.0.values().flat_map(|upper| upper.0.values());
        for slot in leaves.flat_map(|lower| lower.0.values()) {
            if let Slot::Leaf(leaf) = slot {
                out.words(&leaf.active);
                write_values(out, &leaf.values, &leaf.active, &[0; 8], background);
            }
        }
    }
}

impl Upper<'_> {
    const SLOTS: usize = 1 << (3 * (UPPER_LOG2 - LOWER_LOG2));

    fn write_topology(&self, out: &mut Bytes, background: f32) {
        let mut children = vec![0u64; Self::SLOTS / 64];
        let mut values = vec![background; Self::SLOTS];
        for &slot in self.0.keys() {
            set_bit(&mut children, slot, true);
            values[slot] = 0.0;
        }
        let inactive = vec![0u64; Self::SLOTS / 64];
        out.words(&children);
        out.words(&inactive);
        write_values(out, &values, &inactive, &children, background);
        for lower in self.0.values() {
            lower.write_topology(out, background);
        }
    }
}

impl Lower<'_> {
    const SLOTS: usize = 1 << (3 * (LOWER_LOG2 - LEAF_LOG2));

    fn write_topology(&self, out: &mut Bytes, background: f32) {
        let mut children = vec![0u64; Self::SLOTS / 64];
        let mut values = vec![background; Self::SLOTS];
        for (&slot, content) in &self.0 {
            match content {
                Slot::Leaf(_) => {
                    set_bit(&mut children, slot, true);
                    values[slot] = 0.0;
                }
                Slot::Tile(value) => values[slot] = *value,
            }
        }
        let inactive = vec![0u64; Self::SLOTS / 64];
        out.words(&children);
        out.words(&inactive);
        write_values(out, &values, &inactive, &children, background);
        for content in self.0.values() {
            if let Slot::Leaf(leaf) = content {
                out.words(&leaf.active);
            }
        }
    }
}

/// A node's values with active-mask compression: the metadata byte, a
/// selection mask where inactive values are of both signs, then the active
/// values only, or every value where the inactive ones are not ±background.
/// Slots holding a child (`children`) count as neither.
fn write_values(
    out: &mut Bytes,
    values: &[f32],
    active: &[u64],
    children: &[u64],
    background: f32,
) {
    let inactive = inactive_kind(values, active, children, background);
    out.0.push(inactive as u8);
    if inactive == Inactive::Stored {
        values.iter().for_each(|&value| out.f32(value));
        return;
    }
    if inactive == Inactive::Signs {
        let mut selection = vec![0u64; active.len()];
        for (index, &value) in values.iter().enumerate() {
            let outside = !bit(active, index) && value == background;
            set_bit(&mut selection, index, outside);
        }
        out.words(&selection);
    }
    for (index, &value) in values.iter().enumerate() {
        if bit(active, index) {
            out.f32(value);
        }
    }
}

/// How a reader can rebuild a node's inactive values.
fn inactive_kind(values: &[f32], active: &[u64], children: &[u64], background: f32) -> Inactive {
    let (mut plus, mut minus) = (false, false);
    for (index, &value) in values.iter().enumerate() {
        if bit(active, index) || bit(children, index) {
            continue;
        }
        if value == background {
            plus = true;
        } else if value == -background {
            minus = true;
        } else {
            return Inactive::Stored;
        }
    }
    match (plus, minus) {
        (true, true) => Inactive::Signs,
        (false, true) => Inactive::MinusBackground,
        _ => Inactive::Background,
    }
}

fn bit(words: &[u64], index: usize) -> bool {
    words[index >> 6] & (1 << (index & 63)) != 0
}

fn set_bit(words: &mut [u64], index: usize, on: bool) {
    let mask = 1u64 << (index & 63);
    if on {
        words[index >> 6] |= mask;
    } else {
        words[index >> 6] &= !mask;
    }
}

/// A little-endian byte sink with OpenVDB's string and metadata encodings.
#[derive(Default)]
struct Bytes(Vec<u8>);

impl Bytes {
    fn u32(&mut self, value: u32) {
        self.0.extend_from_slice(&value.to_le_bytes());
    }

    fn i32(&mut self, value: i32) {
        self.0.extend_from_slice(&value.to_le_bytes());
    }

    fn i64(&mut self, value: i64) {
        self.0.extend_from_slice(&value.to_le_bytes());
    }

    fn f32(&mut self, value: f32) {
        self.0.extend_from_slice(&value.to_le_bytes());
    }

    /// A bit mask as its 64-bit words.
    fn words(&mut self, words: &[u64]) {
        words
            .iter()
            .for_each(|word| self.0.extend_from_slice(&word.to_le_bytes()));
    }

    /// A string: its length as 32 bits, then its bytes.
    fn string(&mut self, text: &str) {
        self.u32(text.len() as u32);
        self.0.extend_from_slice(text.as_bytes());
    }

    /// A metadata entry's name, type and value size; the value follows.
    fn meta_header(&mut self, name: &str, type_name: &str, size: u32) {
        self.string(name);
        self.string(type_name);
        self.u32(size);
    }

    fn meta_string(&mut self, name: &str, value: &str) {
        self.meta_header(name, "string", value.len() as u32);
        self.0.extend_from_slice(value.as_bytes());
    }

    fn meta_vec3i(&mut self, name: &str, value: [i32; 3]) {
        self.meta_header(name, "vec3i", 12);
        value.iter().for_each(|&c| self.i32(c));
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn one_voxel_grid(ijk: [i32; 3], value: f32) -> FloatGrid {
        let mut grid = FloatGrid::new("density", GridClass::FogVolume, 0.5, [0.0; 3], 0.0);
        let origin = FloatGrid::leaf_origin(ijk);
        let local = [0, 1, 2].map(|axis| ijk[axis] - origin[axis]);
        grid.leaf_mut(ijk).add(Leaf::offset(local), value);
        grid
    }

    #[test]
    fn leaf_offsets_run_z_fastest() {
        assert_eq!(Leaf::offset([0, 0, 1]), 1);
        assert_eq!(Leaf::offset([0, 1, 0]), 8);
        assert_eq!(Leaf::offset([1, 0, 0]), 64);
        assert_eq!(voxel_of([8, -8, 0], 64 + 8 + 1), [9, -7, 1]);
    }

    #[test]
    fn slots_follow_openvdb_order() {
        assert_eq!(slot([8, 0, 0], LOWER_LOG2, LEAF_LOG2), 1 << 8);
        assert_eq!(slot([0, 8, 0], LOWER_LOG2, LEAF_LOG2), 1 << 4);
        assert_eq!(slot([0, 0, 8], LOWER_LOG2, LEAF_LOG2), 1);
        assert_eq!(slot([128, 0, 0], UPPER_LOG2, LOWER_LOG2), 1 << 10);
        assert_eq!(slot([-8, 0, 0], LOWER_LOG2, LEAF_LOG2), 15 << 8);
        assert_eq!(FloatGrid::leaf_origin([-1, 7, 8]), [-8, 0, 8]);
    }

    #[test]
    fn a_single_leaf_has_one_child_bit_per_level() {
        let grid = one_voxel_grid([1, 2, 3], 7.0);
        let bytes = encode_vdb(&[grid]);
        let topology = find(&bytes, MAP_TYPE.as_bytes()) + MAP_TYPE.len() + 18 * 8;
        // buffer count, background, root tiles, root children, child origin
        let root: Vec<i32> = (0..7)
            .map(|i| i32::from_le_bytes(bytes[topology + 4 * i..][..4].try_into().unwrap()))
            .collect();
        assert_eq!(root, [1, 0, 0, 1, 0, 0, 0]);
        let upper_children = &bytes[topology + 28..][..4096];
        assert_eq!(upper_children[0], 1);
        assert!(upper_children[1..].iter().all(|&b| b == 0));
        // the upper node's inactive mask and its one metadata byte (all background)
        let lower_at = topology + 28 + 2 * 4096 + 1;
        assert_eq!(bytes[lower_at - 1], Inactive::Background as u8);
        assert_eq!(bytes[lower_at], 1);
        assert!(bytes[lower_at + 1..lower_at + 512].iter().all(|&b| b == 0));
    }

    #[test]
    fn a_leaf_stores_only_its_active_values() {
        let grid = one_voxel_grid([1, 2, 3], 7.0);
        let bytes = encode_vdb(&[grid]);
        // the leaf's buffer ends the file: mask, metadata byte, one value
        let tail = &bytes[bytes.len() - 64 - 1 - 4..];
        let offset = Leaf::offset([1, 2, 3]);
        assert!(bit(
            &tail[..64]
                .chunks(8)
                .map(|w| u64::from_le_bytes(w.try_into().unwrap()))
                .collect::<Vec<_>>(),
            offset
        ));
        assert_eq!(tail[64], Inactive::Background as u8);
        assert_eq!(f32::from_le_bytes(tail[65..].try_into().unwrap()), 7.0);
    }

    #[test]
    fn inactive_values_pick_the_smallest_encoding() {
        let none = [0u64; 1];
        let kind = |values: &[f32]| inactive_kind(values, &none, &none, 3.0);
        assert_eq!(kind(&[3.0, 3.0]), Inactive::Background);
        assert_eq!(kind(&[-3.0, -3.0]), Inactive::MinusBackground);
        assert_eq!(kind(&[3.0, -3.0]), Inactive::Signs);
        assert_eq!(kind(&[3.0, 1.0]), Inactive::Stored);
        let child = [1u64];
        assert_eq!(
            inactive_kind(&[0.0, 3.0], &none, &child, 3.0),
            Inactive::Background
        );
    }

    #[test]
    fn tiles_replace_leaves_and_answer_values() {
        let mut grid = one_voxel_grid([1, 2, 3], 7.0);
        assert_eq!(grid.value([1, 2, 3]), 7.0);
        grid.set_tile([0, 0, 0], -2.0);
        assert_eq!(grid.value([1, 2, 3]), -2.0);
        assert_eq!(grid.active_voxel_count(), 0);
        assert_eq!(grid.value([100, 0, 0]), 0.0);
    }

    #[test]
    fn the_same_grids_give_the_same_bytes_and_header() {
        let a = encode_vdb(&[one_voxel_grid([-5, 9, 300], 1.5)]);
        let b = encode_vdb(&[one_voxel_grid([-5, 9, 300], 1.5)]);
        assert_eq!(a, b);
        assert_eq!(&a[..8], b" BDV\0\0\0\0");
        assert_eq!(u32::from_le_bytes(a[8..12].try_into().unwrap()), 224);
        let c = encode_vdb(&[one_voxel_grid([-5, 9, 300], 2.5)]);
        assert_ne!(a[21..57], c[21..57], "the uuid follows the content");
    }

    fn find(haystack: &[u8], needle: &[u8]) -> usize {
        haystack
            .windows(needle.len())
            .position(|window| window == needle)
            .expect("present")
    }
}
