//! Build script of the `invsim` command: sets `INVSIM_GIT_REVISION` to `git rev-parse --short HEAD` of the
//! checkout, or to "unknown" when git or the repository is absent (a source tarball builds all the same). The
//! revision is that of the commit checked out; uncommitted edits are not marked.
//!
//! On Linux it also links the `invsim` executable as a non-position-independent one ([`link_fixed_address`]).

use std::path::Path;
use std::process::Command;

/// Stdout of `git ARGS` run in this crate's directory, trimmed, if git ran and succeeded.
fn git(args: &[&str]) -> Option<String> {
    let out = Command::new("git")
        .args(args)
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .ok()?;
    if !out.status.success() {
        return None;
    }
    let text = String::from_utf8(out.stdout).ok()?;
    Some(text.trim().to_string())
}

/// Rebuild when HEAD moves: the HEAD file, the branch it names and packed-refs (only paths that exist, since
/// cargo reruns a script on every build for a missing one).
fn watch_head() {
    let dirs = [
        git(&["rev-parse", "--git-dir"]),
        git(&["rev-parse", "--git-common-dir"]),
    ];
    let branch = git(&["symbolic-ref", "-q", "HEAD"]);
    for dir in dirs.iter().flatten() {
        let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join(dir);
        let mut files = vec![dir.join("HEAD"), dir.join("packed-refs")];
        if let Some(branch) = &branch {
            files.push(dir.join(branch));
        }
        for f in files.iter().filter(|f| f.exists()) {
            println!("cargo:rerun-if-changed={}", f.display());
        }
    }
}

/// Link the `invsim` binary at a fixed address (`-no-pie`; the C compiler rustc links with takes the last of
/// `-pie` and `-no-pie`). A position-independent executable makes the dynamic loader apply ~12 000 relative
/// relocations at every start (the pointers of clap's, serde's and the formatting machinery's tables in
/// `.data.rel.ro`), each page they touch a copy-on-write page fault: about 40 of a `simulate` process's ~215
/// page faults and 0.16 M of its instructions. The cost is the executable's address randomisation (the
/// libraries, the heap and the stack stay randomised). Not for a static build (`-C target-feature=+crt-static`
/// in RUSTFLAGS, which rustc links with `-static-pie`: `-no-pie` after it makes a binary that crashes); one
/// asked for with `cargo rustc -- -C target-feature=+crt-static` is not seen here, so it needs RUSTFLAGS.
fn link_fixed_address() {
    let linux = std::env::var("CARGO_CFG_TARGET_OS").as_deref() == Ok("linux");
    let features = std::env::var("CARGO_CFG_TARGET_FEATURE").unwrap_or_default();
    let crt_static = features.split(',').any(|f| f == "crt-static");
    if linux && !crt_static {
        println!("cargo:rustc-link-arg-bin=invsim=-no-pie");
    }
}

fn main() {
    println!("cargo:rerun-if-changed=build.rs");
    let revision = match git(&["rev-parse", "--short", "HEAD"]) {
        Some(rev) if !rev.is_empty() => {
            watch_head();
            rev
        }
        _ => "unknown".to_string(),
    };
    println!("cargo:rustc-env=INVSIM_GIT_REVISION={revision}");
    link_fixed_address();
}
