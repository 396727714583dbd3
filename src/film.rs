//! The film: the image plane's resolution in pixels (the raster
//! convention is in docs/conventions.md, "Raster").

/// Film resolution in pixels. Pixel (i, j) covers [i, i+1) × [j, j+1),
/// i = column from the left, j = row from the top.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Film {
    pub width: u32,
    pub height: u32,
}
