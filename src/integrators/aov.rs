//! The film every method returns: beauty (RGBA) plus the AOV layers albedo, normal, depth, direct
//! and indirect, assembled from per-pixel values in one place.

use crate::image::Film;
use crate::Result;
use glam::Vec3;

/// Per-pixel values of one image (all slices have width × height entries).
pub struct Aovs<'a> {
    pub direct: &'a [Vec3],
    pub indirect: &'a [Vec3],
    pub albedo: &'a [Vec3],
    pub normal: &'a [Vec3],
    /// Camera-space depth (0 where nothing was hit).
    pub depth: &'a [f32],
}

/// Build the film; beauty = direct + indirect, alpha 1. Its layers are allocated fallibly
/// ([`crate::Error::OutOfMemory`]).
pub fn film(width: u32, height: u32, a: &Aovs) -> Result<Film> {
    let n = (width * height) as usize;
    let mut film = Film::new(width, height);
    film.try_add_layer("", &["R", "G", "B", "A"])?;
    let put3 = |film: &mut Film, name: &str, ch: &[&str], v: &[Vec3]| -> Result<()> {
        film.try_add_layer(name, ch)?;
        let l = film.layer_mut(name).expect("layer just added");
        for (dst, src) in l.data.chunks_exact_mut(3).zip(v) {
            dst.copy_from_slice(&src.to_array());
        }
        Ok(())
    };
    put3(&mut film, "albedo", &["R", "G", "B"], a.albedo)?;
    put3(&mut film, "normal", &["X", "Y", "Z"], a.normal)?;
    film.try_add_layer("depth", &["Z"])?;
    film.layer_mut("depth").expect("depth").data.copy_from_slice(&a.depth[..n]);
    put3(&mut film, "direct", &["R", "G", "B"], a.direct)?;
    put3(&mut film, "indirect", &["R", "G", "B"], a.indirect)?;
    let beauty = film.layer_mut("").expect("beauty");
    for (i, dst) in beauty.data.chunks_exact_mut(4).enumerate() {
        let b = a.direct[i] + a.indirect[i];
        dst.copy_from_slice(&[b.x, b.y, b.z, 1.0]);
    }
    Ok(film)
}
