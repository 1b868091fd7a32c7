//! Fuzz entry point of the drive-cycle reader (contract §4).
//!
//! Returns `Ok(())` when the reader accepted the bytes and `Err(message)` when it rejected them; panics only on
//! a defect (a panic in the reader, or an accepted cycle that breaks the invariants [`Cycle::validate`] checks).

use invsim_runtime::Cycle;

/// Cycle reader: bytes (UTF-8, as `Cycle::from_csv_path` requires) → cycle, which must then be valid.
pub fn cycle_reader(data: &[u8]) -> Result<(), String> {
    let text = std::str::from_utf8(data).map_err(|e| e.to_string())?;
    let cycle = Cycle::from_csv_str("fuzz.csv", text).map_err(|e| e.to_string())?;
    if let Err(e) = cycle.validate() {
        panic!("the reader accepted a cycle that is not valid: {e}");
    }
    Ok(())
}
