//! Smoothness: the non-smooth functions `abs`, `sign`, `min` and `max` may not enter f, g or h — neither
//! directly in a state's rhs, f, g or the output's h, nor through a definition that reaches them — since
//! the method differentiates f, g and h (Lie derivatives); they are allowed in `[outputs]`. The same holds for
//! a map with `interp = "linear"` (plain (bi)linear interpolation, contract §6), its derivative maps included.

use super::definitions::{def_uses, Uses};
use super::error::{ModelError, ModelErrorKind};
use super::expressions::{describe, Item, Role};
use super::names::Names;
use super::raw::RawModel;
use super::spanned::Reader;
use invsim_expr::map::Interp;
use invsim_expr::NON_SMOOTH_FUNCTIONS;

impl Reader<'_> {
    /// Non-smooth functions: never in rhs, f, g or h, nor in a definition that reaches them.
    pub(super) fn check_smooth(
        &self,
        raw: &RawModel,
        names: &Names<'_>,
        items: &[Item],
        uses: &Uses,
    ) -> Result<(), ModelError> {
        let ndef = raw.definitions.len();
        let mut reached_by: Vec<Option<Role>> = vec![None; ndef];
        for item in items.iter().filter(|it| it.role.is_smooth_root()) {
            let mut stack: Vec<usize> = def_uses(item, names).into_iter().map(|(j, _)| j).collect();
            while let Some(j) = stack.pop() {
                if reached_by[j].is_none() {
                    reached_by[j] = Some(item.role);
                    stack.extend(uses[j].iter().map(|&(k, _)| k));
                }
            }
        }
        let linear_map = |called: &str| {
            raw.maps.iter().any(|m| {
                m.data.settings().interp == Interp::Linear
                    && (called == m.name
                        || called
                            .strip_prefix(m.name.as_str())
                            .is_some_and(|r| r.starts_with("_d")))
            })
        };
        for item in items {
            let Some((call, span)) = item
                .ast
                .calls()
                .into_iter()
                .find(|(name, _)| NON_SMOOTH_FUNCTIONS.contains(name) || linear_map(name))
            else {
                continue;
            };
            let at = item.src.at(span.start);
            let root = match item.role {
                Role::Definition(i) => match reached_by[i] {
                    Some(root) => format!(
                        "{} (used by {})",
                        describe(raw, item.role),
                        describe(raw, root)
                    ),
                    None => continue,
                },
                Role::Extra(_) => continue,
                role => describe(raw, role),
            };
            if linear_map(call) {
                return Err(self.err(
                    at,
                    ModelErrorKind::NonSmooth,
                    format!(
                        "map `{call}` has interp = \"linear\" (not smooth), so it may not enter f, g or h: use it only \
                         in [outputs], or give it interp = \"smooth\" (found in {root})"
                    ),
                ));
            }
            return Err(self.err(
                at,
                ModelErrorKind::NonSmooth,
                format!(
                    "`{call}` is not smooth, so it may not enter f, g or h: abs, sign, min and max are allowed only \
                     in [outputs] (found in {root})"
                ),
            ));
        }
        Ok(())
    }
}
