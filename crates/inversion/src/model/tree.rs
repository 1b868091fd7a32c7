//! A TOML tree with byte spans: every value and key of the model file keeps where it is, so that an error
//! names its line and column.
//!
//! `toml::Spanned<T>` cannot be used throughout: implicitly created tables (`[states.v]` without a
//! `[states]` header, dotted keys) have no span, and `Spanned` fails on them. These types speak the same
//! private protocol as `Spanned` (a struct with these reserved names, which the TOML deserializer answers
//! with start, end and value) and fall back to an unspanned value when no span is offered.

use serde::de::{self, Deserialize, Deserializer, IgnoredAny, MapAccess, SeqAccess, Visitor};
use std::fmt;
use std::ops::Range;

const SPANNED_NAME: &str = "$__serde_spanned_private_Spanned";
const SPANNED_START: &str = "$__serde_spanned_private_start";
const SPANNED_END: &str = "$__serde_spanned_private_end";
const SPANNED_VALUE: &str = "$__serde_spanned_private_value";
const SPANNED_FIELDS: &[&str] = &[SPANNED_START, SPANNED_END, SPANNED_VALUE];
const DATETIME_FIELD: &str = "$__toml_private_datetime";

/// A TOML value with its byte span in the file (when the parser knows it).
#[derive(Debug)]
pub(super) struct Tv {
    pub(super) span: Option<Range<usize>>,
    pub(super) kind: Kind,
}

/// What a TOML value is (date-times are not read further: no key takes them; arrays hold their elements,
/// for the grids and values of `[maps]`).
#[derive(Debug)]
pub(super) enum Kind {
    Str(String),
    Int(i64),
    Float(f64),
    Bool(bool),
    Datetime,
    Array(Vec<Tv>),
    /// Entries in file order.
    Table(Vec<(Key, Tv)>),
}

/// A table key with its byte span.
#[derive(Debug)]
pub(super) struct Key {
    pub(super) name: String,
    pub(super) span: Option<Range<usize>>,
}

impl Kind {
    pub(super) fn type_name(&self) -> &'static str {
        match self {
            Kind::Str(_) => "a string",
            Kind::Int(_) => "an integer",
            Kind::Float(_) => "a float",
            Kind::Bool(_) => "a boolean",
            Kind::Datetime => "a date-time",
            Kind::Array(_) => "an array",
            Kind::Table(_) => "a table",
        }
    }
}

impl<'de> Deserialize<'de> for Tv {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Tv, D::Error> {
        d.deserialize_struct(SPANNED_NAME, SPANNED_FIELDS, TvVisitor)
    }
}

impl<'de> Deserialize<'de> for Key {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Key, D::Error> {
        d.deserialize_struct(SPANNED_NAME, SPANNED_FIELDS, KeyVisitor)
    }
}

/// The value part of a spanned value.
struct KindOnly(Kind);

impl<'de> Deserialize<'de> for KindOnly {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<KindOnly, D::Error> {
        d.deserialize_any(TvVisitor).map(|tv| KindOnly(tv.kind))
    }
}

fn unspanned(kind: Kind) -> Tv {
    Tv { span: None, kind }
}

/// Read the rest of a table whose first key has been read already.
fn read_table<'de, A: MapAccess<'de>>(first: Key, mut map: A) -> Result<Kind, A::Error> {
    if first.name == DATETIME_FIELD {
        map.next_value::<IgnoredAny>()?;
        while map.next_entry::<IgnoredAny, IgnoredAny>()?.is_some() {}
        return Ok(Kind::Datetime);
    }
    let mut entries = Vec::new();
    let value: Tv = map.next_value()?;
    entries.push((first, value));
    while let Some(k) = map.next_key::<Key>()? {
        let v: Tv = map.next_value()?;
        entries.push((k, v));
    }
    Ok(Kind::Table(entries))
}

struct TvVisitor;

impl<'de> Visitor<'de> for TvVisitor {
    type Value = Tv;

    fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
        f.write_str("a TOML value")
    }
    fn visit_bool<E: de::Error>(self, v: bool) -> Result<Tv, E> {
        Ok(unspanned(Kind::Bool(v)))
    }
    fn visit_i64<E: de::Error>(self, v: i64) -> Result<Tv, E> {
        Ok(unspanned(Kind::Int(v)))
    }
    fn visit_u64<E: de::Error>(self, v: u64) -> Result<Tv, E> {
        Ok(unspanned(match i64::try_from(v) {
            Ok(i) => Kind::Int(i),
            Err(_) => Kind::Float(v as f64),
        }))
    }
    fn visit_f64<E: de::Error>(self, v: f64) -> Result<Tv, E> {
        Ok(unspanned(Kind::Float(v)))
    }
    fn visit_str<E: de::Error>(self, v: &str) -> Result<Tv, E> {
        Ok(unspanned(Kind::Str(v.to_string())))
    }
    fn visit_string<E: de::Error>(self, v: String) -> Result<Tv, E> {
        Ok(unspanned(Kind::Str(v)))
    }
    fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<Tv, A::Error> {
        let mut items = Vec::new();
        while let Some(v) = seq.next_element::<Tv>()? {
            items.push(v);
        }
        Ok(unspanned(Kind::Array(items)))
    }
    fn visit_map<A: MapAccess<'de>>(self, mut map: A) -> Result<Tv, A::Error> {
        let Some(first) = map.next_key::<Key>()? else {
            return Ok(unspanned(Kind::Table(Vec::new())));
        };
        if first.span.is_some() || !SPANNED_FIELDS.contains(&first.name.as_str()) {
            return read_table(first, map).map(unspanned);
        }
        // The spanned protocol: start, end and value, in any order.
        let (mut start, mut end, mut kind) = (None, None, None);
        let mut key = Some(first);
        while let Some(k) = key {
            match k.name.as_str() {
                SPANNED_START => start = Some(map.next_value::<usize>()?),
                SPANNED_END => end = Some(map.next_value::<usize>()?),
                SPANNED_VALUE => kind = Some(map.next_value::<KindOnly>()?.0),
                other => {
                    return Err(de::Error::custom(format!(
                        "unexpected key `{other}` in a spanned value"
                    )))
                }
            }
            key = map.next_key::<Key>()?;
        }
        let kind = kind.ok_or_else(|| de::Error::custom("spanned value without a value"))?;
        let span = match (start, end) {
            (Some(s), Some(e)) if s <= e => Some(s..e),
            (Some(s), _) => Some(s..s),
            _ => None,
        };
        Ok(Tv { span, kind })
    }
}

struct KeyVisitor;

impl<'de> Visitor<'de> for KeyVisitor {
    type Value = Key;

    fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
        f.write_str("a TOML key")
    }
    fn visit_str<E: de::Error>(self, v: &str) -> Result<Key, E> {
        Ok(Key {
            name: v.to_string(),
            span: None,
        })
    }
    fn visit_string<E: de::Error>(self, v: String) -> Result<Key, E> {
        Ok(Key {
            name: v,
            span: None,
        })
    }
    fn visit_map<A: MapAccess<'de>>(self, mut map: A) -> Result<Key, A::Error> {
        let (mut start, mut end, mut name) = (None, None, None);
        while let Some(k) = map.next_key::<String>()? {
            match k.as_str() {
                SPANNED_START => start = Some(map.next_value::<usize>()?),
                SPANNED_END => end = Some(map.next_value::<usize>()?),
                SPANNED_VALUE => name = Some(map.next_value::<String>()?),
                other => {
                    return Err(de::Error::custom(format!(
                        "unexpected key `{other}` in a spanned key"
                    )))
                }
            }
        }
        let name = name.ok_or_else(|| de::Error::custom("spanned key without a name"))?;
        let span = match (start, end) {
            (Some(s), Some(e)) if s <= e => Some(s..e),
            (Some(s), _) => Some(s..s),
            _ => None,
        };
        Ok(Key { name, span })
    }
}

/// A table's entries, in file order.
pub(super) type Entries = [(Key, Tv)];

/// The value of `key`, if the table has it.
pub(super) fn get<'t>(entries: &'t Entries, key: &str) -> Option<&'t Tv> {
    get_key(entries, key).map(|(_, v)| v)
}

/// The key and value of `key`, if the table has it.
pub(super) fn get_key<'t>(entries: &'t Entries, key: &str) -> Option<(&'t Key, &'t Tv)> {
    entries
        .iter()
        .find(|(k, _)| k.name == key)
        .map(|(k, v)| (k, v))
}

/// Where a key starts in the file.
pub(super) fn key_at(k: &Key) -> Option<usize> {
    k.span.as_ref().map(|s| s.start)
}

/// Where a value starts in the file.
pub(super) fn tv_at(v: &Tv) -> Option<usize> {
    v.span.as_ref().map(|s| s.start)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn spans_for_implicit_tables() {
        let text = "[states.x1]\nrhs = \"u\"\n";
        let root: Tv = toml::from_str(text).expect("valid TOML");
        let Kind::Table(top) = &root.kind else {
            panic!("root is a table")
        };
        let Kind::Table(states) = &top[0].1.kind else {
            panic!("states is a table")
        };
        let Kind::Table(x1) = &states[0].1.kind else {
            panic!("x1 is a table")
        };
        assert_eq!(x1[0].0.name, "rhs");
        assert_eq!(x1[0].0.span, Some(12..15));
        assert_eq!(x1[0].1.span, Some(18..21));
    }
}
