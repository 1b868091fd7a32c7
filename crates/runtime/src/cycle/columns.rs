//! The extra columns of a cycle file (contract §5): every column that is not the time, speed or grade column
//! is kept by its header name (trimmed, case-sensitive) so that a signal can read it (`signals.rs`). A column
//! is checked only when a signal uses it: its cells are parsed as they are read, a cell that is not a finite
//! number becomes NaN and the first such cell is remembered ([`BadCell`]), so that using the column is an
//! error naming file, line and column, while a text column no signal uses (a comment, a phase name) costs
//! nothing.

use super::printable::printable;
use std::collections::HashSet;

/// The first cell of an extra column that is not a finite number: where it is and what it holds.
#[derive(Debug, Clone, PartialEq)]
pub struct BadCell {
    /// The cycle file as named in messages.
    pub file: String,
    /// 1-based line in the file (counting the header and blank lines).
    pub line: u64,
    /// 1-based column, in characters, where the cell starts.
    pub column: usize,
    /// The cell's text (trimmed, control characters escaped, at most 40 characters).
    pub text: String,
}

/// One extra column of a cycle file: its header name and a value per sample (NaN where the cell is not a
/// finite number; `bad` then names the first such cell).
#[derive(Debug, Clone, PartialEq)]
pub struct CycleColumn {
    pub name: String,
    pub values: Vec<f64>,
    pub bad: Option<BadCell>,
}

/// The extra columns being read: for each, its field index in the record and the column so far.
pub(super) struct ExtraColumns {
    columns: Vec<(usize, CycleColumn)>,
}

impl ExtraColumns {
    /// The header fields at `indices` (the ones with no role), by name; an empty name is skipped, a repeated
    /// name keeps its first column (a set of the names seen: linear in the number of columns).
    pub(super) fn new(names: &[String], indices: impl Iterator<Item = usize>) -> ExtraColumns {
        let mut columns: Vec<(usize, CycleColumn)> = Vec::new();
        let mut seen: HashSet<&str> = HashSet::new();
        for i in indices {
            let name = &names[i];
            if name.is_empty() || !seen.insert(name.as_str()) {
                continue;
            }
            columns.push((
                i,
                CycleColumn {
                    name: name.clone(),
                    values: Vec::new(),
                    bad: None,
                },
            ));
        }
        ExtraColumns { columns }
    }

    /// Append the cells of one data row; `line_text` is the row's text (for the character column of a bad
    /// cell), `file` and `line` where it is. The columns where the row's fields start are counted once per row,
    /// when its first bad cell needs them (linear in the row's length, whatever the number of bad cells).
    pub(super) fn push(
        &mut self,
        record: &csv::StringRecord,
        (file, line, line_text): (&str, u64, &str),
    ) {
        let mut starts: Option<Vec<usize>> = None;
        for (index, column) in &mut self.columns {
            let text = record.get(*index).unwrap_or("").trim();
            let value = text.parse::<f64>().ok().filter(|v| v.is_finite());
            column.values.push(value.unwrap_or(f64::NAN));
            if value.is_none() && column.bad.is_none() {
                column.bad = Some(BadCell {
                    file: file.to_string(),
                    line,
                    column: field_starts(&mut starts, line_text, *index),
                    text: printable(text),
                });
            }
        }
    }

    pub(super) fn finish(self) -> Vec<CycleColumn> {
        self.columns.into_iter().map(|(_, c)| c).collect()
    }
}

/// The 1-based character column where field `index` of `line` starts, from the columns of every field of the
/// line (`starts`, counted on the first call for the line).
fn field_starts(starts: &mut Option<Vec<usize>>, line: &str, index: usize) -> usize {
    let starts = starts.get_or_insert_with(|| {
        let mut col = 1;
        line.split(',')
            .map(|field| {
                let start = col;
                col += field.chars().count() + 1;
                start
            })
            .collect()
    });
    starts
        .get(index)
        .copied()
        .unwrap_or_else(|| field_column(line, index))
}

/// The 1-based character column where field `index` of a comma-separated `line` starts (quoted fields that
/// hold commas are not told apart: the column is then approximate). Cycle files and signal files both
/// report a bad cell by it.
pub(crate) fn field_column(line: &str, index: usize) -> usize {
    let mut col = 1;
    for (i, field) in line.split(',').enumerate() {
        if i == index {
            return col;
        }
        col += field.chars().count() + 1;
    }
    col
}

#[cfg(test)]
mod tests {
    use super::{field_column, field_starts};

    #[test]
    fn columns_count_characters() {
        assert_eq!(field_column("1,ä2,x", 0), 1);
        assert_eq!(field_column("1,ä2,x", 2), 6);
        let mut starts = None;
        assert_eq!(field_starts(&mut starts, "1,ä2,x", 2), 6);
        assert_eq!(field_starts(&mut starts, "1,ä2,x", 1), 3);
        assert_eq!(starts, Some(vec![1, 3, 6]));
    }
}
