//! A chunk of points on their way through the batched map path (`batch.rs`, `contract.rs`): its size and one
//! axis's numbers for every point, structure of arrays over the points `i`.

/// Points per chunk: every stage is a loop of this fixed length over arrays of this length (a last, shorter
/// chunk is padded with the grids' first points and its extra results dropped).
pub(super) const CHUNK: usize = 32;

/// One chunk's numbers on one axis, structure of arrays over the points `i`.
pub(super) struct AxisChunk {
    /// The index `c_i` of the grid point nearest `a_i`: the padded index of `Φ_0 = φ_{c−1}`.
    pub(super) c: [usize; CHUNK],
    /// `phi[k][m][i] = Φ_{c−1+k}^(m)(a_i)`.
    pub(super) phi: [[[f64; CHUNK]; 3]; 3],
    /// The kink weights `w[k][i] = w_{c−1+k, c}` of the corner.
    pub(super) w: [[f64; CHUNK]; 3],
    /// `t_i = a_i − x_c`, the offset to the nearest corner.
    pub(super) t: [f64; CHUNK],
}
