//! The C-infinity bump kernel of Fröberg & Nielsen (2004), eq. 33–35: re-exported from `invsim-kernel`, the one
//! implementation that the drive-cycle smoother, the signals and the smooth lookup maps share.

pub use invsim_kernel::{Kernel, UNIT_NORMALISATION};
