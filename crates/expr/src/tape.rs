//! A set of expressions compiled into one flat instruction tape for fast repeated numeric evaluation.
//!
//! Every DAG node below the outputs becomes at most one instruction, so shared subexpressions are evaluated
//! once per call. Sums and products are lowered to binary chains (with subtraction and division for negative
//! coefficients and exponents), integer powers to `powi`, ½-powers to `sqrt`, and powers of one base whose
//! exponents differ by an integer (`v^1.8`, `v^0.8`) share a single `powf`. Evaluation writes into a scratch
//! buffer that is reused between calls: no allocation per evaluation.

use crate::number::Number;
use crate::pool::{Id, Node, Pool, Symbol};
use crate::rules::{Func, Func2};
use crate::calculus::UnboundSymbol;
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
            return Ok(if i == 1 { sb } else { self.emit(Instr::Powi(sb, i as i32)) });
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
    static SCRATCH: RefCell<Vec<f64>> = const { RefCell::new(Vec::new()) };
}

impl Tape {
    /// Compile `outputs`, whose free symbols must all be among `inputs` (in that order at evaluation).
    pub fn compile(pool: &Pool, outputs: &[Id], inputs: &[Symbol]) -> Result<Tape, UnboundSymbol> {
        let mut b = Builder {
            pool,
            inputs: inputs.iter().enumerate().map(|(i, &s)| (s, i as u32)).collect(),
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
        let instrs = b
            .instrs
            .iter()
            .map(|i| match *i {
                Instr::Add(x, y) => Instr::Add(map(x), map(y)),
                Instr::Sub(x, y) => Instr::Sub(map(x), map(y)),
                Instr::Mul(x, y) => Instr::Mul(map(x), map(y)),
                Instr::Div(x, y) => Instr::Div(map(x), map(y)),
                Instr::Neg(x) => Instr::Neg(map(x)),
                Instr::Recip(x) => Instr::Recip(map(x)),
                Instr::Powi(x, k) => Instr::Powi(map(x), k),
                Instr::Sqrt(x) => Instr::Sqrt(map(x)),
                Instr::Powf(x, k) => Instr::Powf(map(x), k),
                Instr::PowVar(x, y) => Instr::PowVar(map(x), map(y)),
                Instr::Call(f, x) => Instr::Call(f, map(x)),
                Instr::Call2(f, x, y) => Instr::Call2(f, map(x), map(y)),
            })
            .collect();
        Ok(Tape { n_inputs: b.n_inputs, consts: b.consts, instrs, outputs: outs.into_iter().map(map).collect() })
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
        for (i, ins) in self.instrs.iter().enumerate() {
            let g = |s: u32| buf[s as usize];
            let v = match *ins {
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
            };
            buf[base + i] = v;
        }
        for (o, &s) in out.iter_mut().zip(&self.outputs) {
            *o = buf[s as usize];
        }
    }

    /// Evaluate with the inputs given as consecutive slices (e.g. `&[xi, eta, params]`), using a
    /// per-thread scratch buffer: no allocation after the first call on a thread.
    pub fn eval_parts(&self, parts: &[&[f64]], out: &mut [f64]) {
        SCRATCH.with(|cell| {
            let mut buf = cell.borrow_mut();
            let n = self.n_slots();
            if buf.len() < n {
                buf.resize(n, 0.0);
            }
            let mut at = 0;
            for p in parts {
                buf[at..at + p.len()].copy_from_slice(p);
                at += p.len();
            }
            assert_eq!(at, self.n_inputs, "tape input count");
            let c0 = self.n_inputs;
            buf[c0..c0 + self.consts.len()].copy_from_slice(&self.consts);
            self.run(&mut buf, out);
        })
    }

    /// Evaluate into `out` with a per-thread scratch buffer (allocated once per thread, then reused).
    pub fn eval(&self, inputs: &[f64], out: &mut [f64]) {
        SCRATCH.with(|cell| {
            let mut buf = cell.borrow_mut();
            let n = self.n_slots();
            if buf.len() < n {
                buf.resize(n, 0.0);
            }
            let c0 = self.n_inputs;
            buf[c0..c0 + self.consts.len()].copy_from_slice(&self.consts);
            self.eval_in(&mut buf, inputs, out);
        })
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
        let names = ["c1", "c2", "c3", "c4", "v", "p", "x", "y", "z", "a", "b", "c"];
        let syms: Vec<Symbol> = names.iter().map(|n| p.symbol(n)).collect();
        let tape = Tape::compile(&p, &es, &syms).unwrap();
        let vals: Vec<f64> = (0..syms.len()).map(|i| 0.3 + 0.37 * i as f64).collect();
        let mut out = vec![0.0; es.len()];
        tape.eval(&vals, &mut out);
        let env: HashMap<Symbol, f64> = syms.iter().copied().zip(vals.iter().copied()).collect();
        for (k, &e) in es.iter().enumerate() {
            let want = p.eval(e, &env).unwrap();
            assert!((out[k] - want).abs() <= 1e-13 * want.abs().max(1.0), "{}: {} vs {want}", srcs[k], out[k]);
        }
        // v^1.8 and v^0.8 share one powf.
        let powfs = tape.instructions().iter().filter(|i| matches!(i, Instr::Powf(..))).count();
        assert_eq!(powfs, 1);
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
