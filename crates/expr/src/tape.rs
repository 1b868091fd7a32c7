//! A set of expressions compiled into one flat instruction tape for fast repeated numeric evaluation.
//!
//! Every DAG node below the outputs becomes at most one instruction, so shared subexpressions are evaluated
//! once per call. Sums and products are lowered to binary chains (with subtraction and division for negative
//! coefficients and exponents), integer powers to `powi`, ½-powers to `sqrt`, and powers of one base whose
//! exponents differ by an integer (`v^1.8`, `v^0.8`) share a single `powf`. Evaluation writes into a scratch
//! buffer that is reused between calls: no allocation per evaluation.

use crate::calculus::UnboundSymbol;
use crate::number::Number;
use crate::pool::{Id, Node, Pool, Symbol};
use crate::func::{Func, Func2};
use std::cell::RefCell;
use std::collections::HashMap;

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
}

struct Builder<'p> {
    pool: &'p Pool,
    inputs: HashMap<Symbol, u32>,
    n_inputs: usize,
    consts: Vec<f64>,
    const_slots: HashMap<u64, u32>,
    instrs: Vec<Instr>,
    memo: HashMap<Id, u32>,
    /// base slot → (exponent, slot) of non-integer powers already computed.
    powers: HashMap<u32, Vec<(Number, u32)>>,
    /// (base, fractional part of the exponent) → the smallest |exponent| with that fractional part.
    min_power: HashMap<(Id, Number), Number>,
    /// Instructions are emitted before constants are known; they are renumbered at the end.
    pending_consts: bool,
}

const OP_BASE: u32 = 1 << 30;
const CONST_BASE: u32 = 1 << 29;

impl Builder<'_> {
    fn constant(&mut self, x: f64) -> u32 {
        if let Some(&s) = self.const_slots.get(&x.to_bits()) {
            return s;
        }
        let s = CONST_BASE + self.consts.len() as u32;
        self.consts.push(x);
        self.const_slots.insert(x.to_bits(), s);
        s
    }

    fn emit(&mut self, i: Instr) -> u32 {
        self.pending_consts = true;
        self.instrs.push(i);
        OP_BASE + (self.instrs.len() - 1) as u32
    }

    fn lower(&mut self, e: Id) -> Result<u32, UnboundSymbol> {
        if let Some(&s) = self.memo.get(&e) {
            return Ok(s);
        }
        let s = match self.pool.node(e) {
            Node::Num(n) => self.constant(n.to_f64()),
            Node::Pi => self.constant(std::f64::consts::PI),
            Node::Sym(sym) => *self
                .inputs
                .get(sym)
                .ok_or_else(|| UnboundSymbol(self.pool.symbol_name(*sym).to_string()))?,
            Node::Add(ts) => {
                let ts = ts.clone();
                let mut acc: Option<u32> = None;
                let mut negs: Vec<u32> = Vec::new();
                for &t in ts.iter() {
                    let (neg, slot) = self.lower_signed(t)?;
                    if neg {
                        match acc {
                            Some(a) => acc = Some(self.emit(Instr::Sub(a, slot))),
                            None => negs.push(slot),
                        }
                    } else {
                        acc = Some(match acc {
                            Some(a) => self.emit(Instr::Add(a, slot)),
                            None => slot,
                        });
                        for n in std::mem::take(&mut negs) {
                            let a = acc.unwrap_or(slot);
                            acc = Some(self.emit(Instr::Sub(a, n)));
                        }
                    }
                }
                match acc {
                    Some(a) => a,
                    None => {
                        // Every term negative: −(t1 + t2 + …).
                        let mut sum = negs[0];
                        for &n in &negs[1..] {
                            sum = self.emit(Instr::Add(sum, n));
                        }
                        self.emit(Instr::Neg(sum))
                    }
                }
            }
            Node::Mul(_) | Node::Pow(..) => {
                let (neg, slot) = self.lower_product(e, false)?;
                if neg {
                    self.emit(Instr::Neg(slot))
                } else {
                    slot
                }
            }
            Node::Call(f, a) => {
                let (f, a) = (*f, *a);
                let sa = self.lower(a)?;
                self.emit(Instr::Call(f, sa))
            }
            Node::Call2(f, a, b) => {
                let (f, a, b) = (*f, *a, *b);
                let (sa, sb) = (self.lower(a)?, self.lower(b)?);
                self.emit(Instr::Call2(f, sa, sb))
            }
        };
        self.memo.insert(e, s);
        Ok(s)
    }

    /// A sum's term as (negative?, slot of its magnitude).
    fn lower_signed(&mut self, t: Id) -> Result<(bool, u32), UnboundSymbol> {
        match self.pool.node(t) {
            Node::Num(n) if n.is_negative() => Ok((true, self.constant(-n.to_f64()))),
            Node::Mul(_) => self.lower_product(t, true),
            _ => Ok((false, self.lower(t)?)),
        }
    }

    /// Lower a product (or a lone power) as coefficient · numerator / denominator. With `split_sign`, a
    /// negative coefficient is returned as a flag instead of being applied.
    fn lower_product(&mut self, e: Id, split_sign: bool) -> Result<(bool, u32), UnboundSymbol> {
        if !split_sign {
            if let Some(&s) = self.memo.get(&e) {
                return Ok((false, s));
            }
        }
        let factors: Vec<Id> = match self.pool.node(e) {
            Node::Mul(fs) => fs.to_vec(),
            _ => vec![e],
        };
        let mut coeff = 1.0;
        let mut num: Vec<u32> = Vec::new();
        let mut den: Vec<u32> = Vec::new();
        for f in factors {
            match self.pool.node(f) {
                Node::Num(n) => coeff *= n.to_f64(),
                Node::Pow(b, p) => {
                    let (b, p) = (*b, *p);
                    match self.pool.as_number(p) {
                        Some(k) if k.is_negative() => {
                            let s = self.lower_power(b, k.neg())?;
                            den.push(s)
                        }
                        Some(k) => {
                            let s = self.lower_power(b, k)?;
                            num.push(s)
                        }
                        None => {
                            let (sb, sp) = (self.lower(b)?, self.lower(p)?);
                            let s = self.emit(Instr::PowVar(sb, sp));
                            num.push(s)
                        }
                    }
                }
                _ => num.push(self.lower(f)?),
            }
        }
        let negative = coeff < 0.0;
        let mag = coeff.abs();
        let sign_applied = negative && !split_sign;
        let mut acc: Option<u32> = None;
        if mag != 1.0 || (num.is_empty() && !sign_applied) {
            acc = Some(self.constant(if sign_applied { -mag } else { mag }));
        } else if sign_applied && num.is_empty() {
            acc = Some(self.constant(-1.0));
        }
        let mut applied = mag != 1.0 || num.is_empty();
        for s in num {
            acc = Some(match acc {
                Some(a) => self.emit(Instr::Mul(a, s)),
                None => s,
            });
        }
        if let Some(first) = den.first().copied() {
            let mut d = first;
            for &s in &den[1..] {
                d = self.emit(Instr::Mul(d, s));
            }
            acc = Some(match acc {
                Some(a) => self.emit(Instr::Div(a, d)),
                None => self.emit(Instr::Recip(d)),
            });
        }
        let mut slot = acc.unwrap_or_else(|| self.constant(1.0));
        if sign_applied && !applied {
            slot = self.emit(Instr::Neg(slot));
            applied = true;
        }
        let _ = applied;
        if !split_sign {
            self.memo.insert(e, slot);
        }
        Ok((negative && split_sign, slot))
    }

    /// s · b^j for an integer j ≥ 0 (`j` exact; anything else falls back to powf of the difference).
    fn times_integer_power(&mut self, s: u32, sb: u32, j: Number) -> u32 {
        match j.as_integer() {
            Some(0) => s,
            Some(1) => self.emit(Instr::Mul(s, sb)),
            Some(i) if i > 0 && i <= i32::MAX as i128 => {
                let p = self.emit(Instr::Powi(sb, i as i32));
                self.emit(Instr::Mul(s, p))
            }
            _ => {
                let p = self.emit(Instr::Powf(sb, j.to_f64()));
                self.emit(Instr::Mul(s, p))
            }
        }
    }

    /// b^k for a positive number k: `powi`, `sqrt`, or one shared `powf` per base and fractional part.
    fn lower_power(&mut self, b: Id, k: Number) -> Result<u32, UnboundSymbol> {
        let sb = self.lower(b)?;
        if let Some(i) = k.as_integer().filter(|i| *i <= i32::MAX as i128) {
            return Ok(if i == 1 {
                sb
            } else {
                self.emit(Instr::Powi(sb, i as i32))
            });
        }
        let half = Number::ratio(1, 2);
        // Split k = m + frac with m integer ≥ 0.
        let kf = k.to_f64();
        let m = kf.floor();
        let frac = k.add(Number::from_f64(-m));
        let base_frac = if frac == half {
            self.emit(Instr::Sqrt(sb))
        } else {
            // Powers of one base whose exponents differ by an integer share one `powf`: the one with the
            // smallest exponent (found in a pre-pass), so the others are products b^q·b^j, never quotients
            // (which would give 0/0 at b = 0).
            let q = self.min_power.get(&(b, frac)).copied().unwrap_or(k);
            if let Some(list) = self.powers.get(&sb) {
                if let Some(&(_, s)) = list.iter().find(|(e, _)| *e == q) {
                    return Ok(self.times_integer_power(s, sb, k.add(q.neg())));
                }
            }
            let s = self.emit(Instr::Powf(sb, q.to_f64()));
            self.powers.entry(sb).or_default().push((q, s));
            return Ok(self.times_integer_power(s, sb, k.add(q.neg())));
        };
        let mi = m as i32;
        Ok(match mi {
            0 => base_frac,
            1 => self.emit(Instr::Mul(base_frac, sb)),
            _ => {
                let p = self.emit(Instr::Powi(sb, mi));
                self.emit(Instr::Mul(base_frac, p))
            }
        })
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
        }
    }
}

impl Tape {
    /// Compile `outputs`, whose free symbols must all be among `inputs` (in that order at evaluation).
    pub fn compile(pool: &Pool, outputs: &[Id], inputs: &[Symbol]) -> Result<Tape, UnboundSymbol> {
        let mut b = Builder {
            pool,
            inputs: inputs
                .iter()
                .enumerate()
                .map(|(i, &s)| (s, i as u32))
                .collect(),
            n_inputs: inputs.len(),
            consts: Vec::new(),
            const_slots: HashMap::new(),
            instrs: Vec::new(),
            memo: HashMap::new(),
            powers: HashMap::new(),
            min_power: HashMap::new(),
            pending_consts: false,
        };
        for id in pool.topological(outputs) {
            if let Node::Pow(base, p) = pool.node(id) {
                if let Some(k) = pool.as_number(*p) {
                    let k = if k.is_negative() { k.neg() } else { k };
                    if k.as_integer().is_some() {
                        continue;
                    }
                    let frac = k.add(Number::from_f64(-k.to_f64().floor()));
                    let e = b.min_power.entry((*base, frac)).or_insert(k);
                    if k.cmp_value(e) == std::cmp::Ordering::Less {
                        *e = k;
                    }
                }
            }
        }
        let mut outs = Vec::with_capacity(outputs.len());
        for &o in outputs {
            outs.push(b.lower(o)?);
        }
        let _ = b.pending_consts;
        // Renumber: inputs [0, n), constants [n, n + c), instructions after.
        let n = b.n_inputs as u32;
        let c = b.consts.len() as u32;
        let map = |s: u32| -> u32 {
            if s >= OP_BASE {
                n + c + (s - OP_BASE)
            } else if s >= CONST_BASE {
                n + (s - CONST_BASE)
            } else {
                s
            }
        };
        let instrs = b.instrs.iter().map(|i| i.remap(map)).collect();
        let tape = Tape {
            id: next_id(),
            n_inputs: b.n_inputs,
            consts: b.consts,
            instrs,
            outputs: outs.into_iter().map(map).collect(),
        };
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
                one[0] = exec(ins, g);
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
        };
        tape.validate();
        tape
    }

    pub fn n_inputs(&self) -> usize {
        self.n_inputs
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
            let v = exec(ins, |s: u32| unsafe { *ptr.add(s as usize) });
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
            let mut start = 0;
            while start < points {
                let len = BATCH.min(points - start);
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
                        Instr::Powi(x, k) => map1(dst, col(x), |a| a.powi(k)),
                        Instr::Sqrt(x) => map1(dst, col(x), f64::sqrt),
                        Instr::Powf(x, k) => map1(dst, col(x), |a| a.powf(k)),
                        Instr::Call(f, x) => map1(dst, col(x), |a| f.eval(a)),
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

/// Execute one instruction with operand values from `g`.
#[inline(always)]
fn exec(ins: &Instr, g: impl Fn(u32) -> f64) -> f64 {
    match *ins {
        Instr::Add(x, y) => g(x) + g(y),
        Instr::Sub(x, y) => g(x) - g(y),
        Instr::Mul(x, y) => g(x) * g(y),
        Instr::Div(x, y) => g(x) / g(y),
        Instr::Neg(x) => -g(x),
        Instr::Recip(x) => 1.0 / g(x),
        Instr::Powi(x, k) => g(x).powi(k),
        Instr::Sqrt(x) => g(x).sqrt(),
        Instr::Powf(x, k) => g(x).powf(k),
        Instr::PowVar(x, y) => g(x).powf(g(y)),
        Instr::Call(f, x) => f.eval(g(x)),
        Instr::Call2(f, x, y) => f.eval(g(x), g(y)),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

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
