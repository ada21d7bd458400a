//! Nothing to build: the build-dependencies of this crate exist for feature unification
//! with the Python extension (Cargo.toml says why).
fn main() {}
