//! Images: the [`Film`] a render produces, OpenEXR input/output, sRGB PNG previews (with an automatic
//! exposure), pixel reconstruction filters, image textures,
//! and the comparison metrics and false-colour error images used to judge a render against a
//! reference.
//!
//! Conventions shared by every function here:
//! - pixel data is row-major with the **top row first**, channels interleaved;
//! - an "RGB buffer" is `3 · width · height` linear floats;
//! - every file is written to a temporary file in the destination directory and renamed into
//!   place, so a failed or interrupted write never leaves a partial file under the final name.
//!
//! This module is safe Rust only: OpenEXR is reached through the safe API of the `openexr` crate.

mod compare;
mod exr;
mod exposure;
mod exr_header;
mod film;
mod filter;
mod png;
mod srgb;
mod texture;

#[cfg(test)]
mod tests;

pub use compare::{block_average, compare, error_image, pixel_relative_error, Metrics, ERROR_RAMP};
pub use exposure::{auto_exposure, AutoExposure, MIDDLE_GREY};
pub use exr::{read_exr, read_exr_string_attribute, read_exr_string_attributes, write_exr, OPENEXR_LIB_DIR};
pub use film::{Film, Layer};
pub use filter::{FilterKind, FilterSampler, FilteredImage, PixelFilter, SplatTile};
pub use png::{write_png, write_png_unsqueezed};
pub use srgb::{srgb_decode, srgb_encode};
pub use texture::{Footprint, Texture};
