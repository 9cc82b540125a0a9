//! Bindings named in one place. Each bind group of a program is one table,
//! written once with the crate's `bind_group!` macro (in `snow/bindings.rs`
//! and `flow/bindings.rs`): every binding's number, name, WGSL type and
//! access. From that table come
//!
//! - the WGSL declarations `@group(G) @binding(N) var<...> name: type;`
//!   that the program text gets ([`BindGroupTable::declarations`], placed by
//!   [`Part::Bindings`](crate::shaders::Part::Bindings)), so no `.wgsl` file
//!   declares a binding by hand;
//! - the bind group layout's entries ([`BindGroupTable::layout_entries`]);
//! - a struct with one buffer field per binding, whose `bind_group` method
//!   binds each field at its number: a bind group is built from named
//!   buffers, never from a list matched by position.
//!
//! `tests/bindings.rs` holds the declarations the WGSL front end reads back
//! to the layout entries.

/// How the kernels may use a buffer binding.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Access {
    /// `var<uniform>`: a uniform buffer.
    Uniform,
    /// `var<storage, read>`: a storage buffer the kernels only read.
    Read,
    /// `var<storage, read_write>`: a storage buffer the kernels may write.
    ReadWrite,
}

impl Access {
    /// The WGSL address space and access between `var<` and `>`.
    pub fn wgsl(self) -> &'static str {
        match self {
            Access::Uniform => "uniform",
            Access::Read => "storage, read",
            Access::ReadWrite => "storage, read_write",
        }
    }

    /// The buffer binding type of a layout entry.
    pub fn buffer_binding_type(self) -> wgpu::BufferBindingType {
        match self {
            Access::Uniform => wgpu::BufferBindingType::Uniform,
            Access::Read => wgpu::BufferBindingType::Storage { read_only: true },
            Access::ReadWrite => wgpu::BufferBindingType::Storage { read_only: false },
        }
    }
}

/// One buffer binding of a bind group.
#[derive(Clone, Copy, Debug)]
pub struct Binding {
    /// The binding number, `@binding(N)`.
    pub number: u32,
    /// The variable's name in WGSL (and the buffer field's name in Rust).
    pub name: &'static str,
    /// The WGSL type of the variable.
    pub ty: &'static str,
    /// How the kernels may use it.
    pub access: Access,
    /// What it holds, one line per line of the Rust doc comment.
    pub doc: &'static str,
}

/// The bindings of one bind group of a program.
#[derive(Clone, Copy, Debug)]
pub struct BindGroupTable {
    /// The label of the layout and bind groups.
    pub label: &'static str,
    /// The group number, `@group(G)`.
    pub group: u32,
    /// The bindings, in the order they are listed.
    pub bindings: &'static [Binding],
}

impl BindGroupTable {
    /// The WGSL declarations of every binding, each after its doc as comments.
    pub fn declarations(&self) -> String {
        let mut text = String::new();
        for binding in self.bindings {
            for line in binding.doc.lines() {
                text += &format!("//{line}\n");
            }
            text += &format!(
                "@group({}) @binding({}) var<{}> {}: {};\n",
                self.group,
                binding.number,
                binding.access.wgsl(),
                binding.name,
                binding.ty
            );
        }
        text
    }

    /// The layout entries of every binding, visible to compute shaders.
    pub fn layout_entries(&self) -> Vec<wgpu::BindGroupLayoutEntry> {
        self.bindings
            .iter()
            .map(|binding| wgpu::BindGroupLayoutEntry {
                binding: binding.number,
                visibility: wgpu::ShaderStages::COMPUTE,
                ty: wgpu::BindingType::Buffer {
                    ty: binding.access.buffer_binding_type(),
                    has_dynamic_offset: false,
                    min_binding_size: None,
                },
                count: None,
            })
            .collect()
    }

    /// The bind group layout of this table on `device`.
    pub fn layout(&self, device: &wgpu::Device) -> wgpu::BindGroupLayout {
        device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some(self.label),
            entries: &self.layout_entries(),
        })
    }

    /// The bind group layout of the bindings `numbers` of this table only
    /// (one kernel's, [`crate::shaders::Reflection::bindings`]).
    pub fn layout_of(&self, device: &wgpu::Device, numbers: &[u32]) -> wgpu::BindGroupLayout {
        let entries: Vec<_> = self
            .layout_entries()
            .into_iter()
            .filter(|entry| numbers.contains(&entry.binding))
            .collect();
        device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some(self.label),
            entries: &entries,
        })
    }
}

/// Declares a bind group's table and its struct of named buffers:
///
/// ```ignore
/// bind_group! {
///     /// Doc of the struct.
///     pub struct FieldBindings("flow field", group 0) {
///         /// Doc of the binding (also the WGSL comment above it).
///         0 => field_constants: Uniform "FieldConstants",
///         1 => obstacles: Read "array<Obstacle>",
///     }
/// }
/// ```
///
/// makes `FieldBindings<'a>` with one `&'a wgpu::Buffer` field per binding,
/// its table `FieldBindings::TABLE` ([`BindGroupTable`]) and
/// `FieldBindings::bind_group`, which binds each field at its number.
macro_rules! bind_group {
    (
        $(#[$meta:meta])*
        $vis:vis struct $name:ident($label:literal, group $group:literal) {
            $(
                $(#[doc = $doc:literal])*
                $number:literal => $field:ident: $access:ident $ty:literal,
            )*
        }
    ) => {
        $(#[$meta])*
        $vis struct $name<'a> {
            $(
                $(#[doc = $doc])*
                pub $field: &'a wgpu::Buffer,
            )*
        }

        impl $name<'_> {
            /// The table these buffers bind by: numbers, names, WGSL types
            /// and access.
            pub const TABLE: $crate::bindings::BindGroupTable = $crate::bindings::BindGroupTable {
                label: $label,
                group: $group,
                bindings: &[$(
                    $crate::bindings::Binding {
                        number: $number,
                        name: stringify!($field),
                        ty: $ty,
                        access: $crate::bindings::Access::$access,
                        doc: concat!($($doc, "\n",)*),
                    },
                )*],
            };

            /// A bind group of these buffers, each at its binding, for
            /// `layout` (made from [`Self::TABLE`]).
            pub fn bind_group(
                &self,
                device: &wgpu::Device,
                layout: &wgpu::BindGroupLayout,
            ) -> wgpu::BindGroup {
                self.bind_group_of(device, layout, &[$($number,)*])
            }

            /// A bind group of the buffers at `numbers` only, for `layout`
            /// (made by [`BindGroupTable::layout_of`](crate::bindings::BindGroupTable::layout_of)
            /// with the same numbers).
            pub fn bind_group_of(
                &self,
                device: &wgpu::Device,
                layout: &wgpu::BindGroupLayout,
                numbers: &[u32],
            ) -> wgpu::BindGroup {
                let all = [$(($number, self.$field),)*];
                let entries: Vec<_> = all
                    .iter()
                    .filter(|(number, _)| numbers.contains(number))
                    .map(|(number, buffer)| wgpu::BindGroupEntry {
                        binding: *number,
                        resource: buffer.as_entire_binding(),
                    })
                    .collect();
                device.create_bind_group(&wgpu::BindGroupDescriptor {
                    label: Some($label),
                    layout,
                    entries: &entries,
                })
            }
        }
    };
}

pub(crate) use bind_group;

#[cfg(test)]
mod tests {
    use crate::flow::bindings::ProbeBindings;

    #[test]
    fn declarations_carry_numbers_names_types_access_and_docs() {
        let text = ProbeBindings::TABLE.declarations();
        let lines: Vec<&str> = text.lines().collect();
        assert!(
            lines.len() > 2
                && lines
                    .iter()
                    .all(|line| line.starts_with("//") || line.starts_with('@'))
        );
        assert!(
            lines.contains(&"@group(1) @binding(0) var<storage, read> probe_input: array<u32>;")
        );
        assert!(
            lines.contains(
                &"@group(1) @binding(1) var<storage, read_write> probe_output: array<f32>;"
            )
        );
    }

    #[test]
    fn layout_entries_follow_the_table() {
        let entries = ProbeBindings::TABLE.layout_entries();
        let numbers: Vec<u32> = entries.iter().map(|entry| entry.binding).collect();
        assert_eq!(numbers, [0, 1]);
        assert!(matches!(
            entries[1].ty,
            wgpu::BindingType::Buffer {
                ty: wgpu::BufferBindingType::Storage { read_only: false },
                ..
            }
        ));
    }
}
