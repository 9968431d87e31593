//! Man pages generated from the clap definitions (clap_mangen), so they never drift.

use cubeforge::{Error, Result};
use std::path::PathBuf;

#[derive(clap::Args, Debug)]
pub struct Args {
    /// Folder that receives cubeforge.1 and one page per command.
    pub dir: PathBuf,
}

pub fn run(args: Args) -> Result<()> {
    let mut cmd = super::command();
    cmd.build();
    let mut pages = vec![("cubeforge.1".to_string(), cmd.clone())];
    for sub in cmd
        .get_subcommands()
        .filter(|s| !s.is_hide_set() && s.get_name() != "help")
    {
        let name = format!("cubeforge-{}", sub.get_name());
        pages.push((format!("{name}.1"), sub.clone().name(name)));
    }
    let mut files = Vec::new();
    for (file, page) in pages {
        let mut buf = Vec::new();
        clap_mangen::Man::new(page)
            .render(&mut buf)
            .map_err(|e| Error::file(&file, e.to_string()))?;
        files.push((args.dir.join(file), buf));
    }
    // The folder, when missing, is made by the write path with the pages, whole.
    super::write_files(&files)
}
