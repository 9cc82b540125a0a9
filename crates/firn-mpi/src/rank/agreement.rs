//! How the ranks agree after a substep: a failure anywhere becomes every
//! rank's, the one the one process would report (the lowest key first).

use firn_mpm::SimulationError;
use firn_run::RunError;

use super::{Phase, RankSnow};
use crate::exchange::Exchange;
use crate::packing::{bytes_to_words, words_to_bytes};

impl<E: Exchange> RankSnow<E> {
    /// Every rank learns whether the substep failed anywhere; the failure
    /// of the lowest key (then the lowest rank) is everyone's.
    pub(super) fn agree(&mut self, result: Result<f32, SimulationError>) -> Result<f32, RunError> {
        let own_failure = result.as_ref().err().map(|error| self.keyed(error));
        let failure = own_failure
            .as_ref()
            .map(|(key, error)| (*key, error.to_string()));
        match (self.first_failure(failure), own_failure, result) {
            (None, _, result) => Ok(result.expect("no rank failed")),
            (Some((rank, _)), Some((_, error)), _) if rank == self.exchange.rank() => {
                Err(RunError::Snow(error))
            }
            (Some((rank, message)), _, _) => Err(RunError::Rank {
                rank,
                ranks: self.exchange.size(),
                message,
            }),
        }
    }

    /// Every rank's failure, if any (a key that orders failures, and a
    /// message): the rank and message of the failure with the lowest key,
    /// then the lowest rank, on every rank; `None` when no rank failed.
    /// One minimum over the ranks finds it (key · ranks + rank), and only
    /// when a rank failed does it broadcast its message.
    pub(super) fn first_failure(
        &mut self,
        failure: Option<(u64, String)>,
    ) -> Option<(usize, String)> {
        let (me, ranks) = (self.rank(), self.exchange.size() as u64);
        let mine = failure
            .as_ref()
            .map_or(u64::MAX, |(key, _)| key * ranks + me as u64);
        let first = self.timed(Phase::Agreement, |exchange| exchange.min_u64(&[mine]))[0];
        if first == u64::MAX {
            return None;
        }
        let rank = (first % ranks) as usize;
        let message = match failure {
            Some((_, message)) if rank == me => text_to_words(&message),
            _ => Vec::new(),
        };
        let words = self.timed(Phase::Agreement, |exchange| {
            exchange.broadcast_from(rank, message)
        });
        Some((rank, words_to_text(&words)))
    }

    /// `error` with its particle named by key (its one-process index), and
    /// that key (0 for a failure of the whole substep).
    pub(super) fn keyed(&self, error: &SimulationError) -> (u64, SimulationError) {
        match error {
            SimulationError::Unstable {
                time,
                step,
                dt,
                particle,
                what,
                position,
                hint,
            } => {
                let key = self.own_keys()[*particle];
                let keyed = SimulationError::Unstable {
                    time: *time,
                    step: *step,
                    dt: *dt,
                    particle: key as usize,
                    what,
                    position: *position,
                    hint: hint.clone(),
                };
                (key, keyed)
            }
            other => (0, SimulationError::SnapshotMismatch(other.to_string())),
        }
    }
}

/// A text as words ([`bytes_to_words`]).
fn text_to_words(text: &str) -> Vec<u32> {
    bytes_to_words(text.as_bytes())
}

/// The text of [`text_to_words`].
fn words_to_text(words: &[u32]) -> String {
    String::from_utf8_lossy(&words_to_bytes(words)).into_owned()
}
