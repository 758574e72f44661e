//! `pn-kernels` — the compiled stencils and the choice between compiled and interpreted.
//!
//! `build.rs` calls [`pn_codegen::codegen::Builder`] to generate one module per stencil into
//! `OUT_DIR` ([`compiled`]) for the P_N orders in `PN_ORDERS` (default 1–5; 2D and 3D,
//! staggered and collocated) plus CDA and diffusion (D as a field). [`pn_kernel`],
//! [`cda_kernel`] and [`diffusion_kernel`] return the compiled stencil when it exists and
//! otherwise derive the same IR and interpret it, with a one-line note in
//! [`KernelChoice::note`] for the caller to show (this library prints nothing).
//!
//! ```
//! use pn_kernels::{pn_kernel, Dim, Staggering};
//!
//! let p1 = pn_kernel(1, Dim::Three, Staggering::Staggered).unwrap();
//! assert!(p1.compiled);
//! assert_eq!(p1.kernel.moments().len(), 4); // (N+1)² moments
//! ```
#![warn(missing_docs)]

use std::sync::Arc;

/// Stencils generated at build time by `build.rs`: one module per stencil (e.g.
/// `p3_3d_staggered::Kernel`), `KERNELS` and `find(name)`.
#[allow(missing_docs)]
pub mod compiled {
    include!(concat!(env!("OUT_DIR"), "/stencils.rs"));
}

use anyhow::Context;
use pn_codegen::discretize;
pub use pn_stencil::Dim;
use pn_stencil::InterpretedKernel;
pub use pn_stencil::Staggering;
use pn_stencil::{FieldContext, MomentPlacement, StencilIr, StencilKernel, TermPattern};

/// Highest P_N order accepted at run time (that of the derivation).
pub const MAX_ORDER: usize = pn_stencil::MAX_ORDER;

/// A stencil ready for assembly.
#[derive(Clone)]
pub struct KernelChoice {
    /// The stencil.
    pub kernel: Arc<dyn StencilKernel>,
    /// Whether it is generated code (`false`: interpreted IR).
    pub compiled: bool,
    /// Why an interpreted stencil was chosen (a one-line `note: …` for the user, e.g.
    /// "note: stencil p7_3d_staggered was not compiled in (see PN_ORDERS); interpreting it
    /// at run time"); `None` for a compiled stencil and for IR interpreted by request.
    /// The library does not print it: a command shows it on stderr.
    pub note: Option<String>,
}

impl std::fmt::Debug for KernelChoice {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("KernelChoice")
            .field("kernel", &self.kernel.name())
            .field("compiled", &self.compiled)
            .field("note", &self.note)
            .finish()
    }
}

/// A compiled stencil behind an `Arc`.
struct Compiled(&'static dyn StencilKernel);

impl StencilKernel for Compiled {
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
        self.0.eval_row(row, ctx, weights)
    }
}

/// The compiled stencil `name`, else `build()` interpreted with a one-line note.
fn choose(
    name: &str,
    build: impl FnOnce() -> anyhow::Result<StencilIr>,
) -> anyhow::Result<KernelChoice> {
    if let Some(k) = compiled::find(name) {
        return Ok(KernelChoice {
            kernel: Arc::new(Compiled(k)),
            compiled: true,
            note: None,
        });
    }
    let ir = build()?;
    Ok(KernelChoice {
        kernel: Arc::new(InterpretedKernel::new(ir)),
        compiled: false,
        note: Some(format!(
            "note: stencil {name} was not compiled in (see PN_ORDERS); interpreting it at run time"
        )),
    })
}

/// The P_N stencil of `order` in `dim` with `layout`.
pub fn pn_kernel(order: usize, dim: Dim, layout: Staggering) -> anyhow::Result<KernelChoice> {
    anyhow::ensure!(
        (1..=MAX_ORDER).contains(&order),
        "P_N order {order} is outside 1..={MAX_ORDER}"
    );
    choose(&discretize::pn_name(order, dim, layout), || {
        discretize::pn_ir_for_order(order, dim, layout)
            .with_context(|| format!("building the P_{order} stencil"))
    })
}

/// Classical diffusion `−∇·(1/(3σ_tr) ∇L_0^0) + σ_a L_0^0 = Q_0^0` with
/// `σ_tr = σ_t − σ_s λ_1p_1` evaluated at the half positions.
pub fn cda_kernel(dim: Dim) -> anyhow::Result<KernelChoice> {
    choose(&format!("cda_{}d", dim.axes()), || {
        discretize::cda_ir(dim).context("building the CDA stencil")
    })
}

/// `−∇·(D ∇L_0^0) + σ_a L_0^0 = Q_0^0` with D the field `FieldRef::Diffusion` (for
/// Picard steps of flux-limited diffusion).
pub fn diffusion_kernel(dim: Dim) -> anyhow::Result<KernelChoice> {
    choose(&format!("diffusion_{}d", dim.axes()), || {
        discretize::diffusion_ir(dim).context("building the diffusion stencil")
    })
}

/// The stencil of a text PDE (docs/pde-text.md) in `dim`: the compiled one when `build.rs`
/// compiled the same IR (same name and [`StencilIr::fingerprint`]), else the IR interpreted;
/// with the PDE's `boundary marshak` conditions attached ([`pn_stencil::robin::WithBoundary`])
/// when it states them, which the runtime applies on the faces with `--bc marshak`.
pub fn pde_kernel(pde: &pn_codegen::text::TextPde, dim: Dim) -> anyhow::Result<KernelChoice> {
    let ir = pde
        .ir(dim)
        .map_err(|e| anyhow::anyhow!("PDE {}: {e}", pde.system.name))?;
    let choice = pde_ir_kernel(ir);
    let boundary = pde
        .boundary(dim, "marshak")
        .map_err(|e| anyhow::anyhow!("PDE {}: {e}", pde.system.name))?;
    Ok(match boundary {
        Some(boundary) => KernelChoice {
            kernel: Arc::new(pn_stencil::robin::WithBoundary {
                inner: choice.kernel,
                boundary,
            }),
            compiled: choice.compiled,
            note: choice.note,
        },
        None => choice,
    })
}

/// [`pde_kernel`] for a text PDE's IR already built ([`pn_codegen::text::TextPde::ir`]).
/// When a compiled stencil of that name exists but was built from other IR, the choice is
/// the interpreted IR with a [`KernelChoice::note`] saying so.
pub fn pde_ir_kernel(ir: StencilIr) -> KernelChoice {
    let mut note = None;
    if let (Some(k), Some(print)) = (compiled::find(&ir.name), compiled::fingerprint(&ir.name)) {
        if print == ir.fingerprint() {
            return KernelChoice {
                kernel: Arc::new(Compiled(k)),
                compiled: true,
                note: None,
            };
        }
        note = Some(format!(
            "note: the compiled stencil {} was built from a different text or other parameters; \
             interpreting this one",
            ir.name
        ));
    }
    KernelChoice {
        kernel: Arc::new(InterpretedKernel::new(ir)),
        compiled: false,
        note,
    }
}
