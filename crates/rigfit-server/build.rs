//! Rebuilds the crate when the page's files change: they are embedded in the binary.

fn main() {
    for path in ["../../web/index.html", "../../web/app", "../../web/vendor"] {
        println!("cargo:rerun-if-changed={path}");
    }
}
