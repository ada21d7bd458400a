//! The `stiction` binary: a thin wrapper around [`stiction_cli::run`].
/// mimalloc instead of the system allocator: a grid search allocates and frees its surface
/// (a megabyte or more) per combination, which glibc hands back to the kernel and then faults
/// in again; the benchmarks that time a command's path use it too
/// (`docs/decisions/2026-11-29-allocator.md`).
#[global_allocator]
static GLOBAL: mimalloc::MiMalloc = mimalloc::MiMalloc;

fn main() -> std::process::ExitCode {
    stiction_cli::run()
}
