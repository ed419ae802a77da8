//! Records the version of spade that Cargo.lock pins, for `geoalpha --version`.

fn main() {
    println!("cargo:rerun-if-changed=Cargo.lock");
    let lock = std::fs::read_to_string("Cargo.lock").unwrap_or_default();
    let version = lock
        .split("[[package]]")
        .find(|p| p.contains("name = \"spade\"\n"))
        .and_then(|p| p.lines().find(|l| l.starts_with("version = ")))
        .and_then(|l| l.split('"').nth(1))
        .unwrap_or("unknown")
        .to_string();
    println!("cargo:rustc-env=GEOALPHA_SPADE_VERSION={version}");
}
