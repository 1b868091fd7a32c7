//! `[maps.NAME]` tables (contract §6): a 1-D or 2-D lookup map with its grid and values inline or from a
//! CSV file next to the model file, its smoothing, extrapolation, interpolation, unit and doc. Every bad map
//! is an error at the offending value (in the model file, or in the CSV file with its own line and column).

use super::error::{ModelError, ModelErrorKind};
use super::keys;
use super::map_csv::{read_csv, Grid};
use super::spanned::Reader;
use super::tree::{get, get_key, key_at, tv_at, Entries, Key, Kind, Tv};
use invsim_expr::map::{Extrapolate, Interp, Map, MapSettings};
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// A map as read and built.
#[derive(Debug, Clone)]
pub(super) struct RawMap {
    pub(super) name: String,
    pub(super) at: Option<usize>,
    /// Argument names for the docs; their number is the arity.
    pub(super) args: Vec<String>,
    pub(super) data: Arc<Map>,
    pub(super) unit: Option<String>,
    pub(super) doc: Option<String>,
    /// The CSV file the values came from, if any.
    pub(super) file: Option<PathBuf>,
}

impl Reader<'_> {
    /// The `[maps]` section: one table per map.
    pub(super) fn maps(&self, v: &Tv) -> Result<Vec<RawMap>, ModelError> {
        let entries = self.table(v, "[maps]")?;
        let mut out = Vec::with_capacity(entries.len());
        for (k, v) in entries {
            out.push(self.map(k, v)?);
        }
        Ok(out)
    }

    fn map(&self, k: &Key, v: &Tv) -> Result<RawMap, ModelError> {
        let what = format!("map `{}`", k.name.escape_debug());
        let t = self.table(v, &what)?;
        self.known_keys(t, keys::MAP, &what)?;
        let at_table = tv_at(v).or(key_at(k));
        let settings = self.map_settings(t, &what)?;
        let args = match get(t, "args") {
            Some(a) => Some(self.map_args(a, &what)?),
            None => None,
        };
        let (grid, file) = match (get_key(t, "file"), get(t, "x")) {
            (Some((fk, f)), None) => {
                if let Some((yk, _)) = get_key(t, "y").or(get_key(t, "values")) {
                    return Err(self.err(
                        key_at(yk),
                        ModelErrorKind::Schema,
                        format!("{what} gives both `file` and inline `{}`; use one of them", yk.name),
                    ));
                }
                let path = self.map_path(f, &what)?;
                let arity = args.as_ref().map(Vec::len);
                let _ = fk;
                (read_csv(&path, arity)?, Some(path))
            }
            (None, Some(_)) => (self.inline_grid(t, &what, at_table)?, None),
            (Some((fk, _)), Some(_)) => {
                return Err(self.err(
                    key_at(fk),
                    ModelErrorKind::Schema,
                    format!("{what} gives both `file` and inline `x`; use one of them"),
                ))
            }
            (None, None) => {
                return Err(self.err(
                    at_table,
                    ModelErrorKind::Schema,
                    format!(
                        "{what} has neither `x` and `values` nor `file`; e.g. {} = {{ x = [0.0, 1.0], values = [1.0, 2.0] }}",
                        k.name
                    ),
                ))
            }
        };
        let arity = if grid.y.is_some() { 2 } else { 1 };
        let args = match args {
            Some(a) if a.len() != arity => {
                return Err(self.err(
                    get(t, "args").and_then(tv_at),
                    ModelErrorKind::Schema,
                    format!("{what} has {} `args` but its data are {arity}-D", a.len()),
                ))
            }
            Some(a) => a,
            None if arity == 1 => vec!["x".to_string()],
            None => vec!["x".to_string(), "y".to_string()],
        };
        let data = match grid.y {
            None => Map::new_1d(grid.x, grid.values, settings),
            Some(y) => Map::new_2d(grid.x, y, grid.values, settings),
        }
        .map_err(|e| self.err(at_table, ModelErrorKind::Schema, format!("{what}: {e}")))?;
        Ok(RawMap {
            name: k.name.clone(),
            at: key_at(k),
            args,
            data: Arc::new(data.named(&k.name)),
            unit: self.optional_string(t, "unit", &what)?,
            doc: self.optional_string(t, "doc", &what)?,
            file,
        })
    }

    fn map_settings(&self, t: &Entries, what: &str) -> Result<MapSettings, ModelError> {
        let mut s = MapSettings::default();
        if let Some(v) = get(t, "smooth") {
            s.smooth = self.number(v, &format!("{what}'s `smooth`"))?;
            if s.smooth <= 0.0 {
                return Err(self.err(
                    tv_at(v),
                    ModelErrorKind::Schema,
                    format!("{what}'s `smooth` must be > 0 (the kernel half-width in grid spacings), found {}", s.smooth),
                ));
            }
        }
        if let Some(v) = get(t, "extrapolate") {
            let name = self.string(v, &format!("{what}'s `extrapolate`"))?;
            s.extrapolate = Extrapolate::from_name(&name).ok_or_else(|| {
                self.err(
                    tv_at(v),
                    ModelErrorKind::Schema,
                    format!(
                        "{what}'s `extrapolate` is `{}`; expected `linear`, `clamp` or `error`",
                        name.escape_debug()
                    ),
                )
            })?;
        }
        if let Some(v) = get(t, "interp") {
            let name = self.string(v, &format!("{what}'s `interp`"))?;
            s.interp = Interp::from_name(&name).ok_or_else(|| {
                self.err(
                    tv_at(v),
                    ModelErrorKind::Schema,
                    format!(
                        "{what}'s `interp` is `{}`; expected `smooth` or `linear`",
                        name.escape_debug()
                    ),
                )
            })?;
        }
        Ok(s)
    }

    fn map_args(&self, v: &Tv, what: &str) -> Result<Vec<String>, ModelError> {
        let items = self.array(v, &format!("{what}'s `args`"))?;
        if !(1..=2).contains(&items.len()) {
            return Err(self.err(
                tv_at(v),
                ModelErrorKind::Schema,
                format!(
                    "{what}'s `args` has {} names; a map takes 1 or 2 arguments",
                    items.len()
                ),
            ));
        }
        items
            .iter()
            .map(|a| self.string(a, &format!("an entry of {what}'s `args`")))
            .collect()
    }

    fn array<'t>(&self, v: &'t Tv, what: &str) -> Result<&'t [Tv], ModelError> {
        match &v.kind {
            Kind::Array(items) => Ok(items),
            k => Err(self.err(
                tv_at(v),
                ModelErrorKind::Schema,
                format!("{what} must be an array, found {}", k.type_name()),
            )),
        }
    }

    /// A strictly increasing grid of at least two finite numbers.
    fn grid(&self, v: &Tv, what: &str) -> Result<Vec<f64>, ModelError> {
        let items = self.array(v, what)?;
        if items.len() < 2 {
            return Err(self.err(
                tv_at(v),
                ModelErrorKind::Schema,
                format!(
                    "{what} has {} point(s); a grid needs at least 2",
                    items.len()
                ),
            ));
        }
        let mut out: Vec<f64> = Vec::with_capacity(items.len());
        for (i, item) in items.iter().enumerate() {
            let x = self.number(item, &format!("entry {} of {what}", i + 1))?;
            if let Some(&prev) = out.last() {
                if x <= prev {
                    return Err(self.err(
                        tv_at(item),
                        ModelErrorKind::Schema,
                        format!(
                            "{what} is not strictly increasing: entry {} ({x}) follows {prev}",
                            i + 1
                        ),
                    ));
                }
            }
            out.push(x);
        }
        Ok(out)
    }

    fn numbers(&self, v: &Tv, len: usize, what: &str) -> Result<Vec<f64>, ModelError> {
        let items = self.array(v, what)?;
        if items.len() != len {
            return Err(self.err(
                tv_at(v),
                ModelErrorKind::Schema,
                format!("{what} has {} values; the grid needs {len}", items.len()),
            ));
        }
        items
            .iter()
            .enumerate()
            .map(|(i, item)| self.number(item, &format!("entry {} of {what}", i + 1)))
            .collect()
    }

    fn inline_grid(&self, t: &Entries, what: &str, at: Option<usize>) -> Result<Grid, ModelError> {
        let Some(x) = get(t, "x") else {
            return Err(self.err(
                at,
                ModelErrorKind::Schema,
                format!("{what} needs `x` (the grid of its first argument) or `file`"),
            ));
        };
        let x = self.grid(x, &format!("{what}'s `x`"))?;
        let Some(values) = get(t, "values") else {
            return Err(self.err(
                at,
                ModelErrorKind::Schema,
                format!("{what} has `x` but no `values`"),
            ));
        };
        let Some(yv) = get(t, "y") else {
            let values = self.numbers(values, x.len(), &format!("{what}'s `values`"))?;
            return Ok(Grid { x, y: None, values });
        };
        let y = self.grid(yv, &format!("{what}'s `y`"))?;
        let rows = self.array(values, &format!("{what}'s `values`"))?;
        if rows.len() != x.len() {
            return Err(self.err(
                tv_at(values),
                ModelErrorKind::Schema,
                format!(
                    "{what}'s `values` has {} rows; a 2-D map needs one per `x` point ({})",
                    rows.len(),
                    x.len()
                ),
            ));
        }
        let mut flat = Vec::with_capacity(x.len() * y.len());
        for (i, row) in rows.iter().enumerate() {
            let row_what = format!("row {} of {what}'s `values`", i + 1);
            flat.extend(self.numbers(row, y.len(), &row_what)?);
        }
        Ok(Grid {
            x,
            y: Some(y),
            values: flat,
        })
    }

    fn map_path(&self, v: &Tv, what: &str) -> Result<PathBuf, ModelError> {
        let name = self.string(v, &format!("{what}'s `file`"))?;
        let base = self.file.parent().unwrap_or(Path::new(""));
        let path = base.join(&name);
        if !path.is_file() {
            return Err(self.err(
                tv_at(v),
                ModelErrorKind::Io,
                format!("{what}'s file `{}` cannot be read: no such file (paths are relative to the model file)", path.display()),
            ));
        }
        Ok(path)
    }
}

/// Is `name` a derivative-map name `M_d<digits>` (or `M_d<digits>_<digits>`, the spelling of orders above 9)
/// of the map `map` (reserved, contract §6)?
fn is_derivative_name(name: &str, map: &str) -> bool {
    let digits = |d: &str| !d.is_empty() && d.bytes().all(|b| b.is_ascii_digit());
    name.strip_prefix(map)
        .and_then(|rest| rest.strip_prefix("_d"))
        .is_some_and(|d| match d.split_once('_') {
            Some((i, j)) => digits(i) && digits(j),
            None => digits(d),
        })
}

impl Reader<'_> {
    /// No declared name (parameter, definition, state, input, output, map) is a derivative-map name
    /// `M_d…` of a declared map `M`.
    pub(super) fn check_derivative_names<'n>(
        &self,
        maps: &[RawMap],
        names: impl Iterator<Item = (&'n str, Option<usize>)>,
    ) -> Result<(), ModelError> {
        for (name, at) in names {
            if let Some(m) = maps.iter().find(|m| is_derivative_name(name, &m.name)) {
                return Err(self.err(
                    at,
                    ModelErrorKind::ReservedName,
                    format!(
                        "reserved name `{name}`: names `{0}_d…` denote the derivative maps of map `{0}` \
                         (e.g. `{0}_d1`, `{0}_d10`); choose another name",
                        m.name
                    ),
                ));
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::is_derivative_name;

    /// Every spelling of [`invsim_expr::map::call_name`] is reserved, the one of orders above 9 too.
    #[test]
    fn derivative_names_are_reserved_in_both_spellings() {
        for name in ["eta_d10", "eta_d3", "eta_d10_0", "eta_d2_11"] {
            assert!(is_derivative_name(name, "eta"), "{name}");
        }
        for name in [
            "eta_d",
            "eta_dx",
            "eta_d1_",
            "eta_d_1",
            "eta2_d10",
            "eta_d1_2_3",
        ] {
            assert!(!is_derivative_name(name, "eta"), "{name}");
        }
    }
}
