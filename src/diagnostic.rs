//! Diagnostics: what went wrong in a scene file, where, and how to fix it.
//!
//! Input: spans and messages produced by the syntax and compile stages.
//! Output: [`SceneError`], which carries the source text and every
//! diagnostic, and renders them through miette. Every diagnostic has a
//! [`Code`], at least one labelled span and, where a fix exists, a hint.

use std::fmt;
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
            Code::ArgumentCount => "E0201",
            Code::WrongKind => "E0202",
            Code::NotConstant => "E0203",
            Code::OutOfRange => "E0301",
            Code::ZeroLength => "E0302",
            Code::ReadFailed => "E0401",
            Code::WriteFailed => "E0402",
        }
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
        }
    }

    /// Each diagnostic as a miette report with the source attached.
    pub fn reports(&self) -> impl Iterator<Item = miette::Report> + '_ {
        self.diagnostics.iter().map(|d| {
            let named = NamedSource::new(self.source_name.clone(), self.source.to_string());
            miette::Report::new(Rendered(d.clone())).with_source_code(named)
        })
    }

    /// All diagnostics as plain text, without colour: for snapshot tests
    /// and for places that are not a terminal.
    pub fn render_plain(&self) -> String {
        let handler =
            GraphicalReportHandler::new_themed(GraphicalTheme::unicode_nocolor()).with_width(100);
        let mut out = String::new();
        for d in &self.diagnostics {
            let with_source = WithSource {
                diagnostic: Rendered(d.clone()),
                source: NamedSource::new(self.source_name.clone(), self.source.to_string()),
            };
            handler
                .render_report(&mut out, &with_source)
                .expect("writing to a String cannot fail");
        }
        out
    }
}

impl fmt::Display for SceneError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let n = self.diagnostics.len();
        write!(
            f,
            "{}: {} error{}",
            self.source_name,
            n,
            if n == 1 { "" } else { "s" }
        )
    }
}

impl std::error::Error for SceneError {}

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
    source: NamedSource<String>,
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
    fn labels(&self) -> Option<Box<dyn Iterator<Item = LabeledSpan> + '_>> {
        self.diagnostic.labels()
    }
    fn source_code(&self) -> Option<&dyn SourceCode> {
        Some(&self.source)
    }
}

/// The names in `candidates` closest to `name`, for "did you mean" hints.
pub fn suggest<'a>(name: &str, candidates: impl IntoIterator<Item = &'a str>) -> Option<String> {
    let mut best: Option<(f64, &str)> = None;
    for c in candidates {
        let score = strsim::jaro_winkler(name, c);
        if score > 0.8 && best.is_none_or(|(s, _)| score > s) {
            best = Some((score, c));
        }
    }
    best.map(|(_, c)| c.to_string())
}
