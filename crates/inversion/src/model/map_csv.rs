//! A map's values from a CSV file (contract §6): comma-separated, an optional UTF-8 byte-order mark, `#`
//! comment lines and blank lines skipped. 1-D: two columns `x, value`, optionally after one header row of
//! two non-numeric cells. 2-D: the first row is the `y` grid (its first cell empty or a label), the first
//! column the `x` grid, the rest the values (one row per `x`). Every error names the CSV file, line and column.

use super::error::{ModelError, ModelErrorKind};
use std::io::Read;
use std::path::Path;

/// Largest map CSV file read, in bytes (16 MiB).
pub const MAX_MAP_FILE_BYTES: u64 = 16 << 20;

/// A map's grid and values (row-major for 2-D).
pub(super) struct Grid {
    pub(super) x: Vec<f64>,
    pub(super) y: Option<Vec<f64>>,
    pub(super) values: Vec<f64>,
}

/// One cell: its text (trimmed), 1-based line and column.
struct Cell<'a> {
    text: &'a str,
    line: usize,
    column: usize,
}

fn error(path: &Path, line: Option<usize>, column: Option<usize>, message: String) -> ModelError {
    ModelError {
        file: path.to_path_buf(),
        line,
        column,
        message,
        kind: ModelErrorKind::Schema,
    }
}

fn cell_error(path: &Path, c: &Cell<'_>, message: String) -> ModelError {
    error(path, Some(c.line), Some(c.column), message)
}

/// The rows of cells, comments and blank lines dropped.
fn rows(text: &str) -> Vec<Vec<Cell<'_>>> {
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    let mut out = Vec::new();
    for (i, line) in text.lines().enumerate() {
        let trimmed = line.trim();
        if trimmed.is_empty() || trimmed.starts_with('#') {
            continue;
        }
        // The 1-based character column of each cell, counted as the line is split (linear in its length).
        let mut cells = Vec::new();
        let mut chars = 0;
        for piece in line.split(',') {
            let lead = piece.len() - piece.trim_start().len();
            cells.push(Cell {
                text: piece.trim(),
                line: i + 1,
                column: chars + piece[..lead].chars().count() + 1,
            });
            chars += piece.chars().count() + 1;
        }
        out.push(cells);
    }
    out
}

/// A finite number, or an error at the cell.
fn number(path: &Path, c: &Cell<'_>, what: &str) -> Result<f64, ModelError> {
    match c.text.parse::<f64>() {
        Ok(x) if x.is_finite() => Ok(x),
        Ok(x) => Err(cell_error(
            path,
            c,
            format!("{what} must be finite, found {x}"),
        )),
        Err(_) => Err(cell_error(
            path,
            c,
            format!("{what} must be a number, found `{}`", c.text.escape_debug()),
        )),
    }
}

/// Checks that `cells` hold a strictly increasing grid of at least two points.
fn grid(path: &Path, cells: &[&Cell<'_>], what: &str) -> Result<Vec<f64>, ModelError> {
    let mut out: Vec<f64> = Vec::with_capacity(cells.len());
    for c in cells {
        let x = number(path, c, &format!("a {what} grid value"))?;
        if let Some(&prev) = out.last() {
            if x <= prev {
                return Err(cell_error(
                    path,
                    c,
                    format!("the {what} grid is not strictly increasing: {x} follows {prev}"),
                ));
            }
        }
        out.push(x);
    }
    if out.len() < 2 {
        let (line, column) = cells
            .first()
            .map_or((None, None), |c| (Some(c.line), Some(c.column)));
        return Err(error(
            path,
            line,
            column,
            format!(
                "the {what} grid has {} point(s); a map needs at least 2",
                out.len()
            ),
        ));
    }
    Ok(out)
}

/// A map's data: x grid, y grid of a 2-D map, values row-major.
pub type MapData = (Vec<f64>, Option<Vec<f64>>, Vec<f64>);

/// A map's CSV file read on its own (`--map NAME=FILE.csv`), 2-D when a row has 3 or more cells.
pub fn read_map_file(path: &Path) -> Result<MapData, ModelError> {
    let g = read_csv(path, None)?;
    Ok((g.x, g.y, g.values))
}

/// Reads a map's CSV file; `arity` from the map's `args` if given, else 2-D when a row has 3 or more cells.
pub(super) fn read_csv(path: &Path, arity: Option<usize>) -> Result<Grid, ModelError> {
    let io = |e: std::io::Error| {
        let mut err = error(path, None, None, format!("cannot read the map file: {e}"));
        err.kind = ModelErrorKind::Io;
        err
    };
    let mut bytes = Vec::new();
    std::fs::File::open(path)
        .map_err(io)?
        .take(MAX_MAP_FILE_BYTES + 1)
        .read_to_end(&mut bytes)
        .map_err(io)?;
    if bytes.len() as u64 > MAX_MAP_FILE_BYTES {
        return Err(error(
            path,
            None,
            None,
            format!("the map file is larger than {MAX_MAP_FILE_BYTES} bytes"),
        ));
    }
    let text = String::from_utf8(bytes).map_err(|_| {
        error(
            path,
            None,
            None,
            "the map file is not valid UTF-8".to_string(),
        )
    })?;
    let rows = rows(&text);
    if rows.is_empty() {
        return Err(error(
            path,
            None,
            None,
            "the map file has no data rows".to_string(),
        ));
    }
    let two_d = arity.map_or_else(|| rows.iter().any(|r| r.len() >= 3), |a| a == 2);
    if two_d {
        read_2d(path, &rows)
    } else {
        read_1d(path, &rows)
    }
}

fn read_1d(path: &Path, rows: &[Vec<Cell<'_>>]) -> Result<Grid, ModelError> {
    let header = rows[0].iter().all(|c| c.text.parse::<f64>().is_err());
    let data = if header && rows[0].len() == 2 {
        &rows[1..]
    } else {
        rows
    };
    let mut xs = Vec::with_capacity(data.len());
    let mut values = Vec::with_capacity(data.len());
    for row in data {
        if row.len() != 2 {
            let c = row.get(2).unwrap_or(&row[0]);
            return Err(cell_error(
                path,
                c,
                format!(
                    "a 1-D map file has two columns (x, value); this row has {}",
                    row.len()
                ),
            ));
        }
        xs.push(&row[0]);
        values.push(number(path, &row[1], "a map value")?);
    }
    let x = grid(path, &xs, "x")?;
    Ok(Grid { x, y: None, values })
}

fn read_2d(path: &Path, rows: &[Vec<Cell<'_>>]) -> Result<Grid, ModelError> {
    let first = &rows[0];
    let ys: Vec<&Cell<'_>> = first.iter().skip(1).collect();
    let y = grid(path, &ys, "y (first row)")?;
    let mut xs = Vec::with_capacity(rows.len() - 1);
    let mut values = Vec::with_capacity((rows.len() - 1) * y.len());
    for row in &rows[1..] {
        if row.len() != y.len() + 1 {
            let c = row.get(y.len() + 1).or(row.last()).unwrap_or(&row[0]);
            return Err(cell_error(
                path,
                c,
                format!(
                    "ragged row: {} values for {} y grid points (each row is the x value and one value per y)",
                    row.len() - 1,
                    y.len()
                ),
            ));
        }
        xs.push(&row[0]);
        for c in &row[1..] {
            values.push(number(path, c, "a map value")?);
        }
    }
    let x = grid(path, &xs, "x (first column)")?;
    Ok(Grid {
        x,
        y: Some(y),
        values,
    })
}
