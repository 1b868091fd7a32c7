//! A signal file (`--signal NAME=FILE.csv`, contract §5): CSV with a header, a UTF-8 byte-order mark
//! accepted, blank lines skipped; a time column (the cycle file's names: `time_s`, `time_seconds`,
//! `cycSecs`, `t`) and a column named NAME (case-sensitive); other columns ignored. Without a time column, a
//! route profile for the grade: a distance column (`distance_m`, `distance_km`) and an elevation column
//! (`elevation_m`, `elevation_ft`), turned into grade along the run's distance (`elevation.rs`). Time (or
//! distance) must be finite and strictly increasing, every value finite; each violation is an error naming
//! the file, the line and the column (1-based).

use thiserror::Error;

use crate::cycle::{field_column, TIME_COLUMNS};
use crate::elevation::{Route, ELEVATION_COLUMNS};
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

/// Route-profile columns of a signal file (elevation over distance, `elevation.rs`): distance and elevation
/// names with their factor to metres.
pub const DISTANCE_COLUMNS: &[(&str, f64)] = &[("distance_m", 1.0), ("distance_km", 1000.0)];

/// Where a file's error is: file, line, column, message.
fn error_at(file: &str) -> impl Fn(usize, usize, String) -> SignalFileError + '_ {
    move |line, column, message| SignalFileError {
        file: file.to_string(),
        line,
        column,
        message,
    }
}

/// The two columns a signal file is read by: the abscissa (time or distance) and the values, each with its
/// index, its name in messages and its factor.
struct Pair<'n> {
    x: (usize, &'n str, f64),
    y: (usize, String, f64),
}

/// Which columns of the header `cells` to read for signal `name`: a time column and `name` (a time series),
/// else a distance and an elevation column (a route profile, then `true`).
fn choose(cells: &[&str], name: &str) -> Option<(Pair<'static>, bool)> {
    let find = |names: &[(&'static str, f64)]| {
        names
            .iter()
            .find_map(|&(n, f)| cells.iter().position(|c| *c == n).map(|i| (i, n, f)))
    };
    let time = cells.iter().position(|c| TIME_COLUMNS.contains(c));
    let value = cells.iter().position(|c| *c == name);
    if let (Some(tc), Some(vc)) = (time, value) {
        let x = (tc, "time", 1.0);
        let y = (vc, format!("the value of `{name}`"), 1.0);
        return Some((Pair { x, y }, false));
    }
    if time.is_some() {
        return None;
    }
    let (Some((di, _, df)), Some((ei, en, ef))) = (find(DISTANCE_COLUMNS), find(ELEVATION_COLUMNS))
    else {
        return None;
    };
    let y = (ei, format!("the elevation `{en}`"), ef);
    Some((
        Pair {
            x: (di, "distance", df),
            y,
        },
        true,
    ))
}

/// Read the samples of signal `name` from the text of a signal file (`file` names it in messages): a time
/// series, or a route profile (elevation over distance) when the file has no time column.
pub fn parse_signal_file(
    file: &str,
    text: &str,
    name: &str,
) -> Result<SignalValue, SignalFileError> {
    let err = error_at(file);
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
    let Some((pair, route)) = choose(&cells, name) else {
        let missing = if cells.iter().any(|c| TIME_COLUMNS.contains(c)) {
            format!("column named `{name}` (names are case-sensitive)")
        } else {
            format!(
                "time column ({}), nor a route profile's distance ({}) and elevation ({})",
                TIME_COLUMNS.join(", "),
                names(DISTANCE_COLUMNS),
                names(ELEVATION_COLUMNS)
            )
        };
        return Err(err(
            h + 1,
            1,
            format!("the header has no {missing}; found: {}", listed(&cells)),
        ));
    };
    let (x, y) = read_pairs(&err, lines, &pair, route)?;
    if x.is_empty() {
        return Err(err(
            h + 1,
            1,
            "the signal file has a header but no samples".into(),
        ));
    }
    Ok(if route {
        SignalValue::Route {
            file: file.to_string(),
            route: Route {
                distance: x,
                elevation: y,
            },
        }
    } else {
        SignalValue::Series {
            file: file.to_string(),
            time: x,
            values: y,
        }
    })
}

/// Most header names a message lists (a header of 10⁵ names would make a message of megabytes).
const LISTED_NAMES: usize = 20;

/// The first [`LISTED_NAMES`] names of a header, comma-separated (control characters escaped), and how many
/// more there are.
fn listed(cells: &[&str]) -> String {
    let shown: Vec<String> = cells
        .iter()
        .take(LISTED_NAMES)
        .map(|c| c.escape_debug().to_string())
        .collect();
    let mut s = shown.join(", ");
    if cells.len() > LISTED_NAMES {
        s.push_str(&format!(" and {} more", cells.len() - LISTED_NAMES));
    }
    s
}

fn names(columns: &[(&str, f64)]) -> String {
    columns.iter().map(|c| c.0).collect::<Vec<_>>().join(", ")
}

/// The finite numbers of the pair's columns on every data line, the abscissa strictly increasing; for a
/// `route`, the elevation changes by less than the distance between two rows (|Δh/Δs| < 1).
fn read_pairs<'t>(
    err: &impl Fn(usize, usize, String) -> SignalFileError,
    lines: impl Iterator<Item = (usize, &'t str)>,
    pair: &Pair,
    route: bool,
) -> Result<(Vec<f64>, Vec<f64>), SignalFileError> {
    let ((xc, x_what, xf), (yc, y_what, yf)) = (pair.x, &pair.y);
    let (mut xs, mut ys): (Vec<f64>, Vec<f64>) = (Vec::new(), Vec::new());
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
        let x = number(xc, x_what)? * xf;
        let y = number(*yc, y_what)? * *yf;
        if let Some(&prev) = xs.last() {
            if x <= prev {
                let unit = if x_what == "time" { "s" } else { "m" };
                return Err(err(
                    i + 1,
                    field_column(line, xc),
                    format!("{x_what} {x} {unit} does not increase (the sample before is at {prev} {unit}); {x_what}s must be strictly increasing"),
                ));
            }
        }
        if let (true, Some(&px), Some(&py)) = (route, xs.last(), ys.last()) {
            if (y - py).abs() >= x - px {
                return Err(err(
                    i + 1,
                    field_column(line, *yc),
                    format!("the elevation changes by {} m over {} m of distance from the row before; a road's elevation changes by less than the distance travelled (check the units)", y - py, x - px),
                ));
            }
        }
        xs.push(x);
        ys.push(y);
    }
    Ok((xs, ys))
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
        let wide: String = (0..1000).map(|i| format!(",c{i}")).collect();
        let e = parse_signal_file(
            "g.csv",
            &format!("t{wide}\n0{}\n", ",1".repeat(1000)),
            "grade",
        )
        .unwrap_err();
        assert!(e.message.ends_with("found: t, c0, c1, c2, c3, c4, c5, c6, c7, c8, c9, c10, c11, c12, c13, c14, c15, c16, c17, c18 and 981 more"), "{e}");
    }

    #[test]
    fn reads_a_route_profile_in_metres() {
        let ok = parse_signal_file(
            "r.csv",
            "distance_km,elevation_ft\n0,100\n0.5,110\n",
            "grade",
        )
        .unwrap();
        let SignalValue::Route { route, .. } = ok else {
            panic!("a route profile expected, got {ok:?}")
        };
        assert_eq!(route.distance, [0.0, 500.0]);
        assert_eq!(route.elevation, [30.48, 33.528]);
        // A time column makes it a time series: the file needs the signal's column then.
        let e =
            parse_signal_file("r.csv", "t,distance_m,elevation_m\n0,0,1\n", "grade").unwrap_err();
        assert_eq!(e.line, 1, "{e}");
    }
}
