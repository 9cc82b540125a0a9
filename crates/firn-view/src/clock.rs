//! The fixed-timestep loop of thesis §5.2 (its Quellcode 6): wall-clock time
//! accumulates, and the physics advances in whole ticks of fixed simulated
//! length, so what is simulated does not depend on the display's frame rate.
//!
//! The k-th tick always ends at simulated time k·tick (never a running sum),
//! so two viewers that ran the same number of ticks hold the same state to
//! the bit, whatever their frame rates were. When the physics cannot keep up
//! (a tick costs more wall-clock time than it simulates), the owed time is
//! not silently lost: [`FixedStepClock::real_time_factor`] and
//! [`FixedStepClock::is_behind`] say so, and the panel shows it.

use std::time::{Duration, Instant};

/// Simulated time owed, in ticks, beyond which the excess is dropped (and
/// reported) rather than worked off in a burst.
const MAX_BACKLOG_TICKS: f64 = 8.0;
/// Relative slack when comparing the accumulator with a tick, so that
/// rounding in the sum of frame times never loses a whole tick.
const TICK_SLACK: f64 = 1e-9;
/// Wall-clock window over which the real-time factor is measured.
const FACTOR_WINDOW: Duration = Duration::from_secs(1);

/// Turns wall-clock time into whole ticks of simulated time.
#[derive(Clone, Debug)]
pub struct FixedStepClock {
    /// Simulated seconds per tick.
    tick: f64,
    /// Simulated seconds per wall-clock second wanted (1: real time).
    time_scale: f64,
    /// Simulated seconds owed to the physics.
    accumulator: f64,
    /// Ticks run since the start.
    ticks: u64,
    /// Simulated seconds dropped because the physics fell behind.
    dropped: f64,
    /// Wall-clock and simulated seconds in the current measuring window.
    window: FactorWindow,
}

/// Wall-clock seconds and the simulated seconds run in them.
#[derive(Clone, Copy, Debug, Default)]
struct FactorWindow {
    real: f64,
    simulated: f64,
    dropped: f64,
    /// The last complete window's simulated/real ratio over the time scale.
    factor: Option<f64>,
    /// Whether the last complete window dropped time.
    behind: bool,
}

/// What one display frame's share of the loop did.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct FrameTicks {
    /// Ticks run.
    pub ran: u32,
    /// Simulated seconds dropped because the physics could not keep up.
    pub dropped: f64,
}

impl FixedStepClock {
    /// A clock of `tick` simulated seconds per step, running `time_scale`
    /// simulated seconds per wall-clock second.
    pub fn new(tick: f64, time_scale: f64) -> FixedStepClock {
        assert!(tick > 0.0, "a tick must be positive");
        FixedStepClock {
            tick,
            time_scale,
            accumulator: 0.0,
            ticks: 0,
            dropped: 0.0,
            window: FactorWindow::default(),
        }
    }

    /// A tick for a scene shown at `fps` frames per second: the frame
    /// divided into equal ticks of at most 1/120 s, so scene frames fall on
    /// tick boundaries and motion is smooth on a 60 Hz display.
    pub fn tick_for_frame_rate(fps: f64) -> f64 {
        let frame = 1.0 / fps;
        frame / (frame * 120.0).ceil().max(1.0)
    }

    /// Simulated seconds per tick.
    pub fn tick(&self) -> f64 {
        self.tick
    }

    /// Ticks run since the start.
    pub fn ticks(&self) -> u64 {
        self.ticks
    }

    /// The simulated time at the end of the last tick run.
    pub fn time(&self) -> f64 {
        self.ticks as f64 * self.tick
    }

    /// The simulated time the next tick ends at.
    pub fn next_tick_end(&self) -> f64 {
        (self.ticks + 1) as f64 * self.tick
    }

    /// Simulated seconds wanted per wall-clock second.
    pub fn time_scale(&self) -> f64 {
        self.time_scale
    }

    /// Changes the simulated seconds wanted per wall-clock second.
    pub fn set_time_scale(&mut self, time_scale: f64) {
        self.time_scale = time_scale.max(0.0);
    }

    /// Simulated seconds dropped so far because the physics fell behind.
    pub fn dropped(&self) -> f64 {
        self.dropped
    }

    /// Simulated time per wall-clock time over the last second, relative to
    /// the time scale (1: keeping up); `None` before a second has passed.
    pub fn real_time_factor(&self) -> Option<f64> {
        self.window.factor
    }

    /// Whether the physics fell behind (dropped time) in the last second.
    pub fn is_behind(&self) -> bool {
        self.window.behind
    }

    /// Restarts at time 0 with nothing owed.
    pub fn reset(&mut self) {
        *self = FixedStepClock::new(self.tick, self.time_scale);
    }

    /// Counts one tick run outside the loop (the panel's single step).
    pub fn count_single_tick(&mut self) {
        self.ticks += 1;
    }

    /// One display frame's share of the loop: adds `real` wall-clock
    /// seconds, then calls `step(end)` for each whole tick owed, where `end`
    /// is the simulated time that tick ends at, until the debt is paid or
    /// `budget` of wall-clock time is spent. What is still owed beyond a few
    /// ticks is dropped and counted. A failing step stops the frame and
    /// returns the error; the tick is not counted.
    pub fn run_frame<E>(
        &mut self,
        real: f64,
        budget: Duration,
        mut step: impl FnMut(f64) -> Result<(), E>,
    ) -> Result<FrameTicks, E> {
        let started = Instant::now();
        self.accumulator += real * self.time_scale;
        let mut frame = FrameTicks::default();
        while self.accumulator >= self.tick * (1.0 - TICK_SLACK) {
            if frame.ran > 0 && started.elapsed() >= budget {
                break;
            }
            step(self.next_tick_end())?;
            self.ticks += 1;
            self.accumulator -= self.tick;
            frame.ran += 1;
        }
        self.accumulator = self.accumulator.max(0.0);
        let backlog = MAX_BACKLOG_TICKS * self.tick;
        if self.accumulator > backlog {
            frame.dropped = self.accumulator - backlog;
            self.accumulator = backlog;
            self.dropped += frame.dropped;
        }
        self.measure(real, f64::from(frame.ran) * self.tick, frame.dropped);
        Ok(frame)
    }

    /// Adds a frame to the real-time-factor window, closing it each second.
    fn measure(&mut self, real: f64, simulated: f64, dropped: f64) {
        let window = &mut self.window;
        window.real += real;
        window.simulated += simulated;
        window.dropped += dropped;
        if window.real >= FACTOR_WINDOW.as_secs_f64() {
            let wanted = window.real * self.time_scale;
            window.factor = (wanted > 0.0).then(|| window.simulated / wanted);
            window.behind = window.dropped > 0.0;
            window.real = 0.0;
            window.simulated = 0.0;
            window.dropped = 0.0;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Runs `seconds` of wall-clock time at `fps` display frames per second
    /// with a physics step that costs nothing; returns the tick end times.
    fn ends_at(fps: u32, seconds: u32) -> Vec<f64> {
        let mut clock = FixedStepClock::new(FixedStepClock::tick_for_frame_rate(24.0), 1.0);
        let mut ends = Vec::new();
        for _ in 0..fps * seconds {
            clock
                .run_frame(1.0 / f64::from(fps), Duration::from_secs(1), |end| {
                    ends.push(end);
                    Ok::<(), ()>(())
                })
                .unwrap();
        }
        assert_eq!(clock.time(), *ends.last().unwrap());
        ends
    }

    #[test]
    fn simulated_time_does_not_depend_on_the_display_rate() {
        let slow = ends_at(30, 3);
        let fast = ends_at(144, 3);
        // 3 s at 24 fps in ticks of 1/120 s: 360 ticks at either rate, and
        // the very same tick ends.
        assert_eq!(slow.len(), 360);
        assert_eq!(slow, fast);
    }

    #[test]
    fn a_slow_display_runs_several_ticks_per_frame() {
        let mut clock = FixedStepClock::new(0.01, 1.0);
        let frame = clock
            .run_frame(0.05, Duration::from_secs(1), |_| Ok::<(), ()>(()))
            .unwrap();
        assert_eq!(frame.ran, 5);
        assert_eq!(frame.dropped, 0.0);
    }

    #[test]
    fn physics_that_cannot_keep_up_is_reported_not_hidden() {
        let mut clock = FixedStepClock::new(0.01, 1.0);
        // Every tick costs 20 ms of wall-clock time for 10 ms simulated.
        for _ in 0..40 {
            clock
                .run_frame(0.04, Duration::from_millis(20), |_| {
                    std::thread::sleep(Duration::from_millis(20));
                    Ok::<(), ()>(())
                })
                .unwrap();
        }
        assert!(clock.is_behind());
        assert!(clock.dropped() > 0.5, "dropped {}", clock.dropped());
        let factor = clock.real_time_factor().unwrap();
        assert!(factor < 0.5, "real-time factor {factor}");
    }

    #[test]
    fn time_scale_slows_simulated_time() {
        let mut clock = FixedStepClock::new(0.01, 0.25);
        for _ in 0..110 {
            clock
                .run_frame(0.01, Duration::from_secs(1), |_| Ok::<(), ()>(()))
                .unwrap();
        }
        assert!((clock.time() - 0.275).abs() < 0.011, "{}", clock.time());
        assert_eq!(clock.real_time_factor().map(f64::round), Some(1.0));
    }

    #[test]
    fn a_failing_step_is_not_counted() {
        let mut clock = FixedStepClock::new(0.01, 1.0);
        let result = clock.run_frame(0.05, Duration::from_secs(1), |end| {
            if end > 0.025 { Err("blew up") } else { Ok(()) }
        });
        assert_eq!(result, Err("blew up"));
        assert_eq!(clock.ticks(), 2);
    }
}
