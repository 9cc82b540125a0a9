//! The particle data of one output frame, borrowed from the solver.
//!
//! Writers only read the data, so a frame holds slices into the solver's own
//! arrays, and a quantity the solver does not store (a particle's density)
//! is computed a particle at a time while it is written; producing a cache
//! costs no copy of the particle state, only buffers of [`CHUNK_VALUES`].

use glam::Vec3;

/// One frame's particles: positions plus any number of named per-particle
/// attributes, all borrowed.
#[derive(Debug, Clone)]
pub struct FrameData<'a> {
    /// Frame number, used in file comments and names.
    pub index: u32,
    /// Simulation time of the frame in seconds.
    pub time: f64,
    /// Particle positions; their count defines the frame's particle count.
    pub positions: &'a [Vec3],
    /// Per-particle attributes, each with one value per position.
    pub attributes: Vec<Attribute<'a>>,
}

/// A named per-particle quantity such as "velocity", "jp" or "density".
#[derive(Debug, Clone)]
pub struct Attribute<'a> {
    /// Name written to the cache files; ASCII letters, digits, `_`, `-` and `.` only.
    pub name: String,
    /// The values, one per particle.
    pub values: AttributeValues<'a>,
}

/// The borrowed values of an attribute, by kind.
#[derive(Debug, Clone, Copy)]
pub enum AttributeValues<'a> {
    /// One float per particle (e.g. density, plastic volume ratio).
    Scalar(Values<'a, f32>),
    /// One 3-vector per particle (e.g. velocity).
    Vector(Values<'a, Vec3>),
    /// One unsigned integer per particle (e.g. material or emitter id).
    Integer(Values<'a, u32>),
}

/// Values a writer takes at a time: computed values are made into a buffer
/// of this many, stored ones lent in slices of this many.
pub const CHUNK_VALUES: usize = 16 * 1024;

/// One value per particle: an array the caller holds, or values computed
/// from the caller's arrays one particle at a time as they are written, so
/// that no array of them is made.
#[derive(Clone, Copy)]
pub enum Values<'a, T> {
    /// The caller's array.
    Stored(&'a [T]),
    /// `len` values, particle `p`'s being `value(p)`.
    Computed {
        /// Number of values (particles).
        len: usize,
        /// The value of a particle, by index.
        value: &'a (dyn Fn(usize) -> T + Sync),
    },
}

impl<T: Copy> Values<'_, T> {
    /// Number of values (particles).
    pub fn len(&self) -> usize {
        match self {
            Self::Stored(values) => values.len(),
            Self::Computed { len, .. } => *len,
        }
    }

    /// Whether there are no values.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The value of particle `index` (which must be below [`Values::len`]).
    pub fn get(&self, index: usize) -> T {
        match self {
            Self::Stored(values) => values[index],
            Self::Computed { value, .. } => value(index),
        }
    }

    /// Hands every value to `take` in order, at most [`CHUNK_VALUES`] at a
    /// time: slices of a stored array, or one buffer refilled with the
    /// computed values of each chunk. Stops at the first error.
    pub fn try_for_each_chunk<E>(
        &self,
        mut take: impl FnMut(&[T]) -> Result<(), E>,
    ) -> Result<(), E> {
        match self {
            Self::Stored(values) => values.chunks(CHUNK_VALUES).try_for_each(take),
            Self::Computed { len, value } => {
                let mut buffer = Vec::with_capacity(CHUNK_VALUES.min(*len));
                for start in (0..*len).step_by(CHUNK_VALUES) {
                    buffer.clear();
                    buffer.extend((start..(start + CHUNK_VALUES).min(*len)).map(value));
                    take(&buffer)?;
                }
                Ok(())
            }
        }
    }
}

impl<T: std::fmt::Debug> std::fmt::Debug for Values<'_, T> {
    fn fmt(&self, formatter: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::Stored(values) => formatter.debug_tuple("Stored").field(values).finish(),
            Self::Computed { len, .. } => formatter
                .debug_struct("Computed")
                .field("len", len)
                .finish_non_exhaustive(),
        }
    }
}

/// Why a frame cannot be written.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum FrameError {
    /// An attribute's value count differs from the particle count.
    #[error("attribute `{name}` has {found} values but the frame has {expected} particles")]
    AttributeLength {
        /// The attribute's name.
        name: String,
        /// How many values it has.
        found: usize,
        /// How many particles the frame has.
        expected: usize,
    },
    /// An attribute name would break one of the file formats.
    #[error("attribute name `{name}` is not allowed: use ASCII letters, digits, `_`, `-` or `.`")]
    InvalidName {
        /// The rejected name.
        name: String,
    },
    /// Two attributes (or their file-level columns) share a name.
    #[error("the name `{name}` is used twice")]
    DuplicateName {
        /// The repeated name.
        name: String,
    },
}

impl<'a> FrameData<'a> {
    /// A frame with the given positions and no attributes yet.
    pub fn new(index: u32, time: f64, positions: &'a [Vec3]) -> Self {
        Self {
            index,
            time,
            positions,
            attributes: Vec::new(),
        }
    }

    /// Adds an attribute, builder style.
    pub fn with_attribute(mut self, attribute: Attribute<'a>) -> Self {
        self.attributes.push(attribute);
        self
    }

    /// Number of particles in the frame.
    pub fn particle_count(&self) -> usize {
        self.positions.len()
    }

    /// Checks that every attribute has one value per particle and a usable,
    /// unique name; writers call this before touching the disk.
    pub fn validate(&self) -> Result<(), FrameError> {
        for (position, attribute) in self.attributes.iter().enumerate() {
            attribute.validate_name()?;
            self.check_length(attribute)?;
            if self.attributes[..position]
                .iter()
                .any(|earlier| earlier.name == attribute.name)
            {
                return Err(FrameError::DuplicateName {
                    name: attribute.name.clone(),
                });
            }
        }
        Ok(())
    }

    fn check_length(&self, attribute: &Attribute) -> Result<(), FrameError> {
        let found = attribute.values.len();
        let expected = self.particle_count();
        if found == expected {
            Ok(())
        } else {
            Err(FrameError::AttributeLength {
                name: attribute.name.clone(),
                found,
                expected,
            })
        }
    }
}

impl<'a> Attribute<'a> {
    /// A scalar attribute.
    pub fn scalar(name: impl Into<String>, values: &'a [f32]) -> Self {
        Self::new(name, AttributeValues::Scalar(Values::Stored(values)))
    }

    /// A 3-vector attribute.
    pub fn vector(name: impl Into<String>, values: &'a [Vec3]) -> Self {
        Self::new(name, AttributeValues::Vector(Values::Stored(values)))
    }

    /// An unsigned integer attribute.
    pub fn integer(name: impl Into<String>, values: &'a [u32]) -> Self {
        Self::new(name, AttributeValues::Integer(Values::Stored(values)))
    }

    /// A scalar attribute of `len` particles, particle `p`'s computed as
    /// `value(p)` while the frame is written.
    pub fn computed_scalar(
        name: impl Into<String>,
        len: usize,
        value: &'a (dyn Fn(usize) -> f32 + Sync),
    ) -> Self {
        Self::new(
            name,
            AttributeValues::Scalar(Values::Computed { len, value }),
        )
    }

    /// An unsigned integer attribute of `len` particles, particle `p`'s
    /// computed as `value(p)` while the frame is written.
    pub fn computed_integer(
        name: impl Into<String>,
        len: usize,
        value: &'a (dyn Fn(usize) -> u32 + Sync),
    ) -> Self {
        Self::new(
            name,
            AttributeValues::Integer(Values::Computed { len, value }),
        )
    }

    fn new(name: impl Into<String>, values: AttributeValues<'a>) -> Self {
        Self {
            name: name.into(),
            values,
        }
    }

    fn validate_name(&self) -> Result<(), FrameError> {
        if is_portable_name(&self.name) {
            Ok(())
        } else {
            Err(FrameError::InvalidName {
                name: self.name.clone(),
            })
        }
    }
}

impl AttributeValues<'_> {
    /// Number of values (particles) held.
    pub fn len(&self) -> usize {
        match self {
            Self::Scalar(values) => values.len(),
            Self::Vector(values) => values.len(),
            Self::Integer(values) => values.len(),
        }
    }

    /// Whether no values are held.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
}

/// Names must survive as PLY header tokens and XML attribute values unescaped.
fn is_portable_name(name: &str) -> bool {
    !name.is_empty()
        && name
            .bytes()
            .all(|byte| byte.is_ascii_alphanumeric() || matches!(byte, b'_' | b'-' | b'.'))
}

#[cfg(test)]
mod tests {
    use super::*;

    const POSITIONS: [Vec3; 2] = [Vec3::ZERO, Vec3::ONE];

    #[test]
    fn a_consistent_frame_is_valid() {
        let density = [1.0, 2.0];
        let velocity = [Vec3::X, Vec3::Y];
        let frame = FrameData::new(0, 0.0, &POSITIONS)
            .with_attribute(Attribute::scalar("density", &density))
            .with_attribute(Attribute::vector("velocity", &velocity));
        assert_eq!(frame.validate(), Ok(()));
    }

    #[test]
    fn a_short_attribute_is_an_error() {
        let jp = [1.0];
        let frame = FrameData::new(0, 0.0, &POSITIONS).with_attribute(Attribute::scalar("jp", &jp));
        let error = frame.validate().unwrap_err();
        assert_eq!(
            error.to_string(),
            "attribute `jp` has 1 values but the frame has 2 particles"
        );
    }

    #[test]
    fn names_with_spaces_or_markup_are_rejected() {
        let ids = [0, 1];
        for bad in ["", "my attr", "a\"b", "<x>"] {
            let frame =
                FrameData::new(0, 0.0, &POSITIONS).with_attribute(Attribute::integer(bad, &ids));
            assert!(
                matches!(frame.validate(), Err(FrameError::InvalidName { .. })),
                "{bad:?}"
            );
        }
    }

    #[test]
    fn computed_values_come_in_chunks_in_order() {
        let len = 2 * CHUNK_VALUES + 3;
        let square = |p: usize| (p * p) as u32;
        let values = Values::Computed {
            len,
            value: &square,
        };
        let mut seen = Vec::new();
        let mut sizes = Vec::new();
        values
            .try_for_each_chunk(|chunk| {
                sizes.push(chunk.len());
                seen.extend_from_slice(chunk);
                Ok::<(), ()>(())
            })
            .unwrap();
        assert_eq!(sizes, [CHUNK_VALUES, CHUNK_VALUES, 3]);
        assert_eq!(seen, (0..len).map(square).collect::<Vec<_>>());
        assert_eq!(values.get(7), 49);
        let frame = FrameData::new(0, 0.0, &POSITIONS)
            .with_attribute(Attribute::computed_integer("square", 2, &square));
        assert_eq!(frame.validate(), Ok(()));
    }

    #[test]
    fn duplicate_names_are_rejected() {
        let ids = [0, 1];
        let frame = FrameData::new(0, 0.0, &POSITIONS)
            .with_attribute(Attribute::integer("id", &ids))
            .with_attribute(Attribute::integer("id", &ids));
        assert!(matches!(
            frame.validate(),
            Err(FrameError::DuplicateName { .. })
        ));
    }
}
