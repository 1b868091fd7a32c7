//! One pass for value and partial derivatives at a point: generated code and the tape ask a map for one
//! partial at a time (`M`, `M_d10`, `M_d01`, … at the same arguments, one after another), so the first such
//! call evaluates every partial up to order 1 per argument at once (orders 0 and 1 need only the kernel's
//! tables, no exponential), or up to order 2 when a second derivative is asked for, and keeps them in a small
//! per-thread memo; the following calls at the same point are table look-ups. Keyed by the map's unique id
//! (new for new data) and the arguments' bits, so a hit is always the same number a fresh evaluation gives.

use std::cell::RefCell;

/// Orders up to this per argument come from the memo.
pub(super) const MEMO_ORDER: usize = 2;
/// Entries per thread (a few maps evaluated in turn).
const SLOTS: usize = 4;
/// Values per entry: every `[i, j]` with `i, j ≤ MEMO_ORDER`, row-major.
pub(super) const WIDTH: usize = (MEMO_ORDER + 1) * (MEMO_ORDER + 1);

#[derive(Clone, Copy)]
struct Entry {
    id: u64,
    args: [u64; 2],
    /// The highest order per argument held (1 or 2).
    cap: usize,
    out: [f64; WIDTH],
}

const EMPTY: Entry = Entry {
    id: 0,
    args: [0; 2],
    cap: 0,
    out: [0.0; WIDTH],
};

thread_local! {
    static MEMO: RefCell<([Entry; SLOTS], usize)> = const { RefCell::new(([EMPTY; SLOTS], 0)) };
}

/// The partial `[i, j]` at `args` of map `id` (ids start at 1). On a miss `eval(cap, out)` writes every
/// partial up to order `cap` per argument (1, or 2 when `i` or `j` is 2 or the map is `small`: its second
/// derivatives cost a table look-up, see `small.rs`) into `out`, row-major with rows of `MEMO_ORDER + 1`.
pub(super) fn partial(
    id: u64,
    args: [f64; 2],
    [i, j]: [usize; 2],
    small: bool,
    eval: impl FnOnce(usize, &mut [f64; WIDTH]),
) -> f64 {
    let need = if small { MEMO_ORDER } else { i.max(j).max(1) };
    let at = i * (MEMO_ORDER + 1) + j;
    fetch(id, args, need, |out| eval(need, out), |out| out[at])
}

/// Every partial up to order `MEMO_ORDER` per argument at `args` of map `id` (rows of `MEMO_ORDER + 1`), from
/// the memo or from `eval(out)`, which then fills it.
pub(super) fn entry(id: u64, args: [f64; 2], eval: impl FnOnce(&mut [f64; WIDTH])) -> [f64; WIDTH] {
    fetch(id, args, MEMO_ORDER, eval, |out| *out)
}

/// `read` of the entry of map `id` at `args` holding at least the orders up to `need`: the memo's, or one
/// `eval` fills (in the slot that held the point at lower orders, else the next in turn).
fn fetch<R>(
    id: u64,
    args: [f64; 2],
    need: usize,
    eval: impl FnOnce(&mut [f64; WIDTH]),
    read: impl FnOnce(&[f64; WIDTH]) -> R,
) -> R {
    let key = [args[0].to_bits(), args[1].to_bits()];
    MEMO.with(|m| {
        let mut m = m.borrow_mut();
        let (slots, next) = &mut *m;
        let at = slots.iter().position(|e| e.id == id && e.args == key);
        if let Some(k) = at.filter(|&k| slots[k].cap >= need) {
            return read(&slots[k].out);
        }
        let mut out = [0.0; WIDTH];
        eval(&mut out);
        let k = at.unwrap_or_else(|| {
            let k = *next;
            *next = (k + 1) % SLOTS;
            k
        });
        slots[k] = Entry {
            id,
            args: key,
            cap: need,
            out,
        };
        read(&out)
    })
}
