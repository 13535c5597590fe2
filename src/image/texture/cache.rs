//! Decoded 8-bit textures kept on disk, beside the conversion cache: decoding is most of a
//! textured scene's preparation (Crytek Sponza: 0.24 s of 0.33 s for its 22 PNG files on 2 cores),
//! and a scene is rendered many times. A file holds one texture's blocks exactly as
//! [`Blocked`] keeps them in memory, so a hit is one read.
//!
//! The key is the SHA-256 of the image file's content, the requested colour space and the cache
//! format version: an edited image is decoded again, whatever its name or date. Files are written
//! to a temporary name and renamed, so concurrent renders never read a partial file; a file that
//! does not match its header or its checksum (a CRC-32 of the blocks) is decoded again and
//! replaced, with a warning. The cache is a speed-up only: when its
//! directory cannot be written, textures are decoded every time, with the same texels.
//!
//! File layout (little-endian): `b"RSTX"`, version `u32`, width `u32`, height `u32`, sRGB flag
//! `u32` (0/1), CRC-32 of the blocks `u32`, then the blocks (64 bytes each, [`Rgba8x4x4`]) of the image and of each of its MIP
//! levels in turn ([`super::mip`]: their sizes follow from the image's).

use std::io::{Read, Write};
use std::path::{Path, PathBuf};

use sha2::{Digest, Sha256};

use super::blocked::{Blocked, Rgba8x4x4};
use super::{mip, ColorSpace};

const MAGIC: &[u8; 4] = b"RSTX";
const VERSION: u32 = 3;
const HEADER: usize = 24;

/// A decoded 8-bit texture: size, whether its colour channels are sRGB-encoded, the blocks of the
/// image and of its MIP levels (the image first).
pub(super) struct Decoded {
    pub width: u32,
    pub height: u32,
    pub srgb: bool,
    pub levels: Vec<Blocked<Rgba8x4x4>>,
}

/// Blocks of a `w × h` level (4 × 4 texels each).
fn block_count(w: u32, h: u32) -> Option<usize> {
    (w as usize).div_ceil(4).checked_mul((h as usize).div_ceil(4))
}

/// The cache file of an image file's `content` read in `color_space`, under `dir`.
pub(super) fn path_for(dir: &Path, content: &[u8], color_space: ColorSpace) -> PathBuf {
    let mut h = Sha256::new();
    h.update(MAGIC);
    h.update(VERSION.to_le_bytes());
    h.update(format!("{color_space:?}").as_bytes());
    h.update(content);
    let key: String = h.finalize()[..16].iter().map(|b| format!("{b:02x}")).collect();
    dir.join("textures").join(format!("{key}.rstx"))
}

/// The texture stored at `path` (marked as just used, for the cache's bound:
/// [`crate::io::cache`]): `Ok(None)` when there is none, an error saying why when the file is
/// damaged (it does not match its header or its checksum, or is of another version).
pub(super) fn read(path: &Path) -> Result<Option<Decoded>, String> {
    let f = match std::fs::File::open(path) {
        Ok(f) => f,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(None),
        Err(e) => return Err(e.to_string()),
    };
    let d = read_file(f)?;
    crate::io::cache::touch(path);
    Ok(Some(d))
}

fn read_file(mut f: std::fs::File) -> Result<Decoded, String> {
    let mut head = [0u8; HEADER];
    f.read_exact(&mut head).map_err(|_| "shorter than its header")?;
    let word = |i: usize| u32::from_le_bytes(head[4 * i..4 * i + 4].try_into().expect("4 bytes"));
    if &head[..4] != MAGIC || word(1) != VERSION || word(4) > 1 {
        return Err("not a decoded texture of this version".into());
    }
    let (width, height) = (word(2), word(3));
    if width == 0 || height == 0 {
        return Err("its header gives an empty image".into());
    }
    // 4 × 4 texels per block (`Blocked::from_blocks` checks the count again)
    let sizes: Vec<(u32, u32)> = std::iter::once((width, height)).chain(mip::sizes(width, height)).collect();
    let counts = sizes.iter().map(|&(w, h)| block_count(w, h)).collect::<Option<Vec<usize>>>().ok_or("absurd size")?;
    let n = counts.iter().try_fold(0usize, |a, &c| a.checked_add(c)).ok_or("absurd size")?;
    let len = n.checked_mul(std::mem::size_of::<Rgba8x4x4>()).ok_or("absurd size")?;
    if f.metadata().map_err(|e| e.to_string())?.len() != (HEADER as u64).checked_add(len as u64).ok_or("absurd size")? {
        return Err(format!("its size does not match its header ({width}x{height})"));
    }
    // read into an unfilled buffer of the exact size (not zero-filled first: one pass over the
    // texels, not two), then view its bytes as blocks (alignment 1: no copy)
    let mut bytes = crate::memory::try_vec_with_capacity(len, || format!("a {width}x{height} texture")).map_err(|e| e.to_string())?;
    if f.take(len as u64).read_to_end(&mut bytes).map_err(|e| e.to_string())? != len {
        return Err("truncated".into());
    }
    if crc32fast::hash(&bytes) != word(5) {
        return Err("checksum mismatch".into());
    }
    let mut blocks: Vec<Rgba8x4x4> = bytemuck::try_cast_vec(bytes).unwrap_or_else(|(_, b)| bytemuck::pod_collect_to_vec(&b));
    // the levels split off from the end, then put back in order
    let mut levels = Vec::with_capacity(sizes.len());
    for (&(w, h), &c) in sizes.iter().zip(&counts).rev() {
        let tail = blocks.split_off(blocks.len() - c);
        levels.push(Blocked::from_blocks(w, h, tail).ok_or("its blocks do not match its size")?);
    }
    levels.reverse();
    Ok(Decoded { width, height, srgb: word(4) == 1, levels })
}

/// Store `t` at `path` (best effort: a cache that cannot be written is no error).
pub(super) fn write(path: &Path, t: &Decoded) {
    let Some(dir) = path.parent() else { return };
    if std::fs::create_dir_all(dir).is_err() {
        return;
    }
    let Some(name) = path.file_name() else { return };
    let Ok(mut tmp) = crate::io::temporaries::create_file(dir, name) else { return };
    let mut crc = crc32fast::Hasher::new();
    t.levels.iter().for_each(|l| crc.update(bytemuck::cast_slice(l.blocks())));
    let mut head = Vec::with_capacity(HEADER);
    head.extend_from_slice(MAGIC);
    for w in [VERSION, t.width, t.height, t.srgb as u32, crc.finalize()] {
        head.extend_from_slice(&w.to_le_bytes());
    }
    let f = tmp.as_file_mut();
    let written = f.write_all(&head).and_then(|_| t.levels.iter().try_for_each(|l| f.write_all(bytemuck::cast_slice(l.blocks()))));
    if written.is_ok() && tmp.persist(path).is_ok() {
        // the conversions and decoded textures together keep to the cache's limit (an unreadable
        // limit leaves the cache as it is: the render reports it when it converts)
        if let (Some(cache), Ok(limit)) = (dir.parent(), crate::io::cache::limit()) {
            crate::io::cache::prune(cache, path, limit);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::super::load::read_ldr_texels;
    use super::super::{Level, Texels};
    use super::*;

    /// Size, colour table and blocks of 8-bit texels (every level), as bytes.
    fn ldr(levels: &[Level]) -> (u32, u32, Vec<f32>, Vec<u8>) {
        let mut bytes = Vec::new();
        let mut lut0 = Vec::new();
        for l in levels {
            let Texels::Ldr { data, lut } = &l.texels else { panic!("not 8-bit") };
            bytes.extend_from_slice(bytemuck::cast_slice(data.blocks()));
            lut0 = lut.to_vec();
        }
        (levels[0].width, levels[0].height, lut0, bytes)
    }

    /// A texture read from the cache is the decoded one, bit for bit, for each colour space and
    /// channel count; a damaged cache file is decoded again and replaced; an edited image is not
    /// served from the old entry.
    #[test]
    fn cached_textures_are_the_decoded_ones() {
        let dir = tempfile::tempdir().unwrap();
        let cache = dir.path().join("cache");
        let rgba = dir.path().join("rgba.png");
        let texel = |x: u32, y: u32, c: u32| ((x * 37 + y * 101 + c * 59) % 251) as u8;
        image::RgbaImage::from_fn(13, 7, |x, y| image::Rgba([0, 1, 2, 3].map(|c| texel(x, y, c)))).save(&rgba).unwrap();
        let grey = dir.path().join("grey.png");
        image::GrayImage::from_fn(5, 9, |x, y| image::Luma([texel(x, y, 0)])).save(&grey).unwrap();
        let mut files = 0;
        for path in [&rgba, &grey] {
            for cs in [ColorSpace::Auto, ColorSpace::Raw, ColorSpace::Srgb] {
                let cold = ldr(&read_ldr_texels(path, cs, &cache, &mut Vec::new()).unwrap());
                files += 1;
                assert_eq!(std::fs::read_dir(cache.join("textures")).unwrap().count(), files, "one file per image and colour space");
                // the second read finds the file (a valid one) and takes it
                let stored = read(&path_for(&cache, &std::fs::read(path).unwrap(), cs)).unwrap().expect("a valid cache file");
                let stored_bytes: Vec<u8> = stored.levels.iter().flat_map(|l| bytemuck::cast_slice::<_, u8>(l.blocks()).to_vec()).collect();
                assert_eq!(stored_bytes, cold.3);
                assert_eq!(stored.levels.len(), 1 + mip::sizes(stored.width, stored.height).len(), "every level is stored");
                let warm = ldr(&read_ldr_texels(path, cs, &cache, &mut Vec::new()).unwrap());
                assert!(cold == warm, "{path:?} {cs:?}: the cached texels differ");
            }
        }
        // the colour spaces are keyed apart: an sRGB table for auto, a linear one for raw
        let (auto, raw) = (ldr(&read_ldr_texels(&rgba, ColorSpace::Auto, &cache, &mut Vec::new()).unwrap()), ldr(&read_ldr_texels(&rgba, ColorSpace::Raw, &cache, &mut Vec::new()).unwrap()));
        // (the image's bytes are the same; its levels, averaged in linear values, are not)
        let image_bytes = 13usize.div_ceil(4) * 7usize.div_ceil(4) * 64;
        assert!(auto.2 != raw.2 && auto.3[..image_bytes] == raw.3[..image_bytes] && auto.3 != raw.3);
        // a damaged file (cut short, or with zeroed texels): decoded again with a note, and replaced
        let content = std::fs::read(&rgba).unwrap();
        let file = path_for(&cache, &content, ColorSpace::Auto);
        let whole = std::fs::read(&file).unwrap();
        let mut zeroed = whole.clone();
        zeroed[HEADER..HEADER + 64].fill(0);
        for (damaged, why) in [(whole[..100].to_vec(), "does not match its header"), (zeroed, "checksum mismatch")] {
            std::fs::write(&file, &damaged).unwrap();
            assert!(read(&file).err().is_some_and(|e| e.contains(why)));
            let mut notes = Vec::new();
            assert!(ldr(&read_ldr_texels(&rgba, ColorSpace::Auto, &cache, &mut notes).unwrap()) == auto);
            assert!(notes.len() == 1 && notes[0].contains(why) && notes[0].contains(&file.display().to_string()), "{notes:?}");
            assert_eq!(std::fs::read(&file).unwrap(), whole);
        }
        // an edited image under the same name
        image::RgbaImage::from_fn(13, 7, |x, y| image::Rgba([0, 1, 2, 3].map(|c| 255 - texel(x, y, c)))).save(&rgba).unwrap();
        let edited = ldr(&read_ldr_texels(&rgba, ColorSpace::Auto, &cache, &mut Vec::new()).unwrap());
        assert!(edited.3 != auto.3, "the old entry was served");
        let fresh = tempfile::tempdir().unwrap();
        assert!(ldr(&read_ldr_texels(&rgba, ColorSpace::Auto, fresh.path(), &mut Vec::new()).unwrap()) == edited);
    }

    /// Every 8-bit format the converter may hand over decodes to the same texels: PNG and BMP by
    /// their signatures, TGA (which has none) by its extension.
    #[test]
    fn every_format_decodes_to_the_same_texels() {
        let dir = tempfile::tempdir().unwrap();
        let img = image::RgbaImage::from_fn(9, 6, |x, y| image::Rgba([x as u8 * 20, y as u8 * 30, 99, 255]));
        let cache = dir.path().join("cache");
        let decoded: Vec<_> = ["t.png", "t.tga", "t.bmp"]
            .iter()
            .map(|name| {
                let path = dir.path().join(name);
                img.save(&path).unwrap();
                ldr(&read_ldr_texels(&path, ColorSpace::Raw, &cache, &mut Vec::new()).unwrap_or_else(|e| panic!("{name}: {e}")))
            })
            .collect();
        assert!(decoded.iter().all(|d| *d == decoded[0]), "the formats decode differently");
    }

    /// A directory that cannot be written leaves the texels as decoded.
    #[test]
    fn an_unwritable_cache_is_no_error() {
        let dir = tempfile::tempdir().unwrap();
        let png = dir.path().join("t.png");
        image::RgbImage::from_fn(6, 5, |x, y| image::Rgb([x as u8 * 40, y as u8 * 50, 7])).save(&png).unwrap();
        let blocker = dir.path().join("file");
        std::fs::write(&blocker, b"not a directory").unwrap();
        let t = read_ldr_texels(&png, ColorSpace::Auto, &blocker, &mut Vec::new()).unwrap();
        assert!(ldr(&t) == ldr(&read_ldr_texels(&png, ColorSpace::Auto, &dir.path().join("c"), &mut Vec::new()).unwrap()));
    }
}
