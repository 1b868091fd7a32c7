//! Derivatives with respect to a map's grid values, as `--gradient` names them: `MAP[i]` (1-D), `MAP[i,j]`
//! (2-D, i along the map's x grid, j along its y grid, both from 1, as a gear's `i_g[3]`), and `MAP` alone for
//! every grid value of the map. `all` does not include them (a map has hundreds of values). The indices refer
//! to the grid in use: the model file's, or the one `--map MAP=FILE.csv` gives.
//!
//! [`split`] takes the grid values out of a list of names and leaves the parameters' names to the parameters'
//! resolution (`resolve`, `resolve_modal`). A list written `m,bsfc[3,4]` arrives cut at every comma (the
//! command line's and Python's list of names): a piece that opens a bracket is joined with the pieces up to the
//! one that closes it.

use invsim_model_api::map::Map;

use super::GradientError;

/// The most grid values one run is differentiated by (each is a column of every point's sensitivities and of
/// the internal states' sensitivities).
pub const MAX_GRID_VALUES: usize = 10_000;

/// One grid value to differentiate by: its name in the gradient block (`bsfc[3,4]`), the map's name and the
/// value's index in the map's row-major values (`Map::values`).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct GridValue {
    pub name: String,
    pub map: String,
    pub index: usize,
}

/// The names of `names` that are grid values of `maps` (by the maps' names), resolved, and the other names,
/// in their order. A grid value named twice (`bsfc` and `bsfc[2,3]`) is refused, as is an index off the map's
/// grid, a 1-D index for a 2-D map (and the reverse), and more than [`MAX_GRID_VALUES`] in all.
pub fn split(
    maps: &[&Map],
    names: &[String],
) -> Result<(Vec<GridValue>, Vec<String>), GradientError> {
    let mut grid: Vec<GridValue> = Vec::new();
    let mut rest = Vec::new();
    for name in &rejoin(names) {
        let (base, indices) = parse(name);
        let Some(map) = maps.iter().find(|m| m.name() == base) else {
            rest.push(name.clone());
            continue;
        };
        let values = match indices {
            None => every(map),
            Some(ix) => vec![one(map, name, ix)?],
        };
        if grid.len() + values.len() > MAX_GRID_VALUES {
            return Err(GradientError::TooManyGridValues {
                max: MAX_GRID_VALUES,
            });
        }
        for v in values {
            if grid.iter().any(|g| g.map == v.map && g.index == v.index) {
                return Err(GradientError::Duplicate { name: v.name });
            }
            grid.push(v);
        }
    }
    Ok((grid, rest))
}

/// `names` with each piece that opens a bracket joined by commas to those up to the one that closes it.
fn rejoin(names: &[String]) -> Vec<String> {
    let mut out: Vec<String> = Vec::with_capacity(names.len());
    let mut open = false;
    for piece in names {
        match out.last_mut() {
            Some(last) if open => {
                last.push(',');
                last.push_str(piece);
            }
            _ => out.push(piece.clone()),
        }
        let last = out.last().map_or("", String::as_str);
        open = match (last.rfind('['), last.rfind(']')) {
            (Some(a), Some(b)) => a > b,
            (Some(_), None) => true,
            _ => false,
        };
    }
    out
}

/// `NAME[i]` or `NAME[i,j]` as (`NAME`, the indices as written); a name without brackets as (itself, None).
fn parse(name: &str) -> (&str, Option<&str>) {
    match name.split_once('[') {
        Some((base, tail)) => match tail.strip_suffix(']') {
            Some(ix) => (base.trim(), Some(ix)),
            None => (name, None),
        },
        None => (name.trim(), None),
    }
}

/// Every grid value of `map`, in the order of its values.
fn every(map: &Map) -> Vec<GridValue> {
    let ny = map.y().map_or(1, <[f64]>::len);
    (0..map.values().len())
        .map(|k| GridValue {
            name: if map.arity() == 2 {
                format!("{}[{},{}]", map.name(), k / ny + 1, k % ny + 1)
            } else {
                format!("{}[{}]", map.name(), k + 1)
            },
            map: map.name().to_string(),
            index: k,
        })
        .collect()
}

/// The grid value `indices` (`i` or `i,j`, from 1) of `map`, named `name`.
fn one(map: &Map, name: &str, indices: &str) -> Result<GridValue, GradientError> {
    let bad = || GradientError::BadGridValue {
        name: name.to_string(),
        expected: expected(map),
    };
    let ix: Vec<usize> = indices
        .split(',')
        .map(|s| s.trim().parse::<usize>().map_err(|_| bad()))
        .collect::<Result<_, _>>()?;
    let nx = map.x().len();
    let index = match (ix.as_slice(), map.y()) {
        ([i], None) if (1..=nx).contains(i) => i - 1,
        ([i, j], Some(y)) if (1..=nx).contains(i) && (1..=y.len()).contains(j) => {
            (i - 1) * y.len() + (j - 1)
        }
        _ => return Err(bad()),
    };
    let name = match map.y() {
        Some(y) => format!(
            "{}[{},{}]",
            map.name(),
            index / y.len() + 1,
            index % y.len() + 1
        ),
        None => format!("{}[{}]", map.name(), index + 1),
    };
    Ok(GridValue {
        name,
        map: map.name().to_string(),
        index,
    })
}

/// What the grid values of `map` are called: `bsfc[i,j], i = 1 … 15 along x, j = 1 … 12 along y`.
fn expected(map: &Map) -> String {
    let (name, nx) = (map.name(), map.x().len());
    match map.y() {
        Some(y) => format!(
            "{name}[i,j] with i = 1 … {nx} along its x grid and j = 1 … {} along its y grid",
            y.len()
        ),
        None => format!("{name}[i] with i = 1 … {nx} along its grid"),
    }
}

/// The maps' grid values as the list of known names says them (empty without maps).
fn known(maps: &[&Map]) -> String {
    maps.iter()
        .map(|m| expected(m))
        .collect::<Vec<_>>()
        .join(", ")
}

/// An unknown name's list of known names with the grid values of `maps` (none: `e` unchanged).
pub(crate) fn with_maps(e: GradientError, maps: &[&Map]) -> GradientError {
    match e {
        GradientError::UnknownParameter {
            name,
            known: params,
        } if !maps.is_empty() => GradientError::UnknownParameter {
            name,
            known: format!("{params}; and the maps' grid values {}", known(maps)),
        },
        e => e,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use invsim_model_api::map::MapSettings;

    fn names(v: &[&str]) -> Vec<String> {
        v.iter().map(|s| s.to_string()).collect()
    }

    #[test]
    fn grid_values_are_named_from_one_along_each_axis() {
        let s = MapSettings::default();
        let two = Map::new_2d(vec![0.0, 1.0, 2.0], vec![0.0, 1.0], vec![0.0; 6], s)
            .expect("valid")
            .named("b");
        let one_d = Map::new_1d(vec![0.0, 1.0], vec![0.0; 2], s)
            .expect("valid")
            .named("c");
        let maps = [&two, &one_d];
        // `b[3, 2]` as the command line cuts it at the comma.
        let (grid, rest) = split(&maps, &names(&["m", "b[3", " 2]", "c", "k"])).expect("valid");
        assert_eq!(rest, ["m", "k"]);
        let got: Vec<(&str, usize)> = grid.iter().map(|g| (g.name.as_str(), g.index)).collect();
        assert_eq!(got, [("b[3,2]", 5), ("c[1]", 0), ("c[2]", 1)]);
        let e = |n: &[&str]| split(&maps, &names(n)).unwrap_err();
        for bad in ["b[4,1]", "b[0,1]", "b[2]", "c[1,1]", "c[x]", "b[1,2,3]"] {
            let err = e(&[bad]);
            assert!(matches!(err, GradientError::BadGridValue { .. }), "{bad}");
        }
        assert!(e(&["b[4,1]"]).to_string().contains("i = 1 … 3"));
        assert!(matches!(
            e(&["c", "c[2]"]),
            GradientError::Duplicate { name } if name == "c[2]"
        ));
        assert_eq!(
            known(&maps),
            "b[i,j] with i = 1 … 3 along its x grid and j = 1 … 2 along its y grid, \
             c[i] with i = 1 … 2 along its grid"
        );
        let big = Map::new_2d(
            (0..101).map(f64::from).collect(),
            (0..100).map(f64::from).collect(),
            vec![0.0; 10_100],
            s,
        )
        .expect("valid")
        .named("big");
        assert!(matches!(
            split(&[&big], &names(&["big"])).unwrap_err(),
            GradientError::TooManyGridValues { .. }
        ));
    }
}
