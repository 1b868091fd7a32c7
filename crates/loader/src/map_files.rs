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
    let Ok(doc) = text.parse::<toml::Table>() else {
        return Vec::new();
    };
    let base = path.parent().unwrap_or(Path::new(""));
    let Some(maps) = doc.get("maps").and_then(toml::Value::as_table) else {
        return Vec::new();
    };
    maps.values()
        .filter_map(|m| m.get("file").and_then(toml::Value::as_str))
        .map(|name| base.join(name))
        .collect()
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
        std::fs::write(&model, "not [ toml").unwrap();
        assert!(map_files(&model).is_empty());
        assert!(map_files(&dir.join("missing.toml")).is_empty());
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
