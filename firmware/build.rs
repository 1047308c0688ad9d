//! Link with cortex-m-rt's link.x and defmt's defmt.x, against the repository's memory.x (the F405's flash and
//! RAM with the field-log sectors carved out, the stack in CCM), or for the `qemu` feature against
//! `qemu/memory.x` (the same, with the stack in SRAM: QEMU's netduinoplus2 has no CCM). The flags apply to this
//! crate's binaries only.
use std::path::PathBuf;

fn main() {
    let root = PathBuf::from(std::env::var("CARGO_MANIFEST_DIR").unwrap()).join("..");
    let root = root.canonicalize().unwrap_or(root);
    // memory.x is found on the linker search path (link.x includes it by name): the first directory wins.
    if std::env::var_os("CARGO_FEATURE_QEMU").is_some() {
        let qemu = PathBuf::from(std::env::var("CARGO_MANIFEST_DIR").unwrap()).join("qemu");
        println!("cargo:rustc-link-search={}", qemu.display());
        println!("cargo:rerun-if-changed={}", qemu.join("memory.x").display());
    }
    println!("cargo:rustc-link-search={}", root.display());
    println!("cargo:rerun-if-changed={}", root.join("memory.x").display());
    println!("cargo:rustc-link-arg-bins=--nmagic");
    println!("cargo:rustc-link-arg-bins=-Tlink.x");
    println!("cargo:rustc-link-arg-bins=-Tdefmt.x");
}
