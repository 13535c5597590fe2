//! The study's log-log plot of error against time (plotters, PNG), one curve per method.

use super::study::Row;
use plotters::prelude::*;
use raysplat::Error;
use std::collections::BTreeMap;
use std::path::Path;
use std::sync::OnceLock;

/// Debian's `fonts-dejavu-core` (installed by `make setup`).
const FONT: &str = "/usr/share/fonts/truetype/dejavu/DejaVuSans.ttf";

/// Register the label font once per process (plotters keeps a `'static` reference to its bytes).
fn font() -> Result<(), Error> {
    static DONE: OnceLock<Result<(), String>> = OnceLock::new();
    DONE.get_or_init(|| {
        let bytes = std::fs::read(FONT).map_err(|e| format!("{FONT}: {e} (install fonts-dejavu-core)"))?;
        let bytes: &'static [u8] = Box::leak(bytes.into_boxed_slice());
        plotters::style::register_font("sans-serif", FontStyle::Normal, bytes).map_err(|_| format!("{FONT}: not a font"))
    })
    .clone()
    .map_err(|m| Error::image(FONT, m))
}

/// Write `path`: relative MSE against seconds, log-log, a curve per method (per method and
/// smoothness when the study varied it), and a dashed line at the reference's own error `noise`
/// when it is known (no render can show less error against the reference).
pub fn error_vs_time(path: &Path, title: &str, rows: &[Row], noise: Option<f64>) -> anyhow::Result<()> {
    font()?;
    let pts: Vec<&Row> = rows.iter().filter(|r| r.seconds > 0.0 && r.rel_mse > 0.0 && r.rel_mse.is_finite()).collect();
    if pts.is_empty() {
        return Err(Error::image(path.display().to_string(), "no finite, positive errors to plot").into());
    }
    let (tmin, tmax) = pts.iter().fold((f64::INFINITY, 0.0f64), |(a, b), r| (a.min(r.seconds), b.max(r.seconds)));
    let (mut emin, emax) = pts.iter().fold((f64::INFINITY, 0.0f64), |(a, b), r| (a.min(r.rel_mse), b.max(r.rel_mse)));
    let noise = noise.filter(|n| *n > 0.0 && n.is_finite());
    if let Some(n) = noise {
        emin = emin.min(n);
    }
    // One curve per method, or per (method, smoothness) when the study varied the smoothness.
    let smoothness = |r: &Row| r.params.get("smoothness").map(|v| v.to_string());
    let varied = |m: &str| {
        let mut cs = pts.iter().filter(|r| r.method == m).map(|r| smoothness(r));
        let first = cs.next().flatten();
        cs.any(|c| c != first)
    };
    let mut by_method: BTreeMap<String, Vec<(f64, f64)>> = BTreeMap::new();
    for r in &pts {
        let key = match smoothness(r) {
            Some(c) if varied(&r.method) => format!("{} C={c}", r.method),
            _ => r.method.clone(),
        };
        by_method.entry(key).or_default().push((r.seconds, r.rel_mse));
    }
    const SIZE: (u32, u32) = (900, 600);
    let mut pixels = vec![0u8; SIZE.0 as usize * SIZE.1 as usize * 3];
    {
        let root = BitMapBackend::with_buffer(&mut pixels, SIZE).into_drawing_area();
        root.fill(&WHITE)?;
        let mut chart = ChartBuilder::on(&root)
            .caption(format!("error vs time — {title}"), ("sans-serif", 24))
            .margin(16)
            .x_label_area_size(48)
            .y_label_area_size(72)
            .build_cartesian_2d((tmin / 1.5..tmax * 1.5).log_scale(), (emin / 1.5..emax * 1.5).log_scale())?;
        chart
            .configure_mesh()
            .x_desc("seconds")
            .y_desc("relative MSE vs reference")
            .label_style(("sans-serif", 15))
            .light_line_style(RGBColor(238, 238, 238))
            .x_label_formatter(&|v| short(*v))
            .y_label_formatter(&|v| format!("{v:.1e}"))
            .draw()?;
        let palette = [RED, BLUE, GREEN, MAGENTA, CYAN, BLACK, RGBColor(255, 140, 0), RGBColor(128, 0, 128)];
        // a denoised curve (`pt+oidn`) takes its method's colour, a thin line and open circles
        let mut colours: Vec<String> = Vec::new();
        for (m, mut p) in by_method {
            p.sort_by(|a, b| a.0.total_cmp(&b.0));
            let (base, denoised) = m.split_once(super::study::DENOISED).map_or((m.as_str(), false), |(b, _)| (b, true));
            let i = colours.iter().position(|c| c == base).unwrap_or_else(|| {
                colours.push(base.to_string());
                colours.len() - 1
            });
            let c = palette[i % palette.len()];
            let width = if denoised { 1 } else { 2 };
            chart
                .draw_series(LineSeries::new(p.clone(), c.stroke_width(width)))?
                .label(m.clone())
                .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], c.stroke_width(width)));
            let style = if denoised { c.stroke_width(2) } else { c.filled() };
            chart.draw_series(p.into_iter().map(|(x, y)| Circle::new((x, y), 4, style)))?;
        }
        if let Some(n) = noise {
            let grey = RGBColor(120, 120, 120);
            let (a, b) = (tmin / 1.5, tmax * 1.5);
            let steps = 60;
            // dashes: every other of `steps` log-spaced pieces
            let dashes = (0..steps).step_by(2).map(move |i| {
                let at = |k: i32| a * (b / a).powf(k as f64 / steps as f64);
                PathElement::new(vec![(at(i), n), (at(i + 1), n)], grey.stroke_width(1))
            });
            chart
                .draw_series(dashes)?
                .label("reference's own error")
                .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 8, y), (x + 12, y), (x + 20, y)], grey.stroke_width(1)));
        }
        chart.configure_series_labels().background_style(WHITE.mix(0.8)).border_style(BLACK).label_font(("sans-serif", 16)).draw()?;
        root.present()?;
    }
    // through the library's writer (the output rule, a temporary renamed into place)
    raysplat::io::write_atomically(path, raysplat::io::Format::Png, |tmp, file| {
        use image::ImageEncoder;
        let mut out = std::io::BufWriter::new(file);
        image::codecs::png::PngEncoder::new(&mut out)
            .write_image(&pixels, SIZE.0, SIZE.1, image::ExtendedColorType::Rgb8)
            .map_err(|e| Error::image(path.display().to_string(), format!("PNG encoding: {e}")))?;
        std::io::Write::flush(&mut out).map_err(|e| Error::io(tmp, e))
    })?;
    Ok(())
}

/// A compact tick label: 3 significant digits without trailing zeros.
fn short(v: f64) -> String {
    if v >= 100.0 {
        format!("{v:.0}")
    } else {
        let digits = (2 - v.abs().log10().floor() as i32).clamp(0, 6) as usize;
        let s = format!("{v:.digits$}");
        if s.contains('.') {
            s.trim_end_matches('0').trim_end_matches('.').to_string()
        } else {
            s
        }
    }
}
