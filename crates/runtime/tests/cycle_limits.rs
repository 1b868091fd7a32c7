//! The cycle reader's limits (issue 15, defects 8, 10, 11): files read through a size cap, finite but absurd
//! speeds and times refused naming their row, cycles that last no time refused, control characters never
//! echoed, and every number in a message short.

use invsim_runtime::cycle::{CycleError, MAX_CYCLE_BYTES, MAX_SPEED_MPS};
use invsim_runtime::Cycle;

fn err(text: &str) -> String {
    Cycle::from_csv_str("c.csv", text)
        .expect_err("must be refused")
        .to_string()
}

#[test]
fn endless_and_large_files_stop_at_the_cap() {
    let e = Cycle::from_csv_path_with_limit("/dev/zero".as_ref(), 1 << 20).unwrap_err();
    assert!(
        matches!(e, CycleError::TooLarge { max, .. } if max == 1 << 20),
        "{e}"
    );
    assert!(e.to_string().contains("--max-cycle-bytes"), "{e}");
    let e = Cycle::load("/dev/zero").unwrap_err();
    assert!(
        matches!(e, CycleError::TooLarge { max, .. } if max == MAX_CYCLE_BYTES),
        "{e}"
    );
    let dir = std::env::temp_dir().join(format!("invsim-cycle-limits-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("c.csv");
    std::fs::write(&path, "time_s,speed_mps\n0,0\n10,5\n20,0\n").unwrap();
    let size = std::fs::metadata(&path).unwrap().len();
    assert!(Cycle::from_csv_path_with_limit(&path, size).is_ok());
    assert!(matches!(
        Cycle::from_csv_path_with_limit(&path, size - 1),
        Err(CycleError::TooLarge { .. })
    ));
    assert!(Cycle::load_with_limit(path.to_str().unwrap(), size).is_ok());
}

#[test]
fn absurd_finite_values_are_refused_naming_the_line() {
    for (text, line, what) in [
        ("time_s,speed_mps\n0,0\n10,1e12\n20,0\n", 3, "speed"),
        ("time_s,speed_mps\n0,0\n10,1e30\n", 3, "speed"),
        ("time_s,speed_kmh\n0,0\n\n10,4000\n", 4, "speed"),
        ("time_s,speed_mph\n0,0\n10,3000\n", 3, "speed"),
        ("time_s,speed_mps\n0,0\n1e300,1\n", 3, "time"),
        ("time_s,speed_mps\n-1e20,0\n1,1\n", 2, "time"),
    ] {
        let e = err(text);
        assert!(e.starts_with(&format!("c.csv: line {line} ")), "{e}");
        assert!(e.contains(what) && e.contains("beyond the limit"), "{e}");
        assert!(e.len() < 300, "{e}");
    }
    // The bound itself is a speed.
    let at_bound = format!("time_s,speed_mps\n0,0\n10,{MAX_SPEED_MPS}\n");
    assert!(Cycle::from_csv_str("c.csv", &at_bound).is_ok());
}

#[test]
fn cycles_that_last_no_time_are_refused() {
    for text in [
        "time_s,speed_mps\n0,0\n1.9e-11,1\n",
        "time_s,speed_mps\n0,0\n0.0000005,1\n0.000001,0\n",
        "t,mps\n5,0\n5.0009,0\n",
    ] {
        let e = err(text);
        assert!(e.contains("lasts only"), "{e}");
    }
    assert!(Cycle::from_csv_str("c.csv", "t,mps\n0,0\n0.001,0\n").is_ok());
}

#[test]
fn control_characters_are_not_echoed() {
    for text in [
        "time_s,speed_mps\n0,0\n1\0\0,1\n2,0\n",
        "time_s,speed_mps\n0,0\n1,\u{1b}[2J\n",
    ] {
        let e = err(text);
        assert!(!e.chars().any(|c| c.is_control()), "{e:?}");
        assert!(e.starts_with("c.csv: line 3 "), "{e}");
    }
    let e = err(&format!(
        "time_s,speed_mps\n0,0\n1,{}\n",
        "x".repeat(10_000)
    ));
    assert!(e.len() < 300, "{e}");
}

#[test]
fn numbers_in_cycle_messages_are_short() {
    let e = err("time_s,speed_mps\n0,0\n0.30000000000000004,1\n0.1,1\n");
    assert!(
        e.contains("time 0.1 s is not after the previous row's 0.3 s"),
        "{e}"
    );
    let e = err("time_s,speed_mps\n0,0\n1,-0.33333333333333331\n");
    assert!(e.contains("speed -0.333333 is negative"), "{e}");
}
