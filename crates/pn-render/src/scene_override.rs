//! `pn render --set SECTION.KEY=VALUE`: generic overrides of a render scene's TOML keys,
//! applied to the parsed TOML table before the scene is deserialized and checked (like
//! Mitsuba's `-D`; see [`super::RenderScene::load_with_overrides`]).
//!
//! * The key is a dotted path of bare TOML keys (`solve.margin`, `medium.sigma_t_scale`); a
//!   number addresses an element of an array of tables (`light.0.irradiance` is the first
//!   `[[light]]`; the index one past the end appends a new table). Missing tables are created.
//! * The value is read as a TOML value (`8`, `0.5`, `true`, `"box"`, `[0, 0, 3]`,
//!   `{ kind = "hg", g = 0.3 }`); anything that is not one — a bare word such as `box` — is
//!   taken as a string. A value that starts like an array, an inline table or a quoted string
//!   but does not parse is an error.
//!
//! Whether the key exists and the value has the right type is decided by the scene format
//! itself (its `deny_unknown_fields` structs), so an unknown key is refused with the name of
//! the field and of the `--set` that introduced it.

use anyhow::{anyhow, bail, ensure, Context, Result};
use std::fmt;
use std::str::FromStr;

/// One `--set SECTION.KEY=VALUE`.
#[derive(Clone, Debug, PartialEq)]
pub struct SceneOverride {
    /// The key path: `["solve", "margin"]`, `["light", "0", "irradiance"]`.
    pub path: Vec<String>,
    /// The value.
    pub value: toml::Value,
    /// The text as given (trimmed), for reports and error messages.
    pub text: String,
}

impl fmt::Display for SceneOverride {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.text)
    }
}

const EXAMPLE: &str = "e.g. solve.margin=8, solve.absorber=box, camera.position=[0,0,3], \
                       light.0.irradiance=2";

impl FromStr for SceneOverride {
    type Err = anyhow::Error;

    /// Parses `SECTION.KEY=VALUE` (see the module documentation).
    fn from_str(s: &str) -> Result<Self> {
        let text = s.trim();
        let Some((key, raw)) = text.split_once('=') else {
            bail!("--set {text:?}: expected SECTION.KEY=VALUE ({EXAMPLE})");
        };
        let (key, raw) = (key.trim(), raw.trim());
        ensure!(
            !key.is_empty(),
            "--set {text:?}: the key before '=' is empty (expected SECTION.KEY=VALUE, {EXAMPLE})"
        );
        let mut path = Vec::new();
        for seg in key.split('.') {
            let seg = seg.trim();
            ensure!(
                !seg.is_empty(),
                "--set {text:?}: the key {key:?} has an empty part (write SECTION.KEY, parts \
                 separated by single dots)"
            );
            ensure!(
                seg.chars()
                    .all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-'),
                "--set {text:?}: key part {seg:?} is not a bare TOML key (letters, digits, '_' \
                 and '-')"
            );
            path.push(seg.to_string());
        }
        ensure!(
            !raw.is_empty(),
            "--set {text:?}: no value after '=' (write {key}=\"\" for an empty string)"
        );
        // One flat message: clap shows only the outermost context of a value parser's error.
        let value = parse_value(raw).map_err(|e| anyhow!("--set {text:?}: {e:#}"))?;
        Ok(Self {
            path,
            value,
            text: format!("{key}={raw}"),
        })
    }
}

/// A TOML value, or `raw` as a string when it is none (a bare word).
fn parse_value(raw: &str) -> Result<toml::Value> {
    match toml::from_str::<toml::Table>(&format!("v = {raw}\n")) {
        Ok(t) if t.len() == 1 => {
            if let Some(v) = t.get("v") {
                return Ok(v.clone());
            }
            bail!("cannot read the value {raw:?}")
        }
        Ok(_) => bail!("the value {raw:?} is more than one TOML value"),
        Err(e) => {
            if raw.starts_with(['[', '{', '"', '\'']) {
                bail!(
                    "the value {raw:?} is not valid TOML: {}",
                    e.message().trim_end().replace('\n', ": ")
                );
            }
            Ok(toml::Value::String(raw.to_string()))
        }
    }
}

impl SceneOverride {
    /// The dotted key (`solve.margin`).
    pub fn key(&self) -> String {
        self.path.join(".")
    }

    /// Sets the value in `table`, creating missing tables (and a missing array of tables
    /// when the next part is an index). Errors name the override and the part that fails.
    pub fn apply(&self, table: &mut toml::Table) -> Result<()> {
        let ctx = || format!("--set {}", self.text);
        let (last, inner) = self
            .path
            .split_last()
            .with_context(|| format!("{}: empty key", ctx()))?;
        let Some((first, rest)) = inner.split_first() else {
            table.insert(last.clone(), self.value.clone());
            return Ok(());
        };
        let mut slot = table
            .entry(first.clone())
            .or_insert_with(|| empty_container(rest.first().unwrap_or(last)));
        let mut walked = first.clone();
        for (k, seg) in rest.iter().enumerate() {
            let next = rest.get(k + 1).unwrap_or(last);
            slot = child(slot, seg, next, &walked).with_context(ctx)?;
            walked = format!("{walked}.{seg}");
        }
        match slot {
            toml::Value::Table(t) => {
                t.insert(last.clone(), self.value.clone());
            }
            toml::Value::Array(a) => {
                let i = index(last, a.len(), &walked).with_context(ctx)?;
                if i == a.len() {
                    a.push(self.value.clone());
                } else {
                    a[i] = self.value.clone();
                }
            }
            other => bail!(
                "{}: {walked} holds a value of type {}, not a table",
                ctx(),
                other.type_str()
            ),
        }
        Ok(())
    }
}

/// A new table, or a new array when the part below it is an index.
fn empty_container(next: &str) -> toml::Value {
    if next.parse::<usize>().is_ok() {
        toml::Value::Array(Vec::new())
    } else {
        toml::Value::Table(toml::Table::new())
    }
}

/// The index `seg` into an array of `len` elements (`len` itself appends).
fn index(seg: &str, len: usize, walked: &str) -> Result<usize> {
    let i: usize = seg
        .parse()
        .with_context(|| format!("{walked} is an array: {seg:?} must be an index 0, 1, …"))?;
    ensure!(
        i <= len,
        "{walked} has {len} element(s): index {i} is out of range (0..={len}, {len} appends)"
    );
    Ok(i)
}

/// The element `seg` of `slot` (created when missing), where `next` is the part after it.
fn child<'a>(
    slot: &'a mut toml::Value,
    seg: &str,
    next: &str,
    walked: &str,
) -> Result<&'a mut toml::Value> {
    match slot {
        toml::Value::Table(t) => Ok(t
            .entry(seg.to_string())
            .or_insert_with(|| empty_container(next))),
        toml::Value::Array(a) => {
            let i = index(seg, a.len(), walked)?;
            if i == a.len() {
                a.push(empty_container(next));
            }
            Ok(&mut a[i])
        }
        other => bail!(
            "{walked} holds a value of type {}, not a table",
            other.type_str()
        ),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn set(s: &str) -> SceneOverride {
        s.parse().unwrap_or_else(|e| panic!("{s}: {e:#}"))
    }

    fn err(s: &str) -> String {
        format!("{:#}", s.parse::<SceneOverride>().unwrap_err())
    }

    fn applied(base: &str, sets: &[&str]) -> toml::Table {
        let mut t: toml::Table = toml::from_str(base).unwrap();
        for s in sets {
            set(s).apply(&mut t).unwrap();
        }
        t
    }

    #[test]
    fn values_are_toml_with_a_string_fallback() {
        let o = set("solve.margin=8");
        assert_eq!(o.path, ["solve", "margin"]);
        assert_eq!(o.value, toml::Value::Integer(8));
        assert_eq!(set("solve.sigma_t_min=0.5").value, toml::Value::Float(0.5));
        assert_eq!(
            set("solve.absorber=\"box\"").value,
            toml::Value::String("box".into())
        );
        assert_eq!(
            set("solve.absorber=box").value,
            toml::Value::String("box".into())
        );
        assert_eq!(
            set(" render.exact_transmittance = true ").value,
            toml::Value::Boolean(true)
        );
        assert_eq!(
            set("render.exact_transmittance = true").text,
            "render.exact_transmittance=true"
        );
        let v = set("camera.position=[0,0,-3]").value;
        assert_eq!(
            v,
            toml::Value::Array(vec![
                toml::Value::Integer(0),
                toml::Value::Integer(0),
                toml::Value::Integer(-3)
            ])
        );
        assert!(set("phase={kind=\"hg\", g=0.3}").value.is_table());
        // A file name with dots is a bare word, kept as the string.
        assert_eq!(
            set("medium.file=d.vol").value,
            toml::Value::String("d.vol".into())
        );
    }

    #[test]
    fn malformed_overrides_are_refused() {
        assert!(
            err("foo").contains("expected SECTION.KEY=VALUE"),
            "{}",
            err("foo")
        );
        assert!(
            err("=3").contains("key before '=' is empty"),
            "{}",
            err("=3")
        );
        assert!(err("  =3").contains("key before '=' is empty"));
        assert!(err("solve..margin=3").contains("empty part"));
        assert!(err(".margin=3").contains("empty part"));
        assert!(err("solve.margin=").contains("no value"));
        assert!(err("solve.mar gin=1").contains("bare TOML key"));
        let e = err("camera.position=[0,0,3");
        assert!(
            e.contains("not valid TOML") && e.contains("camera.position"),
            "{e}"
        );
        assert!(err("solve.absorber=\"box").contains("not valid TOML"));
        assert!(err("solve.margin=1\nb = 2").contains("more than one"));
    }

    #[test]
    fn nested_keys_array_indices_and_missing_tables() {
        let base = "[solve]\nmargin = 2\n[[light]]\nkind = \"point\"\npower = 1.0\n\
                    [[light]]\nkind = \"directional\"\n";
        let t = applied(
            base,
            &[
                "solve.margin=8",
                "light.0.power=2",
                "light.1.irradiance=3.5",
                "render.step=0.25",
                "light.2.kind=point",
            ],
        );
        assert_eq!(t["solve"]["margin"].as_integer(), Some(8));
        assert_eq!(t["light"][0]["power"].as_integer(), Some(2));
        assert_eq!(t["light"][0]["kind"].as_str(), Some("point"));
        assert_eq!(t["light"][1]["irradiance"].as_float(), Some(3.5));
        assert_eq!(t["render"]["step"].as_float(), Some(0.25));
        assert_eq!(t["light"].as_array().map(Vec::len), Some(3));
        // A missing array of tables is created by an index.
        let t = applied("", &["light.0.kind=point"]);
        assert_eq!(t["light"][0]["kind"].as_str(), Some("point"));
        // A top-level key.
        let t = applied("", &["x=1"]);
        assert_eq!(t["x"].as_integer(), Some(1));
        // Errors: out of range, an index into a table's scalar, a non-index into an array.
        let mut t: toml::Table = toml::from_str(base).unwrap();
        let e = format!("{:#}", set("light.5.power=1").apply(&mut t).unwrap_err());
        assert!(
            e.contains("--set light.5.power=1") && e.contains("out of range"),
            "{e}"
        );
        let e = format!("{:#}", set("solve.margin.x=1").apply(&mut t).unwrap_err());
        assert!(
            e.contains("solve.margin holds a value of type integer"),
            "{e}"
        );
        let e = format!(
            "{:#}",
            set("light.first.power=1").apply(&mut t).unwrap_err()
        );
        assert!(e.contains("must be an index"), "{e}");
    }
}
