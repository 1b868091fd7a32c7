//! Models with lookup maps (contract §6): maps read inline and from CSV files give the same derivation; Lie
//! derivatives of a model with a 2-D map in f agree with finite differences of the smoothed model; a map in
//! h is not inverted symbolically (ψ⁻¹ by Newton); the JSON's `maps` object lets the derived expressions be
//! evaluated without the model file; the interpreter evaluates the derived α like the pool does.

use invsim_expr::map::{Extrapolate, Interp, Map, MapSettings};
use invsim_expr::{MapDecl, Pool, Symbol};
use invsim_inversion::{Derivation, Interpreter, Model, Solution};
use invsim_model_api::InverseModel;
use std::collections::HashMap;
use std::path::PathBuf;
use std::sync::Arc;

const INLINE: &str = r#"
name = "two_maps"
[parameters]
c1 = 0.5
c2 = 1.3
[maps.eta]
args = ["a", "b"]
x = [0.0, 1.0, 2.0, 4.0]
y = [0.0, 2.0, 3.0]
values = [[0.7, 0.75, 0.8], [0.78, 0.83, 0.86], [0.82, 0.88, 0.9], [0.8, 0.86, 0.89]]
smooth = 0.7
[maps.loss]
x = [-1.0, 0.0, 1.5, 3.0]
values = [0.2, 0.0, 0.3, 1.1]
extrapolate = "clamp"
[states]
v = { rhs = "p - c1*v - loss(v)" }
p = { rhs = "-c2*eta(v, p)*p + u" }
[input]
name = "u"
[output]
name = "v"
h = "v"
"#;

fn dir() -> PathBuf {
    let d = std::env::temp_dir().join(format!("invsim-maps-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn derive(name: &str, text: &str) -> Derivation {
    let path = dir().join(name);
    std::fs::write(&path, text).unwrap();
    let model = Model::from_path(&path).unwrap_or_else(|e| panic!("{e}"));
    Derivation::new(model).unwrap_or_else(|e| panic!("{e}"))
}

#[test]
fn csv_maps_equal_inline_maps() {
    let d = dir();
    std::fs::write(d.join("eta.csv"), "\u{feff}# eta over a (rows) and b (columns)\nspeed,0,2,3\n0,0.7,0.75,0.8\n1,0.78,0.83,0.86\n2,0.82,0.88,0.9\n4,0.8,0.86,0.89\n").unwrap();
    std::fs::write(
        d.join("loss.csv"),
        "x,loss\n-1,0.2\n0,0\n1.5,0.3\n\n3,1.1\n",
    )
    .unwrap();
    let text = INLINE
        .replace(
            "x = [0.0, 1.0, 2.0, 4.0]\ny = [0.0, 2.0, 3.0]\nvalues = [[0.7, 0.75, 0.8], [0.78, 0.83, 0.86], [0.82, 0.88, 0.9], [0.8, 0.86, 0.89]]",
            "file = \"eta.csv\"",
        )
        .replace("x = [-1.0, 0.0, 1.5, 3.0]\nvalues = [0.2, 0.0, 0.3, 1.1]", "file = \"loss.csv\"");
    assert!(text.contains("eta.csv") && text.contains("loss.csv"));
    let a = derive("inline.toml", INLINE).to_json();
    let b = derive("csv.toml", &text).to_json();
    assert_eq!(a["alpha"], b["alpha"]);
    assert_eq!(a["maps"], b["maps"]);
    assert_eq!(a["maps"]["eta"]["values"][3][2], 0.89);
    assert_eq!(a["maps"]["loss"]["extrapolate"], "clamp");
    assert_eq!(a["maps"]["eta"]["smooth"], 0.7);
    assert!(a["maps"]["loss"].get("y").is_none());
}

/// Values of the parameters and states as the pool's symbols.
fn point(pool: &Pool, v: f64, p: f64) -> HashMap<Symbol, f64> {
    let s = |n: &str| pool.find_symbol(n).unwrap();
    HashMap::from([
        (s("c1"), 0.5),
        (s("c2"), 1.3),
        (s("v"), v),
        (s("p"), p),
        (s("u"), 0.0),
    ])
}

#[test]
fn lie_derivatives_agree_with_finite_differences_of_the_smoothed_model() {
    let d = derive("lie.toml", INLINE);
    let pool = d.pool();
    let f: Vec<_> = d.model.states.iter().map(|s| s.f).collect();
    for (v, p) in [(0.3, 1.1), (1.7, 2.4), (3.9, 0.2), (-0.5, 3.5)] {
        let at = point(pool, v, p);
        for k in 1..=d.relative_degree {
            // L_f^k h = ∇(L_f^(k−1) h) · f, the gradient by central differences of the evaluated expression.
            let prev = |dv: f64, dp: f64| {
                let mut x = at.clone();
                *x.get_mut(&pool.find_symbol("v").unwrap()).unwrap() += dv;
                *x.get_mut(&pool.find_symbol("p").unwrap()).unwrap() += dp;
                pool.eval(d.lie[k - 1], &x).unwrap()
            };
            let step = 1e-5;
            let gv = (prev(step, 0.0) - prev(-step, 0.0)) / (2.0 * step);
            let gp = (prev(0.0, step) - prev(0.0, -step)) / (2.0 * step);
            let fd = gv * pool.eval(f[0], &at).unwrap() + gp * pool.eval(f[1], &at).unwrap();
            let exact = pool.eval(d.lie[k], &at).unwrap();
            assert!(
                (exact - fd).abs() < 1e-7 * (1.0 + exact.abs()),
                "k = {k} at ({v}, {p}): {exact} vs {fd}"
            );
        }
    }
}

#[test]
fn a_map_in_h_is_solved_by_newton() {
    let text = INLINE.replace("h = \"v\"", "h = \"v + 0.2*loss(v)\"");
    let d = derive("h.toml", &text);
    assert!(
        matches!(d.psi_inv[0], Solution::Numeric),
        "ψ⁻¹ through a map must not be closed-form"
    );
    let j = d.to_json();
    assert!(j["psi_inv"]["v"].is_null());
    assert!(
        j["decoupling"].as_str().unwrap().contains("loss_d1(v)"),
        "{}",
        j["decoupling"]
    );
}

#[test]
fn the_json_maps_object_evaluates_the_derivation_without_the_model_file() {
    let d = derive("json.toml", INLINE);
    let j = d.to_json();
    let mut pool = Pool::new();
    for (name, m) in j["maps"].as_object().unwrap() {
        let nums = |v: &serde_json::Value| -> Vec<f64> {
            v.as_array()
                .unwrap()
                .iter()
                .map(|x| x.as_f64().unwrap())
                .collect()
        };
        let settings = MapSettings {
            smooth: m["smooth"].as_f64().unwrap(),
            extrapolate: Extrapolate::from_name(m["extrapolate"].as_str().unwrap()).unwrap(),
            interp: Interp::from_name(m["interp"].as_str().unwrap()).unwrap(),
        };
        let map = match m.get("y") {
            Some(y) => {
                let values = m["values"]
                    .as_array()
                    .unwrap()
                    .iter()
                    .flat_map(nums)
                    .collect();
                Map::new_2d(nums(&m["x"]), nums(y), values, settings).unwrap()
            }
            None => Map::new_1d(nums(&m["x"]), nums(&m["values"]), settings).unwrap(),
        };
        pool.declare_map(MapDecl::new(name, Arc::new(map)));
    }
    let alpha = pool.parse(j["alpha"].as_str().unwrap()).unwrap();
    let s = |pool: &mut Pool, n: &str| pool.symbol(n);
    let (xi1, xi2, c1, c2) = (
        s(&mut pool, "xi1"),
        s(&mut pool, "xi2"),
        s(&mut pool, "c1"),
        s(&mut pool, "c2"),
    );
    let values = HashMap::from([(xi1, 1.2), (xi2, 0.4), (c1, 0.5), (c2, 1.3)]);
    let from_json = pool.eval(alpha, &values).unwrap();
    let dp = d.pool();
    let theirs = HashMap::from([
        (dp.find_symbol("xi1").unwrap(), 1.2),
        (dp.find_symbol("xi2").unwrap(), 0.4),
        (dp.find_symbol("c1").unwrap(), 0.5),
        (dp.find_symbol("c2").unwrap(), 1.3),
    ]);
    let direct = dp.eval(d.alpha, &theirs).unwrap();
    assert_eq!(from_json, direct);
}

#[test]
fn the_interpreter_evaluates_maps_like_the_pool() {
    let d = derive("interp.toml", INLINE);
    let it = Interpreter::new(&d).unwrap();
    let dp = d.pool();
    for (xi1, xi2) in [(0.2, 0.9), (2.5, -0.3), (5.0, 1.0)] {
        let values = HashMap::from([
            (dp.find_symbol("xi1").unwrap(), xi1),
            (dp.find_symbol("xi2").unwrap(), xi2),
            (dp.find_symbol("c1").unwrap(), 0.5),
            (dp.find_symbol("c2").unwrap(), 1.3),
        ]);
        let want = dp.eval(d.alpha, &values).unwrap();
        let got = it.alpha(&[xi1, xi2], &[], &[]);
        assert!(
            (got - want).abs() <= 1e-14 * want.abs().max(1.0),
            "{got} vs {want}"
        );
    }
}

#[test]
fn text_and_markdown_list_every_map_with_its_grid_and_values() {
    let d = derive("render.toml", INLINE);
    let text = d.to_text();
    assert!(
        text.contains("eta(a, b): a ∈ [0, 4] (4 points) × b ∈ [0, 3] (3 points); smooth, kernel half-width 0.7"),
        "{text}"
    );
    assert!(
        text.contains("loss(x): x ∈ [-1, 3] (4 points); smooth, kernel half-width 0.5 × the smallest spacing per axis; outside the grid: clamp"),
        "{text}"
    );
    let md = d.to_markdown();
    assert!(
        md.contains("| `eta(a, b)` | a ∈ [0, 4] (4 points) × b ∈ [0, 3] (3 points) |"),
        "{md}"
    );
    // Every row of the model's values, in order, under the second grid.
    assert!(md.contains("| a \\ b | 0 | 2 | 3 |"), "{md}");
    for row in [
        "| 0 | 0.7 | 0.75 | 0.8 |",
        "| 1 | 0.78 | 0.83 | 0.86 |",
        "| 2 | 0.82 | 0.88 | 0.9 |",
        "| 4 | 0.8 | 0.86 | 0.89 |",
    ] {
        assert!(md.contains(row), "{row} missing:\n{md}");
    }
    for row in ["| -1 | 0.2 |", "| 0 | 0 |", "| 1.5 | 0.3 |", "| 3 | 1.1 |"] {
        assert!(md.contains(row), "{row} missing:\n{md}");
    }
}
