//! The optional `[engine]` table: which two `[outputs]` entries are the engine's speed and torque, so that a
//! run can tabulate the engine's operating points (a time-weighted speed × torque histogram in the summary).
//!
//! ```toml
//! [engine]
//! speed = "n_e"     # an [outputs] entry (its unit is the histogram's speed unit)
//! torque = "T_e"    # an [outputs] entry
//! ```
//!
//! The entries are evaluated like every other extra output, so they are also in the CSV.

use super::error::{ModelError, ModelErrorKind};
use super::keys;
use super::spanned::Reader;
use super::tree::{get, tv_at, Tv};
use super::validated::Engine;

/// `[engine]` as written: the names of the speed and torque outputs with their positions.
#[derive(Debug)]
pub(super) struct RawEngine {
    pub(super) speed: (String, Option<usize>),
    pub(super) torque: (String, Option<usize>),
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
        })
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
        })
    }
}
