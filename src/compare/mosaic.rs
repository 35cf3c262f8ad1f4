//! `mosaic.png`: the reference and every render side by side, each with its name and key
//! numbers drawn underneath (text by plotters, fonts from the system's fontconfig).

use super::Report;
use crate::output;
use anyhow::{anyhow, Context, Result};
use image::RgbImage;
use plotters::prelude::*;
use std::path::Path;

/// Height of the caption band under each image, in pixels.
const CAPTION: u32 = 64;
/// Images per row.
const PER_ROW: usize = 4;

pub fn write(dir: &Path, report: &Report) -> Result<()> {
    let load = |name: &str| -> Result<RgbImage> {
        let p = dir.join(format!("{name}.png"));
        Ok(image::open(&p)
            .with_context(|| format!("{}: cannot read", p.display()))?
            .to_rgb8())
    };
    let mut tiles: Vec<(RgbImage, [String; 3])> = vec![(
        load("reference")?,
        [
            "reference".to_string(),
            shorten(&report.reference, 24),
            String::new(),
        ],
    )];
    for r in &report.rows {
        tiles.push((
            load(&r.label)?,
            [
                r.label.clone(),
                format!("{} spp, {:.2} s", r.spp, r.time),
                format!("MSE {:.2e}  FLIP {:.3}", r.mse, r.flip),
            ],
        ));
    }
    // Small images are enlarged (nearest neighbour) so that captions fit under them.
    let scale = 200u32.div_ceil(report.width).max(1);
    let (w, h) = (report.width * scale, report.height * scale);
    let cols = tiles.len().min(PER_ROW) as u32;
    let rows = tiles.len().div_ceil(PER_ROW) as u32;
    let (mw, mh) = (cols * w, rows * (h + CAPTION));
    let mut buffer = vec![255u8; (mw * mh * 3) as usize];
    for (i, (img, _)) in tiles.iter().enumerate() {
        let (x0, y0) = (
            (i % PER_ROW) as u32 * w,
            (i / PER_ROW) as u32 * (h + CAPTION),
        );
        for y in 0..h {
            for x in 0..w {
                let p = img.get_pixel(x / scale, y / scale);
                let idx = (((y0 + y) * mw + x0 + x) * 3) as usize;
                buffer[idx..idx + 3].copy_from_slice(&p.0);
            }
        }
    }
    {
        let root = BitMapBackend::with_buffer(&mut buffer, (mw, mh)).into_drawing_area();
        let size = (w / 18).clamp(9, 15);
        for (i, (_, caption)) in tiles.iter().enumerate() {
            let (x0, y0) = (
                (i % PER_ROW) as i32 * w as i32,
                (i / PER_ROW) as i32 * (h + CAPTION) as i32 + h as i32,
            );
            let bold = ("sans-serif", size + 3)
                .into_font()
                .style(FontStyle::Bold)
                .color(&BLACK);
            let plain = ("sans-serif", size).into_font().color(&BLACK);
            root.draw(&Text::new(caption[0].clone(), (x0 + 6, y0 + 5), bold))
                .map_err(|e| anyhow!("mosaic: {e}"))?;
            for (line, text) in caption[1..].iter().enumerate() {
                let y = y0 + 8 + (size as i32 + 6) * (line as i32 + 1);
                root.draw(&Text::new(text.clone(), (x0 + 6, y), plain.clone()))
                    .map_err(|e| anyhow!("mosaic: {e}"))?;
            }
        }
        root.present().map_err(|e| anyhow!("mosaic: {e}"))?;
    }
    let img = RgbImage::from_raw(mw, mh, buffer).expect("buffer matches the mosaic size");
    output::write_png(&dir.join("mosaic.png"), &img)
}

fn shorten(s: &str, n: usize) -> String {
    if s.chars().count() <= n {
        s.to_string()
    } else {
        format!("{}...", s.chars().take(n).collect::<String>())
    }
}
