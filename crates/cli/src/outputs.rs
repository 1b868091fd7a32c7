//! The output files of a run (`--out`, `--plot`, `--summary-json`), checked before the run and written so that
//! no file is lost or left half-written.
//!
//! Before the run ([`Outputs::plan`]) every output path is resolved to a canonical path — through symbolic
//! links and `..`; for a file that does not exist yet, the canonical parent directory joined with the file
//! name — and refused (exit 2) when it is an input of the run (the model file, a cycle file; also through a
//! hard link: same device and inode), when two outputs
//! name the same file, when it is a directory or its directory does not exist, or when no file can be created
//! in that directory. A regular file is written to a temporary file next to its target (`.NAME.invsim-PID.tmp`,
//! created at the check) and renamed into place only by [`Outputs::commit`], once the run and every write have
//! succeeded; on any failure the temporary files are removed and the targets keep their old contents.
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
    /// A regular file: written to `tmp`, renamed onto `dest` by [`Outputs::commit`].
    Regular { tmp: PathBuf, dest: PathBuf },
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

/// The way `canon` (the canonical path of `given`) will be written, checked now.
fn target(flag: &str, given: &Path, canon: &Path) -> Result<Target, Failure> {
    let shown = given.display();
    match std::fs::metadata(canon) {
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
        _ => {}
    }
    let dir = canon.parent().unwrap_or(Path::new("/"));
    let name = canon
        .file_name()
        .map_or_else(String::new, |n| n.to_string_lossy().into_owned());
    let tmp = dir.join(format!(".{name}.invsim-{}.tmp", std::process::id()));
    OpenOptions::new()
        .write(true)
        .create_new(true)
        .open(&tmp)
        .map_err(|e| {
            Failure::user(format!(
                "cannot write {flag} `{shown}`: cannot create a file in `{}` ({e})",
                dir.display()
            ))
        })?;
    Ok(Target::Regular {
        tmp,
        dest: canon.to_path_buf(),
    })
}

impl Outputs {
    /// Check the `outputs` (flag, path) against each other and against the `inputs` (what, path), before the
    /// run (see the module docs).
    pub fn plan(
        inputs: &[(&str, &Path)],
        outputs: &[(&'static str, Option<&Path>)],
    ) -> Result<Outputs, Failure> {
        let inputs: Vec<(&str, &Path, PathBuf)> = inputs
            .iter()
            .filter_map(|&(what, p)| std::fs::canonicalize(p).ok().map(|c| (what, p, c)))
            .collect();
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
            let target = target(flag, path, &canon)?;
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

    /// Rename every written regular output into place (all were written: the run succeeded).
    pub fn commit(mut self) -> Result<(), Failure> {
        for p in &self.planned {
            if let Target::Regular { tmp, dest } = &p.target {
                if p.written {
                    std::fs::rename(tmp, dest).map_err(|e| {
                        Failure::user(format!(
                            "cannot write {} `{}`: {e}",
                            p.flag,
                            p.given.display()
                        ))
                    })?;
                }
            }
        }
        self.committed = true;
        self.remove_temporaries();
        Ok(())
    }

    fn remove_temporaries(&self) {
        for p in &self.planned {
            if let Target::Regular { tmp, .. } = &p.target {
                // Already renamed, or left from a failed run: removing is best-effort.
                let _ = std::fs::remove_file(tmp);
            }
        }
    }
}

impl Drop for Outputs {
    /// A run that failed (or a commit that stopped half-way) leaves no temporary file behind.
    fn drop(&mut self) {
        if !self.committed {
            self.remove_temporaries();
        }
    }
}
