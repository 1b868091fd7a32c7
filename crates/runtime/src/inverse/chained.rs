//! The inverse of a block of independent samples chained to the block before it: the previous block's last
//! state and input are the first sample's guesses (a numerically solved ψ⁻¹, an input solved by Newton's
//! method), so that blocks solve as one run does (the run's and the gradient's passes).

use invsim_model_api::InverseModel;

/// A block's columns for [`InverseModel::invert_batch`]: ξ, η, the signals and y^(r).
pub(crate) type InverseColumns<'a> = (&'a [&'a [f64]], &'a [&'a [f64]], &'a [&'a [f64]], &'a [f64]);

/// [`InverseModel::invert_batch`] on a block whose first sample starts from `last` (the previous block's last
/// state and input: the guesses of a numerically solved ψ⁻¹ and of an input solved by Newton's method), then
/// `last` set to this block's last sample: blocks chained as one run (the run's and the gradient's pass).
pub(crate) fn invert_chained<M: InverseModel + ?Sized>(
    model: &M,
    (xi, eta, w, yr): InverseColumns<'_>,
    (x, u): (&mut [&mut [f64]], &mut [f64]),
    (x_last, u_last): (&mut [f64], &mut f64),
) -> Result<(), (usize, invsim_model_api::ModelError)> {
    for (c, &v) in x.iter_mut().zip(x_last.iter()) {
        c[0] = v;
    }
    if let Some(u0) = u.first_mut() {
        *u0 = *u_last;
    }
    model.invert_batch(xi, eta, w, yr, x, u)?;
    let len = u.len();
    for (v, c) in x_last.iter_mut().zip(x.iter()) {
        *v = c[len - 1];
    }
    *u_last = u[len - 1];
    Ok(())
}
