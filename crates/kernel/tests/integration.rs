//! Integration tests of invsim-kernel (one test binary; one file per topic).

mod common;
mod map;
mod map_batch;
/// Grid-value weights: the map's partial derivatives as linear functions of its values.
mod map_weights;
