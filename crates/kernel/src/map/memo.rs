//! One pass for value and partial derivatives at a point: generated code and the tape ask a map for one
//! partial at a time (`M`, `M_d10`, `M_d01`, … at the same arguments, one after another), so the first such
//! call evaluates every partial up to order 2 per argument at once and keeps them in a small per-thread memo;
//! the following calls at the same point are table look-ups. Keyed by the map's unique id (new for new data)
//! and the arguments' bits, so a hit is always the same number a fresh evaluation gives.

use std::cell::RefCell;

/// Orders up to this per argument come from the memo.
pub(super) const MEMO_ORDER: usize = 2;
/// Entries per thread (a few maps evaluated in turn).
const SLOTS: usize = 4;
const WIDTH: usize = (MEMO_ORDER + 1) * (MEMO_ORDER + 1);

#[derive(Clone, Copy)]
struct Entry {
    id: u64,
    args: [u64; 2],
    out: [f64; WIDTH],
}

thread_local! {
    static MEMO: RefCell<([Entry; SLOTS], usize)> = const {
        RefCell::new(([Entry { id: 0, args: [0; 2], out: [0.0; WIDTH] }; SLOTS], 0))
    };
}

/// The partial `[i, j]` at `args` of map `id` (ids start at 1), computing all orders ≤ [`MEMO_ORDER`] with
/// `eval` (which writes them row-major, 3 × 3; 1-D: the first 3) on a miss.
pub(super) fn partial(
    id: u64,
    args: [f64; 2],
    [i, j]: [usize; 2],
    eval: impl FnOnce(&mut [f64; WIDTH]),
) -> f64 {
    let key = [args[0].to_bits(), args[1].to_bits()];
    MEMO.with(|m| {
        let mut m = m.borrow_mut();
        let (slots, next) = &mut *m;
        if let Some(e) = slots.iter().find(|e| e.id == id && e.args == key) {
            return e.out[i * (MEMO_ORDER + 1) + j];
        }
        let mut out = [0.0; WIDTH];
        eval(&mut out);
        let k = *next;
        slots[k] = Entry { id, args: key, out };
        *next = (k + 1) % SLOTS;
        out[i * (MEMO_ORDER + 1) + j]
    })
}
