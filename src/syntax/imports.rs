//! Imports: a scene file and the files it imports, read and parsed into
//! one AST.
//!
//! Input: the main file's name (its path, when it has one) and text.
//! Output: every file read, with the offset where its spans start (the
//! main file at 0, each import after the last), and one
//! [`File`] in which each `import` is replaced by the
//! imported file's definitions, or the diagnostics of every file.
//!
//! `import "PATH"` is resolved against the importing file's folder. A file
//! reached twice (two files import a third) is read once; a cycle is an
//! error shown in both files. What may be read is bounded before any
//! reading: at most [`MAX_FILES`] files, [`MAX_DEPTH`] deep, each a regular
//! file of at most 4 MiB (so `/dev/zero` or a FIFO cannot hang a compile).

use std::collections::HashSet;
use std::io::Read;
use std::path::{Path, PathBuf};
use std::sync::Arc;

use crate::ast::{File, Item};
use crate::diagnostic::{Code, Diagnostic, SourceFile, Span};

/// The most files one scene may read, the main file included.
pub const MAX_FILES: usize = 256;
/// The longest chain of imports.
pub const MAX_DEPTH: usize = 32;

/// Every file read, and the merged file or every diagnostic.
pub struct Loaded {
    /// The main file first, then the imports in the order they were read.
    pub files: Vec<SourceFile>,
    /// The main file with its imports' definitions in place of each import.
    pub result: Result<File, Vec<Diagnostic>>,
}

/// Read the imports of the main file `text`, named `name` (a path, whose
/// folder imports are resolved against).
pub fn load(name: &str, text: &str) -> Loaded {
    let main = SourceFile {
        name: name.to_string(),
        path: Some(PathBuf::from(name)),
        text: Arc::from(text),
        start: 0,
    };
    // The main file is the stack's first entry, so a cycle through it is
    // found like any other (its span is never shown: a cycle's imports are
    // the entries after the file that closes it).
    let canonical = std::fs::canonicalize(name).unwrap_or_else(|_| PathBuf::from(name));
    let mut loader = Loader {
        files: vec![main],
        read: HashSet::from([canonical.clone()]),
        diags: Vec::new(),
        stack: vec![(canonical, Span::default())],
        too_many_reported: false,
    };
    let file = match super::parse_at(text, 0) {
        Ok(f) => Some(f),
        Err(d) => {
            loader.diags.extend(d);
            None
        }
    };
    let items = file.map(|f| loader.expand(0, f.items, true));
    let result = match items {
        Some(items) if loader.diags.is_empty() => Ok(File { items }),
        _ => Err(loader.diags),
    };
    Loaded {
        files: loader.files,
        result,
    }
}

struct Loader {
    files: Vec<SourceFile>,
    /// The canonical paths of the files read, the main file's included.
    read: HashSet<PathBuf>,
    diags: Vec<Diagnostic>,
    /// The main file, then the imports being read, outermost first: each
    /// file's canonical path and the span of the import that reached it.
    stack: Vec<(PathBuf, Span)>,
    /// [`MAX_FILES`] is reported once, however many imports go past it.
    too_many_reported: bool,
}

impl Loader {
    /// `items` of file `index` with each import replaced by its file's
    /// definitions; an imported file (`main` false) may hold only
    /// definitions and imports.
    fn expand(&mut self, index: usize, items: Vec<Item>, main: bool) -> Vec<Item> {
        let mut out = Vec::new();
        for item in items {
            match item {
                Item::Import(import) => {
                    if let Some(more) = self.import(index, &import) {
                        out.extend(more);
                    }
                }
                Item::Object(_) | Item::Directive(_) if !main => {
                    let span = match &item {
                        Item::Object(o) => o.span,
                        Item::Directive(d) => d.name.span,
                        _ => unreachable!(),
                    };
                    self.diags.push(
                        Diagnostic::new(
                            Code::WrongKind,
                            "an imported file may only define constants, shapes and functions",
                        )
                        .label(span, "this belongs in the scene that imports the file")
                        .help("move objects, the camera, lights and settings into the main scene file; keep `let`, `shape`, `fn` and `import` in the library"),
                    );
                }
                item => out.push(item),
            }
        }
        out
    }

    /// The definitions of the file `import` names, read relative to file
    /// `from`; `None` if it cannot be read (reported) or was read before.
    fn import(&mut self, from: usize, import: &crate::ast::ImportItem) -> Option<Vec<Item>> {
        let at = import.path_span;
        let folder = self.files[from]
            .path
            .as_deref()
            .and_then(Path::parent)
            .map(Path::to_path_buf)
            .unwrap_or_default();
        let path = folder.join(&import.path);
        let fail = |this: &mut Self, code: Code, message: String, help: &str| {
            this.diags.push(
                Diagnostic::new(code, message)
                    .label(at, "imported here")
                    .help(help),
            );
            None
        };
        if import.path.is_empty() {
            return fail(
                self,
                Code::ReadFailed,
                "an import needs a file name".into(),
                "write the path of a .nes file, like import \"lib.nes\"",
            );
        }
        let canonical = match std::fs::canonicalize(&path) {
            Ok(c) => c,
            Err(e) => {
                self.unread(&path);
                return fail(
                    self,
                    Code::ReadFailed,
                    format!("cannot read `{}`: {}", path.display(), plain_io_error(&e)),
                    "an import's path is relative to the folder of the file that imports it",
                );
            }
        };
        if let Some(pos) = self.stack.iter().position(|(p, _)| *p == canonical) {
            let mut d = Diagnostic::new(
                Code::RecursiveShape,
                format!("`{}` imports itself", import.path),
            )
            .label(at, "this import closes a cycle");
            // Each entry holds the import that reached its file: the
            // cycle's imports are those after the file's own entry.
            for (_, span) in self.stack[pos + 1..].iter().rev() {
                d = d.label(*span, "part of the cycle");
            }
            self.diags.push(d.help("a file cannot import itself, directly or through others; move what both need into a third file that each imports"));
            return None;
        }
        if self.read.contains(&canonical) {
            // Already read through another import: its definitions are in.
            return None;
        }
        if self.stack.len() >= MAX_DEPTH {
            return fail(
                self,
                Code::TooLarge,
                format!("imports nest more than {MAX_DEPTH} deep"),
                "flatten the chain of imports",
            );
        }
        if self.files.len() >= MAX_FILES {
            if std::mem::replace(&mut self.too_many_reported, true) {
                return None;
            }
            return fail(
                self,
                Code::TooLarge,
                format!("a scene may read at most {MAX_FILES} files"),
                "import fewer files, or merge small ones",
            );
        }
        let text = match read_text(&canonical) {
            Ok(t) => t,
            Err(why) => {
                self.unread(&path);
                return fail(
                    self,
                    Code::ReadFailed,
                    format!("cannot read `{}`: {why}", path.display()),
                    "an import names a .nes text file (UTF-8, at most 4 MiB)",
                );
            }
        };
        self.read.insert(canonical.clone());
        let (index, start) = self.add_file(&path, &text);
        let file = match super::parse_at(&text, start) {
            Ok(f) => f,
            Err(d) => {
                self.diags.extend(d);
                return None;
            }
        };
        self.stack.push((canonical, at));
        let items = self.expand(index, file.items, false);
        self.stack.pop();
        Some(items)
    }

    /// A file that could not be read is listed with no text, so that
    /// `nes watch` renders again when it appears.
    fn unread(&mut self, path: &Path) {
        self.add_file(path, "");
    }

    /// List a file, its spans starting after the last file's end: its
    /// index and that start.
    fn add_file(&mut self, path: &Path, text: &str) -> (usize, usize) {
        let last = self.files.last().expect("the main file is first");
        let start = last.start + last.text.len() + 1;
        self.files.push(SourceFile {
            name: path.display().to_string(),
            path: Some(path.to_path_buf()),
            text: Arc::from(text),
            start,
        });
        (self.files.len() - 1, start)
    }
}

/// A regular file's text, at most 4 MiB of UTF-8; checked before it is
/// opened, so a device or a FIFO is refused, not read.
fn read_text(path: &Path) -> Result<String, String> {
    let meta = std::fs::metadata(path).map_err(|e| plain_io_error(&e))?;
    if !meta.is_file() {
        return Err("it is not a regular file".into());
    }
    let limit = super::MAX_SOURCE_BYTES as u64;
    let mut bytes = Vec::new();
    std::fs::File::open(path)
        .and_then(|f| f.take(limit + 1).read_to_end(&mut bytes))
        .map_err(|e| plain_io_error(&e))?;
    if bytes.len() as u64 > limit {
        return Err(format!("it is larger than {} MiB", limit >> 20));
    }
    let text = super::decode(bytes)
        .map_err(|(line, column)| format!("it is not UTF-8 text (line {line}, column {column})"))?;
    Ok(super::lone_carriage_returns_as_newlines(&text).into_owned())
}

/// An I/O error without its `(os error 2)` suffix.
fn plain_io_error(e: &std::io::Error) -> String {
    let s = e.to_string();
    match s.find(" (os error") {
        Some(i) => s[..i].to_string(),
        None => s,
    }
}
