//! Hostile-input suite: every case in `tests/hostile/*.json` runs the built `invsim` binary on hostile model
//! files, cycle files, options or output paths and must fail cleanly — exit status 2 (never 0, 1 or a signal),
//! a message matching the case's regex (naming file:line:column where there is one), no file in the case's
//! directory created, changed or removed, and the case's time and memory bounds kept.
//!
//! A case is a JSON object:
//!
//! ```json
//! {
//!   "about": "one line: what is hostile",
//!   "files": { "m.toml": { "copy": "models/si_engine.toml" }, "c.csv": { "text": "time_s,mps\n" },
//!              "g.bin": { "hex": "00ff" }, "link.toml": { "symlink": "m.toml" } },
//!   "args": ["simulate", "m.toml", "--cycle", "c.csv"],
//!   "exit": 2,
//!   "stderr": "c\\.csv:2:\\d+",
//!   "timeout_s": 20, "max_rss_mib": 1024
//! }
//! ```
//!
//! Files are created in a fresh directory, which is also the working directory of the run (`{dir}` in an
//! argument is its absolute path). In `text`, `{{repeat N|PIECE}}` expands to N copies of PIECE, where `{i}`
//! is the copy's number (1 … N) and `{i-1}` the previous one. `copy` paths are relative to the repository
//! root. `exit`, `timeout_s` (wall clock, then the run is killed) and `max_rss_mib` (peak resident memory,
//! VmHWM polled from /proc; above it the run is killed) default to 2, 20 s and 1024 MiB; `exit` is 0 only for
//! a hostile input whose correct answer is a result within the bounds (e.g. a large but easy model).
//!
//! Cases that fail today (open defects) live in `tests/hostile/pending/` with a `now` field saying what
//! happens; they are only checked for being well-formed. Move one up a directory once its defect is fixed
//! (the suite then runs it).

use regex_lite::Regex;
use serde_json::Value;
use std::collections::BTreeMap;
use std::os::unix::process::ExitStatusExt;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// One hostile-input case, read from its manifest.
struct Case {
    name: String,
    files: Vec<(String, FileSpec)>,
    args: Vec<String>,
    exit: i32,
    stderr: Regex,
    timeout: Duration,
    max_rss_kib: u64,
}

/// How a case's file is made.
enum FileSpec {
    Text(String),
    Copy(PathBuf),
    Bytes(Vec<u8>),
    Symlink(String),
}

/// What a run did.
struct Outcome {
    status: std::process::ExitStatus,
    stderr: String,
    elapsed: Duration,
    peak_rss_kib: u64,
    killed_for: Option<String>,
}

fn cases_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/hostile")
}

fn repo_root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// The `*.json` manifests directly in `dir`, sorted by name.
fn manifests(dir: &Path) -> Vec<PathBuf> {
    let mut paths: Vec<PathBuf> = std::fs::read_dir(dir)
        .unwrap_or_else(|e| panic!("cannot list {}: {e}", dir.display()))
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|x| x == "json"))
        .collect();
    paths.sort();
    paths
}

fn str_field<'a>(v: &'a Value, key: &str) -> Result<Option<&'a str>, String> {
    match v.get(key) {
        None => Ok(None),
        Some(Value::String(s)) => Ok(Some(s)),
        Some(_) => Err(format!("`{key}` must be a string")),
    }
}

fn num_field(v: &Value, key: &str, default: f64) -> Result<f64, String> {
    match v.get(key) {
        None => Ok(default),
        Some(x) => x
            .as_f64()
            .ok_or_else(|| format!("`{key}` must be a number")),
    }
}

/// Parse a manifest; `pending` manifests must also say what happens now (`now`).
fn read_case(path: &Path, pending: bool) -> Result<Case, String> {
    let text = std::fs::read_to_string(path).map_err(|e| e.to_string())?;
    let v: Value = serde_json::from_str(&text).map_err(|e| format!("not JSON: {e}"))?;
    const KEYS: &[&str] = &[
        "about",
        "files",
        "args",
        "exit",
        "stderr",
        "timeout_s",
        "max_rss_mib",
        "now",
    ];
    let obj = v.as_object().ok_or("a case must be a JSON object")?;
    if let Some(k) = obj.keys().find(|k| !KEYS.contains(&k.as_str())) {
        return Err(format!("unknown key `{k}`"));
    }
    str_field(&v, "about")?.ok_or("`about` is missing")?;
    if pending && str_field(&v, "now")?.is_none() {
        return Err("a pending case needs `now`: what happens today".into());
    }
    let args = v
        .get("args")
        .and_then(Value::as_array)
        .ok_or("`args` must be a list of strings")?
        .iter()
        .map(|a| {
            a.as_str()
                .map(str::to_string)
                .ok_or("`args` must be strings")
        })
        .collect::<Result<Vec<_>, _>>()?;
    let pattern = str_field(&v, "stderr")?.ok_or("`stderr` (a regex) is missing")?;
    let stderr = Regex::new(pattern).map_err(|e| format!("`stderr`: {e}"))?;
    let files = match v.get("files") {
        None => Vec::new(),
        Some(Value::Object(m)) => m
            .iter()
            .map(|(name, spec)| {
                Ok((
                    name.clone(),
                    file_spec(spec).map_err(|e| format!("{name}: {e}"))?,
                ))
            })
            .collect::<Result<Vec<_>, String>>()?,
        Some(_) => return Err("`files` must be an object".into()),
    };
    Ok(Case {
        name: path
            .file_stem()
            .map_or_else(String::new, |s| s.to_string_lossy().into_owned()),
        files,
        args,
        exit: num_field(&v, "exit", 2.0)? as i32,
        stderr,
        timeout: Duration::from_secs_f64(num_field(&v, "timeout_s", 20.0)?),
        max_rss_kib: (num_field(&v, "max_rss_mib", 1024.0)? * 1024.0) as u64,
    })
}

fn file_spec(spec: &Value) -> Result<FileSpec, String> {
    if let Some(t) = str_field(spec, "text")? {
        return Ok(FileSpec::Text(expand(t)?));
    }
    if let Some(p) = str_field(spec, "copy")? {
        return Ok(FileSpec::Copy(repo_root().join(p)));
    }
    if let Some(h) = str_field(spec, "hex")? {
        return hex(h).map(FileSpec::Bytes);
    }
    if let Some(t) = str_field(spec, "symlink")? {
        return Ok(FileSpec::Symlink(t.to_string()));
    }
    Err("a file is { text | copy | hex | symlink }".into())
}

fn hex(h: &str) -> Result<Vec<u8>, String> {
    let digits: Vec<u8> = h.bytes().filter(|b| !b.is_ascii_whitespace()).collect();
    digits
        .chunks(2)
        .map(|p| {
            std::str::from_utf8(p)
                .ok()
                .and_then(|s| u8::from_str_radix(s, 16).ok())
                .filter(|_| p.len() == 2)
                .ok_or_else(|| format!("bad hex `{}`", String::from_utf8_lossy(p)))
        })
        .collect()
}

/// Expand every `{{repeat N|PIECE}}` in `text` (see the module documentation).
fn expand(text: &str) -> Result<String, String> {
    let mut out = String::new();
    let mut rest = text;
    while let Some(start) = rest.find("{{repeat ") {
        out.push_str(&rest[..start]);
        let body = &rest[start + "{{repeat ".len()..];
        let end = body.find("}}").ok_or("unclosed `{{repeat`")?;
        let (count, piece) = body[..end].split_once('|').ok_or("`{{repeat N|PIECE}}`")?;
        let n: usize = count
            .trim()
            .parse()
            .map_err(|_| format!("bad count `{count}`"))?;
        for i in 1..=n {
            let prev = i - 1;
            out.push_str(
                &piece
                    .replace("{i}", &i.to_string())
                    .replace("{i-1}", &prev.to_string()),
            );
        }
        rest = &body[end + 2..];
    }
    out.push_str(rest);
    Ok(out)
}

/// Create the case's files in `dir`.
fn materialise(case: &Case, dir: &Path) -> Result<(), String> {
    for (name, spec) in &case.files {
        let path = dir.join(name);
        if let Some(parent) = path.parent() {
            std::fs::create_dir_all(parent).map_err(|e| e.to_string())?;
        }
        let made = match spec {
            FileSpec::Text(t) => std::fs::write(&path, t),
            FileSpec::Bytes(b) => std::fs::write(&path, b),
            FileSpec::Copy(from) => std::fs::copy(from, &path).map(|_| ()),
            FileSpec::Symlink(to) => std::os::unix::fs::symlink(to, &path),
        };
        made.map_err(|e| format!("cannot create {name}: {e}"))?;
    }
    Ok(())
}

/// Every entry under `dir` (not following links) with its content, or a link's target.
fn snapshot(dir: &Path) -> BTreeMap<PathBuf, Vec<u8>> {
    let mut out = BTreeMap::new();
    let mut todo = vec![dir.to_path_buf()];
    while let Some(d) = todo.pop() {
        let Ok(entries) = std::fs::read_dir(&d) else {
            continue;
        };
        for entry in entries.filter_map(Result::ok) {
            let path = entry.path();
            let rel = path.strip_prefix(dir).unwrap_or(&path).to_path_buf();
            let Ok(meta) = std::fs::symlink_metadata(&path) else {
                continue;
            };
            if meta.file_type().is_symlink() {
                let target = std::fs::read_link(&path).unwrap_or_default();
                out.insert(rel, format!("-> {}", target.display()).into_bytes());
            } else if meta.is_dir() {
                out.insert(rel, b"<dir>".to_vec());
                todo.push(path);
            } else {
                out.insert(rel, std::fs::read(&path).unwrap_or_default());
            }
        }
    }
    out
}

/// The peak resident set (VmHWM, KiB) of a running process, 0 if it cannot be read.
fn peak_rss_kib(pid: u32) -> u64 {
    let status = std::fs::read_to_string(format!("/proc/{pid}/status")).unwrap_or_default();
    status
        .lines()
        .find_map(|l| l.strip_prefix("VmHWM:"))
        .and_then(|v| v.trim().trim_end_matches("kB").trim().parse().ok())
        .unwrap_or(0)
}

/// Run `invsim` in `dir` with the case's arguments, killing it past the time or memory bound.
fn run(case: &Case, dir: &Path, logs: &Path) -> Result<Outcome, String> {
    let args: Vec<String> = case
        .args
        .iter()
        .map(|a| a.replace("{dir}", &dir.display().to_string()))
        .collect();
    let err_path = logs.join("stderr");
    let out = std::fs::File::create(logs.join("stdout")).map_err(|e| e.to_string())?;
    let err = std::fs::File::create(&err_path).map_err(|e| e.to_string())?;
    let start = Instant::now();
    let mut child = Command::new(env!("CARGO_BIN_EXE_invsim"))
        .args(&args)
        .current_dir(dir)
        .stdin(Stdio::null())
        .stdout(out)
        .stderr(err)
        .spawn()
        .map_err(|e| format!("cannot start invsim: {e}"))?;
    let (mut peak, mut killed_for) = (0, None);
    let status = loop {
        peak = peak.max(peak_rss_kib(child.id()));
        if let Some(status) = child.try_wait().map_err(|e| e.to_string())? {
            break status;
        }
        if killed_for.is_none() && start.elapsed() > case.timeout {
            killed_for = Some(format!("still running after {:?}", case.timeout));
        } else if killed_for.is_none() && peak > case.max_rss_kib {
            killed_for = Some(format!("peak memory {} MiB above the bound", peak / 1024));
        }
        if killed_for.is_some() {
            let _ = child.kill();
        }
        std::thread::sleep(Duration::from_millis(5));
    };
    let stderr =
        String::from_utf8_lossy(&std::fs::read(&err_path).unwrap_or_default()).into_owned();
    Ok(Outcome {
        status,
        stderr,
        elapsed: start.elapsed(),
        peak_rss_kib: peak,
        killed_for,
    })
}

/// Run one case and check every property; `Err` says which failed.
fn check(case: &Case) -> Result<(), String> {
    let base = std::env::temp_dir().join(format!(
        "invsim-hostile-{}-{}",
        std::process::id(),
        case.name
    ));
    let (dir, logs) = (base.join("work"), base.join("logs"));
    let _ = std::fs::remove_dir_all(&base);
    std::fs::create_dir_all(&dir).map_err(|e| e.to_string())?;
    std::fs::create_dir_all(&logs).map_err(|e| e.to_string())?;
    materialise(case, &dir)?;
    let before = snapshot(&dir);
    let outcome = run(case, &dir, &logs)?;
    let after = snapshot(&dir);
    let result = judge(case, &outcome, &before, &after);
    let _ = std::fs::remove_dir_all(&base);
    result
}

fn judge(
    case: &Case,
    o: &Outcome,
    before: &BTreeMap<PathBuf, Vec<u8>>,
    after: &BTreeMap<PathBuf, Vec<u8>>,
) -> Result<(), String> {
    let first_line = o
        .stderr
        .lines()
        .next()
        .unwrap_or("")
        .chars()
        .take(300)
        .collect::<String>();
    if let Some(why) = &o.killed_for {
        return Err(format!("{why} (killed); stderr: {first_line}"));
    }
    if o.status.code() != Some(case.exit) {
        let how = match (o.status.code(), o.status.signal()) {
            (Some(c), _) => format!("exit status {c}"),
            (None, Some(s)) => format!("signal {s}"),
            _ => "unknown status".to_string(),
        };
        return Err(format!(
            "{how}, expected {}; stderr: {first_line}",
            case.exit
        ));
    }
    if o.stderr.contains("panicked") || o.stderr.contains("RUST_BACKTRACE") {
        return Err(format!("panic message: {first_line}"));
    }
    if !case.stderr.is_match(&o.stderr) {
        return Err(format!(
            "stderr does not match /{}/: {}",
            case.stderr.as_str(),
            o.stderr.trim()
        ));
    }
    if before != after {
        let changed: Vec<String> = before
            .keys()
            .chain(after.keys())
            .filter(|k| before.get(*k) != after.get(*k))
            .map(|k| k.display().to_string())
            .collect();
        return Err(format!("files created, changed or removed: {changed:?}"));
    }
    eprintln!(
        "  ok {:<40} {:>6.2} s {:>6} MiB",
        case.name,
        o.elapsed.as_secs_f64(),
        o.peak_rss_kib / 1024
    );
    Ok(())
}

#[test]
fn hostile_inputs_fail_cleanly() {
    let paths = manifests(&cases_dir());
    assert!(paths.len() >= 40, "only {} hostile cases", paths.len());
    let mut failures = Vec::new();
    for path in &paths {
        let outcome = read_case(path, false).and_then(|case| check(&case));
        if let Err(e) = outcome {
            failures.push(format!("{}: {e}", path.display()));
        }
    }
    assert!(
        failures.is_empty(),
        "{} hostile case(s) failed:\n{}",
        failures.len(),
        failures.join("\n")
    );
}

#[test]
fn pending_cases_are_well_formed() {
    let dir = cases_dir().join("pending");
    for path in manifests(&dir) {
        if let Err(e) = read_case(&path, true) {
            panic!("{}: {e}", path.display());
        }
    }
}

#[test]
fn repeat_expands_with_indices() {
    assert_eq!(
        expand("a{{repeat 3|d{i}=d{i-1};}}b").as_deref(),
        Ok("ad1=d0;d2=d1;d3=d2;b")
    );
    assert_eq!(hex("efbb bf").as_deref(), Ok(&[0xef, 0xbb, 0xbf][..]));
}
