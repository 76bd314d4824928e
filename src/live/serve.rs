//! The live preview page of `nes watch --serve`.
//!
//! Input: a [`Board`] that the watch loop updates with each new image or
//! each broken edit's diagnostics, and the [`Limits`] a client must keep
//! to. Output: an HTTP server (std::net, a thread per connection, no async
//! runtime) with three routes: `/` (one page that updates itself),
//! `/image.png` (the latest good image, from memory) and `/events`
//! (server-sent events: `image` with the image's version, `diagnostics`
//! with the error text). GET and HEAD only (other methods get 405); any
//! other path is 404; no file is ever read from disk.
//!
//! It answers only requests whose `Host` is the address the client
//! connected to or a loopback name (`localhost`, `127.0.0.1`, `[::1]`,
//! any port), so a page whose own name was rebound to this machine (DNS
//! rebinding) gets 403 and cannot read the image. Other names, `*.localhost`
//! and a LAN hostname included, are refused: serving on a LAN address
//! means browsing to that address as digits.
//!
//! Written here, not with a server crate: three fixed routes and one
//! header read need little HTTP, and what the server must withstand (a
//! deadline for the whole head, a cap on its bytes and lines, a cap on
//! connections answered from the accepting thread, the Host check) would
//! have to be written around either candidate anyway. axum has server-sent
//! events built in but needs tokio and hyper, an async runtime for a page
//! that one person watches. tiny_http is small and synchronous, but when
//! looked at it had no cap on a head's size (tiny-http#56; #232, adding
//! one, still open), timeouts only per socket read (tiny-http#143) and no
//! Host check. `tests/serve.rs` holds this server to each limit over real
//! sockets.

use std::io::{self, Read, Write};
use std::net::{IpAddr, Ipv4Addr, Ipv6Addr, Shutdown, SocketAddr, TcpListener, TcpStream};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::{Arc, Condvar, Mutex};
use std::time::{Duration, Instant};

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
    /// The warnings of the scene last compiled without errors, as plain
    /// text; empty when it has none. Shown beside its image.
    pub warnings: String,
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

    /// The warnings of a scene that compiled (empty text for none): shown
    /// beside its image until the next scene that compiles.
    pub fn publish_warnings(&self, text: String) {
        let mut s = self.state.lock().unwrap_or_else(|e| e.into_inner());
        if s.warnings != text {
            s.version += 1;
            s.warnings = text;
            self.changed.notify_all();
        }
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
            warnings: s.warnings.clone(),
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
    warnings: String,
}

/// What one client may take of the server. [`Limits::default`] is what
/// `nes watch --serve` uses; tests shorten the times.
#[derive(Debug, Clone)]
pub struct Limits {
    /// The request line and headers must all arrive within this time of
    /// the connection's acceptance, however slowly the bytes come: a
    /// timeout per read would let a byte every few seconds hold a thread
    /// for ever.
    pub head_deadline: Duration,
    /// The request line and headers together; a longer head is refused
    /// with 431 without reading more of it.
    pub head_bytes: usize,
    /// Header lines after the request line.
    pub header_lines: usize,
    /// Connections open at once, event streams included; the next one is
    /// answered 503 by the accepting thread and closed.
    pub connections: usize,
    /// Event streams open at once, fewer than `connections` so that pages
    /// left open elsewhere cannot stop images from being fetched.
    pub event_streams: usize,
    /// A write that blocks this long (a client that stopped reading) ends
    /// its connection.
    pub write_timeout: Duration,
    /// After an answer, how long the rest of the client's request is read
    /// and thrown away. Closing a socket with bytes unread sends a reset,
    /// which can destroy the answer before the client reads it.
    pub linger: Duration,
}

impl Default for Limits {
    fn default() -> Limits {
        Limits {
            head_deadline: Duration::from_secs(5),
            head_bytes: 16 * 1024,
            header_lines: 100,
            connections: 64,
            event_streams: 16,
            write_timeout: Duration::from_secs(10),
            linger: Duration::from_secs(2),
        }
    }
}

/// Places for at most `max` holders; a [`Slot`] gives its place back when
/// dropped, however its thread ends.
struct Slots {
    held: AtomicUsize,
    max: usize,
}

struct Slot(Arc<Slots>);

impl Slots {
    fn new(max: usize) -> Arc<Slots> {
        Arc::new(Slots {
            held: AtomicUsize::new(0),
            max,
        })
    }

    fn take(self: &Arc<Slots>) -> Option<Slot> {
        self.held
            .fetch_update(Ordering::SeqCst, Ordering::SeqCst, |n| {
                (n < self.max).then_some(n + 1)
            })
            .ok()?;
        Some(Slot(self.clone()))
    }
}

impl Drop for Slot {
    fn drop(&mut self) {
        self.0.held.fetch_sub(1, Ordering::SeqCst);
    }
}

struct Server {
    board: Arc<Board>,
    limits: Limits,
    connections: Arc<Slots>,
    event_streams: Arc<Slots>,
}

/// Starts serving `board` on `addr` within `limits`; returns the address
/// bound (the port chosen by the system when `addr` asks for port 0).
pub fn start(addr: SocketAddr, board: Arc<Board>, limits: Limits) -> io::Result<SocketAddr> {
    let listener = TcpListener::bind(addr)?;
    let bound = listener.local_addr()?;
    let server = Arc::new(Server {
        board,
        connections: Slots::new(limits.connections),
        event_streams: Slots::new(limits.event_streams),
        limits,
    });
    std::thread::Builder::new()
        .name("nes-serve".into())
        .spawn(move || loop {
            match listener.accept() {
                Ok((stream, _)) => server.admit(stream),
                // Out of file descriptors, most likely: accepting again at
                // once would spin.
                Err(_) => std::thread::sleep(Duration::from_millis(10)),
            }
        })?;
    Ok(bound)
}

impl Server {
    fn admit(self: &Arc<Server>, stream: TcpStream) {
        let accepted = Instant::now();
        let Some(slot) = self.connections.take() else {
            turn_away(stream);
            return;
        };
        let server = self.clone();
        // Should the thread not start, the closure is dropped with the
        // stream and the slot: the connection closes, the place is free.
        let _ = std::thread::Builder::new()
            .name("nes-client".into())
            .spawn(move || {
                let _slot = slot;
                let _ = server.serve(stream, accepted);
            });
    }

    fn serve(&self, mut stream: TcpStream, accepted: Instant) -> io::Result<()> {
        stream.set_write_timeout(Some(self.limits.write_timeout))?;
        let deadline = accepted + self.limits.head_deadline;
        let (response, with_body) = match read_head(&mut stream, deadline, &self.limits) {
            Ok(head) => {
                let with_body = head.method != "HEAD";
                match reply(&head, stream.local_addr()?.ip(), &self.board) {
                    Reply::Whole(response) => (response, with_body),
                    Reply::Events if !with_body => {
                        stream.write_all(EVENTS_HEAD.as_bytes())?;
                        linger(stream, &self.limits);
                        return Ok(());
                    }
                    Reply::Events => match self.event_streams.take() {
                        Some(_slot) => return events(stream, &self.board),
                        None => (
                            Response::text("503 Service Unavailable", "too many event streams\n"),
                            true,
                        ),
                    },
                }
            }
            Err(Refusal::Gone) => return Ok(()),
            // No lingering: the client has had its time.
            Err(Refusal::Late) => {
                let late = Response::text("408 Request Timeout", "the request came too slowly\n");
                return send(&mut stream, &late, true);
            }
            Err(Refusal::TooLarge) => (
                Response::text(
                    "431 Request Header Fields Too Large",
                    "the request's headers are too large\n",
                ),
                true,
            ),
            Err(Refusal::Malformed(why)) => (Response::text("400 Bad Request", why), true),
        };
        send(&mut stream, &response, with_body)?;
        linger(stream, &self.limits);
        Ok(())
    }
}

/// Over the cap: answered by the accepting thread without waiting on the
/// client, so a flood of connections holds no thread.
fn turn_away(mut stream: TcpStream) {
    let _ = stream.set_nonblocking(true);
    let busy = Response::text("503 Service Unavailable", "too many connections\n");
    let _ = send(&mut stream, &busy, true);
    let _ = stream.shutdown(Shutdown::Write);
    // A request that has already arrived is read away (as much as is
    // there, never waiting), so that closing ends the connection rather
    // than resetting it over the answer.
    let mut sink = [0; 4096];
    for _ in 0..16 {
        if !matches!(stream.read(&mut sink), Ok(n) if n > 0) {
            break;
        }
    }
}

/// Ends a connection after its answer: what is left of the request (a
/// body, the rest of an oversized head) is read and thrown away until the
/// client closes or `limits.linger` passes, so that it reads the answer,
/// not a reset.
fn linger(mut stream: TcpStream, limits: &Limits) {
    let _ = stream.shutdown(Shutdown::Write);
    let until = Instant::now() + limits.linger;
    let mut sink = [0; 8192];
    while matches!(stream.read_before(&mut sink, until), Ok(n) if n > 0) {}
}

/// Reads that give up at a deadline, however slowly the bytes come.
trait ReadBefore {
    fn read_before(&mut self, buf: &mut [u8], deadline: Instant) -> io::Result<usize>;
}

impl ReadBefore for TcpStream {
    fn read_before(&mut self, buf: &mut [u8], deadline: Instant) -> io::Result<usize> {
        let left = deadline.saturating_duration_since(Instant::now());
        // A zero timeout would mean none at all.
        if left.is_zero() {
            return Err(io::ErrorKind::TimedOut.into());
        }
        self.set_read_timeout(Some(left))?;
        self.read(buf)
    }
}

/// A request's line and the one header this server reads.
#[derive(Debug, Clone, PartialEq)]
struct Head {
    method: String,
    target: String,
    version: String,
    host: Option<String>,
}

/// Why a head was not read.
#[derive(Debug, PartialEq)]
enum Refusal {
    /// The client closed, or the connection failed, before the head
    /// ended: there is no one to answer.
    Gone,
    /// The head was not whole by the deadline.
    Late,
    /// Over the cap on bytes or lines.
    TooLarge,
    /// Not a request this server understands; the reason is the answer's
    /// body.
    Malformed(&'static str),
}

/// Reads a request's line and headers, all of them by `deadline` and
/// within `limits`' caps, holding no more than `limits.head_bytes`. Bytes
/// after the head (a body) may be read too and are ignored.
fn read_head(
    source: &mut impl ReadBefore,
    deadline: Instant,
    limits: &Limits,
) -> Result<Head, Refusal> {
    let mut buf = vec![0; limits.head_bytes];
    let (mut len, mut line_start, mut lines) = (0, 0, 0);
    loop {
        if len == buf.len() {
            return Err(Refusal::TooLarge);
        }
        let n = match source.read_before(&mut buf[len..], deadline) {
            Ok(0) => return Err(Refusal::Gone),
            Ok(n) => n,
            Err(e) if e.kind() == io::ErrorKind::Interrupted => continue,
            Err(e)
                if matches!(
                    e.kind(),
                    io::ErrorKind::WouldBlock | io::ErrorKind::TimedOut
                ) =>
            {
                return Err(Refusal::Late)
            }
            Err(_) => return Err(Refusal::Gone),
        };
        for end in len..len + n {
            if buf[end] != b'\n' {
                continue;
            }
            let line = &buf[line_start..end];
            let empty = line.is_empty() || line == b"\r";
            if empty && lines > 0 {
                return parse_head(&buf[..line_start]);
            }
            // Empty lines before the request line are skipped (RFC 9112
            // 2.2); they count towards the bytes, not the lines.
            if !empty {
                lines += 1;
                if lines > limits.header_lines + 1 {
                    return Err(Refusal::TooLarge);
                }
            }
            line_start = end + 1;
        }
        len += n;
    }
}

/// The request line and the Host header of a whole head, each line ended
/// by `\n` or `\r\n`; leading empty lines allowed.
fn parse_head(head: &[u8]) -> Result<Head, Refusal> {
    let mut lines = head
        .split(|&b| b == b'\n')
        .map(|line| line.strip_suffix(b"\r").unwrap_or(line))
        .filter(|line| !line.is_empty());
    let request_line = lines.next().unwrap_or_default();
    let request_line = std::str::from_utf8(request_line)
        .map_err(|_| Refusal::Malformed("the request line is not text\n"))?;
    let [method, target, version] = request_line
        .split(' ')
        .collect::<Vec<_>>()
        .try_into()
        .map_err(|_| Refusal::Malformed("the request line is not METHOD PATH VERSION\n"))?;
    if method.is_empty() || !method.bytes().all(|b| b.is_ascii_alphabetic()) {
        return Err(Refusal::Malformed("the method is not a word\n"));
    }
    if version != "HTTP/1.1" && version != "HTTP/1.0" {
        return Err(Refusal::Malformed(
            "only HTTP/1.0 and HTTP/1.1 are spoken\n",
        ));
    }
    // Absolute URLs are for proxies, and `*` is for OPTIONS.
    if !target.starts_with('/') {
        return Err(Refusal::Malformed("the target is not a path\n"));
    }
    let mut host = None;
    for line in lines {
        if line[0] == b' ' || line[0] == b'\t' {
            return Err(Refusal::Malformed("a folded header line\n"));
        }
        let colon = line
            .iter()
            .position(|&b| b == b':')
            .ok_or(Refusal::Malformed("a header line without a colon\n"))?;
        let name = &line[..colon];
        if name.iter().any(|b| b.is_ascii_whitespace()) {
            return Err(Refusal::Malformed("a space in a header's name\n"));
        }
        if name.eq_ignore_ascii_case(b"host") {
            let value = std::str::from_utf8(&line[colon + 1..])
                .map_err(|_| Refusal::Malformed("the Host header is not text\n"))?;
            if host.replace(value.trim().to_string()).is_some() {
                return Err(Refusal::Malformed("more than one Host header\n"));
            }
        }
    }
    Ok(Head {
        method: method.into(),
        target: target.into(),
        version: version.into(),
        host,
    })
}

/// The name part of a `Host` value (`name`, `name:port`, `[v6]:port`), or
/// `None` if it is not of that form.
fn host_name(host: &str) -> Option<&str> {
    let (name, port) = match host.strip_prefix('[') {
        Some(rest) => {
            let close = rest.find(']')?;
            let after = &rest[close + 1..];
            let port = match after {
                "" => None,
                _ => Some(after.strip_prefix(':')?),
            };
            (&host[..close + 2], port)
        }
        None => match host.split_once(':') {
            Some((name, port)) => (name, Some(port)),
            None => (host, None),
        },
    };
    let port_ok = port.is_none_or(|p| p.len() <= 5 && p.bytes().all(|b| b.is_ascii_digit()));
    let name_ok = name.starts_with('[')
        || name
            .bytes()
            .all(|b| b.is_ascii_alphanumeric() || b"-._".contains(&b));
    (!name.is_empty() && name_ok && port_ok).then_some(name)
}

/// Whether `host` names this server as reached at `local`: that address,
/// or a loopback name; any port. `None`: not a host at all.
fn host_is_ours(host: &str, local: IpAddr) -> Option<bool> {
    let name = host_name(host)?;
    if name.eq_ignore_ascii_case("localhost") {
        return Some(true);
    }
    let ip = match name.strip_prefix('[').and_then(|n| n.strip_suffix(']')) {
        Some(v6) => IpAddr::V6(v6.parse::<Ipv6Addr>().ok()?),
        None => match name.parse::<Ipv4Addr>() {
            Ok(v4) => IpAddr::V4(v4),
            // A name: whoever controls its DNS may point it here.
            Err(_) => return Some(false),
        },
    };
    let loopback = [
        IpAddr::V4(Ipv4Addr::LOCALHOST),
        IpAddr::V6(Ipv6Addr::LOCALHOST),
    ];
    // A server on [::] sees IPv4 clients at ::ffff:a.b.c.d.
    Some(ip.to_canonical() == local.to_canonical() || loopback.contains(&ip))
}

enum Body {
    Static(&'static [u8]),
    Shared(Arc<Vec<u8>>),
}

impl Body {
    fn bytes(&self) -> &[u8] {
        match self {
            Body::Static(bytes) => bytes,
            Body::Shared(bytes) => bytes,
        }
    }
}

/// A whole answer, after which the connection closes.
struct Response {
    status: &'static str,
    kind: &'static str,
    body: Body,
    /// A 405: says which methods are.
    allow: bool,
}

impl Response {
    fn new(status: &'static str, kind: &'static str, body: Body) -> Response {
        Response {
            status,
            kind,
            body,
            allow: false,
        }
    }

    fn text(status: &'static str, text: &'static str) -> Response {
        Response::new(status, "text/plain", Body::Static(text.as_bytes()))
    }
}

enum Reply {
    Whole(Response),
    Events,
}

const PAGE: &str = include_str!("serve.html");

fn reply(head: &Head, local: IpAddr, board: &Board) -> Reply {
    let refuse = |status, text| Reply::Whole(Response::text(status, text));
    match &head.host {
        // HTTP/1.0 had no Host; a browser always sends one.
        None if head.version == "HTTP/1.0" => {}
        None => return refuse("400 Bad Request", "no Host header\n"),
        Some(host) => match host_is_ours(host, local) {
            Some(true) => {}
            Some(false) => {
                return refuse(
                    "403 Forbidden",
                    "this server answers to its own address and to localhost only\n",
                )
            }
            None => return refuse("400 Bad Request", "the Host header is not host[:port]\n"),
        },
    }
    if head.method != "GET" && head.method != "HEAD" {
        return Reply::Whole(Response {
            allow: true,
            ..Response::text("405 Method Not Allowed", "GET and HEAD only\n")
        });
    }
    let path = head.target.split('?').next().unwrap_or_default();
    let whole = |kind, body| Reply::Whole(Response::new("200 OK", kind, body));
    match path {
        "/" | "/index.html" => whole("text/html; charset=utf-8", Body::Static(PAGE.as_bytes())),
        "/image.png" => match board.snapshot().png {
            Some(png) => whole("image/png", Body::Shared(png)),
            None => refuse("404 Not Found", "no image yet\n"),
        },
        "/events" => Reply::Events,
        _ => refuse("404 Not Found", "not found\n"),
    }
}

/// Writes `response`; a HEAD's answer has the same head (Content-Length
/// included) and no body.
fn send(stream: &mut TcpStream, response: &Response, with_body: bool) -> io::Result<()> {
    let body = response.body.bytes();
    let allow = if response.allow {
        "Allow: GET, HEAD\r\n"
    } else {
        ""
    };
    let head = format!(
        "HTTP/1.1 {}\r\nContent-Type: {}\r\nContent-Length: {}\r\n{allow}Cache-Control: no-store\r\nConnection: close\r\n\r\n",
        response.status,
        response.kind,
        body.len()
    );
    stream.write_all(head.as_bytes())?;
    if with_body {
        stream.write_all(body)?;
    }
    stream.flush()
}

const EVENTS_HEAD: &str = "HTTP/1.1 200 OK\r\nContent-Type: text/event-stream\r\nCache-Control: no-store\r\nConnection: keep-alive\r\n\r\n";

/// A server-sent event stream: the current state at once, then every
/// change; a comment every 15 s finds clients that went away.
fn events(mut stream: TcpStream, board: &Board) -> io::Result<()> {
    stream.write_all(EVENTS_HEAD.as_bytes())?;
    let (mut seen, mut image_sent) = (u64::MAX, u64::MAX);
    let mut warnings_sent = String::new();
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
            if now.warnings != warnings_sent {
                // An empty event clears them.
                let mut message = String::from("event: warnings\n");
                for line in now.warnings.lines() {
                    message += &format!("data: {line}\n");
                }
                if now.warnings.is_empty() {
                    message += "data:\n";
                }
                message.push('\n');
                stream.write_all(message.as_bytes())?;
                warnings_sent = now.warnings;
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

#[cfg(test)]
mod tests {
    use super::*;

    /// Bytes handed over a few at a time, then an endless run of `a`; it
    /// counts what was taken from it.
    struct Trickle {
        bytes: Vec<u8>,
        at: usize,
        per_read: usize,
    }

    impl ReadBefore for Trickle {
        fn read_before(&mut self, buf: &mut [u8], _: Instant) -> io::Result<usize> {
            let n = buf.len().min(self.per_read);
            for b in &mut buf[..n] {
                *b = self.bytes.get(self.at).copied().unwrap_or(b'a');
                self.at += 1;
            }
            Ok(n)
        }
    }

    fn read(text: &str, per_read: usize) -> (Result<Head, Refusal>, usize) {
        let mut source = Trickle {
            bytes: text.as_bytes().to_vec(),
            at: 0,
            per_read,
        };
        let head = read_head(&mut source, Instant::now(), &Limits::default());
        (head, source.at)
    }

    #[test]
    fn a_head_is_read_whole_however_it_is_split() {
        let text =
            "\r\nGET /image.png?v=3 HTTP/1.1\r\nhOsT:  localhost:8737 \r\nAccept: */*\r\n\r\n";
        let want = Head {
            method: "GET".into(),
            target: "/image.png?v=3".into(),
            version: "HTTP/1.1".into(),
            host: Some("localhost:8737".into()),
        };
        for per_read in [1, 2, 7, 4096] {
            assert_eq!(read(text, per_read).0, Ok(want.clone()));
        }
        assert_eq!(read("GET / HTTP/1.0\n\n", 3).0.unwrap().host, None);
    }

    #[test]
    fn a_head_over_a_cap_is_refused_without_reading_past_the_cap() {
        let limits = Limits::default();
        // One endless line, then a short head of too many lines.
        let (head, taken) = read("GET / HTTP/1.1\r\nX-Big: ", 1000);
        assert_eq!(head, Err(Refusal::TooLarge));
        assert!(taken <= limits.head_bytes, "{taken} bytes read");
        let many = "GET / HTTP/1.1\r\n".to_string() + &"X: 1\r\n".repeat(limits.header_lines + 1);
        assert!(many.len() < limits.head_bytes);
        assert_eq!(read(&many, 64).0, Err(Refusal::TooLarge));
        let enough = "GET / HTTP/1.1\r\n".to_string() + &"X: 1\r\n".repeat(limits.header_lines);
        assert!(read(&(enough + "\r\n"), 64).0.is_ok());
    }

    #[test]
    fn malformed_heads_are_refused() {
        for text in [
            "GET /\r\n\r\n",
            "GET / HTTP/2\r\n\r\n",
            "GET http://localhost/ HTTP/1.1\r\nHost: localhost\r\n\r\n",
            "GET / HTTP/1.1\r\nHost: a\r\nHost: b\r\n\r\n",
            "GET / HTTP/1.1\r\nHost: a\r\n folded\r\n\r\n",
            "GET / HTTP/1.1\r\nno colon\r\n\r\n",
            "GET / HTTP/1.1\r\nHost : a\r\n\r\n",
        ] {
            assert!(
                matches!(read(text, 4096).0, Err(Refusal::Malformed(_))),
                "{text:?}"
            );
        }
    }

    #[test]
    fn hosts_are_this_address_or_loopback_names() {
        let lan: IpAddr = "192.168.1.20".parse().unwrap();
        let mapped: IpAddr = "::ffff:192.168.1.20".parse().unwrap();
        for (host, local, ours) in [
            ("localhost", lan, Some(true)),
            ("LocalHost:8737", lan, Some(true)),
            ("127.0.0.1:8737", lan, Some(true)),
            ("[::1]:8737", lan, Some(true)),
            ("[::1]", lan, Some(true)),
            ("192.168.1.20:8737", lan, Some(true)),
            ("192.168.1.20", mapped, Some(true)),
            ("192.168.1.21", lan, Some(false)),
            ("127.0.0.2", lan, Some(false)),
            ("evil.example", lan, Some(false)),
            ("preview.localhost", lan, Some(false)),
            ("localhost.", lan, Some(false)),
            ("", lan, None),
            (":8737", lan, None),
            ("localhost:http", lan, None),
            ("a:b:c", lan, None),
            ("local host", lan, None),
            ("[::1", lan, None),
            ("[::1]x", lan, None),
            ("[evil]", lan, None),
        ] {
            assert_eq!(host_is_ours(host, local), ours, "{host:?} at {local}");
        }
    }
}
