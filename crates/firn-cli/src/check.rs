//! `firn check`: validate a scene and show what it resolves to.

use std::path::PathBuf;

use clap::Args;
use firn_core::Scene;
use firn_core::scene::{Domain, FlowSettings, Shape, TimeStep};
use firn_flow::FlowSimulation;
use firn_gpu::snow::MemoryEstimate;
use firn_mpm::Simulation;
use firn_run::backend::{first_line, gpu_supports};

use crate::Failure;
use crate::scene_source::load_scene;

/// Arguments of `firn check`.
#[derive(Args, Debug)]
pub struct CheckArgs {
    /// Scene file (TOML); without one, the bundled default scene is checked.
    pub scene: Option<PathBuf>,
    /// Print the fully resolved scene (presets expanded, defaults filled in) as JSON.
    #[arg(long)]
    pub json: bool,
}

/// Validates the scene and prints particle count, grid, memory and first Δt.
pub fn check(args: CheckArgs) -> Result<(), Failure> {
    let (scene, _) = load_scene(args.scene.as_deref())?;
    if args.json {
        let json = serde_json::to_string_pretty(&scene)
            .map_err(|error| Failure::Failed(error.to_string()))?;
        println!("{json}");
        return Ok(());
    }
    if let Some(flow) = scene.kind.flow() {
        return check_flow(&scene, flow);
    }
    let simulation = Simulation::new(scene.clone())
        .map_err(|error| Failure::BadInput(format!("error: {error}")))?;
    let cells = scene.domain.cells();
    let layout = simulation.grid_layout();
    let nodes = layout.node_dims();
    println!("scene       {}", scene.name);
    println!(
        "domain      {} m, h = {} m",
        box_text(&scene.domain),
        scene.domain.cell_size
    );
    println!(
        "grid        {} x {} x {} cells ({} x {} x {} nodes with padding)",
        cells[0], cells[1], cells[2], nodes.x, nodes.y, nodes.z
    );
    println!("transfer    {:?}", scene.solver.transfer);
    println!("particles   {}", simulation.particles().len());
    for (index, body) in scene.bodies.iter().enumerate() {
        let shape = match body.shape {
            Shape::Sphere { radius, .. } => format!("sphere r = {radius}"),
            Shape::Box { size, .. } => format!("box {} x {} x {}", size.x, size.y, size.z),
            Shape::Cylinder { radius, height, .. } => {
                format!("cylinder r = {radius}, height {height}")
            }
            Shape::Mesh(ref mesh) => {
                let size = mesh.max - mesh.min;
                format!(
                    "mesh {} ({:.3} x {:.3} x {:.3} m)",
                    mesh.placement.file.display(),
                    size.x,
                    size.y,
                    size.z
                )
            }
        };
        let material = &scene.materials[body.material];
        println!(
            "  body {index}    {shape}, material {}, {} particles per cell",
            material.name, body.particles_per_cell
        );
    }
    for material in &scene.materials {
        println!(
            "material    {}: E = {:.3e} Pa, nu = {}, xi = {}, theta_c = {:.2e}, theta_s = {:.2e}, rho0 = {} kg/m3",
            material.name,
            material.youngs_modulus,
            material.poisson_ratio,
            material.hardening,
            material.critical_compression,
            material.critical_stretch,
            material.density
        );
    }
    println!(
        "colliders   {} (plus the 6 domain walls)",
        scene.colliders.len()
    );
    println!(
        "memory      {:.1} MiB (sparse grid, bins and particles)",
        simulation.memory_bytes() as f64 / (1024.0 * 1024.0)
    );
    println!(
        "gpu         {}",
        gpu_line(&scene, Some(simulation.particles().len()))
    );
    let policy = match scene.time.step {
        TimeStep::Fixed { dt } => format!("fixed {dt:.2e} s"),
        TimeStep::Adaptive { cfl, max_dt } => {
            format!("adaptive, cfl {cfl}, at most {max_dt:.2e} s")
        }
    };
    println!(
        "time step   {policy}; first step {:.3e} s",
        simulation.next_dt()
    );
    println!(
        "frames      {} at {} fps ({} s)",
        scene.time.frame_count(),
        scene.time.fps,
        scene.time.duration
    );
    println!("output      {}", scene.output.directory.display());
    Ok(())
}

/// Whether the GPU backend runs the scene and, for snow with `particles`,
/// the GPU memory it needs (no adapter is opened).
fn gpu_line(scene: &Scene, particles: Option<usize>) -> String {
    if let Err(error) = gpu_supports(scene) {
        return format!("CPU only: {}", first_line(&error));
    }
    let Some(particles) = particles else {
        return "the GPU backend runs this scene (--backend gpu)".into();
    };
    let estimate = MemoryEstimate::of(scene, particles as u64);
    format!(
        "the GPU backend runs this scene: {:.1} MiB of GPU buffers ({} bytes per particle, {} per node, {} nodes)",
        estimate.total_bytes() as f64 / (1024.0 * 1024.0),
        estimate.bytes_per_particle,
        estimate.bytes_per_node,
        estimate.nodes
    )
}

/// The domain's corners as `[x, y, z] to [x, y, z]`.
fn box_text(domain: &Domain) -> String {
    let (min, max) = (domain.min, domain.max);
    format!(
        "[{}, {}, {}] to [{}, {}, {}]",
        min.x, min.y, min.z, max.x, max.y, max.z
    )
}

/// The summary of a curl-noise flow scene: particles at time 0, the field's
/// parameters, emitters and obstacles.
fn check_flow(scene: &Scene, flow: &FlowSettings) -> Result<(), Failure> {
    let simulation = FlowSimulation::new(scene.clone())
        .map_err(|error| Failure::BadInput(format!("error: {error}")))?;
    println!("scene       {} (curl-noise flow)", scene.name);
    println!("domain      {}", box_text(&scene.domain));
    println!(
        "field       noise share {}, strength {}, length scale {}, background {} along [{}, {}, {}], curl {:?}",
        flow.noise_share,
        flow.noise_strength,
        flow.length_scale,
        flow.background_strength,
        flow.background_direction.x,
        flow.background_direction.y,
        flow.background_direction.z,
        flow.curl
    );
    println!(
        "stepping    {:?}, {} substeps per frame ({:.3e} s)",
        flow.integrator,
        flow.substeps,
        simulation.dt()
    );
    println!("particles   {} at t = 0", simulation.len());
    println!("emitters    {}", flow.emitters.len());
    println!("obstacles   {}", flow.obstacles.len());
    println!(
        "memory      {:.1} MiB",
        simulation.memory_bytes() as f64 / (1024.0 * 1024.0)
    );
    println!("gpu         {}", gpu_line(scene, None));
    println!(
        "frames      {} at {} fps ({} s)",
        scene.time.frame_count(),
        scene.time.fps,
        scene.time.duration
    );
    println!("output      {}", scene.output.directory.display());
    Ok(())
}
