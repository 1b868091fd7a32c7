//! Fuzz target: `invsim_fuzz::inversion_targets::expr_parser` (see fuzz/README.md).
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    let _ = invsim_fuzz::inversion_targets::expr_parser(data);
});
