//! What the derivatives of a run with modes are taken with respect to: a parameter in every mode, as
//! `--set NAME=` moves it, or a parameter the `[gearbox]` sets per gear, in the modes of one gear, named
//! `NAME[g]` (`i_g[3]`: the third gear's ratio; gears count from 1, as the gearbox's arrays are written), or a
//! map's grid value in every mode that calls the map (`--map` replaces a map in all of them).

use invsim_model_api::map::Map;

use super::grid_columns::GridColumns;
use super::grid_values::GridValue;
use super::GradientError;

/// One derivative of a run with modes: its name, the parameter it moves (an index into the modes' shared
/// parameters; P + g for grid value g, which moves none) and, for a gearbox's parameter, the gear whose modes
/// it moves.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ModalParam {
    pub name: String,
    pub param: usize,
    pub gear: Option<usize>,
}

impl ModalParam {
    /// The column of the parameter in a mode of gear `gear` (`None`: the mode does not take it).
    pub fn column_in(&self, gear: Option<usize>) -> Option<usize> {
        match self.gear {
            None => Some(self.param),
            Some(g) => (gear == Some(g)).then_some(self.param),
        }
    }
}

/// The derivatives of a run with modes and the column of each in each mode (`columns[mode][c]`, `None`:
/// the mode does not take it, being of another gear or setting the parameter itself, as overrun's
/// `parameters = { c_fuel = 0.0 }` does, or not calling the map of a grid value), and each mode's columns of
/// the grid values (`grids[mode]`).
#[derive(Debug, Clone, PartialEq)]
pub struct ModalWrt {
    pub params: Vec<ModalParam>,
    pub columns: Vec<Vec<Option<usize>>>,
    pub grids: Vec<GridColumns>,
}

impl ModalWrt {
    /// `params` over modes given as (gear, the parameters the mode sets itself), with the model's
    /// `parameters`.
    pub fn new<'a>(
        params: Vec<ModalParam>,
        parameters: &[String],
        modes: impl Iterator<Item = (Option<usize>, &'a [String])>,
    ) -> ModalWrt {
        let columns = modes
            .map(|(gear, own)| {
                params
                    .iter()
                    .map(|p| {
                        p.column_in(gear)
                            .filter(|&k| !own.iter().any(|o| Some(o) == parameters.get(k)))
                    })
                    .collect()
            })
            .collect::<Vec<Vec<Option<usize>>>>();
        let grids = vec![GridColumns::default(); columns.len()];
        ModalWrt {
            params,
            columns,
            grids,
        }
    }

    /// The derivatives with the grid values `grid` after them, over modes with the maps `maps` (in the modes'
    /// order) and `n_params` parameters: grid value g is column P + g of every mode that has its map.
    pub fn with_grid<'a>(
        mut self,
        n_params: usize,
        grid: &[GridValue],
        maps: impl Iterator<Item = &'a [Map]>,
    ) -> ModalWrt {
        for (g, v) in grid.iter().enumerate() {
            self.params.push(ModalParam {
                name: v.name.clone(),
                param: n_params + g,
                gear: None,
            });
        }
        for ((columns, grids), maps) in self.columns.iter_mut().zip(&mut self.grids).zip(maps) {
            columns.extend(grid.iter().enumerate().map(|(g, v)| {
                maps.iter()
                    .any(|m| m.name() == v.map)
                    .then_some(n_params + g)
            }));
            *grids = GridColumns::new(maps, grid);
        }
        self
    }
}

/// The gearbox of the model: the parameters it sets per gear and its number of gears.
#[derive(Debug, Clone, Copy)]
pub struct GearParameters<'a> {
    pub names: &'a [String],
    pub gears: usize,
}

impl GearParameters<'_> {
    /// Every gear's name of every parameter the gearbox sets per gear, `NAME[g]` (`i_g[1]` … `i_g[5]`): the
    /// names `--set`, a sweep and `--gradient` take for them.
    pub fn per_gear_names(&self) -> Vec<String> {
        self.names
            .iter()
            .flat_map(|n| (1..=self.gears).map(move |g| format!("{n}[{g}]")))
            .collect()
    }
}

/// The derivatives asked for by `names` (`all`: every parameter that is not the gearbox's and every gear's
/// value of each that is), in the parameters' order with a gearbox parameter's gears in order.
pub fn resolve_modal(
    parameters: &[String],
    gearbox: GearParameters<'_>,
    names: &[String],
) -> Result<Vec<ModalParam>, GradientError> {
    let all: Vec<ModalParam> = parameters
        .iter()
        .enumerate()
        .flat_map(|(k, p)| expand(k, p, gearbox))
        .collect();
    if names.len() == 1 && names[0] == "all" && !parameters.iter().any(|p| p == "all") {
        return Ok(all);
    }
    let mut picked = vec![false; all.len()];
    for name in names {
        let Some(i) = all.iter().position(|m| &m.name == name) else {
            return Err(unknown(parameters, gearbox, name));
        };
        if picked[i] {
            return Err(GradientError::Duplicate { name: name.clone() });
        }
        picked[i] = true;
    }
    Ok(all
        .into_iter()
        .zip(picked)
        .filter_map(|(m, p)| p.then_some(m))
        .collect())
}

/// [`resolve_modal`] of the names that are not grid values of `maps` (the maps of every mode, each once), and
/// those grid values ([`super::grid_values::split`]).
pub fn resolve_modal_with_maps(
    (parameters, gearbox): (&[String], GearParameters<'_>),
    maps: &[&Map],
    names: &[String],
) -> Result<(Vec<GridValue>, Vec<ModalParam>), GradientError> {
    let (grid, names) = super::grid_values::split(maps, names)?;
    let params = resolve_modal(parameters, gearbox, &names)
        .map_err(|e| super::grid_values::with_maps(e, maps))?;
    Ok((grid, params))
}

/// Parameter k as the derivatives name it: itself, or one per gear.
fn expand(k: usize, p: &str, gearbox: GearParameters<'_>) -> Vec<ModalParam> {
    if gearbox.names.iter().any(|g| g == p) {
        (1..=gearbox.gears)
            .map(|g| ModalParam {
                name: format!("{p}[{g}]"),
                param: k,
                gear: Some(g),
            })
            .collect()
    } else {
        vec![ModalParam {
            name: p.to_string(),
            param: k,
            gear: None,
        }]
    }
}

/// Why `name` is none of the derivatives: a gearbox parameter named whole or with a gear it lacks, or unknown.
fn unknown(parameters: &[String], gearbox: GearParameters<'_>, name: &str) -> GradientError {
    let gears = gearbox.gears;
    if gearbox.names.iter().any(|g| g == name) {
        return GradientError::PerGear {
            name: name.to_string(),
            gears,
        };
    }
    let base = name.split('[').next().unwrap_or(name);
    if name.ends_with(']') && gearbox.names.iter().any(|g| g == base) {
        return GradientError::NoSuchGear {
            name: name.to_string(),
            gears,
        };
    }
    let known: Vec<String> = parameters
        .iter()
        .map(|p| {
            if gearbox.names.iter().any(|g| g == p) {
                format!("{p}[1] … {p}[{gears}]")
            } else {
                p.clone()
            }
        })
        .collect();
    GradientError::UnknownParameter {
        name: name.to_string(),
        known: known.join(", "),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn names(v: &[&str]) -> Vec<String> {
        v.iter().map(|s| s.to_string()).collect()
    }

    #[test]
    fn gear_parameters_are_named_per_gear() {
        let params = names(&["m", "i_g", "i_f"]);
        let gb = names(&["i_g"]);
        let gearbox = GearParameters {
            names: &gb,
            gears: 3,
        };
        let all = resolve_modal(&params, gearbox, &names(&["all"])).expect("all");
        let got: Vec<&str> = all.iter().map(|m| m.name.as_str()).collect();
        assert_eq!(got, ["m", "i_g[1]", "i_g[2]", "i_g[3]", "i_f"]);
        assert_eq!(all[2].column_in(Some(2)), Some(1));
        assert_eq!(all[2].column_in(Some(3)), None);
        assert_eq!(all[2].column_in(None), None);
        assert_eq!(all[0].column_in(None), Some(0));
        let own = names(&["m"]);
        let wrt = ModalWrt::new(
            all,
            &params,
            [(Some(2), &own[..]), (None, &[][..])].into_iter(),
        );
        assert_eq!(wrt.columns[0], [None, None, Some(1), None, Some(2)]);
        assert_eq!(wrt.columns[1], [Some(0), None, None, None, Some(2)]);
        let some = resolve_modal(&params, gearbox, &names(&["i_f", "i_g[3]"])).expect("two");
        assert_eq!(some.len(), 2);
        assert_eq!(some[0].gear, Some(3));
        let e = |n: &str| resolve_modal(&params, gearbox, &names(&[n])).unwrap_err();
        assert!(matches!(e("i_g"), GradientError::PerGear { .. }));
        assert!(matches!(e("i_g[4]"), GradientError::NoSuchGear { .. }));
        assert!(e("x").to_string().contains("i_g[1] … i_g[3]"));
        assert!(matches!(
            resolve_modal(&params, gearbox, &names(&["m", "m"])).unwrap_err(),
            GradientError::Duplicate { .. }
        ));
    }
}
