//! Which per-point functions a model's module defines, with their arguments, the expressions they compute,
//! their result shapes and their documentation. Mirrors the interpreter (`invsim_inversion::Interpreter`):
//!
//! * ψ⁻¹ in closed form: `psi_inv`, `alpha`, `beta`, `invert` and `zero_dynamics` are evaluated in (ξ, η);
//! * ψ⁻¹ solved numerically: `psi_jacobian` (ψ and ∂ψ/∂x, for Newton's method in `newton`), and α, β and
//!   the zero dynamics in the states (L_f^r h, L_g L_f^(r−1) h, f_η + g_η·u);
//! * ψ⁻¹ solved numerically and y^(r) not affine in u: `psi_jacobian`, and φ(x, w, u) = D^r h with ∂φ/∂u,
//!   the input solution where u was isolated and the zero dynamics in the states (`solve_input`).

use super::context::{Arg, FnKind, Gen, Shape, Straight};
use super::docs::{equations, Lhs};
use invsim_expr::{latex_symbol, Id, Symbol};
use invsim_inversion::Solution;

/// The straight-line functions of this model.
pub(super) fn functions(g: &Gen<'_>) -> Vec<Straight> {
    let lhs = Lhs::new(g);
    let m = &g.d.model;
    let mut doc = vec![
        format!("The tracked output y = h(x) (`{}`).", m.output.name),
        String::new(),
    ];
    doc.extend(equations(g, &[("y".into(), "y".into())], &[m.output.h]));
    let mut fs = vec![Straight::new(
        FnKind::H,
        g.with_w(vec![g.x_arg()]),
        vec![m.output.h],
        Shape::Scalar,
        doc,
    )];
    let mut doc = vec![
        "Normal-form coordinates (ξ, η) = ψ(x): ξ_k = L_f^(k−1) h for k = 1 … r, η the internal states."
            .to_string(),
        String::new(),
    ];
    doc.extend(equations(g, &lhs.psi(), &g.d.psi));
    fs.push(Straight::new(
        FnKind::Psi,
        g.with_w(vec![g.x_arg()]),
        g.d.psi.clone(),
        Shape::Tuple(vec![
            Shape::array("R", g.d.relative_degree),
            Shape::array("N_ETA", g.d.eta.len()),
        ]),
        doc,
    ));
    if g.closed && !g.affine {
        fs.extend(non_affine(g, &lhs));
    } else if g.closed {
        fs.extend(closed(g, &lhs));
    } else if g.affine {
        fs.extend(numeric(g, &lhs));
    } else {
        fs.extend(numeric_non_affine(g, &lhs));
    }
    fs.extend(original(g, &lhs));
    fs
}

/// `beta`'s or `beta_x`'s description, with the model's singular set.
fn beta_doc(g: &Gen<'_>, first: &str, e: Id) -> Vec<String> {
    let mut doc = vec![first.to_string()];
    if !g.d.singular.is_empty() {
        doc.push(String::new());
        doc.push(format!("Vanishes {}.", g.d.singular.join("; ")));
    }
    doc.push(String::new());
    doc.extend(equations(g, &[("beta".into(), "\\beta".into())], &[e]));
    doc
}

/// ψ⁻¹ in closed form, in (ξ, η), and its roots.
fn psi_inv(g: &Gen<'_>, lhs: &Lhs) -> (Straight, Vec<Id>) {
    let d = g.d;
    let n = d.n();
    let inv: Vec<Id> = d
        .psi_inv
        .iter()
        .filter_map(|s| match s {
            Solution::Closed(e) => Some(*e),
            Solution::Numeric => None,
        })
        .collect();
    let xi_eta = || g.with_w(vec![g.xi_arg(), g.eta_arg()]);
    let mut doc =
        vec!["The states at normal-form coordinates: x = ψ⁻¹(ξ, η), in closed form.".to_string()];
    if !d.domain.is_empty() {
        doc.push(String::new());
        doc.push(format!("Valid where: {}.", d.domain.join("; ")));
    }
    doc.push(String::new());
    doc.extend(equations(g, &lhs.states, &inv));
    let f = Straight::new(
        FnKind::PsiInv,
        xi_eta(),
        inv.clone(),
        Shape::array("N", n),
        doc,
    );
    (f, inv)
}

/// The functions of a closed-form ψ⁻¹, evaluated in (ξ, η).
fn closed(g: &Gen<'_>, lhs: &Lhs) -> Vec<Straight> {
    let d = g.d;
    let n = d.n();
    let xi_eta = || g.with_w(vec![g.xi_arg(), g.eta_arg()]);
    let (f, inv) = psi_inv(g, lhs);
    let mut fs = vec![f];
    let mut doc = vec![
        "α(ξ, η) = L_f^r h ∘ ψ⁻¹, the drift term of y^(r) = α(ξ, η) + β(ξ, η)·u.".to_string(),
        String::new(),
    ];
    doc.extend(equations(
        g,
        &[("alpha".into(), "\\alpha".into())],
        &[d.alpha],
    ));
    fs.push(Straight::new(
        FnKind::Alpha,
        xi_eta(),
        vec![d.alpha],
        Shape::Scalar,
        doc,
    ));
    let doc = beta_doc(
        g,
        "β(ξ, η) = L_g L_f^(r−1) h ∘ ψ⁻¹, the gain of the input in y^(r) = α + β·u.",
        d.beta,
    );
    fs.push(Straight::new(
        FnKind::Beta,
        xi_eta(),
        vec![d.beta],
        Shape::Scalar,
        doc,
    ));
    let mut roots = inv;
    roots.push(d.alpha);
    roots.push(d.beta);
    fs.push(Straight::new(
        FnKind::Invert,
        xi_eta(),
        roots,
        Shape::Tuple(vec![Shape::array("N", n), Shape::Scalar, Shape::Scalar]),
        invert_doc(),
    ));
    if !d.eta.is_empty() {
        let mut doc = vec![
            "The zero dynamics dη/dt = L_f η + L_g η · (y^(r) − α)/β in (ξ, η, y^(r)).".to_string(),
            String::new(),
        ];
        doc.extend(equations(g, &lhs.deta, &d.zero_dynamics));
        let mut args = xi_eta();
        args.push(Arg::Scalar(d.yr));
        fs.push(Straight::new(
            FnKind::ZeroDynamics,
            args.clone(),
            d.zero_dynamics.clone(),
            Shape::array("N_ETA", d.eta.len()),
            doc,
        ));
        if let Some(jacobian) = &d.zero_dynamics_jacobian {
            let doc = vec![
                "The partial derivatives of the zero dynamics dη/dt = q(ξ, η, y^(r)) with respect to η_1 … η_(n−r), \
                 ξ_1 … ξ_r, y^(r) and every parameter, row-major (a row per internal state): the sensitivity \
                 equations' matrices dS/dt = (∂q/∂η) S + ∂q/∂p of the runtime's gradient, and the reference's \
                 columns. The equations are the derivatives of those `zero_dynamics` documents."
                    .to_string(),
            ];
            fs.push(Straight::new(
                FnKind::ZeroDynamicsJacobian,
                args.clone(),
                jacobian.clone(),
                Shape::array("N_ZDJ", jacobian.len()),
                doc,
            ));
        }
        if let Some(coefficients) = &d.zero_dynamics_affine {
            let doc = vec![
                "The zero dynamics dη/dt = q(ξ, η, y^(r)) are affine in η, q = A η + b: ∂q/∂η row-major (A, free \
                 of η) then q, which at η = 0 are A and b (the runtime's variation of constants reads both from \
                 one evaluation). The equations are the derivatives of those `zero_dynamics` documents."
                    .to_string(),
            ];
            fs.push(Straight::new(
                FnKind::ZeroDynamicsAffine,
                args,
                coefficients.clone(),
                Shape::array("N_ZDA", coefficients.len()),
                doc,
            ));
        }
    }
    fs
}

/// The functions of a closed-form ψ⁻¹ whose y^(r) = φ(ξ, η, w, u) is not affine in u: ψ⁻¹, φ with ∂φ/∂u
/// (for Newton's method, `solve_input.rs`), the input solution where u was isolated, and the zero dynamics
/// in (ξ, η, y^(r), u) (free of u where the input solution is substituted).
fn non_affine(g: &Gen<'_>, lhs: &Lhs) -> Vec<Straight> {
    let d = g.d;
    let first = psi_inv(g, lhs).0;
    let coords = PhiCoords {
        args: g.with_w(vec![g.xi_arg(), g.eta_arg()]),
        kinds: [FnKind::Phi, FnKind::InputSolution, FnKind::ZeroDynamics],
        phi: [d.alpha, d.beta],
        solution: d.input_solution,
        zero_dynamics: &d.zero_dynamics,
        texts: [
            "y^(r) = φ(ξ, η, u), not affine in the input, and ∂φ/∂u, the derivative Newton's method takes.",
            "The input that gives y^(r) = `yr`, φ(ξ, η, u) = y^(r) solved for u by isolation.",
            "The zero dynamics dη/dt = rhs_η(x, u) at x = ψ⁻¹(ξ, η) and the input u that gives y^(r).",
        ],
        with_domain: true,
    };
    phi_functions(g, lhs, first, coords)
}

/// Where φ, its input solution and the zero dynamics of a non-affine y^(r) are written: in (ξ, η) with a
/// closed-form ψ⁻¹, or in the states with a numeric one; the functions' kinds, expressions and first doc
/// lines.
struct PhiCoords<'a> {
    args: Vec<Arg>,
    /// φ with ∂φ/∂u, the input solution, the zero dynamics.
    kinds: [FnKind; 3],
    phi: [Id; 2],
    solution: Option<Id>,
    zero_dynamics: &'a [Id],
    texts: [&'static str; 3],
    /// The input solution's doc lists where it is valid (the isolation's domain, found in (ξ, η)).
    with_domain: bool,
}

/// `first` (ψ⁻¹ or ψ's Jacobian), then φ with ∂φ/∂u, the input solution where u was isolated, and the zero
/// dynamics, in the coordinates of `c`.
fn phi_functions(g: &Gen<'_>, lhs: &Lhs, first: Straight, c: PhiCoords<'_>) -> Vec<Straight> {
    let d = g.d;
    let u = d.model.input.symbol;
    let with = |extra: &[Symbol]| {
        let mut args = c.args.clone();
        args.extend(extra.iter().map(|&s| Arg::Scalar(s)));
        args
    };
    let mut fs = vec![first];
    let mut doc = vec![c.texts[0].to_string()];
    if !d.singular.is_empty() {
        doc.push(String::new());
        doc.push(format!("∂φ/∂u vanishes {}.", d.singular.join("; ")));
    }
    doc.push(String::new());
    let names = [
        ("phi".into(), "\\varphi".into()),
        (
            "dphi_du".into(),
            "\\frac{\\partial \\varphi}{\\partial u}".into(),
        ),
    ];
    doc.extend(equations(g, &names, &c.phi));
    fs.push(Straight::new(
        c.kinds[0],
        with(&[u]),
        c.phi.to_vec(),
        Shape::Tuple(vec![Shape::Scalar, Shape::Scalar]),
        doc,
    ));
    if let Some(sol) = c.solution {
        let mut doc = vec![c.texts[1].to_string()];
        if c.with_domain && !d.domain.is_empty() {
            doc.push(String::new());
            doc.push(format!("Valid where: {}.", d.domain.join("; ")));
        }
        doc.push(String::new());
        doc.extend(equations(g, &[("u".into(), "u".into())], &[sol]));
        fs.push(Straight::new(
            c.kinds[1],
            with(&[d.yr]),
            vec![sol],
            Shape::Scalar,
            doc,
        ));
    }
    if !d.eta.is_empty() {
        let mut doc = vec![c.texts[2].to_string(), String::new()];
        doc.extend(equations(g, &lhs.deta, c.zero_dynamics));
        fs.push(Straight::new(
            c.kinds[2],
            with(&[d.yr, u]),
            c.zero_dynamics.to_vec(),
            Shape::array("N_ETA", d.eta.len()),
            doc,
        ));
    }
    fs
}

/// The fused inverse's description (paper eq. 26).
fn invert_doc() -> Vec<String> {
    vec![
        "The inverse at one point (paper eq. 26): x = ψ⁻¹(ξ, η) and the input that gives the output \
         derivative y^(r) = `yr`, with ψ⁻¹, α and β evaluated together."
            .to_string(),
        String::new(),
        "```text".into(),
        "u = (yr - alpha)/beta".into(),
        "```".into(),
        String::new(),
        "```math".into(),
        "u = \\frac{y^{(r)} - \\alpha(\\xi, \\eta)}{\\beta(\\xi, \\eta)}".into(),
        "```".into(),
    ]
}

/// ψ(x) and its Jacobian, for Newton's method on ψ(x) = (ξ, η).
fn psi_jacobian(g: &Gen<'_>, lhs: &Lhs) -> Straight {
    let d = g.d;
    let n = d.n();
    let psi_lhs = lhs.psi();
    let mut roots = d.psi.clone();
    let mut eq_lhs = psi_lhs.clone();
    for (i, row) in d.jacobian.iter().enumerate() {
        roots.extend(row.iter().copied());
        for st in g.state_syms() {
            eq_lhs.push((
                format!("d({})/d({})", psi_lhs[i].0, g.name(st)),
                format!(
                    "\\frac{{\\partial {}}}{{\\partial {}}}",
                    psi_lhs[i].1,
                    latex_symbol(g.name(st))
                ),
            ));
        }
    }
    let mut doc = vec![
        "ψ(x) and its Jacobian ∂ψ/∂x (row i = ∂ψ_i/∂x), for Newton's method on ψ(x) = (ξ, η)."
            .to_string(),
        String::new(),
    ];
    doc.extend(equations(g, &eq_lhs, &roots));
    Straight::new(
        FnKind::PsiJacobian,
        g.with_w(vec![g.x_arg()]),
        roots,
        Shape::Tuple(vec![
            Shape::array("N", n),
            Shape::Array("N", n, Box::new(Shape::array("N", n))),
        ]),
        doc,
    )
}

/// The functions of a numeric ψ⁻¹, evaluated in the states.
fn numeric(g: &Gen<'_>, lhs: &Lhs) -> Vec<Straight> {
    let d = g.d;
    let jacobian = psi_jacobian(g, lhs);
    // ψ, ∂ψ/∂x, α and β in one function: Newton's iteration along a block (`invert_batch`) evaluates it, so
    // that α and β at the solution come with the last iteration's shared subexpressions.
    let mut roots = jacobian.roots.clone();
    roots.extend([d.alpha_x, d.beta_x]);
    let n = d.n();
    let fused = Straight::new(
        FnKind::PsiJacobianAlphaBeta,
        g.with_w(vec![g.x_arg()]),
        roots,
        Shape::Tuple(vec![
            Shape::array("N", n),
            Shape::Array("N", n, Box::new(Shape::array("N", n))),
            Shape::Scalar,
            Shape::Scalar,
        ]),
        vec![
            "ψ(x), its Jacobian ∂ψ/∂x, α = L_f^r h(x) and β = L_g L_f^(r−1) h(x) in one pass: the numbers of \
             [`Precomputed::psi_jacobian`], [`Precomputed::alpha_x`] and [`Precomputed::beta_x`], for the Newton \
             iteration of [`Precomputed::invert_batch`]."
                .to_string(),
        ],
    );
    let mut fs = vec![jacobian, fused];
    let mut doc = vec!["α in the states: L_f^r h(x).".to_string(), String::new()];
    doc.extend(equations(
        g,
        &[("alpha".into(), "\\alpha".into())],
        &[d.alpha_x],
    ));
    fs.push(Straight::new(
        FnKind::AlphaX,
        g.with_w(vec![g.x_arg()]),
        vec![d.alpha_x],
        Shape::Scalar,
        doc,
    ));
    let doc = beta_doc(g, "β in the states: L_g L_f^(r−1) h(x).", d.beta_x);
    fs.push(Straight::new(
        FnKind::BetaX,
        g.with_w(vec![g.x_arg()]),
        vec![d.beta_x],
        Shape::Scalar,
        doc,
    ));
    if !d.eta.is_empty() {
        let mut doc = vec![
            "The zero dynamics in the states: dη/dt = f_η(x) + g_η(x)·(y^(r) − L_f^r h)/(L_g L_f^(r−1) h)."
                .to_string(),
            String::new(),
        ];
        doc.extend(equations(g, &lhs.deta, &d.zero_dynamics_x));
        fs.push(Straight::new(
            FnKind::ZeroDynamicsX,
            {
                let mut args = g.with_w(vec![g.x_arg()]);
                args.push(Arg::Scalar(d.yr));
                args
            },
            d.zero_dynamics_x.clone(),
            Shape::array("N_ETA", d.eta.len()),
            doc,
        ));
    }
    fs
}

/// The functions of a numeric ψ⁻¹ whose y^(r) = φ(x, w, u) is not affine in u, in the states (as the
/// interpreter: Newton's x = ψ⁻¹(ξ, η), then u from φ(x, w, u) = y^(r) at that x): ψ and its Jacobian, φ with
/// ∂φ/∂u, the input solution where u was isolated, and the zero dynamics in (x, w, y^(r), u) (free of u
/// where the input solution is substituted).
fn numeric_non_affine(g: &Gen<'_>, lhs: &Lhs) -> Vec<Straight> {
    let d = g.d;
    let coords = PhiCoords {
        args: g.with_w(vec![g.x_arg()]),
        kinds: [
            FnKind::PhiX,
            FnKind::InputSolutionX,
            FnKind::ZeroDynamicsX,
        ],
        phi: [d.alpha_x, d.beta_x],
        solution: d.input_solution_x,
        zero_dynamics: &d.zero_dynamics_x,
        texts: [
            "y^(r) = φ(x, u) = D^r h in the states, not affine in the input, and ∂φ/∂u, the derivative Newton's \
             method takes.",
            "The input that gives y^(r) = `yr`, φ(x, u) = y^(r) solved for u by isolation, in the states.",
            "The zero dynamics dη/dt = rhs_η(x, u) in the states, at the input u that gives y^(r).",
        ],
        with_domain: false,
    };
    phi_functions(g, lhs, psi_jacobian(g, lhs), coords)
}

/// The original model's functions: the right-hand side and the extra outputs.
fn original(g: &Gen<'_>, lhs: &Lhs) -> Vec<Straight> {
    let m = &g.d.model;
    let u = m.input.symbol;
    let rhs: Vec<Id> = m.states.iter().map(|s| s.rhs).collect();
    let mut doc = vec![
        format!(
            "The original model dx/dt = f(x) + g(x)·u, for forward simulation (u = `{}`).",
            m.input.name
        ),
        String::new(),
    ];
    doc.extend(equations(g, &lhs.dot, &rhs));
    let x_w_u = || {
        let mut args = g.with_w(vec![g.x_arg()]);
        args.push(Arg::Scalar(u));
        args
    };
    let mut fs = vec![Straight::new(
        FnKind::Rhs,
        x_w_u(),
        rhs,
        Shape::array("N", g.d.n()),
        doc,
    )];
    if !m.outputs.is_empty() {
        let outs: Vec<Id> = m.outputs.iter().map(|o| o.expr).collect();
        let mut doc = vec![
            "The extra outputs of the model's `[outputs]` table at (x, u).".to_string(),
            String::new(),
        ];
        doc.extend(equations(g, &lhs.outputs, &outs));
        fs.push(Straight::new(
            FnKind::Outputs,
            x_w_u(),
            outs,
            Shape::array("N_OUTPUTS", m.outputs.len()),
            doc,
        ));
    }
    fs.push(sensitivity(g, x_w_u()));
    if let Some(jacobian) = &g.d.outputs_jacobian {
        let doc = vec![
            "The partial derivatives of the extra outputs o(ψ⁻¹(ξ, η), u), u = (y^(r) − α)/β, with respect to \
             η_1 … η_(n−r), ξ_1 … ξ_r, y^(r) and every parameter, at ξ = ψ_ξ(x), η = x_η, y^(r) = α + β·u, \
             row-major (a row per output): the outputs' parameter derivatives of the runtime's gradient. The \
             equations are the derivatives of those `outputs` documents, in the normal-form coordinates."
                .to_string(),
        ];
        fs.push(Straight::new(
            FnKind::OutputsJacobian,
            x_w_u(),
            jacobian.clone(),
            Shape::array("N_OJ", jacobian.len()),
            doc,
        ));
    }
    fs
}

/// ∂/∂(x, u, p) of ψ_1 … ψ_r, y^(r) = φ, the internal states' right-hand sides and the outputs, and ∂/∂[c] by
/// each map call c with the calls' arguments (the derivation's `sensitivity`, laid out as
/// `invsim_model_api::SensitivityLayout`); the equations are the derivatives of those the other functions
/// document, so the doc does not repeat them.
fn sensitivity(g: &Gen<'_>, args: Vec<Arg>) -> Straight {
    let doc = vec![
        "The partial derivatives of ψ_1 … ψ_r, y^(r) = φ(x, u), the internal states' right-hand sides and the \
         extra outputs with respect to x_1 … x_n, u, every parameter and every map call, row-major, then the map \
         calls' arguments (the layout of `invsim_model_api::SensitivityLayout`): the runtime's parameter \
         sensitivities combine them by the implicit function theorem."
            .to_string(),
    ];
    Straight::new(
        FnKind::Sensitivity,
        args,
        g.d.sensitivity.clone(),
        Shape::array("N_SENS", g.d.sensitivity.len()),
        doc,
    )
}
