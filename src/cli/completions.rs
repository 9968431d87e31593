//! `cubeforge completions SHELL`: a completion script from the same clap definition.

use cubeforge::Result;

#[derive(clap::Args, Debug)]
#[command(after_help = EXAMPLES)]
pub struct Args {
    /// The shell to complete for.
    #[arg(value_enum)]
    pub shell: clap_complete::Shell,
}

/// Printed after the options (`-h`, `--help`, the man page); tests/it/help_examples.rs
/// runs every `cubeforge` line of it.
const EXAMPLES: &str = "\
Examples:
  # bash, for this shell
  source <(cubeforge completions bash)
  # zsh: a file in a folder of $fpath
  cubeforge completions zsh > ~/.zfunc/_cubeforge
  # fish
  cubeforge completions fish > ~/.config/fish/completions/cubeforge.fish";

pub fn run(args: Args) -> Result<()> {
    let mut script = Vec::new();
    clap_complete::generate(args.shell, &mut super::command(), "cubeforge", &mut script);
    super::say(String::from_utf8_lossy(&script).trim_end())
}
