//! The start and the end of the `invsim` process on Linux with glibc. `main.rs` is `#![no_main]`: the C
//! runtime calls its `extern "C" fn main` directly, without std's runtime wrapper, whose start-up reads
//! `/proc/self/maps` (glibc's `pthread_getattr_np` for the main thread's stack guard) and installs the
//! stack-overflow handler: about 0.11 M instructions, 8 page faults and 0.1 ms of a 1.5 ms `simulate --dt 1`
//! process. (std still gets the arguments: glibc passes them to its `.init_array` entry before `main`.)
//!
//! What the command relies on of that wrapper is done here, as std does it: the standard streams are open
//! ([`start`]), `SIGPIPE` is ignored so that a closed pipe is a write error (exit 2, contract §3), a panic
//! exits with status 101 after the panic hook's message, and stdout is flushed at the end ([`finish`]). What
//! is not: the message "thread 'main' has overflowed its stack" (an overflow is a plain `SIGSEGV`), and the
//! main thread's name in a panic message (`<unnamed>`).

use std::io::Write;

/// The exit status of a command that panicked, as std's runtime gives it.
const PANICKED: u8 = 101;

/// Before the command: a standard stream (fd 0, 1 or 2) that is closed is opened on `/dev/null`, so that no
/// file the command opens takes its number (the output of a closed stdout is then discarded, as with std's
/// runtime); `SIGPIPE` ignored.
#[cfg_attr(test, allow(dead_code))] // the unit tests' harness has a main of its own
pub fn start() {
    let mut fds = [0, 1, 2].map(|fd| libc::pollfd {
        fd,
        events: 0,
        revents: 0,
    });
    // SAFETY: `fds` is an array of three initialised pollfd the call may write; the timeout 0 makes it not
    // block.
    let polled = unsafe { libc::poll(fds.as_mut_ptr(), 3, 0) };
    for p in &fds {
        // POLLNVAL: not an open descriptor. If poll itself failed, F_GETFD tells (EBADF for a closed one).
        // SAFETY: fcntl(F_GETFD) on any integer only reads the descriptor table.
        let closed = if polled >= 0 {
            p.revents & libc::POLLNVAL != 0
        } else {
            (unsafe { libc::fcntl(p.fd, libc::F_GETFD) }) == -1
        };
        if closed {
            // The lowest free descriptor is this one (the lower ones are open or were just opened).
            // SAFETY: a NUL-terminated path and plain flags; the descriptor is deliberately kept open.
            unsafe { libc::open(c"/dev/null".as_ptr(), libc::O_RDWR) };
        }
    }
    // SAFETY: SIG_IGN for SIGPIPE, before any other thread exists.
    unsafe { libc::signal(libc::SIGPIPE, libc::SIG_IGN) };
}

/// After the command: stdout flushed; the status (`run`'s, or 101 if it panicked) as the C `main` returns it.
pub fn finish(run: std::thread::Result<u8>) -> i32 {
    // A failed flush (stdout closed meanwhile) has nothing left to report to.
    let _ = std::io::stdout().flush();
    i32::from(run.unwrap_or(PANICKED))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_panic_is_status_101_and_a_status_is_kept() {
        assert_eq!(finish(Ok(0)), 0);
        assert_eq!(finish(Ok(3)), 3);
        assert_eq!(finish(Err(Box::new("boom"))), 101);
    }
}
