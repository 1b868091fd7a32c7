//! A run's CSV series read back for `invsim compare --plot`: the file `--series` names, else the `--out` file
//! the run's summary records in its provenance (as given to the run: tried from the current directory, then
//! beside the summary). The CSV must have the columns the summary lists (so that a series is never drawn as
//! another run's); only the columns a figure needs are kept, and the file is read up to a size cap.

use std::io::Read as _;
use std::path::{Path, PathBuf};

use crate::error::Failure;
use crate::run_summary::RunSummary;

/// Largest CSV series read, in bytes.
pub const MAX_SERIES_BYTES: u64 = 512 << 20;

/// The columns of one run's series that a figure uses.
pub struct RunSeries {
    pub names: Vec<String>,
    /// `data[i]`: the values of `names[i]`.
    pub data: Vec<Vec<f64>>,
}

impl RunSeries {
    /// The values of column `name` (empty if it was not read).
    pub fn column(&self, name: &str) -> &[f64] {
        self.names
            .iter()
            .position(|n| n == name)
            .map_or(&[], |i| self.data[i].as_slice())
    }
}

/// The series file of `run`: `given` if any, else the one its provenance records (see the module docs).
pub fn locate(run: &RunSummary, given: Option<&Path>) -> Result<PathBuf, Failure> {
    if let Some(p) = given {
        return Ok(p.to_path_buf());
    }
    let shown = run.path.display();
    let recorded = run.series_path().ok_or_else(|| {
        Failure::user(format!(
            "compare --plot: the summary {shown} names no CSV series (its run had no --out); give the runs' \
             CSV files with --series A.csv,B.csv,… in the order of the summaries"
        ))
    })?;
    let recorded = Path::new(recorded);
    let beside = run
        .path
        .parent()
        .zip(recorded.file_name())
        .map(|(dir, name)| dir.join(name));
    [Some(recorded.to_path_buf()), beside]
        .into_iter()
        .flatten()
        .find(|p| p.is_file())
        .ok_or_else(|| {
            Failure::user(format!(
                "compare --plot: the series {} that the summary {shown} names was not found (neither from the \
                 current directory nor beside the summary); give it with --series",
                recorded.display()
            ))
        })
}

/// Read the columns `wanted` of the series at `path` of `run`, checking its header against the summary's
/// columns.
pub fn read(run: &RunSummary, path: &Path, wanted: &[String]) -> Result<RunSeries, Failure> {
    let shown = path.display();
    let fail = |why: String| Failure::user(format!("compare --plot: the series {shown}: {why}"));
    let file = std::fs::File::open(path).map_err(|e| fail(format!("cannot be read ({e})")))?;
    let mut text = String::new();
    file.take(MAX_SERIES_BYTES + 1)
        .read_to_string(&mut text)
        .map_err(|e| fail(format!("cannot be read as text ({e})")))?;
    if text.len() as u64 > MAX_SERIES_BYTES {
        return Err(fail(format!("larger than {MAX_SERIES_BYTES} bytes")));
    }
    let mut reader = csv::Reader::from_reader(text.as_bytes());
    let header: Vec<String> = reader
        .headers()
        .map_err(|e| fail(format!("no CSV header ({e})")))?
        .iter()
        .map(str::to_string)
        .collect();
    let listed = run.column_names();
    if !listed.is_empty() && header != listed {
        return Err(fail(format!(
            "its columns ({}) are not those the summary {} lists ({}): it is another run's series",
            header.join(", "),
            run.path.display(),
            listed.join(", ")
        )));
    }
    let index: Vec<Option<usize>> = wanted
        .iter()
        .map(|w| header.iter().position(|h| h == w))
        .collect();
    let mut data = vec![Vec::new(); wanted.len()];
    for (row, record) in reader.records().enumerate() {
        let record = record.map_err(|e| fail(format!("row {}: {e}", row + 2)))?;
        for (col, i) in data.iter_mut().zip(&index) {
            if let Some(i) = i {
                let v = record.get(*i).and_then(|s| s.trim().parse::<f64>().ok());
                col.push(v.unwrap_or(f64::NAN));
            }
        }
    }
    Ok(RunSeries {
        names: wanted.to_vec(),
        data,
    })
}
