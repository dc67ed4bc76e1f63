//! No build step. This script exists for its `[build-dependencies]` alone: `syn` with the
//! features the Python binding's proc macros (PyO3's) enable, so that the host-side `syn` of
//! `cargo test` and of the binding's build (`pip install ./`, `.ci/run`) is the same crate, and
//! with it every proc macro (`serde_derive`, `thiserror`, `clap_derive`) and every crate above
//! them. The two builds then share one target directory's artifacts instead of compiling the
//! dependencies twice (Cargo.toml, `[build-dependencies]`).

fn main() {
    // Run once: not again whenever a file of the package (a sweep's results) changes.
    println!("cargo::rerun-if-changed=build.rs");
}
