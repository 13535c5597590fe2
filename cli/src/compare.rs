//! `raysplat compare`: an image against a reference (RMSE, relative MSE, shares of pixels over 5 /
//! 15 / 30 % error), of the beauty or of a named layer, optionally of block averages (`--block`),
//! with an optional false-colour error image.

use raysplat::image::{self, Film};
use raysplat::Error;
use std::path::Path;

fn rgb_of(film: &Film, path: &Path, layer: &str) -> Result<Vec<f32>, Error> {
    film.rgb(layer).ok_or_else(|| {
        let what = if layer.is_empty() { "the beauty layer".to_string() } else { format!("layer {layer:?}") };
        Error::image(path.display().to_string(), format!("{what} has no R, G, B channels"))
    })
}

pub(super) fn compare(test: &Path, reference: &Path, layer: &str, error_image: Option<&Path>, json: bool, block: u32) -> anyhow::Result<()> {
    if block == 0 || block > 4096 {
        return Err(Error::param("block", format!("{block} is out of range (1..=4096 pixels)")).into());
    }
    if let Some(p) = error_image {
        raysplat::io::check_outputs(&[(p, raysplat::io::Format::Png)], &[test, reference])?;
    }
    let t = image::read_exr(test)?;
    let r = image::read_exr(reference)?;
    if (t.width, t.height) != (r.width, r.height) {
        return Err(Error::image(
            test.display().to_string(),
            format!("size {}x{} differs from the reference's {}x{}", t.width, t.height, r.width, r.height),
        )
        .into());
    }
    let (trgb, rrgb) = (rgb_of(&t, test, layer)?, rgb_of(&r, reference, layer)?);
    let (trgb, w, h) = image::block_average(&trgb, t.width, t.height, block);
    let (rrgb, _, _) = image::block_average(&rrgb, r.width, r.height, block);
    let m = image::compare(&trgb, &rrgb);
    if let Some(p) = error_image {
        let img = image::error_image(&trgb, &rrgb);
        image::write_png(p, w, h, &img, 0.0)?;
    }
    if json {
        println!("{}", serde_json::to_string(&m)?);
    } else {
        println!("pixels          {}", m.pixels);
        println!("rmse            {:.6}", m.rmse);
        println!("rel_mse         {:.6}", m.rel_mse);
        println!("mean_rel_error  {:.6}", m.mean_rel_error);
        println!("over_5%         {:.4}", m.over_5);
        println!("over_15%        {:.4}", m.over_15);
        println!("over_30%        {:.4}", m.over_30);
        println!("nan             {} (test), {} (reference)", m.nan, m.nan_reference);
    }
    Ok(())
}
