//! The `[gearbox]` table of a model with modes: the parameters each gear sets (arrays, one value per gear)
//! and the schedule (up- and downshift speeds with hysteresis, the regulation's prescription, or a column of
//! the cycle file), each array element checked at its own line and column.

use super::error::{ModelError, ModelErrorKind};
use super::keys;
use super::modal::{Gearbox, Schedule};
use super::spanned::Reader;
use super::tree::{get, key_at, tv_at, Entries, Kind, Tv};

/// Each gearbox parameter's name and its value per gear.
type GearParameters = Vec<(String, Vec<f64>)>;

/// Largest number of gears.
pub const MAX_GEARS: usize = 32;

impl Reader<'_> {
    /// An array of finite numbers with the file offset of each element.
    pub(super) fn number_array(
        &self,
        v: &Tv,
        what: &str,
    ) -> Result<Vec<(f64, Option<usize>)>, ModelError> {
        let at = tv_at(v);
        let bad = |m: String| self.err(at, ModelErrorKind::Schema, m);
        if !matches!(v.kind, Kind::Array(_)) {
            return Err(bad(format!(
                "{what} must be an array of numbers, found {}",
                v.kind.type_name()
            )));
        }
        let Some(span) = v.span.clone() else {
            return Err(bad(format!(
                "{what}: the array's position is unknown; write it inline, `[1.0, 2.0]`"
            )));
        };
        let slice = self.text.get(span.clone()).unwrap_or("");
        let parsed: toml::Table = toml::from_str(&format!("a = {slice}"))
            .map_err(|_| bad(format!("{what} must be an array of numbers")))?;
        let Some(toml::Value::Array(items)) = parsed.get("a") else {
            return Err(bad(format!("{what} must be an array of numbers")));
        };
        let offsets = element_offsets(slice);
        let mut out = Vec::new();
        for (i, item) in items.iter().enumerate() {
            let pos = offsets.get(i).map(|o| span.start + o).or(at);
            let x = match item {
                toml::Value::Integer(n) => *n as f64,
                toml::Value::Float(x) => *x,
                other => {
                    return Err(self.err(
                        pos,
                        ModelErrorKind::Schema,
                        format!(
                            "{what}: element {} must be a number, found a {}",
                            i + 1,
                            other.type_str()
                        ),
                    ))
                }
            };
            if !x.is_finite() {
                return Err(self.err(
                    pos,
                    ModelErrorKind::NonFinite,
                    format!("{what}: element {} is not finite", i + 1),
                ));
            }
            out.push((x, pos));
        }
        Ok(out)
    }

    pub(super) fn gearbox(&self, v: &Tv) -> Result<Gearbox, ModelError> {
        let t = self.table(v, "[gearbox]")?;
        self.known_keys(t, keys::GEARBOX, "[gearbox]")?;
        let Some(ps) = get(t, "parameters") else {
            return Err(self.err(
                tv_at(v),
                ModelErrorKind::Schema,
                "[gearbox] needs `parameters = { i_g = [3.6, 2.1, 1.4, 1.0, 0.8] }` (each parameter's value per gear)",
            ));
        };
        let (gears, parameters) =
            self.gear_parameters(self.table(ps, "[gearbox] parameters")?, ps)?;
        let kind = get(t, "schedule")
            .map(|s| Ok::<_, ModelError>((self.string(s, "[gearbox] `schedule`")?, tv_at(s))))
            .transpose()?;
        let schedule = match kind.as_ref().map(|(s, a)| (s.as_str(), *a)) {
            None | Some(("speed", _)) => self.speed_schedule(t, v, gears)?,
            Some(("regulation", a)) => {
                if gears != 5 {
                    return Err(self.err(
                        a,
                        ModelErrorKind::Schema,
                        format!("the regulation's gear prescription is for a 5-speed manual gearbox; this one has {gears} gears"),
                    ));
                }
                Schedule::Regulation
            }
            Some(("cycle", _)) => Schedule::Column(
                get(t, "column")
                    .map(|c| self.string(c, "[gearbox] `column`"))
                    .transpose()?
                    .unwrap_or_else(|| "gear".to_string()),
            ),
            Some((other, a)) => {
                return Err(self.err(
                    a,
                    ModelErrorKind::Schema,
                    format!(
                        "unknown [gearbox] schedule `{}`; expected speed, regulation or cycle",
                        other.escape_debug()
                    ),
                ))
            }
        };
        Ok(Gearbox {
            gears,
            parameters,
            schedule,
        })
    }

    fn gear_parameters(
        &self,
        entries: &Entries,
        at: &Tv,
    ) -> Result<(usize, GearParameters), ModelError> {
        let mut gears = None;
        let mut out = Vec::new();
        for (k, v) in entries {
            let what = format!("[gearbox] parameter `{}`", k.name.escape_debug());
            let values = self.number_array(v, &what)?;
            if values.is_empty() || values.len() > MAX_GEARS {
                return Err(self.err(
                    tv_at(v),
                    ModelErrorKind::Schema,
                    format!(
                        "{what} has {} values; a gearbox has 1 to {MAX_GEARS} gears",
                        values.len()
                    ),
                ));
            }
            match gears {
                None => gears = Some(values.len()),
                Some(n) if n != values.len() => {
                    return Err(self.err(
                        tv_at(v),
                        ModelErrorKind::Schema,
                        format!("{what} has {} values, the gearbox's first parameter {n}: one value per gear", values.len()),
                    ))
                }
                Some(_) => {}
            }
            let _ = key_at(k);
            out.push((k.name.clone(), values.into_iter().map(|(x, _)| x).collect()));
        }
        match gears {
            Some(n) => Ok((n, out)),
            None => Err(self.err(
                tv_at(at),
                ModelErrorKind::Schema,
                "[gearbox] parameters is empty",
            )),
        }
    }

    /// Up- and downshift speeds: N − 1 each, strictly increasing, each band down < up, bands not overlapping.
    fn speed_schedule(&self, t: &Entries, v: &Tv, gears: usize) -> Result<Schedule, ModelError> {
        if gears == 1 {
            return Ok(Schedule::Speed {
                up: Vec::new(),
                down: Vec::new(),
            });
        }
        let need = |k: &str| {
            get(t, k).ok_or_else(|| {
                self.err(
                    tv_at(v),
                    ModelErrorKind::Schema,
                    format!("[gearbox] with the speed schedule needs `{k}` ({} speeds in m/s, one per shift)", gears - 1),
                )
            })
        };
        let up = self.number_array(need("upshift")?, "[gearbox] `upshift`")?;
        let down = self.number_array(need("downshift")?, "[gearbox] `downshift`")?;
        for (arr, name, tv) in [
            (&up, "upshift", need("upshift")?),
            (&down, "downshift", need("downshift")?),
        ] {
            if arr.len() != gears - 1 {
                return Err(self.err(
                    tv_at(tv),
                    ModelErrorKind::Schema,
                    format!(
                        "[gearbox] `{name}` has {} speeds; {gears} gears need {}",
                        arr.len(),
                        gears - 1
                    ),
                ));
            }
            for w in arr.windows(2) {
                if w[1].0 <= w[0].0 {
                    return Err(self.err(
                        w[1].1,
                        ModelErrorKind::Schema,
                        format!(
                            "[gearbox] `{name}` is not monotone: {} follows {}; the shift speeds must increase strictly with the gear",
                            w[1].0, w[0].0
                        ),
                    ));
                }
            }
        }
        for b in 0..gears - 1 {
            if down[b].0 >= up[b].0 {
                return Err(self.err(
                    down[b].1,
                    ModelErrorKind::Schema,
                    format!(
                        "[gearbox] downshift {} → {} at {} m/s is not below the upshift {} → {} at {} m/s: the hysteresis band is empty",
                        b + 2, b + 1, down[b].0, b + 1, b + 2, up[b].0
                    ),
                ));
            }
            if b + 1 < gears - 1 && up[b].0 > down[b + 1].0 {
                return Err(self.err(
                    down[b + 1].1,
                    ModelErrorKind::Schema,
                    format!(
                        "[gearbox] hysteresis bands overlap: the band of shift {}↔{} [{}, {}] m/s reaches into that of shift {}↔{} [{}, {}] m/s",
                        b + 1, b + 2, down[b].0, up[b].0, b + 2, b + 3, down[b + 1].0, up[b + 1].0
                    ),
                ));
            }
        }
        let strip = |a: Vec<(f64, Option<usize>)>| a.into_iter().map(|(x, _)| x).collect();
        Ok(Schedule::Speed {
            up: strip(up),
            down: strip(down),
        })
    }
}

/// Byte offsets (in the array's text) of each top-level element.
fn element_offsets(slice: &str) -> Vec<usize> {
    let b = slice.as_bytes();
    let mut out = Vec::new();
    let (mut depth, mut i) = (0usize, 0usize);
    let mut expecting = false;
    while i < b.len() {
        match b[i] {
            b'[' => {
                depth += 1;
                if depth == 1 {
                    expecting = true;
                } else if depth == 2 && expecting {
                    out.push(i);
                    expecting = false;
                }
            }
            b']' => depth = depth.saturating_sub(1),
            b',' if depth == 1 => expecting = true,
            b'#' => {
                while i < b.len() && b[i] != b'\n' {
                    i += 1;
                }
            }
            c if c.is_ascii_whitespace() => {}
            _ if depth == 1 && expecting => {
                out.push(i);
                expecting = false;
            }
            _ => {}
        }
        i += 1;
    }
    out
}

#[cfg(test)]
mod tests {
    #[test]
    fn offsets_of_elements() {
        assert_eq!(
            super::element_offsets("[1.0, 2,\n # c\n 3]"),
            vec![1, 6, 15]
        );
    }
}
