//! Issue 44, the third fault campaign: file names and paths that become build files, pages
//! and outputs, each turned against the user by a hostile input built here.

mod build_files;
mod outputs;
mod serve;
mod small;
