//! Integration tests of the pipeline, one module per stage.
mod sim;
mod features;
mod align;
mod evaluate;
mod monitor;
