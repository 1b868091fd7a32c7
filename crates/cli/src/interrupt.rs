//! Temporary output files removed when the process is interrupted: on SIGINT (Ctrl-C), SIGTERM and SIGHUP
//! the handler unlinks every registered temporary file (`.NAME.invsim-PID.tmp`, [`crate::outputs`]) and
//! re-raises the signal with its default action, so the process ends by that signal as it would have without
//! the handler (a shell reports status 128 + the signal's number). Every other way out (an error, a panic,
//! success) removes them through `Outputs`' `Drop` and commit.
//!
//! A signal handler may only call async-signal-safe functions (POSIX.1-2017, XSH 2.4.3: `unlink`, `raise`
//! and `sigaction` are): the registry is a fixed array of atomic pointers to NUL-terminated paths, built
//! before the handler can see them. A path is never freed once registered (a handler on another thread may be
//! reading it; a run registers at most one per output, a few dozen bytes). The handlers are installed only
//! when a run plans a file output, and not for a signal the process was started ignoring (`nohup`, a
//! background job's SIGINT).

use std::ffi::{c_char, c_int, CString};
use std::os::unix::ffi::OsStrExt;
use std::path::Path;
use std::sync::atomic::{AtomicPtr, Ordering};
use std::sync::Once;

/// Temporary files registered at once (a run has at most three outputs).
const SLOTS: usize = 16;

/// The registered paths (null: a free slot).
static PATHS: [AtomicPtr<c_char>; SLOTS] = [const { AtomicPtr::new(std::ptr::null_mut()) }; SLOTS];

/// The signals that remove the temporary files before the process ends.
const SIGNALS: [c_int; 3] = [libc::SIGINT, libc::SIGTERM, libc::SIGHUP];

static INSTALL: Once = Once::new();

/// A registered path; [`Registered::release`] takes it off the registry.
pub struct Registered(Option<usize>);

/// Register `path` to be unlinked if the process is interrupted (and install the handlers, once). A path
/// that cannot be registered (a NUL byte, every slot taken) is only removed by the ordinary paths.
pub fn register(path: &Path) -> Registered {
    INSTALL.call_once(install);
    let Ok(c) = CString::new(path.as_os_str().as_bytes()) else {
        return Registered(None);
    };
    let raw = c.into_raw();
    for (i, slot) in PATHS.iter().enumerate() {
        if slot
            .compare_exchange(
                std::ptr::null_mut(),
                raw,
                Ordering::SeqCst,
                Ordering::SeqCst,
            )
            .is_ok()
        {
            return Registered(Some(i));
        }
    }
    // SAFETY: `raw` came from `CString::into_raw` above and was stored nowhere.
    drop(unsafe { CString::from_raw(raw) });
    Registered(None)
}

impl Registered {
    /// The file is gone or renamed into place: the handler no longer unlinks it (its path is leaked, see
    /// the module docs).
    pub fn release(&mut self) {
        if let Some(i) = self.0.take() {
            PATHS[i].store(std::ptr::null_mut(), Ordering::SeqCst);
        }
    }
}

/// The handler: unlink every registered path, then the signal again with its default action (reset on
/// entry by `SA_RESETHAND`; blocked until the handler returns, then delivered).
extern "C" fn on_signal(sig: c_int) {
    for slot in &PATHS {
        let p = slot.load(Ordering::SeqCst);
        if !p.is_null() {
            // SAFETY: a registered pointer is a NUL-terminated string that is never freed.
            unsafe { libc::unlink(p) };
        }
    }
    // SAFETY: raise is async-signal-safe; the disposition is the default one now.
    unsafe { libc::raise(sig) };
}

/// Install [`on_signal`] for [`SIGNALS`] not ignored at start.
fn install() {
    for &sig in &SIGNALS {
        // SAFETY: sigaction with a zeroed struct to read the current action, then a filled one to set it;
        // both structs live across the calls.
        unsafe {
            let mut old: libc::sigaction = std::mem::zeroed();
            if libc::sigaction(sig, std::ptr::null(), &mut old) != 0
                || old.sa_sigaction == libc::SIG_IGN
            {
                continue;
            }
            let mut act: libc::sigaction = std::mem::zeroed();
            act.sa_sigaction = on_signal as extern "C" fn(c_int) as libc::sighandler_t;
            act.sa_flags = libc::SA_RESETHAND;
            libc::sigemptyset(&mut act.sa_mask);
            for &other in &SIGNALS {
                libc::sigaddset(&mut act.sa_mask, other);
            }
            libc::sigaction(sig, &act, std::ptr::null_mut());
        }
    }
}
