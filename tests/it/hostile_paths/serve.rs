//! Issue 44: see the parent module.
