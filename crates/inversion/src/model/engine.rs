//! The optional `[engine]` table: which two `[outputs]` entries are the engine's speed and torque, so that a
//! run can tabulate the engine's operating points (a time-weighted speed × torque histogram in the summary).
//!
//! ```toml
//! [engine]
//! speed = "n_e"     # an [outputs] entry (its unit is the histogram's speed unit)
//! torque = "T_e"    # an [outputs] entry
//! map = "bsfc(n_e*pi/30, T_e)"   # optional: the map the plot draws the operating points over
//! map_unit = "g/kWh"
//! map_range = [250, 450]         # optional: the colour scale's ends (default: the 5th and 95th percentile)
//! ```
//!
//! The entries are evaluated like every other extra output, so they are also in the CSV. `map` is an
//! expression in the speed and torque outputs' names, the parameters and the maps, nothing else: a function of
//! the operating point alone, which the plot evaluates over the panel's area.

use super::error::{ModelError, ModelErrorKind};
use super::keys;
use super::spanned::{Reader, Src};
use super::tree::{get, tv_at, Tv};
use super::validated::Engine;
use invsim_model_api::EngineMapInfo;

/// `[engine]` as written: the names of the speed and torque outputs with their positions, and the map.
#[derive(Debug)]
pub(super) struct RawEngine {
    pub(super) speed: (String, Option<usize>),
    pub(super) torque: (String, Option<usize>),
    pub(super) map: Option<Src>,
    pub(super) map_unit: Option<String>,
    pub(super) map_range: Option<[f64; 2]>,
}

impl Reader<'_> {
    /// `[engine]`: `speed` and `torque`, both required strings.
    pub(super) fn engine(&self, v: &Tv) -> Result<RawEngine, ModelError> {
        let t = self.table(v, "[engine]")?;
        self.known_keys(t, keys::ENGINE, "[engine]")?;
        let field = |key: &str| -> Result<(String, Option<usize>), ModelError> {
            let Some(value) = get(t, key) else {
                return Err(self.err(
                    tv_at(v),
                    ModelErrorKind::Schema,
                    format!(
                        "[engine] has no `{key}`; expected the names of two [outputs] entries, e.g. \
                         speed = \"n_e\", torque = \"T_e\""
                    ),
                ));
            };
            Ok((
                self.string(value, &format!("[engine]'s `{key}`"))?,
                tv_at(value),
            ))
        };
        Ok(RawEngine {
            speed: field("speed")?,
            torque: field("torque")?,
            map: get(t, "map")
                .map(|m| self.expression(m, "[engine]'s `map`"))
                .transpose()?,
            map_unit: self.optional_string(t, "map_unit", "[engine]")?,
            map_range: get(t, "map_range").map(|r| self.map_range(r)).transpose()?,
        })
    }

    /// `map_range = [lo, hi]`: two finite numbers, lo < hi.
    fn map_range(&self, v: &Tv) -> Result<[f64; 2], ModelError> {
        let what = "[engine]'s `map_range`";
        match self.number_array(v, what)?.as_slice() {
            [(lo, _), (hi, _)] if lo < hi => Ok([*lo, *hi]),
            _ => Err(self.err(
                tv_at(v),
                ModelErrorKind::Schema,
                format!("{what} must be two numbers [low, high] with low < high, e.g. [250, 450]"),
            )),
        }
    }

    /// The `[engine]` entries as indices into the extra outputs `names`.
    pub(super) fn resolve_engine(
        &self,
        raw: &RawEngine,
        names: &[&str],
    ) -> Result<Engine, ModelError> {
        let index = |(name, at): &(String, Option<usize>), key: &str| {
            names.iter().position(|n| n == name).ok_or_else(|| {
                self.err(
                    *at,
                    ModelErrorKind::Schema,
                    format!(
                        "[engine]'s `{key}` = \"{}\" is not an [outputs] entry (the model has: {}); name \
                         the output that gives the engine's {key}",
                        name.escape_debug(),
                        if names.is_empty() {
                            "none".to_string()
                        } else {
                            names.join(", ")
                        }
                    ),
                )
            })
        };
        Ok(Engine {
            speed: index(&raw.speed, "speed")?,
            torque: index(&raw.torque, "torque")?,
            map: raw.map.as_ref().map(|src| EngineMapInfo {
                expr: src.text.clone(),
                unit: raw.map_unit.clone(),
                range: raw.map_range,
            }),
        })
    }
}
