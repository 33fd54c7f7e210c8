//! `include/lumen.h` is what cbindgen makes of the source today: regenerated here and compared.
//! `LUMEN_BLESS=1 cargo test -p lumen-c --test header` rewrites it.

use std::path::PathBuf;

fn crate_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// The header as cbindgen writes it from this crate, proto's contact record and its headers.
fn generate() -> String {
    let dir = crate_dir();
    let config = cbindgen::Config::from_file(dir.join("cbindgen.toml")).expect("client/c/cbindgen.toml");
    let proto = dir.join("../../proto/src");
    let bindings = cbindgen::Builder::new()
        .with_config(config)
        .with_src(dir.join("src/lib.rs"))
        .with_src(proto.join("contact.rs"))
        .with_src(proto.join("wire.rs"))
        .generate()
        .expect("cbindgen parses the source");
    let mut out = Vec::new();
    bindings.write(&mut out);
    String::from_utf8(out).expect("cbindgen writes UTF-8")
}

#[test]
fn the_checked_in_header_is_the_generated_one() {
    let path = crate_dir().join("include/lumen.h");
    let fresh = generate();
    if std::env::var_os("LUMEN_BLESS").is_some_and(|v| v == "1") {
        std::fs::write(&path, &fresh).expect("writing include/lumen.h");
        return;
    }
    let current = std::fs::read_to_string(&path).unwrap_or_default();
    assert!(current == fresh, "client/c/include/lumen.h differs from what cbindgen makes of the source; refresh it with\n  LUMEN_BLESS=1 cargo test -p lumen-c --test header\nand commit it");
}
