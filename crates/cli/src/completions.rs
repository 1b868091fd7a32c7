//! `invsim completions SHELL`: a completion script for bash, zsh, fish, elvish or PowerShell on stdout,
//! generated from the command-line definition by `clap_complete`.

use crate::error::Failure;
use crate::files::print_stdout;
use clap_complete::Shell;

#[derive(clap::Args, Debug)]
pub struct CompletionsArgs {
    /// The shell, e.g. `invsim completions bash > ~/.local/share/bash-completion/completions/invsim`.
    shell: Shell,
}

/// Print the completion script of `command` (the whole `invsim` command line, from `main`).
pub fn run(args: &CompletionsArgs, mut command: clap::Command) -> Result<(), Failure> {
    let mut script = Vec::new();
    clap_complete::generate(args.shell, &mut command, "invsim", &mut script);
    print_stdout(&String::from_utf8_lossy(&script))
}
