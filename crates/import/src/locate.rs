//! Where a field's value is in the YAML text: the parsed tree has no positions, so the text is walked again
//! along the field's dotted path (`a.b[2].c`) with serde, every other node skipped, and the walk stops at the
//! field with an error to which the YAML reader attaches the position of the node it was reading.

use serde::de::{DeserializeSeed, Deserializer, IgnoredAny, MapAccess, SeqAccess, Visitor};
use std::fmt;

/// The message of the error that stops the walk at the field.
const FOUND: &str = "invsim-import: field found";

/// One step of a path: a mapping key or a sequence index.
enum Step {
    Key(String),
    Index(usize),
}

/// The steps of a dotted path (`grid[0][3]` is the key `grid`, then the indices 0 and 3); `None` when the
/// path is malformed.
fn steps(path: &str) -> Option<Vec<Step>> {
    let mut out = Vec::new();
    for seg in path.split('.') {
        let (key, rest) = seg.split_at(seg.find('[').unwrap_or(seg.len()));
        if !key.is_empty() {
            out.push(Step::Key(key.to_string()));
        }
        if !rest.is_empty() {
            for i in rest.strip_prefix('[')?.strip_suffix(']')?.split("][") {
                out.push(Step::Index(i.parse().ok()?));
            }
        }
    }
    Some(out)
}

/// The 1-based line and column of the value at `path` in the YAML `text`, if the text has it.
pub fn locate(text: &str, path: &str) -> Option<(usize, usize)> {
    let steps = steps(path)?;
    let err = Find(&steps)
        .deserialize(serde_yaml::Deserializer::from_str(text))
        .err()?;
    if !err.to_string().contains(FOUND) {
        return None;
    }
    err.location().map(|l| (l.line(), l.column()))
}

/// The walk along the remaining steps.
struct Find<'s>(&'s [Step]);

impl<'de> DeserializeSeed<'de> for Find<'_> {
    type Value = ();
    fn deserialize<D: Deserializer<'de>>(self, d: D) -> Result<(), D::Error> {
        d.deserialize_any(self)
    }
}

/// At the last step every node is the field (the walk stops with [`FOUND`]); before it, a mapping is
/// searched for the key and a sequence walked to the index, and anything else ends the walk (not found).
macro_rules! found_or_skip {
    ($($name:ident: $t:ty),*) => {
        $(fn $name<E: serde::de::Error>(self, _: $t) -> Result<(), E> {
            self.stop()
        })*
    };
}

impl Find<'_> {
    fn stop<E: serde::de::Error>(&self) -> Result<(), E> {
        if self.0.is_empty() {
            Err(E::custom(FOUND))
        } else {
            Ok(())
        }
    }
}

impl<'de> Visitor<'de> for Find<'_> {
    type Value = ();

    fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
        f.write_str("any YAML node")
    }

    found_or_skip!(visit_bool: bool, visit_i64: i64, visit_u64: u64, visit_f64: f64, visit_str: &str);

    fn visit_unit<E: serde::de::Error>(self) -> Result<(), E> {
        self.stop()
    }

    fn visit_none<E: serde::de::Error>(self) -> Result<(), E> {
        self.stop()
    }

    fn visit_map<A: MapAccess<'de>>(self, mut map: A) -> Result<(), A::Error> {
        let (Some(Step::Key(key)), rest) = (self.0.first(), self.0.get(1..).unwrap_or(&[])) else {
            self.stop::<A::Error>()?;
            while map.next_entry::<IgnoredAny, IgnoredAny>()?.is_some() {}
            return Ok(());
        };
        while let Some(k) = map.next_key::<serde_yaml::Value>()? {
            if k.as_str() == Some(key.as_str()) {
                return map.next_value_seed(Find(rest));
            }
            map.next_value::<IgnoredAny>()?;
        }
        Ok(())
    }

    fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<(), A::Error> {
        let (Some(Step::Index(i)), rest) = (self.0.first(), self.0.get(1..).unwrap_or(&[])) else {
            self.stop::<A::Error>()?;
            while seq.next_element::<IgnoredAny>()?.is_some() {}
            return Ok(());
        };
        for _ in 0..*i {
            if seq.next_element::<IgnoredAny>()?.is_none() {
                return Ok(());
            }
        }
        seq.next_element_seed(Find(rest))?;
        while seq.next_element::<IgnoredAny>()?.is_some() {}
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::locate;

    #[test]
    fn finds_values_by_path() {
        let text = "a: 1\nb:\n  c: [1, 2,  3]\n  d:\n    - x: 5\n";
        assert_eq!(locate(text, "a"), Some((1, 4)));
        assert_eq!(locate(text, "b.c[2]"), Some((3, 14)));
        assert_eq!(locate(text, "b.d[0].x"), Some((5, 10)));
        assert_eq!(locate(text, "b.e"), None);
        assert_eq!(locate(text, "b.c[7]"), None);
    }
}
