//! Generator 1: mutations of the example scenes (and the prelude).
//!
//! Input: the corpus and a [`Rng`]. Output: the bytes of one scene file,
//! at most [`MAX_INPUT`] long. Cheap mutations (byte flips, token and line
//! edits, splices from other files, extreme numbers, odd bytes and line
//! endings) are stacked one to four at a time; rarely, a heavy one (a line
//! repeated thousands of times, a 100 KB line, brackets nested past the
//! limits) is added.

use crate::rng::Rng;

/// The largest input either generator produces.
pub const MAX_INPUT: usize = 1 << 20;

/// Numbers at and past the edges of `f64` and of the language's ranges,
/// and text that only looks like a number.
pub const EXTREME_NUMBERS: &[&str] = &[
    "1e308",
    "-0",
    "1e-320",
    "4.9e-324",
    "1e309",
    "1e-400",
    "1.7976931348623157e308",
    "99999999999999999999",
    "18446744073709551616",
    "123456789012345678901234567890e-10",
    "0.000000000000000000000000000001",
    "0",
    "0.0",
    "-1",
    "1e-9",
    "1e9",
    "65536",
    "65537",
    "11585",
    "11586",
    "2147483647",
    "4294967296",
    "1e+308",
    "-1e308",
    "2.",
    ".5",
    "0e0",
    "1E5",
    "1024",
    "1025",
    "1000001",
    "10000001",
    "NaN",
    "nan",
    "inf",
    "-inf",
    "infinity",
    "0x10",
    "1_000",
    "1e",
    "1.e3",
    "..5",
    "1..2",
    "3.14.15",
];

/// Every word the language knows, and its punctuation.
pub const WORDS: &[&str] = &[
    "let",
    "shape",
    "object",
    "about",
    "camera",
    "light",
    "space",
    "ambient",
    "background",
    "render",
    "position",
    "look_at",
    "yaw",
    "pitch",
    "up",
    "fov",
    "width",
    "height",
    "projection",
    "correction",
    "colour",
    "color",
    "intensity",
    "min",
    "max",
    "wraps",
    "periodic",
    "radius",
    "method",
    "epsilon",
    "step",
    "max_distance",
    "max_steps",
    "samples",
    "shading",
    "shadows",
    "tolerance",
    "translate",
    "rotate",
    "scale",
    "euclidean",
    "torus",
    "sphere",
    "rectilinear",
    "angular",
    "on",
    "off",
    "true",
    "false",
    "lambert",
    "flat",
    "geodesic",
    "auto",
    "exact",
    "interval",
    "march",
    "adaptive",
    "ode",
    "union",
    "intersection",
    "difference",
    "x",
    "y",
    "z",
    "p",
    "pi",
    "tau",
    "e",
    "time",
    "frame",
    "number",
    "positive",
    "vector",
    "direction",
    "sin",
    "cos",
    "tan",
    "asin",
    "acos",
    "atan",
    "atan2",
    "sinh",
    "cosh",
    "tanh",
    "exp",
    "ln",
    "log",
    "sqrt",
    "abs",
    "sign",
    "clamp",
    "pow",
    "smin",
    "dot",
    "cross",
    "length",
    "normalize",
    "rgb",
    "plane",
    "ellipsoid",
    "box",
    "cube",
    "cylinder",
    "capped_cylinder",
    "cone",
    "superellipsoid",
    "red",
    "sky",
    "#ff8800",
    "#fff",
    "#gggggg",
    "(",
    ")",
    "{",
    "}",
    ",",
    "=",
    ":",
    ";",
    "+",
    "-",
    "*",
    "/",
    "^",
    ".",
    ".x",
    ".w",
    "#",
    "//",
    "/*",
    "*/",
    "\"",
    "\\",
    "_",
    "__",
];

/// Text outside ASCII, invisible characters and control characters.
const ODD_TEXT: &[&str] = &[
    "é",
    "𝑥",
    "\u{200b}",
    "\u{202e}",
    "\u{2028}",
    "\u{feff}",
    "😀",
    "e\u{301}",
    "\u{ff11}",
    "Ω",
    "ｘ",
    "\u{a0}",
    "\u{7f}",
    "\u{1b}[31m",
    "\u{10ffff}",
    "\u{0}",
    "\t",
    "\r",
    "\u{b}",
    "\u{c}",
];

/// Bytes worth planting.
const ODD_BYTES: &[u8] = &[
    0, 0xff, 0xfe, 0x80, 0xc3, 0xe2, 0xf0, b'(', b')', b'{', b'}', b'.', b',', b'-', b'^', b'#',
    b'\n', b'\r', b'"', b'/', b'*', b'e', b'0', b'9', b' ',
];

/// Word-like bytes: a token is a run of these, or a run of spaces, or
/// any other single byte.
fn wordy(b: u8) -> bool {
    b.is_ascii_alphanumeric() || b == b'_' || b == b'.' || b == b'#' || b >= 0x80
}

/// The tokens of `text` as byte ranges (also the minimiser's pieces).
pub fn token_ranges(text: &[u8]) -> Vec<(usize, usize)> {
    let mut out = Vec::new();
    let mut i = 0;
    while i < text.len() {
        let start = i;
        let b = text[i];
        if wordy(b) {
            while i < text.len() && wordy(text[i]) {
                i += 1;
            }
        } else if b.is_ascii_whitespace() {
            while i < text.len() && text[i].is_ascii_whitespace() {
                i += 1;
            }
        } else {
            i += 1;
        }
        out.push((start, i));
    }
    out
}

/// The lines of `text`, each with its newline.
fn lines(text: &[u8]) -> Vec<&[u8]> {
    text.split_inclusive(|&b| b == b'\n').collect()
}

/// A random position in `text` (its end included).
fn position(rng: &mut Rng, text: &[u8]) -> usize {
    rng.below(text.len() + 1)
}

/// A random token range of at most `most` tokens.
fn token_range(rng: &mut Rng, toks: &[(usize, usize)], most: usize) -> Option<(usize, usize)> {
    if toks.is_empty() {
        return None;
    }
    let first = rng.below(toks.len());
    let n = rng.between(1, most.min(toks.len() - first));
    Some((toks[first].0, toks[first + n - 1].1))
}

fn splice(text: &mut Vec<u8>, at: usize, insert: &[u8]) {
    let at = at.min(text.len());
    text.splice(at..at, insert.iter().copied());
}

/// One cheap mutation, in place.
fn cheap(rng: &mut Rng, text: &mut Vec<u8>, corpus: &[Vec<u8>]) {
    let other = &corpus[rng.below(corpus.len())];
    match rng.weighted(&[
        6, // 0 flip a bit
        4, // 1 plant a byte
        8, // 2 delete tokens
        6, // 3 duplicate tokens
        4, // 4 swap token ranges
        8, // 5 replace a token with a word
        4, // 6 replace a token with one from another file
        8, // 7 replace a number with an extreme one
        5, // 8 delete lines
        4, // 9 duplicate a line
        3, // 10 swap lines
        6, // 11 splice lines from another file
        3, // 12 unbalance brackets
        3, // 13 odd text
        1, // 14 NUL bytes
        2, // 15 line endings
        2, // 16 byte-order mark
        3, // 17 truncate
        2, // 18 open a comment
        1, // 19 invalid UTF-8
    ]) {
        0 => {
            if !text.is_empty() {
                let i = rng.below(text.len());
                text[i] ^= 1 << rng.below(8);
            }
        }
        1 => {
            let b = *rng.pick(ODD_BYTES);
            if !text.is_empty() && rng.chance(0.5) {
                let i = rng.below(text.len());
                text[i] = b;
            } else {
                let at = position(rng, text);
                splice(text, at, &[b]);
            }
        }
        2 => {
            let toks = token_ranges(text);
            if let Some((a, b)) = token_range(rng, &toks, 6) {
                text.drain(a..b);
            }
        }
        3 => {
            let toks = token_ranges(text);
            if let Some((a, b)) = token_range(rng, &toks, 12) {
                let copy = text[a..b].to_vec();
                let at = toks[rng.below(toks.len())].0;
                splice(text, at, &copy);
            }
        }
        4 => {
            let toks = token_ranges(text);
            if let (Some(r1), Some(r2)) = (token_range(rng, &toks, 5), token_range(rng, &toks, 5)) {
                let (first, second) = if r1.0 <= r2.0 { (r1, r2) } else { (r2, r1) };
                if first.1 <= second.0 {
                    let mut out = text[..first.0].to_vec();
                    out.extend_from_slice(&text[second.0..second.1]);
                    out.extend_from_slice(&text[first.1..second.0]);
                    out.extend_from_slice(&text[first.0..first.1]);
                    out.extend_from_slice(&text[second.1..]);
                    *text = out;
                }
            }
        }
        5 => {
            let toks = token_ranges(text);
            let word = rng.pick(WORDS).as_bytes();
            if toks.is_empty() {
                text.extend_from_slice(word);
            } else {
                let (a, b) = toks[rng.below(toks.len())];
                text.splice(a..b, word.iter().copied());
            }
        }
        6 => {
            let theirs = token_ranges(other);
            let toks = token_ranges(text);
            if let (false, false) = (theirs.is_empty(), toks.is_empty()) {
                let (c, d) = theirs[rng.below(theirs.len())];
                let (a, b) = toks[rng.below(toks.len())];
                text.splice(a..b, other[c..d].iter().copied());
            }
        }
        7 => {
            let toks = token_ranges(text);
            let numbers: Vec<_> = toks
                .iter()
                .filter(|(a, _)| text[*a].is_ascii_digit() || text[*a] == b'.')
                .copied()
                .collect();
            let n = rng.pick(EXTREME_NUMBERS).as_bytes();
            if numbers.is_empty() {
                let at = position(rng, text);
                splice(text, at, n);
            } else {
                let (a, b) = numbers[rng.below(numbers.len())];
                text.splice(a..b, n.iter().copied());
            }
        }
        8 => {
            let ls = lines(text);
            if !ls.is_empty() {
                let first = rng.below(ls.len());
                let n = rng.between(1, 3.min(ls.len() - first));
                let mut out = Vec::new();
                for (i, l) in ls.iter().enumerate() {
                    if i < first || i >= first + n {
                        out.extend_from_slice(l);
                    }
                }
                *text = out;
            }
        }
        9 => {
            let ls = lines(text);
            if !ls.is_empty() {
                let i = rng.below(ls.len());
                let copies = rng.between(1, 4);
                let mut out = Vec::new();
                for (k, l) in ls.iter().enumerate() {
                    out.extend_from_slice(l);
                    if k == i {
                        for _ in 0..copies {
                            out.extend_from_slice(l);
                        }
                    }
                }
                *text = out;
            }
        }
        10 => {
            let mut ls: Vec<Vec<u8>> = lines(text).into_iter().map(|l| l.to_vec()).collect();
            if ls.len() >= 2 {
                let (i, j) = (rng.below(ls.len()), rng.below(ls.len()));
                ls.swap(i, j);
                *text = ls.concat();
            }
        }
        11 => {
            let theirs = lines(other);
            if !theirs.is_empty() {
                let first = rng.below(theirs.len());
                let n = rng.between(1, 6.min(theirs.len() - first));
                let insert = theirs[first..first + n].concat();
                let ls = lines(text);
                let at_line = rng.below(ls.len() + 1);
                let at: usize = ls[..at_line].iter().map(|l| l.len()).sum();
                splice(text, at, &insert);
            }
        }
        12 => {
            let brackets = [b'(', b')', b'{', b'}'];
            let found: Vec<usize> = (0..text.len())
                .filter(|&i| brackets.contains(&text[i]))
                .collect();
            if !found.is_empty() && rng.chance(0.5) {
                text.remove(found[rng.below(found.len())]);
            } else {
                let at = position(rng, text);
                splice(text, at, &[*rng.pick(&brackets)]);
            }
        }
        13 => {
            let odd = rng.pick(ODD_TEXT).as_bytes();
            // At a token boundary, so that the text stays UTF-8.
            let toks = token_ranges(text);
            let at = if toks.is_empty() {
                0
            } else {
                toks[rng.below(toks.len())].0
            };
            splice(text, at, odd);
        }
        14 => {
            let n = rng.between(1, 3);
            let at = position(rng, text);
            splice(text, at, &vec![0u8; n]);
        }
        15 => {
            let endings: [&[u8]; 4] = [b"\r", b"\r\n", b"\n\r", b"\x0c"];
            let with = endings[rng.below(4)];
            let mut out = Vec::with_capacity(text.len() * 2);
            let all = rng.chance(0.7);
            for &b in text.iter() {
                if b == b'\n' && (all || rng.chance(0.5)) {
                    out.extend_from_slice(with);
                } else {
                    out.push(b);
                }
            }
            *text = out;
        }
        16 => {
            let bom = "\u{feff}".as_bytes();
            match rng.below(3) {
                0 => splice(text, 0, bom),
                1 => {
                    splice(text, 0, bom);
                    splice(text, 0, bom);
                }
                _ => {
                    let toks = token_ranges(text);
                    let at = toks.get(rng.below(toks.len().max(1))).map_or(0, |t| t.0);
                    splice(text, at, bom);
                }
            }
        }
        17 => {
            let at = position(rng, text);
            text.truncate(at);
        }
        18 => {
            let opens: [&[u8]; 4] = [b"/*", b"//", b"*/", b"/*/"];
            let open = opens[rng.below(4)];
            let at = position(rng, text);
            splice(text, at, open);
        }
        _ => {
            let bads: [&[u8]; 5] = [
                b"\xff",
                b"\x80",
                b"\xc3",
                b"\xed\xa0\x80",
                b"\xf4\x90\x80\x80",
            ];
            let bad = bads[rng.below(5)];
            let at = position(rng, text);
            splice(text, at, bad);
        }
    }
}

/// About 100 KB of one kind of long line.
fn long_line(rng: &mut Rng) -> Vec<u8> {
    let n = rng.pick(&[65_535usize, 65_536, 70_000, 100_000]).to_owned();
    let line = match rng.below(8) {
        0 => format!("{}object sphre(1)", " ".repeat(n)),
        1 => format!("let a = {}", "1".repeat(n)),
        2 => format!("let {} = 1", "a".repeat(n)),
        3 => format!("// {}", "x".repeat(n)),
        4 => format!("shape s = {}x\nobject s", "x+".repeat(n / 2)),
        5 => format!("let c = #{}", "f".repeat(n)),
        6 => format!("object {}", "sphere(1) ".repeat(n / 10)),
        _ => format!("{}sphere(", "0.".repeat(n / 2)),
    };
    let mut out = line.into_bytes();
    out.push(b'\n');
    out
}

/// Deep nesting of one kind around (or in place of) a token.
fn deep(rng: &mut Rng, inner: &[u8]) -> Vec<u8> {
    let n = *rng.pick(&[64usize, 128, 255, 256, 257, 1000, 20_000, 100_000]);
    let inner = String::from_utf8_lossy(inner);
    let s = match rng.below(8) {
        0 => format!("{}{inner}{}", "(".repeat(n), ")".repeat(n)),
        1 => format!("{}{inner}", "-".repeat(n)),
        2 => format!("{}{inner}{}", "sin(".repeat(n), ")".repeat(n)),
        3 => format!("{}{inner}", "2^".repeat(n)),
        4 => format!("(1, 2, 3){}", ".x".repeat(n)),
        5 => "(".repeat(n),
        6 => format!("{}{}", "{".repeat(n), "}".repeat(rng.below(n + 1))),
        _ => format!(
            "\nobject {}sphere(1){}\n",
            "union(sphere(1), ".repeat(n),
            ")".repeat(n)
        ),
    };
    s.into_bytes()
}

/// One heavy mutation, in place, keeping the input within [`MAX_INPUT`].
fn heavy(rng: &mut Rng, text: &mut Vec<u8>) {
    match rng.below(3) {
        0 => {
            let ls = lines(text);
            if ls.is_empty() {
                return;
            }
            let i = rng.below(ls.len());
            let line = ls[i].to_vec();
            let times = *rng.pick(&[100usize, 1000, 10_000]);
            let room = MAX_INPUT.saturating_sub(text.len()) / line.len().max(1);
            let times = times.min(room);
            let at: usize = ls[..i].iter().map(|l| l.len()).sum();
            let mut block = Vec::with_capacity(line.len() * times);
            for _ in 0..times {
                block.extend_from_slice(&line);
            }
            splice(text, at, &block);
        }
        1 => {
            let ls = lines(text);
            let at_line = rng.below(ls.len() + 1);
            let at: usize = ls[..at_line].iter().map(|l| l.len()).sum();
            let line = long_line(rng);
            splice(text, at, &line);
        }
        _ => {
            let toks = token_ranges(text);
            if toks.is_empty() {
                *text = deep(rng, b"1");
                return;
            }
            let (a, b) = toks[rng.below(toks.len())];
            let nested = deep(rng, &text[a..b]);
            text.splice(a..b, nested);
        }
    }
}

/// A mutation of one example scene. `light` keeps to one or two cheap
/// mutations, for scenes that should still compile often enough to render.
pub fn mutate(rng: &mut Rng, corpus: &[Vec<u8>], light: bool) -> Vec<u8> {
    // The last file is the prelude, which has no camera: splice material,
    // not a scene to start from.
    let mut text = corpus[rng.below(corpus.len().saturating_sub(1).max(1))].clone();
    let n = if light {
        rng.between(1, 2)
    } else {
        rng.between(1, 4)
    };
    for _ in 0..n {
        cheap(rng, &mut text, corpus);
    }
    if !light && rng.chance(0.004) {
        heavy(rng, &mut text);
    }
    text.truncate(MAX_INPUT);
    text
}
