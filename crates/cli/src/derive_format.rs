//! The output formats of `invsim derive` (`--format text|json|markdown`), shared by the single-model and the
//! modal derivation.

use clap::ValueEnum;

#[derive(Copy, Clone, Debug, PartialEq, Eq, ValueEnum)]
pub enum Format {
    Text,
    Json,
    Markdown,
}
