//! The bind group tables agree with the programs they declare bindings for,
//! read back by naga from each program's text (no adapter needed): every
//! binding a program declares is in its table's layout entries with the
//! same name and access, every table entry is declared, no `.wgsl` file
//! declares a binding by hand, and the adapter requirements
//! (`MIN_STORAGE_BUFFERS`, `MIN_BUFFERS`) are what the largest kernel binds.

use std::collections::BTreeMap;

use firn_gpu::bindings::BindGroupTable;
use firn_gpu::context::{MIN_BUFFERS, MIN_STORAGE_BUFFERS};
use firn_gpu::shaders::{BufferKind, PROGRAMS, Part, Program, SNOW_STEP};
use firn_gpu::snow::bindings::StepBindings;

/// A declared binding as naga reads it: its name and the buffer type a
/// layout entry must have for it.
struct Declared {
    name: String,
    ty: wgpu::BufferBindingType,
}

/// The bindings `program` declares, by (group, binding).
fn declared(program: &Program) -> BTreeMap<(u32, u32), Declared> {
    let source = program.source();
    let module = naga::front::wgsl::parse_str(&source)
        .unwrap_or_else(|error| panic!("{}: {}", program.name, error.emit_to_string(&source)));
    module
        .global_variables
        .iter()
        .filter_map(|(_, global)| {
            let binding = global.binding.as_ref()?;
            let ty = match global.space {
                naga::AddressSpace::Uniform => wgpu::BufferBindingType::Uniform,
                naga::AddressSpace::Storage { access } => wgpu::BufferBindingType::Storage {
                    read_only: !access.contains(naga::StorageAccess::STORE),
                },
                other => panic!("{}: unexpected binding space {other:?}", program.name),
            };
            let name = global.name.clone().unwrap_or_default();
            Some(((binding.group, binding.binding), Declared { name, ty }))
        })
        .collect()
}

/// The buffer type of the layout entry of `number` in `table`.
fn layout_type(table: &BindGroupTable, number: u32) -> Option<wgpu::BufferBindingType> {
    table
        .layout_entries()
        .into_iter()
        .find(|entry| entry.binding == number)
        .map(|entry| match entry.ty {
            wgpu::BindingType::Buffer { ty, .. } => ty,
            other => panic!(
                "{}: binding {number} is not a buffer: {other:?}",
                table.label
            ),
        })
}

#[test]
fn every_declared_binding_is_in_the_layout_with_its_access() {
    for program in PROGRAMS {
        let tables: Vec<&BindGroupTable> = program.tables().collect();
        let declared = declared(program);
        assert!(!declared.is_empty(), "{} binds nothing", program.name);
        for (&(group, number), binding) in &declared {
            let table = tables
                .iter()
                .find(|table| table.group == group)
                .unwrap_or_else(|| panic!("{}: no table for group {group}", program.name));
            let entry = table
                .bindings
                .iter()
                .find(|entry| entry.number == number)
                .unwrap_or_else(|| {
                    panic!(
                        "{}: {} (@group({group}) @binding({number})) is not in {}",
                        program.name, binding.name, table.label
                    )
                });
            assert_eq!(
                entry.name, binding.name,
                "{}: binding {number}",
                table.label
            );
            assert_eq!(
                layout_type(table, number),
                Some(binding.ty),
                "{}: {} is declared {:?} but laid out otherwise",
                program.name,
                binding.name,
                binding.ty
            );
        }
        for table in &tables {
            for entry in table.bindings {
                assert!(
                    declared.contains_key(&(table.group, entry.number)),
                    "{}: {} of {} is not declared",
                    program.name,
                    entry.name,
                    table.label
                );
            }
        }
    }
}

#[test]
fn tables_have_one_entry_per_number_and_name() {
    for table in PROGRAMS.iter().flat_map(Program::tables) {
        let mut numbers: Vec<u32> = table.bindings.iter().map(|entry| entry.number).collect();
        let mut names: Vec<&str> = table.bindings.iter().map(|entry| entry.name).collect();
        numbers.sort_unstable();
        names.sort_unstable();
        numbers.dedup();
        names.dedup();
        assert_eq!(numbers.len(), table.bindings.len(), "{}", table.label);
        assert_eq!(names.len(), table.bindings.len(), "{}", table.label);
    }
}

#[test]
fn no_wgsl_file_declares_a_binding_by_hand() {
    for program in PROGRAMS {
        for part in program.parts {
            if let Part::File(file, text) = part {
                assert!(
                    !text.contains("@binding"),
                    "{file} declares a binding; add it to its table in src/*/bindings.rs"
                );
            }
        }
    }
}

#[test]
fn a_group_is_declared_by_one_table_per_program() {
    for program in PROGRAMS {
        let mut groups: Vec<u32> = program.tables().map(|table| table.group).collect();
        let count = groups.len();
        groups.sort_unstable();
        groups.dedup();
        assert_eq!(groups.len(), count, "{}", program.name);
    }
}

/// The buffers of `tables`: (storage, storage and uniform together).
fn buffer_counts<'a>(tables: impl Iterator<Item = &'a BindGroupTable>) -> (u32, u32) {
    tables.flat_map(|table| table.layout_entries()).fold(
        (0, 0),
        |(storage, all), entry| match entry.ty {
            wgpu::BindingType::Buffer {
                ty: wgpu::BufferBindingType::Storage { .. },
                ..
            } => (storage + 1, all + 1),
            _ => (storage, all + 1),
        },
    )
}

/// The adapter requirements are what the largest kernel binds: the snow
/// step's kernels each bind only the buffers naga finds they use
/// (`snow/program.rs`); the other programs bind their whole tables.
#[test]
fn the_adapter_requirements_are_the_largest_kernels_buffers() {
    let mut most = (0, 0);
    for program in PROGRAMS {
        if program.name == SNOW_STEP.name {
            for (_, used) in program.reflect().entry_points() {
                let storage = used
                    .iter()
                    .filter(|binding| binding.kind == BufferKind::Storage)
                    .count() as u32;
                most = (most.0.max(storage), most.1.max(used.len() as u32));
            }
        } else {
            let (storage, all) = buffer_counts(program.tables());
            most = (most.0.max(storage), most.1.max(all));
        }
    }
    assert_eq!(most, (MIN_STORAGE_BUFFERS, MIN_BUFFERS));
    let (storage, all) = buffer_counts(std::iter::once(&StepBindings::TABLE));
    assert!(
        all > 29 && storage > MIN_STORAGE_BUFFERS,
        "the step's table ({storage} storage, {all} in all) would fit one layout on Metal"
    );
}
