//! `cubeforge completions SHELL`: a completion script from the same clap definition.

use cubeforge::Result;

#[derive(clap::Args, Debug)]
pub struct Args {
    /// The shell to complete for.
    #[arg(value_enum)]
    pub shell: clap_complete::Shell,
}

pub fn run(args: Args) -> Result<()> {
    let mut script = Vec::new();
    clap_complete::generate(args.shell, &mut super::command(), "cubeforge", &mut script);
    super::say(String::from_utf8_lossy(&script).trim_end())
}
