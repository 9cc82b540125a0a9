//! The WGSL programs, each put together from `.wgsl` files under `shaders/`
//! and the binding declarations generated from the bind group tables
//! ([`crate::bindings`]).
//!
//! WGSL has no includes, so a program is the concatenation of its parts:
//! the shared physics first, in one place per side (`shaders/common/`:
//! the B-spline weights and the 3x3 SVD of `firn_core::math`, the snow model
//! of `firn_mpm::snow_model`, the colliders of `firn_mpm::contact`;
//! `shaders/flow/`: the noise, random draws, field and emitters of the
//! `firn_flow` files with the same stems), then the structs and bindings,
//! then the kernels. A kernel's `.wgsl` file has the stem of the Rust file
//! that makes its pipelines and records its dispatches
//! (`shaders/snow/p2g.wgsl` and `src/snow/p2g.rs`). Every program is
//! validated by naga in a plain unit test (`tests/validate.rs`), and its
//! declarations are checked against the layouts (`tests/bindings.rs`), no
//! adapter needed.

use crate::bindings::BindGroupTable;
use crate::flow::bindings::{FieldBindings, ParticleBindings, ProbeBindings, TrailBindings};
use crate::snow::bindings::{ParityBindings, StepBindings};

/// One part of a WGSL program.
#[derive(Clone, Copy, Debug)]
pub enum Part {
    /// A file under `shaders/`: its path there and its text.
    File(&'static str, &'static str),
    /// The declarations of one bind group, generated from its table.
    Bindings(&'static BindGroupTable),
}

/// One WGSL program: named parts, concatenated in order.
#[derive(Clone, Copy, Debug)]
pub struct Program {
    /// Name for labels and error messages.
    pub name: &'static str,
    /// The parts, concatenated in order.
    pub parts: &'static [Part],
}

impl Program {
    /// The whole program text.
    pub fn source(&self) -> String {
        self.parts
            .iter()
            .map(|part| match part {
                Part::File(file, text) => format!("// ---- {file} ----\n{text}\n"),
                Part::Bindings(table) => format!(
                    "// ---- bindings of {}, group {} (generated from its table) ----\n{}\n",
                    table.label,
                    table.group,
                    table.declarations()
                ),
            })
            .collect()
    }

    /// The tables of the bind groups the program declares.
    pub fn tables(&self) -> impl Iterator<Item = &'static BindGroupTable> {
        self.parts.iter().filter_map(|part| match part {
            Part::Bindings(table) => Some(*table),
            Part::File(..) => None,
        })
    }

    /// Compiles the program on `device`.
    pub fn module(&self, device: &wgpu::Device) -> wgpu::ShaderModule {
        device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some(self.name),
            source: wgpu::ShaderSource::Wgsl(self.source().into()),
        })
    }

    /// Which bindings each entry point of the program uses, from naga's
    /// analysis of the program (the one wgpu runs when it compiles it).
    ///
    /// # Panics
    /// With naga's message if the program does not parse or validate
    /// (`tests/validate.rs` holds every program to both).
    pub fn reflect(&self) -> Reflection {
        let source = self.source();
        let module = naga::front::wgsl::parse_str(&source).unwrap_or_else(|error| {
            panic!(
                "{} does not parse:\n{}",
                self.name,
                error.emit_to_string(&source)
            )
        });
        let info = naga::valid::Validator::new(
            naga::valid::ValidationFlags::all(),
            naga::valid::Capabilities::empty(),
        )
        .validate(&module)
        .unwrap_or_else(|error| {
            panic!(
                "{} does not validate:\n{}",
                self.name,
                error.emit_to_string(&source)
            )
        });
        let entry_points = module
            .entry_points
            .iter()
            .enumerate()
            .map(|(index, entry)| {
                let uses = info.get_entry_point(index);
                let bindings = module
                    .global_variables
                    .iter()
                    .filter(|(handle, _)| !uses[*handle].is_empty())
                    .filter_map(|(_, global)| {
                        let binding = global.binding.as_ref()?;
                        let kind = match global.space {
                            naga::AddressSpace::Storage { .. } => BufferKind::Storage,
                            naga::AddressSpace::Uniform => BufferKind::Uniform,
                            _ => return None,
                        };
                        Some(UsedBinding {
                            group: binding.group,
                            number: binding.binding,
                            kind,
                        })
                    })
                    .collect();
                (entry.name.clone(), bindings)
            })
            .collect();
        Reflection { entry_points }
    }

    /// The compute pipelines of entry points of the program, compiled once,
    /// each with its bind group layouts (group 0 first).
    pub fn compute_pipelines<const N: usize>(
        &self,
        device: &wgpu::Device,
        kernels: [(&str, &[&wgpu::BindGroupLayout]); N],
    ) -> [wgpu::ComputePipeline; N] {
        let module = self.module(device);
        kernels.map(|(entry, groups)| {
            let bind_group_layouts: Vec<_> = groups.iter().map(|group| Some(*group)).collect();
            let layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
                label: Some(entry),
                bind_group_layouts: &bind_group_layouts,
                immediate_size: 0,
            });
            compute_pipeline(device, &module, &layout, entry, &[])
        })
    }
}

/// Whether a binding is a storage or a uniform buffer.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BufferKind {
    /// `var<storage, ...>`.
    Storage,
    /// `var<uniform>`.
    Uniform,
}

/// A buffer binding an entry point reads or writes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct UsedBinding {
    /// Its bind group.
    pub group: u32,
    /// Its binding number in the group.
    pub number: u32,
    /// Storage or uniform.
    pub kind: BufferKind,
}

/// The bindings each entry point of a program uses ([`Program::reflect`]).
///
/// A kernel's pipeline layout then holds only its own buffers: the snow
/// step binds 42 buffers in all, more than some adapters let one shader
/// stage see (Metal: 29, storage and uniform together), while no single
/// kernel uses more than [`crate::context::MIN_STORAGE_BUFFERS`] storage
/// buffers.
#[derive(Clone, Debug)]
pub struct Reflection {
    entry_points: Vec<(String, Vec<UsedBinding>)>,
}

impl Reflection {
    /// The entry points' names and the bindings each uses.
    pub fn entry_points(&self) -> impl Iterator<Item = (&str, &[UsedBinding])> {
        self.entry_points
            .iter()
            .map(|(name, bindings)| (name.as_str(), bindings.as_slice()))
    }

    /// The binding numbers of `group` that entry point `entry` uses, in
    /// increasing order.
    ///
    /// # Panics
    /// If the program has no entry point `entry`.
    pub fn bindings(&self, entry: &str, group: u32) -> Vec<u32> {
        let (_, used) = self
            .entry_points
            .iter()
            .find(|(name, _)| name == entry)
            .unwrap_or_else(|| panic!("no entry point {entry}"));
        let mut numbers: Vec<u32> = used
            .iter()
            .filter(|binding| binding.group == group)
            .map(|binding| binding.number)
            .collect();
        numbers.sort_unstable();
        numbers
    }
}

/// The compute pipeline of `module`'s entry point `entry` with `layout`,
/// its pipeline-overridable constants set to `constants` (name, value).
pub fn compute_pipeline(
    device: &wgpu::Device,
    module: &wgpu::ShaderModule,
    layout: &wgpu::PipelineLayout,
    entry: &str,
    constants: &[(&str, f64)],
) -> wgpu::ComputePipeline {
    device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
        label: Some(entry),
        layout: Some(layout),
        module,
        entry_point: Some(entry),
        compilation_options: wgpu::PipelineCompilationOptions {
            constants,
            ..Default::default()
        },
        cache: None,
    })
}

macro_rules! part {
    ($file:literal) => {
        Part::File($file, include_str!(concat!("../shaders/", $file)))
    };
}

/// Functions shared by the snow programs: weights, SVD, snow model,
/// colliders, and the semi-implicit solve's stress differential.
const SNOW_LIBRARY: [Part; 7] = [
    part!("common/bspline.wgsl"),
    part!("common/svd.wgsl"),
    part!("common/polar.wgsl"),
    part!("common/snow_model.wgsl"),
    part!("common/colliders.wgsl"),
    part!("common/deforming.wgsl"),
    part!("common/stress_differential.wgsl"),
];

/// The MPM substep, one file per stage in the order the substep runs them
/// (`src/snow/substep.rs`): the grid's blocks, begin (Δt, stop
/// conditions), binning, scatter, the rigid bodies' coupling and the grid
/// update that runs it, semi-implicit solve, gather,
/// spindrift; `snow/nodes.wgsl` addresses the sparse grid's nodes.
pub const SNOW_STEP: Program = Program {
    name: "snow step",
    parts: &[
        SNOW_LIBRARY[0],
        SNOW_LIBRARY[1],
        SNOW_LIBRARY[2],
        SNOW_LIBRARY[3],
        SNOW_LIBRARY[4],
        SNOW_LIBRARY[5],
        SNOW_LIBRARY[6],
        part!("snow/layout.wgsl"),
        part!("flow/layout.wgsl"),
        Part::Bindings(&StepBindings::TABLE),
        part!("snow/nodes.wgsl"),
        part!("snow/fixed_point.wgsl"),
        part!("flow/noise.wgsl"),
        part!("flow/random.wgsl"),
        part!("snow/wind.wgsl"),
        part!("flow/field.wgsl"),
        part!("snow/blocks.wgsl"),
        part!("snow/begin_step.wgsl"),
        part!("snow/binning.wgsl"),
        part!("snow/p2g.wgsl"),
        part!("snow/coupling.wgsl"),
        part!("snow/grid_update.wgsl"),
        part!("snow/implicit.wgsl"),
        part!("snow/g2p.wgsl"),
        part!("snow/spindrift.wgsl"),
        part!("snow/parts.wgsl"),
    ],
};

/// Entry points that run single library functions on arrays, for the parity
/// tests against the CPU functions.
pub const SNOW_PARITY: Program = Program {
    name: "snow parity",
    parts: &[
        SNOW_LIBRARY[0],
        SNOW_LIBRARY[1],
        SNOW_LIBRARY[2],
        SNOW_LIBRARY[3],
        SNOW_LIBRARY[4],
        SNOW_LIBRARY[5],
        SNOW_LIBRARY[6],
        Part::Bindings(&ParityBindings::TABLE),
        part!("parity/snow_parity.wgsl"),
    ],
};

/// Functions shared by the flow programs: the structs and the field's
/// bindings they all see, simplex noise, random draws, the field and the
/// emitters.
const FLOW_LIBRARY: [Part; 7] = [
    part!("flow/layout.wgsl"),
    Part::Bindings(&FieldBindings::TABLE),
    part!("flow/noise.wgsl"),
    part!("flow/random.wgsl"),
    part!("flow/noise_point.wgsl"),
    part!("flow/field.wgsl"),
    part!("flow/emitters.wgsl"),
];

/// The curl-noise flow substep: advance, settle newborns, record trails.
pub const FLOW_STEP: Program = Program {
    name: "flow step",
    parts: &[
        FLOW_LIBRARY[0],
        FLOW_LIBRARY[1],
        FLOW_LIBRARY[2],
        FLOW_LIBRARY[3],
        FLOW_LIBRARY[4],
        FLOW_LIBRARY[5],
        FLOW_LIBRARY[6],
        Part::Bindings(&ParticleBindings::TABLE),
        Part::Bindings(&TrailBindings::TABLE),
        part!("flow/step.wgsl"),
    ],
};

/// Entry points that run the flow's library functions on arrays, for the
/// parity tests against `firn-flow`.
pub const FLOW_PARITY: Program = Program {
    name: "flow parity",
    parts: &[
        FLOW_LIBRARY[0],
        FLOW_LIBRARY[1],
        FLOW_LIBRARY[2],
        FLOW_LIBRARY[3],
        FLOW_LIBRARY[4],
        FLOW_LIBRARY[5],
        FLOW_LIBRARY[6],
        Part::Bindings(&ProbeBindings::TABLE),
        part!("flow/probe.wgsl"),
    ],
};

/// Every program firn builds.
pub const PROGRAMS: &[Program] = &[SNOW_STEP, SNOW_PARITY, FLOW_STEP, FLOW_PARITY];
