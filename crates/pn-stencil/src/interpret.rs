//! Run-time evaluation of a [`StencilIr`]: the fallback when no compiled stencil exists
//! for the requested order/dimension/layout (slower than generated code, same results).

use crate::ir::{Dim, FieldContext, MomentPlacement, StencilIr, StencilKernel, TermPattern};

/// A [`StencilKernel`] that walks the IR's weight expressions for every row.
#[derive(Clone, Debug)]
pub struct InterpretedKernel {
    ir: StencilIr,
    patterns: Vec<Vec<TermPattern>>,
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
        InterpretedKernel { ir, patterns }
    }

    /// The underlying IR.
    pub fn ir(&self) -> &StencilIr {
        &self.ir
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
        let row = &self.ir.rows[row];
        for (w, t) in weights.iter_mut().zip(&row.terms) {
            *w = t.weight.eval(ctx);
        }
        row.rhs.iter().map(|w| w.eval(ctx)).sum()
    }
}
