//! The layout of [`crate::InverseModel::sensitivity`]: the partial derivatives, in the original states, from
//! which the runtime assembles the parameter sensitivities of a run by the chain rule.
//!
//! At one point (x, w, u) the model evaluates, for every parameter p_k of [`crate::ModelInfo::parameters`]:
//!
//! * ξ_i = ψ_i(x, w; p) = L_f^(i−1) h for i = 1 … r: ∂ψ_i/∂x and ∂ψ_i/∂p (the η rows of ψ are states,
//!   η_j = x_{eta_states[j]}, and depend on no parameter);
//! * y^(r) = φ(x, w, u; p) (= α_x + β_x·u where y^(r) is affine in u): ∂φ/∂x, ∂φ/∂u, ∂φ/∂p;
//! * the internal states' right-hand sides dη_j/dt = F_{eta_states[j]}(x, w, u; p): ∂F/∂x, ∂F/∂u, ∂F/∂p;
//! * every `[outputs]` entry o(x, w, u; p): ∂o/∂x, ∂o/∂u, ∂o/∂p;
//! * for each of these rows E and each map call c = M_dIJ(a_c, b_c) the rows contain
//!   ([`crate::ModelInfo::map_calls`]): ∂E/∂[c], the call treated as an independent symbol, and the calls'
//!   arguments (a_c, b_c) at the point;
//! * for each of these rows E and each signal S_j of [`crate::ModelInfo::signals`]: ∂E/∂S_j, the signal's
//!   value (its derivatives S_d1 … held): how a row moves with a decided input, which a mode takes as a signal.
//!
//! A map's value is linear in its grid values (M_dIJ(a, b) = Σ_ij v_ij Φ_i^(I)(a) Ψ_j^(J)(b), `crate::map`),
//! so a grid value v_ij is a parameter like the others, with the column
//! ∂E/∂v_ij = Σ_c ∂E/∂[c] · Φ_i^(I_c)(a_c) Ψ_j^(J_c)(b_c) (the weights of `Map::weights` at the arguments).
//!
//! Since x solves ψ(x; p) = (ξ, η) and u solves φ(x, u; p) = y^(r) with ξ, y^(r) and w given by the reference,
//! the implicit function theorem gives dx = (∂ψ/∂x)⁻¹ ((0, dη) − ∂ψ/∂p dp) and
//! du = −(∂φ/∂x dx + ∂φ/∂p dp)/(∂φ/∂u), whichever way the engine solves ψ⁻¹ and u (closed form or Newton).

/// One map call M_dIJ(a, b) of the sensitivity rows: the map (an index into [`crate::InverseModel::maps`])
/// and the derivative orders [I, J] (1-D: [K, 0]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct MapCall {
    pub map: usize,
    pub orders: [usize; 2],
}

/// Where each partial derivative sits in the flat, row-major slice [`crate::InverseModel::sensitivity`]
/// writes: [`SensitivityLayout::rows`] rows of [`SensitivityLayout::width`] columns, the columns ∂/∂x_1 …
/// ∂/∂x_n, ∂/∂u, ∂/∂p_1 … ∂/∂p_P, ∂/∂[c_1] … ∂/∂[c_C] (the map calls), ∂/∂S_1 … ∂/∂S_S (the signals' values);
/// the rows ψ_1 … ψ_r, φ, F_η1 … F_η(n−r),
/// o_1 … o_m (the ψ rows' ∂/∂u is 0); after the rows the calls' arguments a_1, b_1, …, a_C, b_C (b = 0 for a
/// 1-D map).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct SensitivityLayout {
    pub n: usize,
    pub r: usize,
    pub n_eta: usize,
    pub n_outputs: usize,
    pub n_params: usize,
    pub n_calls: usize,
    pub n_signals: usize,
}

impl SensitivityLayout {
    /// The layout of `info`'s model.
    pub fn of(info: &crate::ModelInfo) -> SensitivityLayout {
        SensitivityLayout {
            n: info.n_states(),
            r: info.relative_degree,
            n_eta: info.n_eta,
            n_outputs: info.outputs.len(),
            n_params: info.parameters.len(),
            n_calls: info.map_calls.len(),
            n_signals: info.signals.len(),
        }
    }

    /// Columns per row: n + 1 + P + C + S.
    pub fn width(&self) -> usize {
        self.n + 1 + self.n_params + self.n_calls + self.n_signals
    }

    /// Rows: r + 1 + (n − r) + m.
    pub fn rows(&self) -> usize {
        self.r + 1 + self.n_eta + self.n_outputs
    }

    /// Length of the slice: the rows, then two arguments per call.
    pub fn len(&self) -> usize {
        self.rows() * self.width() + 2 * self.n_calls
    }

    /// True for a layout without entries (never for a model: it has at least the φ row).
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Row of ψ_i (ξ_(i+1)), i < r.
    pub fn psi(&self, i: usize) -> usize {
        i
    }

    /// Row of φ.
    pub fn phi(&self) -> usize {
        self.r
    }

    /// Row of dη_j/dt.
    pub fn eta(&self, j: usize) -> usize {
        self.r + 1 + j
    }

    /// Row of the output o.
    pub fn output(&self, o: usize) -> usize {
        self.r + 1 + self.n_eta + o
    }

    /// Column of ∂/∂x_j.
    pub fn x(&self, j: usize) -> usize {
        j
    }

    /// Column of ∂/∂u.
    pub fn u(&self) -> usize {
        self.n
    }

    /// Column of ∂/∂p_k.
    pub fn param(&self, k: usize) -> usize {
        self.n + 1 + k
    }

    /// Column of ∂/∂[c], map call c.
    pub fn call(&self, c: usize) -> usize {
        self.n + 1 + self.n_params + c
    }

    /// Column of ∂/∂S_j, the value of signal j.
    pub fn signal(&self, j: usize) -> usize {
        self.n + 1 + self.n_params + self.n_calls + j
    }

    /// Index of call c's first argument a_c in the flat slice (b_c follows).
    pub fn arguments(&self, c: usize) -> usize {
        self.rows() * self.width() + 2 * c
    }

    /// Index of (row, column) in the flat slice.
    pub fn at(&self, row: usize, column: usize) -> usize {
        row * self.width() + column
    }
}
