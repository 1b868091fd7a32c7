//! Reading a vehicle file through a byte cap: the file is read up to [`MAX_VEHICLE_FILE_BYTES`] + 1 bytes,
//! so an endless file (`/dev/zero`) or a huge one is refused without being read whole.

use crate::error::ImportError;
use std::io::Read;
use std::path::Path;

/// Largest vehicle file read, in bytes (4 MiB; FASTSim's vehicle files are 4 to 10 kB, and the YAML tree of a
/// file takes several times its size in memory).
pub const MAX_VEHICLE_FILE_BYTES: u64 = 4 << 20;

/// The text of the vehicle file at `path`; a file larger than [`MAX_VEHICLE_FILE_BYTES`], unreadable or not
/// UTF-8 is an error (the message leaves out the file name: the caller puts it in front).
pub fn read_vehicle_file(path: &Path) -> Result<String, ImportError> {
    read_capped(path, MAX_VEHICLE_FILE_BYTES)
}

/// [`read_vehicle_file`] with the cap `max` bytes.
fn read_capped(path: &Path, max: u64) -> Result<String, ImportError> {
    let fail = |message: String| ImportError::File { message };
    let mut bytes = Vec::new();
    std::fs::File::open(path)
        .and_then(|f| f.take(max.saturating_add(1)).read_to_end(&mut bytes))
        .map_err(|e| fail(format!("cannot read: {e}")))?;
    if bytes.len() as u64 > max {
        return Err(fail(format!(
            "the file is larger than {max} bytes, the limit for a vehicle file (FASTSim's are about 10 kB)"
        )));
    }
    String::from_utf8(bytes).map_err(|e| {
        fail(format!(
            "not UTF-8 text (byte {})",
            e.utf8_error().valid_up_to()
        ))
    })
}

#[cfg(test)]
mod tests {
    use super::read_capped;

    #[test]
    fn a_file_beyond_the_cap_is_refused() {
        let e = read_capped(std::path::Path::new("/dev/zero"), 1000).unwrap_err();
        assert!(e.to_string().contains("larger than 1000 bytes"), "{e}");
    }
}
