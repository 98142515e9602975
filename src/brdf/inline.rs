//! Materials given inline on the command line (`--material 'model = "ward", ks = 1, …'`).

use super::{parse_material, Material, Origin};
use anyhow::{anyhow, Result};
use std::collections::BTreeMap;
use toml::{Spanned, Value};

/// Parse an inline TOML table into a material; warnings go to stderr.
pub fn parse_inline(src: &str) -> Result<Material> {
    let fields: BTreeMap<String, Spanned<Value>> =
        toml::from_str(src).map_err(|e| anyhow!("--material: not a TOML table: {e}"))?;
    let origin = Origin { file: "--material", source: src, material: "inline", span: 0..src.len() };
    let (m, warnings) = parse_material(origin, fields)?;
    for w in warnings {
        eprintln!("{w}");
    }
    Ok(m)
}
