//! Benchmarks: see README.
fn main() {
    divan::main();
}
