//! `firn check`: validate a scene and show what it resolves to and what it
//! will cost, without sampling or allocating it.

use std::path::PathBuf;

use clap::Args;
use firn_core::Scene;
use firn_core::scene::Backend;
use firn_core::scene::{
    Bytes, CacheFormat, ColliderGeometry, Domain, FlowSettings, MeshSequenceCollider, Shape,
    TimeStep,
};
use firn_gpu::AdapterPolicy;
use firn_mpm::grid::GridLayout;
use firn_run::Budget;
use firn_run::backend::{first_line, gpu_supports};
use firn_run::budget::{TooLarge, machine_memory};

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

/// Validates the scene, checks that it fits this machine, and prints what
/// it will cost: particles, grid, memory, the first Δt and frames. Nothing
/// is sampled or allocated, so a scene of any size answers at once.
pub fn check(args: CheckArgs) -> Result<(), Failure> {
    let (scene, _) = load_scene(args.scene.as_deref())?;
    if args.json {
        let json = serde_json::to_string_pretty(&scene)
            .map_err(|error| Failure::Failed(error.to_string()))?;
        outln!("{json}");
        return Ok(());
    }
    let budget = Budget::of(&scene);
    if let Some(machine) = machine_memory().map_err(too_large)? {
        budget.check_memory(&scene, machine).map_err(too_large)?;
    }
    if let Some(flow) = scene.kind.flow() {
        return check_flow(&scene, flow, &budget);
    }
    let cells = scene.domain.cells();
    let domain = &scene.domain;
    let nodes = GridLayout::new(domain.min, domain.max, domain.cell_size).node_dims();
    outln!("scene       {}", scene.name);
    outln!(
        "domain      {} m, h = {} m",
        box_text(&scene.domain),
        scene.domain.cell_size
    );
    outln!(
        "grid        {} x {} x {} cells ({} x {} x {} nodes with padding)",
        cells[0],
        cells[1],
        cells[2],
        nodes.x,
        nodes.y,
        nodes.z
    );
    outln!("transfer    {:?}", scene.solver.transfer);
    outln!(
        "particles   about {} (from the bodies' volumes; {} lattice points tested)",
        budget.work.particles,
        budget.work.lattice_points
    );
    for ((index, body), estimate) in scene.bodies.iter().enumerate().zip(&budget.work.bodies) {
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
        let clumps = body.clumps.map_or(String::new(), |clumps| {
            format!(
                ", clumps of {} m (contrast {})",
                clumps.size, clumps.contrast
            )
        });
        outln!(
            "  body {index}    {shape}, material {}{clumps}, {} particles per cell, about {} particles",
            material.name,
            body.particles_per_cell,
            estimate.particles
        );
    }
    for material in &scene.materials {
        outln!(
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
    outln!(
        "colliders   {} (plus the 6 domain walls)",
        scene.colliders.len()
    );
    for (index, collider) in scene.colliders.iter().enumerate() {
        if let ColliderGeometry::MeshSequence(sequence) = &collider.geometry {
            print_sequence(index, sequence);
        }
    }
    if let Some(wind) = &scene.wind {
        let field = &wind.field;
        let direction = field.background_direction;
        outln!(
            "wind        {:.3} m/s along [{}, {}, {}] with turbulence of about {:.3} m/s rms (L = {} m); drag {} kg/(m2 s), packed at {} kg/m3",
            field.background_speed(),
            direction.x,
            direction.y,
            direction.z,
            field.turbulence_speed(),
            field.length_scale,
            wind.drag,
            wind.packed_density
        );
        if let Some(spindrift) = &wind.spindrift {
            let landing = if spindrift.settle {
                "settles back into snow where it lands"
            } else {
                "rests as drift where it lands"
            };
            outln!(
                "spindrift   snow under {} kg/m3 lifts where the wind over it exceeds {} m/s, {} per second where fully exposed; drift falls at {} m/s and {landing}",
                spindrift.loose_density,
                spindrift.threshold_speed,
                spindrift.rate,
                spindrift.fall_speed
            );
        }
    }
    outln!(
        "memory      about {} at the start: {} for the solver (sparse grid near the bodies, bins and particles) plus {} for writing caches{}",
        Bytes(budget.host_bytes()),
        Bytes(budget.cpu_bytes),
        Bytes(budget.writer_bytes),
        machine_text()
    );
    let gpu = print_gpu_line(&scene, &budget);
    let policy = match scene.time.step {
        TimeStep::Fixed { dt } => format!("fixed {dt:.2e} s"),
        TimeStep::Adaptive { cfl, max_dt } => {
            format!("adaptive, cfl {cfl}, at most {max_dt:.2e} s")
        }
    };
    let first = scene.first_step();
    outln!(
        "time step   {policy}; first step {:.3e} s ({:.0} substeps per frame, at most {})",
        first.dt,
        first.substeps_per_frame.ceil(),
        scene.time.max_substeps_per_frame
    );
    outln!(
        "frames      {} at {} fps ({} s)",
        scene.time.frame_count(),
        scene.time.fps,
        scene.time.duration
    );
    outln!("output      {}", scene.output.directory.display());
    if scene.output.formats.contains(&CacheFormat::Mesh) {
        let mesh = &scene.output.mesh;
        outln!(
            "mesh        voxel {} m, {} smoothing pass(es), surface at {} of the rest density",
            mesh.voxel_size_for(scene.domain.cell_size),
            mesh.smoothing,
            mesh.iso
        );
    }
    gpu
}

/// A scene past the machine's memory, or an unreadable limit (exit code 2).
fn too_large(error: TooLarge) -> Failure {
    Failure::BadInput(format!("error: {error}"))
}

/// ` of X (source)`: the memory the machine allows, where known.
fn machine_text() -> String {
    match machine_memory() {
        Ok(Some(machine)) => format!(", of {} ({})", Bytes(machine.bytes), machine.source),
        _ => String::new(),
    }
}

/// Whether the GPU backend runs the scene on the adapter `--backend gpu`
/// would take, held against that adapter's limits and, for a software
/// adapter, the host memory its buffers live in (no device is opened).
/// `Err` when it cannot: the line says why and what to change.
fn gpu_line(scene: &Scene, budget: &Budget) -> Result<String, String> {
    if let Err(error) = gpu_supports(scene) {
        return Err(format!("CPU only: {}", first_line(&error)));
    }
    let buffers = budget.gpu.as_ref().map_or(String::new(), |estimate| {
        format!(
            ": {:.1} MiB of GPU buffers ({} bytes per particle, {} per node, {} nodes: \
             room for {} of the domain's {} blocks, half as many again as the bodies reach)",
            estimate.total_bytes() as f64 / (1024.0 * 1024.0),
            estimate.bytes_per_particle,
            estimate.bytes_per_node,
            estimate.nodes,
            estimate.grid_blocks(),
            estimate.domain_blocks
        )
    });
    let Some(adapter) = firn_gpu::choose(AdapterPolicy::AllowSoftware) else {
        return Err(format!(
            "no GPU adapter was found: this scene runs on the CPU (on a GPU it would need{})",
            buffers.trim_start_matches(':')
        ));
    };
    let machine = machine_memory().ok().flatten();
    if let Err(error) = budget.check_gpu(&adapter, machine) {
        return Err(error.to_string().replace("\n  ", "\n            "));
    }
    let memory = match (adapter.is_software, machine, &budget.gpu) {
        (_, _, None) => String::new(),
        (true, Some(machine), Some(_)) => format!(
            ", held in host memory beside the state's host copy and the cache writers ({} in all, of {})",
            Bytes(budget.host_bytes() + budget.gpu.map_or(0, |gpu| gpu.total_bytes())),
            Bytes(machine.bytes)
        ),
        (true, None, Some(_)) => String::new(),
        (false, _, Some(_)) => "; the adapter does not report its memory".into(),
    };
    Ok(format!(
        "the GPU backend runs this scene on {}{buffers}{memory}",
        adapter.name
    ))
}

/// Prints the GPU line; fails (exit code 2) when the scene asks for the GPU
/// (`backend = "gpu"`) and the GPU cannot run it.
fn print_gpu_line(scene: &Scene, budget: &Budget) -> Result<(), Failure> {
    match gpu_line(scene, budget) {
        Ok(line) => {
            outln!("gpu         {line}");
            Ok(())
        }
        Err(line) => {
            outln!("gpu         {line}");
            if scene.compute.backend == Backend::Gpu {
                return Err(Failure::BadInput(
                    "error: the scene asks for the GPU ([compute] backend = \"gpu\"), which cannot run it (see the gpu line above)\n  fix: follow the gpu line's fix, or set backend = \"auto\" or \"cpu\"".into(),
                ));
            }
            Ok(())
        }
    }
}

/// The domain's corners as `[x, y, z] to [x, y, z]`.
fn box_text(domain: &Domain) -> String {
    let (min, max) = (domain.min, domain.max);
    format!(
        "[{}, {}, {}] to [{}, {}, {}]",
        min.x, min.y, min.z, max.x, max.y, max.z
    )
}

/// The summary of a curl-noise flow scene: particle slots, the field's
/// parameters, emitters and obstacles.
fn check_flow(scene: &Scene, flow: &FlowSettings, budget: &Budget) -> Result<(), Failure> {
    outln!("scene       {} (curl-noise flow)", scene.name);
    outln!("domain      {}", box_text(&scene.domain));
    outln!(
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
    outln!(
        "stepping    {:?}, {} substeps per frame ({:.3e} s)",
        flow.integrator,
        flow.substeps,
        1.0 / (scene.time.fps * f64::from(flow.substeps))
    );
    outln!("particles   {} slots", budget.work.particles);
    outln!("emitters    {}", flow.emitters.len());
    outln!("obstacles   {}", flow.obstacles.len());
    outln!(
        "memory      about {} with every slot alive: {} for the flow plus {} for writing caches{}",
        Bytes(budget.host_bytes()),
        Bytes(budget.cpu_bytes),
        Bytes(budget.writer_bytes),
        machine_text()
    );
    let gpu = print_gpu_line(scene, budget);
    outln!(
        "frames      {} at {} fps ({} s)",
        scene.time.frame_count(),
        scene.time.fps,
        scene.time.duration
    );
    outln!("output      {}", scene.output.directory.display());
    gpu
}

/// A deforming collider's files and the work of its distance fields: one
/// narrow band per mesh frame, built when the run reaches the frame.
fn print_sequence(index: usize, sequence: &MeshSequenceCollider) {
    let frames = sequence.frames.get();
    let (largest, total) = sequence.footprint();
    outln!(
        "  collider {index} mesh sequence {}: {} files from number {} at {} per second from t = {} s, {} vertices and {} triangles each",
        sequence.pattern.display(),
        sequence.frame_count,
        sequence.first_number,
        sequence.frame_rate,
        sequence.start,
        frames.positions.first().map_or(0, Vec::len),
        frames.triangles.len()
    );
    outln!(
        "              distance band {} m at {} m: at most {} samples ({}) per mesh frame, two held at a time; {} rebuilds sample {} distances in all",
        sequence.band,
        sequence.sdf_spacing,
        largest.samples(),
        Bytes(largest.bytes()),
        sequence.frame_count,
        total
    );
}
