//! The syntax stage: source text to AST.
//!
//! Input: the text of a `.nes` file. Output: an
//! [`ast::File`](crate::ast::File) with a span on every node, or syntax
//! diagnostics. pest types never leave this module.
//!
//! Error recovery: pest stops at the first error. When a file fails, it is
//! cut into chunks at every line that starts (in column 0) with a top-level
//! keyword, and each chunk is parsed alone, so that every broken item is
//! reported, not just the first.

pub mod imports;

use std::sync::Once;

use pest::error::InputLocation;
use pest::iterators::Pair;
use pest::pratt_parser::{Assoc, Op, PrattParser};
use pest::Parser;

use crate::ast::*;
use crate::diagnostic::{Code, Diagnostic, Span};

/// The parser pest generates from the grammar, kept in a private module:
/// its `Rule` enum is generated code, documented in `grammar/nes.pest`.
#[allow(missing_docs)]
mod grammar {
    #[derive(pest_derive::Parser)]
    #[grammar = "../grammar/nes.pest"]
    pub(super) struct NesParser;
}
use grammar::{NesParser, Rule};

/// A scene file's bytes as text: UTF-8, without the byte-order mark some
/// editors (Notepad) put first. Otherwise the 1-based line and column (in
/// bytes) of the first byte that is not UTF-8.
pub fn decode(bytes: Vec<u8>) -> Result<String, (usize, usize)> {
    match String::from_utf8(bytes) {
        Ok(text) => Ok(match text.strip_prefix('\u{feff}') {
            Some(rest) => rest.to_string(),
            None => text,
        }),
        Err(e) => {
            let good = &e.as_bytes()[..e.utf8_error().valid_up_to()];
            // A line ends at \n, \r\n or a lone \r; columns count
            // characters.
            let breaks = |i: usize| {
                good[i] == b'\n' || (good[i] == b'\r' && good.get(i + 1) != Some(&b'\n'))
            };
            let line = (0..good.len()).filter(|&i| breaks(i)).count() + 1;
            let line_start = (0..good.len())
                .rev()
                .find(|&i| breaks(i))
                .map_or(0, |i| i + 1);
            let column = String::from_utf8_lossy(&good[line_start..]).chars().count() + 1;
            Err((line, column))
        }
    }
}

/// Old Mac line endings (a carriage return alone) as newlines, byte for
/// byte, so that every span keeps its offset and the diagnostics' line
/// numbers and excerpts agree; `\r\n` is left as it is.
pub fn lone_carriage_returns_as_newlines(source: &str) -> std::borrow::Cow<'_, str> {
    let bytes = source.as_bytes();
    let lone = |i: usize| bytes[i] == b'\r' && bytes.get(i + 1) != Some(&b'\n');
    if !(0..bytes.len()).any(lone) {
        return std::borrow::Cow::Borrowed(source);
    }
    let fixed: Vec<u8> = (0..bytes.len())
        .map(|i| if lone(i) { b'\n' } else { bytes[i] })
        .collect();
    // One ASCII byte for another: still UTF-8.
    std::borrow::Cow::Owned(String::from_utf8(fixed).expect("ASCII replaced by ASCII"))
}

/// Parse a whole scene file.
pub fn parse(source: &str) -> Result<File, Vec<Diagnostic>> {
    parse_at(source, 0)
}

/// Parse a whole file whose spans start at `base`: an imported file's
/// spans follow the importing files', so that one span names one place
/// among all of them.
pub fn parse_at(source: &str, base: usize) -> Result<File, Vec<Diagnostic>> {
    static DETAIL: Once = Once::new();
    DETAIL.call_once(|| pest::set_error_detail(true));
    check_before_parsing(source).map_err(|mut errors| {
        for l in errors.iter_mut().flat_map(|d| &mut d.labels) {
            l.span = Span::new(l.span.start + base, l.span.end + base);
        }
        errors
    })?;
    let total = base + source.len();
    match parse_chunk(source, base, total, Rule::file) {
        Ok(items) => Ok(File { items }),
        Err(first) => {
            let mut errors = Vec::new();
            for (start, end) in recovery_chunks(source) {
                if let Err(e) =
                    parse_chunk(&source[start..end], base + start, total, Rule::single_item)
                {
                    errors.push(e);
                }
            }
            if errors.is_empty() {
                errors.push(first);
            }
            Err(errors)
        }
    }
}

/// Parse one expression on its own (used by tests and tools).
pub fn parse_expr(source: &str) -> Result<Expr, Diagnostic> {
    let wrapped = format!("let _probe = {source}");
    let file = parse(&wrapped).map_err(|mut e| {
        let mut d = e.remove(0);
        for l in &mut d.labels {
            let shift = |p: usize| p.saturating_sub(13).min(source.len());
            l.span = Span::new(shift(l.span.start), shift(l.span.end));
        }
        d
    })?;
    match file.items.into_iter().next() {
        Some(Item::Let(mut l)) => {
            shift_expr(&mut l.value, 13);
            Ok(l.value)
        }
        _ => Err(Diagnostic::new(Code::Syntax, "expected an expression")
            .label(Span::new(0, source.len()), "here")),
    }
}

fn shift_expr(e: &mut Expr, by: usize) {
    e.span = Span::new(e.span.start - by, e.span.end - by);
    match &mut e.kind {
        ExprKind::Call { name, args } => {
            name.span = Span::new(name.span.start - by, name.span.end - by);
            args.iter_mut().for_each(|a| shift_expr(a, by));
        }
        ExprKind::Tuple(xs) => xs.iter_mut().for_each(|a| shift_expr(a, by)),
        ExprKind::Neg(a) | ExprKind::Component(a, _) => shift_expr(a, by),
        ExprKind::Binary(_, a, b) => {
            shift_expr(a, by);
            shift_expr(b, by);
        }
        _ => {}
    }
}

/// A larger scene file than this (4 MiB) is rejected before parsing: the
/// parse tree takes about 80 bytes per byte of source, and no scene a
/// person or a generator writes needs more (10 000 objects, the most a
/// scene may hold, take about 0.5 MB).
pub const MAX_SOURCE_BYTES: usize = 4 << 20;
/// Deeper bracket nesting than this is rejected before parsing.
pub const MAX_NESTING: usize = 256;
/// More operators than this in one file are rejected before parsing.
pub const MAX_OPERATORS: usize = 20_000;

/// What one pass over the text finds before pest sees it: sizes past the
/// limits (the parser and the compiler recurse over nested expressions;
/// these limits keep absurd input from exhausting the stack, far above
/// anything a person writes), and a block comment never closed (pest would
/// report the `*` after its `/`).
fn check_before_parsing(source: &str) -> Result<(), Vec<Diagnostic>> {
    if source.len() > MAX_SOURCE_BYTES {
        let at = (0..=MAX_SOURCE_BYTES)
            .rev()
            .find(|&i| source.is_char_boundary(i))
            .unwrap_or(0);
        let end = source[at..]
            .chars()
            .next()
            .map_or(at, |c| at + c.len_utf8());
        return Err(vec![Diagnostic::new(
            Code::TooLarge,
            format!(
                "the scene file is larger than {} MiB",
                MAX_SOURCE_BYTES >> 20
            ),
        )
        .label(Span::new(at, end), "the limit is reached here")
        .help(
            "a scene file may hold at most 4 MiB; define repeated parts once as shapes",
        )]);
    }
    let mut depth = 0usize;
    let mut operators = 0usize;
    // Comments hold no brackets or operators, as the grammar reads them.
    enum Comment {
        None,
        Line,
        Block { opened_at: usize },
    }
    let mut comment = Comment::None;
    let bytes = source.as_bytes();
    for (i, &b) in bytes.iter().enumerate() {
        match comment {
            Comment::Line => {
                if b == b'\n' {
                    comment = Comment::None;
                }
                continue;
            }
            Comment::Block { opened_at } => {
                // `/*/` does not close the comment it opens.
                if b == b'/' && i >= opened_at + 3 && bytes[i - 1] == b'*' {
                    comment = Comment::None;
                }
                continue;
            }
            Comment::None => {}
        }
        match b {
            b'/' if bytes.get(i + 1) == Some(&b'/') => comment = Comment::Line,
            b'/' if bytes.get(i + 1) == Some(&b'*') => comment = Comment::Block { opened_at: i },
            b'(' | b'{' => {
                depth += 1;
                if depth > MAX_NESTING {
                    return Err(vec![Diagnostic::new(
                        Code::Syntax,
                        "brackets are nested too deeply",
                    )
                    .label(
                        Span::new(i, i + 1),
                        format!("more than {MAX_NESTING} levels deep"),
                    )
                    .help("split the expression with `let` or helper shapes")]);
                }
            }
            b')' | b'}' => depth = depth.saturating_sub(1),
            // A component access (`v.x`) nests like an operator; a
            // decimal point (`1.5`) does not.
            b'.' if !bytes
                .get(i + 1)
                .is_some_and(|c| c.is_ascii_alphabetic() || *c == b'_') => {}
            b'+' | b'-' | b'*' | b'/' | b'^' | b'.' => {
                operators += 1;
                if operators > MAX_OPERATORS {
                    return Err(vec![Diagnostic::new(Code::Syntax, "the file has too many operators")
                        .label(Span::new(i, i + 1), format!("operator number {}", MAX_OPERATORS + 1))
                        .help(format!("a scene file may hold at most {MAX_OPERATORS} operators; simplify the expressions"))]);
                }
            }
            _ => {}
        }
    }
    if let Comment::Block { opened_at } = comment {
        return Err(vec![Diagnostic::new(
            Code::Syntax,
            "a block comment is not closed",
        )
        .label(Span::new(opened_at, opened_at + 2), "this `/*` has no `*/`")
        .help(
            "end the comment with `*/`, or use `//` for a comment to the end of the line",
        )]);
    }
    Ok(())
}

/// Whether `word` opens a top-level item: where error recovery may cut.
fn opens_item(word: &str) -> bool {
    crate::ast::ITEM_KEYWORDS.contains(&word) || crate::ast::directive(word).is_some()
}

/// Byte ranges of the recovery chunks.
fn recovery_chunks(source: &str) -> Vec<(usize, usize)> {
    let mut starts = vec![0];
    let mut offset = 0;
    for line in source.split_inclusive('\n') {
        let word: String = line
            .chars()
            .take_while(|c| c.is_ascii_alphanumeric() || *c == '_')
            .collect();
        if offset > 0 && opens_item(&word) {
            starts.push(offset);
        }
        offset += line.len();
    }
    let mut chunks = Vec::new();
    for (i, &s) in starts.iter().enumerate() {
        let e = starts.get(i + 1).copied().unwrap_or(source.len());
        chunks.push((s, e));
    }
    chunks
}

fn parse_chunk(
    text: &str,
    offset: usize,
    total_len: usize,
    rule: Rule,
) -> Result<Vec<Item>, Diagnostic> {
    let mut pairs =
        NesParser::parse(rule, text).map_err(|e| syntax_error(e, text, offset, total_len))?;
    let root = pairs.next().expect("the file rule always yields one pair");
    let b = Builder {
        offset,
        ends: significant_ends(text),
    };
    Ok(root
        .into_inner()
        .filter(|p| p.as_rule() != Rule::EOI)
        .map(|p| b.item(p))
        .collect())
}

fn describe_rule(rule: Rule) -> Option<&'static str> {
    Some(match rule {
        Rule::expr => "an expression",
        Rule::ident | Rule::variable => "a name",
        Rule::number => "a number",
        Rule::colour => "a colour like #ff8800",
        Rule::call => "a function call",
        Rule::paren => "a vector like (1, 2, 3)",
        Rule::comma => "`,`",
        Rule::let_item => "`let`",
        Rule::shape_item => "`shape`",
        Rule::object_item => "`object`",
        Rule::directive => "a directive (camera, light, ...)",
        Rule::item => "an item",
        Rule::params => "a parameter list",
        Rule::param => "a parameter",
        Rule::block => "a `{ ... }` block",
        Rule::property => "a property",
        Rule::solid => "a solid",
        Rule::csg => "union/intersection/difference",
        Rule::csg_op => "union/intersection/difference",
        Rule::shape_ref => "a shape",
        Rule::solid_formula => "a formula",
        Rule::args => "arguments",
        Rule::transform => "a transform",
        Rule::transform_op => "translate/rotate/scale",
        Rule::add => "`+`",
        Rule::sub => "`-`",
        Rule::mul => "`*`",
        Rule::div => "`/`",
        Rule::pow => "`^`",
        Rule::neg => "`-`",
        Rule::component => "`.x`, `.y` or `.z`",
        Rule::axis_name => "x, y or z",
        Rule::kw_let => "`let`",
        Rule::kw_import => "`import`",
        Rule::import_item => "`import`",
        Rule::path_string => "a quoted path like \"lib.nes\"",
        Rule::kw_shape => "`shape`",
        Rule::kw_object => "`object`",
        Rule::kw_about => "`about`",
        Rule::kw_in => "`in`",
        Rule::kw_then => "`then`",
        Rule::kw_else => "`else`",
        Rule::equals => "`=`",
        Rule::close_paren => "`)`",
        Rule::close_brace => "`}`",
        Rule::EOI => "the end of the file",
        _ => return None,
    })
}

fn syntax_error(
    e: pest::error::Error<Rule>,
    text: &str,
    offset: usize,
    total_len: usize,
) -> Diagnostic {
    let pos = match e.location {
        InputLocation::Pos(p) => p,
        InputLocation::Span((s, _)) => s,
    };
    const VALUE_RULES: &[Rule] = &[
        Rule::number,
        Rule::colour,
        Rule::call,
        Rule::variable,
        Rule::paren,
        Rule::neg,
        Rule::not,
        Rule::list,
        Rule::if_expr,
        Rule::let_expr,
        Rule::aggregate,
        Rule::aggregate_op,
        Rule::kw_let,
        Rule::kw_if,
    ];
    const OPERATORS: &[&str] = &["`+`", "`-`", "`*`", "`/`", "`^`"];
    const PUNCTUATION: &[&str] = &["(", ")", ",", "=", "{", "}", ":", ";"];
    let mut expected: Vec<String> = Vec::new();
    let mut wants_value = false;
    if let pest::error::ErrorVariant::ParsingError { positives, .. } = &e.variant {
        for r in positives {
            if VALUE_RULES.contains(r) || *r == Rule::expr {
                wants_value = true;
            } else if let Some(d) = describe_rule(*r) {
                if *r != Rule::component {
                    expected.push(d.to_string());
                }
            }
        }
    }
    if let Some(attempts) = e.parse_attempts() {
        for t in attempts.expected_tokens() {
            let s = t.to_string();
            if PUNCTUATION.contains(&s.as_str()) {
                expected.push(format!("`{s}`"));
            }
        }
    }
    if wants_value {
        expected.retain(|e| e != "a name" && e != "`(`");
        expected.push("a value (a number, a name, a vector or a formula)".into());
    }
    expected.sort();
    expected.dedup();
    if OPERATORS.iter().all(|o| expected.iter().any(|e| e == o)) {
        // After a complete operand, a transform may also follow (inside
        // brackets); naming it there only lengthens the message.
        expected.retain(|e| !OPERATORS.contains(&e.as_str()) && e != "translate/rotate/scale");
        expected.push("an operator".into());
    }
    // An error at the end of a chunk points just after its last token, not
    // at the blank lines that follow.
    let pos = if text[pos.min(text.len())..].trim().is_empty() {
        text.trim_end().len()
    } else {
        pos
    };
    let rest = &text[pos.min(text.len())..];
    let found: String = if rest.is_empty() {
        String::new()
    } else if rest.starts_with(|c: char| c.is_alphanumeric() || c == '_') {
        rest.chars()
            .take_while(|c| c.is_alphanumeric() || *c == '_' || *c == '.')
            .collect()
    } else {
        rest.chars().take(1).collect()
    };
    let len = found.len().max(if rest.is_empty() { 0 } else { 1 });
    let span = Span::new(offset + pos, offset + pos + len);
    let unusual = rest.chars().next().and_then(unusual_character);
    let found_text = if let Some((name, _)) = unusual {
        format!(
            "{name} (U+{:04X})",
            rest.chars().next().map_or(0, |c| c as u32)
        )
    } else if found.is_empty() && offset + text.len() == total_len {
        "end of file".to_string()
    } else if found.is_empty() {
        "end of item".to_string()
    } else if found.trim().is_empty() {
        "end of line".to_string()
    } else {
        format!("`{found}`")
    };
    let expected_text = match expected.len() {
        0 => "something else".to_string(),
        1 => expected[0].clone(),
        n => format!("{} or {}", expected[..n - 1].join(", "), expected[n - 1]),
    };
    let mut d = Diagnostic::new(Code::Syntax, format!("unexpected {found_text}"))
        .label(span, format!("expected {expected_text}"));
    if expected.iter().any(|e| e == "`)`") {
        // Only when the item's brackets really do not balance: a `)`
        // expected in the middle of balanced text is another mistake.
        if let Some(open) = unclosed_paren(text) {
            d = d.label(
                Span::new(offset + open, offset + open + 1),
                "this `(` is not closed",
            );
        }
    }
    let line =
        &text[text[..pos.min(text.len())].rfind('\n').map_or(0, |n| n + 1)..pos.min(text.len())];
    d = d.help(match unusual {
        Some((_, hint)) => hint.to_string(),
        None => syntax_hint(&found, rest, line, &expected),
    });
    d
}

/// A character that looks like another or like nothing, which editors and
/// word processors slip into text: its name and how to fix it.
fn unusual_character(c: char) -> Option<(&'static str, &'static str)> {
    const SPACE: &str = "replace it with an ordinary space (a word processor or a web page may have put it there; it looks the same)";
    match c {
        '\u{a0}' | '\u{202f}' => Some(("no-break space", SPACE)),
        '\u{200b}' | '\u{200c}' | '\u{200d}' | '\u{2060}' | '\u{feff}' => Some((
            "invisible zero-width character",
            "delete it: it takes no room on screen, so it is easiest to retype the text around it",
        )),
        '\u{ff10}'..='\u{ff19}' => Some((
            "full-width digit",
            "write the digit in ordinary (ASCII) figures, 0 to 9",
        )),
        '\u{ff01}'..='\u{ff5e}' => Some((
            "full-width character",
            "write it as its ordinary (ASCII) twin: full-width letters and signs are not part of the language",
        )),
        // Signs pasted from typeset mathematics.
        '\u{2212}' | '\u{2013}' | '\u{2014}' => Some((
            "typographic minus or dash",
            "write the ASCII minus `-`: a formula pasted from a document or web page often carries the printed minus sign, which looks the same",
        )),
        '\u{00d7}' | '\u{22c5}' | '\u{00b7}' | '\u{2217}' => Some((
            "multiplication sign",
            "write `*` for a product",
        )),
        '\u{00f7}' | '\u{2215}' => Some(("division sign", "write `/` for a quotient")),
        '\u{03c0}' => Some((
            "Greek letter pi",
            "write `pi`, the built-in constant (and `tau` for 2 pi)",
        )),
        c if c.is_whitespace() && !c.is_ascii() => Some(("unusual space", SPACE)),
        c if c.is_control() && c != '\n' && c != '\r' && c != '\t' => Some((
            "control character",
            "delete it: it is not text (the file may have been saved in another format)",
        )),
        _ => None,
    }
}

/// The byte offset of the last `(` in `before` that no `)` closes,
/// skipping comments.
fn unclosed_paren(before: &str) -> Option<usize> {
    let bytes = before.as_bytes();
    let mut open = Vec::new();
    let mut i = 0;
    while i < bytes.len() {
        match bytes[i] {
            b'/' if bytes.get(i + 1) == Some(&b'/') => {
                while i < bytes.len() && bytes[i] != b'\n' {
                    i += 1;
                }
            }
            b'/' if bytes.get(i + 1) == Some(&b'*') => {
                i += 2;
                while i + 1 < bytes.len() && !(bytes[i] == b'*' && bytes[i + 1] == b'/') {
                    i += 1;
                }
                i += 1;
            }
            b'(' => open.push(i),
            b')' => {
                open.pop();
            }
            _ => {}
        }
        i += 1;
    }
    open.pop()
}

/// How to fix a syntax error at `rest`, where `found` starts, after
/// `line` (the text before it on its line), when `expected` was wanted.
fn syntax_hint(found: &str, rest: &str, line: &str, expected: &[String]) -> String {
    let wants_value = expected.iter().any(|e| e.starts_with("a value"));
    if let Some(hex) = rest.strip_prefix('#') {
        let digits: String = hex
            .chars()
            .take_while(|c| c.is_ascii_alphanumeric())
            .collect();
        return match digits.chars().find(|c| !c.is_ascii_hexdigit()) {
            Some(bad) => format!("a hex colour has six hex digits (0-9, a-f): `{bad}` is not one; write it like #61afef"),
            None => format!("a hex colour has six hex digits, like #c8c8c8; this has {}", digits.len()),
        };
    }
    if let Some(hex) = found
        .strip_prefix("0x")
        .or_else(|| found.strip_prefix("0X"))
        .filter(|h| !h.is_empty() && h.chars().all(|c| c.is_ascii_hexdigit()))
    {
        return match u64::from_str_radix(hex, 16) {
            Ok(n) => format!("numbers are written in decimal: 0x{hex} is {n}"),
            Err(_) => "numbers are written in decimal".to_string(),
        };
    }
    if found.starts_with(|c: char| c.is_alphabetic() && !c.is_ascii()) {
        return "names are made of ASCII letters, digits and `_` (no accents or other scripts): write it without the accent, e.g. `e` for `é`".to_string();
    }
    if found.starts_with(|c: char| c.is_ascii_digit())
        && found.contains(|c: char| c.is_alphabetic())
    {
        let split = found.find(|c: char| c.is_alphabetic()).unwrap_or(0);
        let (n, name) = found.split_at(split);
        if !name.starts_with(['e', 'E']) || name.len() > 1 {
            return format!("a number and a name need `*` between them: write `{n}*{name}`");
        }
    }
    let lone_name = !line.is_empty()
        && !line.starts_with(char::is_whitespace)
        && line
            .trim_end()
            .chars()
            .all(|c| c.is_alphanumeric() || c == '_');
    if lone_name && ["^", "+", "-", "*", "/", "<", ">"].contains(&found) {
        return "a formula at the top level draws nothing: write `object` before it to draw it, or name it with `shape NAME = ...`".into();
    }
    if found == "in" {
        return "`in` belongs to `let NAME = VALUE in FORMULA` and to `sum(NAME in RANGE, TERM)`"
            .into();
    }
    let open = |o: char, c: char| {
        line.chars().filter(|&x| x == o).count() as i64
            - line.chars().filter(|&x| x == c).count() as i64
    };
    if found == ")" && open('(', ')') <= 0 {
        return "this `)` has no matching `(`: remove it, or open the bracket earlier".into();
    }
    if found == "," && open('(', ')') <= 0 && open('[', ']') <= 0 {
        return "a vector is written in brackets: `translate (0, 0, 1)`, `position (1, 2, 3)`"
            .into();
    }
    if rest.starts_with("*/") {
        return "comments do not nest: the first `*/` closed the comment, and this one is left over; remove the inner `/*` (or use a `//` comment on each line)".into();
    }
    match found {
        "°" => {
            return "nes takes angles in degrees, written as plain numbers: `rotate 45 about z`"
                .into()
        }
        "²" | "³" => return "write powers with `^`: `x^2`, `y^3`".into(),
        "π" => return "write pi as `pi`".into(),
        "√" => return "write a square root as `sqrt(...)`: `sqrt(x^2 + y^2)`".into(),
        "∛" => return "write a cube root as `cbrt(...)`".into(),
        _ => {}
    }
    if found == "=" {
        // `name =` right after `(` or `,`: a named argument, or a sum's
        // term written `i = 0..3`.
        let before = line.trim_end();
        let name_start = before
            .rfind(|c: char| !(c.is_alphanumeric() || c == '_'))
            .map_or(0, |i| i + 1);
        let named =
            name_start < before.len() && before[..name_start].trim_end().ends_with(['(', ',']);
        if named {
            let value = rest[1..].split([',', ')']).next().unwrap_or("");
            return if value.contains("..") {
                "the terms of a sum are named with `in`: `sum(i in 0..3, TERM)`".into()
            } else {
                "arguments are given by position, without names: write the values alone, in the order of the parameters".into()
            };
        }
        // `phi = ...` at the top level: a constant as other languages
        // write it.
        let name = before.trim_start();
        let bare_name = !name.is_empty()
            && name.chars().all(|c| c.is_alphanumeric() || c == '_')
            && !name.starts_with(|c: char| c.is_ascii_digit());
        if bare_name && expected.iter().any(|e| e == "`shape`") {
            return match crate::ast::directive(name) {
                Some(d) => format!("a directive takes no `=`: write `{}`", d.example),
                None => format!(
                    "to name a value, write `let {name} = ...`; a shape is `shape {name} = ...`"
                ),
            };
        }
        if line.trim_start().starts_with("shape") && before.contains('=') {
            return "a shape is its formula, which is 0 on the surface: move the right side over, as in `shape s = x^2 + y^2 + z^2 - 1`".into();
        }
    }
    if found == "=" && line.trim_start().starts_with("object") {
        return "an object is drawn where its formula is 0: move the right side over, as in `object x^2 + y^2 + z^2 - 1`".into();
    }
    if expected.iter().any(|e| e == "`in`") {
        return "a local name inside a formula is written `let NAME = VALUE in FORMULA`".into();
    }
    if expected.iter().any(|e| e == "`then`") {
        return "a choice is written `if CONDITION then A else B`".into();
    }
    if expected.iter().any(|e| e == "`else`") {
        return "`if` needs both branches: `if CONDITION then A else B`".into();
    }
    if found == "=" && wants_value {
        return "properties and directives take no `=`: write `fov 60`, `position (1, 2, 3)`"
            .into();
    }
    if found == "=" && expected.iter().any(|e| e == "an operator") {
        "a comparison is written with < or >; nes has no `=` inside a formula (and properties take no `=`: write `fov 60`)".into()
    } else if found == "*" && wants_value {
        "nes writes powers with `^`: `x^2`, not `x**2`".into()
    } else if expected.iter().any(|e| e == "`)`") {
        "a parenthesis opened earlier is not closed; add `)` or remove the extra text".into()
    } else if expected.iter().any(|e| e == "`}`") {
        "a block opened with `{` is not closed, or a property here is missing its value".into()
    } else if expected.iter().any(|e| e == "`=`") {
        "definitions read `let name = value` and `shape name(params) = expression`".into()
    } else if found.is_empty() {
        "the file ends in the middle of an item; finish it or delete it".into()
    } else if expected.iter().any(|e| e.starts_with("a value")) {
        "write a value here: a number, a name, a vector like (1, 2, 3) or a formula".into()
    } else {
        "check this line against the examples in docs/language.md".into()
    }
}

/// Turns pest pairs into AST nodes, shifting spans by the chunk's offset.
struct Builder {
    offset: usize,
    /// For each byte offset in the chunk, where the last character before
    /// it that is not whitespace or comment ends ([`significant_ends`]).
    ends: Vec<u32>,
}

fn pratt() -> &'static PrattParser<Rule> {
    use std::sync::OnceLock;
    static P: OnceLock<PrattParser<Rule>> = OnceLock::new();
    P.get_or_init(|| {
        PrattParser::new()
            .op(Op::infix(Rule::or, Assoc::Left))
            .op(Op::infix(Rule::and, Assoc::Left))
            .op(Op::prefix(Rule::not))
            .op(Op::infix(Rule::lt, Assoc::Left)
                | Op::infix(Rule::le, Assoc::Left)
                | Op::infix(Rule::gt, Assoc::Left)
                | Op::infix(Rule::ge, Assoc::Left)
                | Op::infix(Rule::eq, Assoc::Left)
                | Op::infix(Rule::ne, Assoc::Left))
            .op(Op::infix(Rule::add, Assoc::Left) | Op::infix(Rule::sub, Assoc::Left))
            .op(Op::infix(Rule::mul, Assoc::Left) | Op::infix(Rule::div, Assoc::Left))
            .op(Op::prefix(Rule::neg))
            .op(Op::infix(Rule::pow, Assoc::Right))
            .op(Op::postfix(Rule::component)
                | Op::postfix(Rule::at_point)
                | Op::postfix(Rule::index))
    })
}

impl Builder {
    /// The pair's span without the whitespace and comments it ends with:
    /// a rule's match may end in trivia the parser skipped before a
    /// look-ahead or an optional part that then did not match
    /// (`sphere(1) translate (2, 0, 0)  // far` as an object's solid),
    /// which a span should not cover.
    fn span(&self, p: &Pair<Rule>) -> Span {
        let s = p.as_span();
        let end = (self.ends[s.end()] as usize).max(s.start());
        Span::new(s.start() + self.offset, end + self.offset)
    }

    fn ident(&self, p: Pair<Rule>) -> Ident {
        debug_assert_eq!(p.as_rule(), Rule::ident);
        Ident {
            name: p.as_str().to_string(),
            span: self.span(&p),
        }
    }

    fn item(&self, p: Pair<Rule>) -> Item {
        let span = self.span(&p);
        let rule = p.as_rule();
        let mut inner = p
            .into_inner()
            .filter(|q| {
                !matches!(
                    q.as_rule(),
                    Rule::kw_let
                        | Rule::kw_shape
                        | Rule::kw_object
                        | Rule::kw_import
                        | Rule::equals
                )
            })
            .peekable();
        let function =
            rule == Rule::shape_item && inner.peek().map(|q| q.as_rule()) == Some(Rule::kw_fn);
        if function {
            inner.next();
        }
        match rule {
            Rule::import_item => {
                let quoted = inner.next().unwrap();
                let path_span = self.span(&quoted);
                let text = quoted.as_str();
                Item::Import(ImportItem {
                    path: text[1..text.len() - 1].to_string(),
                    path_span,
                    span,
                })
            }
            Rule::let_item => {
                let name = self.ident(inner.next().unwrap());
                let value = self.expr(inner.next().unwrap());
                Item::Let(LetItem { name, value, span })
            }
            Rule::shape_item => {
                let name = self.ident(inner.next().unwrap());
                let mut params = Vec::new();
                let mut next = inner.next().unwrap();
                if next.as_rule() == Rule::params {
                    for param in next.into_inner().filter(|q| q.as_rule() == Rule::param) {
                        let mut parts = param.into_inner();
                        let name = self.ident(parts.next().unwrap());
                        let kind = parts.next().map(|k| self.ident(k));
                        params.push(Param { name, kind });
                    }
                    next = inner.next().unwrap();
                }
                let body = self.formula(next);
                Item::Shape(ShapeItem {
                    name,
                    params,
                    body,
                    function,
                    span,
                })
            }
            Rule::object_item => {
                let solid = self.solid(inner.next().unwrap());
                let properties = inner
                    .next()
                    .map(|b| self.block(b).properties)
                    .unwrap_or_default();
                Item::Object(ObjectItem {
                    solid,
                    properties,
                    span,
                })
            }
            Rule::directive => {
                let name = self.ident(inner.next().unwrap());
                let mut value = None;
                let mut block = None;
                for q in inner {
                    match q.as_rule() {
                        Rule::expr => value = Some(self.expr(q)),
                        Rule::block => block = Some(self.block(q)),
                        r => unreachable!("directive child {r:?}"),
                    }
                }
                Item::Directive(Directive {
                    name,
                    value,
                    block,
                    span,
                })
            }
            r => unreachable!("item rule {r:?}"),
        }
    }

    fn block(&self, p: Pair<Rule>) -> Block {
        let span = self.span(&p);
        let properties = p
            .into_inner()
            .filter(|q| q.as_rule() == Rule::property)
            .map(|q| {
                let span = self.span(&q);
                let mut parts = q.into_inner().filter(|r| r.as_rule() != Rule::kw_about);
                let name = self.ident(parts.next().unwrap());
                let value = self.expr(parts.next().unwrap());
                let about = parts.next().map(|a| self.expr(a));
                Property {
                    name,
                    value,
                    about,
                    span,
                }
            })
            .collect();
        Block { properties, span }
    }

    fn solid(&self, p: Pair<Rule>) -> Solid {
        debug_assert_eq!(p.as_rule(), Rule::solid);
        let span = self.span(&p);
        let mut inner = p.into_inner().filter(|q| q.as_rule() != Rule::close_paren);
        let atom = inner.next().unwrap();
        let mut solid = match atom.as_rule() {
            Rule::solid => self.solid(atom),
            Rule::csg => {
                let mut parts = atom
                    .into_inner()
                    .filter(|q| q.as_rule() != Rule::close_paren);
                let op = match parts.next().unwrap().as_str() {
                    "union" => CsgOp::Union,
                    "intersection" => CsgOp::Intersection,
                    _ => CsgOp::Difference,
                };
                let children = parts.map(|c| self.solid(c)).collect();
                Solid {
                    kind: SolidKind::Csg { op, children },
                    transforms: Vec::new(),
                    span,
                }
            }
            Rule::shape_ref => {
                let mut parts = atom.into_inner();
                let name = self.ident(parts.next().unwrap());
                let args = parts.next().map(|a| self.args(a));
                Solid {
                    kind: SolidKind::Shape { name, args },
                    transforms: Vec::new(),
                    span,
                }
            }
            Rule::solid_formula => Solid {
                kind: SolidKind::Formula(self.expr(atom.into_inner().next().unwrap())),
                transforms: Vec::new(),
                span,
            },
            r => unreachable!("solid atom {r:?}"),
        };
        for t in inner {
            solid.transforms.push(self.transform(t));
        }
        solid.span = span;
        solid
    }

    fn transform(&self, t: Pair<Rule>) -> Transform {
        let span = self.span(&t);
        let mut parts = t.into_inner().filter(|r| r.as_rule() != Rule::kw_about);
        let op = match parts.next().unwrap().as_str() {
            "translate" => TransformOp::Translate,
            "rotate" => TransformOp::Rotate,
            _ => TransformOp::Scale,
        };
        let value = self.expr(parts.next().unwrap());
        let about = parts.next().map(|a| self.expr(a));
        Transform {
            op,
            value,
            about,
            span,
        }
    }

    /// An expression with the transforms written after it.
    fn formula(&self, p: Pair<Rule>) -> Expr {
        debug_assert_eq!(p.as_rule(), Rule::formula);
        let span = self.span(&p);
        let mut parts = p.into_inner();
        let e = self.expr(parts.next().unwrap());
        let transforms: Vec<Transform> = parts.map(|t| self.transform(t)).collect();
        if transforms.is_empty() {
            return e;
        }
        Expr {
            kind: ExprKind::Moved(Box::new(e), transforms),
            span,
        }
    }

    fn args(&self, p: Pair<Rule>) -> Vec<Expr> {
        p.into_inner()
            .filter(|q| q.as_rule() == Rule::formula)
            .map(|q| self.formula(q))
            .collect()
    }

    fn expr(&self, p: Pair<Rule>) -> Expr {
        debug_assert_eq!(p.as_rule(), Rule::expr);
        pratt()
            .map_primary(|q| self.primary(q))
            .map_prefix(|op, rhs| Expr {
                span: self.span(&op).to(rhs.span),
                kind: if op.as_rule() == Rule::not {
                    ExprKind::Not(Box::new(rhs))
                } else {
                    ExprKind::Neg(Box::new(rhs))
                },
            })
            .map_postfix(|lhs, op| {
                let span = lhs.span.to(self.span(&op));
                let kind = match op.as_rule() {
                    Rule::at_point => {
                        let point = op
                            .into_inner()
                            .find(|q| q.as_rule() != Rule::kw_at)
                            .unwrap();
                        ExprKind::At(Box::new(lhs), Box::new(self.primary(point)))
                    }
                    Rule::index => {
                        let i = op.into_inner().next().unwrap();
                        ExprKind::Index(Box::new(lhs), Box::new(self.expr(i)))
                    }
                    _ => {
                        let axis = match op.as_str().trim_start_matches('.').trim() {
                            "x" => 0,
                            "y" => 1,
                            _ => 2,
                        };
                        ExprKind::Component(Box::new(lhs), axis)
                    }
                };
                Expr { span, kind }
            })
            .map_infix(|lhs, op, rhs| {
                let op = match op.as_rule() {
                    Rule::add => BinaryOp::Add,
                    Rule::sub => BinaryOp::Sub,
                    Rule::mul => BinaryOp::Mul,
                    Rule::div => BinaryOp::Div,
                    Rule::lt => BinaryOp::Less,
                    Rule::le => BinaryOp::LessOrEqual,
                    Rule::gt => BinaryOp::Greater,
                    Rule::ge => BinaryOp::GreaterOrEqual,
                    Rule::eq => BinaryOp::Equal,
                    Rule::ne => BinaryOp::NotEqual,
                    Rule::and => BinaryOp::And,
                    Rule::or => BinaryOp::Or,
                    _ => BinaryOp::Pow,
                };
                Expr {
                    span: lhs.span.to(rhs.span),
                    kind: ExprKind::Binary(op, Box::new(lhs), Box::new(rhs)),
                }
            })
            .parse(p.into_inner())
    }

    fn primary(&self, p: Pair<Rule>) -> Expr {
        let span = self.span(&p);
        let kind = match p.as_rule() {
            Rule::number => ExprKind::Number(p.as_str().parse().unwrap_or(f64::NAN)),
            Rule::colour => {
                let hex = &p.as_str()[1..];
                let byte = |i: usize| u8::from_str_radix(&hex[i..i + 2], 16).unwrap_or(0);
                ExprKind::Colour([byte(0), byte(2), byte(4)])
            }
            Rule::variable => ExprKind::Variable(p.into_inner().next().unwrap().as_str().into()),
            Rule::call => {
                let mut parts = p.into_inner().filter(|q| q.as_rule() != Rule::close_paren);
                let name = self.ident(parts.next().unwrap());
                let args = parts.map(|a| self.formula(a)).collect();
                ExprKind::Call { name, args }
            }
            Rule::if_expr => {
                let mut parts = p.into_inner().filter(|q| {
                    !matches!(q.as_rule(), Rule::kw_if | Rule::kw_then | Rule::kw_else)
                });
                let condition = self.expr(parts.next().unwrap());
                let then = self.formula(parts.next().unwrap());
                let otherwise = self.expr(parts.next().unwrap());
                ExprKind::If {
                    condition: Box::new(condition),
                    then: Box::new(then),
                    otherwise: Box::new(otherwise),
                }
            }
            Rule::let_expr => {
                let mut parts = p
                    .into_inner()
                    .filter(|q| !matches!(q.as_rule(), Rule::kw_let | Rule::kw_in | Rule::equals));
                let name = self.ident(parts.next().unwrap());
                let value = self.expr(parts.next().unwrap());
                let body = self.expr(parts.next().unwrap());
                ExprKind::Let {
                    name,
                    value: Box::new(value),
                    body: Box::new(body),
                }
            }
            Rule::aggregate => {
                let mut parts = p
                    .into_inner()
                    .filter(|q| !matches!(q.as_rule(), Rule::kw_in | Rule::close_paren));
                let op = match parts.next().unwrap().as_str() {
                    "sum" => AggregateOp::Sum,
                    "product" => AggregateOp::Product,
                    "min" => AggregateOp::Min,
                    _ => AggregateOp::Max,
                };
                let name = self.ident(parts.next().unwrap());
                let first = self.expr(parts.next().unwrap());
                let next = parts.next().unwrap();
                let (source, body) = if next.as_rule() == Rule::range_op {
                    let inclusive = next.as_str() == "..=";
                    let to = self.expr(parts.next().unwrap());
                    let body = self.formula(parts.next().unwrap());
                    (
                        Source::Range {
                            from: Box::new(first),
                            to: Box::new(to),
                            inclusive,
                        },
                        body,
                    )
                } else {
                    (Source::List(Box::new(first)), self.formula(next))
                };
                ExprKind::Aggregate {
                    op,
                    name,
                    source,
                    body: Box::new(body),
                }
            }
            Rule::list => ExprKind::List(
                p.into_inner()
                    .filter(|q| q.as_rule() == Rule::formula)
                    .map(|q| self.formula(q))
                    .collect(),
            ),
            Rule::paren => {
                let parts: Vec<Pair<Rule>> = p.into_inner().collect();
                let has_comma = parts.iter().any(|q| q.as_rule() == Rule::comma);
                let mut items: Vec<Expr> = parts
                    .into_iter()
                    .filter(|q| q.as_rule() == Rule::formula)
                    .map(|q| self.formula(q))
                    .collect();
                if !has_comma {
                    // A parenthesised expression spans its brackets, so
                    // that `(x - 1) / 0` spans all of itself, not
                    // `x - 1) / 0`.
                    let mut inner = items.remove(0);
                    inner.span = span;
                    return inner;
                }
                ExprKind::Tuple(items)
            }
            r => unreachable!("primary {r:?}"),
        };
        Expr { kind, span }
    }
}

/// For each byte offset `i` of `text` (and its end), the offset just past
/// the last character before `i` that is neither whitespace nor part of a
/// comment: one pass that knows comments (`//` to the line's end, `/*` to
/// the next `*/`; they do not nest) and strings (a `//` inside quotes is
/// text), so that every span's end is trimmed in constant time.
fn significant_ends(text: &str) -> Vec<u32> {
    let bytes = text.as_bytes();
    let mut ends = vec![0u32; bytes.len() + 1];
    let (mut i, mut last) = (0usize, 0usize);
    while i < bytes.len() {
        let rest = &bytes[i..];
        let (to, significant) = if rest.starts_with(b"//") {
            let line = rest.iter().position(|&b| b == b'\n').unwrap_or(rest.len());
            (i + line, false)
        } else if rest.starts_with(b"/*") {
            let close = rest[2..].windows(2).position(|w| w == b"*/");
            (i + close.map_or(rest.len(), |k| k + 4), false)
        } else if bytes[i].is_ascii_whitespace() {
            (i + 1, false)
        } else if bytes[i] == b'"' {
            let close = rest[1..].iter().position(|&b| b == b'"');
            (i + close.map_or(rest.len(), |k| k + 2), true)
        } else {
            (i + 1, true)
        };
        for (k, e) in ends[i..to].iter_mut().enumerate() {
            // Within a string, an offset ends the string so far.
            *e = if significant {
                (i + k) as u32
            } else {
                last as u32
            };
        }
        if significant {
            ends[i] = last as u32;
            last = to;
        }
        i = to;
    }
    ends[bytes.len()] = last as u32;
    ends
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn spans_end_before_trailing_comments() {
        let trimmed = |text: &str| text[..significant_ends(text)[text.len()] as usize].to_string();
        for (text, want) in [
            (
                "sphere(1) translate (2, 0, 0)   // far away\n// next\n",
                "sphere(1) translate (2, 0, 0)",
            ),
            ("x^2 /* a */ \n /* b */", "x^2"),
            ("import \"a//b.nes\"", "import \"a//b.nes\""),
            ("a // one // two", "a"),
            ("a /* x // y */ + b", "a /* x // y */ + b"),
            ("a /* b /* c */", "a"),
            ("a /* \" */ // c", "a"),
            ("a /* open", "a"),
            ("  ", ""),
        ] {
            assert_eq!(trimmed(text), want, "{text:?}");
        }
        // The span of an object's solid, in a whole file.
        for (src, want) in [
            (
                "object sphere(1) translate (2, 0, 0)  // far\n// more\nobject sphere(2)\n",
                "sphere(1) translate (2, 0, 0)",
            ),
            (
                "object sphere(1) /* unit // ball */ translate (0.5, 0, 0)\n",
                "sphere(1) /* unit // ball */ translate (0.5, 0, 0)",
            ),
        ] {
            let file = parse(src).unwrap();
            let Item::Object(o) = &file.items[0] else {
                panic!()
            };
            assert_eq!(&src[o.solid.span.start..o.solid.span.end], want);
        }
    }

    fn show(e: &Expr) -> String {
        match &e.kind {
            ExprKind::Number(n) => format!("{n}"),
            ExprKind::Colour(c) => format!("#{:02x}{:02x}{:02x}", c[0], c[1], c[2]),
            ExprKind::Variable(v) => v.clone(),
            ExprKind::Call { name, args } => format!(
                "{}({})",
                name.name,
                args.iter().map(show).collect::<Vec<_>>().join(", ")
            ),
            ExprKind::Tuple(xs) => {
                format!("<{}>", xs.iter().map(show).collect::<Vec<_>>().join(", "))
            }
            ExprKind::Neg(a) => format!("(-{})", show(a)),
            ExprKind::Binary(op, a, b) => {
                let o = match op {
                    BinaryOp::Add => "+",
                    BinaryOp::Sub => "-",
                    BinaryOp::Mul => "*",
                    BinaryOp::Div => "/",
                    BinaryOp::Pow => "^",
                    BinaryOp::Less => "<",
                    BinaryOp::LessOrEqual => "<=",
                    BinaryOp::Greater => ">",
                    BinaryOp::GreaterOrEqual => ">=",
                    BinaryOp::Equal => "==",
                    BinaryOp::NotEqual => "!=",
                    BinaryOp::And => "and",
                    BinaryOp::Or => "or",
                };
                format!("({} {o} {})", show(a), show(b))
            }
            ExprKind::Component(a, i) => format!("{}.{}", show(a), ["x", "y", "z"][*i]),
            ExprKind::Not(a) => format!("(not {})", show(a)),
            ExprKind::If {
                condition,
                then,
                otherwise,
            } => format!(
                "(if {} then {} else {})",
                show(condition),
                show(then),
                show(otherwise)
            ),
            ExprKind::Let { name, value, body } => {
                format!("(let {} = {} in {})", name.name, show(value), show(body))
            }
            ExprKind::At(a, p) => format!("({} at {})", show(a), show(p)),
            ExprKind::Moved(a, ts) => format!("({} moved {})", show(a), ts.len()),
            ExprKind::List(xs) => {
                format!("[{}]", xs.iter().map(show).collect::<Vec<_>>().join(", "))
            }
            ExprKind::Index(a, i) => format!("{}[{}]", show(a), show(i)),
            ExprKind::Aggregate {
                op,
                name,
                source,
                body,
            } => {
                let src = match source {
                    Source::Range {
                        from,
                        to,
                        inclusive,
                    } => format!(
                        "{}{}{}",
                        show(from),
                        if *inclusive { "..=" } else { ".." },
                        show(to)
                    ),
                    Source::List(l) => show(l),
                };
                format!("{}({} in {src}, {})", op.name(), name.name, show(body))
            }
        }
    }

    #[test]
    fn precedence_and_associativity() {
        let cases = [
            ("-x^2", "(-(x ^ 2))"),
            ("2^3^2", "(2 ^ (3 ^ 2))"),
            ("1 - 2 - 3", "((1 - 2) - 3)"),
            ("a + b * c", "(a + (b * c))"),
            ("-a * b", "((-a) * b)"),
            ("2^-1", "(2 ^ (-1))"),
            ("(1, 2, 3).x", "<1, 2, 3>.x"),
            ("v.y^2", "(v.y ^ 2)"),
            ("atan2(y, x) + 1e-3", "(atan2(y, x) + 0.001)"),
            ("(a + b) * c", "((a + b) * c)"),
            (".5 + 2.", "(0.5 + 2)"),
            (
                "x < 1 and y > 0 or not z >= 2",
                "(((x < 1) and (y > 0)) or (not (z >= 2)))",
            ),
            ("a + 1 < b * 2", "((a + 1) < (b * 2))"),
            (
                "if x < 0 then -x else x + 1",
                "(if (x < 0) then (-x) else (x + 1))",
            ),
            ("let r = x^2 in r - 1", "(let r = (x ^ 2) in (r - 1))"),
            (
                "-sphere(1) at (x, y, z - 1) + 2",
                "((-(sphere(1) at <x, y, (z - 1)>)) + 2)",
            ),
            ("sum(i in 0..5, i^2)", "sum(i in 0..5, (i ^ 2))"),
            (
                "min(c in [(1, 0, 0), v], length(p - c))",
                "min(c in [<1, 0, 0>, v], length((p - c)))",
            ),
            ("product(k in 1..=n - 1, k)", "product(k in 1..=(n - 1), k)"),
            ("min(a, b)", "min(a, b)"),
            ("cs[2].x", "cs[2].x"),
            ("f(sphere(1) translate (1, 0, 0))", "f((sphere(1) moved 1))"),
        ];
        for (src, want) in cases {
            let e = parse_expr(src).unwrap_or_else(|d| panic!("{src}: {d:?}"));
            assert_eq!(show(&e), want, "{src}");
        }
    }

    #[test]
    fn spans_point_at_the_source() {
        let src = "sin(x) + 2";
        let e = parse_expr(src).unwrap();
        assert_eq!(e.span, Span::new(0, src.len()));
        let ExprKind::Binary(_, a, b) = &e.kind else {
            panic!()
        };
        assert_eq!(&src[a.span.start..a.span.end], "sin(x)");
        assert_eq!(&src[b.span.start..b.span.end], "2");
    }

    #[test]
    fn several_broken_items_are_each_reported() {
        let src = "let a = (1 +\nshape s = x^2 +\nobject sphere(1)\nlet b = = 2\n";
        let errors = parse(src).unwrap_err();
        assert_eq!(errors.len(), 3, "{errors:#?}");
        let lines: Vec<usize> = errors
            .iter()
            .map(|d| src[..d.span().unwrap().start].matches('\n').count())
            .collect();
        assert_eq!(lines, vec![0, 1, 3]);
    }

    #[test]
    fn keywords_are_not_names() {
        assert!(parse("let let = 1").is_err());
        assert!(parse("let letter = 1").is_ok());
        assert!(parse("shape objective = x").is_ok());
        for word in ["fn", "if", "then", "else", "in", "at", "and", "or", "not"] {
            assert!(parse(&format!("let {word} = 1")).is_err(), "{word}");
            assert!(parse(&format!("let {word}x = 1")).is_ok(), "{word}x");
        }
    }
}
