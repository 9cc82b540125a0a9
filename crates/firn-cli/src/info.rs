//! `firn info`: what firn can compute on here: its version, the CPU, every
//! GPU adapter with the limits that decide which scenes fit, and the
//! backend `--backend auto` would take.

use firn_core::math::lanes::Simd;
use firn_gpu::{AdapterPolicy, AdapterReport};
use firn_mpm::g2p::preferred_simd;

use crate::Failure;

/// How to get a GPU adapter on a machine without one.
const INSTALL_HINT: &str = "install a GPU driver, or Mesa's software Vulkan driver \
     (Debian/Ubuntu: apt install mesa-vulkan-drivers libvulkan1) to run --backend gpu \
     on the CPU";

/// Prints firn's version, the CPU, the adapters and `auto`'s choice.
pub fn info() -> Result<(), Failure> {
    outln!("firn {}", env!("CARGO_PKG_VERSION"));
    outln!("cpu: {}", crate::machine::Cpu::detect().describe());
    outln!(
        "cpu threads: {}, SIMD path {} (the snow model uses {})",
        rayon::current_num_threads(),
        Simd::detect().name(),
        preferred_simd().name()
    );
    let adapters = firn_gpu::adapters();
    out!("{}", adapter_lines(&adapters));
    let hardware = firn_gpu::choose(AdapterPolicy::HardwareOnly);
    outln!("{}", auto_choice(hardware.as_ref(), &adapters));
    Ok(())
}

/// The adapter list, one block per adapter, or how to get one.
fn adapter_lines(adapters: &[AdapterReport]) -> String {
    if adapters.is_empty() {
        return format!("gpu adapters: none found; {INSTALL_HINT}\n");
    }
    let mut lines = format!("gpu adapters: {}\n", adapters.len());
    for (index, adapter) in adapters.iter().enumerate() {
        lines.push_str(&adapter_block(index + 1, adapter));
    }
    lines
}

/// One adapter: name, API, type and driver, then its limits.
fn adapter_block(number: usize, adapter: &AdapterReport) -> String {
    let driver = if adapter.driver.is_empty() {
        "not reported"
    } else {
        &adapter.driver
    };
    let software = if adapter.is_software {
        ", software"
    } else {
        ""
    };
    format!(
        "  {number}. {}\n     backend {}, type {}{software}, driver {driver}\n     \
         max storage binding {} MiB, {} storage buffers per stage, {} workgroups per \
         dimension, float atomics {}\n",
        adapter.name,
        adapter.backend,
        adapter.device_type,
        adapter.max_storage_binding / (1024 * 1024),
        adapter.max_storage_buffers_per_stage,
        adapter.max_workgroups_per_dimension,
        if adapter.float_atomics { "yes" } else { "no" }
    )
}

/// What `--backend auto` takes given the best hardware adapter, and why.
fn auto_choice(hardware: Option<&AdapterReport>, adapters: &[AdapterReport]) -> String {
    if let Some(gpu) = hardware {
        return format!(
            "--backend auto: the GPU ({}), the best hardware adapter; scenes the GPU \
             backend cannot run stay on the CPU",
            gpu.name
        );
    }
    match adapters.iter().find(|adapter| adapter.is_software) {
        Some(software) => format!(
            "--backend auto: the CPU, since there is no hardware GPU; the software \
             adapter {} runs only with --backend gpu (the CPU backend is faster)",
            software.name
        ),
        None => "--backend auto: the CPU, since there is no GPU adapter".to_string(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn adapter(name: &str, is_software: bool) -> AdapterReport {
        AdapterReport {
            name: name.into(),
            backend: "Vulkan".into(),
            device_type: if is_software { "Cpu" } else { "DiscreteGpu" }.into(),
            driver: "driver 1.0".into(),
            is_software,
            max_storage_binding: 2 << 30,
            max_storage_buffers_per_stage: 16,
            max_workgroups_per_dimension: 65_535,
            float_atomics: false,
        }
    }

    #[test]
    fn adapters_are_listed_with_their_limits() {
        let lines = adapter_lines(&[adapter("llvmpipe", true)]);
        assert!(
            lines.starts_with("gpu adapters: 1\n  1. llvmpipe\n"),
            "{lines}"
        );
        for fragment in [
            "backend Vulkan, type Cpu, software, driver driver 1.0",
            "max storage binding 2048 MiB",
            "16 storage buffers per stage",
            "65535 workgroups per dimension",
            "float atomics no",
        ] {
            assert!(lines.contains(fragment), "{fragment} missing from\n{lines}");
        }
    }

    #[test]
    fn no_adapter_says_how_to_get_one() {
        let lines = adapter_lines(&[]);
        assert!(lines.contains("none found"), "{lines}");
        assert!(lines.contains("mesa-vulkan-drivers"), "{lines}");
    }

    #[test]
    fn auto_takes_hardware_and_never_software() {
        let gpu = adapter("NVIDIA GeForce GTX 1070", false);
        let lavapipe = adapter("llvmpipe", true);
        let both = [gpu.clone(), lavapipe.clone()];
        assert!(auto_choice(Some(&gpu), &both).starts_with("--backend auto: the GPU (NVIDIA"));
        let software_only = auto_choice(None, &[lavapipe]);
        assert!(
            software_only.starts_with("--backend auto: the CPU")
                && software_only.contains("llvmpipe runs only with --backend gpu"),
            "{software_only}"
        );
        assert!(auto_choice(None, &[]).contains("no GPU adapter"));
    }
}
