//! Writing the benchmark plots (shared by the `*_plots` examples).

use std::path::Path;

use rigfit_render::Image;

/// Writes `image` as `dir/name` (PNG, atomically) and says so.
pub fn write(image: &Image, dir: &Path, name: &str) {
    let path = dir.join(name);
    let bytes = image.png().expect("PNG encoding");
    rigfit_formats::error::write_atomic(&path, &bytes).expect("writing the plot");
    println!("wrote {}", path.display());
}
