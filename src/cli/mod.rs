//! The `vkrad` command line, apart from `main`: its grammar (`args`), one
//! function per subcommand (`commands`), the progress line and Ctrl-C
//! (`progress`) and the printed summaries (`print`). The work itself is in
//! the library.

pub(crate) mod args;
pub(crate) mod commands;
pub(crate) mod print;
pub(crate) mod progress;
