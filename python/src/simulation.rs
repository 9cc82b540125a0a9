//! `firn.Solver` and its two kinds, `firn.Simulation` (snow) and
//! `firn.FlowSimulation` (curl noise): a scene running on the CPU or the
//! GPU through firn-run's `Solver`, stepped by substeps, frames or simulated
//! time with the GIL released, and stopped cleanly by Ctrl-C between
//! substeps or frames; its frame rendered as a numpy image.

use std::sync::Arc;
use std::time::Instant;

use firn_core::scene::{Backend, SceneKind};
use firn_flow::FlowView;
use firn_mpm::particles::Particles;
use firn_render::scene_view::{scene_camera, scene_picture};
use firn_run::pictures::frame_particles;
use firn_run::simulation::{HostState, SolverState};
use firn_run::{Placement, choose_backend};
use glam::{DVec3, Vec3};
use numpy::{AllowTypeChange, PyArray1, PyArray2, PyArray3, PyArrayLike2, PyArrayMethods};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::arrays::{
    matrices_array, points_from_numpy, positions_from_numpy, scalars_array, vectors_array,
};
use crate::errors::simulation_error;
use crate::pictures::{image_array, image_size, style_or_default};
use crate::scene::PyScene;

/// Substeps stepped between two looks for Ctrl-C.
const SUBSTEPS_BETWEEN_SIGNAL_CHECKS: u32 = 8;

/// A scene running on some backend: the stepping shared by snow and flows.
#[pyclass(name = "Solver", module = "firn", subclass)]
pub struct Solver {
    /// The solver of firn-run, as `firn run` uses it.
    solver: firn_run::Solver,
    /// Where it runs.
    placement: Placement,
    /// The worker threads it steps on, if not rayon's global pool.
    pool: Option<Arc<rayon::ThreadPool>>,
    /// The scene, as given.
    scene: PyScene,
}

impl Solver {
    /// Starts `scene` on `backend` with `threads` worker threads.
    fn start(
        scene_given: &PyScene,
        backend: &str,
        threads: Option<usize>,
        kind: SceneKindName,
    ) -> PyResult<Solver> {
        let mut scene = scene_given.scene.clone();
        let is_flow = matches!(scene.kind, SceneKind::Flow(_));
        if is_flow != (kind == SceneKindName::Flow) {
            return Err(PyValueError::new_err(match kind {
                SceneKindName::Snow => "this scene is a flow: use firn.FlowSimulation",
                SceneKindName::Flow => "this scene is snow: use firn.Simulation",
            }));
        }
        scene.compute.backend = backend_named(backend)?;
        let pool = match threads {
            Some(0) => return Err(PyValueError::new_err("threads must be at least 1")),
            Some(count) => Some(Arc::new(
                rayon::ThreadPoolBuilder::new()
                    .num_threads(count)
                    .build()
                    .map_err(simulation_error)?,
            )),
            None => None,
        };
        let placement = choose_backend(&scene).map_err(simulation_error)?.placement;
        let solver = in_pool(&pool, || firn_run::Solver::new(scene, &placement))
            .map_err(simulation_error)?;
        Ok(Solver {
            solver,
            placement,
            pool,
            scene: scene_given.clone(),
        })
    }

    /// Runs `work` on the solver with the GIL released, in its thread pool.
    fn stepping<T: Send>(
        &mut self,
        py: Python<'_>,
        work: impl FnOnce(&mut firn_run::Solver) -> Result<T, firn_run::RunError> + Send,
    ) -> PyResult<T> {
        let Solver { solver, pool, .. } = self;
        py.detach(|| in_pool(pool, || work(solver)))
            .map_err(simulation_error)
    }

    /// The state in host memory (read back from the GPU if need be).
    fn host(&mut self) -> PyResult<HostState<'_>> {
        self.solver.host().map_err(simulation_error)
    }

    /// Replaces the state by `state`, on the same backend.
    fn restore(&mut self, state: SolverState) -> PyResult<()> {
        let options = self.solver.options();
        let scene = self.solver.scene().clone();
        let placement = self.placement.clone();
        self.solver = in_pool(&self.pool, || {
            firn_run::Solver::restore(scene, state, &placement)
        })
        .map_err(simulation_error)?
        .with_options(options);
        Ok(())
    }

    /// Calls `progress` with a dict of how far stepping has come: `done`
    /// is the share of the call's work done (0 to 1).
    fn report(
        &self,
        py: Python<'_>,
        progress: &Option<Py<PyAny>>,
        started: Instant,
        substeps: u64,
        done: f64,
    ) -> PyResult<()> {
        let Some(callback) = progress else {
            return Ok(());
        };
        let elapsed = started.elapsed().as_secs_f64().max(1e-9);
        let info = PyDict::new(py);
        info.set_item("frame", self.solver.frame())?;
        info.set_item("time", self.solver.time())?;
        info.set_item("substeps", self.solver.steps())?;
        info.set_item("substeps_per_second", substeps as f64 / elapsed)?;
        info.set_item("elapsed_seconds", elapsed)?;
        info.set_item("eta_seconds", elapsed * (1.0 - done) / done.max(1e-9))?;
        callback.call1(py, (info,))?;
        Ok(())
    }
}

/// The backend named `name`: "cpu", "gpu" or "auto".
pub fn backend_named(name: &str) -> PyResult<Backend> {
    name.parse().map_err(PyValueError::new_err)
}

/// Which of the two simulation classes is starting.
#[derive(Clone, Copy, PartialEq, Eq)]
enum SceneKindName {
    Snow,
    Flow,
}

/// Runs `work` in `pool` if there is one.
fn in_pool<T: Send>(pool: &Option<Arc<rayon::ThreadPool>>, work: impl FnOnce() -> T + Send) -> T {
    match pool {
        Some(pool) => pool.install(work),
        None => work(),
    }
}

#[pymethods]
impl Solver {
    /// Takes `substeps` substeps (on the GPU: as many as the time of that
    /// many of the longest substep); returns the substeps taken.
    #[pyo3(signature = (substeps = 1))]
    fn step(&mut self, py: Python<'_>, substeps: u32) -> PyResult<u32> {
        let mut left = substeps;
        let mut taken = 0;
        while left > 0 {
            let chunk = left.min(SUBSTEPS_BETWEEN_SIGNAL_CHECKS);
            taken += self.stepping(py, |solver| solver.advance_substeps(chunk))?;
            left -= chunk;
            py.check_signals()?;
        }
        Ok(taken)
    }

    /// Steps `frames` whole frames; `progress`, if given, is called after
    /// each with a dict (frame, time, substeps, substeps_per_second,
    /// elapsed_seconds, eta_seconds). Returns the frame reached.
    #[pyo3(signature = (frames = 1, progress = None))]
    fn advance_frames(
        &mut self,
        py: Python<'_>,
        frames: u32,
        progress: Option<Py<PyAny>>,
    ) -> PyResult<u32> {
        let started = Instant::now();
        let first = self.solver.steps();
        for done in 1..=frames {
            self.stepping(py, |solver| solver.advance_frame())?;
            let share = f64::from(done) / f64::from(frames);
            self.report(py, &progress, started, self.solver.steps() - first, share)?;
            py.check_signals()?;
        }
        Ok(self.solver.frame())
    }

    /// Steps until simulated time `time` (seconds), frame by frame;
    /// `progress` as for `advance_frames`. Returns the substeps taken.
    #[pyo3(signature = (time, progress = None))]
    fn advance_to(
        &mut self,
        py: Python<'_>,
        time: f64,
        progress: Option<Py<PyAny>>,
    ) -> PyResult<u64> {
        if !time.is_finite() {
            return Err(PyValueError::new_err(
                "time must be a finite number of seconds",
            ));
        }
        let started = Instant::now();
        let (first, start_time) = (self.solver.steps(), self.solver.time());
        let frame_length = 1.0 / self.solver.scene().time.fps;
        while self.solver.time() < time - 1e-9 {
            let next = (f64::from(self.solver.frame() + 1) * frame_length).min(time);
            self.stepping(py, |solver| solver.advance_to(next))?;
            let share = (self.solver.time() - start_time) / (time - start_time);
            self.report(py, &progress, started, self.solver.steps() - first, share)?;
            py.check_signals()?;
        }
        Ok(self.solver.steps() - first)
    }

    /// Simulated time in seconds.
    #[getter]
    fn time(&self) -> f64 {
        self.solver.time()
    }

    /// Substeps taken so far.
    #[getter]
    fn substeps(&self) -> u64 {
        self.solver.steps()
    }

    /// Frames completed so far.
    #[getter]
    fn frame(&self) -> u32 {
        self.solver.frame()
    }

    /// `"cpu"` or `"gpu"`.
    #[getter]
    fn backend(&self) -> &'static str {
        self.placement.name()
    }

    /// The scene simulated.
    #[getter]
    fn scene(&self) -> PyScene {
        self.scene.clone()
    }

    /// Bytes of memory the simulation holds (host or device buffers).
    #[getter]
    fn memory_bytes(&self) -> u64 {
        self.solver.memory_bytes()
    }

    /// The simulation now as the scene's camera sees it (its `[camera]`,
    /// or the automatic view of the domain), drawn in `style` ("points",
    /// "volume", "billboards" or "trails"; default: the scene's first
    /// `[render] styles`) at `width` x `height` pixels (default: its
    /// `[render] size`): an (height, width, 3) uint8 array of sRGB pixels,
    /// those `firn run` writes into a frame's PNG at that size.
    #[pyo3(signature = (width = None, height = None, style = None))]
    fn render<'py>(
        &mut self,
        py: Python<'py>,
        width: Option<u32>,
        height: Option<u32>,
        style: Option<&str>,
    ) -> PyResult<Bound<'py, PyArray3<u8>>> {
        let scene = self.solver.scene();
        let size = image_size(scene, width, height)?;
        let style = style_or_default(scene, style)?;
        let pixels = self.stepping(py, |solver| {
            let time = solver.time();
            let host = solver.host()?;
            let scene = host.scene();
            let particles = host.particles(scene.render.color_by);
            let picture =
                scene_picture(scene, time, style, frame_particles(&particles), Some(size));
            Ok(firn_render::render(&picture).into_raw())
        })?;
        image_array(py, pixels, size)
    }

    /// Where `points` (shape (M, 3), metres) fall in a picture of `width`
    /// x `height` pixels (default: `[render] size`) rendered now: (M, 2)
    /// pixel coordinates, x to the right and y down from the top-left
    /// corner (pixel (i, j) covers [i, i+1) x [j, j+1)); NaN for points
    /// behind the camera.
    #[pyo3(signature = (points, width = None, height = None))]
    fn project<'py>(
        &self,
        py: Python<'py>,
        points: PyArrayLike2<'_, f64, AllowTypeChange>,
        width: Option<u32>,
        height: Option<u32>,
    ) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let scene = self.solver.scene();
        let [width, height] = image_size(scene, width, height)?;
        let camera = scene_camera(scene, self.solver.time(), width, height);
        let points = points_from_numpy(&points)?;
        let pixels: Vec<f64> = points
            .iter()
            .flat_map(|point| {
                camera
                    .project(point.as_vec3())
                    .map_or([f64::NAN; 2], |projected| {
                        projected.pixel.as_dvec2().to_array()
                    })
            })
            .collect();
        PyArray1::from_vec(py, pixels).reshape([points.len(), 2])
    }

    fn __len__(&self) -> usize {
        self.solver.particle_count()
    }
}

/// A snow simulation (the Material Point Method of Stomakhin et al. 2013).
///
/// Particle arrays are copies in the solver's current order: the solver
/// reorders its particles by grid block as it steps (and on the GPU they
/// live in device memory), so a view would change under the caller.
#[pyclass(name = "Simulation", module = "firn", extends = Solver)]
pub struct Simulation;

#[pymethods]
impl Simulation {
    /// Starts a snow scene at time 0 on `backend` ("cpu", "gpu" or "auto")
    /// with `threads` worker threads (default: all cores; results are the
    /// same bits for any count).
    #[new]
    #[pyo3(signature = (scene, backend = "cpu", threads = None))]
    fn new(
        scene: &PyScene,
        backend: &str,
        threads: Option<usize>,
    ) -> PyResult<PyClassInitializer<Simulation>> {
        let solver = Solver::start(scene, backend, threads, SceneKindName::Snow)?;
        Ok(PyClassInitializer::from(solver).add_subclass(Simulation))
    }

    /// Positions x_p in metres, shape (N, 3), float32.
    #[getter]
    fn positions<'py>(
        mut this: PyRefMut<'py, Self>,
        py: Python<'py>,
    ) -> PyResult<Bound<'py, PyArray2<f32>>> {
        let particles = snow(this.as_super())?;
        Ok(vectors_array(py, &particles.position))
    }

    /// Sets the positions from an (N, 3) array of finite numbers.
    #[setter]
    fn set_positions(
        mut this: PyRefMut<'_, Self>,
        values: PyArrayLike2<'_, f64, AllowTypeChange>,
    ) -> PyResult<()> {
        set_snow_vectors(this.as_super(), values, "positions", |particles| {
            &mut particles.position
        })
    }

    /// Velocities v_p in m/s, shape (N, 3), float32.
    #[getter]
    fn velocities<'py>(
        mut this: PyRefMut<'py, Self>,
        py: Python<'py>,
    ) -> PyResult<Bound<'py, PyArray2<f32>>> {
        let particles = snow(this.as_super())?;
        Ok(vectors_array(py, &particles.velocity))
    }

    /// Sets the velocities from an (N, 3) array of finite numbers.
    #[setter]
    fn set_velocities(
        mut this: PyRefMut<'_, Self>,
        values: PyArrayLike2<'_, f64, AllowTypeChange>,
    ) -> PyResult<()> {
        set_snow_vectors(this.as_super(), values, "velocities", |particles| {
            &mut particles.velocity
        })
    }

    /// Elastic deformation gradients F_E, shape (N, 3, 3), row-major
    /// (`F[p] @ x` maps a vector), float32.
    #[getter]
    fn elastic_deformation<'py>(
        mut this: PyRefMut<'py, Self>,
        py: Python<'py>,
    ) -> PyResult<Bound<'py, PyArray3<f32>>> {
        let particles = snow(this.as_super())?;
        Ok(matrices_array(py, &particles.elastic))
    }

    /// Plastic volume ratios J_P = det F_P, shape (N,), float32.
    #[getter]
    fn plastic_j<'py>(
        mut this: PyRefMut<'py, Self>,
        py: Python<'py>,
    ) -> PyResult<Bound<'py, PyArray1<f32>>> {
        let particles = snow(this.as_super())?;
        Ok(scalars_array(py, particles.plastic_j.clone()))
    }

    /// Densities ρ_p = m_p / (V⁰_p det F_E J_P) in kg/m³, shape (N,).
    #[getter]
    fn density<'py>(
        mut this: PyRefMut<'py, Self>,
        py: Python<'py>,
    ) -> PyResult<Bound<'py, PyArray1<f32>>> {
        let particles = snow(this.as_super())?;
        Ok(scalars_array(
            py,
            (0..particles.len()).map(|p| particles.density(p)).collect(),
        ))
    }

    /// Masses m_p in kg, shape (N,).
    #[getter]
    fn masses<'py>(
        mut this: PyRefMut<'py, Self>,
        py: Python<'py>,
    ) -> PyResult<Bound<'py, PyArray1<f32>>> {
        let particles = snow(this.as_super())?;
        Ok(scalars_array(py, particles.mass.clone()))
    }

    /// Each particle's material: its index in the scene's materials, (N,).
    #[getter]
    fn material<'py>(
        mut this: PyRefMut<'py, Self>,
        py: Python<'py>,
    ) -> PyResult<Bound<'py, PyArray1<u16>>> {
        let particles = snow(this.as_super())?;
        Ok(PyArray1::from_slice(py, &particles.material))
    }

    fn __repr__(this: PyRef<'_, Self>) -> String {
        let solver = this.as_ref();
        format!(
            "<firn.Simulation '{}': {} snow particles on the {}, t = {:.4} s, frame {}, {} substeps>",
            solver.solver.scene().name,
            solver.solver.particle_count(),
            solver.placement.name(),
            solver.solver.time(),
            solver.solver.frame(),
            solver.solver.steps()
        )
    }
}

/// The snow particles in host memory.
fn snow(solver: &mut Solver) -> PyResult<&Particles> {
    match solver.host()? {
        HostState::Snow(snow) => Ok(snow.particles()),
        HostState::Flow(_) => Err(simulation_error("not a snow simulation")),
    }
}

/// Replaces one vector attribute of every snow particle by `values`.
fn set_snow_vectors(
    solver: &mut Solver,
    values: PyArrayLike2<'_, f64, AllowTypeChange>,
    name: &str,
    attribute: impl FnOnce(&mut Particles) -> &mut Vec<Vec3>,
) -> PyResult<()> {
    let vectors = positions_from_numpy(values, solver.solver.particle_count(), name)?;
    let mut state = solver.solver.state().map_err(simulation_error)?;
    let SolverState::Snow(snapshot) = &mut state else {
        return Err(simulation_error("not a snow simulation"));
    };
    *attribute(&mut snapshot.particles) = vectors;
    solver.restore(state)
}

/// A curl-noise particle flow (Bridson et al. 2007).
///
/// Particle arrays are copies in the flow's current order (emission and
/// expiry change it; on the GPU they live in device memory).
#[pyclass(name = "FlowSimulation", module = "firn", extends = Solver)]
pub struct FlowSimulation;

#[pymethods]
impl FlowSimulation {
    /// Starts a flow scene at time 0 on `backend` with `threads` threads.
    #[new]
    #[pyo3(signature = (scene, backend = "cpu", threads = None))]
    fn new(
        scene: &PyScene,
        backend: &str,
        threads: Option<usize>,
    ) -> PyResult<PyClassInitializer<FlowSimulation>> {
        let solver = Solver::start(scene, backend, threads, SceneKindName::Flow)?;
        Ok(PyClassInitializer::from(solver).add_subclass(FlowSimulation))
    }

    /// Positions in metres, shape (N, 3), float32.
    #[getter]
    fn positions<'py>(
        mut this: PyRefMut<'py, Self>,
        py: Python<'py>,
    ) -> PyResult<Bound<'py, PyArray2<f32>>> {
        let flow = flow(this.as_super())?;
        Ok(vectors_array(py, flow.positions()))
    }

    /// Velocities of the last step in m/s, shape (N, 3), float32.
    #[getter]
    fn velocities<'py>(
        mut this: PyRefMut<'py, Self>,
        py: Python<'py>,
    ) -> PyResult<Bound<'py, PyArray2<f32>>> {
        let flow = flow(this.as_super())?;
        Ok(vectors_array(py, flow.velocities()))
    }

    /// Ages in seconds, shape (N,).
    #[getter]
    fn ages<'py>(
        mut this: PyRefMut<'py, Self>,
        py: Python<'py>,
    ) -> PyResult<Bound<'py, PyArray1<f32>>> {
        let flow = flow(this.as_super())?;
        Ok(PyArray1::from_slice(py, flow.ages()))
    }

    /// Lifetimes in seconds, shape (N,).
    #[getter]
    fn lifetimes<'py>(
        mut this: PyRefMut<'py, Self>,
        py: Python<'py>,
    ) -> PyResult<Bound<'py, PyArray1<f32>>> {
        let flow = flow(this.as_super())?;
        Ok(PyArray1::from_slice(py, flow.lifetimes()))
    }

    /// The field's velocity at `points` (shape (M, 3)) at time `time`
    /// (default: now), in double precision, shape (M, 3).
    #[pyo3(signature = (points, time = None))]
    fn velocity_at<'py>(
        mut this: PyRefMut<'py, Self>,
        py: Python<'py>,
        points: PyArrayLike2<'_, f64, AllowTypeChange>,
        time: Option<f64>,
    ) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let points = points_from_numpy(&points)?;
        let flow = flow(this.as_super())?;
        let t = time.unwrap_or(flow.time());
        let field = flow.field();
        let values: Vec<f64> = points
            .iter()
            .flat_map(|&x| field.velocity_f64(x, t).to_array())
            .collect();
        PyArray1::from_vec(py, values).reshape([points.len(), 3])
    }

    /// The field's divergence ∇·v at `points` (shape (M, 3)), by central
    /// differences of step `h` metres in double precision; zero up to
    /// O(h²) for a divergence-free field. Shape (M,).
    #[pyo3(signature = (points, time = None, h = 1e-4))]
    fn divergence_at<'py>(
        mut this: PyRefMut<'py, Self>,
        py: Python<'py>,
        points: PyArrayLike2<'_, f64, AllowTypeChange>,
        time: Option<f64>,
        h: f64,
    ) -> PyResult<Bound<'py, PyArray1<f64>>> {
        if !(h.is_finite() && h > 0.0) {
            return Err(PyValueError::new_err(
                "h must be a positive number of metres",
            ));
        }
        let points = points_from_numpy(&points)?;
        let flow = flow(this.as_super())?;
        let t = time.unwrap_or(flow.time());
        let field = flow.field();
        let divergence = |x: DVec3| {
            (0..3)
                .map(|axis| {
                    let step = DVec3::AXES[axis] * h;
                    (field.velocity_f64(x + step, t)[axis] - field.velocity_f64(x - step, t)[axis])
                        / (2.0 * h)
                })
                .sum::<f64>()
        };
        Ok(PyArray1::from_vec(
            py,
            points.iter().map(|&x| divergence(x)).collect(),
        ))
    }

    fn __repr__(this: PyRef<'_, Self>) -> String {
        let solver = this.as_ref();
        format!(
            "<firn.FlowSimulation '{}': {} flow particles on the {}, t = {:.4} s, frame {}>",
            solver.solver.scene().name,
            solver.solver.particle_count(),
            solver.placement.name(),
            solver.solver.time(),
            solver.solver.frame()
        )
    }
}

/// The flow in host memory.
fn flow(solver: &mut Solver) -> PyResult<FlowView<'_>> {
    match solver.host()? {
        HostState::Flow(flow) => Ok(flow),
        HostState::Snow(_) => Err(simulation_error("not a flow simulation")),
    }
}
