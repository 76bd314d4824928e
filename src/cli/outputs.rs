//! Where a command may write: every `-o` is checked here before any work
//! starts, so that no output destroys a file nes did not write.
//!
//! Input: the output path, the scene's path (its imports are found from
//! it) and the kinds of file the command can write there. Output: the
//! kind the path names, or the error that says why the path is refused.

use std::io::Read;
use std::ops::Range;
use std::path::{Path, PathBuf};

use crate::output::AnimationFormat;

use super::CliError;

/// A kind of file a command writes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Writes {
    Png,
    Gif,
    Svg,
    /// A shard of a render (`nes render --shard`): any name, but an
    /// existing file there must be a shard.
    Shard,
}

impl Writes {
    /// The extension the kind is written under (`None`: any name).
    fn extension(self) -> Option<&'static str> {
        match self {
            Writes::Png => Some("png"),
            Writes::Gif => Some("gif"),
            Writes::Svg => Some("svg"),
            Writes::Shard => None,
        }
    }

    fn named_by(self, path: &Path) -> bool {
        let named = |ext: &str| {
            path.extension()
                .is_some_and(|e| e.to_string_lossy().eq_ignore_ascii_case(ext))
        };
        match self {
            // An animated PNG may be named .apng.
            Writes::Png => named("png") || named("apng"),
            Writes::Shard => true,
            _ => self.extension().is_some_and(named),
        }
    }

    /// Whether a file starting with `head` is one of this kind: what nes
    /// may replace.
    fn starts(self, head: &[u8]) -> bool {
        match self {
            Writes::Png => head.starts_with(b"\x89PNG\r\n\x1a\n"),
            Writes::Gif => head.starts_with(b"GIF87a") || head.starts_with(b"GIF89a"),
            Writes::Svg => {
                let text = String::from_utf8_lossy(head);
                let text = text.trim_start_matches('\u{feff}').trim_start();
                text.starts_with("<svg") || text.starts_with("<?xml")
            }
            Writes::Shard => head.starts_with(b"nes shard "),
        }
    }

    fn describe(kinds: &[Writes]) -> String {
        let names: Vec<&str> = kinds
            .iter()
            .map(|k| match k {
                Writes::Png => "a PNG image",
                Writes::Gif => "a GIF",
                Writes::Svg => "an SVG drawing",
                Writes::Shard => "a shard",
            })
            .collect();
        names.join(" or ")
    }
}

/// Check that `output` may be written with one of `kinds`, and say which
/// its name asks for. Refused: the scene file or any file it imports
/// (however spelled, by identity), a name whose extension is not one of
/// the kinds' (`-o out.jpg` would get PNG bytes), a folder, and an
/// existing non-empty file that is not already of one of the kinds (a
/// render replaces its old image, never `notes.txt`).
pub(super) fn checked(
    output: &Path,
    scene: Option<&Path>,
    kinds: &[Writes],
) -> Result<Writes, CliError> {
    if let Some(scene) = scene {
        not_a_source(output, scene)?;
    }
    let existing = std::fs::metadata(output).ok();
    match &existing {
        // A device or a pipe (`-o /dev/null`) is written into, never
        // replaced, whatever its name.
        Some(m) if !m.is_file() && !m.is_dir() => return Ok(kinds[0]),
        Some(m) if m.is_dir() => {
            return Err(CliError::Argument {
                message: format!("{} is a folder", output.display()),
                help: format!(
                    "give a file name inside it, e.g. -o {}",
                    output.join("image.png").display()
                ),
            })
        }
        _ => {}
    }
    let Some(&kind) = kinds.iter().find(|k| k.named_by(output)) else {
        let extensions: Vec<String> = kinds
            .iter()
            .filter_map(|k| k.extension().map(|e| format!(".{e}")))
            .collect();
        return Err(CliError::Argument {
            message: format!(
                "{} does not name {}: its name should end in {}",
                output.display(),
                Writes::describe(kinds),
                extensions.join(" or ")
            ),
            help: format!(
                "this command writes {}; choose a name such as image{}",
                Writes::describe(kinds),
                extensions.first().map_or("", String::as_str)
            ),
        });
    };
    let folder = match output.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    if !folder.is_dir() {
        return Err(CliError::Argument {
            message: format!("{} is not a folder that exists", folder.display()),
            help: format!(
                "create it first (mkdir -p {}), or choose another path",
                folder.display()
            ),
        });
    }
    if existing.is_some_and(|m| m.len() > 0) {
        let mut head = [0u8; 64];
        let read = std::fs::File::open(output)
            .and_then(|mut f| f.read(&mut head))
            .unwrap_or(0);
        if !kinds.iter().any(|k| k.starts(&head[..read])) {
            return Err(CliError::Argument {
                message: format!(
                    "{} exists and is not {}: writing there would destroy it",
                    output.display(),
                    Writes::describe(kinds)
                ),
                help:
                    "choose another output path, or delete the file first if it is no longer needed"
                        .into(),
            });
        }
    }
    Ok(kind)
}

/// Refuse `output` if it is the scene file or a file the scene imports,
/// however spelled (by identity, so hard links count).
pub(super) fn not_a_source(output: &Path, scene: &Path) -> Result<(), CliError> {
    for source in std::iter::once(scene.to_path_buf()).chain(imports_of(scene)) {
        if crate::output::same_file(output, &source) {
            let what = if source == scene {
                "the scene file itself".to_string()
            } else if source == output {
                "a file the scene imports".to_string()
            } else {
                format!("{}, a file the scene imports", source.display())
            };
            return Err(CliError::Argument {
                message: format!(
                    "{} is {what}: writing there would destroy it",
                    output.display()
                ),
                help: "choose another output path, e.g. -o image.png".into(),
            });
        }
    }
    Ok(())
}

/// The files the scene at `scene` imports, as far as they can be read (a
/// scene that cannot be read has none here: reading it reports why).
fn imports_of(scene: &Path) -> Vec<PathBuf> {
    let Ok(text) = super::read_source(scene) else {
        return Vec::new();
    };
    let loaded = crate::syntax::imports::load(&scene.display().to_string(), &text);
    loaded.files[1..]
        .iter()
        .filter_map(|f| f.path.clone())
        .collect()
}

/// [`checked`] for an animation of `frames` written as `format` at
/// `output`: the one file, or every numbered frame's file, all before the
/// first frame is rendered.
pub(super) fn checked_animation(
    output: &Path,
    scene: Option<&Path>,
    format: AnimationFormat,
    frames: Range<u32>,
) -> Result<(), CliError> {
    match format {
        AnimationFormat::Apng => checked(output, scene, &[Writes::Png]).map(drop),
        AnimationFormat::Gif => checked(output, scene, &[Writes::Gif]).map(drop),
        AnimationFormat::Numbered => {
            for frame in frames {
                if let Some(file) = crate::output::numbered_path(output, frame) {
                    checked(&file, scene, &[Writes::Png])?;
                }
            }
            Ok(())
        }
    }
}
