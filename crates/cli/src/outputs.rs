//! The output files of a run (`--out`, `--plot`, `--summary-json`), checked before the run and written so that
//! no file is lost or left half-written.
//!
//! Before the run ([`Outputs::plan`]) every output path is resolved to a canonical path — through symbolic
//! links and `..`; for a file that does not exist yet, the canonical parent directory joined with the file
//! name — and refused (exit 2) when it is an input of the run (any file of [`crate::inputs`]: the model file
//! and the map CSV files it names, cycle files, `--map` and `--signal` files, a sweep's table, an import's
//! vehicle file; also through a hard link: same device and inode), when two outputs name the same file, when
//! it is a directory or its directory does not exist, when no file can be created in that directory, or when
//! it is an existing file the user may not write (`access(2)` W_OK fails, or no write permission bit is set
//! at all: a read-only file is refused also for root). A regular file is written to a temporary file next to
//! its target (`.NAME.invsim-PID.tmp`, created at the check; NAME shortened so that the name fits in
//! NAME_MAX = 255 bytes, with the output's number added: `.NAME.invsim-PID-K.tmp`) and put in place only by
//! [`Outputs::commit`], once the run and every write have succeeded; on any failure (and on SIGINT, SIGTERM,
//! SIGHUP: [`crate::interrupt`]) the temporary files are removed and the targets keep their old contents.
//!
//! Replacing an existing file keeps its nature: the temporary file takes the file's permission bits (a 0600
//! file stays 0600; through a symbolic link, the linked file's), so the rename changes only the contents; a
//! file with more than one hard link is not replaced but written in place (the temporary file copied into it
//! after the run, before the renames), so every name of it sees the new contents. Such an in-place copy is
//! not atomic: a write error during it (a full disk) leaves that file truncated (exit 2).
//!
//! A character device or a FIFO named as an output (`/dev/stdout`, `/dev/null`, a pipe) cannot be replaced by a
//! rename: it is written directly (not checked against the inputs, which are files), and before any regular
//! output is renamed into place, so that a write error there (`/dev/full`: no space left) still leaves the
//! regular outputs untouched. Other kinds of file (sockets, block devices) are refused.

use std::fs::{File, OpenOptions};
use std::io;
use std::os::unix::fs::FileTypeExt;
use std::path::{Path, PathBuf};

use crate::error::Failure;

/// How an output is written.
enum Target {
    /// A regular file: written to `tmp`, renamed onto `dest` by [`Outputs::commit`] (copied into it when
    /// `in_place`: `dest` has other hard links); `registered` for the interrupt handler.
    Regular {
        tmp: PathBuf,
        dest: PathBuf,
        in_place: bool,
        registered: crate::interrupt::Registered,
    },
    /// A character device or FIFO: written directly.
    Device(PathBuf),
}

/// One checked output.
struct Planned {
    flag: &'static str,
    /// The path as the user gave it (for messages).
    given: PathBuf,
    target: Target,
    written: bool,
}

/// The checked outputs of one run.
pub struct Outputs {
    planned: Vec<Planned>,
    committed: bool,
}

/// The canonical form of an output path that may not exist yet: the path itself if it exists (links resolved),
/// else the canonical parent joined with the file name.
fn canonical_output(flag: &str, path: &Path) -> Result<PathBuf, Failure> {
    if let Ok(c) = std::fs::canonicalize(path) {
        return Ok(c);
    }
    let shown = path.display();
    if path.symlink_metadata().is_ok() {
        return Err(Failure::user(format!(
            "{flag} `{shown}` is a symbolic link to a file that does not exist; name the file itself"
        )));
    }
    let name = path.file_name().ok_or_else(|| {
        Failure::user(format!(
            "{flag} `{shown}` does not name a file; give a file name"
        ))
    })?;
    let parent = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    let dir = std::fs::canonicalize(parent).map_err(|e| {
        Failure::user(format!(
            "cannot write {flag} `{shown}`: its directory `{}` does not exist or cannot be reached ({e})",
            parent.display()
        ))
    })?;
    if !dir.is_dir() {
        return Err(Failure::user(format!(
            "cannot write {flag} `{shown}`: `{}` is not a directory",
            parent.display()
        )));
    }
    Ok(dir.join(name))
}

/// The device and inode of an existing file (a hard link to an input is that input too).
fn file_id(path: &Path) -> Option<(u64, u64)> {
    use std::os::unix::fs::MetadataExt;
    std::fs::metadata(path).ok().map(|m| (m.dev(), m.ino()))
}

/// True if `path` (links followed) is a character device or a FIFO.
fn is_device(path: &Path) -> bool {
    std::fs::metadata(path).is_ok_and(|m| m.file_type().is_char_device() || m.file_type().is_fifo())
}

/// NAME_MAX of Linux file systems: the longest file name, in bytes.
const NAME_MAX: usize = 255;

/// The temporary file of output number `k` whose file name is `name`: `.NAME.invsim-PID.tmp`, or, when that
/// would exceed [`NAME_MAX`], NAME cut to fit and the output's number added (`.NAME.invsim-PID-K.tmp`: two
/// cut names that agree stay distinct).
fn temporary_name(name: &std::ffi::OsStr, k: usize) -> std::ffi::OsString {
    use std::os::unix::ffi::{OsStrExt, OsStringExt};
    let pid = std::process::id();
    let full = format!(".invsim-{pid}.tmp");
    let bytes = name.as_bytes();
    let mut out = vec![b'.'];
    if 1 + bytes.len() + full.len() <= NAME_MAX {
        out.extend_from_slice(bytes);
        out.extend_from_slice(full.as_bytes());
    } else {
        let suffix = format!(".invsim-{pid}-{k}.tmp");
        out.extend_from_slice(&bytes[..NAME_MAX - 1 - suffix.len()]);
        out.extend_from_slice(suffix.as_bytes());
    }
    std::ffi::OsString::from_vec(out)
}

/// Refuse an existing file the user may not write (see the module docs).
fn check_writable(flag: &str, given: &Path, canon: &Path, mode: u32) -> Result<(), Failure> {
    use std::os::unix::ffi::OsStrExt;
    let denied = match std::ffi::CString::new(canon.as_os_str().as_bytes()) {
        // SAFETY: a NUL-terminated path; access only reads it.
        Ok(c) => (unsafe { libc::access(c.as_ptr(), libc::W_OK) }) != 0,
        Err(_) => false,
    };
    if denied || mode & 0o222 == 0 {
        return Err(Failure::user(format!(
            "refusing to replace {flag} `{}`: the file is read-only (mode {:03o}); make it writable or choose \
             another file name",
            given.display(),
            mode & 0o777
        )));
    }
    Ok(())
}

/// The way `canon` (the canonical path of `given`, output number `k`) will be written, checked now.
fn target(flag: &str, given: &Path, canon: &Path, k: usize) -> Result<Target, Failure> {
    use std::os::unix::fs::{MetadataExt, PermissionsExt};
    let shown = given.display();
    let existing = match std::fs::metadata(canon) {
        Ok(m) if m.is_dir() => {
            return Err(Failure::user(format!(
                "cannot write {flag} `{shown}`: it is a directory; give a file name"
            )))
        }
        Ok(m) if !m.is_file() => {
            return Err(Failure::user(format!(
                "cannot write {flag} `{shown}`: it is neither a regular file, a character device nor a FIFO"
            )))
        }
        Ok(m) => {
            check_writable(flag, given, canon, m.mode())?;
            Some(m)
        }
        Err(_) => None,
    };
    let dir = canon.parent().unwrap_or(Path::new("/"));
    let tmp = dir.join(temporary_name(canon.file_name().unwrap_or_default(), k));
    let cannot_create = |e: io::Error| {
        Failure::user(format!(
            "cannot write {flag} `{shown}`: cannot create a file in `{}` ({e})",
            dir.display()
        ))
    };
    let registered = crate::interrupt::register(&tmp);
    let file = OpenOptions::new()
        .write(true)
        .create_new(true)
        .open(&tmp)
        .map_err(cannot_create)?;
    let mut t = Target::Regular {
        tmp: tmp.clone(),
        dest: canon.to_path_buf(),
        in_place: existing.as_ref().is_some_and(|m| m.nlink() > 1),
        registered,
    };
    if let Some(m) = existing {
        // The replaced file's permission bits (the temporary file is removed by `Drop` if this fails).
        let keep = std::fs::Permissions::from_mode(m.mode() & 0o777);
        if let Err(e) = file.set_permissions(keep) {
            remove(&mut t);
            return Err(cannot_create(e));
        }
    }
    Ok(t)
}

/// Remove the temporary file of `t` (best-effort: it may be renamed already) and take it off the interrupt
/// registry.
fn remove(t: &mut Target) {
    if let Target::Regular {
        tmp, registered, ..
    } = t
    {
        let _ = std::fs::remove_file(&*tmp);
        registered.release();
    }
}

impl Outputs {
    /// Check the `outputs` (flag, path) against each other and against the `inputs` (what, path), before the
    /// run (see the module docs).
    pub fn plan(
        inputs: &crate::inputs::Inputs,
        outputs: &[(&'static str, Option<&Path>)],
    ) -> Result<Outputs, Failure> {
        // Resolved once, at the first output that is a file (a run without one reads no model file for it).
        let mut resolved: Option<Vec<(&str, PathBuf, PathBuf)>> = None;
        let mut plan = Outputs {
            planned: Vec::new(),
            committed: false,
        };
        let mut seen: Vec<(&str, &Path, PathBuf)> = Vec::new();
        for &(flag, path) in outputs {
            let Some(path) = path else { continue };
            if is_device(path) {
                // `/dev/stdout` may resolve to a pipe that has no canonical path: a device is no input file.
                plan.planned.push(Planned {
                    flag,
                    given: path.to_path_buf(),
                    target: Target::Device(path.to_path_buf()),
                    written: false,
                });
                continue;
            }
            let canon = canonical_output(flag, path)?;
            let id = file_id(&canon);
            let inputs = resolved.get_or_insert_with(|| {
                inputs
                    .list()
                    .into_iter()
                    .filter_map(|(what, p)| std::fs::canonicalize(&p).ok().map(|c| (what, p, c)))
                    .collect()
            });
            if let Some((what, p, _)) = inputs
                .iter()
                .find(|(_, _, c)| *c == canon || (id.is_some() && file_id(c) == id))
            {
                return Err(Failure::user(format!(
                    "refusing to write {flag} `{}`: it is the {what} `{}`, an input of this run; choose another \
                     file name",
                    path.display(),
                    p.display()
                )));
            }
            if let Some((other, p, _)) = seen.iter().find(|(_, _, c)| *c == canon) {
                return Err(Failure::user(format!(
                    "{other} `{}` and {flag} `{}` name the same file; each output needs its own file",
                    p.display(),
                    path.display()
                )));
            }
            let target = target(flag, path, &canon, plan.planned.len())?;
            plan.planned.push(Planned {
                flag,
                given: path.to_path_buf(),
                target,
                written: false,
            });
            seen.push((flag, path, canon));
        }
        Ok(plan)
    }

    fn find(&mut self, flag: &str) -> Option<&mut Planned> {
        self.planned.iter_mut().find(|p| p.flag == flag)
    }

    /// Write the output of `flag` (if it was asked for) with `write`: a regular file into its temporary file,
    /// a device directly.
    pub fn write(
        &mut self,
        flag: &str,
        write: impl FnOnce(File) -> io::Result<()>,
    ) -> Result<(), Failure> {
        let Some(p) = self.find(flag) else {
            return Ok(());
        };
        let path = match &p.target {
            Target::Regular { tmp, .. } => tmp,
            Target::Device(d) => d,
        };
        let fail = |e: io::Error| {
            Failure::user(format!("cannot write {flag} `{}`: {e}", p.given.display()))
        };
        let file = OpenOptions::new()
            .write(true)
            .truncate(true)
            .open(path)
            .map_err(fail)?;
        write(file).map_err(fail)?;
        p.written = true;
        Ok(())
    }

    /// Put every written regular output in place (all were written: the run succeeded): first the files
    /// written in place (copied from their temporary file: a hard link keeps its other names), then the
    /// renames.
    pub fn commit(mut self) -> Result<(), Failure> {
        for in_place in [true, false] {
            for p in &self.planned {
                let Target::Regular {
                    tmp,
                    dest,
                    in_place: here,
                    ..
                } = &p.target
                else {
                    continue;
                };
                if !p.written || *here != in_place {
                    continue;
                }
                let done = match in_place {
                    true => copy_into(tmp, dest),
                    false => std::fs::rename(tmp, dest),
                };
                done.map_err(|e| {
                    Failure::user(format!(
                        "cannot write {} `{}`: {e}",
                        p.flag,
                        p.given.display()
                    ))
                })?;
            }
        }
        self.committed = true;
        self.remove_temporaries();
        Ok(())
    }

    fn remove_temporaries(&mut self) {
        for p in &mut self.planned {
            // Already renamed, or left from a failed run: removing is best-effort.
            remove(&mut p.target);
        }
    }
}

/// Copy the contents of `tmp` into the existing file `dest` (truncated first), keeping its inode.
fn copy_into(tmp: &Path, dest: &Path) -> io::Result<()> {
    let mut from = File::open(tmp)?;
    let mut to = OpenOptions::new().write(true).truncate(true).open(dest)?;
    io::copy(&mut from, &mut to).map(|_| ())
}

impl Drop for Outputs {
    /// A run that failed (or a commit that stopped half-way) leaves no temporary file behind.
    fn drop(&mut self) {
        if !self.committed {
            self.remove_temporaries();
        }
    }
}
