//! The `[hybrid]` table of a model with modes (docs/hybrids.md): what an energy-management strategy weighs —
//! the fuel's and the battery's chemical power (two `[outputs]` entries), the charge state it keeps (a state),
//! the modes in which the engine runs (for the start penalty and the count of starts), the start penalty and
//! the grid over the decided inputs. The table needs at least one mode that decides an input.

use super::error::{ModelError, ModelErrorKind};
use super::keys;
use super::modal::HybridSpec;
use super::modes::RawMode;
use super::spanned::Reader;
use super::tree::{get, key_at, tv_at, Key, Kind, Tv};
use super::validated::Model;
use invsim_model_api::RuleSpec;

/// Largest grid over a decided input (the strategy evaluates every point at every sample).
pub const MAX_HYBRID_GRID: usize = 1001;

impl Reader<'_> {
    /// `[hybrid]`, its names checked against the modes and, where it was built, a mode's model.
    pub(super) fn hybrid(
        &self,
        k: &Key,
        v: &Tv,
        raws: &[RawMode<'_>],
        model: Option<&Model>,
    ) -> Result<HybridSpec, ModelError> {
        let t = self.table(v, "[hybrid]")?;
        self.known_keys(t, keys::HYBRID, "[hybrid]")?;
        if !raws.iter().any(|r| !r.decided.is_empty()) {
            return Err(self.err(
                key_at(k),
                ModelErrorKind::Schema,
                "[hybrid] but no mode decides an input: name the split in a mode, e.g. decided = [\"T_m\"]",
            ));
        }
        let name = |key: &str| -> Result<(String, Option<usize>), ModelError> {
            let v = get(t, key).ok_or_else(|| {
                self.err(
                    key_at(k),
                    ModelErrorKind::Schema,
                    format!("[hybrid] needs `{key}`"),
                )
            })?;
            Ok((self.string(v, &format!("[hybrid] `{key}`"))?, tv_at(v)))
        };
        let (fuel_power, fuel_at) = name("fuel_power")?;
        let (battery_power, battery_at) = name("battery_power")?;
        let (soc, soc_at) = name("soc")?;
        if let Some(m) = model {
            for (n, at) in [(&fuel_power, fuel_at), (&battery_power, battery_at)] {
                if !m.outputs.iter().any(|o| &o.name == n) {
                    return Err(self.err(
                        at,
                        ModelErrorKind::UnknownName,
                        format!(
                            "[hybrid] names `{}`, which is not an [outputs] entry",
                            n.escape_debug()
                        ),
                    ));
                }
            }
            if !m.states.iter().any(|s| s.name == soc) {
                return Err(self.err(
                    soc_at,
                    ModelErrorKind::UnknownName,
                    format!("[hybrid] `soc = \"{}\"` is not a state", soc.escape_debug()),
                ));
            }
        }
        let engine_on = self.engine_on(t, raws)?;
        let start_penalty = match get(t, "start_penalty") {
            Some(x) => {
                let p = self.number(x, "[hybrid] `start_penalty`")?;
                if p < 0.0 {
                    return Err(self.err(
                        tv_at(x),
                        ModelErrorKind::Schema,
                        format!("[hybrid] `start_penalty` must be ≥ 0 J, found {p}"),
                    ));
                }
                p
            }
            None => 0.0,
        };
        let grid = match get(t, "grid") {
            Some(x) => {
                let g = self.number(x, "[hybrid] `grid`")?;
                if !(g.fract() == 0.0 && (3.0..=MAX_HYBRID_GRID as f64).contains(&g)) {
                    return Err(self.err(
                        tv_at(x),
                        ModelErrorKind::Schema,
                        format!("[hybrid] `grid` must be a whole number from 3 to {MAX_HYBRID_GRID}, found {g}"),
                    ));
                }
                g as usize
            }
            None => 11,
        };
        let rules = self.rules(k, t, model)?;
        Ok(HybridSpec {
            fuel_power,
            battery_power,
            soc,
            engine_on,
            start_penalty,
            grid,
            rules,
        })
    }

    /// `rule_request` and `rule_target` (both or neither: `[outputs]` names) and `rule_min_on` (s, ≥ 0,
    /// default 0): the model's own rules for `--strategy rule-based`.
    fn rules(
        &self,
        k: &Key,
        t: &[(Key, Tv)],
        model: Option<&Model>,
    ) -> Result<Option<RuleSpec>, ModelError> {
        let (request, target) = match (get(t, "rule_request"), get(t, "rule_target")) {
            (None, None) => {
                if get(t, "rule_min_on").is_some() {
                    return Err(self.err(
                        key_at(k),
                        ModelErrorKind::Schema,
                        "[hybrid] `rule_min_on` needs `rule_request` and `rule_target`",
                    ));
                }
                return Ok(None);
            }
            (Some(r), Some(g)) => (r, g),
            _ => {
                return Err(self.err(
                    key_at(k),
                    ModelErrorKind::Schema,
                    "[hybrid] needs both `rule_request` and `rule_target`, or neither",
                ));
            }
        };
        let mut names = Vec::new();
        for (v, key) in [(request, "rule_request"), (target, "rule_target")] {
            let n = self.string(v, &format!("[hybrid] `{key}`"))?;
            if let Some(m) = model {
                if !m.outputs.iter().any(|o| o.name == n) {
                    return Err(self.err(
                        tv_at(v),
                        ModelErrorKind::UnknownName,
                        format!(
                            "[hybrid] `{key}` names `{}`, which is not an [outputs] entry",
                            n.escape_debug()
                        ),
                    ));
                }
            }
            names.push(n);
        }
        let min_on = match get(t, "rule_min_on") {
            Some(x) => {
                let s = self.number(x, "[hybrid] `rule_min_on`")?;
                if !(s >= 0.0 && s.is_finite()) {
                    return Err(self.err(
                        tv_at(x),
                        ModelErrorKind::Schema,
                        format!(
                            "[hybrid] `rule_min_on` must be a number of seconds ≥ 0, found {s}"
                        ),
                    ));
                }
                s
            }
            None => 0.0,
        };
        let target = names.pop().unwrap_or_default();
        let request = names.pop().unwrap_or_default();
        Ok(Some(RuleSpec {
            request,
            target,
            min_on,
        }))
    }

    /// `engine_on = ["hybrid", …]`: names of `[modes]` tables.
    fn engine_on(&self, t: &[(Key, Tv)], raws: &[RawMode<'_>]) -> Result<Vec<String>, ModelError> {
        let Some(v) = get(t, "engine_on") else {
            return Ok(Vec::new());
        };
        let Kind::Array(items) = &v.kind else {
            return Err(self.err(
                tv_at(v),
                ModelErrorKind::Schema,
                "[hybrid] `engine_on` must be an array of mode names, e.g. engine_on = [\"hybrid\"]",
            ));
        };
        let mut out = Vec::new();
        for item in items {
            let n = self.string(item, "[hybrid] `engine_on` entry")?;
            if !raws.iter().any(|r| r.name == n) {
                let known: Vec<&str> = raws.iter().map(|r| r.name.as_str()).collect();
                return Err(self.err(
                    tv_at(item),
                    ModelErrorKind::UnknownName,
                    format!(
                        "[hybrid] `engine_on` names `{}`, which is not a mode; the modes are: {}",
                        n.escape_debug(),
                        known.join(", ")
                    ),
                ));
            }
            out.push(n);
        }
        Ok(out)
    }
}
