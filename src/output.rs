//! The output stage: an image in memory to a PNG file on disk.
//!
//! Input: a traced [`Image`]. Output: an 8-bit sRGB PNG, written to a
//! temporary file in the same folder and renamed into place, so that no
//! reader ever sees half an image.

use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

use crate::shade::to_srgb8;
use crate::trace::Image;

#[derive(Debug, thiserror::Error)]
pub enum WriteError {
    #[error("cannot write {path}: {source}")]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error("cannot encode {path} as PNG: {source}")]
    Encode {
        path: PathBuf,
        #[source]
        source: image::ImageError,
    },
}

/// The image as 8-bit sRGB bytes, row by row.
pub fn to_rgb8(img: &Image) -> image::RgbImage {
    use rayon::prelude::*;
    let mut bytes = vec![0u8; img.pixels.len() * 3];
    bytes
        .par_chunks_mut(3)
        .zip(img.pixels.par_iter())
        .for_each(|(out, &c)| out.copy_from_slice(&to_srgb8(c)));
    image::RgbImage::from_raw(img.width, img.height, bytes).expect("buffer size matches")
}

/// The image as PNG file contents.
pub fn encode_png(img: &Image) -> Result<Vec<u8>, image::ImageError> {
    let rgb = to_rgb8(img);
    let mut bytes = Vec::new();
    let encoder = image::codecs::png::PngEncoder::new(&mut bytes);
    image::ImageEncoder::write_image(
        encoder,
        rgb.as_raw(),
        img.width,
        img.height,
        image::ExtendedColorType::Rgb8,
    )?;
    Ok(bytes)
}

/// Write `img` to `path` as PNG, atomically and durably.
pub fn write_png(img: &Image, path: &Path) -> Result<(), WriteError> {
    let bytes = encode_png(img).map_err(|source| WriteError::Encode {
        path: path.to_path_buf(),
        source,
    })?;
    write_atomically(&bytes, path, true).map_err(|source| WriteError::Io {
        path: path.to_path_buf(),
        source,
    })
}

/// Write `bytes` to a temporary file beside `path` and rename it into
/// place: a reader sees the old file or the new one, never half of one.
/// With `durable`, the data reaches the disk before the rename (slower;
/// watch mode, which rewrites the file on every save, skips it).
pub fn write_atomically(bytes: &[u8], path: &Path, durable: bool) -> std::io::Result<()> {
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
        _ => PathBuf::from("."),
    };
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| "image.png".into());
    let tmp = dir.join(format!(".{name}.{}.tmp", std::process::id()));
    let result = (|| {
        let file = std::fs::File::create(&tmp)?;
        let mut w = BufWriter::new(file);
        w.write_all(bytes)?;
        w.flush()?;
        if durable {
            w.get_ref().sync_all()?;
        }
        drop(w);
        std::fs::rename(&tmp, path)
    })();
    if result.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    result
}

/// `img` scaled to `width` x `height`, nearest pixel: a
/// preview shown at the final image's size.
pub fn upscale(img: &Image, width: u32, height: u32) -> Image {
    let mut pixels = Vec::with_capacity((width * height) as usize);
    for y in 0..height {
        let sy = (y as u64 * img.height as u64 / height as u64) as u32;
        for x in 0..width {
            let sx = (x as u64 * img.width as u64 / width as u64) as u32;
            pixels.push(img.pixels[(sy * img.width + sx) as usize]);
        }
    }
    Image {
        width,
        height,
        pixels,
    }
}

/// Height of the label bar above each panel of a comparison, in pixels.
const LABEL_BAR: u32 = 24;

/// Several images side by side, each under a label bar naming it (the
/// report's figures 16-18). Panels of different heights are padded at the
/// bottom with black.
pub fn side_by_side(panels: &[(String, Image)]) -> Image {
    let gap = 4;
    let width = panels.iter().map(|(_, i)| i.width).sum::<u32>()
        + gap * panels.len().saturating_sub(1) as u32;
    let height = panels.iter().map(|(_, i)| i.height).max().unwrap_or(0) + LABEL_BAR;
    let mut out = Image {
        width,
        height,
        pixels: vec![glam::DVec3::ZERO; (width * height) as usize],
    };
    let bar = glam::DVec3::splat(0.03);
    let mut x0 = 0;
    for (label, img) in panels {
        for y in 0..LABEL_BAR {
            for x in 0..img.width {
                out.pixels[(y * width + x0 + x) as usize] = bar;
            }
        }
        // Large letters where the label fits, small ones otherwise.
        let (scale, top) = if label.len() as u32 * 16 + 12 <= img.width {
            (2, 4)
        } else {
            (1, 8)
        };
        draw_text(
            &mut out,
            label,
            x0 + 6,
            top,
            scale,
            img.width.saturating_sub(6),
        );
        for y in 0..img.height {
            for x in 0..img.width {
                out.pixels[((y + LABEL_BAR) * width + x0 + x) as usize] = img.pixel(x, y);
            }
        }
        x0 += img.width + gap;
    }
    out
}

/// White ASCII text from an 8x8 bitmap font, scaled, clipped to `max_width`.
fn draw_text(img: &mut Image, text: &str, x: u32, y: u32, scale: u32, max_width: u32) {
    let advance = 8 * scale;
    for (i, ch) in text.chars().enumerate() {
        let gx = i as u32 * advance;
        if gx + advance > max_width {
            break;
        }
        let glyph = font8x8::legacy::BASIC_LEGACY[(ch as usize).min(127)];
        for (row, bits) in glyph.iter().enumerate() {
            for col in 0..8 {
                if bits & (1 << col) == 0 {
                    continue;
                }
                for dy in 0..scale {
                    for dx in 0..scale {
                        let px = x + gx + col * scale + dx;
                        let py = y + row as u32 * scale + dy;
                        if px < img.width && py < img.height {
                            img.pixels[(py * img.width + px) as usize] = glam::DVec3::ONE;
                        }
                    }
                }
            }
        }
    }
}
