//! The sensitivities' matrices from the model's closed-form partial derivatives in normal-form coordinates
//! (`InverseModel::zero_dynamics_jacobian`, `InverseModel::outputs_jacobian`), where it has them: at a point
//! (ξ, η, w, y^(r)) of the run, for rows q (the zero dynamics dη/dt = q(ξ, η, w, y^(r); p), or the extra
//! outputs o(ξ, η, w, y^(r); p)),
//!
//! ```text
//! A = ∂q/∂η (m × ne),   B = ∂q/∂p (m × P, the parameters asked for),   R = ∂q/∂(ξ, y^(r)) (m × (r + 1))
//! ```
//!
//! in one evaluation of generated (or interpreted) code — the numbers [`super::Point::row_jacobians`]
//! assembles from the partial derivatives in the states by the implicit function theorem, which stays the
//! route for a ψ⁻¹ or an input solved numerically and for a derivative with respect to a map's grid value or
//! a decided input (not a model parameter).

use invsim_model_api::InverseModel;

/// Which rows, where: the zero dynamics (all n_η) at (ξ, η, w, y^(r)), or the extra outputs listed (indices
/// into the model's) at the point (x, w, u).
#[derive(Clone, Copy)]
pub(crate) enum Rows<'a> {
    ZeroDynamics(&'a [f64], &'a [f64], &'a [f64], f64),
    Outputs(&'a [f64], &'a [f64], f64, &'a [usize]),
}

/// The matrices of [`ClosedJacobian::eval`]: A, B and, where asked, R.
pub(crate) type Matrices<'o> = (&'o mut [f64], &'o mut [f64], Option<&'o mut [f64]>);

/// The buffer of one evaluation, reused from point to point.
#[derive(Default)]
pub(crate) struct ClosedJacobian {
    buf: Vec<f64>,
}

impl ClosedJacobian {
    /// A, B and (where asked) R of `rows` into `a`, `b` and `reference`, column-major
    /// (entry (i, j) of a matrix of m rows at j·m + i), B's column c that of `params[c]` (a model parameter's
    /// index; `None`: a zero column). False, with nothing written, where the model has no closed form for the
    /// rows or a column is not a model parameter's.
    pub(crate) fn eval<M: InverseModel + ?Sized>(
        &mut self,
        model: &M,
        (rows, params): (Rows<'_>, &[Option<usize>]),
        (a, b, reference): Matrices<'_>,
    ) -> bool {
        let info = model.info();
        let (ne, r, np) = (info.n_eta, info.relative_degree, info.parameters.len());
        if params.iter().flatten().any(|&k| k >= np) {
            return false;
        }
        let width = ne + r + 1 + np;
        let evaluated = match rows {
            Rows::ZeroDynamics(xi, eta, w, yr) => {
                self.buf.resize(ne * width, 0.0);
                model.zero_dynamics_jacobian(xi, eta, w, yr, &mut self.buf)
            }
            Rows::Outputs(x, w, u, _) => {
                self.buf.resize(info.outputs.len() * width, 0.0);
                model.outputs_jacobian(x, w, u, &mut self.buf)
            }
        };
        if !evaluated {
            return false;
        }
        let picked = |i: usize| match rows {
            Rows::ZeroDynamics(..) => i,
            Rows::Outputs(.., o) => o[i],
        };
        let m = match rows {
            Rows::ZeroDynamics(..) => ne,
            Rows::Outputs(.., o) => o.len(),
        };
        if m == 1 {
            // One row (one internal state, one accumulated output): the matrices are the row's pieces.
            let row = &self.buf[picked(0) * width..(picked(0) + 1) * width];
            a[..ne].copy_from_slice(&row[..ne]);
            for (v, k) in b.iter_mut().zip(params) {
                *v = match *k {
                    Some(k) => row[ne + r + 1 + k],
                    None => 0.0,
                };
            }
            if let Some(reference) = reference {
                reference[..=r].copy_from_slice(&row[ne..=ne + r]);
            }
            return true;
        }
        let mut reference = reference;
        for i in 0..m {
            // ∂q_i/∂(η, ξ, y^(r), p).
            let row = &self.buf[picked(i) * width..(picked(i) + 1) * width];
            for (j, &v) in row[..ne].iter().enumerate() {
                a[j * m + i] = v;
            }
            for (c, k) in params.iter().enumerate() {
                b[c * m + i] = k.map_or(0.0, |k| row[ne + r + 1 + k]);
            }
            if let Some(reference) = reference.as_deref_mut() {
                for (l, &v) in row[ne..=ne + r].iter().enumerate() {
                    reference[l * m + i] = v;
                }
            }
        }
        true
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gradient::{GridColumns, Point};

    /// At points off the equilibrium, A, B and R of the zero dynamics and of the extra outputs from the closed
    /// form equal those the implicit function theorem assembles from the partial derivatives in the states,
    /// every parameter's column, compiled and interpreted.
    #[test]
    fn the_closed_form_equals_the_implicit_function_theorem() {
        let compiled = invsim_models::builtin("driveline").expect("built in");
        let file = concat!(env!("CARGO_MANIFEST_DIR"), "/../../models/driveline.toml");
        let derived = invsim_inversion::derive_file(std::path::Path::new(file)).expect("derives");
        let interpreted = invsim_inversion::Interpreter::new(&derived).expect("interprets");
        for model in [compiled.as_ref(), &interpreted as &dyn InverseModel] {
            let info = model.info();
            let (n, ne, r, np) = (
                info.n_states(),
                info.n_eta,
                info.relative_degree,
                info.parameters.len(),
            );
            for x in [
                [80.0, 0.01, 16.0, 0.002, 4.8],
                [200.0, -0.02, 40.1, -0.001, 12.0],
            ] {
                let (mut xi, mut eta) = (vec![0.0; r], vec![0.0; ne]);
                model.psi(&x, &[], &mut xi, &mut eta);
                let yr = 0.3;
                let mut xs = vec![0.0; n];
                let u = model.invert(&xi, &eta, &[], yr, &mut xs).expect("inverts");
                let at = (&info.eta_states[..], &GridColumns::default());
                let point =
                    Point::new(model, (&xs, &[], u), at, Default::default()).expect("a point");
                let columns: Vec<Option<usize>> = (0..np).map(Some).collect();
                let l = point.layout();
                let eta_rows: Vec<usize> = (0..ne).map(|i| l.eta(i)).collect();
                let output_rows: Vec<usize> =
                    (0..info.outputs.len()).map(|o| l.output(o)).collect();
                let outputs: Vec<usize> = (0..info.outputs.len()).collect();
                for (rows, closed_rows) in [
                    (&eta_rows, Rows::ZeroDynamics(&xi, &eta, &[], yr)),
                    (&output_rows, Rows::Outputs(&xs, &[], u, &outputs)),
                ] {
                    // A, B and R by the implicit function theorem, then by the closed form.
                    let m = rows.len();
                    let sizes = [m * ne, m * np, m * (r + 1)];
                    let mut ifp: Vec<Vec<f64>> = sizes.iter().map(|&k| vec![0.0; k]).collect();
                    let [a0, b0, r0] = &mut ifp[..] else {
                        unreachable!()
                    };
                    point.moved_row_jacobians(rows, &columns, (a0, b0), r0);
                    let mut cf: Vec<Vec<f64>> = sizes.iter().map(|&k| vec![0.0; k]).collect();
                    let [a1, b1, r1] = &mut cf[..] else {
                        unreachable!()
                    };
                    let mut closed = ClosedJacobian::default();
                    let abr = (&mut a1[..], &mut b1[..], Some(&mut r1[..]));
                    assert!(closed.eval(model, (closed_rows, &columns), abr));
                    // Column by column (each its own unit), within 1e-9 of the column's largest entry.
                    let all = |v: &[Vec<f64>]| -> Vec<Vec<f64>> {
                        v.iter()
                            .flat_map(|c| c.chunks_exact(m).map(<[f64]>::to_vec))
                            .collect()
                    };
                    for (c, (c0, c1)) in all(&ifp).iter().zip(all(&cf)).enumerate() {
                        let scale = c0.iter().fold(0.0f64, |m, v| m.max(v.abs()));
                        for (v0, v1) in c0.iter().zip(&c1) {
                            assert!(
                                (v0 - v1).abs() <= 1e-9 * scale,
                                "{} rows {rows:?} column {c}: {v0:e} against {v1:e} (scale {scale:e})",
                                info.name
                            );
                        }
                    }
                }
            }
        }
    }
}
