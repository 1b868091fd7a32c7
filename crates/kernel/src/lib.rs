//! invsim's C-infinity bump kernel (Fröberg & Nielsen 2004, eq. 33–35) and what is built from it: the
//! [`Kernel`] itself, used by the drive-cycle smoother and the signals, and the smooth lookup maps of
//! [`map`], the convolution of a (bi)linear interpolant with the same kernel.
//!
//! Modules, in the one direction their imports go: `construction` (the tables, also run by `build.rs`) →
//! `kernel` ([`Kernel`]) → [`map`] (1-D and 2-D maps: value and partial derivatives in one pass).

// The library itself only needs the derivative polynomials of orders above 32 from `construction`; the rest
// runs in build.rs and in the tests.
#[cfg_attr(not(test), allow(dead_code))]
mod construction;
mod kernel;
pub mod map;

pub use construction::UNIT_NORMALISATION;
pub use kernel::Kernel;
