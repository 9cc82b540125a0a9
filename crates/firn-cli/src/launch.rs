//! How firn was started: a build without MPI refuses to be one of several
//! processes that mpirun started.
//!
//! Without the `mpi` feature every process that `mpirun -np N firn run`
//! starts would run the whole scene into the same output directory, each
//! overwriting the others' files. MPI launchers tell their processes how
//! many they are through the environment; a build without MPI that finds
//! more than one refuses before it reads or writes anything.

use crate::Failure;

/// The variables MPI launchers set to the number of processes they started:
/// Open MPI's mpirun, MPICH's and Intel MPI's Hydra (and Slurm's PMI), and
/// MVAPICH's.
const LAUNCHER_SIZES: [&str; 3] = ["OMPI_COMM_WORLD_SIZE", "PMI_SIZE", "MV2_COMM_WORLD_SIZE"];

/// Refuses (exit code 2) a start by an MPI launcher with more than one
/// process, in a build without MPI; a build with MPI runs split.
pub fn refuse_mpirun_without_mpi() -> Result<(), Failure> {
    if cfg!(feature = "mpi") {
        return Ok(());
    }
    match launched_as(|name| std::env::var(name).ok()) {
        Some((variable, processes)) => Err(Failure::BadInput(format!(
            "error: firn was started as one of {processes} processes ({variable}={processes}), \
             but this build has no MPI: every process would run the whole scene into the same \
             output directory\n  fix: build firn with MPI (cargo build --release -p firn-cli \
             --features mpi; it needs Open MPI or MPICH and libclang, see the README's \"MPI\" \
             section) and start that binary with mpirun, or run firn without mpirun"
        ))),
        None => Ok(()),
    }
}

/// The first launcher variable that `lookup` gives a process count above
/// one for, with that count.
fn launched_as(lookup: impl Fn(&str) -> Option<String>) -> Option<(&'static str, u32)> {
    LAUNCHER_SIZES.into_iter().find_map(|variable| {
        let processes = lookup(variable)?.trim().parse::<u32>().ok()?;
        (processes > 1).then_some((variable, processes))
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn environment(pairs: &[(&str, &str)]) -> impl Fn(&str) -> Option<String> {
        let pairs: Vec<(String, String)> = pairs
            .iter()
            .map(|(k, v)| (k.to_string(), v.to_string()))
            .collect();
        move |name| {
            pairs
                .iter()
                .find(|(key, _)| key == name)
                .map(|(_, value)| value.clone())
        }
    }

    #[test]
    fn every_launcher_is_recognised() {
        for variable in LAUNCHER_SIZES {
            assert_eq!(
                launched_as(environment(&[(variable, "4")])),
                Some((variable, 4))
            );
        }
    }

    #[test]
    fn one_process_or_none_is_not_a_split_launch() {
        assert_eq!(launched_as(environment(&[])), None);
        assert_eq!(
            launched_as(environment(&[("OMPI_COMM_WORLD_SIZE", "1")])),
            None
        );
        assert_eq!(launched_as(environment(&[("PMI_SIZE", "x")])), None);
    }
}
