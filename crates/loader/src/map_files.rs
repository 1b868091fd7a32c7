//! The CSV files a model file's `[maps]` name (`file = "…"`, contract §6), for the check of a run's outputs
//! against its inputs: a run must not write onto a file its model reads, whichever engine runs it (compiled
//! code for a built-in model does not read the CSV at run time, but the model file still names it).
//!
//! The paths are resolved as the model reader resolves them: relative to the model file's directory
//! (`invsim_inversion`'s `maps.rs`, `map_path`).

use std::path::{Path, PathBuf};

/// The map CSV files the model file at `path` names, resolved against its directory. Only a regular file is
/// read (a pipe given as the model file is read once, by the loader); a file that cannot be read or parsed
/// names none (loading it then reports why).
pub fn map_files(path: &Path) -> Vec<PathBuf> {
    if !std::fs::metadata(path).is_ok_and(|m| m.is_file()) {
        return Vec::new();
    }
    let mut bytes = Vec::new();
    let read = std::fs::File::open(path).and_then(|f| {
        use std::io::Read;
        f.take(invsim_inversion::MAX_MODEL_FILE_BYTES + 1)
            .read_to_end(&mut bytes)
    });
    if read.is_err() || bytes.len() as u64 > invsim_inversion::MAX_MODEL_FILE_BYTES {
        return Vec::new();
    }
    let Ok(text) = std::str::from_utf8(&bytes) else {
        return Vec::new();
    };
    let keys = file_keys(text);
    if keys == 0 {
        return Vec::new();
    }
    // The `[maps…]` sections alone are an eighth of si_engine_maps.toml: parsed first, the whole file only if
    // they do not account for every `file` key.
    let base = path.parent().unwrap_or(Path::new(""));
    let files = |t: &str| -> Option<Vec<PathBuf>> {
        let doc = toml::from_str::<Doc>(t).ok()?;
        Some(
            doc.maps
                .into_values()
                .filter_map(|m| m.file)
                .map(|name| base.join(name))
                .collect(),
        )
    };
    match files(&maps_sections(text)) {
        Some(found) if found.len() >= keys => found,
        _ => files(text).unwrap_or_default(),
    }
}

/// The part of a model file read here: `[maps.NAME] file = "…"`; every other key is skipped.
#[derive(serde::Deserialize)]
struct Doc {
    #[serde(default)]
    maps: std::collections::BTreeMap<String, MapEntry>,
}

#[derive(serde::Deserialize)]
struct MapEntry {
    #[serde(default)]
    file: Option<String>,
}

/// How many keys of the text may be `file`: a key `file` (bare, quoted or the last part of a dotted key) is
/// the letters `file`, an optional closing quote and blanks before its `=`. A key spelled with escapes
/// (`"fil\u0065"`) cannot be seen this way: a backslash anywhere counts as one more. Zero for a model without
/// map files (most), which is then not parsed again.
fn file_keys(text: &str) -> usize {
    let b = text.as_bytes();
    let escaped = usize::from(memchr::memchr(b'\\', b).is_some());
    let keys = memchr::memmem::find_iter(b, b"file")
        .filter(|&i| {
            let rest = &b[i + 4..];
            let rest = rest
                .strip_prefix(b"\"")
                .or(rest.strip_prefix(b"'"))
                .unwrap_or(rest);
            let blanks = rest
                .iter()
                .take_while(|&&c| c == b' ' || c == b'\t')
                .count();
            rest.get(blanks) == Some(&b'=')
        })
        .count();
    keys + escaped
}

/// The lines of the text's `[maps…]` sections (from such a header to the next header) and every other line
/// that may hold a `file` key, in order. A line inside a multi-line value that looks like a header may cut a
/// section short: the caller then finds fewer files than [`file_keys`] and parses the whole file.
fn maps_sections(text: &str) -> String {
    let mut out = String::new();
    let mut in_maps = false;
    for line in text.lines() {
        let t = line.trim_start();
        let key = t.trim_start_matches(['[', ' ', '\t']);
        let header = t.starts_with('[')
            && key.starts_with(|c: char| {
                c.is_ascii_alphabetic() || c == '_' || c == '"' || c == '\''
            });
        if header {
            in_maps = key.trim_start_matches(['"', '\'']).starts_with("maps");
        }
        if in_maps || file_keys(line) > 0 {
            out.push_str(line);
            out.push('\n');
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_maps_file_entries_relative_to_the_model() {
        let dir = std::env::temp_dir().join(format!("invsim-map-files-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let model = dir.join("m.toml");
        std::fs::write(
            &model,
            "name = \"m\"\n[maps.a]\nfile = \"a.csv\"\n[maps.b]\nx = [0.0, 1.0]\nvalues = [1.0, 2.0]\n\
             [maps.c]\nfile = \"../c.csv\"\n",
        )
        .unwrap();
        assert_eq!(map_files(&model), [dir.join("a.csv"), dir.join("../c.csv")]);
        std::fs::write(
            &model,
            "name = \"m\"\n[maps.a]\n\"fil\\u0065\" = \"e.csv\"\n",
        )
        .unwrap();
        assert_eq!(map_files(&model), [dir.join("e.csv")]);
        std::fs::write(&model, "name = \"file\"  # a profile = nothing\n").unwrap();
        assert_eq!(file_keys("name = \"file\"  # a profile: nothing\n"), 0);
        assert_eq!(file_keys("[maps.a]\n'file'\t= \"a.csv\"\nb.file = 1\n"), 2);
        assert!(map_files(&model).is_empty());
        // A line of a multi-line array that looks like a header cuts the section: the whole file is parsed.
        std::fs::write(
            &model,
            "[maps.a]\nvalues = [\n [\"q\"],\n]\nfile = \"a.csv\"\n[maps.b]\nfile = \"b.csv\"\n",
        )
        .unwrap();
        assert_eq!(map_files(&model), [dir.join("a.csv"), dir.join("b.csv")]);
        std::fs::write(&model, "not [ toml file = 1").unwrap();
        assert!(map_files(&model).is_empty());
        assert!(map_files(&dir.join("missing.toml")).is_empty());
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
