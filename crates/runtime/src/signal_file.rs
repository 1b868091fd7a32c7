//! A signal file (`--signal NAME=FILE.csv`, contract §5): CSV with a header, a UTF-8 byte-order mark
//! accepted, blank lines skipped; a time column (the cycle file's names: `time_s`, `time_seconds`,
//! `cycSecs`, `t`) and a column named NAME (case-sensitive); other columns ignored. Time must be finite and
//! strictly increasing, every value finite; each violation is an error naming the file, the line and the
//! column (1-based).

use thiserror::Error;

use crate::cycle::TIME_COLUMNS;
use crate::signals::SignalValue;

/// Largest signal file read, in bytes (as the cycle's default cap, 64 MiB).
pub const MAX_SIGNAL_FILE_BYTES: u64 = 64 << 20;

/// A bad signal file: where and why.
#[derive(Debug, Clone, PartialEq, Error)]
#[error("{file}:{line}:{column}: {message}")]
pub struct SignalFileError {
    pub file: String,
    pub line: usize,
    pub column: usize,
    pub message: String,
}

/// The column (1-based, in characters) where field `index` of `line` starts.
fn field_column(line: &str, index: usize) -> usize {
    let mut col = 1;
    for (i, field) in line.split(',').enumerate() {
        if i == index {
            return col;
        }
        col += field.chars().count() + 1;
    }
    col
}

/// Read the samples of signal `name` from the text of a signal file (`file` names it in messages).
pub fn parse_signal_file(
    file: &str,
    text: &str,
    name: &str,
) -> Result<SignalValue, SignalFileError> {
    let err = |line: usize, column: usize, message: String| SignalFileError {
        file: file.to_string(),
        line,
        column,
        message,
    };
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    let mut lines = text
        .lines()
        .enumerate()
        .filter(|(_, l)| !l.trim().is_empty());
    let Some((h, header)) = lines.next() else {
        return Err(err(1, 1, "the signal file is empty; expected a header with a time column and a column named after the signal".into()));
    };
    let cells: Vec<&str> = header
        .split(',')
        .map(|c| c.trim().trim_matches('"'))
        .collect();
    let time_col = cells.iter().position(|c| TIME_COLUMNS.contains(c));
    let value_col = cells.iter().position(|c| *c == name);
    let (Some(tc), Some(vc)) = (time_col, value_col) else {
        let missing = if time_col.is_none() {
            format!("time column ({})", TIME_COLUMNS.join(", "))
        } else {
            format!("column named `{name}` (names are case-sensitive)")
        };
        return Err(err(
            h + 1,
            1,
            format!("the header has no {missing}; found: {}", cells.join(", ")),
        ));
    };
    let (mut time, mut values) = (Vec::new(), Vec::new());
    for (i, line) in lines {
        let fields: Vec<&str> = line.split(',').collect();
        let number = |c: usize, what: &str| -> Result<f64, SignalFileError> {
            let cell = fields
                .get(c)
                .map(|s| s.trim().trim_matches('"'))
                .unwrap_or("");
            let v: f64 = cell.parse().map_err(|_| {
                err(
                    i + 1,
                    field_column(line, c),
                    format!("{what} `{}` is not a number", cell.escape_debug()),
                )
            })?;
            if !v.is_finite() {
                return Err(err(
                    i + 1,
                    field_column(line, c),
                    format!("{what} {cell} is not finite"),
                ));
            }
            Ok(v)
        };
        let t = number(tc, "time")?;
        let v = number(vc, &format!("the value of `{name}`"))?;
        if let Some(&prev) = time.last() {
            if t <= prev {
                return Err(err(
                    i + 1,
                    field_column(line, tc),
                    format!("time {t} s does not increase (the sample before is at {prev} s); times must be strictly increasing"),
                ));
            }
        }
        time.push(t);
        values.push(v);
    }
    if time.is_empty() {
        return Err(err(
            h + 1,
            1,
            "the signal file has a header but no samples".into(),
        ));
    }
    Ok(SignalValue::Series {
        file: file.to_string(),
        time,
        values,
    })
}

/// Read signal `name` from the file at `path` (at most [`MAX_SIGNAL_FILE_BYTES`]).
pub fn read_signal_file(
    path: &std::path::Path,
    name: &str,
) -> Result<SignalValue, SignalFileError> {
    use std::io::Read;
    let file = path.display().to_string();
    let fail = |message: String| SignalFileError {
        file: file.clone(),
        line: 1,
        column: 1,
        message,
    };
    let f =
        std::fs::File::open(path).map_err(|e| fail(format!("cannot read the signal file: {e}")))?;
    let mut bytes = Vec::new();
    f.take(MAX_SIGNAL_FILE_BYTES + 1)
        .read_to_end(&mut bytes)
        .map_err(|e| fail(format!("cannot read the signal file: {e}")))?;
    if bytes.len() as u64 > MAX_SIGNAL_FILE_BYTES {
        return Err(fail(format!(
            "the signal file is larger than {MAX_SIGNAL_FILE_BYTES} bytes"
        )));
    }
    let text =
        String::from_utf8(bytes).map_err(|_| fail("the signal file is not UTF-8 text".into()))?;
    parse_signal_file(&file, &text, name)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reads_and_locates_errors() {
        let ok = parse_signal_file("g.csv", "\u{feff}t,grade\n0,0.01\n10,0.02\n", "grade").unwrap();
        assert_eq!(
            ok,
            SignalValue::Series {
                file: "g.csv".into(),
                time: vec![0.0, 10.0],
                values: vec![0.01, 0.02]
            }
        );
        let e = parse_signal_file("g.csv", "t,grade\n0,0.01\n0,0.02\n", "grade").unwrap_err();
        assert_eq!((e.line, e.column), (3, 1), "{e}");
        let e = parse_signal_file("g.csv", "t,grade\n0,0.01\n1,NaN\n", "grade").unwrap_err();
        assert_eq!((e.line, e.column), (3, 3), "{e}");
        let e = parse_signal_file("g.csv", "t,slope\n0,0.01\n", "grade").unwrap_err();
        assert_eq!(e.line, 1, "{e}");
    }
}
