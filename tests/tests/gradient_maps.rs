//! Exact gradients with respect to a map's grid values (`--gradient bsfc[3,2]`) against independent
//! references: central finite differences of the summary's figures in a grid value (the map's values
//! replaced in process, as `--map` replaces them) for si_engine_maps (eta_vol: smooth, inside the dynamics, ψ⁻¹
//! by Newton; bsfc: plain bilinear, in an output), map_heat (a map inside causal zero dynamics) and map_nmp
//! (inside unstable zero dynamics, inverted stably), the compiled engine against the interpreter, and a model
//! whose fuel integral is linear in a 1-D map's values in closed form.

use crate::gradient::{
    agrees, block, central_along, compiled, fd_plan, figure, interpreted, model_path, opts_for,
    Block,
};
use invsim_model_api::InverseModel;
use invsim_runtime::{simulate, Cycle, SimulationOptions, Summary};

/// The options of the runs here: dt 0.1, the gradient with respect to `names` (none: no gradient).
fn options(names: Option<&[&str]>) -> SimulationOptions {
    let mut o = opts_for(names.map(|n| n.iter().map(|s| s.to_string()).collect()));
    o.dt = 0.1;
    o
}

/// `model` with value `index` of map `map` moved by `offset` from `values` (the map's values in use).
fn move_value(
    model: &mut dyn InverseModel,
    (map, index): (&str, usize),
    values: &[f64],
    offset: f64,
) {
    let m = model
        .maps()
        .iter()
        .find(|m| m.name() == map)
        .expect("the map")
        .clone();
    let mut v = values.to_vec();
    v[index] += offset;
    model
        .set_map(map, (m.x(), m.y(), &v))
        .expect("the same grid");
}

/// The flat index of grid value (i, j) (from 1) of a 2-D map (1-D: j = 1 and a single column).
fn flat(model: &dyn InverseModel, map: &str, (i, j): (usize, usize)) -> usize {
    let m = model
        .maps()
        .iter()
        .find(|m| m.name() == map)
        .expect("the map");
    (i - 1) * m.y().map_or(1, <[f64]>::len) + (j - 1)
}

/// The gradient of `cycle` with respect to `grid` (each (name, map, (i, j))) of the compiled model `name`:
/// equal to the interpreter's within `equal` of each figure (compared as v·d figure/dv, the figure's change for
/// a relative change of the value v), within 1e-6 relative of the central differences or twice their error
/// estimate, and 0 exactly where `zero` says so (a value the run never reaches: the differences are 0 too).
fn check(name: &str, cycle: &Cycle, grid: &[(&str, &str, (usize, usize), bool)], equal: f64) {
    let names: Vec<&str> = grid.iter().map(|g| g.0).collect();
    let o = options(Some(&names));
    let mut comp = compiled(name);
    let sc = simulate(comp.as_ref(), cycle, &o).expect("runs").summary;
    let interp = interpreted(&model_path(name));
    let si = simulate(interp.as_ref(), cycle, &o).expect("runs").summary;
    let (gc, gi) = (block(&sc), block(&si));
    let figures: Vec<&String> = gc.keys().collect();
    assert!(!figures.is_empty(), "{name} has figures");
    let (rel, noise) = fd_plan(&sc);
    let plain = options(None);
    for &(label, map, ij, zero) in grid {
        let k = flat(comp.as_ref(), map, ij);
        let values = comp
            .maps()
            .iter()
            .find(|m| m.name() == map)
            .expect("map")
            .values()
            .to_vec();
        let v = values[k];
        compare_engines((&sc, &gc, &gi), (label, v), equal);
        let mut set =
            |m: &mut dyn InverseModel, offset: f64| move_value(m, (map, k), &values, offset);
        let h = rel * v.abs();
        let exact: Vec<f64> = figures.iter().map(|f| gc[*f][label]).collect();
        let fd = central_along(
            comp.as_mut(),
            (cycle, &plain),
            &mut set,
            (h, noise),
            (&figures, &exact),
        );
        for (f, (d, err)) in figures.iter().zip(fd) {
            let g = gc[*f][label];
            if zero {
                assert!(
                    g == 0.0 && d == 0.0,
                    "{name}: d{f}/d{label} = {g:e}, differences {d:e}"
                );
            }
            assert!(
                agrees(g, d, err),
                "{name} {}: d{f}/d{label} = {g:e}, central differences {d:e} ± {err:e}",
                cycle.name
            );
        }
    }
}

/// Every figure's derivative in grid value `label` (of value v): compiled within `equal` of the interpreted.
fn compare_engines((sc, gc, gi): (&Summary, &Block, &Block), (label, v): (&str, f64), equal: f64) {
    for (f, row) in gc {
        let (c, i) = (row[label], gi[f][label]);
        let size = (c.abs() * v.abs()).max(figure(sc, f).abs());
        assert!(
            (c - i).abs() * v.abs() <= equal * size,
            "d{f}/d{label}: compiled {c:e}, interpreted {i:e}"
        );
    }
}

/// si_engine_maps on NEDC: eta_vol (smooth, in the air charge: ψ⁻¹ by Newton, the fuel through the input) at a
/// value the run leans on (4 × 2: 300 rad/s, 40 kPa) and one it never reaches (8 × 5: 700 rad/s, 100 kPa);
/// bsfc (plain bilinear, in fuel_bsfc; its figure is linear in the values, so the differences are exact to
/// rounding) at a visited value (3 × 2: 300 rad/s, 30 N m) and one beyond every operating point (6 × 7:
/// 600 rad/s, 180 N m). r = n: the engines agree within 1e-12.
#[test]
fn si_engine_maps_grid_values_against_finite_differences() {
    let cycle = Cycle::builtin("nedc").expect("built in");
    let grid = [
        ("eta_vol[4,2]", "eta_vol", (4, 2), false),
        ("eta_vol[8,5]", "eta_vol", (8, 5), true),
        ("bsfc[3,2]", "bsfc", (3, 2), false),
        ("bsfc[6,7]", "bsfc", (6, 7), true),
    ];
    check("si_engine_maps", &cycle, &grid, 1e-12);
    let s = simulate(
        compiled("si_engine_maps").as_ref(),
        &cycle,
        &options(Some(&["eta_vol[4,2]"])),
    )
    .expect("runs")
    .summary;
    assert!(
        block(&s)["fuel"]["eta_vol[4,2]"].abs() > 1e-3,
        "clearly nonzero"
    );
}

/// map_heat (tests/models) on NEDC: the map drives the internal state of a causal run (its sensitivities
/// integrated along the run's steps), on which the fuel depends: values at speeds the run drives (10, 20 m/s)
/// and one it never reaches (60 m/s), the engines within the causal tolerance 1e-7 of the figure.
#[test]
fn a_map_in_causal_zero_dynamics_against_finite_differences() {
    let cycle = Cycle::builtin("nedc").expect("built in");
    let grid = [
        ("heat[3]", "heat", (3, 1), false),
        ("heat[4]", "heat", (4, 1), false),
        ("heat[7]", "heat", (7, 1), true),
    ];
    check("map_heat", &cycle, &grid, 1e-7);
}

/// map_nmp (tests/models) on NEDC: the map drives the unstable internal state of a stable (non-causal)
/// inversion, differentiated through its collocation equations: values at outputs the run drives (5, 20) and
/// one it never reaches (50), the engines within 1e-12 of the figure (a stable run is a sum of rounded terms).
#[test]
fn a_map_in_unstable_zero_dynamics_against_finite_differences() {
    let cycle = Cycle::builtin("nedc").expect("built in");
    let grid = [
        ("couple[2]", "couple", (2, 1), false),
        ("couple[4]", "couple", (4, 1), false),
        ("couple[7]", "couple", (7, 1), true),
    ];
    check("map_nmp", &cycle, &grid, 1e-12);
}

/// map_fuel (tests/models): fuel = M(v) with v = y_d, so dF/dv_i = T(Φ_i(y_d)), the run's trapezoidal rule of
/// the map's basis function at the reference (`Map::weights` at each sample), to 1e-12 for both engines on
/// UDDS; the value at 50 m/s, beyond the cycle, has the derivative 0 exactly.
#[test]
fn a_fuel_map_s_gradient_is_the_closed_form() {
    let cycle = Cycle::builtin("udds").expect("built in");
    let models: Vec<Box<dyn InverseModel>> = vec![
        interpreted("tests/models/map_fuel.toml"),
        compiled("map_fuel"),
    ];
    for m in &models {
        let mut o = options(Some(&["fuel_map"]));
        o.keep_series = true;
        let r = simulate(m.as_ref(), &cycle, &o).expect("runs");
        let yd = &r.data[r.columns.iter().position(|c| c == "yd_0").expect("yd_0")];
        let map = &m.maps()[0];
        let mut exact = vec![0.0; map.values().len()];
        let mut w = Vec::new();
        let mut last = vec![0.0; exact.len()];
        for (k, &y) in yd.iter().enumerate() {
            let mut now = vec![0.0; exact.len()];
            map.weights(&[y], [0, 0], &mut w);
            for &(i, c) in &w {
                now[i] = c;
            }
            if k > 0 {
                for (e, (a, b)) in exact.iter_mut().zip(last.iter().zip(&now)) {
                    *e += 0.5 * o.dt * (a + b);
                }
            }
            last = now;
        }
        let g = block(&r.summary);
        for (i, e) in exact.iter().enumerate() {
            let v = g["fuel"][&format!("fuel_map[{}]", i + 1)];
            assert!(
                (v - e).abs() <= 1e-12 * e.abs(),
                "{}: dF/dv_{} = {v:e}, exact {e:e}",
                m.info().name,
                i + 1
            );
        }
        assert_eq!(g["fuel"]["fuel_map[10]"], 0.0);
        assert!(exact[3] > 10.0, "a value the cycle leans on: {exact:?}");
    }
}
