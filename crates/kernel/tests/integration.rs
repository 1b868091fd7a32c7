//! Integration tests of invsim-kernel (one test binary; one file per topic).

mod common;
mod map;
mod map_batch;
