//! Drive cycles: the built-in NEDC, ECE-15, EUDC, UDDS, HWFET and WLTC class 3b (with its four phases), and
//! CSV cycle files (interface contract, section 4).
//!
//! A cycle is a speed trace `y_c(t)` given at strictly increasing times and linear between them, as the
//! regulations define it; before the first and after the last sample it is held constant. This is the
//! input `y_c` that the smoother convolves with the paper's kernel (Fröberg & Nielsen 2004, eq. 33–35).

mod builtin;
mod columns;
mod plausibility;
mod printable;
mod tolerance;

pub use builtin::BuiltinCycle;
use builtin::{BUILTINS, BUILTIN_NAMES};
pub(crate) use columns::field_column;
use columns::ExtraColumns;
pub use columns::{BadCell, CycleColumn};
pub use plausibility::{
    Implausible, MAX_PLAUSIBLE_ACCEL_MPS2, MAX_PLAUSIBLE_SPEED_MPS, MS_MEDIAN_STEP,
};
use printable::printable;
pub use tolerance::{Tolerance, ToleranceError, MAX_TOLERANCE_KMH, MAX_TOLERANCE_S};

use std::fmt::Write as _;
use std::io::Read as _;
use std::path::Path;

use crate::numfmt::num;

/// Largest cycle file read by default, bytes (64 MiB: a 1 Hz table of a year is 30 MiB); the file is read
/// through this cap, so an endless file (`/dev/zero`) stops there. [`Cycle::load_with_limit`] raises it (the
/// CLI's `--max-cycle-bytes`).
pub const MAX_CYCLE_BYTES: u64 = 64 << 20;
/// Largest speed a cycle file may hold, m/s (3600 km/h; the land speed record is 341 m/s): a finite but larger
/// value is a unit or typing error and is refused naming its row.
pub const MAX_SPEED_MPS: f64 = 1000.0;
/// Largest magnitude of a time in a cycle file, s (about 3 years).
pub const MAX_TIME_S: f64 = 1e8;
/// Shortest duration of a cycle file, s.
pub const MIN_DURATION_S: f64 = 1e-3;

/// A drive cycle: speed (m/s) against time (s), optionally with road grade (decimal, rise/run).
#[derive(Debug, Clone, PartialEq)]
pub struct Cycle {
    /// Built-in name or the file stem of the CSV file.
    pub name: String,
    /// Sample times in seconds, strictly increasing.
    pub time: Vec<f64>,
    /// Speed in m/s at each sample time, finite and non-negative.
    pub speed: Vec<f64>,
    /// Road grade (decimal) at each sample time, when the file has a grade column.
    pub grade: Option<Vec<f64>>,
    /// The file's other columns by header name, for signals (contract §5); empty for a built-in cycle.
    pub columns: Vec<CycleColumn>,
    /// The speed tolerance its regulation allows ([`Tolerance::EPA`] for UDDS, HWFET and CSV files unless
    /// the user gives another, [`Tolerance::UNECE`] for the NEDC and the WLTC).
    pub tolerance: Tolerance,
}

/// Errors from loading or checking a drive cycle. Every message names the file (or the cycle) and, where it
/// applies, the line in the file (1-based, counting the header and blank lines), the data row (1-based,
/// counting only data rows) and the column, and says what was expected.
#[derive(Debug, thiserror::Error)]
pub enum CycleError {
    /// The file could not be read.
    #[error(
        "cannot read cycle file `{file}`: {source} (expected a CSV file or one of the built-in cycles {})",
        builtin_list()
    )]
    Io {
        file: String,
        #[source]
        source: std::io::Error,
    },
    /// The file is larger than the cap.
    #[error(
        "{file}: the file is larger than {max} bytes, the limit for a cycle file (raise it with \
         --max-cycle-bytes if the file really is a drive cycle)"
    )]
    TooLarge { file: String, max: u64 },
    /// A finite but physically absurd speed or time (`what`: "speed" in m/s or "time" in s; the limits are
    /// [`MAX_SPEED_MPS`] and [`MAX_TIME_S`]).
    #[error(
        "{file}: line {line} (data row {row}), column `{column}`: {what} {} {unit} is beyond the limit of {} \
         {unit}; expected {expected}",
        num(*value), num(bound(what).1), unit = bound(what).2, expected = bound(what).3
    )]
    Absurd {
        file: String,
        line: u64,
        row: usize,
        column: String,
        what: &'static str,
        value: f64,
    },
    /// The cycle lasts (almost) no time.
    #[error(
        "{file}: line {line}: the cycle lasts only {} s (from t = {} s to {} s); expected a duration of at \
         least {} s",
        num(*duration), num(*first), num(*last), num(MIN_DURATION_S)
    )]
    TooShort {
        file: String,
        line: u64,
        duration: f64,
        first: f64,
        last: f64,
    },
    /// The file is not UTF-8 text.
    #[error("{file}: line {line}: not valid UTF-8 text (expected a CSV text file)")]
    NotUtf8 { file: String, line: u64 },
    /// Nothing but white space (or a byte-order mark).
    #[error(
        "{file}: the file is empty (expected a header row such as `time_s,speed_mps` followed by at least \
         two data rows)"
    )]
    Empty { file: String },
    /// The first row holds numbers, not column names.
    #[error(
        "{file}: line {line} looks like data, not a header (expected a header row naming the columns, such \
         as `time_s,speed_mps`)"
    )]
    NoHeader { file: String, line: u64 },
    /// No recognised time column.
    #[error(
        "{file}: line {line}: no time column in the header (found {found}; expected one of `time_s`, \
         `time_seconds`, `cycSecs`, `t`)"
    )]
    NoTimeColumn {
        file: String,
        line: u64,
        found: String,
    },
    /// No recognised speed column.
    #[error(
        "{file}: line {line}: no speed column in the header (found {found}; expected one of `speed_mps`, \
         `mps`, `cycMps`, `speed_meters_per_second` (m/s), `speed_kmh` (km/h), `speed_mph` (mph))"
    )]
    NoSpeedColumn {
        file: String,
        line: u64,
        found: String,
    },
    /// Two columns of the same kind (time, speed or grade).
    #[error(
        "{file}: line {line}: two {kind} columns, `{first}` (column {first_index}) and `{second}` (column \
         {second_index}); expected exactly one"
    )]
    DuplicateColumn {
        file: String,
        line: u64,
        kind: &'static str,
        first: String,
        first_index: usize,
        second: String,
        second_index: usize,
    },
    /// The CSV reader rejected the text.
    #[error("{file}: line {line}: malformed CSV ({message}); expected comma-separated fields")]
    Csv {
        file: String,
        line: u64,
        message: String,
    },
    /// A data row with a different number of fields than the header.
    #[error(
        "{file}: line {line} (data row {row}): {found} field(s), expected {expected} as in the header"
    )]
    Ragged {
        file: String,
        line: u64,
        row: usize,
        found: usize,
        expected: usize,
    },
    /// A field that is not a number.
    #[error("{file}: line {line} (data row {row}), column `{column}`: expected a number, found `{text}`")]
    BadNumber {
        file: String,
        line: u64,
        row: usize,
        column: String,
        text: String,
    },
    /// An infinite or NaN field.
    #[error(
        "{file}: line {line} (data row {row}), column `{column}`: expected a finite number, found `{text}`"
    )]
    NonFinite {
        file: String,
        line: u64,
        row: usize,
        column: String,
        text: String,
    },
    /// A time not greater than the one before it.
    #[error(
        "{file}: line {line} (data row {row}), column `{column}`: time {} s is not after the previous \
         row's {} s; expected strictly increasing times",
        num(*time), num(*previous)
    )]
    TimeNotIncreasing {
        file: String,
        line: u64,
        row: usize,
        column: String,
        time: f64,
        previous: f64,
    },
    /// A negative speed.
    #[error(
        "{file}: line {line} (data row {row}), column `{column}`: speed {} is negative; expected a \
         speed ≥ 0",
        num(*value)
    )]
    NegativeSpeed {
        file: String,
        line: u64,
        row: usize,
        column: String,
        value: f64,
    },
    /// Fewer than two data rows.
    #[error("{file}: {found} data row(s); expected at least 2 (a cycle needs a start and an end)")]
    TooFewRows { file: String, found: usize },
    /// An in-memory cycle that breaks the invariants documented on [`Cycle`].
    #[error("cycle `{name}`: {reason}")]
    Invalid { name: String, reason: String },
}

/// Unit of a recognised speed column.
#[derive(Debug, Clone, Copy, PartialEq)]
enum SpeedUnit {
    MetresPerSecond,
    KilometresPerHour,
    MilesPerHour,
}

impl SpeedUnit {
    fn to_mps(self, v: f64) -> f64 {
        match self {
            SpeedUnit::MetresPerSecond => v,
            SpeedUnit::KilometresPerHour => v / 3.6,
            SpeedUnit::MilesPerHour => v * 0.44704,
        }
    }

    /// The unit's symbol in messages.
    fn symbol(self) -> &'static str {
        match self {
            SpeedUnit::MetresPerSecond => "m/s",
            SpeedUnit::KilometresPerHour => "km/h",
            SpeedUnit::MilesPerHour => "mph",
        }
    }
}

/// Recognised time column names (matched after trimming, ignoring ASCII case).
pub const TIME_COLUMNS: &[&str] = &["time_s", "time_seconds", "cycSecs", "t"];
/// Recognised speed column names in m/s.
pub const SPEED_MPS_COLUMNS: &[&str] = &["speed_mps", "mps", "cycMps", "speed_meters_per_second"];
/// Recognised speed column name in km/h.
pub const SPEED_KMH_COLUMN: &str = "speed_kmh";
/// Recognised speed column name in mph (0.44704 m/s).
pub const SPEED_MPH_COLUMN: &str = "speed_mph";
/// Recognised grade column names (decimal rise/run).
pub const GRADE_COLUMNS: &[&str] = &["grade", "cycGrade"];

fn builtin_list() -> String {
    BUILTIN_NAMES.join(", ")
}

/// ECE-15 urban cycle (UNECE R83 / 70/220/EEC): (time s, speed km/h) waypoints, linear in between.
const ECE15: [(f64, f64); 26] = [
    (0.0, 0.0),
    (11.0, 0.0),
    (15.0, 15.0),
    (23.0, 15.0),
    (25.0, 10.0),
    (28.0, 0.0),
    (49.0, 0.0),
    (54.0, 15.0),
    (56.0, 15.0),
    (61.0, 32.0),
    (85.0, 32.0),
    (93.0, 10.0),
    (96.0, 0.0),
    (117.0, 0.0),
    (122.0, 15.0),
    (124.0, 15.0),
    (133.0, 35.0),
    (135.0, 35.0),
    (143.0, 50.0),
    (155.0, 50.0),
    (163.0, 35.0),
    (176.0, 35.0),
    (178.0, 32.0),
    (185.0, 10.0),
    (188.0, 0.0),
    (195.0, 0.0),
];

/// EUDC extra-urban cycle: (time s, speed km/h) waypoints, linear in between.
const EUDC: [(f64, f64); 22] = [
    (0.0, 0.0),
    (20.0, 0.0),
    (25.0, 15.0),
    (27.0, 15.0),
    (36.0, 35.0),
    (38.0, 35.0),
    (46.0, 50.0),
    (48.0, 50.0),
    (61.0, 70.0),
    (111.0, 70.0),
    (119.0, 50.0),
    (188.0, 50.0),
    (201.0, 70.0),
    (251.0, 70.0),
    (286.0, 100.0),
    (316.0, 100.0),
    (336.0, 120.0),
    (346.0, 120.0),
    (362.0, 80.0),
    (370.0, 50.0),
    (380.0, 0.0),
    (400.0, 0.0),
];

/// Concatenates waypoint lists at the given offsets, converting km/h to m/s and merging a point that
/// repeats the previous one (the end of one part is the start of the next).
fn from_waypoints(name: &str, parts: &[(f64, &[(f64, f64)])]) -> Cycle {
    let mut time: Vec<f64> = Vec::new();
    let mut speed: Vec<f64> = Vec::new();
    for &(offset, points) in parts {
        for &(t, kmh) in points {
            let t = offset + t;
            let v = kmh / 3.6;
            if time.last() == Some(&t) {
                debug_assert_eq!(speed.last(), Some(&v), "waypoints disagree at {t} s");
                continue;
            }
            time.push(t);
            speed.push(v);
        }
    }
    Cycle {
        name: name.to_string(),
        time,
        speed,
        grade: None,
        columns: Vec::new(),
        tolerance: Tolerance::UNECE,
    }
}

impl Cycle {
    /// A built-in cycle by name, ignoring ASCII case: `nedc` (4 × ECE-15 + EUDC, 1180 s), `ece` (one ECE-15,
    /// 195 s), `eudc` (400 s), `udds` (1369 s), `hwfet` (765 s), `wltc3b` (1800 s) or one of its phases
    /// `wltc3b-low`, `wltc3b-medium`, `wltc3b-high`, `wltc3b-extra-high` (which keep the regulation's time:
    /// `wltc3b-medium` runs from 589 s to 1022 s). Speeds in m/s, no grade.
    pub fn builtin(name: &str) -> Option<Cycle> {
        let lower = name.trim().to_ascii_lowercase();
        match lower.as_str() {
            "ece" => Some(from_waypoints("ece", &[(0.0, &ECE15)])),
            "eudc" => Some(from_waypoints("eudc", &[(0.0, &EUDC)])),
            "nedc" => Some(from_waypoints(
                "nedc",
                &[
                    (0.0, &ECE15),
                    (195.0, &ECE15),
                    (390.0, &ECE15),
                    (585.0, &ECE15),
                    (780.0, &EUDC),
                ],
            )),
            other => builtin::tabulated(other).map(|(time, speed)| Cycle {
                name: other.to_string(),
                time,
                speed,
                grade: None,
                columns: Vec::new(),
                tolerance: if other.starts_with("wltc") {
                    Tolerance::UNECE
                } else {
                    Tolerance::EPA
                },
            }),
        }
    }

    /// Names accepted by [`Cycle::builtin`].
    pub fn builtin_names() -> &'static [&'static str] {
        BUILTIN_NAMES
    }

    /// Every built-in cycle with its description, in the order of [`Cycle::builtin_names`].
    pub fn builtins() -> &'static [BuiltinCycle] {
        BUILTINS
    }

    /// Loads a CSV cycle file (section 4 of the contract); the cycle is named after the file stem.
    pub fn from_csv_path(path: &Path) -> Result<Cycle, CycleError> {
        Cycle::from_csv_path_with_limit(path, MAX_CYCLE_BYTES)
    }

    /// [`Cycle::from_csv_path`] reading at most `max_bytes` (a larger file is [`CycleError::TooLarge`]).
    pub fn from_csv_path_with_limit(path: &Path, max_bytes: u64) -> Result<Cycle, CycleError> {
        Cycle::from_csv_path_checked(path, max_bytes).map(|(cycle, _)| cycle)
    }

    /// [`Cycle::from_csv_path_with_limit`] with the file's plausibility warnings ([`Implausible`]: a top
    /// speed, accelerations or time steps that do not fit the declared units).
    pub fn from_csv_path_checked(
        path: &Path,
        max_bytes: u64,
    ) -> Result<(Cycle, Vec<Implausible>), CycleError> {
        let file = path.display().to_string();
        let io = |source| CycleError::Io {
            file: file.clone(),
            source,
        };
        let mut bytes = Vec::new();
        std::fs::File::open(path)
            .map_err(io)?
            .take(max_bytes.saturating_add(1))
            .read_to_end(&mut bytes)
            .map_err(io)?;
        if bytes.len() as u64 > max_bytes {
            return Err(CycleError::TooLarge {
                file,
                max: max_bytes,
            });
        }
        let text = std::str::from_utf8(&bytes).map_err(|e| CycleError::NotUtf8 {
            file: file.clone(),
            line: 1 + bytes[..e.valid_up_to()]
                .iter()
                .filter(|&&b| b == b'\n')
                .count() as u64,
        })?;
        let name = path
            .file_stem()
            .map_or_else(|| "cycle".to_string(), |s| s.to_string_lossy().into_owned());
        parse_csv(name, &file, text)
    }

    /// Parses CSV text; `name` is both the cycle's name and the file name used in error messages.
    ///
    /// The first non-blank row is the header (an optional UTF-8 byte-order mark is skipped; names are trimmed
    /// and matched ignoring ASCII case). Recognised columns: time `time_s`, `time_seconds`, `cycSecs`, `t`;
    /// speed `speed_mps`, `mps`, `cycMps`, `speed_meters_per_second` (m/s), `speed_kmh` (km/h), `speed_mph`
    /// (mph); optional grade `grade`, `cycGrade`. Other columns are kept by name in [`Cycle::columns`] for
    /// signals and checked only when a signal reads them; blank lines skipped. Every data row must have as
    /// many fields as the header.
    pub fn from_csv_str(name: &str, text: &str) -> Result<Cycle, CycleError> {
        Cycle::from_csv_str_checked(name, text).map(|(cycle, _)| cycle)
    }

    /// [`Cycle::from_csv_str`] with the text's plausibility warnings ([`Implausible`]).
    pub fn from_csv_str_checked(
        name: &str,
        text: &str,
    ) -> Result<(Cycle, Vec<Implausible>), CycleError> {
        parse_csv(name.to_string(), name, text)
    }

    /// A built-in cycle name (see [`Cycle::builtin`]) or else a path to a CSV cycle file. A built-in name
    /// wins over a file of the same name in the working directory; write `./nedc` for the file.
    pub fn load(spec: &str) -> Result<Cycle, CycleError> {
        Cycle::load_with_limit(spec, MAX_CYCLE_BYTES)
    }

    /// [`Cycle::load`] reading a cycle file of at most `max_bytes`.
    pub fn load_with_limit(spec: &str, max_bytes: u64) -> Result<Cycle, CycleError> {
        Cycle::load_checked(spec, max_bytes).map(|(cycle, _)| cycle)
    }

    /// [`Cycle::load_with_limit`] with a cycle file's plausibility warnings ([`Implausible`]; a built-in
    /// cycle has none).
    pub fn load_checked(
        spec: &str,
        max_bytes: u64,
    ) -> Result<(Cycle, Vec<Implausible>), CycleError> {
        match Cycle::builtin(spec) {
            Some(cycle) => Ok((cycle, Vec::new())),
            None => Cycle::from_csv_path_checked(Path::new(spec), max_bytes),
        }
    }

    /// Checks the invariants documented on the fields: at least two samples, equal lengths, finite strictly
    /// increasing times, finite non-negative speeds, finite grades. Cycles from the constructors above
    /// always pass; use this for cycles built by hand.
    pub fn validate(&self) -> Result<(), CycleError> {
        let invalid = |reason: String| CycleError::Invalid {
            name: self.name.clone(),
            reason,
        };
        if self.time.len() != self.speed.len() {
            return Err(invalid(format!(
                "{} times but {} speeds; expected one speed per time",
                self.time.len(),
                self.speed.len()
            )));
        }
        if let Some(grade) = &self.grade {
            if grade.len() != self.time.len() {
                return Err(invalid(format!(
                    "{} times but {} grades; expected one grade per time",
                    self.time.len(),
                    grade.len()
                )));
            }
            if let Some(i) = grade.iter().position(|g| !g.is_finite()) {
                return Err(invalid(format!(
                    "grade {} at sample {i} is not finite",
                    grade[i]
                )));
            }
        }
        if self.time.len() < 2 {
            return Err(invalid(format!(
                "{} sample(s); expected at least 2",
                self.time.len()
            )));
        }
        if self.samples_valid() {
            return Ok(());
        }
        for (i, (&t, &v)) in self.time.iter().zip(&self.speed).enumerate() {
            if !t.is_finite() {
                return Err(invalid(format!(
                    "time {} at sample {i} is not finite",
                    num(t)
                )));
            }
            if !v.is_finite() || v < 0.0 {
                return Err(invalid(format!(
                    "speed {} at sample {i}; expected a finite speed ≥ 0",
                    num(v)
                )));
            }
            if i > 0 && t <= self.time[i - 1] {
                return Err(invalid(format!(
                    "time {} at sample {i} is not after {}; expected strictly increasing times",
                    num(t),
                    num(self.time[i - 1])
                )));
            }
        }
        Ok(())
    }

    /// Whether every time is finite and after the one before and every speed finite and ≥ 0: the checks of
    /// [`Cycle::validate`]'s loop in one pass without early exits (the compiler vectorises it), the loop
    /// then only runs to name the first bad sample.
    fn samples_valid(&self) -> bool {
        let finite = |ok: bool, x: &f64| ok & x.is_finite();
        let times = self.time.iter().fold(true, finite);
        let increasing = self.time.windows(2).fold(true, |ok, w| ok & (w[1] > w[0]));
        let speeds = self
            .speed
            .iter()
            .fold(true, |ok, &v| ok & (v.is_finite() & (v >= 0.0)));
        times & increasing & speeds
    }

    /// Last time minus first time, in seconds (0 for an empty cycle).
    pub fn duration(&self) -> f64 {
        match (self.time.first(), self.time.last()) {
            (Some(first), Some(last)) => last - first,
            _ => 0.0,
        }
    }

    /// Distance in metres: the exact integral of the piecewise-linear speed (trapezoidal rule).
    pub fn distance(&self) -> f64 {
        self.time
            .windows(2)
            .zip(self.speed.windows(2))
            .map(|(t, v)| 0.5 * (v[0] + v[1]) * (t[1] - t[0]))
            .sum()
    }

    /// Highest speed in m/s (0 for an empty cycle).
    pub fn max_speed(&self) -> f64 {
        self.speed.iter().copied().fold(0.0, f64::max)
    }

    /// Speed at time `t` (m/s): linear between samples, held at the first/last value outside the cycle.
    /// NaN for NaN or for an empty cycle.
    pub fn speed_at(&self, t: f64) -> f64 {
        interpolate(&self.time, &self.speed, t)
    }

    /// Grade at time `t`, interpolated like [`Cycle::speed_at`]; 0 when the cycle has no grade.
    pub fn grade_at(&self, t: f64) -> f64 {
        match &self.grade {
            Some(grade) => interpolate(&self.time, grade, t),
            None => 0.0,
        }
    }
}

/// Piecewise-linear interpolation of `values` over strictly increasing `time`, held constant outside.
fn interpolate(time: &[f64], values: &[f64], t: f64) -> f64 {
    let n = time.len().min(values.len());
    if n == 0 || t.is_nan() {
        return f64::NAN;
    }
    let i = time[..n].partition_point(|&x| x <= t);
    if i == 0 {
        values[0]
    } else if i == n {
        values[n - 1]
    } else {
        let (t0, t1) = (time[i - 1], time[i]);
        let (v0, v1) = (values[i - 1], values[i]);
        v0 + (v1 - v0) * ((t - t0) / (t1 - t0))
    }
}

/// Which recognised column a header field is.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Role {
    Time,
    Speed(SpeedUnit),
    Grade,
}

fn role_of(name: &str) -> Option<Role> {
    let is = |candidates: &[&str]| candidates.iter().any(|c| c.eq_ignore_ascii_case(name));
    if is(TIME_COLUMNS) {
        Some(Role::Time)
    } else if is(SPEED_MPS_COLUMNS) {
        Some(Role::Speed(SpeedUnit::MetresPerSecond))
    } else if name.eq_ignore_ascii_case(SPEED_KMH_COLUMN) {
        Some(Role::Speed(SpeedUnit::KilometresPerHour))
    } else if name.eq_ignore_ascii_case(SPEED_MPH_COLUMN) {
        Some(Role::Speed(SpeedUnit::MilesPerHour))
    } else if is(GRADE_COLUMNS) {
        Some(Role::Grade)
    } else {
        None
    }
}

/// A chosen column: index in the record and its trimmed header name.
struct Column {
    index: usize,
    name: String,
}

/// 1-based line numbers of CSV records in a text.
struct Lines<'a> {
    text: &'a str,
    newlines: Vec<usize>,
}

impl<'a> Lines<'a> {
    fn new(text: &'a str) -> Self {
        Lines {
            text,
            newlines: text.match_indices('\n').map(|(i, _)| i).collect(),
        }
    }

    /// The line of the record starting at `byte`. The reader reports where a record's text begins *including*
    /// preceding blank lines, so skip line breaks from that byte offset and count the newlines before it.
    fn at(&self, byte: usize) -> u64 {
        let skipped = self.text.as_bytes().get(byte..).map_or(0, |rest| {
            rest.iter()
                .take_while(|&&b| b == b'\n' || b == b'\r')
                .count()
        });
        1 + self.newlines.partition_point(|&i| i < byte + skipped) as u64
    }

    /// The text of 1-based `line` (without its line break).
    fn text_of(&self, line: u64) -> &'a str {
        let i = line.saturating_sub(1) as usize;
        let start = if i == 0 {
            0
        } else {
            self.newlines.get(i - 1).map_or(self.text.len(), |&n| n + 1)
        };
        let end = self.newlines.get(i).copied().unwrap_or(self.text.len());
        self.text
            .get(start..end.max(start))
            .unwrap_or("")
            .trim_end_matches('\r')
    }

    fn of(&self, r: &csv::StringRecord) -> u64 {
        r.position().map_or(0, |p| self.at(p.byte() as usize))
    }

    fn csv_error(&self, file: &str, e: csv::Error) -> CycleError {
        CycleError::Csv {
            file: file.to_string(),
            line: e.position().map_or(0, |p| self.at(p.byte() as usize)),
            message: e.to_string(),
        }
    }
}

/// A blank (or white-space-only) line; a row of empty fields such as `,,` is not blank but malformed.
fn is_blank(r: &csv::StringRecord) -> bool {
    r.len() <= 1 && r.iter().all(|f| f.trim().is_empty())
}

/// The recognised columns of a header.
struct Columns {
    time: Column,
    speed: Column,
    unit: SpeedUnit,
    grade: Option<Column>,
    /// Indices of the fields with no role (kept for signals, `cycle/columns.rs`).
    extra: Vec<usize>,
    /// Number of fields of the header (every row must have as many).
    width: usize,
}

/// Most header names a message lists (a header of 10⁵ names would make a message of megabytes).
const LISTED_NAMES: usize = 20;

/// The header's trimmed names, each as `` `name` `` (control characters escaped, at most 40 characters),
/// comma-separated, the first [`LISTED_NAMES`] and how many more (for messages).
fn list_names(names: &[String]) -> String {
    let mut s = String::new();
    for (i, n) in names.iter().take(LISTED_NAMES).enumerate() {
        if i > 0 {
            s.push_str(", ");
        }
        let _ = write!(s, "`{}`", printable(n));
    }
    if names.len() > LISTED_NAMES {
        let _ = write!(s, " and {} more", names.len() - LISTED_NAMES);
    }
    if s.is_empty() {
        s.push_str("no names");
    }
    s
}

/// Picks the time, speed and grade columns of the header at `line`; two columns of one kind are an error.
fn choose_columns(file: &str, line: u64, names: &[String]) -> Result<Columns, CycleError> {
    if names
        .iter()
        .all(|n| n.is_empty() || n.parse::<f64>().is_ok())
    {
        return Err(CycleError::NoHeader {
            file: file.to_string(),
            line,
        });
    }
    let mut time_col: Option<Column> = None;
    let mut speed_col: Option<(Column, SpeedUnit)> = None;
    let mut grade_col: Option<Column> = None;
    let mut extra = Vec::new();
    for (index, n) in names.iter().enumerate() {
        let Some(role) = role_of(n) else {
            extra.push(index);
            continue;
        };
        let (slot_name, kind) = match role {
            Role::Time => (time_col.as_ref().map(|c| (c.index, &c.name)), "time"),
            Role::Speed(_) => (speed_col.as_ref().map(|(c, _)| (c.index, &c.name)), "speed"),
            Role::Grade => (grade_col.as_ref().map(|c| (c.index, &c.name)), "grade"),
        };
        if let Some((first_index, first)) = slot_name {
            return Err(CycleError::DuplicateColumn {
                file: file.to_string(),
                line,
                kind,
                first: first.clone(),
                first_index: first_index + 1,
                second: n.clone(),
                second_index: index + 1,
            });
        }
        let column = Column {
            index,
            name: n.clone(),
        };
        match role {
            Role::Time => time_col = Some(column),
            Role::Speed(unit) => speed_col = Some((column, unit)),
            Role::Grade => grade_col = Some(column),
        }
    }
    let Some(time) = time_col else {
        return Err(CycleError::NoTimeColumn {
            file: file.to_string(),
            line,
            found: list_names(names),
        });
    };
    let Some((speed, unit)) = speed_col else {
        return Err(CycleError::NoSpeedColumn {
            file: file.to_string(),
            line,
            found: list_names(names),
        });
    };
    Ok(Columns {
        time,
        speed,
        unit,
        grade: grade_col,
        extra,
        width: names.len(),
    })
}

/// Where a data row is: for messages.
struct RowAt<'a> {
    file: &'a str,
    line: u64,
    row: usize,
}

impl RowAt<'_> {
    /// The finite number in `col` of `record`.
    fn number(&self, record: &csv::StringRecord, col: &Column) -> Result<f64, CycleError> {
        let text = record.get(col.index).unwrap_or("").trim();
        let value: f64 = text.parse().map_err(|_| CycleError::BadNumber {
            file: self.file.to_string(),
            line: self.line,
            row: self.row,
            column: printable(&col.name),
            text: printable(text),
        })?;
        if value.is_finite() {
            Ok(value)
        } else {
            Err(CycleError::NonFinite {
                file: self.file.to_string(),
                line: self.line,
                row: self.row,
                column: printable(&col.name),
                text: printable(text),
            })
        }
    }

    /// `Err(Absurd)` for a finite `value` of `col` beyond the bound of `what` in magnitude.
    fn bounded(&self, col: &Column, value: f64, what: &'static str) -> Result<(), CycleError> {
        if value.abs() <= bound(what).1 {
            return Ok(());
        }
        Err(CycleError::Absurd {
            file: self.file.to_string(),
            line: self.line,
            row: self.row,
            column: printable(&col.name),
            what,
            value,
        })
    }
}

/// A physical bound: what, the largest magnitude, its unit, what is expected.
type Bound = (&'static str, f64, &'static str, &'static str);

/// The bound of a time ("time") or a speed ("speed", after the conversion to m/s) in a cycle file.
fn bound(what: &str) -> Bound {
    if what == "time" {
        ("time", MAX_TIME_S, "s", "a time in seconds")
    } else {
        (
            "speed",
            MAX_SPEED_MPS,
            "m/s",
            "a vehicle's speed (check the column's unit)",
        )
    }
}

/// The samples read so far.
struct Samples {
    time: Vec<f64>,
    speed: Vec<f64>,
    grade: Option<Vec<f64>>,
    extra: ExtraColumns,
    /// The 1-based line of each sample (for the plausibility warnings).
    lines: Vec<u64>,
}

impl Samples {
    /// Checks and appends one data row.
    fn push(
        &mut self,
        at: &RowAt,
        record: &csv::StringRecord,
        cols: &Columns,
    ) -> Result<(), CycleError> {
        if record.len() != cols.width {
            return Err(CycleError::Ragged {
                file: at.file.to_string(),
                line: at.line,
                row: at.row,
                found: record.len(),
                expected: cols.width,
            });
        }
        let t = at.number(record, &cols.time)?;
        at.bounded(&cols.time, t, "time")?;
        let v = at.number(record, &cols.speed)?;
        at.bounded(&cols.speed, cols.unit.to_mps(v), "speed")?;
        let g = cols
            .grade
            .as_ref()
            .map(|c| at.number(record, c))
            .transpose()?;
        if let Some(&previous) = self.time.last() {
            if t <= previous {
                return Err(CycleError::TimeNotIncreasing {
                    file: at.file.to_string(),
                    line: at.line,
                    row: at.row,
                    column: cols.time.name.clone(),
                    time: t,
                    previous,
                });
            }
        }
        if v < 0.0 {
            return Err(CycleError::NegativeSpeed {
                file: at.file.to_string(),
                line: at.line,
                row: at.row,
                column: cols.speed.name.clone(),
                value: v,
            });
        }
        self.time.push(t);
        self.speed.push(cols.unit.to_mps(v));
        self.lines.push(at.line);
        if let (Some(grades), Some(g)) = (self.grade.as_mut(), g) {
            grades.push(g);
        }
        Ok(())
    }
}

fn parse_csv(
    name: String,
    file: &str,
    text: &str,
) -> Result<(Cycle, Vec<Implausible>), CycleError> {
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    let mut reader = csv::ReaderBuilder::new()
        .has_headers(false)
        .flexible(true)
        .from_reader(text.as_bytes());
    let mut records = reader.records();
    let lines = Lines::new(text);

    // Header: the first non-blank record.
    let header = loop {
        match records.next() {
            None => {
                return Err(CycleError::Empty {
                    file: file.to_string(),
                })
            }
            Some(Err(e)) => return Err(lines.csv_error(file, e)),
            Some(Ok(r)) if is_blank(&r) => continue,
            Some(Ok(r)) => break r,
        }
    };
    let names: Vec<String> = header.iter().map(|f| f.trim().to_string()).collect();
    let cols = choose_columns(file, lines.of(&header), &names)?;

    let mut samples = Samples {
        time: Vec::new(),
        speed: Vec::new(),
        grade: cols.grade.as_ref().map(|_| Vec::new()),
        extra: ExtraColumns::new(&names, cols.extra.iter().copied()),
        lines: Vec::new(),
    };
    let (mut row, mut last_line) = (0usize, 0u64);
    for record in records {
        let record = record.map_err(|e| lines.csv_error(file, e))?;
        if is_blank(&record) {
            continue;
        }
        row += 1;
        let at = RowAt {
            file,
            line: lines.of(&record),
            row,
        };
        last_line = at.line;
        samples.push(&at, &record, &cols)?;
        samples
            .extra
            .push(&record, (file, at.line, lines.text_of(at.line)));
    }
    if samples.time.len() < 2 {
        return Err(CycleError::TooFewRows {
            file: file.to_string(),
            found: samples.time.len(),
        });
    }
    let (first, last) = (samples.time[0], samples.time[samples.time.len() - 1]);
    if last - first < MIN_DURATION_S {
        return Err(CycleError::TooShort {
            file: file.to_string(),
            line: last_line,
            duration: last - first,
            first,
            last,
        });
    }
    let warnings = plausibility::check(
        &plausibility::Source {
            file,
            time_column: &printable(&cols.time.name),
            speed_column: &printable(&cols.speed.name),
            unit: cols.unit.symbol(),
            lines: &samples.lines,
        },
        &samples.time,
        &samples.speed,
    );
    let cycle = Cycle {
        name,
        time: samples.time,
        speed: samples.speed,
        grade: samples.grade,
        columns: samples.extra.finish(),
        tolerance: Tolerance::EPA,
    };
    Ok((cycle, warnings))
}
