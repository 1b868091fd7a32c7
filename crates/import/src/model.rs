//! The invsim model file being built: parameters (value, unit, doc naming the FASTSim field), definitions,
//! the speed state driven by the tractive force, outputs; rendered as TOML text.

use crate::error::ImportError;

/// One parameter of the generated model.
#[derive(Debug, Clone)]
pub struct Param {
    pub name: String,
    pub value: f64,
    pub unit: String,
    pub doc: String,
}

/// One definition or output: name, expression, unit, doc, and for outputs whether it is accumulated.
#[derive(Debug, Clone)]
pub struct Item {
    pub name: String,
    pub expr: String,
    pub unit: String,
    pub doc: String,
    pub accumulate: Option<bool>,
}

/// A 1-D or 2-D map with plain (bi)linear interpolation held at the edge values outside its grid (contract §6,
/// `interp = "linear"`, `extrapolate = "clamp"`): exact, for `[outputs]` only.
#[derive(Debug, Clone)]
pub struct LinearMap {
    pub name: String,
    /// The arguments' names (one or two), for the docs.
    pub args: Vec<String>,
    pub x: Vec<f64>,
    /// The second argument's grid (empty for a 1-D map).
    pub y: Vec<f64>,
    /// 1-D: one value per x; 2-D: `len(x)` rows of `len(y)` values, row by row.
    pub values: Vec<f64>,
    pub unit: String,
    pub doc: String,
}

/// A signal of the generated model besides the road grade: its default and what it is.
#[derive(Debug, Clone)]
pub struct Signal {
    pub name: String,
    pub default: f64,
    pub unit: String,
    pub doc: String,
}

/// A state besides the speed: an internal state (zero dynamics) integrated from `initial`.
#[derive(Debug, Clone)]
pub struct State {
    pub name: String,
    pub rhs: String,
    pub initial: f64,
    pub unit: String,
    pub doc: String,
}

/// One input of a model with several (a hybrid's `[inputs.NAME]`): its bounds, unit and doc.
#[derive(Debug, Clone)]
pub struct Input {
    pub name: String,
    pub min: f64,
    pub max: f64,
    pub unit: String,
    pub doc: String,
}

/// A model under construction.
#[derive(Debug, Default)]
pub struct Model {
    pub name: String,
    pub description: String,
    pub header: Vec<String>,
    pub params: Vec<Param>,
    pub defs: Vec<Item>,
    pub outputs: Vec<Item>,
    pub maps: Vec<LinearMap>,
    pub signals: Vec<Signal>,
    /// Maps with `interp = "smooth"` (the kernel-smoothed linear interpolant, contract §6), which may enter
    /// a state's rhs.
    pub smooth_maps: Vec<LinearMap>,
    /// States besides the speed `v` (internal states: the output keeps relative degree 1).
    pub states: Vec<State>,
    /// The `[headline]` table's keys as TOML lines (`output = "fuel"`), empty for none.
    pub headline: Vec<String>,
    /// The inputs of a model with several (`[inputs.NAME]`); empty for the one input `F_t` (`[input]`).
    pub inputs: Vec<Input>,
    /// Tables after all others (a hybrid's `[sequence]`, `[modes.*]` and `[hybrid]`), as TOML text.
    pub tail: String,
}

impl Model {
    /// A parameter read from the FASTSim field `path` (its doc names the field), finite and in the field's
    /// physical range (`limits.rs`).
    pub fn field(
        &mut self,
        name: &str,
        value: f64,
        unit: &str,
        what: &str,
        path: &str,
    ) -> Result<(), ImportError> {
        if !value.is_finite() {
            return Err(ImportError::field(
                path,
                format!("{value} is not a finite number"),
            ));
        }
        crate::limits::check(path, value)?;
        self.params.push(Param {
            name: name.to_string(),
            value,
            unit: unit.to_string(),
            doc: format!("{what}; FASTSim `{path}`"),
        });
        Ok(())
    }

    /// A parameter that is a constant of FASTSim's physics (not a field of the vehicle file).
    pub fn constant(&mut self, name: &str, value: f64, unit: &str, doc: &str) {
        self.params.push(Param {
            name: name.to_string(),
            value,
            unit: unit.to_string(),
            doc: doc.to_string(),
        });
    }

    /// A definition.
    pub fn def(&mut self, name: &str, expr: &str, unit: &str, doc: &str) {
        self.defs.push(item(name, expr, unit, doc, None));
    }

    /// An extra output; `accumulate` integrates it over the run.
    pub fn output(&mut self, name: &str, expr: &str, unit: &str, doc: &str, accumulate: bool) {
        self.outputs
            .push(item(name, expr, unit, doc, Some(accumulate)));
    }

    /// The model's answer: the accumulated output `output`, of the fuel `fuel` (`None` for electric energy).
    pub fn headline(&mut self, output: &str, fuel: Option<&str>) {
        self.headline = vec![format!("output = {}", quote(output))];
        self.headline
            .extend(fuel.map(|f| format!("fuel = {}", quote(f))));
    }

    /// The TOML text of the model.
    pub fn render(&self) -> String {
        let mut s = String::new();
        for line in &self.header {
            s.push_str(&format!("# {}\n", comment(line)).replace("# \n", "#\n"));
        }
        s.push_str(&format!("name = {}\n", quote(&self.name)));
        s.push_str(&format!(
            "description = {}\n\n[parameters]\n",
            quote(&self.description)
        ));
        for p in &self.params {
            s.push_str(&format!(
                "{} = {{ value = {}, unit = {}, doc = {} }}\n",
                p.name,
                number(p.value),
                quote(&p.unit),
                quote(&p.doc)
            ));
        }
        s.push_str(SIGNALS);
        for g in &self.signals {
            s.push_str(&format!(
                "{} = {{ default = {}, unit = {}, doc = {} }}\n",
                g.name,
                number(g.default),
                quote(&g.unit),
                quote(&g.doc)
            ));
        }
        for m in &self.maps {
            s.push_str(&render_map(m, "linear"));
        }
        for m in &self.smooth_maps {
            s.push_str(&render_map(m, "smooth"));
        }
        s.push_str("\n[definitions]\n");
        for d in &self.defs {
            s.push_str(&render_item(d));
        }
        s.push_str(STATE);
        for x in &self.states {
            s.push_str(&format!(
                "{} = {{ rhs = {}, initial = {}, unit = {}, doc = {} }}\n",
                x.name,
                quote(&x.rhs),
                number(x.initial),
                quote(&x.unit),
                quote(&x.doc)
            ));
        }
        if self.inputs.is_empty() {
            s.push_str(INPUT);
        }
        for i in &self.inputs {
            s.push_str(&format!(
                "\n[inputs.{}]\nunit = {}\ndoc = {}\nmin = {}\nmax = {}\n",
                i.name,
                quote(&i.unit),
                quote(&i.doc),
                number(i.min),
                number(i.max)
            ));
        }
        s.push_str(OUTPUT);
        s.push_str("\n[outputs]\n");
        for o in &self.outputs {
            s.push_str(&render_item(o));
        }
        if !self.headline.is_empty() {
            s.push_str("\n[headline]                       # the model's answer, which the summary leads with\n");
            for line in &self.headline {
                s.push_str(line);
                s.push('\n');
            }
        }
        s.push_str(&self.tail);
        s
    }
}

/// The road grade, FASTSim's cycle field `grade`: from the cycle file's `grade` (or `cycGrade`) column, or
/// `--signal grade=…`, else 0.
const SIGNALS: &str = r#"
[signals]
grade = { default = 0.0, column = "grade", unit = "-", doc = "road grade, rise over run; FASTSim's cycle field `grade` (the cycle file's grade or cycGrade column, or --signal grade=...)" }
"#;

/// Vehicle speed driven by the tractive force at the wheels (FASTSim's road-load equation, quasi-static in
/// FASTSim; here the state of a relative-degree-one model).
const STATE: &str = r#"
[states]
v = { rhs = "(F_t - F_res)/m_eff", unit = "m/s", doc = "vehicle speed: m_eff dv/dt = F_t - F_res" }
"#;

/// The tractive force as the one input.
const INPUT: &str = r#"
[input]
name = "F_t"
unit = "N"
doc = "tractive force at the wheels; negative = braking"
"#;

/// The speed as output.
const OUTPUT: &str = r#"
[output]
name = "v"
h = "v"
unit = "m/s"
doc = "vehicle speed"
"#;

fn item(name: &str, expr: &str, unit: &str, doc: &str, accumulate: Option<bool>) -> Item {
    Item {
        name: name.to_string(),
        expr: expr.to_string(),
        unit: unit.to_string(),
        doc: doc.to_string(),
        accumulate,
    }
}

/// `[maps.NAME]` with its grid and values, `interp` (`linear` between the points, or `smooth`: that
/// interpolant smoothed by the kernel) and held at the end values outside.
fn render_map(m: &LinearMap, interp: &str) -> String {
    let list = |v: &[f64]| v.iter().map(|x| number(*x)).collect::<Vec<_>>().join(", ");
    let args = m
        .args
        .iter()
        .map(|a| quote(a))
        .collect::<Vec<_>>()
        .join(", ");
    let (y, values) = if m.y.is_empty() {
        (String::new(), format!("[{}]", list(&m.values)))
    } else {
        let rows: Vec<String> = m
            .values
            .chunks(m.y.len())
            .map(|row| format!("[{}]", list(row)))
            .collect();
        (
            format!("y = [{}]\n", list(&m.y)),
            format!("[{}]", rows.join(", ")),
        )
    };
    format!(
        "\n[maps.{}]\nargs = [{args}]\nx = [{}]\n{y}values = {values}\ninterp = \"{interp}\"\nextrapolate = \"clamp\"\nunit = {}\ndoc = {}\n",
        m.name,
        list(&m.x),
        quote(&m.unit),
        quote(&m.doc)
    )
}

fn render_item(i: &Item) -> String {
    let acc = match i.accumulate {
        Some(true) => ", accumulate = true",
        _ => "",
    };
    format!(
        "{} = {{ expr = {}, unit = {}{acc}, doc = {} }}\n",
        i.name,
        quote(&i.expr),
        quote(&i.unit),
        quote(&i.doc)
    )
}

/// A TOML float that reads back to the same f64 (Rust's shortest round-trip form).
pub fn number(x: f64) -> String {
    let s = format!("{x:?}");
    if s.contains(['.', 'e', 'E']) {
        s
    } else {
        format!("{s}.0")
    }
}

/// A TOML basic string (TOML 1.0 §String): `"` and `\` escaped, every control character (C0, DEL, C1) as
/// `\uXXXX`, so that any text (a vehicle name with line breaks or quotes) stays one string.
pub fn quote(s: &str) -> String {
    let mut out = String::from("\"");
    for c in s.chars() {
        match c {
            '"' => out.push_str("\\\""),
            '\\' => out.push_str("\\\\"),
            c if c.is_control() => out.push_str(&format!("\\u{:04x}", c as u32)),
            c => out.push(c),
        }
    }
    out.push('"');
    out
}

/// The text of a TOML comment line: a comment ends at the line break and may hold no control character but
/// tab (TOML 1.0 §Comment), so every other control character is written as `\uXXXX` (a vehicle name or a
/// file name with a line break cannot end the comment and add TOML).
pub fn comment(s: &str) -> String {
    let mut out = String::with_capacity(s.len());
    for c in s.chars() {
        if c.is_control() && c != '\t' {
            out.push_str(&format!("\\u{:04x}", c as u32));
        } else {
            out.push(c);
        }
    }
    out
}
