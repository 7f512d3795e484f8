//! The `garmatnet` command line: one file per subcommand.

pub mod bench;
pub mod body;
pub mod dataset;
pub mod drape;
pub mod ensemble;
pub mod eval;
pub mod materials;
pub mod simulate;
pub mod stress;
pub mod template;
pub mod train;
