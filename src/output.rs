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

/// Write `img` to `path` as PNG, atomically.
pub fn write_png(img: &Image, path: &Path) -> Result<(), WriteError> {
    let rgb = to_rgb8(img);
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
        _ => PathBuf::from("."),
    };
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| "image.png".into());
    let tmp = dir.join(format!(".{name}.{}.tmp", std::process::id()));
    let io = |source| WriteError::Io {
        path: path.to_path_buf(),
        source,
    };
    let result = (|| {
        let file = std::fs::File::create(&tmp).map_err(io)?;
        let mut w = BufWriter::new(file);
        let encoder = image::codecs::png::PngEncoder::new(&mut w);
        image::ImageEncoder::write_image(
            encoder,
            rgb.as_raw(),
            img.width,
            img.height,
            image::ExtendedColorType::Rgb8,
        )
        .map_err(|source| WriteError::Encode {
            path: path.to_path_buf(),
            source,
        })?;
        w.flush().map_err(io)?;
        w.get_ref().sync_all().map_err(io)?;
        drop(w);
        std::fs::rename(&tmp, path).map_err(io)
    })();
    if result.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    result
}
