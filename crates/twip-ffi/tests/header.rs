//! The header kept in the repository is the one cbindgen makes from the Rust declarations
//! now. `TWIP_BLESS=1 cargo test -p twip-ffi --test header` rewrites it.
use std::path::Path;

fn generated() -> String {
    let dir = env!("CARGO_MANIFEST_DIR");
    let config = cbindgen::Config::from_file(Path::new(dir).join("cbindgen.toml")).expect("cbindgen.toml");
    let mut out = Vec::new();
    cbindgen::Builder::new()
        .with_crate(dir)
        .with_config(config)
        .generate()
        .expect("cbindgen reads the crate")
        .write(&mut out);
    String::from_utf8(out).expect("UTF-8 header")
}

#[test]
fn header_matches_the_rust_declarations() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("include/twip.h");
    let now = generated();
    if std::env::var_os("TWIP_BLESS").is_some() {
        std::fs::write(&path, &now).expect("write include/twip.h");
    }
    let kept = std::fs::read_to_string(&path).unwrap_or_default();
    assert!(
        kept == now,
        "include/twip.h differs from the Rust declarations; regenerate it with \
         `TWIP_BLESS=1 cargo test -p twip-ffi --test header` and review the diff"
    );
}

#[test]
fn robot_fields_are_the_cores_in_order() {
    let header = generated();
    let end = header.find("} TwipRobot;").expect("TwipRobot");
    let start = header[..end].rfind("typedef struct {").expect("its opening");
    let robot = &header[start..end];
    let fields: Vec<&str> = robot
        .lines()
        .filter_map(|l| l.trim().strip_prefix("float ").and_then(|f| f.strip_suffix(';')))
        .collect();
    assert_eq!(fields, twip_core::model::params::FIELD_NAMES.to_vec());
}
