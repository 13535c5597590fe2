//! OpenEXR input and output through the safe API of the `openexr` crate (OpenEXR 3.0).
//!
//! Files are written as single-part scan-line images with 32-bit float channels and ZIP
//! compression (via `openexr::flat`, whose save function is safe). Files are read with
//! `InputFile` + `Frame`, which reads scan-line and tiled files (level 0 of mip-mapped ones) and
//! converts half and uint channels to float.

use std::collections::BTreeMap;
use std::path::Path;

use openexr::core::attribute::CppStringAttribute;
use openexr::core::channel_list::{CHANNEL_FLOAT, CHANNEL_HALF, CHANNEL_UINT};
use openexr::core::frame_buffer::Frame;
use openexr::core::header::Header;
use openexr::core::input_file::InputFile;
use openexr::core::{Compression, DataWindowSource, LevelMode, LevelRoundingMode};
use openexr::flat::flat_image::FlatImage;
use openexr::flat::flat_image_io::save_flat_image_with_header;

use crate::io::atomic::{shown, write_atomically};
use super::film::{Film, Layer};
use crate::{Error, Result};

/// Directory holding the shared OpenEXR, Imath and zlib libraries (`libOpenEXR-3_0.so.29`, ...)
/// that `openexr-sys` built for this build profile; binaries of this crate carry it in their
/// run-time search path (see `openexr_rpath` in `build.rs`).
pub const OPENEXR_LIB_DIR: &str = env!("RAYSPLAT_OPENEXR_LIB_DIR");

/// `numThreads` for OpenEXR's `InputFile`: the number of line buffers it decodes into (decoding
/// threads come from OpenEXR's global pool, sized once per process by `io::exr_threads`).
const THREADS_HINT: i32 = 1;

/// Write `film` to `path` as an OpenEXR file.
///
/// Every channel is stored as a 32-bit float with ZIP compression. The beauty layer (`""`) keeps
/// bare channel names (`R`, `G`, `B`, `A`); channel `C` of layer `L` is stored as `L.C`
/// (`albedo.R`, `normal.X`, `depth.Z`). Each `(name, value)` of `attributes` becomes a string
/// attribute of the header (render settings, timings, ...).
///
/// The file is written to a temporary file in the same directory and renamed, so an error never
/// leaves a partial file behind; a missing directory is reported as such.
///
/// # Errors
/// [`Error::Image`] for an invalid film (empty, a layer whose data length does not match, a
/// channel name given twice), an invalid attribute (empty name, NUL byte, a name OpenEXR reserves
/// for another type) or a failure inside OpenEXR; [`Error::Io`] when the file cannot be created
/// or renamed.
pub fn write_exr(path: &Path, film: &Film, attributes: &[(String, String)]) -> Result<()> {
    let err = |m: String| Error::image(shown(path), m);
    let (w, h) = exr_size(film).map_err(err)?;
    let names = channel_names(film).map_err(err)?;
    for (name, value) in attributes {
        if name.is_empty() || name.contains('\0') || value.contains('\0') {
            return Err(err(format!("invalid header attribute {name:?} = {value:?}")));
        }
    }

    let image = flat_image(film, &names, w, h).map_err(err)?;
    let mut header = Header::from_dimensions(w, h);
    header.set_compression(Compression::Zip);
    header.set_pixel_aspect_ratio(film.pixel_aspect);
    for (name, value) in attributes {
        header
            .insert(name, &CppStringAttribute::from_value(value))
            .map_err(|e| err(format!("header attribute {name:?}: {e}")))?;
    }

    // ZIP compression of the line blocks on OpenEXR's pool, sized once per process from the first
    // caller's rayon pool (the file does not depend on it; a failure only leaves compression on
    // this thread).
    let _ = crate::io::exr_threads::size_pool_for_caller();
    write_atomically(path, crate::io::Format::Exr, |tmp, _file| {
        let tmp_str = tmp.to_str().ok_or_else(|| err("path is not valid UTF-8".into()))?;
        save_flat_image_with_header(tmp_str, &header, &image, DataWindowSource::Image)
            .map_err(|e| err(format!("OpenEXR: {e}")))
    })
}

/// Read an OpenEXR file into a [`Film`].
///
/// Scan-line and tiled single-part files are supported (of a mip-mapped file, the full-resolution
/// level; of a multi-part file, the first part), with half, float or uint channels, all converted
/// to `f32`. The film covers the display window; pixels outside the data window are 0.
///
/// Channels are grouped into layers by the prefix before their last dot (`albedo.R` → layer
/// `albedo`, channel `R`; `R` → the beauty layer `""`). The beauty layer comes first, the others
/// follow in alphabetical order; within a layer the channels are ordered R, G, B, A, X, Y, Z and
/// then any others alphabetically.
///
/// # Errors
/// [`Error::Io`] if the file cannot be opened; [`Error::Image`] if it is not a readable EXR file,
/// is deep, or has sub-sampled channels.
pub fn read_exr(path: &Path) -> Result<Film> {
    let err = |m: String| Error::image(shown(path), m);
    let file = open_input(path)?;
    let (data, display, channels, pixel_aspect) = {
        let header = file.header();
        let pixel_aspect = header.pixel_aspect_ratio();
        let data: [i32; 4] = *header.data_window::<[i32; 4]>();
        let display: [i32; 4] = *header.display_window::<[i32; 4]>();
        let channels: Vec<(String, openexr::core::channel_list::Channel)> =
            header.channels().iter().map(|(name, c)| (name.to_string(), c.clone())).collect();
        (data, display, channels, pixel_aspect)
    };
    let (Some((width, height)), Some(_)) = (window_size(display), window_size(data)) else {
        return Err(err(format!("unsupported display or data window ({display:?}, {data:?})")));
    };

    // Group channels by layer; BTreeMap orders layers alphabetically with "" (beauty) first.
    let mut layers: BTreeMap<String, Vec<String>> = BTreeMap::new();
    for (name, channel) in &channels {
        if channel.x_sampling != 1 || channel.y_sampling != 1 {
            return Err(err(format!("channel {name} is sub-sampled, which is not supported")));
        }
        let known = [CHANNEL_HALF.type_, CHANNEL_FLOAT.type_, CHANNEL_UINT.type_];
        if !known.contains(&channel.type_) {
            return Err(err(format!("channel {name} has an unknown pixel type")));
        }
        let (layer, chan) = split_channel_name(name);
        layers.entry(layer.to_string()).or_default().push(chan.to_string());
    }
    if layers.is_empty() {
        return Err(err("the file has no channels".into()));
    }
    for chans in layers.values_mut() {
        chans.sort_by_key(|c| channel_rank(c));
    }

    let mut frames = Vec::with_capacity(layers.len());
    for (layer, chans) in &layers {
        let full: Vec<String> = chans.iter().map(|c| full_channel_name(layer, c)).collect();
        frames.push(Frame::new::<f32, _, _>(&full, data).map_err(|e| err(format!("OpenEXR: {e}")))?);
    }
    let (_file, frames) = file
        .into_reader(frames)
        .and_then(|r| r.read_pixels(data[1], data[3]))
        .map_err(|e| err(format!("OpenEXR: {e}")))?;

    let mut film = Film::new(width, height);
    film.pixel_aspect = if pixel_aspect.is_finite() && pixel_aspect > 0.0 { pixel_aspect } else { 1.0 };
    for ((layer, chans), frame) in layers.into_iter().zip(frames) {
        let n = chans.len();
        let mut out = crate::memory::try_vec(film.pixel_count() * n, 0.0f32, || format!("{}: layer {layer:?} of {width}x{height} pixels", shown(path)))?;
        copy_window(frame.as_slice::<f32>(), data, &mut out, display, n);
        film.layers.push(Layer { name: layer, channels: chans, data: out });
    }
    Ok(film)
}

/// The value of the string attribute `name` in the header of the EXR file at `path`, or `None`
/// if the header has no string attribute of that name.
///
/// # Errors
/// As for [`read_exr`] when the file cannot be opened.
pub fn read_exr_string_attribute(path: &Path, name: &str) -> Result<Option<String>> {
    if name.contains('\0') {
        return Ok(None);
    }
    let file = open_input(path)?;
    let header = file.header();
    let value = header.find_typed_attribute_string(name).map(|a| a.value().to_string());
    Ok(value)
}

/// The string attributes among `names` that the header of the EXR file at `path` has, in the
/// order of `names` (one open of the file).
///
/// # Errors
/// As for [`read_exr`] when the file cannot be opened.
pub fn read_exr_string_attributes(path: &Path, names: &[&str]) -> Result<Vec<(String, String)>> {
    let file = open_input(path)?;
    let header = file.header();
    Ok(names
        .iter()
        .filter(|n| !n.contains('\0'))
        .filter_map(|n| header.find_typed_attribute_string(n).map(|a| (n.to_string(), a.value().to_string())))
        .collect())
}

/// Open `path` for reading, turning the crate's panics on odd paths into errors.
fn open_input(path: &Path) -> Result<InputFile> {
    // a regular file only: OpenEXR would wait forever on a FIFO and read /dev/zero without end
    let (file, len) = crate::io::input::open_input(path)?;
    // headers checked first: the `openexr` crate panics on some damaged ones
    let mut head = Vec::new();
    std::io::Read::read_to_end(&mut std::io::Read::take(file, (len as usize).min(super::exr_header::MAX_HEADER_BYTES) as u64), &mut head)
        .map_err(|e| Error::io(path, e))?;
    super::exr_header::check(&head).map_err(|m| Error::image(shown(path), format!("not a readable OpenEXR file: {m}")))?;
    let p = path.to_str().ok_or_else(|| Error::image(shown(path), "path is not valid UTF-8"))?;
    if p.contains('\0') {
        return Err(Error::image(shown(path), "path contains a NUL byte"));
    }
    // Decoding uses OpenEXR's pool too: it must be sized before any file is open (see `exr_threads`).
    let _ = crate::io::exr_threads::size_pool_for_caller();
    InputFile::new(p, THREADS_HINT).map_err(|e| Error::image(shown(path), format!("not a readable OpenEXR file: {e}")))
}

/// Largest window [`read_exr`] accepts, in pixels (32768²): guards against absurd headers.
const MAX_PIXELS: u64 = 1 << 30;

/// `(width, height)` of an inclusive `[xmin, ymin, xmax, ymax]` window, or `None` if it is empty
/// or larger than [`MAX_PIXELS`].
fn window_size(win: [i32; 4]) -> Option<(u32, u32)> {
    let w = win[2] as i64 - win[0] as i64 + 1;
    let h = win[3] as i64 - win[1] as i64 + 1;
    let ok = w > 0 && h > 0 && (w as u64) * (h as u64) <= MAX_PIXELS;
    ok.then_some((w as u32, h as u32))
}

/// The film size as OpenEXR wants it, or why it cannot be written.
fn exr_size(film: &Film) -> std::result::Result<(i32, i32), String> {
    let (w, h) = (i32::try_from(film.width), i32::try_from(film.height));
    match (w, h) {
        (Ok(w), Ok(h)) if w > 0 && h > 0 => Ok((w, h)),
        _ => Err(format!("cannot write a {}x{} image", film.width, film.height)),
    }
}

/// The EXR channel names of all layers, checking that the film can be written faithfully.
fn channel_names(film: &Film) -> std::result::Result<Vec<Vec<String>>, String> {
    if film.layers.is_empty() {
        return Err("the film has no layers".into());
    }
    let mut seen = std::collections::HashSet::new();
    let mut all = Vec::with_capacity(film.layers.len());
    for layer in &film.layers {
        let n = layer.channels.len();
        if n == 0 || layer.data.len() != film.pixel_count() * n {
            return Err(format!(
                "layer {:?}: {} values for {} channels of {}x{} pixels",
                layer.name,
                layer.data.len(),
                n,
                film.width,
                film.height
            ));
        }
        if layer.name.contains('\0') || layer.name.starts_with('.') || layer.name.ends_with('.') {
            return Err(format!("invalid layer name {:?}", layer.name));
        }
        let mut names = Vec::with_capacity(n);
        for c in &layer.channels {
            if c.is_empty() || c.contains('.') || c.contains('\0') {
                return Err(format!("layer {:?}: invalid channel name {c:?}", layer.name));
            }
            let full = full_channel_name(&layer.name, c);
            if !seen.insert(full.clone()) {
                return Err(format!("channel {full} appears twice"));
            }
            names.push(full);
        }
        all.push(names);
    }
    Ok(all)
}

/// A flat image with every channel of `film` as a float channel.
fn flat_image(film: &Film, names: &[Vec<String>], w: i32, h: i32) -> std::result::Result<FlatImage, String> {
    let oe = |e: openexr::Error| format!("OpenEXR: {e}");
    let mut image =
        FlatImage::new([0, 0, w - 1, h - 1], LevelMode::OneLevel, LevelRoundingMode::RoundDown).map_err(oe)?;
    for name in names.iter().flatten() {
        image.insert_channel(name, &CHANNEL_FLOAT).map_err(oe)?;
    }
    let level = image.level_mut(0, 0).map_err(oe)?;
    for (layer, layer_names) in film.layers.iter().zip(names) {
        let n = layer.channels.len();
        for (c, name) in layer_names.iter().enumerate() {
            let mut channel = level
                .find_channel_f32_mut(name)
                .ok_or_else(|| format!("OpenEXR: channel {name} missing after insertion"))?;
            let rows = layer.data.chunks_exact(w as usize * n);
            for (y, src) in (0..h).zip(rows) {
                let row = channel.row_mut(y).ok_or_else(|| format!("OpenEXR: no row {y} in channel {name}"))?;
                if row.len() != w as usize {
                    return Err(format!("OpenEXR: row of {} pixels, expected {w}", row.len()));
                }
                for (dst, px) in row.iter_mut().zip(src.chunks_exact(n)) {
                    *dst = px[c];
                }
            }
        }
    }
    Ok(image)
}

/// Copy interleaved pixels covering window `src_win` into `dst` covering window `dst_win`
/// (windows as `[xmin, ymin, xmax, ymax]`, inclusive), `n` channels per pixel; pixels of `dst`
/// outside `src_win` are left as they are.
fn copy_window(src: &[f32], src_win: [i32; 4], dst: &mut [f32], dst_win: [i32; 4], n: usize) {
    let src_w = (src_win[2] - src_win[0] + 1) as usize;
    let dst_w = (dst_win[2] - dst_win[0] + 1) as usize;
    let (x0, x1) = (src_win[0].max(dst_win[0]), src_win[2].min(dst_win[2]));
    let (y0, y1) = (src_win[1].max(dst_win[1]), src_win[3].min(dst_win[3]));
    if x0 > x1 || y0 > y1 {
        return;
    }
    let len = (x1 - x0 + 1) as usize * n;
    for y in y0..=y1 {
        let s = ((y - src_win[1]) as usize * src_w + (x0 - src_win[0]) as usize) * n;
        let d = ((y - dst_win[1]) as usize * dst_w + (x0 - dst_win[0]) as usize) * n;
        dst[d..d + len].copy_from_slice(&src[s..s + len]);
    }
}

/// `(layer, channel)` of an EXR channel name: split at the last dot; names with no dot, or a dot
/// only at the start or end, belong to no layer (OpenEXR's convention).
fn split_channel_name(name: &str) -> (&str, &str) {
    match name.rsplit_once('.') {
        Some((layer, chan)) if !layer.is_empty() && !chan.is_empty() => (layer, chan),
        _ => ("", name),
    }
}

/// The EXR channel name of channel `chan` of layer `layer`.
fn full_channel_name(layer: &str, chan: &str) -> String {
    if layer.is_empty() {
        chan.to_string()
    } else {
        format!("{layer}.{chan}")
    }
}

/// Sort key putting the usual channels in their conventional order.
fn channel_rank(c: &str) -> (usize, String) {
    const ORDER: [&str; 7] = ["R", "G", "B", "A", "X", "Y", "Z"];
    (ORDER.iter().position(|o| *o == c).unwrap_or(ORDER.len()), c.to_string())
}
