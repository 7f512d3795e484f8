//! The `garmatnet` command line: one file per subcommand.

pub mod body;
pub mod materials;
pub mod pose_arg;
pub mod template;
