//! Parameter files: a scenario's parameters are its documented defaults, overridden by a TOML
//! file whose keys mirror the parameter struct. An unknown key, a wrong type or an invalid
//! value is an error that names the file, the key and (from the TOML parser) the line.

use std::path::Path;

use serde::de::DeserializeOwned;

use crate::error::{Error, Result};

/// Reads a whole text file, naming it in the error.
pub fn read_text(path: &Path) -> Result<String> {
    std::fs::read_to_string(path).map_err(|source| Error::Read {
        path: path.to_path_buf(),
        source,
    })
}

/// Parses `text` (the contents of `path`) as TOML into `T`.
///
/// `T` should be `#[serde(default, deny_unknown_fields)]` so that omitted keys keep their
/// defaults and a misspelt key is rejected by name.
pub fn parse_toml<T: DeserializeOwned>(path: &Path, text: &str) -> Result<T> {
    toml::from_str(text).map_err(|e| {
        let message = e.message().to_string();
        let at = e
            .span()
            .map(|span| {
                let line = text[..span.start.min(text.len())].matches('\n').count() + 1;
                // Name the key of a `key = value` line too (a wrong-type value's message
                // from the parser does not).
                let key = text
                    .lines()
                    .nth(line - 1)
                    .and_then(|l| l.split_once('='))
                    .map(|(k, _)| k.trim())
                    .filter(|k| !k.is_empty() && !k.starts_with('['));
                match key {
                    Some(k) => format!("line {line}, key `{k}`: "),
                    None => format!("line {line}: "),
                }
            })
            .unwrap_or_default();
        Error::invalid(path, format!("{at}{message}"))
    })
}

/// Loads parameters from an optional TOML file: the defaults when `path` is `None`.
pub fn load_or_default<T: DeserializeOwned + Default>(path: Option<&Path>) -> Result<T> {
    match path {
        None => Ok(T::default()),
        Some(p) => parse_toml(p, &read_text(p)?),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[derive(Debug, Default, serde::Deserialize, PartialEq)]
    #[serde(default, deny_unknown_fields)]
    struct P {
        runs: usize,
        dt: f64,
    }

    #[test]
    fn unknown_key_is_named_with_its_line() {
        let err = parse_toml::<P>(Path::new("c.toml"), "runs = 3\nrunz = 4\n")
            .expect_err("unknown key must fail");
        let msg = err.to_string();
        assert!(
            msg.contains("c.toml") && msg.contains("runz") && msg.contains("line 2"),
            "{msg}"
        );
        let ok: P = parse_toml(Path::new("c.toml"), "dt = 0.5\n").expect("valid");
        assert_eq!(ok.runs, 0);
        assert!((ok.dt - 0.5).abs() < f64::EPSILON);
    }
}
