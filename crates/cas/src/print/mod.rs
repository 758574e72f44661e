//! Printers: LaTeX for people, Rust expressions for generated code.

pub mod latex;
pub mod rust;
