//! Parts of a render that several machines share: a crop window (`--crop X0,Y0,X1,Y1`), a tile of
//! the image (`--tile I/N`: band `I` of `N` bands of rows) and a range of passes (`--passes N
//! --pass-range FIRST:END`). What a part holds is written into its EXR header
//! ([`part_attributes`]), which `raysplat merge` reads to stitch tiles and average passes.

use raysplat::Error;

/// Parse `X0,Y0,X1,Y1` (pixels, `X1`/`Y1` exclusive); checked against the image size later.
pub fn parse_crop(s: &str) -> Result<[u32; 4], Error> {
    let bad = || Error::param("crop", format!("{s:?} is not of the form X0,Y0,X1,Y1 (pixels, the window [X0, X1) x [Y0, Y1), e.g. 0,0,64,32)"));
    let v: Vec<u32> = s.split(',').map(|p| p.trim().parse::<u32>().map_err(|_| bad())).collect::<Result<_, _>>()?;
    let [x0, y0, x1, y1] = v[..] else { return Err(bad()) };
    Ok([x0, y0, x1, y1])
}

/// Parse `I/N` (tile `I` of `N`, from 0).
pub fn parse_tile(s: &str) -> Result<(u32, u32), Error> {
    let bad = |why: &str| Error::param("tile", format!("{s:?}: {why} (expected I/N, tile I of N counted from 0, e.g. 0/4)"));
    let (i, n) = s.split_once('/').ok_or_else(|| bad("not of the form I/N"))?;
    let i: u32 = i.trim().parse().map_err(|_| bad("I is not a whole number"))?;
    let n: u32 = n.trim().parse().map_err(|_| bad("N is not a whole number"))?;
    if n == 0 || i >= n {
        return Err(bad("I must be below N, N at least 1"));
    }
    Ok((i, n))
}

/// The crop window of tile `i` of `n` of a `w`×`h` image: band `i` of `n` bands of whole rows
/// (rows `⌊i·h/n⌋ .. ⌊(i+1)·h/n⌋`; whole rows keep each task's primary rays coherent).
pub fn tile_window(i: u32, n: u32, [w, h]: [u32; 2]) -> Result<[u32; 4], Error> {
    if n > h {
        return Err(Error::param("tile", format!("{n} tiles of a {w}x{h} image: at most one per row ({h})")));
    }
    let row = |k: u32| (k as u64 * h as u64 / n as u64) as u32;
    Ok([0, row(i), w, row(i + 1)])
}

/// Parse `FIRST:END` (passes `FIRST .. END`, from 0).
pub fn parse_pass_range(s: &str) -> Result<(u32, u32), Error> {
    let bad = || Error::param("pass-range", format!("{s:?} is not of the form FIRST:END (passes FIRST up to END, from 0, e.g. 0:16)"));
    let (a, b) = s.split_once(':').ok_or_else(bad)?;
    Ok((a.trim().parse().map_err(|_| bad())?, b.trim().parse().map_err(|_| bad())?))
}

/// Header attributes saying what part of the whole a render is: the hash of the scene file it
/// read, the whole image's size and the window rendered (the whole image when not cropped).
pub fn part_attributes(scene_sha256: &str, full: [u32; 2], crop: Option<[u32; 4]>) -> Vec<(String, String)> {
    let [x0, y0, x1, y1] = crop.unwrap_or([0, 0, full[0], full[1]]);
    vec![
        ("raysplat:scene_sha256".into(), scene_sha256.to_string()),
        ("raysplat:full_resolution".into(), format!("{}x{}", full[0], full[1])),
        ("raysplat:crop".into(), format!("{x0},{y0},{x1},{y1}")),
    ]
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The tiles of an image are disjoint bands of rows that cover it.
    #[test]
    fn tiles_cover_the_image_once() {
        for (h, n) in [(7u32, 3u32), (64, 4), (5, 5), (100, 7)] {
            let mut next = 0;
            for i in 0..n {
                let [x0, y0, x1, y1] = tile_window(i, n, [9, h]).unwrap();
                assert_eq!((x0, x1, y0), (0, 9, next));
                assert!(y1 > y0);
                next = y1;
            }
            assert_eq!(next, h);
        }
        assert!(tile_window(0, 8, [9, 7]).is_err());
    }

    #[test]
    fn parse_errors_name_the_form() {
        assert_eq!(parse_crop("1, 2,30,40").unwrap(), [1, 2, 30, 40]);
        assert!(parse_crop("1,2,3").unwrap_err().to_string().contains("X0,Y0,X1,Y1"));
        assert_eq!(parse_tile("3/4").unwrap(), (3, 4));
        assert!(parse_tile("4/4").unwrap_err().to_string().contains("I/N"));
        assert_eq!(parse_pass_range("2:5").unwrap(), (2, 5));
        assert!(parse_pass_range("2-5").is_err());
    }
}
