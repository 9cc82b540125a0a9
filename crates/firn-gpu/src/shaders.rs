//! The WGSL programs, each put together from `.wgsl` files under `shaders/`.
//!
//! WGSL has no includes, so a program is the concatenation of its parts:
//! shared functions (B-spline weights, the 3x3 SVD, the snow model,
//! colliders, simplex noise) first, then the kernels that use them. Every
//! program is validated by naga in a plain unit test (`tests/validate.rs`),
//! no adapter needed.

/// One WGSL program: named parts, concatenated in order.
#[derive(Clone, Copy, Debug)]
pub struct Program {
    /// Name for labels and error messages.
    pub name: &'static str,
    /// `(file, source)` pairs, concatenated in order.
    pub parts: &'static [(&'static str, &'static str)],
}

impl Program {
    /// The whole program text.
    pub fn source(&self) -> String {
        self.parts
            .iter()
            .map(|(file, text)| format!("// ---- {file} ----\n{text}\n"))
            .collect()
    }

    /// Compiles the program on `device`.
    pub fn module(&self, device: &wgpu::Device) -> wgpu::ShaderModule {
        device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some(self.name),
            source: wgpu::ShaderSource::Wgsl(self.source().into()),
        })
    }
}

macro_rules! part {
    ($file:literal) => {
        ($file, include_str!(concat!("../shaders/", $file)))
    };
}

/// Functions shared by the snow programs: weights, SVD, snow model, colliders.
const SNOW_LIBRARY: [(&str, &str); 4] = [
    part!("common/bspline.wgsl"),
    part!("common/svd.wgsl"),
    part!("common/snow_model.wgsl"),
    part!("common/colliders.wgsl"),
];

/// The MPM substep, one file per stage in the order the substep runs them:
/// begin (Δt, stop conditions), binning, scatter, grid update, gather.
pub const SNOW_STEP: Program = Program {
    name: "snow step",
    parts: &[
        SNOW_LIBRARY[0],
        SNOW_LIBRARY[1],
        SNOW_LIBRARY[2],
        SNOW_LIBRARY[3],
        part!("snow/layout.wgsl"),
        part!("snow/fixed_point.wgsl"),
        part!("snow/begin_step.wgsl"),
        part!("snow/binning.wgsl"),
        part!("snow/p2g.wgsl"),
        part!("snow/grid_update.wgsl"),
        part!("snow/g2p.wgsl"),
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
        part!("parity/snow_parity.wgsl"),
    ],
};

/// Functions shared by the flow programs: the bindings they all see,
/// simplex noise, random draws, the field and the emitters.
const FLOW_LIBRARY: [(&str, &str); 5] = [
    part!("flow/layout.wgsl"),
    part!("flow/noise.wgsl"),
    part!("flow/random.wgsl"),
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
        part!("flow/probe.wgsl"),
    ],
};

/// Every program firn builds.
pub const PROGRAMS: &[Program] = &[SNOW_STEP, SNOW_PARITY, FLOW_STEP, FLOW_PARITY];
