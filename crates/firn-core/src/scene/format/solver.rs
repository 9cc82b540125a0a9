//! Reads and checks the `[solver]` table: transfer, gravity, seed and the time integrator.

use serde::Deserialize;

use super::issue::{Check, Issue, KeyPath};
use super::values::{Num, ensure, finite_vec, vec3};
use crate::scene::model::{ImplicitSettings, Integrator, SolverSettings, Transfer};

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawSolver {
    transfer: Option<RawTransfer>,
    flip: Option<f32>,
    gravity: Option<[f32; 3]>,
    seed: Option<u64>,
    integrator: Option<RawIntegrator>,
    implicit_beta: Option<f32>,
    solver_tolerance: Option<f32>,
    solver_max_iterations: Option<u32>,
}

#[derive(Clone, Copy, Deserialize)]
#[serde(rename_all = "kebab-case")]
enum RawIntegrator {
    Explicit,
    SemiImplicit,
}

#[derive(Clone, Copy, Deserialize)]
#[serde(rename_all = "kebab-case")]
enum RawTransfer {
    PicFlip,
    Apic,
}

pub(super) fn resolve_solver(raw: Option<RawSolver>) -> Result<SolverSettings, Issue> {
    let raw = raw.unwrap_or(RawSolver {
        transfer: None,
        flip: None,
        gravity: None,
        seed: None,
        integrator: None,
        implicit_beta: None,
        solver_tolerance: None,
        solver_max_iterations: None,
    });
    let integrator = resolve_integrator(&raw)?;
    let defaults = SolverSettings::default();
    Ok(SolverSettings {
        transfer: match raw.transfer {
            Some(RawTransfer::Apic) => Transfer::Apic,
            Some(RawTransfer::PicFlip) => Transfer::PicFlip,
            None => defaults.transfer,
        },
        flip_blend: raw.flip.unwrap_or(defaults.flip_blend),
        gravity: raw.gravity.map_or(defaults.gravity, vec3),
        seed: raw.seed.unwrap_or(defaults.seed),
        integrator,
    })
}

/// The time integrator; the semi-implicit solver's keys are an error with
/// the explicit one, like `cfl` with a fixed step.
fn resolve_integrator(raw: &RawSolver) -> Result<Integrator, Issue> {
    // Without the key: the kind of `Integrator::default()`.
    let integrator = raw.integrator.unwrap_or(match Integrator::default() {
        Integrator::Explicit => RawIntegrator::Explicit,
        Integrator::SemiImplicit(_) => RawIntegrator::SemiImplicit,
    });
    match integrator {
        RawIntegrator::SemiImplicit => {
            let defaults = ImplicitSettings::default();
            Ok(Integrator::SemiImplicit(ImplicitSettings {
                beta: raw.implicit_beta.unwrap_or(defaults.beta),
                tolerance: raw.solver_tolerance.unwrap_or(defaults.tolerance),
                max_iterations: raw.solver_max_iterations.unwrap_or(defaults.max_iterations),
            }))
        }
        RawIntegrator::Explicit => {
            let implicit_keys = [
                ("implicit_beta", raw.implicit_beta.is_some()),
                ("solver_tolerance", raw.solver_tolerance.is_some()),
                ("solver_max_iterations", raw.solver_max_iterations.is_some()),
            ];
            match implicit_keys.iter().find(|(_, given)| *given) {
                Some((key, _)) => Err(Issue::new(
                    KeyPath::of("solver").key(key),
                    format!("solver.{key} only applies when integrator = \"semi-implicit\""),
                    format!("remove {key}, or set integrator = \"semi-implicit\""),
                )),
                None => Ok(Integrator::Explicit),
            }
        }
    }
}

pub(super) fn check_solver(solver: &SolverSettings) -> Check {
    let path = KeyPath::of("solver");
    ensure(
        (0.0..=1.0).contains(&solver.flip_blend),
        path.key("flip"),
        "in [0, 1]",
        Num::from(solver.flip_blend),
        "set the FLIP share of the PIC/FLIP blend, e.g. flip = 0.95 (0: pure PIC)".to_string(),
    )?;
    finite_vec(solver.gravity, path.key("gravity"))?;
    check_integrator(&path, &solver.integrator)
}

fn check_integrator(path: &KeyPath, integrator: &Integrator) -> Check {
    let Integrator::SemiImplicit(settings) = integrator else {
        return Ok(());
    };
    ensure(
        (0.0..=1.0).contains(&settings.beta),
        path.key("implicit_beta"),
        "in [0, 1]",
        Num::from(settings.beta),
        "set how implicit the update is, e.g. implicit_beta = 0.5 (0: explicit, 1: backward \
         Euler)"
            .to_string(),
    )?;
    ensure(
        settings.tolerance > 0.0 && settings.tolerance < 1.0,
        path.key("solver_tolerance"),
        "in (0, 1)",
        Num::from(settings.tolerance),
        "set the relative residual at which the solve stops, e.g. solver_tolerance = 1e-3 \
         (below 1e-5, f32 rounding may keep it from converging)"
            .to_string(),
    )?;
    ensure(
        settings.max_iterations >= 1,
        path.key("solver_max_iterations"),
        "at least 1",
        settings.max_iterations,
        "allow the solver some iterations, e.g. solver_max_iterations = 100".to_string(),
    )
}
