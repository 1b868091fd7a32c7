//! Fuzz target: `invsim_fuzz::cycle_target::cycle_reader` (see fuzz/README.md).
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    let _ = invsim_fuzz::cycle_target::cycle_reader(data);
});
