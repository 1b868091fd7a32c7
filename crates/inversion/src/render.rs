//! Rendering a [`Derivation`] as JSON (the contract's `derive --format json`), plain text and Markdown
//! (the derived-equation documents in `docs/models/`).

mod maps;
mod modes;

pub use modes::{coupling_text, modal_title, mode_heading};

use crate::derive::{Derivation, Solution};
use invsim_expr::{latex_symbol, DecidedBy, Id, TooLarge};
use serde_json::{json, Map, Value};
use std::fmt::Write as _;

fn decided(d: DecidedBy) -> &'static str {
    match d {
        DecidedBy::Canonical => "canonical form",
        DecidedBy::Expanded => "expansion",
        DecidedBy::Probing => "numeric probing",
    }
}

/// A derived expression is too large to print (`derive` prints them all; `simulate` prints none).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error(
    "{file}: {quantity} is too large to print: {source}; the model's definitions or its derivatives grow \
     too much (a definition that uses the previous one several times doubles or triples the written-out \
     size at every step); `invsim simulate` evaluates it without printing, `derive` cannot show it"
)]
pub struct TooLargeToPrint {
    pub file: String,
    /// The quantity, as `derive` names it (`L_f^2 h`, `alpha`, `psi_inv of x`, …).
    pub quantity: String,
    pub source: TooLarge,
}

impl Derivation {
    /// Every expression `derive` prints (text, JSON or Markdown), with its name.
    fn printed_quantities(&self) -> Vec<(String, Id)> {
        let m = &self.model;
        let r = self.relative_degree;
        let mut q: Vec<(String, Id)> = vec![("h".into(), m.output.h)];
        for st in &m.states {
            q.push((format!("f_{}", st.name), st.f));
            q.push((format!("g_{}", st.name), st.g));
        }
        q.extend(
            m.definitions
                .iter()
                .map(|d| (format!("definition `{}`", d.name), d.expr)),
        );
        q.extend(
            m.outputs
                .iter()
                .map(|o| (format!("output `{}`", o.name), o.expr)),
        );
        q.extend(
            self.lie
                .iter()
                .enumerate()
                .map(|(k, &e)| (format!("L_f^{k} h"), e)),
        );
        q.extend(
            self.lg_lie
                .iter()
                .enumerate()
                .map(|(k, &e)| (format!("L_g L_f^{k} h"), e)),
        );
        q.extend(
            self.psi[..r]
                .iter()
                .enumerate()
                .map(|(k, &e)| (format!("xi{}", k + 1), e)),
        );
        q.extend(
            self.psi[r..]
                .iter()
                .enumerate()
                .map(|(j, &e)| (format!("eta{}", j + 1), e)),
        );
        for (st, sol) in m.states.iter().zip(&self.psi_inv) {
            if let Solution::Closed(e) = sol {
                q.push((format!("psi_inv of {}", st.name), *e));
            }
        }
        q.push(("alpha".into(), self.alpha));
        q.push(("beta".into(), self.beta));
        q.extend(
            self.zero_dynamics
                .iter()
                .enumerate()
                .map(|(j, &e)| (format!("d(eta{})/dt", j + 1), e)),
        );
        q
    }

    /// Are all expressions that `derive` prints within the printing budget of `invsim_expr::limits`?
    /// O(1) per expression; call it before [`Derivation::to_json`], [`Derivation::to_text`] or
    /// [`Derivation::to_markdown`], which print a placeholder for an expression over the budget.
    pub fn check_printable(&self) -> Result<(), TooLargeToPrint> {
        for (mut quantity, e) in self.printed_quantities() {
            if let Err(source) = self.pool().printable(e) {
                // Name where it grew: the first definition already over the budget once inlined.
                let grown = self
                    .model
                    .definitions
                    .iter()
                    .find(|d| d.inlined != e && self.pool().printable(d.inlined).is_err());
                if let Some(d) = grown {
                    let _ = write!(
                        quantity,
                        " (it uses definition `{}`, which is already too large once the definitions \
                         it uses are inlined)",
                        d.name
                    );
                }
                return Err(TooLargeToPrint {
                    file: self.model.file.display().to_string(),
                    quantity,
                    source,
                });
            }
        }
        Ok(())
    }

    fn show(&self, e: Id) -> String {
        self.pool().display(e)
    }
    fn tex(&self, e: Id) -> String {
        self.pool().latex(e)
    }

    /// The contract's JSON form of `invsim derive` (section 3), plus `domain`, `lie_zero_tests`, the output's
    /// `reference` map, the classification of the zero dynamics at the nominal point and (models with maps) `maps`
    /// (`zero_dynamics_class`, `zero_dynamics_eigenvalues` as [re, im] pairs, `zero_dynamics_nominal`).
    pub fn to_json(&self) -> Value {
        let m = &self.model;
        let mut params = Map::new();
        for p in &m.parameters {
            params.insert(p.name.clone(), json!(p.value));
        }
        let mut psi_inv = Map::new();
        for (s, sol) in m.states.iter().zip(&self.psi_inv) {
            psi_inv.insert(
                s.name.clone(),
                match sol {
                    Solution::Closed(e) => Value::String(self.show(*e)),
                    Solution::Numeric => Value::Null,
                },
            );
        }
        let r = self.relative_degree;
        let c = self.classify();
        let mut out = json!({
            "name": m.name,
            "states": m.states.iter().map(|s| s.name.clone()).collect::<Vec<_>>(),
            "input": m.input.name,
            "output": m.output.name,
            "parameters": params,
            "relative_degree": r,
            "lie_derivatives": self.lie.iter().map(|&e| self.show(e)).collect::<Vec<_>>(),
            "decoupling": self.show(self.beta_x),
            "xi": self.psi[..r].iter().map(|&e| self.show(e)).collect::<Vec<_>>(),
            "eta": self.psi[r..].iter().map(|&e| self.show(e)).collect::<Vec<_>>(),
            "psi_inv": psi_inv,
            "alpha": self.show(self.alpha),
            "beta": self.show(self.beta),
            "zero_dynamics": self.zero_dynamics.iter().map(|&e| self.show(e)).collect::<Vec<_>>(),
            "singular": self.singular,
            "domain": self.domain,
            "lie_zero_tests": self.lg_lie.iter().zip(&self.lg_decided_by).enumerate().map(|(k, (&e, &d))| json!({
                "k": k, "lg_lf_k_h": self.show(e), "decided_by": decided(d)
            })).collect::<Vec<_>>(),
            "reference": { "offset": m.output.reference_offset, "scale": m.output.reference_scale },
            "zero_dynamics_class": c.class.as_str(),
            "zero_dynamics_eigenvalues": c.eigenvalues,
            "zero_dynamics_nominal": {
                "output": c.output,
                "yr": 0.0,
                "eta": c.eta,
                "note": c.note,
            },
            "warnings": self.warnings,
        });
        // Only models with maps carry the object (the others' output is unchanged).
        if !m.maps.is_empty() {
            if let Value::Object(o) = &mut out {
                o.insert("maps".into(), maps::maps_json(&m.maps));
            }
        }
        // Contract §5: the signals in file order (the key is left out for a model without signals, whose
        // output is unchanged).
        if !m.signals.is_empty() {
            out["signals"] = json!(m.signals.iter().map(|s| s.name.clone()).collect::<Vec<_>>());
        }
        // Contract §5: `affine`; a non-affine model has `yr_equation` and `input_solution` instead of α and β,
        // and its `lie_derivatives` stop at k = r − 1.
        out["affine"] = json!(self.affine);
        if !self.affine {
            if let Some(o) = out.as_object_mut() {
                o.remove("alpha");
                o.remove("beta");
            }
            out["yr_equation"] = json!(self.show(self.yr_equation.unwrap_or(self.alpha)));
            out["input_solution"] = match self.input_solution {
                Some(e) => json!(self.show(e)),
                None => Value::Null,
            };
            out["lie_derivatives"] = json!(self.lie[..r]
                .iter()
                .map(|&e| self.show(e))
                .collect::<Vec<_>>());
        }
        out
    }

    /// One line naming the signals, their defaults and columns (None without signals).
    fn signals_line(&self) -> Option<String> {
        let m = &self.model;
        (!m.signals.is_empty()).then(|| {
            let parts: Vec<String> = m
                .signals
                .iter()
                .map(|s| {
                    let default = s.default.map_or("none".to_string(), |d| d.to_string());
                    format!(
                        "{} (default {default}, column {})",
                        s.name,
                        s.column.as_deref().unwrap_or(&s.name)
                    )
                })
                .collect();
            format!(
                "signals w = {}; S_dk is the k-th time derivative of the smoothed signal S, and every Lie \
                 derivative is the total time derivative D",
                parts.join(", ")
            )
        })
    }

    /// The drive cycle → reference map of `[output]`, when it is not the identity.
    fn reference_line(&self) -> Option<String> {
        let o = &self.model.output;
        (o.reference_offset != 0.0 || o.reference_scale != 1.0).then(|| {
            format!(
                "reference from a drive cycle: y_d = {} + {} * (smoothed cycle speed in m/s)",
                o.reference_offset, o.reference_scale
            )
        })
    }

    /// One line on the zero dynamics at the nominal point (r < n only).
    fn classification_line(&self) -> Option<String> {
        if self.eta.is_empty() {
            return None;
        }
        let c = self.classify();
        let eigs: Vec<String> = c
            .eigenvalues
            .iter()
            .map(|&[re, im]| {
                if im == 0.0 {
                    format!("{re:.6e}")
                } else if im > 0.0 {
                    format!("{re:.6e} + {im:.6e}i")
                } else {
                    format!("{re:.6e} - {:.6e}i", -im)
                }
            })
            .collect();
        let at = if c.eta.is_empty() {
            format!("y = {}, y^(r) = 0", c.output)
        } else {
            let eta: Vec<String> = c.eta.iter().map(|v| format!("{v:.6e}")).collect();
            format!(
                "y = {}, y^(r) = 0, equilibrium eta = ({})",
                c.output,
                eta.join(", ")
            )
        };
        let mut line = format!("{} at {at}", c.class.as_str());
        if !eigs.is_empty() {
            line.push_str(&format!(
                "; eigenvalues of d(q)/d(eta): {}",
                eigs.join(", ")
            ));
        }
        if let Some(note) = c.note {
            line.push_str(&format!(" ({note})"));
        }
        Some(line)
    }

    /// A plain-text report of the derivation.
    pub fn to_text(&self) -> String {
        let m = &self.model;
        let r = self.relative_degree;
        let mut s = String::new();
        let _ = writeln!(s, "model {} ({})", m.name, m.file.display());
        let names: Vec<&str> = m.states.iter().map(|s| s.name.as_str()).collect();
        let _ = writeln!(
            s,
            "states x = ({}), input {}, output y = {}",
            names.join(", "),
            m.input.name,
            self.show(m.output.h)
        );
        if let Some(line) = self.reference_line() {
            let _ = writeln!(s, "{line}");
        }
        if let Some(line) = self.signals_line() {
            let _ = writeln!(s, "{line}");
        }
        if !m.maps.is_empty() {
            let _ = write!(
                s,
                "maps (values in --format json):\n{}",
                maps::maps_text(&m.maps)
            );
        }
        let _ = writeln!(s, "\nvector fields (definitions inlined):");
        for st in &m.states {
            let pool = &m.pool;
            if !st.affine && (pool.is_undefined(st.f) || pool.is_undefined(st.g)) {
                // Not affine in the input, and f or g at u = 0 undefined (g = k_T/(2·m·sqrt(P)) at P = 0):
                // the method uses the whole right-hand side, which is shown instead.
                let _ = writeln!(s, "  rhs_{} = {}", st.name, self.show(st.rhs));
                continue;
            }
            let _ = writeln!(s, "  f_{} = {}", st.name, self.show(st.f));
            let _ = writeln!(s, "  g_{} = {}", st.name, self.show(st.g));
        }
        let _ = writeln!(s, "\nLie derivatives:");
        for (k, &e) in self.lie.iter().enumerate() {
            let _ = writeln!(s, "  L_f^{k} h = {}", self.show(e));
        }
        for (k, (&e, &d)) in self.lg_lie.iter().zip(&self.lg_decided_by).enumerate() {
            let _ = writeln!(s, "  L_g L_f^{k} h = {}   [{}]", self.show(e), decided(d));
        }
        let _ = writeln!(s, "\nrelative degree r = {r} (n = {})", self.n());
        for k in 0..r {
            let _ = writeln!(s, "  xi{} = {}", k + 1, self.show(self.psi[k]));
        }
        for j in 0..self.eta.len() {
            let _ = writeln!(s, "  eta{} = {}", j + 1, self.show(self.psi[r + j]));
        }
        let _ = writeln!(s, "\ninverse coordinate change x = psi_inv(xi, eta):");
        for (st, sol) in m.states.iter().zip(&self.psi_inv) {
            match sol {
                Solution::Closed(e) => {
                    let _ = writeln!(s, "  {} = {}", st.name, self.show(*e));
                }
                Solution::Numeric => {
                    let _ = writeln!(s, "  {} = (solved numerically by Newton's method)", st.name);
                }
            }
        }
        if self.affine {
            let _ = writeln!(s, "\ny^(r) = alpha + beta*u:");
            let _ = writeln!(s, "  alpha = {}", self.show(self.alpha));
            let _ = writeln!(s, "  beta  = {}", self.show(self.beta));
        } else {
            let u = &m.input.name;
            let _ = writeln!(s, "\ny^(r) = yr, not affine in the input {u}:");
            let _ = writeln!(
                s,
                "  yr = {}",
                self.show(self.yr_equation.unwrap_or(self.alpha))
            );
            let _ = writeln!(s, "  d(yr)/d({u}) = {}", self.show(self.beta_x));
            match self.input_solution {
                Some(e) => {
                    let _ = writeln!(s, "  {u} = {}", self.show(e));
                }
                None => {
                    let _ = writeln!(s, "  {u} = (solved by Newton's method with d(yr)/d({u}))");
                }
            }
        }
        if !self.zero_dynamics.is_empty() {
            let _ = writeln!(s, "\nzero dynamics:");
            for (j, &q) in self.zero_dynamics.iter().enumerate() {
                let _ = writeln!(s, "  d(eta{})/dt = {}", j + 1, self.show(q));
            }
            if let Some(line) = self.classification_line() {
                let _ = writeln!(s, "  class: {line}");
            }
        }
        for d in &self.domain {
            let _ = writeln!(s, "domain: {d}");
        }
        for w in &self.warnings {
            let _ = writeln!(s, "warning: {w}");
        }
        s
    }

    /// The derived-equation document: the model as written and every step of the derivation, in Markdown
    /// with math GitHub renders.
    pub fn to_markdown(&self) -> String {
        let mut s = String::new();
        self.md_model(&mut s);
        self.md_tables(&mut s);
        self.md_vector_fields(&mut s);
        self.md_relative_degree(&mut s);
        self.md_coordinates(&mut s);
        self.md_input_output(&mut s);
        self.md_zero_dynamics(&mut s);
        self.md_notes(&mut s);
        s
    }

    /// The title, the source file and the model as written: states, input, output, reference.
    fn md_model(&self, s: &mut String) {
        let m = &self.model;
        let _ = writeln!(s, "# `{}` — derived equations\n", m.name);
        if let Some(d) = &m.description {
            let _ = writeln!(s, "{d}\n");
        }
        let file = m
            .file
            .file_name()
            .map(|f| f.to_string_lossy().to_string())
            .unwrap_or_default();
        let _ = writeln!(
            s,
            "Generated by `invsim` from `{file}` (sha256 `{}`). Regenerate with `cargo xtask docs`.\n",
            &m.source_hash
        );
        let _ = writeln!(s, "## The model as written\n");
        let _ = writeln!(s, "| state | unit | description |\n|---|---|---|");
        for st in &m.states {
            let _ = writeln!(
                s,
                "| ${}$ | {} | {} |",
                latex_symbol(&st.name),
                st.unit.as_deref().unwrap_or("–"),
                st.doc.as_deref().unwrap_or("")
            );
        }
        let bounds = match (m.input.min, m.input.max) {
            (Some(a), Some(b)) => format!(", bounds [{a}, {b}]"),
            (Some(a), None) => format!(", lower bound {a}"),
            (None, Some(b)) => format!(", upper bound {b}"),
            (None, None) => String::new(),
        };
        // `y = v` rather than `y = v = v` when the output is a state of the same name.
        let h_tex = self.tex(m.output.h);
        let y_tex = if h_tex == latex_symbol(&m.output.name) {
            h_tex
        } else {
            format!("{} = {h_tex}", latex_symbol(&m.output.name))
        };
        let _ = writeln!(
            s,
            "\nInput $u = {}$ ({}{}){}. Output $y = {}$ ({}){}.\n",
            latex_symbol(&m.input.name),
            m.input.unit.as_deref().unwrap_or("–"),
            bounds,
            m.input
                .doc
                .as_deref()
                .map(|d| format!(": {d}"))
                .unwrap_or_default(),
            y_tex,
            m.output.unit.as_deref().unwrap_or("–"),
            m.output
                .doc
                .as_deref()
                .map(|d| format!(": {d}"))
                .unwrap_or_default(),
        );
        if let Some(line) = self.reference_line() {
            let _ = writeln!(s, "{line}\n");
        }
    }

    /// The tables of parameters and extra outputs, and the definitions.
    fn md_tables(&self, s: &mut String) {
        let m = &self.model;
        if !m.parameters.is_empty() {
            let _ = writeln!(
                s,
                "| parameter | value | unit | description |\n|---|---|---|---|"
            );
            for p in &m.parameters {
                let _ = writeln!(
                    s,
                    "| ${}$ | {} | {} | {} |",
                    latex_symbol(&p.name),
                    p.value,
                    p.unit.as_deref().unwrap_or("–"),
                    p.doc.as_deref().unwrap_or("")
                );
            }
            s.push('\n');
        }
        if !m.signals.is_empty() {
            let _ = writeln!(
                s,
                "| signal | default | cycle column | unit | description |\n|---|---|---|---|---|"
            );
            for g in &m.signals {
                let _ = writeln!(
                    s,
                    "| ${}$ | {} | {} | {} | {} |",
                    latex_symbol(&g.name),
                    g.default.map_or("–".to_string(), |d| d.to_string()),
                    g.column.as_deref().unwrap_or(&g.name),
                    g.unit.as_deref().unwrap_or("–"),
                    g.doc.as_deref().unwrap_or("")
                );
            }
            let _ = writeln!(
                s,
                "\nSignals are exogenous: $S_{{dk}}$ is the $k$-th time derivative of the smoothed signal $S$, and \
                 every Lie derivative below is the total time derivative along the states and the signals.\n"
            );
        }
        if !m.maps.is_empty() {
            let _ = writeln!(
                s,
                "{}\nA map's partial derivatives print as derivative maps: $M_{{dIJ}}$ is \
                 $\\partial^{{I+J}} M / \\partial a^I \\partial b^J$ (1-D: $M_{{dK}}$).\n",
                maps::maps_markdown(&m.maps)
            );
        }
        if !m.outputs.is_empty() {
            let _ = writeln!(
                s,
                "| extra output | unit | integrated | expression |\n|---|---|---|---|"
            );
            for o in &m.outputs {
                let _ = writeln!(
                    s,
                    "| ${}$ | {} | {} | ${}$ |",
                    latex_symbol(&o.name),
                    o.unit.as_deref().unwrap_or("–"),
                    if o.accumulate { "yes" } else { "no" },
                    // A `|` (from abs) would end the table cell.
                    self.tex(o.expr).replace('|', "\\vert ")
                );
            }
            s.push('\n');
        }
        if !m.definitions.is_empty() {
            let _ = writeln!(
                s,
                "Definitions (inlined before any derivation):\n\n$$\n\\begin{{aligned}}"
            );
            for d in &m.definitions {
                let _ = writeln!(s, "{} &= {} \\\\", latex_symbol(&d.name), self.tex(d.expr));
            }
            let _ = writeln!(s, "\\end{{aligned}}\n$$\n");
        }
    }

    /// f, g and h with definitions inlined.
    fn md_vector_fields(&self, s: &mut String) {
        let m = &self.model;
        let _ = writeln!(s, "## Vector fields\n\n$\\dot x = f(x) + g(x)\\,u$ with definitions inlined:\n\n$$\n\\begin{{aligned}}");
        for st in &m.states {
            let _ = writeln!(
                s,
                "f_{{{}}} &= {} \\\\",
                latex_symbol(&st.name),
                self.tex(st.f)
            );
            let _ = writeln!(
                s,
                "g_{{{}}} &= {} \\\\",
                latex_symbol(&st.name),
                self.tex(st.g)
            );
        }
        let _ = writeln!(s, "h &= {}\n\\end{{aligned}}\n$$\n", self.tex(m.output.h));
    }

    /// L_f^k h, L_g L_f^k h and the relative degree with how each zero test was decided.
    fn md_relative_degree(&self, s: &mut String) {
        let r = self.relative_degree;
        let n = self.n();
        let _ = writeln!(
            s,
            "## Lie derivatives and relative degree\n\n$$\n\\begin{{aligned}}"
        );
        for (k, &e) in self.lie.iter().enumerate() {
            let _ = writeln!(s, "L_f^{{{k}}} h &= {} \\\\", self.tex(e));
        }
        for (k, &e) in self.lg_lie.iter().enumerate() {
            let _ = writeln!(s, "L_g L_f^{{{k}}} h &= {} \\\\", self.tex(e));
        }
        let _ = writeln!(s, "\\end{{aligned}}\n$$\n");
        let why: Vec<String> = self
            .lg_decided_by
            .iter()
            .enumerate()
            .map(|(k, d)| {
                let z = if k + 1 < r {
                    "is identically zero"
                } else {
                    "is not identically zero"
                };
                format!("$L_g L_f^{{{k}}} h$ {z} (decided by {})", decided(*d))
            })
            .collect();
        let _ = writeln!(
            s,
            "The relative degree is **r = {r}** (n = {n}): {}.\n",
            why.join("; ")
        );
    }

    /// ξ, η, ψ⁻¹ and the conditions under which it is valid.
    fn md_coordinates(&self, s: &mut String) {
        let m = &self.model;
        let r = self.relative_degree;
        let _ = writeln!(s, "## Normal-form coordinates\n\n$$\n\\begin{{aligned}}");
        for k in 0..r {
            let _ = writeln!(s, "\\xi_{{{}}} &= {} \\\\", k + 1, self.tex(self.psi[k]));
        }
        for j in 0..self.eta.len() {
            let _ = writeln!(
                s,
                "\\eta_{{{}}} &= {} \\\\",
                j + 1,
                self.tex(self.psi[r + j])
            );
        }
        let _ = writeln!(s, "\\end{{aligned}}\n$$\n");
        let _ = writeln!(
            s,
            "Inverse coordinate change $x = \\psi^{{-1}}(\\xi, \\eta)$:\n\n$$\n\\begin{{aligned}}"
        );
        for (st, sol) in m.states.iter().zip(&self.psi_inv) {
            match sol {
                Solution::Closed(e) => {
                    let _ = writeln!(s, "{} &= {} \\\\", latex_symbol(&st.name), self.tex(*e));
                }
                Solution::Numeric => {
                    let _ = writeln!(
                        s,
                        "{} &: \\text{{solved numerically (Newton)}} \\\\",
                        latex_symbol(&st.name)
                    );
                }
            }
        }
        let _ = writeln!(s, "\\end{{aligned}}\n$$\n");
        if !self.domain.is_empty() {
            let _ = writeln!(s, "Valid where:\n");
            for d in &self.domain {
                let _ = writeln!(s, "- `{d}`");
            }
            s.push('\n');
        }
    }

    /// α, β and the singular set.
    fn md_input_output(&self, s: &mut String) {
        if !self.affine {
            let solution = match self.input_solution {
                Some(e) => format!("$$\n u = {}\n$$\n", self.tex(e)),
                None => "$u$ is solved by Newton's method with the analytic $\\partial y^{(r)}/\\partial u$.\n"
                    .to_string(),
            };
            let _ = writeln!(
                s,
                "## Input–output form\n\nThe model is not affine in the input: $y^{{(r)}} = \\varphi(\\xi, \\eta, w, u)$ \
                 with\n\n$$\n\\begin{{aligned}}\n\\varphi &= {} \\\\\n\\partial\\varphi/\\partial u &= {}\n\\end{{aligned}}\n$$\n\n{solution}",
                self.tex(self.yr_equation.unwrap_or(self.alpha)),
                self.tex(self.beta_x)
            );
            return;
        }
        let _ = writeln!(
            s,
            "## Input–output form\n\n$y^{{(r)}} = \\alpha(\\xi, \\eta) + \\beta(\\xi, \\eta)\\,u$, so \
             $u = (y^{{(r)}} - \\alpha)/\\beta$:\n\n$$\n\\begin{{aligned}}\n\\alpha &= {} \\\\\n\\beta &= {}\n\\end{{aligned}}\n$$\n",
            self.tex(self.alpha),
            self.tex(self.beta)
        );
        if self.singular.is_empty() {
            let _ = writeln!(
                s,
                "β does not vanish: the inverse exists everywhere ψ⁻¹ is defined.\n"
            );
        } else {
            let _ = writeln!(s, "Singular set (β = 0):\n");
            for x in &self.singular {
                let _ = writeln!(s, "- {x}");
            }
            s.push('\n');
        }
    }

    /// The zero dynamics and their classification.
    fn md_zero_dynamics(&self, s: &mut String) {
        if self.zero_dynamics.is_empty() {
            let _ = writeln!(s, "## Zero dynamics\n\nNone: r = n.\n");
        } else {
            let _ = writeln!(s, "## Zero dynamics\n\n$$\n\\begin{{aligned}}");
            for (j, &q) in self.zero_dynamics.iter().enumerate() {
                let _ = writeln!(s, "\\dot\\eta_{{{}}} &= {} \\\\", j + 1, self.tex(q));
            }
            let _ = writeln!(s, "\\end{{aligned}}\n$$\n");
            if let Some(line) = self.classification_line() {
                let _ = writeln!(
                    s,
                    "Linearised at the nominal point (ξ = (y0, 0, …), y^(r) = 0, η at the equilibrium of the zero \
                     dynamics): **{line}**.\n"
                );
            }
        }
    }

    /// Warnings, the compiled code, and the plain form.
    fn md_notes(&self, s: &mut String) {
        if !self.warnings.is_empty() {
            let _ = writeln!(s, "## Notes\n");
            for w in &self.warnings {
                let _ = writeln!(s, "- {w}");
            }
            s.push('\n');
        }
        let _ = writeln!(
            s,
            "## Compiled code\n\n`cargo xtask gen` writes the Rust module generated from these equations (ψ, ψ⁻¹, α, β, \
             zero dynamics, f + g·u, outputs), each function documented with the equation it implements; models in \
             `models/` are compiled into the `invsim-models` crate and used by `invsim simulate` automatically.\n"
        );
        let _ = writeln!(s, "## Plain form\n\n```text\n{}```", self.to_text());
    }
}
