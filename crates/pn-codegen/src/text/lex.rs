//! The tokenizer of the PDE text syntax: identifiers, decimal numbers, operators and
//! statement-ending newlines, each with its 1-based line and column.

use super::PdeTextError;

/// A position in the source, 1-based.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub struct Pos {
    /// Line, from 1.
    pub line: usize,
    /// Column (in characters), from 1.
    pub col: usize,
}

/// A token.
#[derive(Clone, Debug, PartialEq)]
pub enum Tok {
    /// A name: letters, digits, `_`, not starting with a digit.
    Ident(String),
    /// A decimal literal as written (`3`, `0.25`, `1e-3`).
    Number(String),
    /// One of `+ - * / ^ ( ) , : =` or `..`.
    Op(&'static str),
    /// The end of a statement (a newline outside parentheses, or `;`).
    End,
}

/// A token with its position.
#[derive(Clone, Debug, PartialEq)]
pub struct Token {
    /// The token.
    pub tok: Tok,
    /// Where it starts.
    pub pos: Pos,
}

/// Operators, longest first.
const OPS: [&str; 11] = ["..", "+", "-", "*", "/", "^", "(", ")", ",", ":", "="];

/// Splits `src` into tokens. `#` starts a comment to the end of the line. A newline ends a
/// statement unless it is inside parentheses or the line ends with an operator that needs
/// a right operand (`+ - * / ^ , : = ..`), so long equations can continue on the next line.
pub fn tokenize(src: &str) -> Result<Vec<Token>, PdeTextError> {
    let mut out: Vec<Token> = Vec::new();
    let mut depth: i64 = 0;
    for (li, line) in src.lines().enumerate() {
        let chars: Vec<char> = line.chars().collect();
        let mut i = 0;
        while i < chars.len() {
            let c = chars[i];
            let pos = Pos {
                line: li + 1,
                col: i + 1,
            };
            if c == '#' {
                break;
            }
            if c.is_whitespace() {
                i += 1;
                continue;
            }
            if c == ';' {
                push_end(&mut out, pos);
                i += 1;
                continue;
            }
            if c.is_ascii_alphabetic() || c == '_' {
                let start = i;
                while i < chars.len() && (chars[i].is_ascii_alphanumeric() || chars[i] == '_') {
                    i += 1;
                }
                out.push(Token {
                    tok: Tok::Ident(chars[start..i].iter().collect()),
                    pos,
                });
                continue;
            }
            if c.is_ascii_digit()
                || (c == '.' && chars.get(i + 1).is_some_and(char::is_ascii_digit))
            {
                let start = i;
                while i < chars.len() && chars[i].is_ascii_digit() {
                    i += 1;
                }
                // A fraction, but not the range operator `..`.
                if i < chars.len() && chars[i] == '.' && chars.get(i + 1) != Some(&'.') {
                    i += 1;
                    while i < chars.len() && chars[i].is_ascii_digit() {
                        i += 1;
                    }
                }
                if i < chars.len() && (chars[i] == 'e' || chars[i] == 'E') {
                    let mut j = i + 1;
                    if j < chars.len() && (chars[j] == '+' || chars[j] == '-') {
                        j += 1;
                    }
                    if j < chars.len() && chars[j].is_ascii_digit() {
                        i = j;
                        while i < chars.len() && chars[i].is_ascii_digit() {
                            i += 1;
                        }
                    }
                }
                out.push(Token {
                    tok: Tok::Number(chars[start..i].iter().collect()),
                    pos,
                });
                continue;
            }
            let rest: String = chars[i..].iter().take(2).collect();
            let Some(op) = OPS.iter().find(|op| rest.starts_with(**op)) else {
                return Err(PdeTextError::at(pos, format!("unexpected character {c:?}")));
            };
            match *op {
                "(" => depth += 1,
                ")" => {
                    depth -= 1;
                    if depth < 0 {
                        return Err(PdeTextError::at(pos, "unmatched ')'"));
                    }
                }
                _ => {}
            }
            out.push(Token {
                tok: Tok::Op(op),
                pos,
            });
            i += op.len();
        }
        let continues = matches!(
            out.last(),
            Some(Token {
                tok: Tok::Op("+" | "-" | "*" | "/" | "^" | "," | ":" | "=" | ".." | "("),
                ..
            })
        );
        if depth == 0 && !continues {
            push_end(
                &mut out,
                Pos {
                    line: li + 1,
                    col: chars.len() + 1,
                },
            );
        }
    }
    if depth > 0 {
        let pos = out.last().map(|t| t.pos).unwrap_or_default();
        return Err(PdeTextError::at(pos, "unclosed '(' at the end of the file"));
    }
    push_end(
        &mut out,
        Pos {
            line: src.lines().count() + 1,
            col: 1,
        },
    );
    Ok(out)
}

/// Appends a statement end unless the previous token already is one (blank lines).
fn push_end(out: &mut Vec<Token>, pos: Pos) {
    if !matches!(out.last(), None | Some(Token { tok: Tok::End, .. })) {
        out.push(Token { tok: Tok::End, pos });
    }
}
