//! The live preview page of `nes watch --serve`.
//!
//! Input: a [`Board`] that the watch loop updates with each new image or
//! each broken edit's diagnostics. Output: an HTTP server (std::net, a
//! thread per connection, no async runtime) with three routes: `/` (one
//! page that updates itself), `/image.png` (the latest good image, from
//! memory) and `/events` (server-sent events: `image` with the image's
//! version, `diagnostics` with the error text). Anything else is 404; no
//! file is ever read from disk.

use std::io::{self, BufRead, BufReader, Write};
use std::net::{SocketAddr, TcpListener, TcpStream};
use std::sync::{Arc, Condvar, Mutex};
use std::time::Duration;

/// What the page shows: the latest good image and, while the scene is
/// broken, its diagnostics. `version` grows with every change.
#[derive(Debug, Default)]
pub struct State {
    /// Bumped by every publish, image or diagnostics; the event streams wait
    /// for it to change.
    pub version: u64,
    /// The version at which the image last changed.
    pub image_version: u64,
    /// The latest good image as PNG bytes; `None` until the first render.
    pub png: Option<Arc<Vec<u8>>>,
    /// The broken save's diagnostics as plain text; `None` while the scene
    /// compiles (cleared by the next good image).
    pub diagnostics: Option<String>,
}

/// The shared state and a signal for the event streams.
#[derive(Debug, Default)]
pub struct Board {
    state: Mutex<State>,
    changed: Condvar,
}

impl Board {
    /// An empty board: no image, no diagnostics, version 0.
    pub fn new() -> Arc<Board> {
        Arc::new(Board::default())
    }

    /// A new good image: shown, and any diagnostics cleared.
    pub fn publish_image(&self, png: Vec<u8>) {
        let mut s = self.state.lock().unwrap_or_else(|e| e.into_inner());
        s.version += 1;
        s.image_version = s.version;
        s.png = Some(Arc::new(png));
        s.diagnostics = None;
        self.changed.notify_all();
    }

    /// A broken edit: its diagnostics shown over the last good image.
    pub fn publish_diagnostics(&self, text: String) {
        let mut s = self.state.lock().unwrap_or_else(|e| e.into_inner());
        s.version += 1;
        s.diagnostics = Some(text);
        self.changed.notify_all();
    }

    fn snapshot(&self) -> Snapshot {
        let s = self.state.lock().unwrap_or_else(|e| e.into_inner());
        Snapshot {
            version: s.version,
            image_version: s.image_version,
            png: s.png.clone(),
            diagnostics: s.diagnostics.clone(),
        }
    }

    /// Waits until the version differs from `seen`, or `timeout` passes.
    fn wait_newer(&self, seen: u64, timeout: Duration) -> u64 {
        let s = self.state.lock().unwrap_or_else(|e| e.into_inner());
        let (s, _) = self
            .changed
            .wait_timeout_while(s, timeout, |s| s.version == seen)
            .unwrap_or_else(|e| e.into_inner());
        s.version
    }
}

struct Snapshot {
    version: u64,
    image_version: u64,
    png: Option<Arc<Vec<u8>>>,
    diagnostics: Option<String>,
}

/// Starts serving `board` on `addr`; returns the address bound (the port
/// chosen by the system when `addr` asks for port 0).
pub fn start(addr: SocketAddr, board: Arc<Board>) -> io::Result<SocketAddr> {
    let listener = TcpListener::bind(addr)?;
    let bound = listener.local_addr()?;
    std::thread::Builder::new()
        .name("nes-serve".into())
        .spawn(move || {
            for stream in listener.incoming().flatten() {
                let board = board.clone();
                let _ = std::thread::Builder::new()
                    .name("nes-client".into())
                    .spawn(move || {
                        let _ = handle(stream, &board);
                    });
            }
        })?;
    Ok(bound)
}

const PAGE: &str = include_str!("serve.html");

fn handle(mut stream: TcpStream, board: &Board) -> io::Result<()> {
    stream.set_read_timeout(Some(Duration::from_secs(10)))?;
    let mut reader = BufReader::new(stream.try_clone()?);
    let mut request_line = String::new();
    reader.read_line(&mut request_line)?;
    // Skip the headers; a request of more than 64 header lines is refused.
    for _ in 0..64 {
        let mut line = String::new();
        if reader.read_line(&mut line)? == 0 || line == "\r\n" || line == "\n" {
            break;
        }
    }
    let mut parts = request_line.split_whitespace();
    let (method, target) = (parts.next().unwrap_or(""), parts.next().unwrap_or(""));
    let path = target.split('?').next().unwrap_or("");
    if method != "GET" {
        return respond(
            &mut stream,
            "405 Method Not Allowed",
            "text/plain",
            b"GET only\n",
        );
    }
    match path {
        "/" | "/index.html" => respond(
            &mut stream,
            "200 OK",
            "text/html; charset=utf-8",
            PAGE.as_bytes(),
        ),
        "/image.png" => match board.snapshot().png {
            Some(png) => respond(&mut stream, "200 OK", "image/png", &png),
            None => respond(
                &mut stream,
                "404 Not Found",
                "text/plain",
                b"no image yet\n",
            ),
        },
        "/events" => events(stream, board),
        _ => respond(&mut stream, "404 Not Found", "text/plain", b"not found\n"),
    }
}

fn respond(stream: &mut TcpStream, status: &str, kind: &str, body: &[u8]) -> io::Result<()> {
    write!(
        stream,
        "HTTP/1.1 {status}\r\nContent-Type: {kind}\r\nContent-Length: {}\r\nCache-Control: no-store\r\nConnection: close\r\n\r\n",
        body.len()
    )?;
    stream.write_all(body)?;
    stream.flush()
}

/// A server-sent event stream: the current state at once, then every
/// change; a comment every 15 s finds clients that went away.
fn events(mut stream: TcpStream, board: &Board) -> io::Result<()> {
    write!(
        stream,
        "HTTP/1.1 200 OK\r\nContent-Type: text/event-stream\r\nCache-Control: no-store\r\nConnection: keep-alive\r\n\r\n"
    )?;
    let (mut seen, mut image_sent) = (u64::MAX, u64::MAX);
    loop {
        let now = board.snapshot();
        if now.version != seen {
            seen = now.version;
            // The image first (it clears the page's errors), then the
            // errors of a broken scene over it.
            if now.png.is_some() && now.image_version != image_sent {
                image_sent = now.image_version;
                write!(stream, "event: image\ndata: {}\n\n", now.image_version)?;
            }
            if let Some(text) = now.diagnostics {
                // Each line its own data field; the browser joins them.
                let mut message = String::from("event: diagnostics\n");
                for line in text.lines() {
                    message += &format!("data: {line}\n");
                }
                message.push('\n');
                stream.write_all(message.as_bytes())?;
            }
            stream.flush()?;
        }
        if board.wait_newer(seen, Duration::from_secs(15)) == seen {
            stream.write_all(b": still here\n\n")?;
            stream.flush()?;
        }
    }
}
