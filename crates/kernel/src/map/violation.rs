//! The run-time check of `extrapolate = "error"` (contract §6): a map evaluated with an argument outside its
//! grid records the first such event of the thread; the driver of a run takes it after each step and reports
//! it with the time. Evaluation itself never fails (the generated code and the interpreter return plain
//! numbers), so the check costs one comparison per evaluation and nothing when no map uses the rule.

use std::cell::RefCell;
use std::sync::Arc;

/// An argument outside a map's grid under `extrapolate = "error"`.
#[derive(Debug, Clone, PartialEq)]
pub struct Violation {
    /// The map's name.
    pub map: Arc<str>,
    /// Which argument (0-based).
    pub arg: usize,
    pub value: f64,
    /// The grid's first and last value.
    pub range: (f64, f64),
}

impl std::fmt::Display for Violation {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "map `{}` (extrapolate = \"error\"): argument {} = {} is outside [{}, {}], the map's grid",
            self.map,
            self.arg + 1,
            self.value,
            self.range.0,
            self.range.1
        )
    }
}

thread_local! {
    static FIRST: RefCell<Option<Violation>> = const { RefCell::new(None) };
}

/// Records a violation unless one is pending already.
pub(super) fn record(map: &Arc<str>, arg: usize, value: f64, range: (f64, f64)) {
    FIRST.with(|c| {
        let mut c = c.borrow_mut();
        if c.is_none() {
            *c = Some(Violation {
                map: map.clone(),
                arg,
                value,
                range,
            });
        }
    });
}

/// The first violation recorded on this thread since the last call, clearing it.
pub fn take_violation() -> Option<Violation> {
    FIRST.with(|c| c.borrow_mut().take())
}
