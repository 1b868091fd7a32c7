//! `docs/reference.md` is complete: it mentions every key the model-file reader accepts (the lists of
//! `invsim_inversion::model::keys`, which the reader checks every table against), every command and every
//! long option of the `invsim` command line (read from the clap attributes of `crates/cli/src/*.rs`). The test
//! fails naming each one the reference does not mention, and a reference with a mention removed is caught.
//!
//! A mention is an inline code span or a line of a fenced block: a key as `` `key` ``, `` `key = …` ``,
//! `` `[key]` ``/`` `[key.NAME]` `` or `key = …` in a TOML block; an option as `` `--option …` `` or
//! `--option` in a fenced block (the synopsis); a command as `` `command` `` or `invsim command …`.

use invsim_inversion::model::keys;
use std::collections::BTreeSet;
use std::path::{Path, PathBuf};

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

fn reference() -> String {
    let path = root().join("docs/reference.md");
    std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

/// The reference's inline code spans and the lines of its fenced blocks (with the fence's language).
struct Mentions {
    spans: Vec<String>,
    fenced: Vec<(String, String)>,
}

fn mentions(doc: &str) -> Mentions {
    let (mut spans, mut fenced) = (Vec::new(), Vec::new());
    let mut fence: Option<String> = None;
    for line in doc.lines() {
        let trimmed = line.trim_start();
        if let Some(lang) = trimmed.strip_prefix("```") {
            fence = match fence {
                Some(_) => None,
                None => Some(lang.trim().to_string()),
            };
            continue;
        }
        match &fence {
            Some(lang) => fenced.push((lang.clone(), line.to_string())),
            None => spans.extend(
                line.split('`')
                    .skip(1)
                    .step_by(2)
                    .map(|s| s.trim().to_string()),
            ),
        }
    }
    Mentions { spans, fenced }
}

/// `word` occurs in `text` not as a part of a longer name.
fn has_word(text: &str, word: &str, name_char: fn(char) -> bool) -> bool {
    text.match_indices(word).any(|(i, _)| {
        let before = text[..i].chars().next_back();
        let after = text[i + word.len()..].chars().next();
        !before.is_some_and(name_char) && !after.is_some_and(name_char)
    })
}

fn key_char(c: char) -> bool {
    c.is_ascii_alphanumeric() || c == '_'
}

fn option_char(c: char) -> bool {
    c.is_ascii_alphanumeric() || c == '-' || c == '_'
}

fn mentions_key(m: &Mentions, key: &str) -> bool {
    let span = |s: &String| {
        s == key
            || s.starts_with(&format!("{key} ="))
            || s.starts_with(&format!("{key}="))
            || s.starts_with(&format!("[{key}]"))
            || s.starts_with(&format!("[{key}."))
    };
    let toml = |(lang, line): &(String, String)| {
        let code = line.split('#').next().unwrap_or("").trim();
        lang == "toml"
            && (code.starts_with(&format!("[{key}]"))
                || code.starts_with(&format!("[{key}."))
                || code.match_indices(key).any(|(i, _)| {
                    let before = code[..i].chars().next_back();
                    let rest = code[i + key.len()..].trim_start();
                    !before.is_some_and(key_char)
                        && !before.is_some_and(|c| c == '"' || c == '.')
                        && rest.starts_with('=')
                        && !rest.starts_with("==")
                }))
    };
    m.spans.iter().any(span) || m.fenced.iter().any(toml)
}

fn mentions_option(m: &Mentions, option: &str) -> bool {
    let long = format!("--{option}");
    m.spans
        .iter()
        .any(|s| s.starts_with(&long) && has_word(s, &long, option_char))
        || m.fenced
            .iter()
            .any(|(_, l)| has_word(l, &long, option_char))
}

fn mentions_command(m: &Mentions, command: &str, commands: &BTreeSet<String>) -> bool {
    let text = m.spans.iter().chain(m.fenced.iter().map(|(_, l)| l));
    text.into_iter().any(|s| {
        let mut tokens = s.split_whitespace().peekable();
        if tokens.peek() == Some(&"invsim") {
            tokens.next();
        }
        // The leading command names: `derive`, `import fastsim`, `invsim simulate …`.
        tokens
            .take_while(|t| commands.contains(*t))
            .any(|t| t == command)
    })
}

/// The attribute starting at `lines[i]` (`#[…]`, possibly over several lines) and the index after it.
fn attribute(lines: &[&str], i: usize) -> (String, usize) {
    let mut text = String::new();
    let mut depth = 0i32;
    let mut j = i;
    while j < lines.len() {
        text.push_str(lines[j]);
        text.push(' ');
        depth += lines[j].matches('[').count() as i32 - lines[j].matches(']').count() as i32;
        j += 1;
        if depth <= 0 {
            break;
        }
    }
    (text, j)
}

fn kebab(name: &str) -> String {
    let mut out = String::new();
    for (i, c) in name.chars().enumerate() {
        if c.is_ascii_uppercase() {
            if i > 0 {
                out.push('-');
            }
            out.push(c.to_ascii_lowercase());
        } else {
            out.push(if c == '_' { '-' } else { c });
        }
    }
    out
}

/// The long options and the commands of the command line, from the clap attributes of its sources.
fn cli() -> (BTreeSet<String>, BTreeSet<String>) {
    let dir = root().join("crates/cli/src");
    let (mut options, mut commands) = (BTreeSet::new(), BTreeSet::new());
    // clap's own.
    options.extend(["help", "version"].map(String::from));
    let mut files: Vec<_> = std::fs::read_dir(&dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .map(|e| e.expect("a directory entry").path())
        .filter(|p| p.extension().is_some_and(|x| x == "rs"))
        .collect();
    files.sort();
    for file in files {
        let text = std::fs::read_to_string(&file).expect("a CLI source file");
        let lines: Vec<&str> = text.lines().collect();
        let mut i = 0;
        let mut in_subcommands = false;
        while i < lines.len() {
            let line = lines[i].trim();
            if line.starts_with("#[derive(") && line.contains("Subcommand") {
                in_subcommands = true;
            }
            if in_subcommands && line == "}" && lines[i].starts_with('}') {
                in_subcommands = false;
            }
            if in_subcommands && lines[i].starts_with("    ") && !lines[i].starts_with("     ") {
                let variant: String = line.chars().take_while(|c| key_char(*c)).collect();
                if variant.starts_with(|c: char| c.is_ascii_uppercase()) {
                    commands.insert(kebab(&variant));
                }
            }
            if !line.starts_with("#[arg(") {
                i += 1;
                continue;
            }
            let (attr, next) = attribute(&lines, i);
            i = next;
            if !has_word(&attr, "long", key_char) {
                continue;
            }
            if let Some(rest) = attr.split("long = \"").nth(1) {
                options.insert(rest.split('"').next().unwrap_or("").to_string());
                continue;
            }
            // `long` without a name: the field's name, after any further attributes and doc comments.
            while i < lines.len() {
                let l = lines[i].trim();
                if l.starts_with("#[") {
                    i = attribute(&lines, i).1;
                } else if l.starts_with("///") || l.is_empty() {
                    i += 1;
                } else {
                    let field = l
                        .trim_start_matches("pub(crate) ")
                        .trim_start_matches("pub ");
                    let name: String = field.chars().take_while(|c| key_char(*c)).collect();
                    assert!(
                        field[name.len()..].starts_with(':'),
                        "{}:{}: expected the field of a `#[arg(long)]`, found `{l}`",
                        file.display(),
                        i + 1
                    );
                    options.insert(kebab(&name));
                    break;
                }
            }
        }
    }
    (options, commands)
}

/// Everything the reference does not mention, one line each.
fn missing(doc: &str) -> Vec<String> {
    let m = mentions(doc);
    let mut out = Vec::new();
    for (table, list) in keys::TABLES {
        for key in *list {
            if !mentions_key(&m, key) {
                out.push(format!("model-file key `{key}` of {table}"));
            }
        }
    }
    let (options, commands) = cli();
    for command in &commands {
        if !mentions_command(&m, command, &commands) {
            out.push(format!("command `{command}`"));
        }
    }
    for option in &options {
        if !mentions_option(&m, option) {
            out.push(format!("option `--{option}`"));
        }
    }
    out
}

#[test]
fn the_cli_reader_finds_the_commands_and_options() {
    let (options, commands) = cli();
    for c in [
        "derive",
        "simulate",
        "forward",
        "sweep",
        "compare",
        "cycles",
        "import",
        "fastsim",
        "completions",
    ] {
        assert!(
            commands.contains(c),
            "command {c} not found in {commands:?}"
        );
    }
    assert_eq!(commands.len(), 9, "{commands:?}");
    for o in [
        "cycle",
        "strict",
        "transition-time",
        "series",
        "signal",
        "max-cycle-bytes",
        "no-feedforward",
        "summary-json",
        "window",
        "threads",
    ] {
        assert!(options.contains(o), "option --{o} not found in {options:?}");
    }
    assert!(
        options.len() >= 40,
        "{} options: {options:?}",
        options.len()
    );
}

#[test]
fn the_reference_mentions_every_key_command_and_option() {
    let missing = missing(&reference());
    assert!(
        missing.is_empty(),
        "docs/reference.md does not mention (fix: document each in docs/reference.md):\n{}",
        missing.join("\n")
    );
}

#[test]
fn a_mention_removed_is_caught() {
    let doc = reference()
        .replace("--window", "--time-window")
        .replace("brake_band", "brake-band")
        .replace("`fastsim", "`fast-sim")
        .replace("import fastsim", "import fast-sim");
    let missing = missing(&doc);
    for what in [
        "option `--window`",
        "model-file key `brake_band` of [sequence]",
        "command `fastsim`",
    ] {
        assert!(
            missing.iter().any(|m| m == what),
            "{what} not reported: {missing:?}"
        );
    }
    assert_eq!(missing.len(), 3, "{missing:?}");
}
