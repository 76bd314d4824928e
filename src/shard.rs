//! Shards: one part of a render as a file of its own, and the stitch that
//! puts the parts back together.
//!
//! Input: a still's band of rows, or an animation's run of frames, as
//! 8-bit sRGB pixels, with a [`Header`] saying which render and which part
//! they are. Output: a shard file, written atomically; and from a set of
//! shard files, checked to belong together, the PNG, animated PNG, GIF or
//! numbered frames a single render would have written, byte for byte
//! (they go through the same encoders, row by row), streamed so that
//! memory holds one band or one frame, never the whole image.
//!
//! **A shard is a pure function of (scene, settings, shard index)**: the
//! cut points come from a deterministic cost estimate, and the file holds
//! no time, host or path but the scene's name, so the same shard is the
//! same bytes wherever it is rendered with the same binary.
//!
//! The file: a text header (`nes shard 1`, then `key value` lines, then an
//! empty line), then each image as `png LENGTH` and that many bytes of
//! PNG, then `end`. A file without its `end`, or whose lengths do not add
//! up, is incomplete.

use std::fs::File;
use std::io::{BufRead, BufReader, BufWriter, Read, Seek, SeekFrom, Write};
use std::ops::Range;
use std::path::{Path, PathBuf};

use sha2::{Digest, Sha256};

use crate::output::{self, AnimationFormat, AnimationWriter, WriteError};
use crate::render::Image;

const MAGIC: &str = "nes shard 1";

/// Which part of how many: shard `index` (from 0) of `count`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ShardIndex {
    /// From 0 to `count - 1`, as Slurm's and Kubernetes' array indices.
    pub index: u32,
    /// How many shards the render is cut into.
    pub count: u32,
}

impl ShardIndex {
    /// `K/N`, with `0 <= K < N` and `1 <= N <= 100000`.
    pub fn parse(text: &str) -> Result<ShardIndex, String> {
        let (k, n) = text
            .split_once('/')
            .ok_or_else(|| format!("`{text}` is not K/N"))?;
        let k: u32 = k
            .trim()
            .parse()
            .map_err(|_| format!("`{}` is not a shard index", k.trim()))?;
        let n: u32 = n
            .trim()
            .parse()
            .map_err(|_| format!("`{}` is not a shard count", n.trim()))?;
        if n == 0 || n > 100_000 {
            return Err(format!("the shard count must be from 1 to 100000, got {n}"));
        }
        if k >= n {
            return Err(format!(
                "shard {k} of {n} does not exist: indices run from 0 to {}",
                n - 1
            ));
        }
        Ok(ShardIndex { index: k, count: n })
    }
}

/// What a shard holds a part of.
#[derive(Debug, Clone, PartialEq)]
pub enum Whole {
    /// A still image; the part is a range of rows.
    Still,
    /// An animation of the frames `frames`, shown at `fps`; the part is a
    /// range of frames.
    Animation {
        /// Every frame of the animation.
        frames: Range<u32>,
        /// Frames per second.
        fps: f64,
    },
}

/// Which render a shard belongs to and which part of it it holds.
#[derive(Debug, Clone, PartialEq)]
pub struct Header {
    /// [`scene_hash`] of the scene's source.
    pub scene: String,
    /// The scene file's name, for messages.
    pub source: String,
    /// Every setting that shapes the pixels, as text: shards of one render
    /// have the same.
    pub settings: String,
    /// Which shard of how many.
    pub shard: ShardIndex,
    /// A still or an animation.
    pub whole: Whole,
    /// The image's (or each frame's) width in pixels.
    pub width: u32,
    /// The image's (or each frame's) height in pixels.
    pub height: u32,
    /// The rows (still) or frames (animation) this shard holds.
    pub part: Range<u32>,
}

impl Header {
    /// How many images the shard holds: one band, or one per frame.
    fn image_count(&self) -> u32 {
        match self.whole {
            Whole::Still => 1,
            Whole::Animation { .. } => self.part.end - self.part.start,
        }
    }

    fn to_text(&self) -> String {
        let range = |r: &Range<u32>| format!("{}..{}", r.start, r.end);
        let mut text = format!(
            "{MAGIC}\nscene {}\nsource {}\nsettings {}\nshard {} of {}\nsize {}x{}\n",
            self.scene,
            self.source.replace('\n', " "),
            self.settings,
            self.shard.index,
            self.shard.count,
            self.width,
            self.height
        );
        match &self.whole {
            Whole::Still => text += &format!("kind still\nrows {}\n", range(&self.part)),
            Whole::Animation { frames, fps } => {
                text += &format!(
                    "kind animation\nall {}\nfps {fps}\nframes {}\n",
                    range(frames),
                    range(&self.part)
                )
            }
        }
        text + "\n"
    }

    /// Whether `other` is a shard of the same render (any part of it).
    fn same_render(&self, other: &Header) -> Option<&'static str> {
        if self.scene != other.scene {
            Some("scene")
        } else if self.settings != other.settings {
            Some("settings")
        } else if self.whole != other.whole {
            Some("kind of output")
        } else if (self.width, self.height) != (other.width, other.height) {
            Some("image size")
        } else if self.shard.count != other.shard.count {
            Some("shard count")
        } else {
            None
        }
    }
}

/// The hash that names a scene: SHA-256 of its source text, in hex.
pub fn scene_hash(source: &str) -> String {
    Sha256::digest(source.as_bytes())
        .iter()
        .map(|b| format!("{b:02x}"))
        .collect()
}

/// Cut `0..costs.len()` into `count` runs of about equal total cost, none
/// empty: run `k` starts at the first item where the cost so far reaches
/// `k / count` of the whole. `None` when there are fewer items than runs.
pub fn balanced_runs(costs: &[u64], count: u32) -> Option<Vec<Range<u32>>> {
    let n = costs.len();
    let count = count as usize;
    if count == 0 || count > n {
        return None;
    }
    let total: u128 = costs.iter().map(|&c| c as u128).sum();
    let mut starts = vec![0usize];
    let mut so_far: u128 = 0;
    let mut item = 0;
    for k in 1..count {
        let target = total * k as u128 / count as u128;
        while item < n && so_far + (costs[item] as u128) <= target {
            so_far += costs[item] as u128;
            item += 1;
        }
        // Never empty: at least one item after the previous start, and
        // enough left for the runs still to come.
        let start = item.max(starts[k - 1] + 1).min(n - (count - k));
        while item < start {
            so_far += costs[item] as u128;
            item += 1;
        }
        starts.push(start);
    }
    starts.push(n);
    Some(
        starts
            .windows(2)
            .map(|w| w[0] as u32..w[1] as u32)
            .collect(),
    )
}

/// Everything that can go wrong with shard files.
#[derive(Debug, thiserror::Error, miette::Diagnostic)]
pub enum ShardError {
    /// A file could not be read or written.
    #[error("cannot {action} {path}: {source}")]
    #[diagnostic(code(E0601), help("check the path and the folder's permissions"))]
    Io {
        /// What was being done: read, write.
        action: &'static str,
        /// The file.
        path: PathBuf,
        /// Why.
        #[source]
        source: std::io::Error,
    },
    /// A file is not a complete shard.
    #[error("{path} is not a complete nes shard: {why}")]
    #[diagnostic(
        code(E0602),
        help("render that shard again (`nes render SCENE --shard K/N --resume -o FILE` redoes only incomplete ones)")
    )]
    NotAShard {
        /// The file.
        path: PathBuf,
        /// What is wrong with it.
        why: String,
    },
    /// Two shards belong to different renders.
    #[error("{path} belongs to another render than {first}: its {what} differs")]
    #[diagnostic(
        code(E0603),
        help("stitch the shards of one render: the same scene file, the same options and the same shard count")
    )]
    Mismatch {
        /// The shard that differs.
        path: PathBuf,
        /// The first shard, the one it is compared with.
        first: PathBuf,
        /// What differs.
        what: &'static str,
    },
    /// Shards are missing or given twice.
    #[error("{problem}")]
    #[diagnostic(code(E0604), help("{hint}"))]
    Incomplete {
        /// Which indices are missing or doubled.
        problem: String,
        /// What to do.
        hint: String,
    },
    /// The output could not be written.
    #[error(transparent)]
    #[diagnostic(code(E0402), help("check that the folder exists and is writable"))]
    Write(#[from] WriteError),
}

/// Writes one shard: the header at once, then each image as it is made,
/// into a temporary file renamed into place by [`ShardWriter::finish`];
/// dropped unfinished, it leaves no file.
pub struct ShardWriter {
    path: PathBuf,
    temp: Option<PathBuf>,
    file: BufWriter<File>,
    left: u32,
}

impl ShardWriter {
    /// Start the shard `header` at `path`.
    pub fn create(path: &Path, header: &Header) -> Result<ShardWriter, ShardError> {
        let io = |source| ShardError::Io {
            action: "write",
            path: path.to_path_buf(),
            source,
        };
        // A device or a pipe is written in place, never replaced.
        let temp = (!output::special_target(path).map_err(io)?).then(|| output::temp_beside(path));
        let file = match &temp {
            Some(t) => File::create(t),
            None => std::fs::OpenOptions::new().write(true).open(path),
        }
        .map_err(io)?;
        let mut writer = ShardWriter {
            path: path.to_path_buf(),
            temp,
            file: BufWriter::new(file),
            left: header.image_count(),
        };
        writer
            .file
            .write_all(header.to_text().as_bytes())
            .map_err(io)?;
        Ok(writer)
    }

    fn io(&self, source: std::io::Error) -> ShardError {
        ShardError::Io {
            action: "write",
            path: self.path.clone(),
            source,
        }
    }

    /// Add the next image: `width * height * 3` bytes of 8-bit sRGB.
    pub fn push(&mut self, rgb: &[u8], width: u32, height: u32) -> Result<(), ShardError> {
        let stride = width as usize * 3;
        self.push_rows(width, height, |y, row| {
            row.copy_from_slice(&rgb[y as usize * stride..(y as usize + 1) * stride]);
        })
    }

    /// Add the next image from a render's linear colours.
    pub fn push_image(&mut self, image: &Image) -> Result<(), ShardError> {
        self.push_rows(image.width, image.height, |y, row| {
            output::srgb_row(image, y, row)
        })
    }

    fn push_rows(
        &mut self,
        width: u32,
        height: u32,
        mut fill: impl FnMut(u32, &mut [u8]),
    ) -> Result<(), ShardError> {
        assert!(self.left > 0, "more images than the header says");
        let mut png = Vec::new();
        output::png_from_rows(&mut png, width, height, |y, row| {
            fill(y, row);
            Ok(())
        })
        .map_err(|e| self.io(e))?;
        let result =
            writeln!(self.file, "png {}", png.len()).and_then(|_| self.file.write_all(&png));
        result.map_err(|e| self.io(e))?;
        self.left -= 1;
        Ok(())
    }

    /// Complete the shard and move it into place.
    pub fn finish(mut self) -> Result<(), ShardError> {
        assert_eq!(self.left, 0, "fewer images than the header says");
        let result = (|| {
            self.file.write_all(b"end\n")?;
            self.file.flush()?;
            match &self.temp {
                Some(temp) => {
                    self.file.get_ref().sync_all()?;
                    std::fs::rename(temp, &self.path)
                }
                None => Ok(()),
            }
        })();
        result.map_err(|e| self.io(e))?;
        if let Some(temp) = self.temp.take() {
            output::settled(&temp);
        }
        Ok(())
    }
}

impl Drop for ShardWriter {
    fn drop(&mut self) {
        if let Some(temp) = &self.temp {
            let _ = std::fs::remove_file(temp);
            output::settled(temp);
        }
    }
}

/// A complete shard file: its header and where each image's PNG lies.
#[derive(Debug, Clone)]
pub struct ShardFile {
    /// Where the file is.
    pub path: PathBuf,
    /// Which render and which part.
    pub header: Header,
    /// Each image's PNG: byte offset and length in the file.
    images: Vec<(u64, u64)>,
}

/// Reads `key value` from a header line.
fn field<'a>(lines: &'a [String], key: &str) -> Result<&'a str, String> {
    lines
        .iter()
        .find_map(|l| l.strip_prefix(key).and_then(|r| r.strip_prefix(' ')))
        .ok_or_else(|| format!("its header has no `{key}`"))
}

fn range_of(text: &str) -> Result<Range<u32>, String> {
    let (a, b) = text
        .split_once("..")
        .ok_or_else(|| format!("`{text}` is not a range"))?;
    let a = a.parse().map_err(|_| format!("`{text}` is not a range"))?;
    let b = b.parse().map_err(|_| format!("`{text}` is not a range"))?;
    if a >= b {
        return Err(format!("`{text}` is an empty range"));
    }
    Ok(a..b)
}

fn parse_header(lines: &[String]) -> Result<Header, String> {
    let shard = field(lines, "shard")?;
    let (k, n) = shard
        .split_once(" of ")
        .ok_or_else(|| format!("`shard {shard}` is not `K of N`"))?;
    let shard = ShardIndex::parse(&format!("{k}/{n}"))?;
    let size = field(lines, "size")?;
    let (w, h) = size
        .split_once('x')
        .ok_or_else(|| format!("`size {size}` is not WxH"))?;
    let (width, height) = match (w.parse(), h.parse()) {
        (Ok(w), Ok(h)) if w > 0 && h > 0 => (w, h),
        _ => return Err(format!("`size {size}` is not WxH")),
    };
    let (whole, part) = match field(lines, "kind")? {
        "still" => (Whole::Still, range_of(field(lines, "rows")?)?),
        "animation" => {
            let fps: f64 = field(lines, "fps")?
                .parse()
                .map_err(|_| "its `fps` is not a number".to_string())?;
            let frames = range_of(field(lines, "all")?)?;
            let part = range_of(field(lines, "frames")?)?;
            if part.start < frames.start || part.end > frames.end {
                return Err("its frames lie outside the animation".into());
            }
            (Whole::Animation { frames, fps }, part)
        }
        other => return Err(format!("`kind {other}` is neither still nor animation")),
    };
    if whole == Whole::Still && part.end > height {
        return Err("its rows lie outside the image".into());
    }
    Ok(Header {
        scene: field(lines, "scene")?.to_string(),
        source: field(lines, "source")?.to_string(),
        settings: field(lines, "settings")?.to_string(),
        shard,
        whole,
        width,
        height,
        part,
    })
}

impl ShardFile {
    /// Read and check `path`: a header, every image's length within the
    /// file, and the closing `end`.
    pub fn open(path: &Path) -> Result<ShardFile, ShardError> {
        let not_a_shard = |why: String| ShardError::NotAShard {
            path: path.to_path_buf(),
            why,
        };
        let io = |source| ShardError::Io {
            action: "read",
            path: path.to_path_buf(),
            source,
        };
        let file = File::open(path).map_err(io)?;
        let size = file.metadata().map_err(io)?.len();
        let mut reader = BufReader::new(file);
        // Lines are short; a file that is not a shard must not make us
        // read it whole looking for one.
        let read_line = |reader: &mut BufReader<File>| -> Result<String, ShardError> {
            let mut line = Vec::new();
            reader
                .by_ref()
                .take(4096)
                .read_until(b'\n', &mut line)
                .map_err(io)?;
            if line.last() != Some(&b'\n') {
                return Err(not_a_shard("it ends inside a line".into()));
            }
            line.pop();
            String::from_utf8(line).map_err(|_| not_a_shard("its header is not text".into()))
        };
        if read_line(&mut reader)? != MAGIC {
            return Err(not_a_shard(format!("it does not start with `{MAGIC}`")));
        }
        let mut lines = Vec::new();
        loop {
            let line = read_line(&mut reader)?;
            if line.is_empty() {
                break;
            }
            if lines.len() > 64 {
                return Err(not_a_shard("its header does not end".into()));
            }
            lines.push(line);
        }
        let header = parse_header(&lines).map_err(not_a_shard)?;
        let mut images = Vec::new();
        for _ in 0..header.image_count() {
            let line = read_line(&mut reader)?;
            let length: u64 = line
                .strip_prefix("png ")
                .and_then(|n| n.parse().ok())
                .ok_or_else(|| not_a_shard(format!("`{line}` is not an image's length")))?;
            let offset = reader.stream_position().map_err(io)?;
            if offset.checked_add(length).is_none_or(|end| end > size) {
                return Err(not_a_shard("it is cut short".into()));
            }
            images.push((offset, length));
            reader.seek(SeekFrom::Start(offset + length)).map_err(io)?;
        }
        if read_line(&mut reader)? != "end" {
            return Err(not_a_shard("it has no `end`".into()));
        }
        Ok(ShardFile {
            path: path.to_path_buf(),
            header,
            images,
        })
    }

    /// A PNG reader for image `i`, reading from the file as rows are asked
    /// for.
    fn image(&self, i: usize) -> Result<png::Reader<BufReader<std::io::Take<File>>>, ShardError> {
        let io = |source| ShardError::Io {
            action: "read",
            path: self.path.clone(),
            source,
        };
        let (offset, length) = self.images[i];
        let mut file = File::open(&self.path).map_err(io)?;
        file.seek(SeekFrom::Start(offset)).map_err(io)?;
        let mut decoder = png::Decoder::new(BufReader::new(file.take(length)));
        decoder.set_transformations(png::Transformations::IDENTITY);
        let reader = decoder.read_info().map_err(|e| self.broken(e))?;
        let info = reader.info();
        let (w, h) = (info.width, info.height);
        let rows = match self.header.whole {
            Whole::Still => self.header.part.end - self.header.part.start,
            Whole::Animation { .. } => self.header.height,
        };
        if (w, h) != (self.header.width, rows)
            || info.color_type != png::ColorType::Rgb
            || info.bit_depth != png::BitDepth::Eight
        {
            return Err(ShardError::NotAShard {
                path: self.path.clone(),
                why: format!("image {i} is not {}x{rows} 8-bit RGB", self.header.width),
            });
        }
        Ok(reader)
    }

    fn broken(&self, e: png::DecodingError) -> ShardError {
        ShardError::NotAShard {
            path: self.path.clone(),
            why: format!("an image in it cannot be decoded: {e}"),
        }
    }
}

/// Whether `path` already holds the complete shard `header` (`--resume`).
pub fn is_done(path: &Path, header: &Header) -> bool {
    ShardFile::open(path).is_ok_and(|f| f.header == *header)
}

/// Check that `shards` are every part of one render, each once, and put
/// them in order.
pub fn check_set(mut shards: Vec<ShardFile>) -> Result<Vec<ShardFile>, ShardError> {
    let Some(first) = shards.first().cloned() else {
        return Err(ShardError::Incomplete {
            problem: "no shard files were given".into(),
            hint: "name every shard file of the render, e.g. parts/*.shard".into(),
        });
    };
    for s in &shards[1..] {
        if let Some(what) = first.header.same_render(&s.header) {
            return Err(ShardError::Mismatch {
                path: s.path.clone(),
                first: first.path.clone(),
                what,
            });
        }
    }
    let count = first.header.shard.count;
    shards.sort_by_key(|s| s.header.shard.index);
    for pair in shards.windows(2) {
        if pair[0].header.shard.index == pair[1].header.shard.index {
            return Err(ShardError::Incomplete {
                problem: format!(
                    "shard {} of {count} is given twice: {} and {}",
                    pair[0].header.shard.index,
                    pair[0].path.display(),
                    pair[1].path.display()
                ),
                hint: "name each shard file once".into(),
            });
        }
    }
    let have: Vec<u32> = shards.iter().map(|s| s.header.shard.index).collect();
    let missing: Vec<String> = (0..count)
        .filter(|k| have.binary_search(k).is_err())
        .map(|k| k.to_string())
        .collect();
    if !missing.is_empty() {
        let shown = if missing.len() > 20 {
            format!(
                "{} and {} more",
                missing[..20].join(", "),
                missing.len() - 20
            )
        } else {
            missing.join(", ")
        };
        return Err(ShardError::Incomplete {
            problem: format!("{} of {count} shards are missing: {shown}", missing.len()),
            hint: "render the missing shards (`--shard K/N`), then stitch again".into(),
        });
    }
    // The parts must tile the whole: each starts where the last ended.
    let (start, end) = match &first.header.whole {
        Whole::Still => (0, first.header.height),
        Whole::Animation { frames, .. } => (frames.start, frames.end),
    };
    let mut at = start;
    for s in &shards {
        if s.header.part.start != at {
            return Err(ShardError::Mismatch {
                path: s.path.clone(),
                first: first.path.clone(),
                what: "cut of the image (the shards were cut differently)",
            });
        }
        at = s.header.part.end;
    }
    if at != end {
        return Err(ShardError::Mismatch {
            path: shards.last().expect("one at least").path.clone(),
            first: first.path.clone(),
            what: "cut of the image (the shards were cut differently)",
        });
    }
    Ok(shards)
}

/// Stitch `shards` (checked by [`check_set`]) into `out`: for a still,
/// a PNG streamed row by row; for an animation, the animated PNG, GIF or
/// numbered frames its name asks for, frame by frame.
pub fn stitch(shards: &[ShardFile], out: &Path) -> Result<(), ShardError> {
    // Never write over a shard being read.
    let same_file = |a: &Path, b: &Path| match (a.canonicalize(), b.canonicalize()) {
        (Ok(a), Ok(b)) => a == b,
        _ => false,
    };
    if let Some(s) = shards.iter().find(|s| same_file(&s.path, out)) {
        return Err(ShardError::Incomplete {
            problem: format!("the output {} is one of the shards", s.path.display()),
            hint: "write the image to another file with -o".into(),
        });
    }
    let first = &shards[0].header;
    let (width, height) = (first.width, first.height);
    match &first.whole {
        Whole::Still => {
            let png = out
                .extension()
                .is_some_and(|e| e.eq_ignore_ascii_case("png"));
            if !png {
                return Err(ShardError::Incomplete {
                    problem: format!(
                        "a still is written as PNG, and {} is not a .png",
                        out.display()
                    ),
                    hint: "name the output IMAGE.png".into(),
                });
            }
            let mut current = 0;
            let mut reader = shards[0].image(0)?;
            let mut failure: Option<ShardError> = None;
            let result = output::write_atomically_with(out, true, |w| {
                output::png_from_rows(w, width, height, |y, row| {
                    while y >= shards[current].header.part.end {
                        current += 1;
                        reader = shards[current]
                            .image(0)
                            .map_err(|e| std::io::Error::other(e.to_string()))?;
                    }
                    match reader.next_row() {
                        Ok(Some(r)) => {
                            row.copy_from_slice(r.data());
                            Ok(())
                        }
                        Ok(None) => Err(std::io::Error::other("a shard has too few rows")),
                        Err(e) => {
                            failure = Some(shards[current].broken(e));
                            Err(std::io::Error::other("a shard cannot be decoded"))
                        }
                    }
                })
            });
            if let Some(f) = failure {
                return Err(f);
            }
            result.map_err(|source| {
                ShardError::Write(WriteError::Io {
                    path: out.to_path_buf(),
                    source,
                })
            })
        }
        Whole::Animation { frames, fps } => {
            let format = AnimationFormat::of(out).ok_or_else(|| ShardError::Incomplete {
                problem: format!("cannot tell how to write an animation to {}", out.display()),
                hint: "end the name in .png (animated PNG) or .gif, or put %04d in it for one PNG per frame".into(),
            })?;
            let count = frames.end - frames.start;
            let mut writer = AnimationWriter::create(out, format, count, *fps, width, height)?;
            let mut rgb = vec![0u8; width as usize * height as usize * 3];
            for shard in shards {
                for (i, frame) in shard.header.part.clone().enumerate() {
                    let mut reader = shard.image(i)?;
                    reader.next_frame(&mut rgb).map_err(|e| shard.broken(e))?;
                    writer.push_rgb8(frame, &rgb, width, height)?;
                }
            }
            writer.finish()?;
            Ok(())
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Runs are contiguous, cover everything, are never empty, and share
    /// the cost fairly: no run costs more than the average plus the
    /// dearest item.
    #[test]
    fn balanced_runs_tile_and_share_the_cost() {
        let costs: Vec<u64> = (0..1000u64).map(|i| 1 + (i * i) % 97 + i / 10).collect();
        for count in [1, 2, 7, 100, 1000] {
            let runs = balanced_runs(&costs, count).unwrap();
            assert_eq!(runs.len(), count as usize);
            assert_eq!(runs[0].start, 0);
            assert_eq!(runs.last().unwrap().end, 1000);
            let total: u64 = costs.iter().sum();
            let dearest = *costs.iter().max().unwrap();
            for pair in runs.windows(2) {
                assert_eq!(pair[0].end, pair[1].start);
            }
            for r in &runs {
                assert!(r.start < r.end, "{count}: empty run {r:?}");
                let cost: u64 = costs[r.start as usize..r.end as usize].iter().sum();
                assert!(
                    cost <= total / count as u64 + dearest,
                    "{count}: {r:?} costs {cost} of {total}"
                );
            }
        }
        // One dear item: the runs around it still split the rest.
        let mut lumpy = vec![1u64; 100];
        lumpy[50] = 10_000;
        let runs = balanced_runs(&lumpy, 4).unwrap();
        assert!(
            runs.iter().any(|r| r.contains(&50) && r.len() <= 2),
            "{runs:?}"
        );
        assert_eq!(balanced_runs(&lumpy, 101), None);
    }

    #[test]
    fn shard_indices_are_checked() {
        assert_eq!(
            ShardIndex::parse("3/7"),
            Ok(ShardIndex { index: 3, count: 7 })
        );
        for bad in ["7/7", "1/0", "a/3", "3", "-1/4"] {
            assert!(ShardIndex::parse(bad).is_err(), "{bad}");
        }
    }

    /// A header survives its text form.
    #[test]
    fn headers_read_back_as_written() {
        let dir = std::env::temp_dir().join(format!("nes-shard-unit-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let header = Header {
            scene: scene_hash("camera { position (1, 0, 0) }"),
            source: "s.nes".into(),
            settings: "width=4 height=3".into(),
            shard: ShardIndex { index: 1, count: 2 },
            whole: Whole::Animation {
                frames: 0..4,
                fps: 12.5,
            },
            width: 4,
            height: 3,
            part: 2..4,
        };
        let path = dir.join("a.shard");
        let mut w = ShardWriter::create(&path, &header).unwrap();
        w.push(&[7u8; 36], 4, 3).unwrap();
        w.push(&[9u8; 36], 4, 3).unwrap();
        w.finish().unwrap();
        let read = ShardFile::open(&path).unwrap();
        assert_eq!(read.header, header);
        assert!(is_done(&path, &header));
        // Cut short: no longer complete.
        let bytes = std::fs::read(&path).unwrap();
        std::fs::write(&path, &bytes[..bytes.len() - 10]).unwrap();
        assert!(matches!(
            ShardFile::open(&path),
            Err(ShardError::NotAShard { .. })
        ));
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
