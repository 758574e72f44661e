//! Field evaluation for one stencil row: implements [`FieldContext`] on top of a [`Problem`].
//!
//! A field requested at `offset` half cells from the row is evaluated at the absolute
//! half-coordinate `row + offset`, i.e. at world position `min + (row + offset)·h/2`
//! (exact for analytic fields, averaged between cell centres for voxel data, see
//! [`crate::field`]). Invalid coefficients are recorded and reported after the row.

use crate::field::{Point, Sampling};
use crate::problem::Coefficients;
use crate::problem::{CoefficientError, Problem, Scattering};
use pn_stencil::{FieldContext, FieldRef, HalfOffset};
use std::cell::{Cell, RefCell};

/// The field context of one row location.
pub struct RowContext<'a> {
    problem: &'a Problem,
    inv_h: [f64; 3],
    /// Half a cell per axis, `h / 2` ([`crate::problem::Grid::coord`] as `min + half · h/2`,
    /// the same value: halving is exact).
    half_h: [f64; 3],
    row: [i64; 3],
    /// The coefficients last evaluated for this row, at that offset: a row's σ_t and σ_s
    /// at one position (its collision weight `σ_t − λ_l σ_s` reads both) come from one
    /// evaluation.
    last: Cell<Option<(HalfOffset, Coefficients)>>,
    error: RefCell<Option<CoefficientError>>,
}

impl<'a> RowContext<'a> {
    /// A context for the row at absolute half-coordinate `row`.
    pub fn new(problem: &'a Problem, row: [i64; 3]) -> Self {
        let g = &problem.grid;
        Self {
            problem,
            inv_h: [1.0 / g.h(0), 1.0 / g.h(1), 1.0 / g.h(2)],
            half_h: [0.5 * g.h(0), 0.5 * g.h(1), 0.5 * g.h(2)],
            row,
            last: Cell::new(None),
            error: RefCell::new(None),
        }
    }

    /// Moves the context to another row, clearing nothing but the position.
    pub fn set_row(&mut self, row: [i64; 3]) {
        self.row = row;
        self.last.set(None);
    }

    /// The coefficients at `offset` from the row (see [`Problem::coefficients`]), from the
    /// last evaluation where it was at the same offset.
    fn coefficients(&self, offset: HalfOffset) -> Result<Coefficients, CoefficientError> {
        if let Some((at, c)) = self.last.get() {
            if at == offset {
                return Ok(c);
            }
        }
        let c = self.problem.coefficients(self.point(offset))?;
        self.last.set(Some((offset, c)));
        Ok(c)
    }

    /// The first invalid coefficient met since the last call, if any.
    pub fn take_error(&self) -> Option<CoefficientError> {
        self.error.borrow_mut().take()
    }

    /// World position of the row plus `offset`.
    pub fn point(&self, offset: HalfOffset) -> Point {
        let min = &self.problem.grid.min;
        std::array::from_fn(|d| min[d] + (self.row[d] + offset[d] as i64) as f64 * self.half_h[d])
    }

    fn record<T: Default>(&self, r: Result<T, CoefficientError>) -> T {
        match r {
            Ok(v) => v,
            Err(e) => {
                let mut slot = self.error.borrow_mut();
                if slot.is_none() {
                    *slot = Some(e);
                }
                T::default()
            }
        }
    }
}

impl FieldContext for RowContext<'_> {
    fn field(&self, field: &FieldRef, offset: HalfOffset) -> f64 {
        let pb = self.problem;
        match field {
            FieldRef::SigmaT => self.record(self.coefficients(offset).map(|c| c.sigma_t)),
            FieldRef::SigmaS => self.record(self.coefficients(offset).map(|c| c.sigma_s)),
            FieldRef::SigmaA => {
                self.record(self.coefficients(offset).map(|c| c.sigma_t - c.sigma_s))
            }
            FieldRef::PhaseMoment(l) => pb.phase.moment(*l),
            FieldRef::Source { l, m } => self.record(pb.source(*l, *m, self.point(offset))),
            // Classical diffusion coefficient D = 1/(3 σ_tr), σ_tr = σ_t − σ_s λ_1 p_1
            // (docs/design.md §2.2).
            FieldRef::Diffusion => {
                self.record(self.coefficients(offset).map(|c| c.diffusion(&pb.phase)))
            }
        }
    }

    fn inv_h(&self, axis: usize) -> f64 {
        self.inv_h[axis]
    }
}

/// `problem` with its analytic fields sampled by `sampling` (see [`Sampling`]): with
/// `Average(n)` every analytic σ_t, σ_s/albedo and source field is replaced by its mean over
/// the control volume of one cell (`h` per active axis) around the evaluation point. Call it
/// after the resolution is final (the control volume follows the grid). `Exact` returns an
/// unchanged clone, so the default path is bit-identical to not calling it.
///
/// Derived coefficients are formed from the averaged fields: σ_a = ⟨σ_t⟩ − ⟨σ_s⟩, and the
/// diffusion coefficient 1/(3σ_tr) of the averaged σ_t and σ_s (an arithmetic, not a
/// harmonic, mean of σ_tr across an interface). With an albedo field σ_s = ⟨α⟩⟨σ_t⟩.
pub fn apply_sampling(problem: &Problem, sampling: Sampling) -> Problem {
    let mut out = problem.clone();
    if sampling == Sampling::Exact {
        return out;
    }
    let g = &problem.grid;
    let axes = g.dim.axes();
    let sampling = sampling.resolved(axes);
    let size: Point = [0, 1, 2].map(|d| if d < axes { g.h(d) } else { 0.0 });
    out.sigma_t = problem.sigma_t.with_sampling(sampling, size);
    out.scattering = match &problem.scattering {
        Scattering::SigmaS(f) => Scattering::SigmaS(f.with_sampling(sampling, size)),
        Scattering::Albedo(f) => Scattering::Albedo(f.with_sampling(sampling, size)),
    };
    for s in &mut out.sources {
        s.field = s.field.with_sampling(sampling, size);
    }
    out
}
