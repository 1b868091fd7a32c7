//! Fuzz target: `invsim_fuzz::inversion_targets::derive_pipeline` (see fuzz/README.md).
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    let _ = invsim_fuzz::inversion_targets::derive_pipeline(data);
});
