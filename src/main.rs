//! The `latticesim` command-line program (the library `latticesim` does the work).

#[global_allocator]
static ALLOCATOR: latticesim::alloc::HugePages = latticesim::alloc::HugePages;

fn main() -> std::process::ExitCode {
    latticesim::alloc::tune();
    latticesim::main()
}
