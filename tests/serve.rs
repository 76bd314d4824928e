//! The preview server of `nes watch --serve` against clients that abuse
//! it, over real sockets on 127.0.0.1: slow heads, huge heads, floods of
//! connections, foreign Host headers, methods other than GET. Each test
//! starts its own server on port 0 with limits made small or short where
//! the test needs it; margins are generous, and nothing asserts speed.

use std::io::{BufRead, BufReader, ErrorKind, Read, Write};
use std::net::{SocketAddr, TcpStream};
use std::sync::Arc;
use std::time::{Duration, Instant};

use nes::live::serve::{start, Board, Limits};

/// What `/image.png` serves in these tests; the server does not look
/// inside it.
const IMAGE: &[u8] = b"\x89PNG\r\n\x1a\n not really an image";

fn serve(limits: Limits) -> (SocketAddr, Arc<Board>) {
    let board = Board::new();
    board.publish_image(IMAGE.to_vec());
    let addr = start("127.0.0.1:0".parse().unwrap(), board.clone(), limits).unwrap();
    (addr, board)
}

struct Answer {
    status: u16,
    head: String,
    body: Vec<u8>,
}

impl Answer {
    fn header(&self, name: &str) -> Option<&str> {
        self.head.lines().skip(1).find_map(|line| {
            let (n, value) = line.split_once(':')?;
            n.eq_ignore_ascii_case(name).then(|| value.trim())
        })
    }
}

/// Everything the server sends until it closes (a reset after the answer
/// counts as closing), split into head and body.
fn read_answer(mut stream: TcpStream) -> Answer {
    stream
        .set_read_timeout(Some(Duration::from_secs(20)))
        .unwrap();
    let mut bytes = Vec::new();
    let mut buf = [0; 8192];
    loop {
        match stream.read(&mut buf) {
            Ok(0) => break,
            Ok(n) => bytes.extend_from_slice(&buf[..n]),
            Err(e) if matches!(e.kind(), ErrorKind::WouldBlock | ErrorKind::TimedOut) => {
                panic!("the server neither answered nor closed")
            }
            Err(_) => break,
        }
    }
    let end = bytes
        .windows(4)
        .position(|w| w == b"\r\n\r\n")
        .unwrap_or_else(|| panic!("no whole head in {:?}", String::from_utf8_lossy(&bytes)));
    let head = String::from_utf8_lossy(&bytes[..end]).to_string();
    let status = head.split_whitespace().nth(1).unwrap().parse().unwrap();
    Answer {
        status,
        head,
        body: bytes[end + 4..].to_vec(),
    }
}

fn ask(addr: SocketAddr, request: &str) -> Answer {
    let mut stream = TcpStream::connect(addr).unwrap();
    stream.write_all(request.as_bytes()).unwrap();
    read_answer(stream)
}

fn get(addr: SocketAddr, path: &str) -> Answer {
    ask(
        addr,
        &format!("GET {path} HTTP/1.1\r\nHost: {addr}\r\n\r\n"),
    )
}

fn wait_until(what: &str, mut ok: impl FnMut() -> bool) {
    let start = Instant::now();
    while !ok() {
        assert!(
            start.elapsed() < Duration::from_secs(20),
            "timed out waiting for {what}"
        );
        std::thread::sleep(Duration::from_millis(20));
    }
}

/// Sends a head one byte every 300 ms, never ending it, until the server
/// closes the connection; how long after `connected` that was, and what
/// the server said first.
fn trickle(mut stream: TcpStream, connected: Instant) -> (Duration, Vec<u8>) {
    stream
        .set_read_timeout(Some(Duration::from_millis(300)))
        .unwrap();
    stream
        .write_all(b"GET / HTTP/1.1\r\nHost: 127.0.0.1\r\nX-Slow: ")
        .unwrap();
    let mut said = Vec::new();
    let mut buf = [0; 1024];
    loop {
        assert!(
            connected.elapsed() < Duration::from_secs(60),
            "the slow client was never dropped"
        );
        if said.is_empty() {
            // After the answer, a byte more would only draw a reset.
            let _ = stream.write_all(b"a");
        }
        match stream.read(&mut buf) {
            Ok(0) => break,
            Ok(n) => said.extend_from_slice(&buf[..n]),
            Err(e) if matches!(e.kind(), ErrorKind::WouldBlock | ErrorKind::TimedOut) => {}
            Err(_) => break,
        }
    }
    (connected.elapsed(), said)
}

fn assert_dropped_at_deadline((after, said): (Duration, Vec<u8>), deadline: Duration) {
    // A timeout per read would never fire: a byte comes every 300 ms.
    assert!(
        after > deadline / 2 && after < deadline + Duration::from_secs(3),
        "dropped after {after:?}, the deadline being {deadline:?}"
    );
    assert!(
        said.is_empty() || said.starts_with(b"HTTP/1.1 408 "),
        "{}",
        String::from_utf8_lossy(&said)
    );
}

#[test]
fn a_head_that_trickles_in_is_dropped_at_the_deadline() {
    let deadline = Duration::from_secs(1);
    let (addr, _board) = serve(Limits {
        head_deadline: deadline,
        ..Limits::default()
    });
    let stream = TcpStream::connect(addr).unwrap();
    assert_dropped_at_deadline(trickle(stream, Instant::now()), deadline);
    assert_eq!(get(addr, "/").status, 200);
}

#[test]
fn slow_clients_up_to_the_cap_turn_the_next_away_until_the_deadline_drops_them() {
    let deadline = Duration::from_secs(2);
    let (addr, _board) = serve(Limits {
        head_deadline: deadline,
        connections: 4,
        ..Limits::default()
    });
    let slow: Vec<_> = (0..4)
        .map(|_| {
            let stream = TcpStream::connect(addr).unwrap();
            let connected = Instant::now();
            std::thread::spawn(move || trickle(stream, connected))
        })
        .collect();
    // The server accepts in order, so these four hold every place.
    let busy = get(addr, "/");
    assert_eq!(busy.status, 503, "{}", busy.head);
    for client in slow {
        assert_dropped_at_deadline(client.join().unwrap(), deadline);
    }
    // A place is given back when its thread ends, just after the close.
    wait_until("a place for a normal request", || {
        let answer = get(addr, "/");
        assert!([200, 503].contains(&answer.status), "{}", answer.head);
        answer.status == 200
    });
}

#[test]
fn idle_connections_over_the_cap_turn_the_next_away_at_once() {
    let (addr, _board) = serve(Limits {
        head_deadline: Duration::from_secs(60),
        connections: 3,
        ..Limits::default()
    });
    let idle: Vec<_> = (0..3).map(|_| TcpStream::connect(addr).unwrap()).collect();
    // Answered without a request: the accepting thread says no and closes.
    let turned_away = read_answer(TcpStream::connect(addr).unwrap());
    assert_eq!(turned_away.status, 503);
    assert_eq!(turned_away.header("Connection"), Some("close"));
    let with_request = get(addr, "/image.png");
    assert_eq!(with_request.status, 503);
    assert!(!with_request.body.starts_with(IMAGE));
    // The places come back when the idle clients leave, not at a timeout.
    drop(idle);
    wait_until("the idle connections' places", || {
        get(addr, "/").status == 200
    });
    assert_eq!(get(addr, "/image.png").body, IMAGE);
}

#[test]
fn an_oversized_head_gets_431_and_the_server_stays_responsive() {
    let (addr, _board) = serve(Limits::default());
    let stream = TcpStream::connect(addr).unwrap();
    let mut writer = stream.try_clone().unwrap();
    // The server stops reading the head at its cap; the writer may fail
    // once it closes, which is fine.
    let sending = std::thread::spawn(move || {
        let mut line = b"GET / HTTP/1.1\r\nHost: 127.0.0.1\r\nX-Big: ".to_vec();
        line.resize(line.len() + 1024 * 1024, b'a');
        let _ = writer.write_all(&line);
    });
    let answer = read_answer(stream);
    assert_eq!(answer.status, 431, "{}", answer.head);
    assert_eq!(answer.header("Connection"), Some("close"));
    sending.join().unwrap();

    // Short lines, but too many of them.
    let many =
        format!("GET / HTTP/1.1\r\nHost: {addr}\r\n") + &"X-Line: 1\r\n".repeat(500) + "\r\n";
    assert_eq!(ask(addr, &many).status, 431);

    let page = get(addr, "/");
    assert_eq!(page.status, 200);
    assert!(String::from_utf8_lossy(&page.body).contains("EventSource(\"/events\")"));
}

#[test]
fn only_this_address_and_loopback_names_are_answered() {
    let (addr, _board) = serve(Limits::default());
    let port = addr.port();
    let with_host = |path: &str, host: &str| {
        ask(
            addr,
            &format!("GET {path} HTTP/1.1\r\nHost: {host}\r\n\r\n"),
        )
    };
    // A page on a name rebound to this machine cannot read the image.
    for host in [
        "evil.example".to_string(),
        format!("evil.example:{port}"),
        format!("127.0.0.1.evil.example:{port}"),
        // Refused too: only the names listed in serve.rs are answered.
        format!("preview.localhost:{port}"),
    ] {
        for path in ["/", "/image.png", "/events"] {
            let answer = with_host(path, &host);
            assert_eq!(answer.status, 403, "{path} for {host}");
            assert!(!answer.body.starts_with(IMAGE));
        }
    }
    for host in [
        format!("127.0.0.1:{port}"),
        format!("localhost:{port}"),
        "localhost".to_string(),
        format!("[::1]:{port}"),
    ] {
        let answer = with_host("/image.png", &host);
        assert_eq!(answer.status, 200, "{host}");
        assert_eq!(answer.body, IMAGE);
    }
    assert_eq!(with_host("/", "local host").status, 400);
    assert_eq!(ask(addr, "GET / HTTP/1.1\r\n\r\n").status, 400);
    // HTTP/1.0 had no Host header.
    assert_eq!(ask(addr, "GET / HTTP/1.0\r\n\r\n").status, 200);
}

/// Listening on one address answers a Host of that address, which is not
/// a loopback name (Linux: all of 127.0.0.0/8 is this machine).
#[cfg(target_os = "linux")]
#[test]
fn a_server_on_another_address_answers_to_that_address() {
    let board = Board::new();
    board.publish_image(IMAGE.to_vec());
    let addr = start(
        "127.0.0.2:0".parse().unwrap(),
        board.clone(),
        Limits::default(),
    )
    .unwrap();
    let with_host = |host: &str| ask(addr, &format!("GET / HTTP/1.1\r\nHost: {host}\r\n\r\n"));
    assert_eq!(with_host(&addr.to_string()).status, 200);
    assert_eq!(with_host("127.0.0.2").status, 200);
    assert_eq!(with_host("localhost").status, 200);
    assert_eq!(with_host("127.0.0.3").status, 403);
    assert_eq!(with_host("evil.example").status, 403);
}

#[test]
fn head_is_answered_like_get_without_a_body() {
    let (addr, _board) = serve(Limits::default());
    for path in ["/", "/image.png", "/nothing-here"] {
        let got = get(addr, path);
        let head = ask(
            addr,
            &format!("HEAD {path} HTTP/1.1\r\nHost: {addr}\r\n\r\n"),
        );
        assert_eq!(head.status, got.status, "{path}");
        assert_eq!(head.head, got.head, "{path}");
        assert_eq!(
            head.header("Content-Length"),
            Some(got.body.len().to_string().as_str())
        );
        assert!(head.body.is_empty(), "{path}: {} bytes", head.body.len());
    }
    let events = ask(
        addr,
        &format!("HEAD /events HTTP/1.1\r\nHost: {addr}\r\n\r\n"),
    );
    assert_eq!(events.status, 200);
    assert_eq!(events.header("Content-Type"), Some("text/event-stream"));
    assert!(events.body.is_empty());
}

#[test]
fn other_methods_get_405_with_the_allowed_ones() {
    let (addr, _board) = serve(Limits::default());
    let post = ask(
        addr,
        &format!("POST / HTTP/1.1\r\nHost: {addr}\r\nContent-Length: 5\r\n\r\nhello"),
    );
    assert_eq!(post.status, 405);
    assert_eq!(post.header("Allow"), Some("GET, HEAD"));
    for method in ["PUT", "DELETE", "OPTIONS"] {
        let answer = ask(
            addr,
            &format!("{method} /image.png HTTP/1.1\r\nHost: {addr}\r\n\r\n"),
        );
        assert_eq!(answer.status, 405, "{method}");
        assert_eq!(answer.header("Allow"), Some("GET, HEAD"));
    }
}

/// Opens `/events`; the returned function reads up to the next event's name.
fn event_stream(addr: SocketAddr) -> impl FnMut() -> String {
    let stream = TcpStream::connect(addr).unwrap();
    stream
        .set_read_timeout(Some(Duration::from_secs(20)))
        .unwrap();
    let mut writer = stream.try_clone().unwrap();
    write!(writer, "GET /events HTTP/1.1\r\nHost: {addr}\r\n\r\n").unwrap();
    let mut lines = BufReader::new(stream).lines();
    let status = lines.next().unwrap().unwrap();
    assert!(status.starts_with("HTTP/1.1 200 "), "{status}");
    move || loop {
        let line = lines.next().expect("the stream stays open").unwrap();
        if let Some(name) = line.strip_prefix("event: ") {
            return name.to_string();
        }
    }
}

#[test]
fn event_streams_have_a_cap_of_their_own_and_free_it_when_the_page_goes() {
    let (addr, board) = serve(Limits {
        connections: 8,
        event_streams: 2,
        ..Limits::default()
    });
    let mut first = event_stream(addr);
    let mut second = event_stream(addr);
    assert_eq!(first(), "image");
    assert_eq!(second(), "image");
    assert_eq!(get(addr, "/events").status, 503);
    // The image still loads with every stream taken.
    assert_eq!(get(addr, "/image.png").body, IMAGE);
    board.publish_diagnostics("E0101 unknown shape".into());
    assert_eq!(first(), "diagnostics");
    assert_eq!(second(), "diagnostics");

    // A closed page's stream ends at the next write that fails, and its
    // place serves a new page.
    drop(second);
    let mut third = None;
    wait_until("a place for a new event stream", || {
        board.publish_image(IMAGE.to_vec());
        let stream = TcpStream::connect(addr).unwrap();
        write!(&stream, "GET /events HTTP/1.1\r\nHost: {addr}\r\n\r\n").unwrap();
        let mut status = String::new();
        BufReader::new(&stream).read_line(&mut status).unwrap();
        let open = status.starts_with("HTTP/1.1 200 ");
        if open {
            third = Some(stream);
        }
        open
    });
    assert!(third.is_some());
    assert_eq!(first(), "image");
}
