//! Loading and parsing recipes (TOML or JSON), with every error placed on its line.

#![warn(missing_docs)]

use super::image::ContextGuard;
use super::recipe::Recipe;
use crate::error::{Error, Result};
use crate::io::{self, Limits};
use std::path::Path;

/// Recipes larger than this are refused before they are read.
const MAX_RECIPE_BYTES: u64 = 4 << 20;

/// The recipe languages.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Syntax {
    /// TOML, the usual way to write a recipe by hand.
    Toml,
    /// JSON with the same structure, for recipes written by other tools.
    Json,
}

impl Syntax {
    /// By the file's extension: `.toml` or `.json`.
    pub fn from_path(path: &Path) -> Option<Syntax> {
        match path.extension()?.to_str()?.to_ascii_lowercase().as_str() {
            "toml" => Some(Syntax::Toml),
            "json" => Some(Syntax::Json),
            _ => None,
        }
    }
}

/// Reads a recipe file (`.toml` or `.json`) and every image it names, relative to its folder.
pub fn load(path: &Path, limits: &Limits) -> Result<Recipe> {
    let syntax = Syntax::from_path(path)
        .ok_or_else(|| Error::file(path, "a recipe must be a .toml or .json file"))?;
    let len = std::fs::metadata(path)
        .map_err(|e| Error::io(path, e))?
        .len();
    if len > MAX_RECIPE_BYTES {
        return Err(Error::file(
            path,
            format!("{len} bytes is too long for a recipe (at most {MAX_RECIPE_BYTES})"),
        ));
    }
    limits.session.note(path);
    let text =
        String::from_utf8(io::read_file(path)?).map_err(|_| Error::file(path, "not UTF-8 text"))?;
    let base = path
        .parent()
        .filter(|p| !p.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    parse(&text, syntax, path, base, limits)
}

/// Parses recipe text; `origin` names it in errors, `base` is the folder image paths are
/// relative to. Images are read here, so every problem is reported with its line.
pub fn parse(
    text: &str,
    syntax: Syntax,
    origin: &Path,
    base: &Path,
    limits: &Limits,
) -> Result<Recipe> {
    let recipe: Recipe = {
        let _context = ContextGuard::enter(base, limits);
        match syntax {
            Syntax::Toml => toml::from_str(text).map_err(|e| {
                let line = e.span().map(|s| line_of(text, s.start));
                Error::recipe(origin, line, e.message().trim())
            })?,
            Syntax::Json if !text.trim_start().starts_with('{') => {
                let at = text.len() - text.trim_start().len();
                return Err(Error::recipe(
                    origin,
                    Some(line_of(text, at)),
                    "a JSON recipe is one object: { \"size\": ..., \"reflectivity\": ... }",
                ));
            }
            Syntax::Json => serde_json::from_str(text).map_err(|e| {
                let msg = e.to_string();
                let suffix = format!(" at line {} column {}", e.line(), e.column());
                let msg = msg.strip_suffix(&suffix).unwrap_or(&msg);
                Error::recipe(origin, (e.line() > 0).then_some(e.line()), msg)
            })?,
        }
    };
    let mut recipe = recipe;
    if recipe.size.is_some() {
        recipe.size_line = text
            .lines()
            .position(|l| {
                let l = l.trim_start();
                let rest = l
                    .strip_prefix("\"size\"")
                    .or_else(|| l.strip_prefix("size"));
                rest.is_some_and(|r| r.trim_start().starts_with(['=', ':']))
            })
            .map(|i| i + 1);
    }
    if recipe.blur.is_some() && recipe.max_lod_bias.is_none() {
        return Err(Error::recipe(
            origin,
            None,
            "blur is set but max_lod_bias is not: add `max_lod_bias = <mip levels>` at the top \
             (the LOD bias that blur = 1 stands for)",
        ));
    }
    Ok(recipe)
}

/// The 1-based line holding byte `offset`.
fn line_of(text: &str, offset: usize) -> usize {
    let end = offset.min(text.len());
    text.as_bytes()[..end]
        .iter()
        .filter(|&&b| b == b'\n')
        .count()
        + 1
}

#[cfg(test)]
mod tests {
    use super::*;

    fn toml(text: &str) -> Result<Recipe> {
        parse(
            text,
            Syntax::Toml,
            Path::new("r.toml"),
            Path::new("."),
            &Limits::default(),
        )
    }

    #[test]
    fn lines_of_errors() {
        let e = toml("size = 4\n\n[blur]\nconstant = 2\n")
            .unwrap_err()
            .to_string();
        assert!(e.contains("line 4"), "{e}");
        let e = toml("size = 4\nroughness = 1\n").unwrap_err().to_string();
        assert!(e.contains("line 2") && e.contains("roughness"), "{e}");
    }
}
