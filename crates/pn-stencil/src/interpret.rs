//! Run-time evaluation of a [`StencilIr`]: the fallback when no compiled stencil exists
//! for the requested order/dimension/layout (same results as generated code up to rounding).
//!
//! **How.** [`InterpretedKernel::new`] translates every row once into a flat program, the
//! way the generator writes Rust (`pn-codegen`): the row's distinct field reads and `1/h`
//! values become *loads*, read once per row into slots, and each weight becomes postfix
//! operations on those slots, with the constants of a product folded into one factor and a
//! constant times one slot (every transport term, `±c/h`) a single operation. Evaluating a
//! row then costs one `FieldContext` call per distinct load and a short loop over the
//! operations, instead of a walk over boxed expression trees with one call per leaf
//! ([`InterpretedKernel::eval_row_tree`], kept as the reference, [`TreeWalk`]). `pn bench`
//! times all three ("Compiled against interpreted stencils").

use crate::ir::{
    Dim, FieldContext, FieldRef, HalfOffset, MomentPlacement, StencilIr, StencilKernel,
    TermPattern, Weight,
};

/// Largest evaluation stack and slot count of a flat row program; a row needing more keeps
/// walking its trees (none of the derived P_N stencils does: `pn-kernels`' tests).
const MAX_SLOTS: usize = 32;

/// A value a row reads from its context once.
#[derive(Clone, Debug, PartialEq)]
enum Load {
    InvH(usize),
    Field(FieldRef, HalfOffset),
}

/// One postfix operation.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Op {
    /// Push a constant.
    Const(f64),
    /// Push a slot.
    Slot(u32),
    /// Push constant × slot.
    ScaledSlot(f64, u32),
    /// Replace the top `n` values by their sum.
    Add(u32),
    /// Replace the top `n` values by their product.
    Mul(u32),
    /// Replace the top value by its reciprocal.
    Recip,
}

/// The flat program of one row: loads, then the operations of each weight (the program of
/// weight `k` is `ops[ends[k-1]..ends[k]]`, the last one the right-hand side).
#[derive(Clone, Debug, PartialEq)]
struct RowProgram {
    loads: Vec<Load>,
    ops: Vec<Op>,
    ends: Vec<usize>,
}

impl RowProgram {
    /// Translates `terms` (the terms' weights) and `rhs` (summed); `None` when the row
    /// needs more than [`MAX_SLOTS`] slots or stack entries.
    fn new(terms: &[&Weight], rhs: &[Weight]) -> Option<RowProgram> {
        let mut p = RowProgram {
            loads: vec![],
            ops: vec![],
            ends: vec![],
        };
        for w in terms {
            p.emit(w);
            p.ends.push(p.ops.len());
        }
        match rhs {
            [] => p.ops.push(Op::Const(0.0)),
            [w] => p.emit(w),
            ws => {
                for w in ws {
                    p.emit(w);
                }
                p.ops.push(Op::Add(ws.len() as u32));
            }
        }
        p.ends.push(p.ops.len());
        (p.loads.len() <= MAX_SLOTS && p.max_depth() <= MAX_SLOTS).then_some(p)
    }

    fn slot(&mut self, load: Load) -> u32 {
        match self.loads.iter().position(|l| *l == load) {
            Some(i) => i as u32,
            None => {
                self.loads.push(load);
                (self.loads.len() - 1) as u32
            }
        }
    }

    /// Appends the postfix program of `w` (leaves one value on the stack).
    fn emit(&mut self, w: &Weight) {
        match w {
            Weight::Const(c) => self.ops.push(Op::Const(*c)),
            Weight::InvH(axis) => {
                let s = self.slot(Load::InvH(*axis));
                self.ops.push(Op::Slot(s));
            }
            Weight::Field { field, offset } => {
                let s = self.slot(Load::Field(field.clone(), *offset));
                self.ops.push(Op::Slot(s));
            }
            Weight::Add(ws) => match ws.as_slice() {
                [] => self.ops.push(Op::Const(0.0)),
                [w] => self.emit(w),
                ws => {
                    for w in ws {
                        self.emit(w);
                    }
                    self.ops.push(Op::Add(ws.len() as u32));
                }
            },
            Weight::Mul(ws) => {
                // Constants folded into one factor (the product is taken in another order
                // than the tree walk's: equal to rounding).
                let c: f64 = ws
                    .iter()
                    .filter_map(|w| match w {
                        Weight::Const(c) => Some(*c),
                        _ => None,
                    })
                    .product();
                let rest: Vec<&Weight> = ws
                    .iter()
                    .filter(|w| !matches!(w, Weight::Const(_)))
                    .collect();
                match rest.as_slice() {
                    [] => self.ops.push(Op::Const(c)),
                    [leaf @ (Weight::InvH(_) | Weight::Field { .. })] => {
                        self.emit(leaf);
                        if c != 1.0 {
                            if let Some(Op::Slot(s)) = self.ops.pop() {
                                self.ops.push(Op::ScaledSlot(c, s));
                            }
                        }
                    }
                    rest => {
                        for w in rest {
                            self.emit(w);
                        }
                        let mut n = rest.len() as u32;
                        if c != 1.0 {
                            self.ops.push(Op::Const(c));
                            n += 1;
                        }
                        if n > 1 {
                            self.ops.push(Op::Mul(n));
                        }
                    }
                }
            }
            Weight::Recip(w) => {
                self.emit(w);
                self.ops.push(Op::Recip);
            }
        }
    }

    /// The deepest the evaluation stack gets.
    fn max_depth(&self) -> usize {
        let (mut d, mut max) = (0usize, 0usize);
        for op in &self.ops {
            match op {
                Op::Const(_) | Op::Slot(_) | Op::ScaledSlot(..) => d += 1,
                Op::Add(n) | Op::Mul(n) => d = d + 1 - *n as usize,
                Op::Recip => {}
            }
            max = max.max(d);
        }
        max
    }

    fn eval(&self, ctx: &dyn FieldContext, weights: &mut [f64]) -> f64 {
        let mut slots = [0.0f64; MAX_SLOTS];
        for (s, load) in slots.iter_mut().zip(&self.loads) {
            *s = match load {
                Load::InvH(axis) => ctx.inv_h(*axis),
                Load::Field(field, offset) => ctx.field(field, *offset),
            };
        }
        let mut stack = [0.0f64; MAX_SLOTS];
        let mut start = 0;
        let mut rhs = 0.0;
        let last = self.ends.len() - 1;
        for (k, &end) in self.ends.iter().enumerate() {
            let program = &self.ops[start..end];
            start = end;
            // Most weights are one operation (a transport term's ±c/h): no stack.
            let value = match program {
                [Op::Const(c)] => *c,
                [Op::Slot(s)] => slots[*s as usize],
                [Op::ScaledSlot(c, s)] => c * slots[*s as usize],
                _ => Self::run(program, &slots, &mut stack),
            };
            if k == last {
                rhs = value;
            } else if let Some(w) = weights.get_mut(k) {
                *w = value;
            }
        }
        rhs
    }

    /// Runs one weight's postfix `program` on `stack`; returns its value.
    fn run(program: &[Op], slots: &[f64; MAX_SLOTS], stack: &mut [f64; MAX_SLOTS]) -> f64 {
        let mut sp = 0usize;
        {
            for op in program {
                match *op {
                    Op::Const(c) => {
                        stack[sp] = c;
                        sp += 1;
                    }
                    Op::Slot(s) => {
                        stack[sp] = slots[s as usize];
                        sp += 1;
                    }
                    Op::ScaledSlot(c, s) => {
                        stack[sp] = c * slots[s as usize];
                        sp += 1;
                    }
                    Op::Add(n) => {
                        let lo = sp - n as usize;
                        stack[lo] = stack[lo..sp].iter().sum();
                        sp = lo + 1;
                    }
                    Op::Mul(n) => {
                        let lo = sp - n as usize;
                        stack[lo] = stack[lo..sp].iter().product();
                        sp = lo + 1;
                    }
                    Op::Recip => stack[sp - 1] = 1.0 / stack[sp - 1],
                }
            }
        }
        stack[0]
    }
}

/// A [`StencilKernel`] that evaluates the IR's weight expressions for every row (as flat
/// per-row programs, see the module documentation).
#[derive(Clone, Debug)]
pub struct InterpretedKernel {
    ir: StencilIr,
    patterns: Vec<Vec<TermPattern>>,
    /// Per row: its flat program, or `None` to walk the trees.
    programs: Vec<Option<RowProgram>>,
}

impl InterpretedKernel {
    /// Wraps `ir`.
    pub fn new(ir: StencilIr) -> InterpretedKernel {
        let patterns = ir
            .rows
            .iter()
            .map(|row| {
                row.terms
                    .iter()
                    .map(|t| TermPattern {
                        moment: t.moment,
                        offset: t.offset,
                    })
                    .collect()
            })
            .collect();
        let programs = ir
            .rows
            .iter()
            .map(|row| {
                let terms: Vec<&Weight> = row.terms.iter().map(|t| &t.weight).collect();
                RowProgram::new(&terms, &row.rhs)
            })
            .collect();
        InterpretedKernel {
            ir,
            patterns,
            programs,
        }
    }

    /// The underlying IR.
    pub fn ir(&self) -> &StencilIr {
        &self.ir
    }

    /// How many rows have no flat program and walk their trees (0 for the derived stencils).
    pub fn tree_walked_rows(&self) -> usize {
        self.programs.iter().filter(|p| p.is_none()).count()
    }

    /// Evaluates row `row` by walking its expression trees: what the interpreter did before
    /// the flat programs, kept as their reference (tests, `pn bench`).
    pub fn eval_row_tree(&self, row: usize, ctx: &dyn FieldContext, weights: &mut [f64]) -> f64 {
        let row = &self.ir.rows[row];
        for (w, t) in weights.iter_mut().zip(&row.terms) {
            *w = t.weight.eval(ctx);
        }
        row.rhs.iter().map(|w| w.eval(ctx)).sum()
    }
}

impl StencilKernel for InterpretedKernel {
    fn name(&self) -> &str {
        &self.ir.name
    }
    fn dim(&self) -> Dim {
        self.ir.dim
    }
    fn moments(&self) -> &[MomentPlacement] {
        &self.ir.moments
    }
    fn pattern(&self, row: usize) -> &[TermPattern] {
        &self.patterns[row]
    }
    fn eval_row(&self, row: usize, ctx: &dyn FieldContext, weights: &mut [f64]) -> f64 {
        match &self.programs[row] {
            Some(p) => p.eval(ctx, weights),
            None => self.eval_row_tree(row, ctx, weights),
        }
    }
}

/// The interpreter as it was before its flat row programs, as a [`StencilKernel`]: every
/// weight's expression tree walked per row ([`InterpretedKernel::eval_row_tree`]). The
/// reference the flat programs are tested against, and the third kind `pn bench` times.
pub struct TreeWalk<'a>(pub &'a InterpretedKernel);

impl StencilKernel for TreeWalk<'_> {
    fn name(&self) -> &str {
        self.0.name()
    }
    fn dim(&self) -> Dim {
        self.0.dim()
    }
    fn moments(&self) -> &[MomentPlacement] {
        self.0.moments()
    }
    fn pattern(&self, row: usize) -> &[TermPattern] {
        self.0.pattern(row)
    }
    fn eval_row(&self, row: usize, ctx: &dyn FieldContext, weights: &mut [f64]) -> f64 {
        self.0.eval_row_tree(row, ctx, weights)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    struct Ctx;
    impl FieldContext for Ctx {
        fn field(&self, field: &FieldRef, offset: HalfOffset) -> f64 {
            let base = match field {
                FieldRef::SigmaT => 3.0,
                FieldRef::SigmaS => 2.0,
                FieldRef::SigmaA => 1.0,
                FieldRef::PhaseMoment(l) => 0.5f64.powi(*l as i32),
                FieldRef::Source { l, m } => 1.0 + *l as f64 + 0.1 * *m as f64,
                FieldRef::Diffusion => 0.25,
            };
            base + 0.01 * (offset[0] + 2 * offset[1] + 3 * offset[2]) as f64
        }
        fn inv_h(&self, axis: usize) -> f64 {
            [4.0, 5.0, 7.0][axis]
        }
    }

    fn field(f: FieldRef, o: HalfOffset) -> Weight {
        Weight::Field {
            field: f,
            offset: o,
        }
    }

    /// Every operation kind, nested, against the tree walk: a product with several
    /// constants and one slot, a constant-only product, an empty sum and product, a
    /// reciprocal of a sum, a repeated load, a multi-term right-hand side.
    #[test]
    fn flat_programs_equal_the_tree_walk() {
        let w = vec![
            Weight::Mul(vec![
                Weight::Const(-0.5),
                Weight::InvH(1),
                Weight::Const(3.0),
            ]),
            Weight::Mul(vec![Weight::Const(2.0), Weight::Const(4.0)]),
            Weight::Add(vec![
                field(FieldRef::SigmaT, [0, 0, 0]),
                Weight::Mul(vec![
                    Weight::Const(-1.0),
                    field(FieldRef::PhaseMoment(2), [0, 0, 0]),
                    field(FieldRef::SigmaS, [1, 0, -1]),
                ]),
            ]),
            Weight::Recip(Box::new(Weight::Add(vec![
                field(FieldRef::SigmaT, [0, 0, 0]),
                Weight::InvH(2),
            ]))),
            Weight::Add(vec![]),
            Weight::Mul(vec![]),
            Weight::Mul(vec![
                Weight::Recip(Box::new(field(FieldRef::Diffusion, [1, 0, 0]))),
                Weight::InvH(0),
                Weight::InvH(0),
            ]),
        ];
        let rhs = vec![
            field(FieldRef::Source { l: 1, m: -1 }, [0, 0, 0]),
            Weight::Const(0.5),
        ];
        let refs: Vec<&Weight> = w.iter().collect();
        let p = RowProgram::new(&refs, &rhs).expect("fits");
        assert_eq!(p.loads.len(), 8, "each distinct load once: {:?}", p.loads);
        let mut got = vec![0.0; w.len()];
        let got_rhs = p.eval(&Ctx, &mut got);
        for (k, (g, t)) in got.iter().zip(&w).enumerate() {
            let want = t.eval(&Ctx);
            assert!(
                (g - want).abs() <= 1e-15 * want.abs(),
                "weight {k}: {g} vs {want}"
            );
        }
        let want_rhs: f64 = rhs.iter().map(|w| w.eval(&Ctx)).sum();
        assert!((got_rhs - want_rhs).abs() <= 1e-15 * want_rhs.abs());
        // A row without right-hand side terms has rhs 0.
        let p = RowProgram::new(&refs[..1], &[]).expect("fits");
        let mut one = [0.0];
        assert_eq!(p.eval(&Ctx, &mut one), 0.0);
        assert_eq!(one[0], -0.5 * 5.0 * 3.0);
    }

    /// A row with more distinct loads than slots keeps the tree walk.
    #[test]
    fn rows_beyond_the_slots_fall_back_to_the_tree() {
        let w: Vec<Weight> = (0..MAX_SLOTS as i32 + 1)
            .map(|i| field(FieldRef::SigmaT, [i, 0, 0]))
            .collect();
        let refs: Vec<&Weight> = w.iter().collect();
        assert!(RowProgram::new(&refs, &[]).is_none());
    }
}
