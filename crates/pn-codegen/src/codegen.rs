//! Rust code generation from the stencil IR, and the builder that `build.rs` calls
//! (in the style of `prost-build`).
//!
//! Every stencil becomes a module `<name>` with a unit struct `Kernel` implementing
//! [`pn_stencil::StencilKernel`]: the placement and the per-row sparsity patterns are
//! statics, and `eval_row` is a `match` over rows whose arms read each field once into a
//! local and then compute every weight with straight-line arithmetic. The generated file
//! also holds `KERNELS` (all stencils) and `find(name)`.

use std::path::{Path, PathBuf};

use proc_macro2::{Ident, Literal, Span, TokenStream};
use quote::quote;

use crate::discretize::{cda_ir, derive_pn, diffusion_ir};
use pn_stencil::Staggering;
use pn_stencil::{Dim, FieldRef, HalfOffset, StencilError, StencilIr, Weight};

/// Operator precedence of a generated expression, to parenthesise only where needed.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
enum Prec {
    Sum,
    Neg,
    Prod,
    Atom,
}

struct Code {
    tokens: TokenStream,
    prec: Prec,
}

impl Code {
    fn atom(tokens: TokenStream) -> Code {
        Code {
            tokens,
            prec: Prec::Atom,
        }
    }
    /// Tokens, parenthesised if the precedence is below `min`.
    fn at_least(self, min: Prec) -> TokenStream {
        if self.prec < min {
            let t = self.tokens;
            quote!((#t))
        } else {
            self.tokens
        }
    }
}

fn float(v: f64) -> TokenStream {
    let lit = Literal::f64_unsuffixed(v);
    quote!(#lit)
}

fn ident(s: &str) -> Ident {
    Ident::new(s, Span::call_site())
}

/// Per-row code generator: maps fields and 1/h to locals.
struct RowGen {
    fields: Vec<(FieldRef, HalfOffset)>,
}

impl RowGen {
    #[expect(
        clippy::expect_used,
        reason = "RowGen::fields is collected from every field reference of the row before any code is generated"
    )]
    fn field_ident(&self, f: &FieldRef, o: &HalfOffset) -> Ident {
        let k = self
            .fields
            .iter()
            .position(|(g, p)| g == f && p == o)
            .expect("fields are collected before generation");
        ident(&format!("f{k}"))
    }

    /// `(negative, |w|)`: pulls a leading negative constant out of `w`.
    #[expect(clippy::expect_used, reason = "the pop is under rest.len() == 1")]
    fn signed(&self, w: &Weight) -> (bool, Code) {
        match w {
            Weight::Const(c) if *c < 0.0 => (true, Code::atom(float(-c))),
            Weight::Mul(fs) => match fs.first() {
                Some(Weight::Const(c)) if *c < 0.0 => {
                    let mut rest: Vec<Weight> = fs[1..].to_vec();
                    if *c != -1.0 || rest.is_empty() {
                        rest.insert(0, Weight::Const(-c));
                    }
                    let w = if rest.len() == 1 {
                        rest.pop().expect("one factor")
                    } else {
                        Weight::Mul(rest)
                    };
                    (true, self.code(&w))
                }
                _ => (false, self.code_unsigned(w)),
            },
            _ => (false, self.code_unsigned(w)),
        }
    }

    /// Code for `w`, a leading negative constant factor written as a negation.
    fn code(&self, w: &Weight) -> Code {
        match self.signed(w) {
            (false, c) => c,
            (true, c) => {
                let t = c.at_least(Prec::Prod);
                Code {
                    tokens: quote!(-#t),
                    prec: Prec::Neg,
                }
            }
        }
    }

    /// Code for `w` as it stands (constants may be negative literals).
    fn code_unsigned(&self, w: &Weight) -> Code {
        match w {
            Weight::Const(c) if *c < 0.0 => {
                let t = float(-c);
                Code {
                    tokens: quote!(-#t),
                    prec: Prec::Neg,
                }
            }
            Weight::Const(c) => Code::atom(float(*c)),
            Weight::InvH(d) => Code::atom({
                let id = ident(&format!("ih{d}"));
                quote!(#id)
            }),
            Weight::Field { field, offset } => Code::atom({
                let id = self.field_ident(field, offset);
                quote!(#id)
            }),
            Weight::Add(ws) => {
                let mut tokens = TokenStream::new();
                for (i, t) in ws.iter().enumerate() {
                    let (neg, c) = self.signed(t);
                    match (i, neg) {
                        (0, false) => tokens.extend(c.at_least(Prec::Sum)),
                        (0, true) => {
                            let c = c.at_least(Prec::Prod);
                            tokens.extend(quote!(-#c));
                        }
                        (_, false) => {
                            let c = c.at_least(Prec::Neg);
                            tokens.extend(quote!(+ #c));
                        }
                        (_, true) => {
                            let c = c.at_least(Prec::Prod);
                            tokens.extend(quote!(- #c));
                        }
                    }
                }
                Code {
                    tokens,
                    prec: Prec::Sum,
                }
            }
            Weight::Mul(fs) => {
                let (num, den): (Vec<&Weight>, Vec<&Weight>) =
                    fs.iter().partition(|f| !matches!(f, Weight::Recip(_)));
                let mut tokens = TokenStream::new();
                if num.is_empty() {
                    tokens.extend(float(1.0));
                }
                for (i, f) in num.iter().enumerate() {
                    let c = self.code(f).at_least(Prec::Prod);
                    if i > 0 {
                        tokens.extend(quote!(*));
                    }
                    tokens.extend(c);
                }
                for f in den {
                    let Weight::Recip(inner) = f else {
                        unreachable!("partitioned on Recip")
                    };
                    let c = self.code(inner).at_least(Prec::Atom);
                    tokens.extend(quote!(/ #c));
                }
                Code {
                    tokens,
                    prec: Prec::Prod,
                }
            }
            Weight::Recip(inner) => {
                let one = float(1.0);
                let c = self.code(inner).at_least(Prec::Atom);
                Code {
                    tokens: quote!(#one / #c),
                    prec: Prec::Prod,
                }
            }
        }
    }
}

fn field_ref_tokens(f: &FieldRef) -> TokenStream {
    match f {
        FieldRef::SigmaT => quote!(FieldRef::SigmaT),
        FieldRef::SigmaS => quote!(FieldRef::SigmaS),
        FieldRef::SigmaA => quote!(FieldRef::SigmaA),
        FieldRef::PhaseMoment(l) => {
            let l = Literal::u32_unsuffixed(*l);
            quote!(FieldRef::PhaseMoment(#l))
        }
        FieldRef::Source { l, m } => {
            let l = Literal::u32_unsuffixed(*l);
            let m = Literal::i32_unsuffixed(*m);
            quote!(FieldRef::Source { l: #l, m: #m })
        }
        FieldRef::Diffusion => quote!(FieldRef::Diffusion),
    }
}

fn offset_tokens(o: &HalfOffset) -> TokenStream {
    let [x, y, z] = o.map(Literal::i32_unsuffixed);
    quote!([#x, #y, #z])
}

/// Checks that `name` can be a module name of the generated file.
fn check_name(name: &str) -> Result<(), StencilError> {
    let ok = name.chars().next().is_some_and(|c| c.is_ascii_lowercase())
        && name
            .chars()
            .all(|c| c.is_ascii_lowercase() || c.is_ascii_digit() || c == '_');
    if ok {
        Ok(())
    } else {
        Err(StencilError::Codegen(format!(
            "stencil name `{name}` is not a lowercase identifier"
        )))
    }
}

/// The module `<ir.name>` with the struct `Kernel` implementing `StencilKernel`.
pub fn kernel_tokens(ir: &StencilIr) -> Result<TokenStream, StencilError> {
    check_name(&ir.name)?;
    let module = ident(&ir.name);
    let name = &ir.name;
    let n = ir.moments.len();
    let dim = match ir.dim {
        Dim::Two => quote!(Dim::Two),
        Dim::Three => quote!(Dim::Three),
    };
    let moments = ir.moments.iter().map(|p| {
        let l = Literal::i32_unsuffixed(p.l);
        let m = Literal::i32_unsuffixed(p.m);
        let [sx, sy, sz] = p.shift.map(Literal::u8_unsuffixed);
        quote!(MomentPlacement { l: #l, m: #m, shift: [#sx, #sy, #sz] })
    });
    let pattern_names: Vec<Ident> = (0..ir.rows.len())
        .map(|r| ident(&format!("PATTERN_{r}")))
        .collect();
    let patterns = ir.rows.iter().zip(&pattern_names).map(|(row, pname)| {
        let k = row.terms.len();
        let entries = row.terms.iter().map(|t| {
            let q = Literal::usize_unsuffixed(t.moment);
            let o = offset_tokens(&t.offset);
            quote!(TermPattern { moment: #q, offset: #o })
        });
        quote!(static #pname: [TermPattern; #k] = [#(#entries),*];)
    });
    let arms = ir.rows.iter().enumerate().map(|(r, row)| {
        let mut fields = Vec::new();
        let mut inv_h = [false; 3];
        fn scan(w: &Weight, inv_h: &mut [bool; 3]) {
            match w {
                Weight::InvH(d) => inv_h[*d] = true,
                Weight::Add(ws) | Weight::Mul(ws) => ws.iter().for_each(|w| scan(w, inv_h)),
                Weight::Recip(w) => scan(w, inv_h),
                Weight::Const(_) | Weight::Field { .. } => {}
            }
        }
        for w in row.terms.iter().map(|t| &t.weight).chain(&row.rhs) {
            w.fields(&mut fields);
            scan(w, &mut inv_h);
        }
        let mut uniq: Vec<(FieldRef, HalfOffset)> = Vec::new();
        for f in fields {
            if !uniq.contains(&f) {
                uniq.push(f);
            }
        }
        let gen = RowGen { fields: uniq };
        let field_lets = gen.fields.iter().enumerate().map(|(k, (f, o))| {
            let id = ident(&format!("f{k}"));
            let f = field_ref_tokens(f);
            let o = offset_tokens(o);
            quote!(let #id = ctx.field(&#f, #o);)
        });
        let h_lets = (0..3).filter(|&d| inv_h[d]).map(|d| {
            let id = ident(&format!("ih{d}"));
            let dl = Literal::usize_unsuffixed(d);
            quote!(let #id = ctx.inv_h(#dl);)
        });
        let assigns = row.terms.iter().enumerate().map(|(k, t)| {
            let kl = Literal::usize_unsuffixed(k);
            let c = gen.code(&t.weight).tokens;
            quote!(weights[#kl] = #c;)
        });
        let rhs = if row.rhs.is_empty() {
            float(0.0)
        } else if row.rhs.len() == 1 {
            gen.code(&row.rhs[0]).tokens
        } else {
            gen.code(&Weight::Add(row.rhs.clone())).tokens
        };
        let rl = Literal::usize_unsuffixed(r);
        quote! {
            #rl => {
                #(#h_lets)*
                #(#field_lets)*
                #(#assigns)*
                #rhs
            }
        }
    });
    let doc = format!(
        " Generated stencil `{name}` ({}D; unknowns per cell: {n}).",
        ir.dim.axes()
    );
    Ok(quote! {
        #[doc = #doc]
        #[allow(clippy::approx_constant, clippy::excessive_precision, clippy::unreadable_literal)]
        pub mod #module {
            use pn_stencil::{
                Dim, FieldContext, FieldRef, MomentPlacement, StencilKernel, TermPattern,
            };

            /// The stencil; evaluate through [`StencilKernel`].
            #[derive(Clone, Copy, Debug, Default)]
            pub struct Kernel;

            static MOMENTS: [MomentPlacement; #n] = [#(#moments),*];
            #(#patterns)*
            static PATTERNS: [&[TermPattern]; #n] = [#(&#pattern_names),*];

            impl StencilKernel for Kernel {
                fn name(&self) -> &str {
                    #name
                }
                fn dim(&self) -> Dim {
                    #dim
                }
                fn moments(&self) -> &[MomentPlacement] {
                    &MOMENTS
                }
                fn pattern(&self, row: usize) -> &[TermPattern] {
                    PATTERNS[row]
                }
                #[expect(clippy::panic, reason = "rows are 0..moments().len() by the StencilKernel contract; like PATTERNS[row], another row is the caller's bug")]
                fn eval_row(&self, row: usize, ctx: &dyn FieldContext, weights: &mut [f64]) -> f64 {
                    match row {
                        #(#arms)*
                        _ => panic!("row {row} out of range for stencil {}", #name),
                    }
                }
            }
        }
    })
}

/// A formatted Rust source file with one module per stencil, `KERNELS` and `find`.
pub fn generate_source(irs: &[StencilIr]) -> Result<String, StencilError> {
    let mut modules = Vec::new();
    let mut seen = Vec::new();
    for ir in irs {
        if seen.contains(&ir.name) {
            return Err(StencilError::Codegen(format!(
                "duplicate stencil `{}`",
                ir.name
            )));
        }
        seen.push(ir.name.clone());
        modules.push(kernel_tokens(ir)?);
    }
    let idents: Vec<Ident> = irs.iter().map(|ir| ident(&ir.name)).collect();
    let count = irs.len();
    let names: Vec<&str> = irs.iter().map(|ir| ir.name.as_str()).collect();
    let prints: Vec<u64> = irs.iter().map(StencilIr::fingerprint).collect();
    let file = quote! {
        #(#modules)*

        /// Every compiled stencil.
        pub static KERNELS: [&dyn pn_stencil::StencilKernel; #count] =
            [#(&#idents::Kernel),*];

        /// The compiled stencil called `name`, if it was generated.
        pub fn find(name: &str) -> Option<&'static dyn pn_stencil::StencilKernel> {
            KERNELS.iter().copied().find(|k| k.name() == name)
        }

        /// `(name, StencilIr::fingerprint)` of every compiled stencil.
        pub static FINGERPRINTS: [(&str, u64); #count] = [#((#names, #prints)),*];

        /// The fingerprint of the IR the compiled stencil `name` was generated from.
        pub fn fingerprint(name: &str) -> Option<u64> {
            FINGERPRINTS.iter().find(|(n, _)| *n == name).map(|(_, f)| *f)
        }
    };
    let parsed: syn::File = syn::parse2(file)
        .map_err(|e| StencilError::Codegen(format!("generated code does not parse: {e}")))?;
    Ok(format!(
        "// @generated by pn-codegen from the derived equations; do not edit.\n{}",
        prettyplease::unparse(&parsed)
    ))
}

/// Parses a comma-separated list of P_N orders from the environment variable `var`
/// (value `value`; `None` means unset → `default`). Errors name the variable.
pub fn parse_orders(
    var: &str,
    value: Option<&str>,
    default: &[usize],
) -> Result<Vec<usize>, StencilError> {
    let Some(value) = value else {
        return Ok(default.to_vec());
    };
    let mut orders = Vec::new();
    for part in value.split(',').map(str::trim) {
        if value.trim().is_empty() {
            // An empty list compiles no P_N stencils (everything is interpreted).
            break;
        }
        let n: usize = part.parse().map_err(|_| {
            StencilError::Config(format!(
                "invalid {var}={value:?}: `{part}` is not a non-negative integer \
                 (expected a comma-separated list of P_N orders such as 1,2,3)"
            ))
        })?;
        if n == 0 || n > 15 {
            return Err(StencilError::Config(format!(
                "invalid {var}={value:?}: order {n} is outside 1..=15"
            )));
        }
        if !orders.contains(&n) {
            orders.push(n);
        }
    }
    orders.sort_unstable();
    Ok(orders)
}

/// Builder for the compiled-stencil file (used by the `pn-kernels` build script).
#[derive(Clone, Debug)]
pub struct Builder {
    orders: Vec<usize>,
    dims: Vec<Dim>,
    layouts: Vec<Staggering>,
    diffusion: bool,
    /// PDE text files (docs/pde-text.md) compiled with their default parameters.
    pdes: Vec<PathBuf>,
}

impl Default for Builder {
    fn default() -> Self {
        Builder::new()
    }
}

impl Builder {
    /// Default orders used when `PN_ORDERS` is unset.
    pub const DEFAULT_ORDERS: [usize; 5] = [1, 2, 3, 4, 5];

    /// Orders 1–5, 2D and 3D, staggered and collocated, with CDA and diffusion stencils.
    pub fn new() -> Builder {
        Builder {
            orders: Builder::DEFAULT_ORDERS.to_vec(),
            dims: vec![Dim::Two, Dim::Three],
            layouts: vec![Staggering::Staggered, Staggering::Collocated],
            diffusion: true,
            pdes: Vec::new(),
        }
    }

    /// Sets the orders from `value`, the value of the variable `var` (e.g. `PN_ORDERS`;
    /// `None`: unset, the [`Builder::DEFAULT_ORDERS`]); see [`parse_orders`].
    pub fn orders_from(mut self, var: &str, value: Option<&str>) -> Result<Builder, StencilError> {
        self.orders = parse_orders(var, value, &Builder::DEFAULT_ORDERS)?;
        Ok(self)
    }

    /// Sets the P_N orders.
    pub fn orders(mut self, orders: &[usize]) -> Builder {
        self.orders = orders.to_vec();
        self
    }

    /// Sets the dimensions.
    pub fn dims(mut self, dims: &[Dim]) -> Builder {
        self.dims = dims.to_vec();
        self
    }

    /// Sets the layouts of the P_N stencils.
    pub fn layouts(mut self, layouts: &[Staggering]) -> Builder {
        self.layouts = layouts.to_vec();
        self
    }

    /// Whether to include the CDA and diffusion (D as a field) stencils.
    pub fn diffusion(mut self, yes: bool) -> Builder {
        self.diffusion = yes;
        self
    }

    /// Adds PDE text files (docs/pde-text.md), compiled in every dimension of the builder
    /// with their default parameters, as `pde_<name>_<d>d`.
    pub fn pde_files(mut self, files: &[PathBuf]) -> Builder {
        self.pdes.extend(files.iter().cloned());
        self
    }

    /// Adds the PDE files named by `value`, the value of a variable such as `PN_PDES`
    /// (comma-separated paths; `None`, unset: every `*.pde` in `default_dir`, sorted;
    /// empty: none).
    pub fn pde_files_from(self, value: Option<&str>, default_dir: &Path) -> Builder {
        let files: Vec<PathBuf> = match value {
            Some(v) => v
                .split(',')
                .map(str::trim)
                .filter(|s| !s.is_empty())
                .map(PathBuf::from)
                .collect(),
            None => {
                let mut fs: Vec<PathBuf> = std::fs::read_dir(default_dir)
                    .map(|rd| {
                        rd.filter_map(|e| e.ok().map(|e| e.path()))
                            .filter(|p| p.extension().is_some_and(|x| x == "pde"))
                            .collect()
                    })
                    .unwrap_or_default();
                fs.sort();
                fs
            }
        };
        self.pde_files(&files)
    }

    /// All stencil IRs the builder would compile.
    pub fn irs(&self) -> Result<Vec<StencilIr>, StencilError> {
        let mut irs = Vec::new();
        for &order in &self.orders {
            let sys = derive_pn(order)?;
            for &dim in &self.dims {
                for &layout in &self.layouts {
                    irs.push(crate::discretize::pn_ir(&sys, dim, layout)?);
                }
            }
        }
        if self.diffusion {
            for &dim in &self.dims {
                irs.push(cda_ir(dim)?);
                irs.push(diffusion_ir(dim)?);
            }
        }
        for path in &self.pdes {
            let src = std::fs::read_to_string(path)
                .map_err(|e| StencilError::Config(format!("reading {}: {e}", path.display())))?;
            let pde = crate::text::parse_pde(&src, &[])
                .map_err(|e| StencilError::Config(format!("{}: {e}", path.display())))?;
            for &dim in &self.dims {
                irs.push(
                    pde.ir(dim)
                        .map_err(|e| StencilError::Config(format!("{}: {e}", path.display())))?,
                );
            }
        }
        Ok(irs)
    }

    /// The generated Rust source of every stencil of the builder ([`generate_source`] of
    /// [`Builder::irs`]); the caller writes it (a build script into `OUT_DIR`).
    pub fn source(&self) -> Result<String, StencilError> {
        generate_source(&self.irs()?)
    }

    /// For build scripts, which read the environment and write the file themselves: the
    /// source of `stencils.rs` for the P_N orders in `orders` (the value of `PN_ORDERS`;
    /// `None`: unset, orders 1–5) and the PDE text files in `pdes` (the value of `PN_PDES`;
    /// `None`: every `*.pde` in `pde_dir`), and the paths the build script declares with
    /// `cargo:rerun-if-changed` (`pde_dir` and every PDE file). Cargo re-runs the build
    /// script by itself when this crate or `cas` (its build dependencies) change.
    pub fn compile_for_build_script(
        orders: Option<&str>,
        pdes: Option<&str>,
        pde_dir: &Path,
    ) -> Result<BuildScriptOutput, StencilError> {
        let builder = Builder::new()
            .orders_from("PN_ORDERS", orders)?
            .pde_files_from(pdes, pde_dir);
        let mut rerun_if_changed = vec![pde_dir.to_path_buf()];
        rerun_if_changed.extend(builder.pdes.iter().cloned());
        Ok(BuildScriptOutput {
            source: builder.source()?,
            rerun_if_changed,
        })
    }
}

/// What [`Builder::compile_for_build_script`] returns.
#[derive(Clone, Debug)]
pub struct BuildScriptOutput {
    /// The generated source, for `OUT_DIR/stencils.rs`.
    pub source: String,
    /// The paths the build script declares with `cargo:rerun-if-changed`.
    pub rerun_if_changed: Vec<PathBuf>,
}
