//! One file per subcommand; each `run()` reads as its slice of the pipeline.

pub mod align;
pub mod demo;
pub mod evaluate;
pub mod fit;
pub mod monitor;
pub mod replay;
pub mod report;
pub mod serve;
pub mod simulate;
pub mod spill;
pub mod status;
pub mod step;
pub mod ui;
