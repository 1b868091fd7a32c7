//! Output files of `simulate`, `forward` and `sweep`: written in place, through links into the linked file,
//! onto character devices directly, keeping a replaced file's mode and hard links, read-only files refused,
//! names up to 255 bytes, and no temporary file left behind — on success, failure or SIGINT/SIGTERM/SIGHUP;
//! a stderr or stdout that cannot be written keeps the exit status (the refusals of inputs are hostile cases
//! in `tests/hostile/`).

use crate::common;
use common::*;

use std::path::Path;

/// A fresh directory of this test.
fn dir(name: &str) -> std::path::PathBuf {
    let d = tmp(name);
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// The names in `d`, sorted.
fn names(d: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(d)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
}

#[test]
fn outputs_replace_old_files_and_leave_no_temporary() {
    let d = dir("replace");
    let (out, json, svg) = (d.join("a.csv"), d.join("a.json"), d.join("a.svg"));
    std::fs::write(&out, "old\n").unwrap();
    let o = invsim(&[
        "simulate",
        "models/si_engine.toml",
        "--cycle",
        "ece",
        "--dt",
        "1",
        "--out",
        out.to_str().unwrap(),
        "--summary-json",
        json.to_str().unwrap(),
        "--plot",
        svg.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(std::fs::read_to_string(&out).unwrap().starts_with("t,yd_0"));
    assert_eq!(json_file(&json)["cycle"], "ece");
    assert!(std::fs::read_to_string(&svg).unwrap().contains("<svg"));
    assert_eq!(names(&d), ["a.csv", "a.json", "a.svg"]);
}

#[test]
fn an_output_through_a_link_is_written_into_the_linked_file() {
    let d = dir("link");
    let target = d.join("target.json");
    std::fs::write(&target, "old\n").unwrap();
    std::os::unix::fs::symlink(&target, d.join("link.json")).unwrap();
    let o = invsim(&[
        "forward",
        "models/si_engine.toml",
        "--cycle",
        "ece",
        "--dt",
        "1",
        "--summary-json",
        d.join("link.json").to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(json_file(&target)["cycle"], "ece");
    assert!(std::fs::symlink_metadata(d.join("link.json"))
        .unwrap()
        .file_type()
        .is_symlink());
    assert_eq!(names(&d), ["link.json", "target.json"]);
}

#[test]
fn character_devices_are_written_directly() {
    for cmd in ["simulate", "forward"] {
        let o = invsim(&[
            cmd,
            "models/si_engine.toml",
            "--cycle",
            "ece",
            "--dt",
            "1",
            "--out",
            "/dev/null",
            "--summary-json",
            "/dev/stdout",
        ]);
        assert!(o.status.success(), "{cmd}: {}", stderr(&o));
        let text = String::from_utf8_lossy(&o.stdout);
        assert!(text.contains("\"cycle\": \"ece\""), "{cmd}: {text}");
    }
}

#[test]
fn a_failed_run_leaves_the_old_outputs_and_no_temporary() {
    let d = dir("failed");
    let out = d.join("a.csv");
    std::fs::write(&out, "precious\n").unwrap();
    let o = invsim(&[
        "simulate",
        "models/si_engine.toml",
        "--cycle",
        "ece",
        "--dt",
        "-1",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert_eq!(std::fs::read_to_string(&out).unwrap(), "precious\n");
    assert_eq!(names(&d), ["a.csv"]);
}

#[test]
fn an_output_that_is_a_hard_link_to_an_input_is_refused() {
    let d = dir("hardlink");
    let model = d.join("m.toml");
    std::fs::copy(root().join("models/si_engine.toml"), &model).unwrap();
    let before = std::fs::read(&model).unwrap();
    std::fs::hard_link(&model, d.join("alias.csv")).unwrap();
    for cmd in ["simulate", "forward"] {
        let o = invsim(&[
            cmd,
            model.to_str().unwrap(),
            "--cycle",
            "ece",
            "--out",
            d.join("alias.csv").to_str().unwrap(),
        ]);
        assert_eq!(o.status.code(), Some(2), "{cmd}: {}", stderr(&o));
        assert!(stderr(&o).contains("the model file"), "{}", stderr(&o));
    }
    assert_eq!(std::fs::read(&model).unwrap(), before);
    assert_eq!(names(&d), ["alias.csv", "m.toml"]);
}

/// The permission bits of `p` (links followed).
fn mode(p: &Path) -> u32 {
    use std::os::unix::fs::PermissionsExt;
    std::fs::metadata(p).unwrap().permissions().mode() & 0o777
}

#[test]
fn a_replaced_output_keeps_its_mode_also_through_a_link() {
    use std::os::unix::fs::PermissionsExt;
    let d = dir("mode");
    let (out, target) = (d.join("a.csv"), d.join("target.json"));
    std::fs::write(&out, "old\n").unwrap();
    std::fs::set_permissions(&out, std::fs::Permissions::from_mode(0o600)).unwrap();
    std::fs::write(&target, "old\n").unwrap();
    std::fs::set_permissions(&target, std::fs::Permissions::from_mode(0o640)).unwrap();
    std::os::unix::fs::symlink(&target, d.join("link.json")).unwrap();
    for cmd in ["simulate", "forward"] {
        let o = invsim(&[
            cmd,
            "models/si_engine.toml",
            "--cycle",
            "ece",
            "--dt",
            "1",
            "--out",
            out.to_str().unwrap(),
            "--summary-json",
            d.join("link.json").to_str().unwrap(),
        ]);
        assert!(o.status.success(), "{cmd}: {}", stderr(&o));
        assert!(std::fs::read_to_string(&out).unwrap().starts_with("t,"));
        assert_eq!(json_file(&target)["cycle"], "ece");
        assert_eq!(mode(&out), 0o600, "{cmd}");
        assert_eq!(mode(&target), 0o640, "{cmd}");
    }
    assert_eq!(names(&d), ["a.csv", "link.json", "target.json"]);
}

#[test]
fn a_hard_linked_output_is_written_in_place_not_split() {
    use std::os::unix::fs::MetadataExt;
    let d = dir("hard-out");
    let (out, other) = (d.join("a.csv"), d.join("b.csv"));
    std::fs::write(&out, "old\n").unwrap();
    std::fs::hard_link(&out, &other).unwrap();
    let ino = std::fs::metadata(&out).unwrap().ino();
    let o = invsim(&[
        "sweep",
        "models/si_engine.toml",
        "--cycle",
        "ece",
        "--dt",
        "1",
        "--grid",
        "m=1200:1300:2",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = std::fs::read_to_string(&out).unwrap();
    assert_eq!(text.lines().count(), 3, "{text}");
    assert_eq!(std::fs::read_to_string(&other).unwrap(), text);
    let m = std::fs::metadata(&out).unwrap();
    assert_eq!((m.ino(), m.nlink()), (ino, 2));
    assert_eq!(names(&d), ["a.csv", "b.csv"]);
}

#[test]
fn a_read_only_output_is_refused_before_the_run() {
    use std::os::unix::fs::PermissionsExt;
    let d = dir("read-only");
    let out = d.join("a.csv");
    std::fs::write(&out, "keep\n").unwrap();
    std::fs::set_permissions(&out, std::fs::Permissions::from_mode(0o444)).unwrap();
    for args in [
        vec![
            "simulate",
            "models/si_engine.toml",
            "--cycle",
            "ece",
            "--out",
        ],
        vec![
            "forward",
            "models/si_engine.toml",
            "--cycle",
            "ece",
            "--summary-json",
        ],
        vec![
            "sweep",
            "models/si_engine.toml",
            "--cycle",
            "ece",
            "--grid",
            "m=1200:1300:2",
            "--out",
        ],
    ] {
        let mut args = args.clone();
        args.push(out.to_str().unwrap());
        let o = invsim(&args);
        assert_eq!(o.status.code(), Some(2), "{args:?}: {}", stderr(&o));
        assert!(stderr(&o).contains("read-only"), "{}", stderr(&o));
        assert!(o.stdout.is_empty(), "refused before the run");
        assert_eq!(std::fs::read_to_string(&out).unwrap(), "keep\n");
        assert_eq!(mode(&out), 0o444);
    }
    assert_eq!(names(&d), ["a.csv"]);
}

/// Start `invsim` with `args` in `d`, wait (at most 60 s) until its temporary output file exists, send it
/// `sig`; how it ended. The child starts with `sig`'s default action: a test run started in the background
/// (`cmd &`, `nohup`) passes SIGINT or SIGHUP on ignored, and invsim rightly keeps a signal it was started
/// ignoring ignored (crates/cli/src/interrupt.rs).
fn interrupt(d: &Path, args: &[&str], sig: i32) -> std::process::ExitStatus {
    use std::os::unix::process::CommandExt;
    use std::time::{Duration, Instant};
    let mut cmd = std::process::Command::new(env!("CARGO_BIN_EXE_invsim"));
    cmd.args(args)
        .current_dir(d)
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null());
    // SAFETY: between fork and exec only signal(2), which is async-signal-safe (POSIX.1-2017, XSH 2.4.3).
    unsafe {
        cmd.pre_exec(move || {
            libc::signal(sig, libc::SIG_DFL);
            Ok(())
        });
    }
    let mut child = cmd.spawn().unwrap();
    let deadline = Instant::now() + Duration::from_secs(60);
    let has_tmp = || names(d).iter().any(|n| n.ends_with(".tmp"));
    while !has_tmp() {
        assert!(Instant::now() < deadline, "no temporary file appeared");
        assert!(child.try_wait().unwrap().is_none(), "invsim ended early");
        std::thread::sleep(Duration::from_millis(10));
    }
    // SAFETY: kill(2) on the child's process id.
    assert_eq!(unsafe { libc::kill(child.id() as i32, sig) }, 0);
    loop {
        if let Some(status) = child.try_wait().unwrap() {
            return status;
        }
        if Instant::now() > deadline {
            let _ = child.kill();
            panic!("invsim did not end on signal {sig}");
        }
        std::thread::sleep(Duration::from_millis(10));
    }
}

/// An interrupted run (SIGINT, SIGTERM, SIGHUP) ends by that signal and leaves neither its output nor a
/// temporary file. The run is held before it reads its cycle, a FIFO no one writes, so the signal always
/// arrives while the temporary file exists.
#[test]
fn an_interrupted_run_leaves_no_temporary_file() {
    use std::os::unix::process::ExitStatusExt;
    let d = dir("interrupted");
    std::fs::copy(root().join("models/si_engine.toml"), d.join("m.toml")).unwrap();
    let made = std::process::Command::new("mkfifo")
        .arg(d.join("c.csv"))
        .status()
        .unwrap();
    assert!(made.success());
    let sim = ["simulate", "m.toml", "--cycle", "c.csv", "--out", "out.csv"];
    let fwd = [
        "forward",
        "m.toml",
        "--cycle",
        "c.csv",
        "--summary-json",
        "s.json",
    ];
    let sweep = [
        "sweep", "m.toml", "--cycle", "c.csv", "--grid", "m=1:2:2", "--out", "out.csv",
    ];
    for (args, sig) in [
        (&sim[..], libc::SIGINT),
        (&sim[..], libc::SIGTERM),
        (&sim[..], libc::SIGHUP),
        (&fwd[..], libc::SIGTERM),
        (&sweep[..], libc::SIGINT),
    ] {
        let status = interrupt(&d, args, sig);
        assert_eq!(status.signal(), Some(sig), "{args:?}: {status:?}");
        assert_eq!(names(&d), ["c.csv", "m.toml"], "{args:?} on signal {sig}");
    }
}

/// Run `invsim` with `args`, its stderr opened on `/dev/full` (every write fails: no space left).
fn with_full_stderr(args: &[&str]) -> std::process::Output {
    std::process::Command::new(env!("CARGO_BIN_EXE_invsim"))
        .args(args)
        .current_dir(root())
        .stderr(
            std::fs::OpenOptions::new()
                .write(true)
                .open("/dev/full")
                .unwrap(),
        )
        .output()
        .unwrap()
}

/// A stderr that cannot be written (`2>/dev/full`) loses the message, not the exit status: 2 for bad input,
/// 3 for a sweep with failed variants, 0 for a success whose warnings could not be printed — never a panic.
#[test]
fn an_unwritable_stderr_keeps_the_exit_status() {
    let bad = with_full_stderr(&[
        "simulate",
        "models/si_engine.toml",
        "--cycle",
        "missing.csv",
    ]);
    assert_eq!(bad.status.code(), Some(2));
    let failed = with_full_stderr(&[
        "sweep",
        "models/si_engine.toml",
        "--cycle",
        "ece",
        "--grid",
        "i_t=0:5:2",
        "--threads",
        "8",
    ]);
    assert_eq!(failed.status.code(), Some(3));
    assert_eq!(String::from_utf8_lossy(&failed.stdout).lines().count(), 3);
    let warned = with_full_stderr(&["import", "fastsim", "models/vehicles/ford_fusion_2012.yaml"]);
    assert_eq!(warned.status.code(), Some(0));
    assert!(String::from_utf8_lossy(&warned.stdout).contains("[parameters]"));
}

/// `sweep` on a stdout that cannot be written exits 2 like the other commands.
#[test]
fn sweep_on_a_full_stdout_exits_2() {
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_invsim"))
        .args([
            "sweep",
            "models/si_engine.toml",
            "--cycle",
            "ece",
            "--dt",
            "1",
            "--grid",
            "m=1200:1300:2",
        ])
        .current_dir(root())
        .stdout(
            std::fs::OpenOptions::new()
                .write(true)
                .open("/dev/full")
                .unwrap(),
        )
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("cannot write to stdout"),
        "{}",
        stderr(&o)
    );
}

/// Output names of 254 and 255 bytes (NAME_MAX) are written: the temporary name is cut to fit.
#[test]
fn output_names_up_to_255_bytes_are_written() {
    let d = dir("long-names");
    let n254 = format!("{}.csv", "a".repeat(250));
    let n255 = format!("{}.jsn", "a".repeat(251));
    std::fs::write(d.join(&n255), "old\n").unwrap();
    let o = invsim(&[
        "simulate",
        "models/si_engine.toml",
        "--cycle",
        "ece",
        "--dt",
        "1",
        "--out",
        d.join(&n254).to_str().unwrap(),
        "--summary-json",
        d.join(&n255).to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(std::fs::read_to_string(d.join(&n254))
        .unwrap()
        .starts_with("t,"));
    assert_eq!(json_file(&d.join(&n255))["cycle"], "ece");
    let mut want = vec![n254, n255];
    want.sort();
    assert_eq!(names(&d), want);
}
