//! Deforming mesh colliders on the GPU (`shaders/common/deforming.wgsl`):
//! the host builds each mesh frame's narrow band as the CPU does
//! ([`MeshSequenceCollider::field_of`]) and uploads the two of the current
//! interval into the collider's region of `collider_fields`, with the
//! interval's vertex velocities, when the run enters the interval.
//!
//! A region is sized before the run for the largest band of any frame
//! ([`MeshSequenceCollider::footprint`]): a header, the triangles (written
//! once), the vertex velocities, and two slots, each a band's header, its
//! frame's vertex positions, its table and its samples. A frame already in a slot stays there, so going from
//! interval (k, k + 1) to (k + 1, k + 2) uploads one band.
//!
//! `begin_step` places the colliders at the end of the next substep; when
//! a deforming collider's pose there falls in an interval that its region
//! does not hold, it stops the batch before the substep
//! ([`StepState::waiting`](super::layout::StepState)), and
//! [`ColliderBuffers::load_wanted_mesh_frames`] uploads the frames the poses
//! ask for, so the shaders always see the interval of their substep's time.

use firn_core::scene::{MeshSequenceCollider, SequenceInterval};
use firn_mesh::NarrowBandField;
use glam::Vec3;

use super::buffers::ColliderBuffers;
use crate::buffers::read_back;
use crate::context::GpuContext;
use crate::error::GpuError;

/// Words of a region's header (`REGION_*` in `deforming.wgsl`).
const REGION_HEADER: usize = 12;
/// Words of a slot's header (`SLOT_*` in `deforming.wgsl`).
const SLOT_HEADER: usize = 16;
/// The header's `from` and `to` before any frame is uploaded.
const NO_FRAME: u32 = u32::MAX;

/// One slot of a region: where it starts, how many words of table and
/// samples it can hold, and the mesh frame it holds.
#[derive(Debug)]
struct Slot {
    offset: u32,
    vertices: usize,
    capacity: usize,
    frame: Option<usize>,
}

/// Where one deforming collider's data lie in `collider_fields`, and which
/// mesh frames they hold.
#[derive(Debug)]
pub struct SequenceRegion {
    /// The collider's index among the packed colliders.
    collider: usize,
    sequence: MeshSequenceCollider,
    offset: u32,
    velocities: u32,
    slots: [Slot; 2],
    /// The interval (from, to) the header says the slots hold.
    loaded: Option<(usize, usize)>,
}

impl SequenceRegion {
    /// Appends the region of `sequence` (collider `collider`) to `fields`,
    /// sized for the largest band of any of its frames, with its triangles
    /// and empty slots (whose band says "far outside").
    pub fn reserve(
        collider: usize,
        sequence: &MeshSequenceCollider,
        fields: &mut Vec<u32>,
    ) -> SequenceRegion {
        // Four bytes a table entry, eight a sample: its words.
        let capacity = (sequence.footprint().0.bytes() / 4) as usize;
        let frames = sequence.frames.get();
        let vertices = frames.positions.first().map_or(0, Vec::len);
        let offset = fields.len();
        let triangles = offset + REGION_HEADER;
        let velocities = triangles + 3 * frames.triangles.len();
        let first_slot = velocities + 3 * vertices;
        let slot_words = SLOT_HEADER + 3 * vertices + capacity;
        let slots = [0, 1].map(|k| Slot {
            offset: word(first_slot + k * slot_words),
            vertices,
            capacity,
            frame: None,
        });
        fields.resize(first_slot + 2 * slot_words, 0);
        let header = [
            NO_FRAME,
            NO_FRAME,
            slots[0].offset,
            slots[0].offset,
            0,
            0,
            0,
            word(velocities),
            word(triangles),
        ];
        fields[offset..offset + header.len()].copy_from_slice(&header);
        fields[triangles..velocities].copy_from_slice(bytemuck::cast_slice(&frames.triangles));
        for slot in &slots {
            let start = slot.offset as usize;
            fields[start..start + SLOT_HEADER].copy_from_slice(&empty_slot_header(slot));
        }
        SequenceRegion {
            collider,
            sequence: sequence.clone(),
            offset: word(offset),
            velocities: word(velocities),
            slots,
            loaded: None,
        }
    }

    /// The region's first word in `collider_fields`.
    pub fn offset(&self) -> u32 {
        self.offset
    }

    /// Uploads the bands of mesh frames `from` and `to` that the slots do
    /// not hold yet, the interval's vertex velocities and the header;
    /// returns whether the interval was new.
    fn load(
        &mut self,
        context: &GpuContext,
        buffer: &wgpu::Buffer,
        (from, to): (usize, usize),
    ) -> bool {
        if self.loaded == Some((from, to)) {
            return false;
        }
        let from_slot = self.slot_holding(context, buffer, from, to);
        let to_slot = self.slot_holding(context, buffer, to, from);
        let interval = SequenceInterval {
            from,
            to,
            fraction: 0.0,
        };
        let velocities = self.sequence.vertex_velocities(interval);
        let sum: Vec3 = velocities.iter().sum();
        let mean = sum / velocities.len().max(1) as f32;
        write_words(context, buffer, self.velocities, &vector_words(&velocities));
        let header = [
            word(from),
            word(to),
            from_slot,
            to_slot,
            mean.x.to_bits(),
            mean.y.to_bits(),
            mean.z.to_bits(),
        ];
        write_words(context, buffer, self.offset, &header);
        self.loaded = Some((from, to));
        true
    }

    /// The offset of a slot holding mesh frame `frame`'s band, uploading it
    /// into a slot that does not hold frame `keep` when none holds it.
    fn slot_holding(
        &mut self,
        context: &GpuContext,
        buffer: &wgpu::Buffer,
        frame: usize,
        keep: usize,
    ) -> u32 {
        if let Some(slot) = self.slots.iter().find(|s| s.frame == Some(frame)) {
            return slot.offset;
        }
        let field = self.sequence.field_of(frame);
        let slot = self
            .slots
            .iter_mut()
            .find(|s| s.frame != Some(keep) || frame == keep)
            .expect("two slots, one of them without the other frame");
        write_band(context, buffer, slot, &field);
        slot.frame = Some(frame);
        slot.offset
    }
}

/// The header of a slot without a band: no bricks, and a band so wide that
/// every point is far outside.
fn empty_slot_header(slot: &Slot) -> [u32; SLOT_HEADER] {
    let mut header = [0; SLOT_HEADER];
    header[3] = 1.0f32.to_bits();
    header[7] = f32::MAX.to_bits();
    let (positions, table) = slot_parts(slot);
    header[11] = table;
    header[12] = table;
    header[13] = positions;
    header
}

/// The first words of a slot's vertex positions and of its table (its
/// samples follow the table).
fn slot_parts(slot: &Slot) -> (u32, u32) {
    let positions = slot.offset as usize + SLOT_HEADER;
    (word(positions), word(positions + 3 * slot.vertices))
}

/// Writes `field` (a band, its table, samples and its frame's vertices)
/// into `slot`.
fn write_band(context: &GpuContext, buffer: &wgpu::Buffer, slot: &Slot, field: &NarrowBandField) {
    let samples: Vec<u32> = field
        .samples()
        .flat_map(|(distance, triangle)| [distance.to_bits(), triangle])
        .collect();
    assert!(
        field.table().len() + samples.len() <= slot.capacity,
        "a mesh frame's band outgrew its footprint"
    );
    let (positions, table) = slot_parts(slot);
    let samples_at = table + word(field.table().len());
    let (origin, bricks, centre) = (field.origin(), field.bricks(), field.centre());
    let header = [
        origin.x.to_bits(),
        origin.y.to_bits(),
        origin.z.to_bits(),
        field.spacing().to_bits(),
        bricks.x,
        bricks.y,
        bricks.z,
        field.band().to_bits(),
        centre.x.to_bits(),
        centre.y.to_bits(),
        centre.z.to_bits(),
        table,
        samples_at,
        positions,
    ];
    write_words(context, buffer, slot.offset, &header);
    write_words(context, buffer, table, field.table());
    write_words(context, buffer, samples_at, &samples);
    write_words(
        context,
        buffer,
        positions,
        &vector_words(&field.mesh().vertices),
    );
}

/// Vectors as words, three a vector.
fn vector_words(vectors: &[Vec3]) -> Vec<u32> {
    vectors
        .iter()
        .flat_map(|v| v.to_array().map(f32::to_bits))
        .collect()
}

fn write_words(context: &GpuContext, buffer: &wgpu::Buffer, offset: u32, words: &[u32]) {
    if !words.is_empty() {
        let bytes = 4 * u64::from(offset);
        context
            .queue
            .write_buffer(buffer, bytes, bytemuck::cast_slice(words));
    }
}

/// A word offset or count that fits the shaders' u32 words.
fn word(value: usize) -> u32 {
    u32::try_from(value).expect("the colliders' fields pass 2^32 words")
}

/// The interval a pose's code (`SequenceInterval` in `deforming.wgsl`,
/// 2 from + (to − from)) names.
fn decode(code: f32) -> (usize, usize) {
    let code = code as usize;
    (code / 2, code / 2 + code % 2)
}

impl ColliderBuffers {
    /// Uploads, for every deforming collider, the bands of the mesh frames
    /// around simulated `time` ([`MeshSequenceCollider::interval_at`]), as
    /// a run does when it enters their interval.
    pub fn load_mesh_frames(&mut self, context: &GpuContext, time: f64) {
        for region in &mut self.sequences {
            let interval = region.sequence.interval_at(time);
            region.load(context, &self.fields, (interval.from, interval.to));
        }
    }

    /// Uploads the mesh frames that the deforming colliders' poses, as the
    /// last `begin_step` placed them, ask for; returns whether any was new.
    pub(super) fn load_wanted_mesh_frames(
        &mut self,
        context: &GpuContext,
    ) -> Result<bool, GpuError> {
        let Some(last) = self.sequences.iter().map(|r| r.collider).max() else {
            return Ok(false);
        };
        let poses = read_back::<[f32; 4]>(context, &[(&self.poses, 4 * (last + 1))])?.remove(0);
        let mut loaded = false;
        for region in &mut self.sequences {
            // The code is the w of the pose's fourth vector.
            let wanted = decode(poses[4 * region.collider + 3][3]);
            loaded |= region.load(context, &self.fields, wanted);
        }
        Ok(loaded)
    }
}
