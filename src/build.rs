//! Tells campath the optimisation level it is built at, so that a frame-hash test in an
//! unoptimised build can say how to make it fast.
fn main() {
    let level = std::env::var("OPT_LEVEL").unwrap_or_default();
    println!("cargo:rustc-env=CAMPATH_OPT_LEVEL={level}");
    println!("cargo:rerun-if-changed=build.rs");
}
