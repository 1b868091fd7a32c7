//! What keeps an `invsim` process cheap to start without changing what it prints: each command's arguments
//! are built only when it runs (clap's `defer`), which must leave every command's about, `help` tree and
//! completions as they were; on Linux the executable is linked at a fixed address (no relocations); and the
//! process starts without std's runtime wrapper (`src/process.rs`), so what that wrapper did for the command
//! must still hold: a closed pipe on stdout is exit 2 (not death by `SIGPIPE`), a closed stdout is
//! `/dev/null`.

use crate::common;
use common::*;

fn stdout(o: &std::process::Output) -> String {
    String::from_utf8_lossy(&o.stdout).into_owned()
}

/// The `(name, about)` rows of the "Commands:" list of `invsim --help`.
fn listed_commands() -> Vec<(String, String)> {
    let o = invsim(&["--help"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = stdout(&o);
    let list = text.split("Commands:\n").nth(1).expect("a Commands: list");
    list.lines()
        .take_while(|l| l.starts_with("  "))
        .filter_map(|l| {
            let (name, about) = l.trim().split_once(char::is_whitespace)?;
            Some((name.to_string(), about.trim().to_string()))
        })
        .collect()
}

#[test]
fn each_command_help_starts_with_the_about_the_command_list_gives_it() {
    let commands = listed_commands();
    let names: Vec<&str> = commands.iter().map(|(n, _)| n.as_str()).collect();
    for expected in [
        "derive",
        "simulate",
        "sweep",
        "forward",
        "cycles",
        "import",
        "completions",
    ] {
        assert!(
            names.contains(&expected),
            "{expected} not listed in {names:?}"
        );
    }
    for (name, about) in commands.iter().filter(|(n, _)| n != "help") {
        let o = invsim(&[name, "--help"]);
        assert!(o.status.success(), "{name}: {}", stderr(&o));
        let help = stdout(&o);
        let first = help.lines().next().unwrap_or("");
        // The list shows the first sentence without its final period, as the command's own help does.
        assert_eq!(
            first, about,
            "{name} --help begins otherwise than its line in invsim --help"
        );
    }
}

#[test]
fn help_and_completions_know_the_nested_import_command() {
    let o = invsim(&["help", "import", "fastsim"]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        stdout(&o).contains("Usage: invsim import fastsim"),
        "{}",
        stdout(&o)
    );
    let o = invsim(&["completions", "bash"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let script = stdout(&o);
    for case in [
        "invsim__subcmd__import__subcmd__fastsim)",
        "invsim__subcmd__help__subcmd__import__subcmd__fastsim)",
    ] {
        assert!(script.contains(case), "the bash script lacks {case}");
    }
}

/// Does the 64-bit little-endian ELF file `bytes` ask for a dynamic loader (a PT_INTERP program header)?
#[cfg(target_os = "linux")]
fn has_interpreter(bytes: &[u8]) -> bool {
    let u16_at = |o: usize| usize::from(u16::from_le_bytes([bytes[o], bytes[o + 1]]));
    let phoff = u64::from_le_bytes(bytes[32..40].try_into().unwrap()) as usize;
    let (phentsize, phnum) = (u16_at(54), u16_at(56));
    (0..phnum).any(|i| {
        let p = phoff + i * phentsize;
        u32::from_le_bytes(bytes[p..p + 4].try_into().unwrap()) == 3 // PT_INTERP
    })
}

#[cfg(target_os = "linux")]
#[test]
fn the_executable_is_linked_at_a_fixed_address() {
    let bytes = std::fs::read(env!("CARGO_BIN_EXE_invsim")).unwrap();
    assert_eq!(
        &bytes[..6],
        b"\x7fELF\x02\x01",
        "a 64-bit little-endian ELF file"
    );
    // e_type, a u16 at offset 16 of the ELF header: 2 = ET_EXEC, 3 = ET_DYN (a PIE). A static build
    // (crt-static: no loader) stays a static PIE on purpose (build.rs).
    let e_type = u16::from_le_bytes([bytes[16], bytes[17]]);
    assert!(
        has_interpreter(&bytes) || e_type == 3,
        "a static executable that is not a PIE"
    );
    if has_interpreter(&bytes) {
        assert_eq!(
            e_type, 2,
            "invsim is not a fixed-address executable (e_type {e_type})"
        );
    }
}

/// A pipe whose reading end is closed, its writing end for a child's stdout (close-on-exec, so that no other
/// test's child keeps it open).
#[cfg(target_os = "linux")]
fn pipe_without_reader() -> std::process::Stdio {
    use std::os::fd::{FromRawFd, OwnedFd};
    let mut fds = [0; 2];
    // SAFETY: pipe2 writes two descriptors into `fds`.
    assert_eq!(unsafe { libc::pipe2(fds.as_mut_ptr(), libc::O_CLOEXEC) }, 0);
    // SAFETY: both descriptors were just created and are owned by nothing else.
    let (read, write) = unsafe { (OwnedFd::from_raw_fd(fds[0]), OwnedFd::from_raw_fd(fds[1])) };
    drop(read);
    std::process::Stdio::from(write)
}

#[cfg(target_os = "linux")]
#[test]
fn a_closed_pipe_on_stdout_is_exit_2_with_a_message() {
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_invsim"))
        .args([
            "simulate",
            "models/si_engine.toml",
            "--cycle",
            "nedc",
            "--dt",
            "1",
        ])
        .current_dir(root())
        .stdout(pipe_without_reader())
        .output()
        .expect("run invsim");
    assert_eq!(o.status.code(), Some(2), "{:?}: {}", o.status, stderr(&o));
    assert!(
        stderr(&o).contains("cannot write to stdout"),
        "{}",
        stderr(&o)
    );
}

#[cfg(target_os = "linux")]
#[test]
fn a_closed_stdout_is_dev_null_for_the_command() {
    // With fd 1 closed, /dev/stdout names nothing unless the process opened fd 1 on /dev/null at its start.
    let o = std::process::Command::new("sh")
        .args(["-c", "exec \"$0\" \"$@\" >&-", env!("CARGO_BIN_EXE_invsim")])
        .args([
            "simulate",
            "models/si_engine.toml",
            "--cycle",
            "ece",
            "--dt",
            "1",
        ])
        .args(["--summary-json", "/dev/stdout"])
        .current_dir(root())
        .output()
        .expect("run sh");
    assert!(o.status.success(), "{:?}: {}", o.status, stderr(&o));
}
