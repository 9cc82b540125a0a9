//! Printing that ends quietly when the reader goes away.
//!
//! `println!` panics when standard output is a pipe whose reader has closed
//! (`firn check scene.toml | head -1`, `grep -q`, a pager quit early),
//! because Rust ignores SIGPIPE and every write then fails with EPIPE. Every
//! line firn prints goes through [`outln!`], [`out!`] or [`errln!`] instead:
//! a failed write marks that stream closed, later lines to it are dropped,
//! and the command finishes its work and exits as it would have (a run keeps
//! recording frames: its progress lines are for the reader, its caches for
//! the disk). The crate denies `clippy::print_stdout` and
//! `clippy::print_stderr` outside this module, so nothing prints around it.

#![allow(clippy::print_stdout, clippy::print_stderr)]

use std::fmt;
use std::io::Write;
use std::sync::atomic::{AtomicBool, Ordering};

/// Set once a write to standard output failed.
static STDOUT_CLOSED: AtomicBool = AtomicBool::new(false);
/// Set once a write to standard error failed.
static STDERR_CLOSED: AtomicBool = AtomicBool::new(false);

/// Writes `text` to standard output, unless its reader has gone.
pub fn write_stdout(text: fmt::Arguments<'_>) {
    write_to(&mut std::io::stdout().lock(), &STDOUT_CLOSED, text);
}

/// Writes `text` to standard error, unless its reader has gone.
pub fn write_stderr(text: fmt::Arguments<'_>) {
    write_to(&mut std::io::stderr().lock(), &STDERR_CLOSED, text);
}

/// Writes and flushes `text` to `stream`; a failure marks it `closed`.
fn write_to(stream: &mut impl Write, closed: &AtomicBool, text: fmt::Arguments<'_>) {
    if closed.load(Ordering::Relaxed) {
        return;
    }
    if stream
        .write_fmt(text)
        .and_then(|()| stream.flush())
        .is_err()
    {
        closed.store(true, Ordering::Relaxed);
    }
}

/// `println!` that stops quietly when standard output is closed.
macro_rules! outln {
    () => { $crate::console::write_stdout(format_args!("\n")) };
    ($($arg:tt)*) => {
        $crate::console::write_stdout(format_args!("{}\n", format_args!($($arg)*)))
    };
}

/// `print!` that stops quietly when standard output is closed.
macro_rules! out {
    ($($arg:tt)*) => { $crate::console::write_stdout(format_args!($($arg)*)) };
}

/// `eprintln!` that stops quietly when standard error is closed.
macro_rules! errln {
    ($($arg:tt)*) => {
        $crate::console::write_stderr(format_args!("{}\n", format_args!($($arg)*)))
    };
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A stream whose reader has gone: every write fails.
    struct Closed {
        attempts: usize,
    }

    impl Write for Closed {
        fn write(&mut self, _: &[u8]) -> std::io::Result<usize> {
            self.attempts += 1;
            Err(std::io::ErrorKind::BrokenPipe.into())
        }

        fn flush(&mut self) -> std::io::Result<()> {
            Ok(())
        }
    }

    #[test]
    fn a_closed_stream_is_tried_once_then_left_alone() {
        let closed = AtomicBool::new(false);
        let mut stream = Closed { attempts: 0 };
        write_to(&mut stream, &closed, format_args!("first\n"));
        write_to(&mut stream, &closed, format_args!("second\n"));
        assert!(closed.load(Ordering::Relaxed));
        assert_eq!(stream.attempts, 1);
    }

    #[test]
    fn an_open_stream_gets_every_line() {
        let closed = AtomicBool::new(false);
        let mut stream = Vec::new();
        write_to(&mut stream, &closed, format_args!("a {}\n", 1));
        write_to(&mut stream, &closed, format_args!("b\n"));
        assert_eq!(stream, b"a 1\nb\n");
        assert!(!closed.load(Ordering::Relaxed));
    }
}
