//! Reading the YAML tree: parsing with positions for errors, and typed access to fields by their dotted path
//! (`pt_type.Conv.fc.pwr_out_max_watts`), each access recorded so that unused fields can be listed.

use crate::error::ImportError;
use serde_yaml::Value;
use std::cell::RefCell;
use std::collections::BTreeSet;

/// Parse `text` as YAML; a syntax error carries its 1-based line and column. The nesting depth is checked
/// first, in linear time (`depth.rs`).
pub fn parse(text: &str) -> Result<Value, ImportError> {
    crate::depth::check(text)?;
    serde_yaml::from_str::<Value>(text).map_err(|e| {
        let (line, column) = e.location().map_or((1, 1), |l| (l.line(), l.column()));
        ImportError::Yaml {
            line,
            column,
            message: e.to_string(),
        }
    })
}

/// A YAML document with a record of the field paths the importer read.
pub struct Doc {
    pub root: Value,
    used: RefCell<BTreeSet<String>>,
    subtrees: RefCell<BTreeSet<String>>,
}

impl Doc {
    pub fn new(root: Value) -> Doc {
        Doc {
            root,
            used: RefCell::new(BTreeSet::new()),
            subtrees: RefCell::new(BTreeSet::new()),
        }
    }

    /// The node at a dotted `path` (`a.b.c`; a segment `[k]` indexes a sequence), if present and not null.
    pub fn get(&self, path: &str) -> Option<&Value> {
        self.used.borrow_mut().insert(path.to_string());
        lookup(&self.root, path).filter(|v| !v.is_null())
    }

    /// A required number at `path`.
    pub fn num(&self, path: &str) -> Result<f64, ImportError> {
        let v = self
            .get(path)
            .ok_or_else(|| ImportError::field(path, "missing (needed by the model)"))?;
        as_number(v).ok_or_else(|| {
            ImportError::field(path, format!("expected a number, found {}", kind(v)))
        })
    }

    /// An optional number at `path` (absent or null: `None`).
    pub fn opt_num(&self, path: &str) -> Result<Option<f64>, ImportError> {
        match self.get(path) {
            None => Ok(None),
            Some(v) => as_number(v).map(Some).ok_or_else(|| {
                ImportError::field(path, format!("expected a number, found {}", kind(v)))
            }),
        }
    }

    /// Mark `path` (and everything below it) as read without reading it.
    pub fn mark(&self, path: &str) {
        self.subtrees.borrow_mut().insert(path.to_string());
    }

    /// Whether `path` or one of its ancestors was marked as a whole.
    pub fn was_marked(&self, path: &str) -> bool {
        let subtrees = self.subtrees.borrow();
        let mut p = path;
        loop {
            if subtrees.contains(p) {
                return true;
            }
            match p.rfind('.') {
                Some(i) => p = &p[..i],
                None => return false,
            }
        }
    }

    /// Whether `path` was read, or it or one of its ancestors was marked.
    pub fn was_used(&self, path: &str) -> bool {
        if self.used.borrow().contains(path) {
            return true;
        }
        let subtrees = self.subtrees.borrow();
        let mut p = path;
        loop {
            if subtrees.contains(p) {
                return true;
            }
            match p.rfind('.') {
                Some(i) => p = &p[..i],
                None => return false,
            }
        }
    }
}

/// The node at a dotted path.
pub fn lookup<'a>(root: &'a Value, path: &str) -> Option<&'a Value> {
    let mut node = root;
    for seg in path.split('.') {
        let (key, indices) = split_index(seg)?;
        if !key.is_empty() {
            node = node.as_mapping()?.get(Value::String(key.to_string()))?;
        }
        for i in indices {
            node = node.as_sequence()?.get(i)?;
        }
    }
    Some(node)
}

/// `grid[0][3]` → (`grid`, [0, 3]); `values` → (`values`, []); a malformed index: `None`.
fn split_index(seg: &str) -> Option<(&str, Vec<usize>)> {
    let Some(open) = seg.find('[') else {
        return Some((seg, Vec::new()));
    };
    let indices = seg[open..]
        .strip_prefix('[')?
        .strip_suffix(']')?
        .split("][")
        .map(|i| i.parse().ok())
        .collect::<Option<Vec<usize>>>()?;
    Some((&seg[..open], indices))
}

/// A YAML number (integers included) as f64; FASTSim writes `.nan` for unset masses.
pub fn as_number(v: &Value) -> Option<f64> {
    v.as_f64()
}

/// A short description of a node's type for messages.
pub fn kind(v: &Value) -> &'static str {
    match v {
        Value::Null => "null",
        Value::Bool(_) => "a boolean",
        Value::Number(_) => "a number",
        Value::String(_) => "a string",
        Value::Sequence(_) => "a list",
        Value::Mapping(_) => "a mapping",
        Value::Tagged(_) => "a tagged value",
    }
}
