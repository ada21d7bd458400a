//! Nothing to build: the build-dependencies of this crate exist for feature unification
//! with the test suite and the CLI (Cargo.toml says why).
fn main() {}
