//! Whether a scene fits this machine, known before anything is sampled or
//! allocated: the scene's [`WorkEstimate`] (particles, lattice points,
//! frames, the first substep), the memory that follows on the CPU (the
//! solver's, and what the cache writers hold while they write a frame)
//! and, for snow on the GPU, in device buffers, compared with what the
//! machine has.
//!
//! The documented limits of the scene format are checked when a scene is
//! loaded; this is the part that depends on the machine. `firn check` and
//! `firn run` call it before they write anything, and [`Solver::new`]
//! before it samples a particle.
//!
//! [`Solver::new`]: crate::Solver::new

use std::path::Path;

use firn_core::Scene;
use firn_core::scene::{Bytes, SceneKind, WorkEstimate};
use firn_flow::FlowSimulation;
use firn_gpu::snow::MemoryEstimate;
use firn_gpu::{AdapterReport, GpuError};
use firn_mpm::Simulation;

use crate::backend::Placement;
use crate::caches::writer_bytes;
use crate::error::RunError;

/// The environment variable that caps the memory firn plans for, in bytes
/// or with a unit (`512MiB`, `8GiB`): for a machine shared with other
/// work, or a container whose limit the kernel does not show.
pub const MEMORY_LIMIT_VARIABLE: &str = "FIRN_MEMORY_LIMIT";

/// What a scene will take, before it runs.
#[derive(Clone, Debug)]
pub struct Budget {
    /// The scene's own estimate: particles, frames, the first substep.
    pub work: WorkEstimate,
    /// Bytes of host memory the CPU solver holds at the start (a GPU run
    /// keeps this host copy too).
    pub cpu_bytes: u64,
    /// Bytes the cache writers hold beyond the solver's arrays while they
    /// write a frame ([`crate::caches::writer_bytes`]).
    pub writer_bytes: u64,
    /// The GPU buffers of a snow scene.
    pub gpu: Option<MemoryEstimate>,
}

/// How much memory this machine lets firn plan for, and why.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct MachineMemory {
    /// Bytes.
    pub bytes: u64,
    /// Where the figure comes from ("physical memory", ...).
    pub source: &'static str,
}

/// A scene that needs more than the machine has, or a memory limit that
/// cannot be read: what and the fix.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("{message}\n  fix: {fix}")]
pub struct TooLarge {
    /// What it needs against what there is.
    pub message: String,
    /// What to change.
    pub fix: String,
}

impl Budget {
    /// The budget of `scene`, from its description alone.
    pub fn of(scene: &Scene) -> Budget {
        let work = scene.estimate();
        let (cpu_bytes, gpu) = match scene.kind {
            SceneKind::Snow => (
                Simulation::estimate_memory_bytes(scene, work.particles),
                Some(MemoryEstimate::of(scene, work.particles)),
            ),
            SceneKind::Flow(_) => (FlowSimulation::estimate_memory_bytes(scene), None),
        };
        Budget {
            writer_bytes: writer_bytes(scene, &work),
            work,
            cpu_bytes,
            gpu,
        }
    }

    /// Bytes of host memory a run takes: the solver's and the writers'.
    pub fn host_bytes(&self) -> u64 {
        self.cpu_bytes.saturating_add(self.writer_bytes)
    }

    /// Refuses a scene whose host memory passes `machine`'s, with the
    /// particles that would fit beside the writers.
    pub fn check_memory(&self, scene: &Scene, machine: MachineMemory) -> Result<(), TooLarge> {
        let host_bytes = self.host_bytes();
        if host_bytes <= machine.bytes {
            return Ok(());
        }
        let needed = Bytes(host_bytes);
        let has = format!(
            "this machine allows {} ({})",
            Bytes(machine.bytes),
            machine.source
        );
        let share =
            machine.bytes.saturating_sub(self.writer_bytes) as f64 / self.cpu_bytes.max(1) as f64;
        let fit = (self.work.particles as f64 * share).floor() as u64;
        match &scene.kind {
            SceneKind::Snow => {
                let cell_size = f64::from(scene.domain.cell_size) / share.cbrt();
                Err(TooLarge {
                    message: format!(
                        "the scene needs about {needed} of memory for about {} particles; {has}",
                        self.work.particles
                    ),
                    fix: format!(
                        "about {fit} particles fit: use a cell_size of about {cell_size:.3e} m \
                         or more (now {} m), fewer particles_per_cell, or smaller bodies",
                        scene.domain.cell_size
                    ),
                })
            }
            SceneKind::Flow(_) => Err(TooLarge {
                message: format!(
                    "the flow needs about {needed} of memory for {} particle slots; {has}",
                    self.work.particles
                ),
                fix: format!(
                    "about {fit} particles fit: lower the emitters' count or rate, shorten \
                     their lifetime, or draw shorter trails (trail_length)"
                ),
            }),
        }
    }

    /// Refuses what `placement` cannot hold: the host memory on any
    /// backend, and on the GPU a buffer past the adapter's limits or, on a
    /// software adapter, buffers past the host memory.
    pub fn check_placement(&self, scene: &Scene, placement: &Placement) -> Result<(), RunError> {
        let machine = machine_memory().map_err(RunError::TooLarge)?;
        if let Some(machine) = machine {
            self.check_memory(scene, machine)
                .map_err(RunError::TooLarge)?;
        }
        if let (Placement::Gpu(context), Some(gpu)) = (placement, &self.gpu) {
            gpu.check_fits(context)?;
            self.check_gpu_memory(&context.adapter, machine)?;
        }
        Ok(())
    }

    /// Refuses a snow scene whose GPU buffers `adapter` cannot hold: a
    /// buffer past its limits or, on a software adapter (its buffers are
    /// host memory), the buffers and the host's copy past `machine`.
    /// Hardware adapters do not report their memory through wgpu; a run
    /// that passes theirs fails when the buffers are made.
    pub fn check_gpu(
        &self,
        adapter: &AdapterReport,
        machine: Option<MachineMemory>,
    ) -> Result<(), GpuError> {
        if let Some(gpu) = &self.gpu {
            gpu.check_fits_adapter(adapter)?;
        }
        self.check_gpu_memory(adapter, machine)
    }

    /// The host-memory half of [`Budget::check_gpu`].
    fn check_gpu_memory(
        &self,
        adapter: &AdapterReport,
        machine: Option<MachineMemory>,
    ) -> Result<(), GpuError> {
        let (Some(gpu), Some(machine), true) = (&self.gpu, machine, adapter.is_software) else {
            return Ok(());
        };
        if gpu.total_bytes().saturating_add(self.host_bytes()) <= machine.bytes {
            return Ok(());
        }
        Err(GpuError::HostMemory {
            needed: Bytes(gpu.total_bytes()),
            host: Bytes(self.host_bytes()),
            available: Bytes(machine.bytes),
            limited_by: machine.source,
            adapter: adapter.name.clone(),
            fix: "use a larger cell_size or a smaller [domain] (the GPU grid is dense over the \
                  whole domain), or run with --backend cpu (its grid is sparse)"
                .into(),
        })
    }
}

/// The memory firn may plan for: the least of the physical memory, the
/// control group's limit and [`MEMORY_LIMIT_VARIABLE`]; `None` where none
/// is known. An unreadable [`MEMORY_LIMIT_VARIABLE`] is an error.
pub fn machine_memory() -> Result<Option<MachineMemory>, TooLarge> {
    let mut least: Option<MachineMemory> = None;
    let mut consider = |bytes: Option<u64>, source| {
        if let Some(bytes) = bytes
            && least.is_none_or(|least| bytes < least.bytes)
        {
            least = Some(MachineMemory { bytes, source });
        }
    };
    consider(physical_memory(), "physical memory");
    consider(cgroup_memory(), "the control group's memory.max");
    if let Some(text) = std::env::var_os(MEMORY_LIMIT_VARIABLE) {
        let text = text.to_string_lossy();
        let bytes = parse_size(&text).ok_or_else(|| TooLarge {
            message: format!("{MEMORY_LIMIT_VARIABLE} = '{text}' is not a size"),
            fix: format!(
                "set {MEMORY_LIMIT_VARIABLE} to bytes or a size such as 512MiB or 8GiB, or \
                 unset it"
            ),
        })?;
        consider(Some(bytes), MEMORY_LIMIT_VARIABLE);
    }
    Ok(least)
}

/// `MemTotal` of `/proc/meminfo`, in bytes.
fn physical_memory() -> Option<u64> {
    let text = std::fs::read_to_string("/proc/meminfo").ok()?;
    let line = text.lines().find(|line| line.starts_with("MemTotal:"))?;
    let kib: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    kib.checked_mul(1024)
}

/// The control group's (v2) memory limit, if it sets one.
fn cgroup_memory() -> Option<u64> {
    let text = std::fs::read_to_string(Path::new("/sys/fs/cgroup/memory.max")).ok()?;
    text.trim().parse().ok()
}

/// A size such as `1048576`, `512MiB`, `8GiB` or `2G` in bytes.
fn parse_size(text: &str) -> Option<u64> {
    let text = text.trim();
    let digits = text
        .find(|c: char| !(c.is_ascii_digit() || c == '.'))
        .unwrap_or(text.len());
    let (number, unit) = text.split_at(digits);
    let number: f64 = number.parse().ok()?;
    let scale = match unit.trim().to_ascii_lowercase().as_str() {
        "" | "b" => 1u64,
        "k" | "kb" | "kib" => 1 << 10,
        "m" | "mb" | "mib" => 1 << 20,
        "g" | "gb" | "gib" => 1 << 30,
        "t" | "tb" | "tib" => 1 << 40,
        _ => return None,
    };
    let bytes = number * scale as f64;
    (bytes.is_finite() && bytes >= 0.0 && bytes < u64::MAX as f64).then_some(bytes as u64)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sizes_take_binary_units() {
        assert_eq!(parse_size("1048576"), Some(1 << 20));
        assert_eq!(parse_size("512MiB"), Some(512 << 20));
        assert_eq!(parse_size("8 GiB"), Some(8 << 30));
        assert_eq!(parse_size("2g"), Some(2 << 30));
        assert_eq!(parse_size("1.5KiB"), Some(1536));
        assert_eq!(parse_size("lots"), None);
        assert_eq!(parse_size("12 parsecs"), None);
    }

    #[test]
    fn a_snow_scene_past_the_machine_is_refused_with_what_fits() {
        let scene = Scene::from_toml_str(
            "format = 1\n[domain]\nmax = [1.0, 1.0, 1.0]\ncell_size = 0.05\n[time]\n\
             duration = 1.0\n[[bodies]]\nshape = \"box\"\ncenter = [0.5, 0.5, 0.5]\n\
             size = [0.5, 0.5, 0.5]\n",
            "box.toml",
        )
        .unwrap();
        let budget = Budget::of(&scene);
        assert_eq!(budget.work.particles, 8000);
        assert_eq!(budget.writer_bytes, 1536 << 10);
        let machine = MachineMemory {
            bytes: 2 << 20,
            source: "a test",
        };
        let error = budget.check_memory(&scene, machine).unwrap_err();
        assert!(
            error.message.starts_with("the scene needs about 3.3"),
            "{error}"
        );
        assert!(
            error
                .message
                .ends_with("for about 8000 particles; this machine allows 2.00 MiB (a test)"),
            "{error}"
        );
        assert!(error.fix.starts_with("about 2"), "{error}");
        let roomy = MachineMemory {
            bytes: 1 << 30,
            source: "a test",
        };
        assert_eq!(budget.check_memory(&scene, roomy), Ok(()));
    }
}
