//! Model files are read through a size cap ([`MAX_MODEL_FILE_BYTES`]): devices, endless streams and huge
//! files are refused with a message naming the file and the cap; control characters from a file are escaped
//! in messages.

use invsim_inversion::{Model, ModelErrorKind, MAX_MODEL_FILE_BYTES};
use std::path::{Path, PathBuf};

const SMALL: &str = "[states]\nx = { rhs = \"-x + u\" }\n[input]\nname = \"u\"\n[output]\nname = \"y\"\nh = \"x\"\n";

fn temp(name: &str, bytes: &[u8]) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("invsim-read-limits-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    let path = dir.join(name);
    std::fs::write(&path, bytes).expect("write temp file");
    path
}

fn refused_for_size(path: &Path) {
    let e = Model::from_path(path).expect_err("over the cap");
    assert_eq!(e.kind, ModelErrorKind::Io);
    let msg = e.to_string();
    assert!(msg.starts_with(&path.display().to_string()), "{msg}");
    assert!(msg.contains(&MAX_MODEL_FILE_BYTES.to_string()), "{msg}");
}

#[test]
fn endless_devices_are_refused_at_the_cap() {
    for dev in ["/dev/zero", "/dev/urandom"] {
        if Path::new(dev).exists() {
            refused_for_size(Path::new(dev));
        }
    }
}

#[test]
fn files_over_the_cap_are_refused_and_files_at_the_cap_load() {
    let cap = usize::try_from(MAX_MODEL_FILE_BYTES).expect("cap fits");
    // A valid model padded with a comment to exactly the cap, then one byte more.
    let mut text = SMALL.to_string();
    text.push('#');
    while text.len() < cap - 1 {
        text.push('x');
    }
    text.push('\n');
    assert_eq!(text.len(), cap);
    let at_cap = temp("at_cap.toml", text.as_bytes());
    assert!(Model::from_path(&at_cap).is_ok());
    text.push('\n');
    refused_for_size(&temp("over_cap.toml", text.as_bytes()));
    refused_for_size(&temp("huge.toml", &vec![b'#'; 3 * cap]));
}

#[test]
fn control_characters_are_escaped_in_messages() {
    for (rhs, raw) in [
        ("-x + \\u0000", '\0'),
        ("-x + \\u0007u", '\u{7}'),
        ("\\u001b[31m", '\u{1b}'),
    ] {
        let text = SMALL.replace("-x + u", rhs);
        let e = Model::from_str(Path::new("m.toml"), &text).expect_err("bad character");
        let msg = e.to_string();
        assert!(!msg.contains(raw), "raw control character in {msg:?}");
        assert!(msg.contains("\\u{"), "{msg}");
    }
}
