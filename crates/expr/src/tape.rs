//! A set of expressions compiled into one flat instruction tape for fast repeated numeric evaluation.
//!
//! The tape encodes the lowering plan of [`crate::lower`] (the one the code generator prints): each operation
//! of the plan is one instruction, so shared subexpressions are evaluated once per call; sums and products are
//! binary chains (with subtraction and division for negative coefficients and exponents), integer powers
//! `powi`, ½-powers `sqrt`, and powers of one base whose exponents differ by an integer (`v^1.8`, `v^0.8`)
//! share a single `powf`. Evaluation writes into a scratch buffer that is reused between calls: no
//! allocation per evaluation.

use crate::calculus::UnboundSymbol;
use crate::func::{Func, Func2};
use crate::fxhash::FxHashMap;
use crate::lower::{self, Arena, Invariants, Lowered, Op, Strategy, Val};
use crate::map::Map;
use crate::pool::{Id, Pool, Symbol};
use std::cell::RefCell;
use std::sync::Arc;

/// One instruction; operands are slot indices. Instruction `i` writes slot `first_op_slot + i`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Instr {
    Add(u32, u32),
    Sub(u32, u32),
    Mul(u32, u32),
    Div(u32, u32),
    Neg(u32),
    Recip(u32),
    Powi(u32, i32),
    Sqrt(u32),
    Powf(u32, f64),
    PowVar(u32, u32),
    Call(Func, u32),
    Call2(Func2, u32, u32),
    /// Map `maps[m]`'s partial derivative of orders `[I, J]` at the slots (1-D: the second is the first).
    Map(u32, [u8; 2], u32, u32),
}

/// Compiled expressions: slots are `[inputs | constants | instruction results]`.
#[derive(Clone, Debug)]
pub struct Tape {
    /// Identifies the constants of this tape in a per-thread scratch buffer (see [`Tape::eval`]).
    id: u64,
    n_inputs: usize,
    consts: Vec<f64>,
    instrs: Vec<Instr>,
    outputs: Vec<u32>,
    /// The data of every map declared in the pool, by [`crate::MapId::index`].
    maps: Vec<Arc<Map>>,
}

/// Slot numbering of a lowered plan: inputs `[0, n)`, constants `[n, n + c)`, then the invariant arena's
/// operations (empty with [`Strategy::TAPE`]) and the function's, in order.
struct Encoder<'a> {
    n_inputs: usize,
    inputs: FxHashMap<Symbol, u32>,
    consts: Vec<f64>,
    const_slots: FxHashMap<u64, u32>,
    inv: &'a Arena,
    /// Slot of the first invariant operation.
    inv_base: u32,
}

impl<'a> Encoder<'a> {
    fn new(inputs: &[Symbol], inv: &'a Arena, lowered: &Lowered) -> Encoder<'a> {
        let mut e = Encoder {
            n_inputs: inputs.len(),
            inputs: (0u32..).zip(inputs).map(|(i, &s)| (s, i)).collect(),
            consts: Vec::new(),
            const_slots: FxHashMap::default(),
            inv,
            inv_base: 0,
        };
        // Constants in order of first use.
        let ops = inv.ops().iter().chain(lowered.arena.ops());
        for v in ops
            .flat_map(|op| op.operands())
            .chain(lowered.roots.iter().copied())
        {
            let x = match v {
                Val::Num(n) => n.to_f64(),
                Val::Pi => std::f64::consts::PI,
                _ => continue,
            };
            if !e.const_slots.contains_key(&x.to_bits()) {
                let slot = (inputs.len() + e.consts.len()) as u32;
                e.const_slots.insert(x.to_bits(), slot);
                e.consts.push(x);
            }
        }
        e.inv_base = (inputs.len() + e.consts.len()) as u32;
        e
    }

    /// The slot of an operand. Every symbol is an input (the plan reports unbound ones) and every number
    /// has a constant slot (collected in `new`).
    fn slot(&self, v: Val) -> u32 {
        match v {
            Val::Sym(s) => self.inputs[&s],
            Val::Num(n) => self.const_slots[&n.to_f64().to_bits()],
            Val::Pi => self.const_slots[&std::f64::consts::PI.to_bits()],
            Val::Inv(i) => self.inv_base + i as u32,
            Val::Loc(i) => self.inv_base + (self.inv.ops().len() + i) as u32,
        }
    }

    fn instr(&self, op: &Op) -> Instr {
        let s = |v: Val| self.slot(v);
        match *op {
            Op::Add(a, b) => Instr::Add(s(a), s(b)),
            Op::Sub(a, b) => Instr::Sub(s(a), s(b)),
            Op::Mul(a, b) => Instr::Mul(s(a), s(b)),
            Op::Div(a, b) => Instr::Div(s(a), s(b)),
            Op::Neg(a) => Instr::Neg(s(a)),
            Op::Recip(a) => Instr::Recip(s(a)),
            Op::Powi(a, k) => Instr::Powi(s(a), k),
            Op::Sqrt(a) => Instr::Sqrt(s(a)),
            Op::Powf(a, q) => Instr::Powf(s(a), q.to_f64()),
            Op::PowVar(a, b) => Instr::PowVar(s(a), s(b)),
            Op::Call(f, a) => Instr::Call(f, s(a)),
            Op::Call2(f, a, b) => Instr::Call2(f, s(a), s(b)),
            Op::Map1(m, k, a) => Instr::Map(m.index() as u32, [k, 0], s(a), s(a)),
            Op::Map2(m, o, a, b) => Instr::Map(m.index() as u32, o, s(a), s(b)),
        }
    }

    fn tape(self, lowered: &Lowered, maps: Vec<Arc<Map>>) -> Tape {
        let ops = self.inv.ops().iter().chain(lowered.arena.ops());
        let instrs = ops.map(|op| self.instr(op)).collect();
        let outputs = lowered.roots.iter().map(|&v| self.slot(v)).collect();
        Tape {
            id: next_id(),
            n_inputs: self.n_inputs,
            consts: self.consts,
            instrs,
            outputs,
            maps,
        }
    }
}

thread_local! {
    /// Per-thread scratch buffer and the id of the tape whose constants it holds.
    static SCRATCH: RefCell<(u64, Vec<f64>)> = const { RefCell::new((0, Vec::new())) };
}

thread_local! {
    /// Per-thread column buffer of [`Tape::eval_batch`].
    static BATCH_SCRATCH: RefCell<Vec<f64>> = const { RefCell::new(Vec::new()) };
}

/// Points per block in [`Tape::eval_batch`].
pub const BATCH: usize = 64;

#[inline(always)]
fn zip2(dst: &mut [f64], a: &[f64], b: &[f64], f: impl Fn(f64, f64) -> f64) {
    for ((d, &x), &y) in dst.iter_mut().zip(a).zip(b) {
        *d = f(x, y);
    }
}

#[inline(always)]
fn map1(dst: &mut [f64], a: &[f64], f: impl Fn(f64) -> f64) {
    for (d, &x) in dst.iter_mut().zip(a) {
        *d = f(x);
    }
}

static NEXT_ID: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(1);

fn next_id() -> u64 {
    NEXT_ID.fetch_add(1, std::sync::atomic::Ordering::Relaxed)
}

impl Instr {
    fn operands(&self) -> [Option<u32>; 2] {
        match *self {
            Instr::Add(x, y)
            | Instr::Sub(x, y)
            | Instr::Mul(x, y)
            | Instr::Div(x, y)
            | Instr::PowVar(x, y)
            | Instr::Map(_, _, x, y)
            | Instr::Call2(_, x, y) => [Some(x), Some(y)],
            Instr::Neg(x)
            | Instr::Recip(x)
            | Instr::Powi(x, _)
            | Instr::Sqrt(x)
            | Instr::Powf(x, _)
            | Instr::Call(_, x) => [Some(x), None],
        }
    }

    fn remap(&self, m: impl Fn(u32) -> u32) -> Instr {
        match *self {
            Instr::Add(x, y) => Instr::Add(m(x), m(y)),
            Instr::Sub(x, y) => Instr::Sub(m(x), m(y)),
            Instr::Mul(x, y) => Instr::Mul(m(x), m(y)),
            Instr::Div(x, y) => Instr::Div(m(x), m(y)),
            Instr::Neg(x) => Instr::Neg(m(x)),
            Instr::Recip(x) => Instr::Recip(m(x)),
            Instr::Powi(x, k) => Instr::Powi(m(x), k),
            Instr::Sqrt(x) => Instr::Sqrt(m(x)),
            Instr::Powf(x, k) => Instr::Powf(m(x), k),
            Instr::PowVar(x, y) => Instr::PowVar(m(x), m(y)),
            Instr::Call(f, x) => Instr::Call(f, m(x)),
            Instr::Call2(f, x, y) => Instr::Call2(f, m(x), m(y)),
            Instr::Map(k, o, x, y) => Instr::Map(k, o, m(x), m(y)),
        }
    }
}

impl Tape {
    /// Compile `outputs`, whose free symbols must all be among `inputs` (in that order at evaluation).
    ///
    /// The instructions are the lowering plan of [`crate::lower`] with [`Strategy::TAPE`], one per operation.
    pub fn compile(pool: &Pool, outputs: &[Id], inputs: &[Symbol]) -> Result<Tape, UnboundSymbol> {
        let mut inv = Invariants::new(pool, &[], Strategy::TAPE);
        let lowered = lower::lower(&mut inv, outputs, inputs)?;
        let maps = pool.maps().iter().map(|d| d.data.clone()).collect();
        let tape = Encoder::new(inputs, inv.arena(), &lowered).tape(&lowered, maps);
        tape.validate();
        Ok(tape)
    }

    /// Partial evaluation: fix the last `values.len()` inputs (the parameters) to `values`, evaluate every
    /// instruction that depends on them and constants only, and return a tape over the remaining inputs whose
    /// constants include those results. Per-point work is then only what depends on the varying inputs.
    pub fn specialize(&self, values: &[f64]) -> Tape {
        let nv = self.n_inputs - values.len();
        let base = self.n_inputs + self.consts.len();
        let mut buf = self.new_buffer();
        buf[nv..self.n_inputs].copy_from_slice(values);
        let total = self.n_slots();
        let mut invariant = vec![true; total];
        for flag in invariant.iter_mut().take(nv) {
            *flag = false;
        }
        for (i, ins) in self.instrs.iter().enumerate() {
            let inv = ins
                .operands()
                .iter()
                .flatten()
                .all(|&o| invariant[o as usize]);
            invariant[base + i] = inv;
            if inv {
                let mut one = [0.0];
                // Evaluate this single instruction on the buffer.
                let g = |s: u32| buf[s as usize];
                one[0] = exec(ins, &self.maps, g);
                buf[base + i] = one[0];
            }
        }
        // New layout: varying inputs, then constants (old constants and needed invariant results), then the
        // varying instructions.
        let mut used = vec![false; total];
        for ins in self
            .instrs
            .iter()
            .enumerate()
            .filter(|(i, _)| !invariant[base + i])
            .map(|(_, x)| x)
        {
            for &o in ins.operands().iter().flatten() {
                used[o as usize] = true;
            }
        }
        for &o in &self.outputs {
            used[o as usize] = true;
        }
        let mut map = vec![u32::MAX; total];
        for (s, m) in map.iter_mut().enumerate().take(nv) {
            *m = s as u32;
        }
        // x / c for an invariant c becomes x · (1/c): a multiplication instead of a division per point.
        let mut recip_of: std::collections::HashMap<u32, f64> = std::collections::HashMap::new();
        for (i, ins) in self.instrs.iter().enumerate() {
            if let Instr::Div(_, y) = ins {
                if !invariant[base + i] && invariant[*y as usize] {
                    recip_of.insert(*y, 1.0 / buf[*y as usize]);
                }
            }
        }
        let mut consts = Vec::new();
        let mut recip_slot: std::collections::HashMap<u32, u32> = std::collections::HashMap::new();
        for (&y, &r) in {
            let mut v: Vec<(&u32, &f64)> = recip_of.iter().collect();
            v.sort_by_key(|(k, _)| **k);
            v
        } {
            recip_slot.insert(y, (nv + consts.len()) as u32);
            consts.push(r);
        }
        for s in nv..total {
            if invariant[s] && used[s] {
                map[s] = (nv + consts.len()) as u32;
                consts.push(buf[s]);
            }
        }
        let first = (nv + consts.len()) as u32;
        let mut instrs = Vec::new();
        for (i, ins) in self.instrs.iter().enumerate() {
            if !invariant[base + i] {
                map[base + i] = first + instrs.len() as u32;
                let new = match ins {
                    Instr::Div(x, y) if recip_slot.contains_key(y) => {
                        Instr::Mul(map[*x as usize], recip_slot[y])
                    }
                    _ => ins.remap(|o| map[o as usize]),
                };
                instrs.push(new);
            }
        }
        let tape = Tape {
            id: next_id(),
            n_inputs: nv,
            consts,
            instrs,
            outputs: self.outputs.iter().map(|&o| map[o as usize]).collect(),
            maps: self.maps.clone(),
        };
        tape.validate();
        tape
    }

    pub fn n_inputs(&self) -> usize {
        self.n_inputs
    }

    /// Replaces the data of map `index` ([`crate::MapId::index`]); a specialised tape keeps the values it
    /// folded (map calls of parameters alone), so specialise again after replacing.
    pub fn set_map(&mut self, index: usize, data: Arc<Map>) {
        if let Some(m) = self.maps.get_mut(index) {
            *m = data;
        }
    }
    pub fn n_outputs(&self) -> usize {
        self.outputs.len()
    }
    /// Number of instructions (a measure of evaluation cost).
    pub fn len(&self) -> usize {
        self.instrs.len()
    }
    pub fn is_empty(&self) -> bool {
        self.instrs.is_empty()
    }
    pub fn instructions(&self) -> &[Instr] {
        &self.instrs
    }

    /// Slots needed by [`Tape::eval_in`].
    pub fn n_slots(&self) -> usize {
        self.n_inputs + self.consts.len() + self.instrs.len()
    }

    /// A scratch buffer for [`Tape::eval_in`], with the constants already in place.
    pub fn new_buffer(&self) -> Vec<f64> {
        let mut buf = vec![0.0; self.n_slots()];
        buf[self.n_inputs..self.n_inputs + self.consts.len()].copy_from_slice(&self.consts);
        buf
    }

    /// Evaluate into `out` using a buffer made by [`Tape::new_buffer`] (constants must be intact).
    #[inline]
    pub fn eval_in(&self, buf: &mut [f64], inputs: &[f64], out: &mut [f64]) {
        assert_eq!(inputs.len(), self.n_inputs, "tape input count");
        assert!(buf.len() >= self.n_slots(), "tape buffer too small");
        buf[..self.n_inputs].copy_from_slice(inputs);
        self.run(buf, out);
    }

    /// Execute the instructions on a buffer whose input and constant slots are filled.
    #[inline]
    fn run(&self, buf: &mut [f64], out: &mut [f64]) {
        let base = self.n_inputs + self.consts.len();
        assert!(
            buf.len() >= base + self.instrs.len(),
            "tape buffer too small"
        );
        let ptr = buf.as_mut_ptr();
        for (i, ins) in self.instrs.iter().enumerate() {
            // SAFETY: every tape is built (by `compile` or `specialize`, the only constructors) so that each
            // operand of instruction i names a slot below `base + i` (checked by `debug_validate`), and the
            // buffer holds at least `base + instrs.len()` slots (asserted above). Reads and the write are
            // therefore in bounds, and the write slot is never read by this instruction.
            let v = exec(ins, &self.maps, |s: u32| unsafe { *ptr.add(s as usize) });
            unsafe { *ptr.add(base + i) = v };
        }
        for (o, &s) in out.iter_mut().zip(&self.outputs) {
            *o = buf[s as usize];
        }
    }

    /// Check the invariant `run` relies on: operands of instruction i are slots below `base + i`.
    fn validate(&self) {
        let base = self.n_inputs + self.consts.len();
        for (i, ins) in self.instrs.iter().enumerate() {
            for &o in ins.operands().iter().flatten() {
                assert!(
                    (o as usize) < base + i,
                    "tape operand {o} of instruction {i} is not an earlier slot"
                );
            }
        }
        for &o in &self.outputs {
            assert!(
                (o as usize) < base + self.instrs.len(),
                "tape output slot {o} out of range"
            );
        }
    }

    /// Evaluate many points at once, column-wise: `inputs[j][k]` is input j at point k, and
    /// `outputs[o][k]` receives output o at point k. Instructions run over blocks of [`BATCH`] points, so
    /// the per-instruction dispatch is paid once per block and the arithmetic vectorises.
    pub fn eval_batch(&self, inputs: &[&[f64]], outputs: &mut [&mut [f64]]) {
        assert_eq!(inputs.len(), self.n_inputs, "tape input count");
        let points = inputs
            .first()
            .map(|c| c.len())
            .or_else(|| outputs.first().map(|c| c.len()))
            .unwrap_or(0);
        assert!(
            inputs.iter().all(|c| c.len() == points),
            "input columns differ in length"
        );
        assert!(
            outputs.len() >= self.outputs.len(),
            "too few output columns"
        );
        assert!(
            outputs.iter().all(|c| c.len() >= points),
            "output column too short"
        );
        BATCH_SCRATCH.with(|cell| {
            let mut buf = cell.borrow_mut();
            let n = self.n_slots() * BATCH;
            if buf.len() < n {
                buf.resize(n, 0.0);
            }
            for (c, &v) in self.consts.iter().enumerate() {
                buf[(self.n_inputs + c) * BATCH..(self.n_inputs + c + 1) * BATCH].fill(v);
            }
            let base = self.n_inputs + self.consts.len();
            let mut maps = MapBlock::new(&self.instrs);
            let mut start = 0;
            while start < points {
                let len = BATCH.min(points - start);
                maps.clear();
                for (j, col) in inputs.iter().enumerate() {
                    buf[j * BATCH..j * BATCH + len].copy_from_slice(&col[start..start + len]);
                }
                for (i, ins) in self.instrs.iter().enumerate() {
                    let (done, rest) = buf.split_at_mut((base + i) * BATCH);
                    let dst = &mut rest[..len];
                    let col = |s: u32| &done[s as usize * BATCH..s as usize * BATCH + len];
                    match *ins {
                        Instr::Add(x, y) => zip2(dst, col(x), col(y), |a, b| a + b),
                        Instr::Sub(x, y) => zip2(dst, col(x), col(y), |a, b| a - b),
                        Instr::Mul(x, y) => zip2(dst, col(x), col(y), |a, b| a * b),
                        Instr::Div(x, y) => zip2(dst, col(x), col(y), |a, b| a / b),
                        Instr::PowVar(x, y) => zip2(dst, col(x), col(y), f64::powf),
                        Instr::Call2(f, x, y) => zip2(dst, col(x), col(y), |a, b| f.eval(a, b)),
                        Instr::Neg(x) => map1(dst, col(x), |a| -a),
                        Instr::Recip(x) => map1(dst, col(x), |a| 1.0 / a),
                        Instr::Powi(x, 2) => map1(dst, col(x), |a| a * a),
                        Instr::Powi(x, k) => map1(dst, col(x), |a| powi(a, k)),
                        Instr::Sqrt(x) => map1(dst, col(x), f64::sqrt),
                        Instr::Powf(x, k) => map1(dst, col(x), |a| a.powf(k)),
                        Instr::Call(f, x) => map1(dst, col(x), |a| f.eval(a)),
                        Instr::Map(m, o, x, y) if maps.shared((m, o, x, y)) => {
                            let map = &self.maps[m as usize];
                            let e = if map.arity() == 2 {
                                3 * o[0] as usize + o[1] as usize
                            } else {
                                o[0] as usize
                            };
                            let v = maps.entries((m, x, y), map, col(x), col(y));
                            dst.copy_from_slice(&v[e * len..][..len]);
                        }
                        Instr::Map(m, [0, 0], x, y) if self.maps[m as usize].arity() == 2 => {
                            // A lone value of a 2-D map: the block at once (the same numbers).
                            self.maps[m as usize].values_batch(col(x), col(y), dst)
                        }
                        Instr::Map(m, o, x, y) => {
                            let map = &self.maps[m as usize];
                            let o = [o[0] as usize, o[1] as usize];
                            zip2(dst, col(x), col(y), |a, b| {
                                map.partial_unmemoized(&[a, b], o)
                            })
                        }
                    }
                }
                for (o, &sl) in self.outputs.iter().enumerate() {
                    let sl = sl as usize;
                    outputs[o][start..start + len]
                        .copy_from_slice(&buf[sl * BATCH..sl * BATCH + len]);
                }
                start += len;
            }
        })
    }

    /// Evaluate with the inputs given as consecutive slices (e.g. `&[xi, eta, params]`), using a
    /// per-thread scratch buffer: no allocation after the first call on a thread.
    pub fn eval_parts(&self, parts: &[&[f64]], out: &mut [f64]) {
        SCRATCH.with(|cell| {
            let mut guard = cell.borrow_mut();
            let (owner, buf) = &mut *guard;
            let n = self.n_slots();
            if buf.len() < n {
                buf.resize(n, 0.0);
            }
            if *owner != self.id {
                let c0 = self.n_inputs;
                buf[c0..c0 + self.consts.len()].copy_from_slice(&self.consts);
                *owner = self.id;
            }
            let mut at = 0;
            for p in parts {
                buf[at..at + p.len()].copy_from_slice(p);
                at += p.len();
            }
            assert_eq!(at, self.n_inputs, "tape input count");
            self.run(buf, out);
        })
    }

    /// Evaluate into `out` with a per-thread scratch buffer (allocated once per thread, then reused).
    pub fn eval(&self, inputs: &[f64], out: &mut [f64]) {
        self.eval_parts(&[inputs], out)
    }
}

/// The value and every partial up to order 2 of the maps of one block of [`Tape::eval_batch`], one
/// `Map::partials2_batch` per (map, argument slots): computed at the group's first instruction, read by the
/// others (`partials2_batch` is `partials2`, hence `partial`, bit for bit). The buffers are kept from block
/// to block.
///
/// Only groups of two or more instructions (orders ≤ 2 per argument) are taken this way: a lone call is
/// cheaper point by point (`Map::partial_unmemoized` evaluates only the partial it needs), except the lone
/// value of a 2-D map, taken a block at a time by `Map::values_batch`.
struct MapBlock {
    /// (map, slot of a, slot of b) of the groups with two or more instructions.
    shared: Vec<(u32, u32, u32)>,
    /// (map, slot of a, slot of b) and its entries: entry e of point k at `e · len + k`.
    groups: Vec<((u32, u32, u32), Vec<f64>)>,
    /// The groups of the current block: the first `used`.
    used: usize,
}

impl MapBlock {
    fn new(instrs: &[Instr]) -> MapBlock {
        let mut count: Vec<((u32, u32, u32), usize)> = Vec::new();
        for ins in instrs {
            if let Instr::Map(m, o, x, y) = *ins {
                if o[0] <= 2 && o[1] <= 2 {
                    match count.iter_mut().find(|c| c.0 == (m, x, y)) {
                        Some(c) => c.1 += 1,
                        None => count.push(((m, x, y), 1)),
                    }
                }
            }
        }
        MapBlock {
            shared: count
                .into_iter()
                .filter(|c| c.1 >= 2)
                .map(|c| c.0)
                .collect(),
            groups: Vec::new(),
            used: 0,
        }
    }

    /// Is this map instruction taken a block at a time?
    fn shared(&self, (m, o, x, y): (u32, [u8; 2], u32, u32)) -> bool {
        o[0] <= 2 && o[1] <= 2 && self.shared.contains(&(m, x, y))
    }

    fn clear(&mut self) {
        self.used = 0;
    }

    /// The entries of `map` at the columns `a`, `b` (slots `key.1`, `key.2`) of this block.
    fn entries(&mut self, key: (u32, u32, u32), map: &Map, a: &[f64], b: &[f64]) -> &[f64] {
        let live = &self.groups[..self.used];
        let j = match live.iter().position(|g| g.0 == key) {
            Some(j) => j,
            None => {
                if self.used == self.groups.len() {
                    self.groups.push((key, Vec::new()));
                }
                let g = &mut self.groups[self.used];
                self.used += 1;
                g.0 = key;
                g.1.resize(9 * a.len(), 0.0);
                map.partials2_batch(a, b, &mut g.1);
                self.used - 1
            }
        };
        &self.groups[j].1
    }
}

/// Execute one instruction with operand values from `g`.
#[inline(always)]
fn exec(ins: &Instr, maps: &[Arc<Map>], g: impl Fn(u32) -> f64) -> f64 {
    match *ins {
        Instr::Map(m, o, x, y) => {
            maps[m as usize].partial(&[g(x), g(y)], [o[0] as usize, o[1] as usize])
        }
        Instr::Add(x, y) => g(x) + g(y),
        Instr::Sub(x, y) => g(x) - g(y),
        Instr::Mul(x, y) => g(x) * g(y),
        Instr::Div(x, y) => g(x) / g(y),
        Instr::Neg(x) => -g(x),
        Instr::Recip(x) => 1.0 / g(x),
        Instr::Powi(x, k) => powi(g(x), k),
        Instr::Sqrt(x) => g(x).sqrt(),
        Instr::Powf(x, k) => g(x).powf(k),
        Instr::PowVar(x, y) => g(x).powf(g(y)),
        Instr::Call(f, x) => f.eval(g(x)),
        Instr::Call2(f, x, y) => f.eval(g(x), g(y)),
    }
}

/// `a^k` as `f64::powi` computes it (the runtime's `__powidf2`: binary powering, the running product times
/// the squared base at each set bit, then 1/· for k < 0; the same products, so the same bits), inlined:
/// the library call costs more than the multiplications.
#[inline]
fn powi(a: f64, k: i32) -> f64 {
    let mut n = k.unsigned_abs();
    let mut y = if n % 2 == 1 { a } else { 1.0 };
    let mut x = a;
    while n > 1 {
        n >>= 1;
        x *= x;
        if n % 2 == 1 {
            y *= x;
        }
    }
    if k < 0 {
        1.0 / y
    } else {
        y
    }
}

#[cfg(test)]
mod tests {

    /// The inlined integer power is `f64::powi` bit for bit, for exponents of either sign and every base
    /// kind (tiny, huge, negative, zero, infinite, NaN).
    #[test]
    fn powi_is_the_library_s() {
        let bases = [
            0.0,
            -0.0,
            1.0,
            -1.0,
            0.37,
            -2.5,
            1e-200,
            3e150,
            f64::INFINITY,
            f64::NAN,
            1.0 + 1e-12,
        ];
        for &a in &bases {
            for k in -40..=40 {
                let (got, want) = (super::powi(a, k), a.powi(k));
                assert!(
                    got.to_bits() == want.to_bits() || (got.is_nan() && want.is_nan()),
                    "{a}^{k}"
                );
            }
            for i in 0..200 {
                let b = a * (1.0 + i as f64 * 0.013) - i as f64 * 0.7;
                assert_eq!(super::powi(b, 2).to_bits(), (b * b).to_bits());
            }
        }
    }
    use super::*;
    use std::collections::HashMap;

    #[test]
    fn tape_matches_reference_evaluator() {
        let mut p = Pool::new();
        let srcs = [
            "c1*v^2 + c2*v^1.8 + c3*p + c4",
            "1.8*c2*v^0.8 - x/(y*z^2) + sqrt(v)*v^1.5",
            "-a - b",
            "-(a*b)/c + exp(-v)*sin(2*pi*a)",
            "min(a, b) - max(a, 2) + atan(a)^3 + v^y",
            "-2/a",
            "-a",
            "3",
        ];
        let es: Vec<Id> = srcs.iter().map(|s| p.parse(s).unwrap()).collect();
        let names = [
            "c1", "c2", "c3", "c4", "v", "p", "x", "y", "z", "a", "b", "c",
        ];
        let syms: Vec<Symbol> = names.iter().map(|n| p.symbol(n)).collect();
        let tape = Tape::compile(&p, &es, &syms).unwrap();
        let vals: Vec<f64> = (0..syms.len()).map(|i| 0.3 + 0.37 * i as f64).collect();
        let mut out = vec![0.0; es.len()];
        tape.eval(&vals, &mut out);
        let env: HashMap<Symbol, f64> = syms.iter().copied().zip(vals.iter().copied()).collect();
        for (k, &e) in es.iter().enumerate() {
            let want = p.eval(e, &env).unwrap();
            assert!(
                (out[k] - want).abs() <= 1e-13 * want.abs().max(1.0),
                "{}: {} vs {want}",
                srcs[k],
                out[k]
            );
        }
        // v^1.8 and v^0.8 share one powf.
        let powfs = tape
            .instructions()
            .iter()
            .filter(|i| matches!(i, Instr::Powf(..)))
            .count();
        assert_eq!(powfs, 1);
    }

    #[test]
    fn specialization_matches_the_full_tape() {
        let mut p = Pool::new();
        let e = p
            .parse("(1 + sqrt(a)/b)*x^1.8 + exp(a*b)*y - a/(1 + b)")
            .unwrap();
        let syms: Vec<Symbol> = ["x", "y", "a", "b"].iter().map(|n| p.symbol(n)).collect();
        let full = Tape::compile(&p, &[e], &syms).unwrap();
        let spec = full.specialize(&[2.0, 3.0]);
        assert_eq!(spec.n_inputs(), 2);
        assert!(spec.len() < full.len(), "{} vs {}", spec.len(), full.len());
        let (mut a, mut b) = ([0.0], [0.0]);
        full.eval(&[1.3, -0.4, 2.0, 3.0], &mut a);
        spec.eval(&[1.3, -0.4], &mut b);
        assert_eq!(a, b);
        // Alternating between tapes on one thread keeps each one's constants right.
        full.eval(&[0.7, 0.1, 2.0, 3.0], &mut a);
        spec.eval(&[0.7, 0.1], &mut b);
        assert_eq!(a, b);
    }

    #[test]
    fn batch_evaluation_matches_pointwise() {
        let mut p = Pool::new();
        let srcs = [
            "a*x^1.8 + b/x - sqrt(y)",
            "exp(-x*y)*sin(a) + min(x, y)",
            "x^y",
            "-x - y",
        ];
        let es: Vec<Id> = srcs.iter().map(|s| p.parse(s).unwrap()).collect();
        let syms: Vec<Symbol> = ["x", "y", "a", "b"].iter().map(|n| p.symbol(n)).collect();
        let tape = Tape::compile(&p, &es, &syms)
            .unwrap()
            .specialize(&[1.5, -0.25]);
        let n = 150; // more than two blocks
        let xs: Vec<f64> = (0..n).map(|k| 0.1 + 0.05 * k as f64).collect();
        let ys: Vec<f64> = (0..n).map(|k| 2.0 - 0.01 * k as f64).collect();
        let mut cols = vec![vec![0.0; n]; es.len()];
        {
            let mut outs: Vec<&mut [f64]> = cols.iter_mut().map(|c| c.as_mut_slice()).collect();
            tape.eval_batch(&[&xs, &ys], &mut outs);
        }
        for k in 0..n {
            let mut one = vec![0.0; es.len()];
            tape.eval(&[xs[k], ys[k]], &mut one);
            for o in 0..es.len() {
                assert_eq!(
                    cols[o][k].to_bits(),
                    one[o].to_bits(),
                    "{} at point {k}",
                    srcs[o]
                );
            }
        }
    }

    #[test]
    fn unbound_symbols_are_reported() {
        let mut p = Pool::new();
        let e = p.parse("x + y").unwrap();
        let x = p.symbol("x");
        let err = Tape::compile(&p, &[e], &[x]).unwrap_err();
        assert_eq!(err.0, "y");
    }
}
