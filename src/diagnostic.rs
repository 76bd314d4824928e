//! Diagnostics: what went wrong in a scene file, where, and how to fix it.
//!
//! Input: spans and messages produced by the syntax and compile stages.
//! Output: [`SceneError`], which carries the source text and every
//! diagnostic, and renders them through miette. Every diagnostic has a
//! [`Code`], at least one labelled span and, where a fix exists, a hint.

use std::fmt;
use std::path::PathBuf;
use std::sync::Arc;

use miette::{GraphicalReportHandler, GraphicalTheme, LabeledSpan, NamedSource, SourceCode};

/// A half-open byte range `[start, end)` in the scene's source text.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub struct Span {
    /// Byte offset of the first byte.
    pub start: usize,
    /// Byte offset one past the last byte; equal to `start` for an empty span.
    pub end: usize,
}

impl Span {
    /// The span `[start, end)`; no check that `start <= end`.
    pub fn new(start: usize, end: usize) -> Self {
        Span { start, end }
    }
    /// The smallest span covering both.
    pub fn to(self, other: Span) -> Span {
        Span::new(self.start.min(other.start), self.end.max(other.end))
    }
}

/// Every kind of error has a stable code, listed in `docs/errors.md`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Code {
    /// The text does not follow the grammar.
    Syntax,
    /// A name that nothing defines.
    UnknownName,
    /// Two definitions of one name.
    DuplicateName,
    /// A shape that calls itself, directly or through others.
    RecursiveShape,
    /// A directive or property that does not exist where it was written.
    UnknownSetting,
    /// A required directive or property is missing, or given twice.
    MissingSetting,
    /// Expressions that expand past the compile's budget of work.
    TooLarge,
    /// A call with the wrong number of arguments.
    ArgumentCount,
    /// A vector where a number is needed, or the like.
    WrongKind,
    /// `x`, `y`, `z` where only a constant can be used.
    NotConstant,
    /// A value outside its allowed range.
    OutOfRange,
    /// A direction or axis of length zero.
    ZeroLength,
    /// The scene file cannot be read.
    ReadFailed,
    /// The output image cannot be written.
    WriteFailed,
    /// Warning: an angle that looks like radians, where nes takes degrees.
    AngleInRadians,
    /// Warning: the camera is inside an object, so the view is its inside.
    CameraInside,
    /// Warning: a light is inside an object, so it lights nothing outside.
    LightInside,
    /// Warning: noise with features finer than a pixel: the image shows
    /// aliasing and the search resolves every feature, which is slow.
    FinerThanAPixel,
    /// Warning: an object no ray can reach (its surface is empty, or lies
    /// beyond `max_distance`).
    Unreachable,
    /// Warning: an object's bound is much larger than its surface, so
    /// rays search empty space (the image is right, only slower).
    LooseBound,
    /// Warning: `rgb()` given only 0s and 1s, nearly black as bytes, and
    /// likely meant as fractions.
    BytesLikeFractions,
    /// Warning: a constant (`let`) that is not a number or is infinite,
    /// most often a fractional power of a negative number.
    NotANumber,
    /// Warning: a transform written on the line of a `clip`, which moves
    /// the whole object, not the clip alone.
    TransformAfterClip,
    /// Warning: an object whose whole bound is under a pixel across as
    /// the camera sees it, so it shows in one pixel or none.
    SmallerThanAPixel,
    /// Warning: a formula that is not a number over part of the region
    /// its surface would cross, where no surface is drawn.
    PartlyUndefined,
    /// Warning: a formula that is 0 everywhere, so every point is on the
    /// surface.
    ZeroEverywhere,
    /// Warning: a formula that is a nonzero number over something, never
    /// 0: it changes sign only through a pole, which is no surface.
    NeverZero,
    /// Warning: a formula whose numbers (after folding) overflow to
    /// infinity or fall below the smallest normal number.
    BadConstant,
    /// Warning: an object not much larger than `epsilon`, the distance
    /// hits are located to, so its shape is lost.
    FinerThanEpsilon,
    /// Warning: the camera on an object's surface (within `epsilon`), so
    /// every ray finds its hit where it starts.
    CameraOnSurface,
    /// Warning: a formula so long, for the image's size, that the render
    /// will take minutes.
    LongRender,
    /// Render warning: pixels whose rays ran out of steps.
    OutOfSteps,
    /// Render warning: hits that could not be located to epsilon.
    Imprecise,
    /// Render warning: hits where the value or gradient is not a number,
    /// so the normal is a guess.
    UndefinedNormal,
    /// Render warning: values overflowing to infinities of both signs.
    Overflow,
    /// Render warning: a colour formula that is not a number at a hit.
    UndefinedColour,
    /// Render warning: pixels that met NaN or infinity and show the
    /// background.
    NotFinite,
    /// Render warning: no integrated path came near any object.
    NoPathNear,
    /// Render warning: integrated paths ended before their length (left
    /// the domain, met a singularity, ran out of steps, escaped).
    EndedEarly,
    /// Render warning: shadow geodesics whose shooting failed.
    ShootingFailed,
    /// Render warning: the unit-speed constraint drifted past its limit.
    Drift,
}

impl Code {
    /// The code as printed and listed in `docs/errors.md`, e.g. `"E0101"`.
    pub fn as_str(self) -> &'static str {
        match self {
            Code::Syntax => "E0001",
            Code::UnknownName => "E0101",
            Code::DuplicateName => "E0102",
            Code::RecursiveShape => "E0103",
            Code::UnknownSetting => "E0104",
            Code::MissingSetting => "E0105",
            Code::TooLarge => "E0106",
            Code::ArgumentCount => "E0201",
            Code::WrongKind => "E0202",
            Code::NotConstant => "E0203",
            Code::OutOfRange => "E0301",
            Code::ZeroLength => "E0302",
            Code::ReadFailed => "E0401",
            Code::WriteFailed => "E0402",
            Code::AngleInRadians => "W0001",
            Code::CameraInside => "W0002",
            Code::LightInside => "W0003",
            Code::FinerThanAPixel => "W0004",
            Code::Unreachable => "W0005",
            Code::LooseBound => "W0006",
            Code::BytesLikeFractions => "W0007",
            Code::NotANumber => "W0008",
            Code::TransformAfterClip => "W0009",
            Code::SmallerThanAPixel => "W0010",
            Code::PartlyUndefined => "W0011",
            Code::ZeroEverywhere => "W0012",
            Code::NeverZero => "W0013",
            Code::BadConstant => "W0014",
            Code::FinerThanEpsilon => "W0015",
            Code::CameraOnSurface => "W0016",
            Code::LongRender => "W0017",
            Code::OutOfSteps => "W0101",
            Code::Imprecise => "W0102",
            Code::UndefinedNormal => "W0103",
            Code::Overflow => "W0104",
            Code::UndefinedColour => "W0105",
            Code::NotFinite => "W0106",
            Code::NoPathNear => "W0107",
            Code::EndedEarly => "W0108",
            Code::ShootingFailed => "W0109",
            Code::Drift => "W0110",
        }
    }

    /// Whether this is a warning: the scene is drawn anyway (unless
    /// `--deny-warnings`), and the diagnostic says what may surprise.
    pub fn is_warning(self) -> bool {
        self.as_str().starts_with('W')
    }
}

/// A piece of source a diagnostic points at, with a note printed beside it.
#[derive(Debug, Clone, PartialEq)]
pub struct Label {
    /// The text pointed at.
    pub span: Span,
    /// The note; an empty string shows the span without a note.
    pub text: String,
}

/// One problem in a scene file.
#[derive(Debug, Clone, PartialEq)]
pub struct Diagnostic {
    /// Which kind of problem; printed as its `E....` code.
    pub code: Code,
    /// The headline, e.g. ``unknown shape `sphre` ``.
    pub message: String,
    /// The first label is the primary one.
    pub labels: Vec<Label>,
    /// How to fix it, printed after the source excerpt; `None` when there is no
    /// hint.
    pub help: Option<String>,
}

impl Diagnostic {
    /// A diagnostic with no label and no hint yet; add them with [`label`] and
    /// [`help`].
    ///
    /// [`label`]: Diagnostic::label
    /// [`help`]: Diagnostic::help
    pub fn new(code: Code, message: impl Into<String>) -> Self {
        Diagnostic {
            code,
            message: message.into(),
            labels: Vec::new(),
            help: None,
        }
    }
    /// Adds a labelled span; the first one added is the primary label.
    pub fn label(mut self, span: Span, text: impl Into<String>) -> Self {
        self.labels.push(Label {
            span,
            text: text.into(),
        });
        self
    }
    /// Sets the hint, replacing any earlier one.
    pub fn help(mut self, help: impl Into<String>) -> Self {
        self.help = Some(help.into());
        self
    }
    /// The primary span, for tests and tools.
    pub fn span(&self) -> Option<Span> {
        self.labels.first().map(|l| l.span)
    }
}

/// One file of a scene.
#[derive(Debug, Clone)]
pub struct SourceFile {
    /// The name it is shown as: the path as resolved.
    pub name: String,
    /// Where it was read from; `None` for text given directly.
    pub path: Option<PathBuf>,
    /// Its text; empty for a file that could not be read.
    pub text: Arc<str>,
    /// The span offset of its first byte.
    pub start: usize,
}

impl SourceFile {
    /// Whether `at` is an offset in this file (its end included).
    pub fn holds(&self, at: usize) -> bool {
        at >= self.start && at <= self.start + self.text.len()
    }
}

/// A scene that failed to parse or compile: its source and every problem
/// found, in source order.
#[derive(Debug, Clone)]
pub struct SceneError {
    /// The name the file is shown as in reports, usually its path.
    pub source_name: String,
    /// The whole source text the spans index into.
    pub source: Arc<str>,
    /// The problems, sorted by their primary span's start (those without a span
    /// last).
    pub diagnostics: Vec<Diagnostic>,
    /// The files the source imports, read or not, with where their spans
    /// start (after the source's own).
    pub imported: Vec<SourceFile>,
}

/// One file's text and name, and where its spans start.
#[derive(Clone, Copy)]
struct FileView<'a> {
    name: &'a str,
    text: &'a Arc<str>,
    start: usize,
}

impl SceneError {
    /// Collects the diagnostics of one source, sorting them by their primary
    /// span's start; diagnostics without a label go last.
    pub fn new(source_name: &str, source: &str, mut diagnostics: Vec<Diagnostic>) -> Self {
        diagnostics.sort_by_key(|d| d.span().map_or(usize::MAX, |s| s.start));
        SceneError {
            source_name: source_name.to_string(),
            source: Arc::from(source),
            diagnostics,
            imported: Vec::new(),
        }
    }

    /// With the files the source imports (`files[0]`, the source itself,
    /// is skipped), so that spans in them are shown in their own file.
    pub fn with_imports(mut self, files: &[SourceFile]) -> Self {
        self.imported = files.iter().skip(1).cloned().collect();
        self
    }

    /// The first [`MAX_REPORTS`] diagnostics as miette reports with their
    /// source excerpts attached; [`SceneError::unreported`] says how many
    /// more there are.
    pub fn reports(&self) -> impl Iterator<Item = miette::Report> + '_ {
        self.diagnostics
            .iter()
            .take(MAX_REPORTS)
            .map(|d| miette::Report::new(self.with_excerpt(d)))
    }

    /// The file a span offset lies in.
    fn file_of(&self, at: usize) -> FileView<'_> {
        let main = FileView {
            name: &self.source_name,
            text: &self.source,
            start: 0,
        };
        if at <= self.source.len() {
            return main;
        }
        self.imported
            .iter()
            .find(|f| f.holds(at))
            .map_or(main, |f| FileView {
                name: &f.name,
                text: &f.text,
                start: f.start,
            })
    }

    /// `d` ready for miette, in the file of its primary label; labels in
    /// other files (a definition that clashes with an imported one, a
    /// cycle of imports) are shown as notes in their own files.
    fn with_excerpt(&self, d: &Diagnostic) -> WithSource {
        let file = self.file_of(d.span().map_or(0, |s| s.start));
        let mut here = d.clone();
        here.labels.clear();
        let mut elsewhere: Vec<(FileView, Vec<Label>)> = Vec::new();
        for l in &d.labels {
            let f = self.file_of(l.span.start);
            let shifted = Label {
                span: Span::new(l.span.start - f.start, l.span.end.saturating_sub(f.start)),
                text: l.text.clone(),
            };
            if f.start == file.start {
                here.labels.push(shifted);
            } else if let Some((_, ls)) = elsewhere.iter_mut().find(|(g, _)| g.start == f.start) {
                ls.push(shifted);
            } else {
                elsewhere.push((f, vec![shifted]));
            }
        }
        let (diagnostic, source) = excerpt(&here, file);
        let related = elsewhere
            .into_iter()
            .map(|(f, labels)| {
                let note = Diagnostic {
                    code: d.code,
                    message: format!("also in {}", f.name),
                    labels,
                    help: None,
                };
                let (diagnostic, source) = excerpt(&note, f);
                WithSource {
                    diagnostic,
                    source,
                    related: Vec::new(),
                    note: true,
                }
            })
            .collect();
        WithSource {
            diagnostic,
            source,
            related,
            note: false,
        }
    }

    /// How many diagnostics [`SceneError::reports`] leaves out.
    pub fn unreported(&self) -> usize {
        self.diagnostics.len().saturating_sub(MAX_REPORTS)
    }

    /// All diagnostics (up to [`MAX_REPORTS`], then a line counting the
    /// rest) as plain text, without colour: for snapshot tests and for
    /// places that are not a terminal.
    pub fn render_plain(&self) -> String {
        let handler =
            GraphicalReportHandler::new_themed(GraphicalTheme::unicode_nocolor()).with_width(100);
        let mut out = String::new();
        for d in self.diagnostics.iter().take(MAX_REPORTS) {
            let with_source = self.with_excerpt(d);
            handler
                .render_report(&mut out, &with_source)
                .expect("writing to a String cannot fail");
        }
        if self.unreported() > 0 {
            out += &format!("... and {} more errors\n", self.unreported());
        }
        out
    }
}

/// `d` (its labels in `file`'s own offsets) ready for miette: with the
/// whole file when every line its labels touch is short (the usual case),
/// otherwise with an excerpt of those lines cut to a window around the
/// labels, so that a huge line costs no more than a short one, and its
/// labels moved into it.
fn excerpt(d: &Diagnostic, file: FileView) -> (Rendered, Source) {
    let whole = || {
        (
            Rendered(d.clone()),
            Source::Whole(NamedSource::new(file.name, file.text.clone())),
        )
    };
    let text: &str = file.text;
    let clamp = |i: usize| {
        let mut i = i.min(text.len());
        while !text.is_char_boundary(i) {
            i -= 1;
        }
        i
    };
    let line_of = |i: usize| {
        let start = text[..clamp(i)].rfind('\n').map_or(0, |n| n + 1);
        let end = text[clamp(i)..]
            .find('\n')
            .map_or(text.len(), |n| clamp(i) + n);
        (start, end)
    };
    let Some(primary) = d.span() else {
        return whole();
    };
    let (line_start, line_end) = line_of(primary.start);
    let long = |s: Span| {
        let (a, b) = line_of(s.start);
        let (c, e) = line_of(s.end);
        b - a > WINDOW || e - c > WINDOW || s.end.saturating_sub(s.start) > WINDOW
    };
    if !d.labels.iter().any(|l| long(l.span)) {
        return whole();
    }
    // A window of the primary label's line around it; labels elsewhere
    // are left out of the snippet (their text goes into the message).
    let from = clamp(primary.start.saturating_sub(WINDOW / 2).max(line_start));
    let to = clamp((primary.start + WINDOW / 2).min(line_end).max(from));
    let mut excerpt = String::new();
    if from > line_start {
        excerpt.push_str("...");
    }
    let shift = excerpt.len();
    excerpt.push_str(&text[from..to]);
    if to < line_end {
        excerpt.push_str("...");
    }
    let mut moved = d.clone();
    moved.labels.clear();
    let mut elsewhere = Vec::new();
    for l in &d.labels {
        if l.span.start >= from && l.span.start <= to {
            let start = l.span.start - from + shift;
            let end = (clamp(l.span.end).min(to).max(l.span.start) - from + shift).max(start);
            moved.labels.push(Label {
                span: Span::new(start, end),
                text: l.text.clone(),
            });
        } else {
            elsewhere.push(l);
        }
    }
    for l in elsewhere {
        let (line, column) = line_column(text, clamp(l.span.start));
        moved.message += &format!(" ({} at {line}:{column})", l.text);
    }
    let (line, column) = line_column(text, from);
    (
        Rendered(moved),
        Source::Excerpt(Excerpt {
            name: file.name.to_string(),
            text: excerpt,
            line: line - 1,
            column: column - 1 - shift.min(column - 1),
        }),
    )
}

impl fmt::Display for SceneError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let warnings = self
            .diagnostics
            .iter()
            .filter(|d| d.code.is_warning())
            .count();
        let errors = self.diagnostics.len() - warnings;
        let count = |n: usize, what: &str| format!("{n} {what}{}", if n == 1 { "" } else { "s" });
        match (errors, warnings) {
            (_, 0) => write!(f, "{}: {}", self.source_name, count(errors, "error")),
            (0, w) => write!(
                f,
                "{}: {}, denied by --deny-warnings",
                self.source_name,
                count(w, "warning")
            ),
            (e, w) => write!(
                f,
                "{}: {} and {}",
                self.source_name,
                count(e, "error"),
                count(w, "warning")
            ),
        }
    }
}

impl std::error::Error for SceneError {}

/// At most this many diagnostics are shown for one scene; the rest are
/// counted ("... and N more errors"), so a file with a million mistakes
/// costs no more to report than one with fifty.
pub const MAX_REPORTS: usize = 50;

/// The most bytes of one line shown under a diagnostic: a longer line is
/// shown as a window around its label.
const WINDOW: usize = 160;

/// The 1-based line and column (in characters, as editors count them) of
/// byte `at` of `text`.
fn line_column(text: &str, at: usize) -> (usize, usize) {
    let before = &text.as_bytes()[..at];
    let line = before.iter().filter(|&&b| b == b'\n').count() + 1;
    (line, char_column(text, at) + 1)
}

/// The characters between the start of byte `at`'s line and `at`: its
/// column from 0. miette counts bytes, so `café` moved every later
/// column of its line one to the right.
fn char_column(text: &str, at: usize) -> usize {
    let mut at = at.min(text.len());
    while !text.is_char_boundary(at) {
        at -= 1;
    }
    let start = text[..at].rfind('\n').map_or(0, |n| n + 1);
    text[start..at].chars().count()
}

/// What miette reads a snippet from: the whole source, or an excerpt.
#[derive(Debug)]
enum Source {
    Whole(NamedSource<Arc<str>>),
    Excerpt(Excerpt),
}

/// One window of one line, with where it stands in the file, so that the
/// report's `file:line:column` is the file's.
#[derive(Debug)]
struct Excerpt {
    name: String,
    text: String,
    /// The window's line in the file, from 0.
    line: usize,
    /// The file's column (from 0, in characters) of the excerpt's first
    /// character.
    column: usize,
}

impl SourceCode for Source {
    fn read_span<'a>(
        &'a self,
        span: &miette::SourceSpan,
        before: usize,
        after: usize,
    ) -> Result<Box<dyn miette::SpanContents<'a> + 'a>, miette::MietteError> {
        // miette's own contents give the column in bytes; the report's
        // `file:line:column` gives it in characters.
        match self {
            Source::Whole(s) => {
                let inner = s.read_span(span, before, after)?;
                Ok(Box::new(miette::MietteSpanContents::new_named(
                    s.name().to_string(),
                    inner.data(),
                    *inner.span(),
                    inner.line(),
                    char_column(s.inner(), span.offset()),
                    inner.line_count(),
                )))
            }
            Source::Excerpt(e) => {
                let inner = e.text.as_str().read_span(span, before, after)?;
                Ok(Box::new(miette::MietteSpanContents::new_named(
                    e.name.clone(),
                    inner.data(),
                    *inner.span(),
                    e.line + inner.line(),
                    e.column + char_column(&e.text, span.offset()),
                    inner.line_count(),
                )))
            }
        }
    }
}

/// A [`Diagnostic`] seen through miette's trait.
#[derive(Debug, Clone)]
struct Rendered(Diagnostic);

impl fmt::Display for Rendered {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.0.message)
    }
}
impl std::error::Error for Rendered {}

impl miette::Diagnostic for Rendered {
    fn code<'a>(&'a self) -> Option<Box<dyn fmt::Display + 'a>> {
        Some(Box::new(self.0.code.as_str()))
    }
    fn severity(&self) -> Option<miette::Severity> {
        Some(if self.0.code.is_warning() {
            miette::Severity::Warning
        } else {
            miette::Severity::Error
        })
    }
    fn help<'a>(&'a self) -> Option<Box<dyn fmt::Display + 'a>> {
        self.0
            .help
            .as_ref()
            .map(|h| Box::new(h) as Box<dyn fmt::Display>)
    }
    fn labels(&self) -> Option<Box<dyn Iterator<Item = LabeledSpan> + '_>> {
        Some(Box::new(self.0.labels.iter().enumerate().map(|(i, l)| {
            let span = (l.span.start, l.span.end - l.span.start);
            let text = (!l.text.is_empty()).then(|| l.text.clone());
            if i == 0 {
                LabeledSpan::new_primary_with_span(text, span)
            } else {
                LabeledSpan::new_with_span(text, span)
            }
        })))
    }
}

#[derive(Debug)]
struct WithSource {
    diagnostic: Rendered,
    source: Source,
    /// The same diagnostic's labels in other files.
    related: Vec<WithSource>,
    /// Whether this is such a part, shown as advice under the diagnostic.
    note: bool,
}
impl fmt::Display for WithSource {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        self.diagnostic.fmt(f)
    }
}
impl std::error::Error for WithSource {}
impl miette::Diagnostic for WithSource {
    fn code<'a>(&'a self) -> Option<Box<dyn fmt::Display + 'a>> {
        self.diagnostic.code()
    }
    fn help<'a>(&'a self) -> Option<Box<dyn fmt::Display + 'a>> {
        self.diagnostic.help()
    }
    fn severity(&self) -> Option<miette::Severity> {
        if self.note {
            return Some(miette::Severity::Advice);
        }
        self.diagnostic.severity()
    }
    fn labels(&self) -> Option<Box<dyn Iterator<Item = LabeledSpan> + '_>> {
        self.diagnostic.labels()
    }
    fn source_code(&self) -> Option<&dyn SourceCode> {
        Some(&self.source)
    }
    fn related<'a>(&'a self) -> Option<Box<dyn Iterator<Item = &'a dyn miette::Diagnostic> + 'a>> {
        if self.related.is_empty() {
            return None;
        }
        Some(Box::new(
            self.related.iter().map(|r| r as &dyn miette::Diagnostic),
        ))
    }
}

/// The names in `candidates` closest to `name`, for "did you mean" hints.
/// The same word in another case (`S3` for `s3`) is the best guess; then
/// one typing slip away (a letter wrong, missing, extra, or two swapped:
/// `sni` for `sin`, which Jaro-Winkler alone ranks below `sinh`); then
/// the most similar by Jaro-Winkler, if similar enough.
pub fn suggest<'a>(name: &str, candidates: impl IntoIterator<Item = &'a str>) -> Option<String> {
    let mut best: Option<(f64, &str)> = None;
    for c in candidates {
        let similar = strsim::jaro_winkler(name, c);
        let score = if c.eq_ignore_ascii_case(name) {
            4.0
        } else if name.len() >= 3 && strsim::osa_distance(name, c) == 1 {
            2.0 + similar
        } else {
            similar
        };
        if score > 0.8 && best.is_none_or(|(s, _)| score > s) {
            best = Some((score, c));
        }
    }
    best.map(|(_, c)| c.to_string())
}
