//! Link with cortex-m-rt's link.x and defmt's defmt.x, against the repository's memory.x (the F405's flash and
//! RAM with the field-log sectors carved out). The flags apply to this crate's binaries only.
use std::path::PathBuf;

fn main() {
    let root = PathBuf::from(std::env::var("CARGO_MANIFEST_DIR").unwrap()).join("..");
    let root = root.canonicalize().unwrap_or(root);
    // memory.x is found on the linker search path: link.x includes it by name.
    println!("cargo:rustc-link-search={}", root.display());
    println!("cargo:rerun-if-changed={}", root.join("memory.x").display());
    println!("cargo:rustc-link-arg-bins=--nmagic");
    println!("cargo:rustc-link-arg-bins=-Tlink.x");
    println!("cargo:rustc-link-arg-bins=-Tdefmt.x");
}
