//! `firn bench --sweep particles|grid`: the thesis' performance figures 8 and
//! 9 (§6.2), substeps per second of the snowball drop against the particle
//! count and against the grid size, as a table, CSV, JSON and two charts each.
//!
//! Both sweeps use the cell size of the 256³ unit box, h = 1/256 m (so the
//! same Δt = 0.0128 h), the bench's snow and a ball sampled with the scenes'
//! default 8 particles per cell, 60 % of the box height up, falling freely
//! for the whole timed window:
//!
//! - `particles`: the 256³ unit box; the ball holds about 2¹⁰, 2¹³, 2¹⁴ … 2²⁰
//!   particles, its radius growing with the count (3 to 31.5 cells). firn
//!   samples bodies on a lattice with a whole number of particles per cell,
//!   so a fixed 0.3 m ball could not hold fewer than 237,000 particles at
//!   this h; fewer, in a ball that size, would be far apart, not snow.
//! - `grid`: the same ball of about 2¹⁶ particles (radius 12.5 cells, 4.9 cm)
//!   in boxes of 64³, 128³, 256³ and 512x512x256 cells: the cell size stays,
//!   the box grows, so only the grid's node count changes (and, with the
//!   sparse grid, only its page table grows with it).
//!
//! Before each size the memory it needs (the sparse grid's page table and the
//! blocks near the ball, bins, particles) is estimated and compared with the
//! memory available (MemAvailable and any cgroup limit, less 10 %, or
//! `--memory-budget`); a size that does not fit is recorded as skipped, never
//! allocated.

use std::fmt::Write as _;
use std::io::Write as _;
use std::path::{Path, PathBuf};
use std::time::Duration;

use clap::{Args, ValueEnum};
use firn_core::scene::{Scene, Shape, Transfer};
use firn_mpm::grid::{BLOCK_NODES, BLOCK_WIDTH, GridLayout, Node};
use firn_mpm::{Particles, PermuteBuffers};
use firn_run::Placement;
use glam::{UVec3, Vec3};
use serde::Serialize;

use crate::Failure;
use crate::bench::{BenchArgs, bench_solver, snowball_drop, time_substeps, transfer_name};
use crate::charts::{self, ChartText, Sample, XTicks, superscript};

/// Cells per metre in both sweeps: the 256³ grid of the unit box.
const CELLS_PER_METRE: u32 = 256;
/// Particles per cell of the ball (the scene format's default).
const PARTICLES_PER_CELL: u32 = 8;
/// The particle sweep's grid, in cells per axis.
const PARTICLE_SWEEP_CELLS: u32 = 256;
/// Particles in the grid sweep's ball.
const GRID_SWEEP_PARTICLES: u64 = 1 << 16;
/// The thesis' particle counts (figure 8).
const DEFAULT_PARTICLES: [u64; 9] = [
    1 << 10,
    1 << 13,
    1 << 14,
    1 << 15,
    1 << 16,
    1 << 17,
    1 << 18,
    1 << 19,
    1 << 20,
];
/// The thesis' grid sizes in cells (figure 9).
const DEFAULT_GRIDS: [[u32; 3]; 4] = [
    [64, 64, 64],
    [128, 128, 128],
    [256, 256, 256],
    [512, 512, 256],
];
/// Share of the available memory a size may take.
const MEMORY_HEADROOM: f64 = 0.9;
/// Cells per axis a grid size may have.
const MAX_CELLS_PER_AXIS: u32 = 1 << 16;
/// Sampled counts scatter around the ball's volume over the lattice volume;
/// the estimate allows this much more.
const COUNT_MARGIN: f64 = 1.05;

/// `--sweep` and its options (part of `firn bench`).
#[derive(Args, Debug)]
pub struct SweepArgs {
    /// Sweep one size of the snowball drop and chart it: `particles` (2^10,
    /// 2^13 … 2^20 particles on a 256³ grid) or `grid` (64³, 128³, 256³ and
    /// 512x512x256 cells, 2^16 particles); --transfer, --steps, --warmup and
    /// --threads apply, --particles and --grid do not.
    #[arg(long, value_enum, conflicts_with_all = ["scene", "render", "flow"])]
    pub sweep: Option<SweepKind>,
    /// With --sweep: the sizes instead of the thesis' list, comma separated:
    /// particle counts (1024 or 2^10) or grids in cells (64 for 64³, or
    /// 512x512x256).
    #[arg(long, value_delimiter = ',', requires = "sweep")]
    pub sizes: Vec<String>,
    /// With --sweep: the folder for sweep-KIND.csv, .json and the two charts.
    #[arg(long, default_value = "bench-sweep", requires = "sweep")]
    pub sweep_out: PathBuf,
    /// With --sweep: memory one size may take, in GiB (default: the memory
    /// available, from /proc/meminfo and the cgroup limit, less 10 %).
    #[arg(long, requires = "sweep")]
    pub memory_budget: Option<f64>,
    /// With --sweep: stop timing a size after this many seconds (after at
    /// least 3 substeps), so that large sizes time fewer than --steps.
    #[arg(long, default_value_t = 10.0, requires = "sweep")]
    pub sweep_seconds: f64,
}

/// What a sweep varies.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum SweepKind {
    /// The particle count, on a 256³ grid (thesis figure 8).
    Particles,
    /// The grid size, with 2^16 particles (thesis figure 9).
    Grid,
}

impl SweepKind {
    fn name(self) -> &'static str {
        match self {
            SweepKind::Particles => "particles",
            SweepKind::Grid => "grid",
        }
    }
}

/// One size of a sweep.
#[derive(Clone, Debug, PartialEq)]
struct SweepSize {
    /// As the table shows it: "2^16" or "512x512x256".
    label: String,
    /// Grid cells per axis.
    cells: UVec3,
    /// Particles asked for.
    particles: u64,
}

/// One measured (or skipped) size and transfer scheme.
#[derive(Clone, Debug, Serialize)]
struct SweepRecord {
    sweep: &'static str,
    transfer: Transfer,
    /// The size's label: "2^16" or "512x512x256".
    size: String,
    target_particles: u64,
    /// Particles sampled; `None` when skipped.
    particles: Option<u64>,
    /// Grid cells per axis (the box over h).
    cells: [u32; 3],
    /// Nodes allocated per axis: cells + 1, 3 padding nodes on each side,
    /// rounded up to whole 4³ blocks.
    grid_nodes: [u32; 3],
    grid_nodes_total: u64,
    cell_size: f32,
    dt: f32,
    threads: usize,
    /// Timed substeps (0 when skipped).
    substeps: u32,
    seconds: Option<f64>,
    substeps_per_second: Option<f64>,
    ns_per_particle_substep: Option<f64>,
    /// CPU seconds of all threads over the timed substeps (Linux only): what
    /// other programs on a shared machine do not inflate.
    cpu_seconds: Option<f64>,
    cpu_ns_per_particle_substep: Option<f64>,
    /// Resident memory before the size plus its estimated bytes.
    estimated_peak_bytes: u64,
    /// VmHWM after the timed substeps (Linux only).
    measured_peak_bytes: Option<u64>,
    fits: bool,
    note: String,
}

/// Runs the sweep, printing a line per size, and writes the CSV, JSON and
/// charts into `--sweep-out`.
pub fn bench_sweep(kind: SweepKind, args: &BenchArgs) -> Result<(), Failure> {
    let options = &args.sweep;
    let sizes = if options.sizes.is_empty() {
        default_sizes(kind)
    } else {
        parse_sizes(kind, &options.sizes)?
    };
    if !(options.sweep_seconds > 0.0 && options.sweep_seconds.is_finite()) {
        return Err(Failure::BadInput(
            "error: --sweep-seconds must be positive\n  fix: pass e.g. --sweep-seconds 10".into(),
        ));
    }
    let budget = match options.memory_budget {
        Some(gib) if gib > 0.0 && gib.is_finite() => Some((gib * GIB) as u64),
        Some(_) => {
            return Err(Failure::BadInput(
                "error: --memory-budget must be a positive number of GiB\n  fix: pass e.g. --memory-budget 4"
                    .into(),
            ));
        }
        None => None,
    };
    std::fs::create_dir_all(&options.sweep_out).map_err(|error| {
        Failure::BadInput(format!(
            "error: cannot create {}: {error}",
            options.sweep_out.display()
        ))
    })?;
    let transfers = args.transfer.schemes();
    outln!(
        "sweep {} ({}; {} threads; up to {} timed substeps or {} s per size)",
        kind.name(),
        match kind {
            SweepKind::Particles => format!("{PARTICLE_SWEEP_CELLS}³ grid"),
            SweepKind::Grid => format!("about {GRID_SWEEP_PARTICLES} particles"),
        },
        rayon::current_num_threads(),
        args.steps,
        options.sweep_seconds
    );
    outln!(
        "{:<9} {:<12} {:>10} {:>22} {:>8} {:>8} {:>11} {:>10} {:>10} {:>9} {:>9}",
        "transfer",
        "size",
        "particles",
        "grid nodes",
        "substeps",
        "seconds",
        "substeps/s",
        "ns/p-step",
        "CPU ns/p",
        "est. MiB",
        "peak MiB"
    );
    let mut records = Vec::new();
    let mut failures = Vec::new();
    for size in &sizes {
        for &transfer in transfers {
            out!("{:<9} {:<12}", transfer_name(transfer), size.label);
            let _ = std::io::stdout().flush();
            let record = measure_size(kind, size, transfer, args, budget);
            match &record {
                Ok(record) if !record.fits => outln!(" {}", record.note),
                Ok(record) => outln!(" {}", table_columns(record)),
                Err(message) => outln!(" failed: {message}"),
            }
            match record {
                Ok(record) => records.push(record),
                Err(message) => {
                    failures.push(format!(
                        "{} {}: {message}",
                        size.label,
                        transfer_name(transfer)
                    ));
                }
            }
        }
    }
    write_outputs(kind, &records, &options.sweep_out)?;
    if failures.is_empty() {
        Ok(())
    } else {
        Err(Failure::Failed(format!(
            "error: some sizes failed:\n  {}",
            failures.join("\n  ")
        )))
    }
}

const GIB: f64 = 1024.0 * 1024.0 * 1024.0;
const MIB: f64 = 1024.0 * 1024.0;

/// The table's columns after transfer and size.
fn table_columns(record: &SweepRecord) -> String {
    let nodes = format!(
        "{}x{}x{} ({:.1}M)",
        record.grid_nodes[0],
        record.grid_nodes[1],
        record.grid_nodes[2],
        record.grid_nodes_total as f64 / 1e6
    );
    let mut line = format!(
        "{:>10} {:>22} {:>8} {:>8.2} {:>11.2} {:>10.1} {:>10} {:>9.0} {:>9}",
        record.particles.unwrap_or(0),
        nodes,
        record.substeps,
        record.seconds.unwrap_or(0.0),
        record.substeps_per_second.unwrap_or(0.0),
        record.ns_per_particle_substep.unwrap_or(0.0),
        record
            .cpu_ns_per_particle_substep
            .map(|ns| format!("{ns:.1}"))
            .unwrap_or_else(|| "-".into()),
        record.estimated_peak_bytes as f64 / MIB,
        record
            .measured_peak_bytes
            .map(|bytes| format!("{:.0}", bytes as f64 / MIB))
            .unwrap_or_else(|| "-".into()),
    );
    if !record.note.is_empty() {
        let _ = write!(line, "  ({})", record.note);
    }
    line
}

/// The thesis' sizes for `kind`.
fn default_sizes(kind: SweepKind) -> Vec<SweepSize> {
    match kind {
        SweepKind::Particles => DEFAULT_PARTICLES
            .iter()
            .map(|&count| particle_size(count))
            .collect(),
        SweepKind::Grid => DEFAULT_GRIDS
            .iter()
            .map(|&cells| grid_size(UVec3::from_array(cells)))
            .collect(),
    }
}

fn particle_size(count: u64) -> SweepSize {
    SweepSize {
        label: if count.is_power_of_two() {
            format!("2^{}", count.trailing_zeros())
        } else {
            count.to_string()
        },
        cells: UVec3::splat(PARTICLE_SWEEP_CELLS),
        particles: count,
    }
}

fn grid_size(cells: UVec3) -> SweepSize {
    SweepSize {
        label: format!("{}x{}x{}", cells.x, cells.y, cells.z),
        cells,
        particles: GRID_SWEEP_PARTICLES,
    }
}

/// Parses `--sizes` for `kind`: counts (`1024`, `2^10`) or grids (`64`,
/// `512x512x256`).
fn parse_sizes(kind: SweepKind, texts: &[String]) -> Result<Vec<SweepSize>, Failure> {
    texts
        .iter()
        .map(|text| {
            let text = text.trim();
            let parsed = match kind {
                SweepKind::Particles => parse_count(text).map(particle_size),
                SweepKind::Grid => parse_cells(text).map(grid_size),
            };
            parsed.ok_or_else(|| {
                let fix = match kind {
                    SweepKind::Particles => {
                        "pass particle counts from 1 to 2^31, e.g. --sizes 1024,2^13"
                    }
                    SweepKind::Grid => {
                        "pass cells per axis from 8 to 65536, e.g. --sizes 64,128 or --sizes 512x512x256"
                    }
                };
                Failure::BadInput(format!(
                    "error: --sizes: cannot read {text:?} as a {} size\n  fix: {fix}",
                    kind.name()
                ))
            })
        })
        .collect()
}

fn parse_count(text: &str) -> Option<u64> {
    let count = match text.split_once('^') {
        Some(("2", exponent)) => 1u64.checked_shl(exponent.parse().ok()?)?,
        Some(_) => return None,
        None => text.parse().ok()?,
    };
    (1..=1 << 31).contains(&count).then_some(count)
}

fn parse_cells(text: &str) -> Option<UVec3> {
    let axes: Vec<u32> = text
        .split(['x', 'X'])
        .map(|axis| axis.trim().parse().ok())
        .collect::<Option<_>>()?;
    let cells = match *axes.as_slice() {
        [n] => UVec3::splat(n),
        [x, y, z] => UVec3::new(x, y, z),
        _ => return None,
    };
    let valid = (8..=MAX_CELLS_PER_AXIS).contains(&cells.min_element())
        && cells.max_element() <= MAX_CELLS_PER_AXIS;
    valid.then_some(cells)
}

/// The falling ball of a size, in cells.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Ball {
    centre: Vec3,
    radius: f32,
    particles_per_cell: u32,
    /// Whether the box was too small for the ball at 8 particles per cell.
    shrunk: bool,
}

impl Ball {
    /// A ball of about `particles` at 8 per cell, centred horizontally and
    /// 60 % of the way up `cells`; in a box too small for it (its diameter
    /// over 80 % of the shortest side) it shrinks and packs up to 64 per cell.
    fn new(particles: u64, cells: UVec3) -> Ball {
        let volume_per_cell = 4.0 / 3.0 * std::f64::consts::PI;
        let nominal = (particles as f64 / (PARTICLES_PER_CELL as f64 * volume_per_cell)).cbrt();
        let fitting = 0.4 * cells.min_element() as f64 - 1.0;
        let (radius, particles_per_cell) = if nominal <= fitting {
            (nominal, PARTICLES_PER_CELL)
        } else {
            let per_cell = particles as f64 / (volume_per_cell * fitting.powi(3));
            (fitting, per_cell.round().clamp(1.0, 64.0) as u32)
        };
        let box_size = cells.as_vec3();
        Ball {
            centre: Vec3::new(0.5 * box_size.x, 0.6 * box_size.y, 0.5 * box_size.z),
            radius: radius as f32,
            particles_per_cell,
            shrunk: nominal > fitting,
        }
    }

    /// Expected particle count: the ball's volume over the lattice's.
    fn expected_particles(&self) -> f64 {
        4.0 / 3.0
            * std::f64::consts::PI
            * (self.radius as f64).powi(3)
            * self.particles_per_cell as f64
    }
}

/// The bench's snowball drop, in a box of `cells` at h = 1/256 m, with `ball`.
fn sweep_scene(cells: UVec3, ball: &Ball, transfer: Transfer) -> Scene {
    let particles = ball.expected_particles().round().min(u32::MAX as f64) as u32;
    let mut scene = snowball_drop(particles, CELLS_PER_METRE, transfer);
    let h = scene.domain.cell_size;
    scene.domain.max = cells.as_vec3() * h;
    let body = &mut scene.bodies[0];
    body.shape = Shape::Sphere {
        center: ball.centre * h,
        radius: ball.radius * h,
    };
    body.particles_per_cell = ball.particles_per_cell;
    scene
}

/// Bytes a simulation of `particles` in `ball` on `layout` holds at its
/// peak. The grid is sparse: a page table and the binning's block table, 4
/// bytes each per block of the box, and node storage only for the blocks near
/// the snow, here the ball's bounding cube in blocks widened by one block each
/// side for the stencils' reach (twice over, for the pool's growth). Per
/// particle: its attributes, bin key and order, and the space to reorder
/// them.
fn estimate_bytes(layout: &GridLayout, ball: &Ball, particles: u64) -> u64 {
    let blocks = layout.blocks.as_u64vec3();
    let tables = blocks.element_product() * 2 * std::mem::size_of::<u32>() as u64;
    let ball_blocks = ((2.0 * ball.radius + 2.0) / BLOCK_WIDTH as f32).ceil() as u64 + 3;
    let near_blocks = blocks
        .min(glam::U64Vec3::splat(ball_blocks))
        .element_product();
    let nodes = 2 * near_blocks * (BLOCK_NODES * std::mem::size_of::<Node>()) as u64;
    let per_particle = Particles::bytes_per_particle()
        + std::mem::size_of::<u32>()
        + PermuteBuffers::BYTES_PER_PARTICLE;
    tables + nodes + particles * per_particle as u64
}

/// Measures one size with one scheme, or records why it was skipped.
fn measure_size(
    kind: SweepKind,
    size: &SweepSize,
    transfer: Transfer,
    args: &BenchArgs,
    budget: Option<u64>,
) -> Result<SweepRecord, String> {
    let ball = Ball::new(size.particles, size.cells);
    let scene = sweep_scene(size.cells, &ball, transfer);
    let h = scene.domain.cell_size;
    let dt = match scene.time.step {
        firn_core::scene::TimeStep::Fixed { dt } => dt,
        firn_core::scene::TimeStep::Adaptive { max_dt, .. } => max_dt,
    };
    let layout = GridLayout::new(scene.domain.min, scene.domain.max, h);
    let nodes = layout.node_dims();
    let needed = estimate_bytes(
        &layout,
        &ball,
        (ball.expected_particles() * COUNT_MARGIN).ceil() as u64,
    );
    let resident = procfs::status_bytes("VmRSS");
    let mut record = SweepRecord {
        sweep: kind.name(),
        transfer,
        size: size.label.clone(),
        target_particles: size.particles,
        particles: None,
        cells: size.cells.to_array(),
        grid_nodes: nodes.to_array(),
        grid_nodes_total: nodes.as_u64vec3().element_product(),
        cell_size: h,
        dt,
        threads: rayon::current_num_threads(),
        substeps: 0,
        seconds: None,
        substeps_per_second: None,
        ns_per_particle_substep: None,
        cpu_seconds: None,
        cpu_ns_per_particle_substep: None,
        estimated_peak_bytes: resident.unwrap_or(0) + needed,
        measured_peak_bytes: None,
        fits: true,
        note: String::new(),
    };
    let mut notes = Vec::new();
    if ball.shrunk {
        notes.push(format!(
            "box too small for the ball: radius {:.1} cells, {} per cell",
            ball.radius, ball.particles_per_cell
        ));
    }
    match memory_limit(budget) {
        Some((limit, source)) if needed > limit => {
            record.fits = false;
            record.note = format!(
                "{}: needs {}, {} available{source} — skipped",
                size.label,
                format_bytes(needed),
                format_bytes(limit)
            );
            return Ok(record);
        }
        Some(_) => {}
        None => notes.push("available memory unknown".into()),
    }
    let peak_reset = procfs::reset_peak();
    let message = |failure| match failure {
        Failure::BadInput(message) | Failure::Failed(message) => message,
    };
    let mut solver = bench_solver(scene, &Placement::Cpu, args).map_err(message)?;
    let budget = Duration::from_secs_f64(args.sweep.sweep_seconds);
    time_substeps(&mut solver, args.warmup, 0, None).map_err(message)?;
    let cpu_before = procfs::cpu_seconds();
    let (substeps, seconds) =
        time_substeps(&mut solver, 0, args.steps, Some(budget)).map_err(message)?;
    let cpu = cpu_before
        .zip(procfs::cpu_seconds())
        .map(|(before, after)| after - before);
    record.measured_peak_bytes = procfs::status_bytes("VmHWM");
    if record.measured_peak_bytes.is_some() && !peak_reset {
        notes.push("peak is the process' so far (clear_refs not writable)".into());
    }
    let particles = solver.particle_count() as u64;
    record_timing(&mut record, particles, substeps, seconds, cpu);
    record.note = notes.join("; ");
    Ok(record)
}

/// The memory a size may use and where that figure comes from: the
/// `--memory-budget`, else what the machine has available less headroom.
fn memory_limit(budget: Option<u64>) -> Option<(u64, &'static str)> {
    match budget {
        Some(bytes) => Some((bytes, " (--memory-budget)")),
        None => {
            procfs::available_bytes().map(|bytes| ((bytes as f64 * MEMORY_HEADROOM) as u64, ""))
        }
    }
}

/// Fills in the speed figures of `substeps` timed substeps of `particles`
/// particles that took `seconds` of wall clock and `cpu` seconds of CPU.
fn record_timing(
    record: &mut SweepRecord,
    particles: u64,
    substeps: u32,
    seconds: f64,
    cpu: Option<f64>,
) {
    record.particles = Some(particles);
    record.substeps = substeps;
    if substeps == 0 {
        return;
    }
    record.seconds = Some(seconds);
    record.substeps_per_second = Some(substeps as f64 / seconds);
    let per_particle_substep = 1e9 / (substeps as f64 * particles.max(1) as f64);
    record.ns_per_particle_substep = Some(seconds * per_particle_substep);
    record.cpu_seconds = cpu;
    record.cpu_ns_per_particle_substep = cpu.map(|cpu| cpu * per_particle_substep);
}

/// "4.3 GiB" from a gibibyte on, else "512.0 MiB".
fn format_bytes(bytes: u64) -> String {
    let bytes = bytes as f64;
    if bytes >= GIB {
        format!("{:.1} GiB", bytes / GIB)
    } else {
        format!("{:.1} MiB", bytes / MIB)
    }
}

/// Writes sweep-KIND.csv, sweep-KIND.json and, when a size was measured, the
/// charts sweep-KIND-substeps.png and sweep-KIND-ns.png.
fn write_outputs(kind: SweepKind, records: &[SweepRecord], out: &Path) -> Result<(), Failure> {
    let stem = format!("sweep-{}", kind.name());
    let write = |name: String, bytes: &[u8]| {
        let path = out.join(name);
        firn_io::write_atomically(&path, |file| file.write_all(bytes))
            .map_err(|error| Failure::BadInput(format!("error: {error}")))?;
        outln!("wrote {}", path.display());
        Ok::<(), Failure>(())
    };
    write(format!("{stem}.csv"), csv(records).as_bytes())?;
    let json = crate::bench::records_json(records)?;
    write(format!("{stem}.json"), json.as_bytes())?;

    if !records
        .iter()
        .any(|record| record.substeps_per_second.is_some())
    {
        outln!("no size was measured: no charts");
        return Ok(());
    }
    let threads = records.first().map_or(1, |record| record.threads);
    let (setting, x_label, x_ticks) = match kind {
        SweepKind::Particles => (
            format!(
                "{PARTICLE_SWEEP_CELLS}³ grid, h = 1/{CELLS_PER_METRE} m, {PARTICLES_PER_CELL} particles per cell"
            ),
            "particles, log₂ scale".to_string(),
            XTicks::PowersOfTwo,
        ),
        SweepKind::Grid => (
            format!(
                "2{} particles, h = 1/{CELLS_PER_METRE} m, the box grows with the grid",
                superscript(GRID_SWEEP_PARTICLES.trailing_zeros() as i32)
            ),
            "grid size in cells, log₂ scale of the cell count".to_string(),
            XTicks::Labelled(grid_ticks(records)),
        ),
    };
    let subtitle =
        format!("firn, snowball drop of thesis §6.2, explicit, f32; {setting}; {threads} threads");
    let versus = match kind {
        SweepKind::Particles => "particle count",
        SweepKind::Grid => "grid size",
    };
    let charts_to_draw = [
        (
            "substeps",
            format!("Substeps per second against {versus}"),
            "substeps per second, 1/s",
            Metric::SubstepsPerSecond,
        ),
        (
            "ns",
            format!("Time per particle and substep against {versus}"),
            "ns per particle-substep, wall clock",
            Metric::NsPerParticleSubstep,
        ),
    ];
    for (suffix, title, y_label, metric) in charts_to_draw {
        let path = out.join(format!("{stem}-{suffix}.png"));
        let text = ChartText {
            title,
            subtitle: subtitle.clone(),
            x_label: x_label.clone(),
            y_label: y_label.to_string(),
        };
        let series = charts::build_series(&samples(kind, records, metric));
        charts::draw_chart(&path, &text, &x_ticks, &series)
            .map_err(|error| Failure::Failed(format!("error: {error}")))?;
        outln!("wrote {}", path.display());
    }
    Ok(())
}

/// Which measured value a chart shows.
#[derive(Clone, Copy, Debug)]
enum Metric {
    SubstepsPerSecond,
    NsPerParticleSubstep,
}

/// The records as chart samples: x is the particle count (particle sweep)
/// or the cell count (grid sweep); skipped sizes have no y.
fn samples(kind: SweepKind, records: &[SweepRecord], metric: Metric) -> Vec<Sample> {
    records
        .iter()
        .map(|record| Sample {
            series: scheme_legend(record.transfer).into(),
            x: match kind {
                SweepKind::Particles => record.particles.unwrap_or(record.target_particles) as f64,
                SweepKind::Grid => record.cells.iter().map(|&n| n as f64).product(),
            },
            y: match metric {
                Metric::SubstepsPerSecond => record.substeps_per_second,
                Metric::NsPerParticleSubstep => record.ns_per_particle_substep,
            },
        })
        .collect()
}

fn scheme_legend(transfer: Transfer) -> &'static str {
    match transfer {
        Transfer::PicFlip => "PIC/FLIP, cubic B-splines",
        Transfer::Apic => "APIC, quadratic B-splines",
    }
}

/// Ticks of the grid sweep's x-axis: each measured size, "64³" or
/// "512×512×256".
fn grid_ticks(records: &[SweepRecord]) -> Vec<(f64, String)> {
    let mut ticks: Vec<(f64, String)> = Vec::new();
    for record in records.iter().filter(|record| record.fits) {
        let [x, y, z] = record.cells;
        let cells = x as f64 * y as f64 * z as f64;
        let label = if x == y && y == z {
            format!("{x}³")
        } else {
            format!("{x}×{y}×{z}")
        };
        if !ticks.iter().any(|(at, _)| *at == cells) {
            ticks.push((cells, label));
        }
    }
    ticks
}

/// The records as CSV, a header line and one line per record.
fn csv(records: &[SweepRecord]) -> String {
    let mut text = String::from(
        "sweep,transfer,size,target_particles,particles,cells_x,cells_y,cells_z,\
         grid_nodes_x,grid_nodes_y,grid_nodes_z,grid_nodes,cell_size,dt,threads,substeps,\
         seconds,substeps_per_second,ns_per_particle_substep,cpu_seconds,\
         cpu_ns_per_particle_substep,estimated_peak_bytes,measured_peak_bytes,fits,note\n",
    );
    let optional = |value: Option<String>| value.unwrap_or_default();
    for record in records {
        let [cx, cy, cz] = record.cells;
        let [nx, ny, nz] = record.grid_nodes;
        let _ = writeln!(
            text,
            "{},{},{},{},{},{cx},{cy},{cz},{nx},{ny},{nz},{},{},{},{},{},{},{},{},{},{},{},{},{},\"{}\"",
            record.sweep,
            transfer_name(record.transfer),
            record.size,
            record.target_particles,
            optional(record.particles.map(|n| n.to_string())),
            record.grid_nodes_total,
            record.cell_size,
            record.dt,
            record.threads,
            record.substeps,
            optional(record.seconds.map(|s| format!("{s:.6}"))),
            optional(record.substeps_per_second.map(|s| format!("{s:.4}"))),
            optional(record.ns_per_particle_substep.map(|s| format!("{s:.3}"))),
            optional(record.cpu_seconds.map(|s| format!("{s:.2}"))),
            optional(
                record
                    .cpu_ns_per_particle_substep
                    .map(|s| format!("{s:.3}"))
            ),
            record.estimated_peak_bytes,
            optional(record.measured_peak_bytes.map(|b| b.to_string())),
            record.fits,
            record.note.replace('"', "\"\""),
        );
    }
    text
}

/// Memory and CPU time of this process and the machine's free memory, from
/// /proc on Linux; `None` (or `false`) elsewhere.
mod procfs {
    /// User and system CPU seconds of all this process' threads, from
    /// /proc/self/stat (the kernel's fixed 100 ticks per second).
    pub fn cpu_seconds() -> Option<f64> {
        let stat = std::fs::read_to_string("/proc/self/stat").ok()?;
        // Fields after the command name (which may hold spaces) start at 3.
        let fields: Vec<&str> = stat.rsplit_once(')')?.1.split_whitespace().collect();
        let ticks = |field: usize| fields.get(field - 3)?.parse::<f64>().ok();
        Some((ticks(14)? + ticks(15)?) / 100.0)
    }

    /// A "kB" field of /proc/self/status (VmRSS, VmHWM), in bytes.
    pub fn status_bytes(field: &str) -> Option<u64> {
        let status = std::fs::read_to_string("/proc/self/status").ok()?;
        kib_field(&status, field)
    }

    /// Resets VmHWM to the current resident size (Linux 4.0 on), so that the
    /// next reading is the peak of what follows.
    pub fn reset_peak() -> bool {
        std::fs::write("/proc/self/clear_refs", "5").is_ok()
    }

    /// MemAvailable, or less where a cgroup (v2 or v1) limits this process.
    pub fn available_bytes() -> Option<u64> {
        let meminfo = std::fs::read_to_string("/proc/meminfo").ok()?;
        let available = kib_field(&meminfo, "MemAvailable")?;
        let read =
            |path: &str| -> Option<u64> { std::fs::read_to_string(path).ok()?.trim().parse().ok() };
        let cgroup = [
            ("/sys/fs/cgroup/memory.max", "/sys/fs/cgroup/memory.current"),
            (
                "/sys/fs/cgroup/memory/memory.limit_in_bytes",
                "/sys/fs/cgroup/memory/memory.usage_in_bytes",
            ),
        ]
        .iter()
        .find_map(|(limit, usage)| Some(read(limit)?.saturating_sub(read(usage)?)));
        Some(cgroup.map_or(available, |free| free.min(available)))
    }

    fn kib_field(text: &str, field: &str) -> Option<u64> {
        let line = text
            .lines()
            .find(|line| line.split(':').next() == Some(field))?;
        let kib: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
        Some(kib * 1024)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sizes_parse_counts_and_grids() {
        let counts = parse_sizes(SweepKind::Particles, &["1024".into(), "2^13".into()]).unwrap();
        assert_eq!(counts[0].particles, 1024);
        assert_eq!(counts[0].label, "2^10");
        assert_eq!(counts[1].particles, 8192);
        let grids = parse_sizes(SweepKind::Grid, &["64".into(), "512x512x256".into()]).unwrap();
        assert_eq!(grids[0].cells, UVec3::splat(64));
        assert_eq!(grids[1].cells, UVec3::new(512, 512, 256));
        assert_eq!(grids[1].label, "512x512x256");
        for bad in ["0", "3^4", "x", "2^40"] {
            assert!(
                parse_sizes(SweepKind::Particles, &[bad.into()]).is_err(),
                "{bad}"
            );
        }
        for bad in ["4", "64x64", "0x64x64", "100000"] {
            assert!(
                parse_sizes(SweepKind::Grid, &[bad.into()]).is_err(),
                "{bad}"
            );
        }
    }

    #[test]
    fn the_grid_sweep_ball_is_the_same_in_every_default_box() {
        let balls: Vec<Ball> = DEFAULT_GRIDS
            .iter()
            .map(|&cells| Ball::new(GRID_SWEEP_PARTICLES, UVec3::from_array(cells)))
            .collect();
        for ball in &balls {
            assert!(!ball.shrunk);
            assert_eq!(ball.radius, balls[0].radius);
            assert_eq!(ball.particles_per_cell, PARTICLES_PER_CELL);
        }
        let expected = balls[0].expected_particles();
        assert!((expected / GRID_SWEEP_PARTICLES as f64 - 1.0).abs() < 1e-6);
    }

    #[test]
    fn the_estimate_follows_the_ball_and_covers_the_simulation() {
        use firn_run::Solver;
        let cells = UVec3::splat(64);
        let ball = Ball::new(1 << 12, cells);
        let scene = sweep_scene(cells, &ball, Transfer::Apic);
        let layout = GridLayout::new(scene.domain.min, scene.domain.max, scene.domain.cell_size);
        let mut solver = Solver::new(scene, &Placement::Cpu).unwrap();
        solver.advance_substeps(3).unwrap();
        let particles = solver.particle_count() as u64;
        let estimate = estimate_bytes(&layout, &ball, particles);
        assert!(estimate >= solver.memory_bytes());

        let big = GridLayout::new(Vec3::ZERO, Vec3::new(2.0, 2.0, 1.0), 1.0 / 256.0);
        let block_bytes = 8 * (big.block_count() - layout.block_count()) as u64;
        assert_eq!(
            estimate_bytes(&big, &ball, particles) - estimate,
            block_bytes,
            "a bigger box costs only its page and binning tables"
        );
    }
}
