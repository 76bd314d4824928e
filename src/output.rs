//! The output stage: an image in memory to a PNG file on disk.
//!
//! Input: a traced [`Image`]. Output: an 8-bit sRGB PNG, written to a
//! temporary file in the same folder and renamed into place, so that no
//! reader ever sees half an image.

use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

use crate::render::Image;
use crate::shade::to_srgb8;

/// Why an image or animation could not be written.
#[derive(Debug, thiserror::Error)]
pub enum WriteError {
    /// Creating, writing, syncing or renaming a file failed.
    #[error("cannot write {path}: {source}")]
    Io {
        /// The output file as the user named it (for numbered frames, that
        /// frame's file), not the temporary file written first.
        path: PathBuf,
        /// The underlying I/O error.
        #[source]
        source: std::io::Error,
    },
    /// Encoding failed: a PNG, or a GIF frame (the message says PNG for both).
    #[error("cannot encode {path} as PNG: {source}")]
    Encode {
        /// The output file as the user named it.
        path: PathBuf,
        /// The encoder's error.
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

/// Encode a PNG of `width` x `height` 8-bit sRGB pixels into `out`, asking
/// `next_row` for each row in turn (`width * 3` bytes, top row first).
/// **The one PNG encoder**: a render, a stitch of shards and each numbered
/// frame all write through it, one row per call, so the same pixels make
/// the same bytes however they arrived.
pub fn png_from_rows<W: Write>(
    out: W,
    width: u32,
    height: u32,
    mut next_row: impl FnMut(u32, &mut [u8]) -> std::io::Result<()>,
) -> std::io::Result<()> {
    let mut encoder = png::Encoder::new(out, width, height);
    encoder.set_color(png::ColorType::Rgb);
    encoder.set_depth(png::BitDepth::Eight);
    // Fast: fdeflate tuned for PNG; Balanced took 100 ms of an 800 x 500
    // render that traces in 800 ms (Fast: 14 ms), for files a third smaller.
    encoder.set_compression(png::Compression::Fast);
    let png_error = |e: png::EncodingError| std::io::Error::other(e);
    let mut writer = encoder.write_header().map_err(png_error)?;
    let mut stream = writer.stream_writer().map_err(png_error)?;
    let mut row = vec![0u8; width as usize * 3];
    for y in 0..height {
        next_row(y, &mut row)?;
        stream.write_all(&row)?;
    }
    stream.finish().map_err(png_error)?;
    writer.finish().map_err(png_error)
}

/// Row `y` of `img` as 8-bit sRGB bytes, into `out`.
pub(crate) fn srgb_row(img: &Image, y: u32, out: &mut [u8]) {
    let w = img.width as usize;
    let pixels = &img.pixels[y as usize * w..(y as usize + 1) * w];
    for (bytes, &c) in out.chunks_exact_mut(3).zip(pixels) {
        bytes.copy_from_slice(&to_srgb8(c));
    }
}

/// The image as PNG file contents.
pub fn encode_png(img: &Image) -> Vec<u8> {
    let mut bytes = Vec::new();
    png_from_rows(&mut bytes, img.width, img.height, |y, row| {
        srgb_row(img, y, row);
        Ok(())
    })
    .expect("writing to memory cannot fail");
    bytes
}

/// Write `img` to `path` as PNG, atomically and durably.
pub fn write_png(img: &Image, path: &Path) -> Result<(), WriteError> {
    write_atomically_with(path, true, |w| {
        png_from_rows(w, img.width, img.height, |y, row| {
            srgb_row(img, y, row);
            Ok(())
        })
    })
    .map_err(|source| WriteError::Io {
        path: path.to_path_buf(),
        source,
    })
}

/// Write 8-bit sRGB pixels (`width * height * 3` bytes) to `path` as
/// PNG, atomically and durably.
pub fn write_png_rgb8(rgb: &[u8], width: u32, height: u32, path: &Path) -> Result<(), WriteError> {
    let stride = width as usize * 3;
    write_atomically_with(path, true, |w| {
        png_from_rows(w, width, height, |y, row| {
            row.copy_from_slice(&rgb[y as usize * stride..(y as usize + 1) * stride]);
            Ok(())
        })
    })
    .map_err(|source| WriteError::Io {
        path: path.to_path_buf(),
        source,
    })
}

/// Write `bytes` to a temporary file beside `path` and rename it into
/// place: a reader sees the old file or the new one, never half of one.
/// With `durable`, the data reaches the disk before the rename (slower;
/// watch mode, which rewrites the file on every save, skips it).
pub fn write_atomically(bytes: &[u8], path: &Path, durable: bool) -> std::io::Result<()> {
    write_atomically_with(path, durable, |w| w.write_all(bytes))
}

/// [`write_atomically`] with the contents streamed by `write`, so that a
/// large file never needs to be held in memory.
pub fn write_atomically_with(
    path: &Path,
    durable: bool,
    write: impl FnOnce(&mut BufWriter<std::fs::File>) -> std::io::Result<()>,
) -> std::io::Result<()> {
    // A device or a pipe (`-o /dev/null`, a FIFO) is written in place:
    // renaming over it would replace the node with a file.
    if special_target(path)? {
        let mut w = BufWriter::new(std::fs::OpenOptions::new().write(true).open(path)?);
        write(&mut w)?;
        return w.flush();
    }
    // Through a symbolic link to where it points, as `cp` writes: the
    // rename would replace the link itself with a file.
    let target = link_target(path)?;
    let path = target.as_deref().unwrap_or(path);
    let tmp = temp_beside(path);
    let result = (|| {
        let file = std::fs::File::create(&tmp)?;
        let mut w = BufWriter::new(file);
        write(&mut w)?;
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
    settled(&tmp);
    result
}

/// Where `path` leads when it is a symbolic link (through every link of
/// a chain; for a dangling link, the path it names); `None` when it is
/// not a link.
fn link_target(path: &Path) -> std::io::Result<Option<std::path::PathBuf>> {
    let mut at = path.to_path_buf();
    let mut hops = 0;
    while std::fs::symlink_metadata(&at).is_ok_and(|m| m.file_type().is_symlink()) {
        hops += 1;
        if hops > 40 {
            return Err(std::io::Error::other("too many levels of symbolic links"));
        }
        let next = std::fs::read_link(&at)?;
        at = match at.parent() {
            Some(parent) if next.is_relative() => parent.join(next),
            _ => next,
        };
    }
    Ok((hops > 0).then_some(at))
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
        // Large letters where the label fits, small ones otherwise, and a
        // label too long even for those shortened with "..." (a metric's
        // formula), not cut mid-letter.
        let (scale, top) = if label.len() as u32 * 16 + 12 <= img.width {
            (2, 4)
        } else {
            (1, 8)
        };
        let fits = (img.width.saturating_sub(12) / (8 * scale)) as usize;
        let label = if label.chars().count() > fits {
            let kept: String = label.chars().take(fits.saturating_sub(3)).collect();
            format!("{}...", kept.trim_end())
        } else {
            label.clone()
        };
        draw_text(
            &mut out,
            &label,
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

/// How an animation is written, from the output path: an animated PNG
/// (`.png`), a GIF (`.gif`), or one PNG per frame when the name holds a
/// frame-number pattern (`out-%04d.png`, `%d`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum AnimationFormat {
    /// `.png` (or `.apng`) without a frame pattern: one animated PNG file.
    Apng,
    /// `.gif` without a frame pattern: one looping GIF file.
    Gif,
    /// A `.png` name with a `%d` or `%0Nd` pattern: one PNG file per frame.
    Numbered,
}

impl AnimationFormat {
    /// The format for `path`, from its extension (case-insensitive) and whether
    /// its file name holds a `%d`/`%0Nd` pattern; `None` for any other
    /// extension, for a pattern in a non-PNG name, or for a path without a file
    /// name or extension.
    pub fn of(path: &Path) -> Option<AnimationFormat> {
        let name = path.file_name()?.to_string_lossy();
        let numbered = frame_pattern(&name).is_some();
        // A `%` that is not one frame pattern (`%d%d`, `%s`) would be
        // written literally: say so instead.
        if name.contains('%') && !numbered {
            return None;
        }
        let extension = path.extension()?.to_string_lossy().to_ascii_lowercase();
        match extension.as_str() {
            // Numbered frames are PNGs: a pattern ending in .gif would
            // name PNG files as GIFs.
            "png" if numbered => Some(AnimationFormat::Numbered),
            "png" | "apng" if !numbered => Some(AnimationFormat::Apng),
            "gif" if !numbered => Some(AnimationFormat::Gif),
            _ => None,
        }
    }
}

/// `(prefix, zero-padded width, suffix)` of the first `%d` / `%0Nd` in a
/// file name.
fn frame_pattern(name: &str) -> Option<(String, usize, String)> {
    let at = name.find('%')?;
    let rest = &name[at + 1..];
    let digits: String = rest.chars().take_while(|c| c.is_ascii_digit()).collect();
    let after = &rest[digits.len()..];
    let suffix = after.strip_prefix('d')?;
    if suffix.contains('%') {
        return None;
    }
    let width = if digits.is_empty() {
        0
    } else {
        digits.parse().ok()?
    };
    Some((name[..at].to_string(), width, suffix.to_string()))
}

/// The file of frame `frame` for a numbered pattern such as `out-%04d.png`.
pub fn numbered_path(pattern: &Path, frame: u32) -> Option<PathBuf> {
    let name = pattern.file_name()?.to_string_lossy();
    let (prefix, width, suffix) = frame_pattern(&name)?;
    Some(pattern.with_file_name(format!("{prefix}{frame:0width$}{suffix}")))
}

/// Writes the frames of an animation as they are rendered, so that only
/// one frame is held in memory. An animated PNG or GIF goes to a
/// temporary file renamed into place by [`AnimationWriter::finish`];
/// dropped unfinished (an error, Ctrl-C), it leaves no partial file.
pub struct AnimationWriter {
    path: PathBuf,
    temp: Option<PathBuf>,
    sink: Sink,
}

enum Sink {
    Apng(png::Writer<BufWriter<std::fs::File>>),
    /// The encoder, the same file again (the encoder writes the GIF
    /// trailer when dropped and cannot hand its file back), and each
    /// frame's display time.
    Gif(
        Box<image::codecs::gif::GifEncoder<BufWriter<std::fs::File>>>,
        std::fs::File,
        image::Delay,
    ),
    /// The frame files written so far: removed if the writer is dropped
    /// unfinished, so a failed animation leaves no partial set.
    Numbered(Vec<PathBuf>),
}

impl AnimationWriter {
    /// `frames` frames of `width` x `height`, shown at `fps` frames per
    /// second, looping.
    pub fn create(
        path: &Path,
        format: AnimationFormat,
        frames: u32,
        fps: f64,
        width: u32,
        height: u32,
    ) -> Result<AnimationWriter, WriteError> {
        let io = |source: std::io::Error| WriteError::Io {
            path: path.to_path_buf(),
            source,
        };
        if format == AnimationFormat::Numbered {
            return Ok(AnimationWriter {
                path: path.to_path_buf(),
                temp: None,
                sink: Sink::Numbered(Vec::new()),
            });
        }
        // A device or a pipe is written in place, never replaced.
        let temp = (!special_target(path).map_err(io)?).then(|| temp_beside(path));
        let file = BufWriter::new(match &temp {
            Some(t) => std::fs::File::create(t).map_err(io)?,
            None => std::fs::OpenOptions::new()
                .write(true)
                .open(path)
                .map_err(io)?,
        });
        let (num, den) = frame_delay(fps);
        // Made before the encoder, so that a failure below drops it and
        // removes the temporary file.
        let mut writer = AnimationWriter {
            path: path.to_path_buf(),
            temp,
            sink: Sink::Numbered(Vec::new()),
        };
        writer.sink = match format {
            AnimationFormat::Apng => {
                let mut encoder = png::Encoder::new(file, width, height);
                encoder.set_color(png::ColorType::Rgb);
                encoder.set_depth(png::BitDepth::Eight);
                let png_error = |e: png::EncodingError| io(std::io::Error::other(e));
                encoder.set_animated(frames, 0).map_err(png_error)?;
                encoder.set_frame_delay(num, den).map_err(png_error)?;
                Sink::Apng(encoder.write_header().map_err(png_error)?)
            }
            AnimationFormat::Gif => {
                let same = file.get_ref().try_clone().map_err(io)?;
                let mut encoder = image::codecs::gif::GifEncoder::new_with_speed(file, 10);
                encoder
                    .set_repeat(image::codecs::gif::Repeat::Infinite)
                    .map_err(|source| WriteError::Encode {
                        path: path.to_path_buf(),
                        source,
                    })?;
                let delay = image::Delay::from_numer_denom_ms(1000 * num as u32, den as u32);
                Sink::Gif(Box::new(encoder), same, delay)
            }
            AnimationFormat::Numbered => unreachable!("handled above"),
        };
        Ok(writer)
    }

    /// Add frame number `frame` (used in numbered file names).
    pub fn push(&mut self, frame: u32, img: &Image) -> Result<(), WriteError> {
        let rgb = to_rgb8(img);
        self.push_rgb8(frame, rgb.as_raw(), img.width, img.height)
    }

    /// Add frame number `frame` as 8-bit sRGB pixels (`width * height * 3`
    /// bytes, the size the writer was made for): what a stitch of shards
    /// holds, written exactly as [`AnimationWriter::push`] writes a render.
    pub fn push_rgb8(
        &mut self,
        frame: u32,
        rgb: &[u8],
        width: u32,
        height: u32,
    ) -> Result<(), WriteError> {
        let path = self.path.clone();
        let io = |source: std::io::Error| WriteError::Io {
            path: path.clone(),
            source,
        };
        match &mut self.sink {
            Sink::Numbered(written) => {
                let file = numbered_path(&self.path, frame).expect("a numbered pattern");
                write_png_rgb8(rgb, width, height, &file)?;
                written.push(file);
                Ok(())
            }
            Sink::Apng(w) => w
                .write_image_data(rgb)
                .map_err(|e| io(std::io::Error::other(e))),
            Sink::Gif(encoder, _, delay) => {
                let image = image::RgbImage::from_raw(width, height, rgb.to_vec())
                    .expect("a frame of the writer's size");
                let rgba = image::DynamicImage::ImageRgb8(image).into_rgba8();
                encoder
                    .encode_frame(image::Frame::from_parts(rgba, 0, 0, *delay))
                    .map_err(|source| WriteError::Encode {
                        path: path.clone(),
                        source,
                    })
            }
        }
    }

    /// Complete the file and move it into place.
    pub fn finish(mut self) -> Result<(), WriteError> {
        let path = self.path.clone();
        let io = |source: std::io::Error| WriteError::Io {
            path: path.clone(),
            source,
        };
        let sink = std::mem::replace(&mut self.sink, Sink::Numbered(Vec::new()));
        match sink {
            Sink::Numbered(_) => return Ok(()),
            Sink::Apng(w) => w.finish().map_err(|e| io(std::io::Error::other(e)))?,
            Sink::Gif(encoder, file, _) => {
                drop(encoder);
                if self.temp.is_some() {
                    file.sync_all().map_err(io)?;
                }
            }
        }
        match self.temp.take() {
            Some(temp) => {
                let moved = std::fs::rename(&temp, &self.path);
                if moved.is_err() {
                    let _ = std::fs::remove_file(&temp);
                }
                settled(&temp);
                moved.map_err(io)
            }
            None => Ok(()),
        }
    }
}

impl Drop for AnimationWriter {
    fn drop(&mut self) {
        if let Sink::Numbered(written) = &self.sink {
            for file in written {
                let _ = std::fs::remove_file(file);
            }
        }
        if let Some(temp) = &self.temp {
            let _ = std::fs::remove_file(temp);
            settled(temp);
        }
    }
}

/// Whether `path` exists and is neither a regular file nor a folder (a
/// device, a pipe, a socket): such a target is written in place, never
/// replaced. A folder is an error.
pub(crate) fn special_target(path: &Path) -> std::io::Result<bool> {
    match std::fs::metadata(path) {
        Ok(m) if m.is_dir() => Err(std::io::Error::other("it is a folder, not a file")),
        Ok(m) => Ok(!m.is_file()),
        Err(_) => Ok(false),
    }
}

/// Whether `a` and `b` name the same existing file, however spelled (by
/// device and inode where the system has them, so hard links count too).
pub fn same_file(a: &Path, b: &Path) -> bool {
    match (std::fs::metadata(a), std::fs::metadata(b)) {
        #[cfg(unix)]
        (Ok(x), Ok(y)) => {
            use std::os::unix::fs::MetadataExt;
            x.dev() == y.dev() && x.ino() == y.ino()
        }
        #[cfg(not(unix))]
        (Ok(_), Ok(_)) => match (a.canonicalize(), b.canonicalize()) {
            (Ok(x), Ok(y)) => x == y,
            _ => false,
        },
        _ => false,
    }
}

/// The temporary files this process is writing: removed by
/// [`remove_temporaries`] when a signal ends it.
static TEMPORARIES: std::sync::Mutex<Vec<PathBuf>> = std::sync::Mutex::new(Vec::new());

/// A temporary file beside `path`, for writing it atomically; registered
/// until [`settled`], so that an interrupted process leaves none behind.
pub(crate) fn temp_beside(path: &Path) -> PathBuf {
    register_temporary(temp_name_beside(path))
}

/// Records `temp` as a temporary file being written (see [`temp_beside`]).
pub(crate) fn register_temporary(temp: PathBuf) -> PathBuf {
    let mut live = TEMPORARIES.lock().unwrap_or_else(|e| e.into_inner());
    live.push(temp.clone());
    temp
}

/// `temp` was renamed into place or removed: no longer ours to clean up.
pub(crate) fn settled(temp: &Path) {
    let mut live = TEMPORARIES.lock().unwrap_or_else(|e| e.into_inner());
    if let Some(i) = live.iter().position(|p| p == temp) {
        live.swap_remove(i);
    }
}

/// Removes every temporary file still being written, for a process about
/// to exit on a signal. The registry stays locked afterwards, so that no
/// new temporary file is started.
pub fn remove_temporaries() {
    let live = TEMPORARIES.lock().unwrap_or_else(|e| e.into_inner());
    for temp in live.iter() {
        let _ = std::fs::remove_file(temp);
    }
    std::mem::forget(live);
}

/// The name of a temporary file beside `path`.
pub(crate) fn temp_name_beside(path: &Path) -> PathBuf {
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
        _ => PathBuf::from("."),
    };
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| "output".into());
    dir.join(format!(".{name}.{}.tmp", std::process::id()))
}

/// A frame's display time as a fraction of a second (PNG's form, also
/// used for GIF frames): exactly 1/fps
/// for whole rates, otherwise to the millisecond.
fn frame_delay(fps: f64) -> (u16, u16) {
    if fps.fract() == 0.0 && (1.0..=65535.0).contains(&fps) {
        (1, fps as u16)
    } else {
        ((1000.0 / fps).round().clamp(1.0, 65535.0) as u16, 1000)
    }
}
