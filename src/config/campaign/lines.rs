//! Where a field is written in a campaign's TOML text: field paths such as
//! `debris[1].tle_file`, their keys, and 1-based lines, for errors that name file and line.

use toml::Spanned;
use toml::de::{DeTable, DeValue};

/// The keys of a field path: `debris[1].tle_file` is `debris` at index 1, then `tle_file`.
pub(super) fn field_keys(field: &str) -> Vec<(String, Option<usize>)> {
    field
        .split('.')
        .map(|part| match part.find('[') {
            Some(i) => (
                part[..i].to_string(),
                part[i + 1..].trim_end_matches(']').parse().ok(),
            ),
            None => (part.to_string(), None),
        })
        .collect()
}

/// 1-based line of a byte offset.
pub(super) fn line_of_offset(text: &str, offset: usize) -> usize {
    text[..offset.min(text.len())].matches('\n').count() + 1
}

/// Line where a field path such as `exposure.min_s` or `debris[1].elements` is written, if it is.
/// Falls back to the nearest enclosing table that is written.
pub(super) fn line_of_field(text: &str, field: &str) -> Option<usize> {
    let doc = DeTable::parse(text).ok()?;
    let keys = field_keys(field);
    let mut table = doc.get_ref();
    let mut best = None;
    // Walk as deep as the text goes; a field left to its default reports its enclosing table.
    for (k, (key, idx)) in keys.iter().enumerate() {
        let Some((span_key, value)) = table.get_key_value(key.as_str()) else {
            break;
        };
        best = Some(span_key.span().start);
        let mut value = value;
        if let Some(i) = idx {
            let Some(item) = value.get_ref().as_array().and_then(|a| a.get(*i)) else {
                break;
            };
            value = item;
            best = Some(value.span().start);
        }
        if k + 1 < keys.len() {
            let Some(t) = value.get_ref().as_table() else {
                break;
            };
            table = t;
        }
    }
    best.map(|o| line_of_offset(text, o))
}

/// The path of the field whose key or value holds byte `offset` of `text` (where toml reports
/// an error in a composed campaign), e.g. `sensor.width` or `debris[1]`.
pub(super) fn field_at_offset(text: &str, offset: usize) -> Option<String> {
    // The innermost value wins: an error in `[sensor] width` names `sensor.width`, not `sensor`.
    fn in_value(value: &Spanned<DeValue>, offset: usize, path: String) -> Option<String> {
        let inner = match value.get_ref() {
            DeValue::Table(t) => in_table(t, offset, &path),
            DeValue::Array(a) => a
                .iter()
                .enumerate()
                .find_map(|(i, item)| in_value(item, offset, format!("{path}[{i}]"))),
            _ => None,
        };
        inner.or_else(|| value.span().contains(&offset).then_some(path))
    }
    fn in_table(table: &DeTable, offset: usize, prefix: &str) -> Option<String> {
        table.iter().find_map(|(key, value)| {
            let path = if prefix.is_empty() {
                key.get_ref().to_string()
            } else {
                format!("{prefix}.{}", key.get_ref())
            };
            if key.span().contains(&offset) {
                Some(path)
            } else {
                in_value(value, offset, path)
            }
        })
    }
    let doc = DeTable::parse(text).ok()?;
    in_table(doc.get_ref(), offset, "")
}

/// The field that line `line` (1-based) of `text` writes, `key = ...` under the last `[table]`
/// header above it: for errors in text that does not parse (a duplicate key), where
/// `field_at_offset` has no document to search.
pub(super) fn field_on_line(text: &str, line: usize) -> Option<String> {
    let lines: Vec<&str> = text.lines().take(line).collect();
    let (key, _) = lines.last()?.split_once('=')?;
    let key = key.trim().trim_matches('"');
    let table = lines[..lines.len() - 1].iter().rev().find_map(|l| {
        let l = l.trim();
        l.starts_with('[')
            .then(|| l.trim_matches(|c| c == '[' || c == ']').trim())
    });
    Some(match table {
        Some(t) => format!("{t}.{key}"),
        None => key.to_string(),
    })
}
