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

/// The command line as a user sees it: the hidden commands (`man`, `fixtures`: the project's
/// own) are not offered, and `--material` offers the presets' names (and `list`), not files.
fn visible() -> clap::Command {
    let full = super::command();
    let mut cmd = clap::Command::new("cubeforge")
        .version(full.get_version().unwrap_or_default().to_owned())
        .about(full.get_about().cloned().unwrap_or_default());
    for a in full.get_arguments() {
        cmd = cmd.arg(a.clone());
    }
    let mut names: Vec<String> = cubeforge::internals::preview::material::presets()
        .into_iter()
        .map(|(m, _)| m.name)
        .collect();
    names.push("list".into());
    for s in full.get_subcommands().filter(|s| !s.is_hide_set()) {
        let names = names.clone();
        cmd = cmd.subcommand(s.clone().mut_args(move |a| {
            if a.get_id() == "material" {
                a.value_parser(clap::builder::PossibleValuesParser::new(names.clone()))
            } else {
                a
            }
        }));
    }
    cmd
}

pub fn run(args: Args) -> Result<()> {
    let mut script = Vec::new();
    clap_complete::generate(args.shell, &mut visible(), "cubeforge", &mut script);
    super::say(String::from_utf8_lossy(&script).trim_end())
}
