//! Every file a run reads, gathered in one list for the check of its outputs ([`crate::outputs`]): the model
//! file and the map CSV files it names (`[maps] … file = …`, `invsim_loader::map_files`), the cycle files,
//! the `--map NAME=FILE` and `--signal NAME=FILE` files, a sweep's `--table`, an import's vehicle file. An
//! output is refused when it is any of them (by canonical path or by device and inode), so no run writes onto
//! a file it reads. The model file is read for its map files only when the list is asked for, i.e. when a
//! run has a file output (a run without one does not parse its model file twice).

use std::path::{Path, PathBuf};

/// The input files of one run: (what the file is, its path as given or resolved), and the model files whose
/// map files are inputs too.
#[derive(Default)]
pub struct Inputs {
    files: Vec<(&'static str, PathBuf)>,
    models: Vec<PathBuf>,
}

impl Inputs {
    /// No inputs yet.
    pub fn new() -> Inputs {
        Inputs::default()
    }

    /// Any file the run reads, named `what` in a refusal.
    pub fn file(mut self, what: &'static str, path: &Path) -> Inputs {
        self.files.push((what, path.to_path_buf()));
        self
    }

    /// The model file and the map CSV files it names.
    pub fn model(mut self, path: &Path) -> Inputs {
        self.models.push(path.to_path_buf());
        self.file("model file", path)
    }

    /// A `--cycle` argument: a file unless it names a built-in cycle.
    pub fn cycle(self, spec: &str) -> Inputs {
        match crate::cycle_spec::is_builtin(spec) {
            true => self,
            false => self.file("cycle file", Path::new(spec.trim())),
        }
    }

    /// The files of `--map NAME=FILE` and `--signal NAME=FILE` (a `--signal` value that is a number is none).
    pub fn data(mut self, data: &crate::data_args::DataArgs) -> Inputs {
        for arg in &data.map {
            if let Some((_, file)) = crate::map_args::split(arg) {
                self.files.push(("--map file", PathBuf::from(file)));
            }
        }
        for arg in &data.signal {
            if let Some(file) = crate::signal_args::file_of(arg) {
                self.files.push(("--signal file", PathBuf::from(file)));
            }
        }
        self
    }

    /// The list, in the order gathered, then the map files of each model file.
    pub fn list(&self) -> Vec<(&'static str, PathBuf)> {
        let mut all = self.files.clone();
        for model in &self.models {
            for m in invsim_loader::map_files(model) {
                all.push(("map file named in the model's [maps]", m));
            }
        }
        all
    }
}
