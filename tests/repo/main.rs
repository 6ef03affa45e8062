//! Checks of the repository itself, one binary: the module graph and layers, the
//! crates' dependency trees, and the generated results tables.
//!
//! One crate for the layer (each module was a test binary of its own): the layer's
//! tests link once. Run one module with `cargo test --release --test repo MODULE::`.

mod architecture;
mod dependencies;
mod results;
