//! `invsim --version`: the package version and the git revision the binary was built from (set by
//! `build.rs`; "unknown" when built outside a git checkout).

/// `0.1.0 (rev abc1234)`.
pub const VERSION: &str = concat!(
    env!("CARGO_PKG_VERSION"),
    " (rev ",
    env!("INVSIM_GIT_REVISION"),
    ")"
);
