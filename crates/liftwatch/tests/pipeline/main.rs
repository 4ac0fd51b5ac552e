//! Integration tests of the pipeline, one module per stage.
mod align;
mod evaluate;
mod features;
mod layers;
mod monitor;
mod sim;
mod tester;
