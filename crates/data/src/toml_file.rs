//! Shared handling of the contract's TOML files: key checking against a fixed schema with
//! suggestions, and TOML error positions turned into line and column.

use std::path::Path;

use crate::error::{DataError, DataErrorKind, Location, nearest_name};

/// A table of the schema: its dotted name (`""` for the top level; `a.*` for every sub-table
/// of `a`) and its valid keys.
pub struct TableSchema {
    pub name: &'static str,
    pub keys: &'static [&'static str],
}

/// Parses `text` into a TOML table, reporting syntax errors with line and column.
pub fn parse_toml(text: &str, path: &Path) -> Result<toml::Table, DataError> {
    text.parse::<toml::Table>()
        .map_err(|e| toml_error(text, path, e.message(), e.span()))
}

/// Deserialises an already key-checked table into `T`, reporting type errors with position.
pub fn deserialize<T: serde::de::DeserializeOwned>(
    text: &str,
    path: &Path,
) -> Result<T, DataError> {
    toml::from_str(text).map_err(|e: toml::de::Error| toml_error(text, path, e.message(), e.span()))
}

fn toml_error(
    text: &str,
    path: &Path,
    message: &str,
    span: Option<std::ops::Range<usize>>,
) -> DataError {
    let mut loc = Location::file(path);
    if let Some(span) = span {
        let (line, column) = line_column(text, span.start);
        loc = loc.line(line).column(column, None);
    }
    DataError::new(loc, DataErrorKind::Toml(message.trim().to_owned()))
}

/// 1-based line and column of byte offset `offset` in `text`.
pub fn line_column(text: &str, offset: usize) -> (u64, u64) {
    let offset = offset.min(text.len());
    let before = text.get(..offset).unwrap_or(text);
    let line = before.matches('\n').count() as u64 + 1;
    let column = before.rsplit('\n').next().map_or(0, |l| l.chars().count()) as u64 + 1;
    (line, column)
}

/// Checks every key of `table` against `schema`; the first unknown key is an error naming its
/// line, with the nearest valid key as a suggestion.
pub fn check_keys(
    table: &toml::Table,
    schema: &[TableSchema],
    text: &str,
    path: &Path,
) -> Result<(), DataError> {
    check_table(table, "", schema, text, path)
}

fn check_table(
    table: &toml::Table,
    prefix: &str,
    schema: &[TableSchema],
    text: &str,
    path: &Path,
) -> Result<(), DataError> {
    // `a.*` stands for every sub-table of `a` (tables keyed by free names).
    let parent = prefix.rsplit_once('.').map(|(parent, _)| parent);
    let Some(entry) = schema
        .iter()
        .find(|s| s.name == prefix || s.name.strip_suffix(".*").is_some_and(|p| Some(p) == parent))
    else {
        return Ok(());
    };
    for (key, value) in table {
        if !entry.keys.contains(&key.as_str()) {
            let line = find_key_line(text, prefix, key);
            let mut loc = Location::file(path);
            if let Some(line) = line {
                loc = loc.line(line);
            }
            let shown = if prefix.is_empty() {
                key.clone()
            } else {
                format!("{prefix}.{key}")
            };
            return Err(DataError::new(
                loc,
                DataErrorKind::UnknownKey {
                    key: shown,
                    suggestion: nearest_name(key, entry.keys.iter().copied()),
                    valid: entry.keys.iter().map(|k| (*k).to_owned()).collect(),
                },
            ));
        }
        let child = if prefix.is_empty() {
            key.clone()
        } else {
            format!("{prefix}.{key}")
        };
        match value {
            toml::Value::Table(t) => check_table(t, &child, schema, text, path)?,
            toml::Value::Array(items) => {
                for item in items {
                    if let toml::Value::Table(t) = item {
                        check_table(t, &child, schema, text, path)?;
                    }
                }
            }
            _ => {}
        }
    }
    Ok(())
}

/// Every number in the file must be finite: TOML admits `nan` and `inf`, no parameter does.
pub fn check_finite(table: &toml::Table, text: &str, path: &Path) -> Result<(), DataError> {
    fn walk(
        value: &toml::Value,
        section: &str,
        key: &str,
        text: &str,
        path: &Path,
    ) -> Result<(), DataError> {
        match value {
            toml::Value::Float(f) if !f.is_finite() => {
                let mut loc = Location::file(path);
                if let Some(line) = find_key_line(text, section, key) {
                    loc = loc.line(line);
                }
                Err(DataError::new(
                    loc,
                    DataErrorKind::InvalidValue {
                        key: if section.is_empty() {
                            key.to_owned()
                        } else {
                            format!("{section}.{key}")
                        },
                        value: f.to_string(),
                        reason: "expected a finite number".to_owned(),
                    },
                ))
            }
            toml::Value::Array(items) => items
                .iter()
                .try_for_each(|v| walk(v, section, key, text, path)),
            toml::Value::Table(t) => {
                let child = if section.is_empty() {
                    key.to_owned()
                } else {
                    format!("{section}.{key}")
                };
                t.iter()
                    .try_for_each(|(k, v)| walk(v, &child, k, text, path))
            }
            _ => Ok(()),
        }
    }
    table
        .iter()
        .try_for_each(|(k, v)| walk(v, "", k, text, path))
}

/// The line where `key` is written inside table `table` (or as a `[table.key]` header).
/// A best-effort text search: it only serves to point the reader at the right line.
pub(crate) fn find_key_line(text: &str, table: &str, key: &str) -> Option<u64> {
    let leaf = table.rsplit('.').next().unwrap_or(table);
    let mut in_table = table.is_empty();
    for (i, raw) in text.lines().enumerate() {
        let line = raw.trim();
        if line.starts_with('[') {
            // `[section]  # a comment`: the name ends at the first `]`.
            let name = line
                .trim_start_matches('[')
                .split(']')
                .next()
                .unwrap_or_default()
                .trim();
            if name == key || name.ends_with(&format!(".{key}")) {
                return Some(i as u64 + 1);
            }
            in_table = name == table || name.ends_with(&format!(".{leaf}")) && !table.is_empty();
            continue;
        }
        if in_table
            && let Some(rest) = line.strip_prefix(key)
            && rest.trim_start().starts_with('=')
        {
            return Some(i as u64 + 1);
        }
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_key_is_found_under_a_section_header_with_a_comment() {
        let text = "[a]\nx = 1\n[slow_dynamics]  # Model 2 extended (thesis Table 5.5)\nx = 2\n";
        assert_eq!(find_key_line(text, "slow_dynamics", "x"), Some(4));
        assert_eq!(find_key_line(text, "a", "x"), Some(2));
    }

    #[test]
    fn line_column_counts_from_one() {
        assert_eq!(line_column("ab\ncd", 0), (1, 1));
        assert_eq!(line_column("ab\ncd", 4), (2, 2));
    }

    #[test]
    fn unknown_key_is_located_and_suggested() {
        let text = "[geometry]\nh0_m = 0.1\nl1m = 0.6\n";
        let schema = [
            TableSchema {
                name: "",
                keys: &["geometry"],
            },
            TableSchema {
                name: "geometry",
                keys: &["h0_m", "l1_m"],
            },
        ];
        let table = parse_toml(text, Path::new("t.toml")).unwrap();
        let err = check_keys(&table, &schema, text, Path::new("t.toml")).unwrap_err();
        assert_eq!(err.location.line, Some(3));
        assert!(
            err.to_string()
                .contains("unknown key `geometry.l1m` (did you mean `l1_m`?)"),
            "{err}"
        );
    }

    #[test]
    fn syntax_error_has_position() {
        let err = parse_toml("a = 1\nb = = 2\n", Path::new("t.toml")).unwrap_err();
        assert_eq!(err.location.line, Some(2));
    }
}
