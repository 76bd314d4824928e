//! `nes watch`, driven as a user would: a real process on a temporary
//! scene file, edited by writing and by renaming over it, and its preview
//! server spoken to over HTTP.

use std::io::{BufRead, BufReader, Read, Write};
use std::net::TcpStream;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

fn scene(background: &str) -> String {
    format!(
        "camera {{ position (-6, 0, 1) look_at (0, 0, 0) width 80 height 50 }}\n\
         background {background}\n\
         light {{ position (-3, -4, 5) }}\n\
         object sphere(1) {{ colour orange }}\n"
    )
}

struct Watch {
    child: Child,
    stderr: Arc<Mutex<String>>,
    stdout: Arc<Mutex<String>>,
    dir: PathBuf,
}

impl Watch {
    fn start(name: &str, first: &str, extra: &[&str]) -> Watch {
        let dir = std::env::temp_dir().join(format!("nes-watch-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        std::fs::write(dir.join("scene.nes"), first).unwrap();
        let mut child = Command::new(env!("CARGO_BIN_EXE_nes"))
            .arg("watch")
            .arg(dir.join("scene.nes"))
            .arg("-o")
            .arg(dir.join("out.png"))
            .args(extra)
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
        let collect = |pipe: Box<dyn Read + Send>| {
            let text = Arc::new(Mutex::new(String::new()));
            let sink = text.clone();
            std::thread::spawn(move || {
                for line in BufReader::new(pipe).lines().map_while(Result::ok) {
                    let mut s = sink.lock().unwrap();
                    s.push_str(&line);
                    s.push('\n');
                }
            });
            text
        };
        let stderr = collect(Box::new(child.stderr.take().unwrap()));
        let stdout = collect(Box::new(child.stdout.take().unwrap()));
        Watch {
            child,
            stderr,
            stdout,
            dir,
        }
    }

    fn output(&self) -> PathBuf {
        self.dir.join("out.png")
    }

    fn save(&self, text: &str) {
        std::fs::write(self.dir.join("scene.nes"), text).unwrap();
    }

    /// The way many editors save: a temporary file renamed over the scene.
    fn save_by_rename(&self, text: &str) {
        let tmp = self.dir.join(".scene.nes.swp");
        std::fs::write(&tmp, text).unwrap();
        std::fs::rename(&tmp, self.dir.join("scene.nes")).unwrap();
    }

    fn full_renders(&self) -> usize {
        self.stderr.lock().unwrap().matches(", full ").count()
    }

    fn stderr(&self) -> String {
        self.stderr.lock().unwrap().clone()
    }
}

impl Drop for Watch {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
        let _ = std::fs::remove_dir_all(&self.dir);
    }
}

fn wait_until(what: &str, mut ok: impl FnMut() -> bool) {
    let start = Instant::now();
    while !ok() {
        assert!(
            start.elapsed() < Duration::from_secs(20),
            "timed out waiting for {what}"
        );
        std::thread::sleep(Duration::from_millis(10));
    }
}

/// The top-left pixel of the PNG at `path` (background in these scenes).
fn corner(path: &Path) -> Option<[u8; 3]> {
    let img = image::open(path).ok()?.to_rgb8();
    Some(img.get_pixel(0, 0).0)
}

fn close(a: [u8; 3], b: [u8; 3]) -> bool {
    a.iter().zip(b).all(|(x, y)| x.abs_diff(y) <= 1)
}

#[test]
fn saves_render_and_broken_saves_keep_the_last_good_image() {
    let w = Watch::start("edits", &scene("#204060"), &[]);
    wait_until("the first full render", || w.full_renders() >= 1);
    assert!(close(corner(&w.output()).unwrap(), [0x20, 0x40, 0x60]));

    // A good save: a new image.
    w.save(&scene("#806040"));
    wait_until("the new background", || {
        corner(&w.output()).is_some_and(|c| close(c, [0x80, 0x60, 0x40]))
    });
    wait_until("the second full render", || w.full_renders() >= 2);

    // A broken save: diagnostics, and the image untouched byte for byte.
    let before = std::fs::read(w.output()).unwrap();
    w.save(&(scene("#ff0000") + "object sphre(1)\n"));
    wait_until("the diagnostic", || w.stderr().contains("E0101"));
    assert!(
        w.stderr().contains("did you mean `sphere`"),
        "{}",
        w.stderr()
    );
    std::thread::sleep(Duration::from_millis(300));
    assert_eq!(
        std::fs::read(w.output()).unwrap(),
        before,
        "a broken save changed the image"
    );

    // A save whose image cannot fit in memory: reported, the image kept,
    // and the watch goes on (its allocation once aborted the process).
    w.save(&scene("#ff0000").replace("width 80 height 50", "width 60000 height 60000"));
    wait_until("the memory diagnostic", || w.stderr().contains("E0501"));
    assert!(w.stderr().contains("60000 x 60000"), "{}", w.stderr());
    assert_eq!(
        std::fs::read(w.output()).unwrap(),
        before,
        "an oversized save changed the image"
    );

    // A rename-style save is picked up, and renders again after the error.
    w.save_by_rename(&scene("#10a010"));
    wait_until("the renamed-over scene's image", || {
        corner(&w.output()).is_some_and(|c| close(c, [0x10, 0xa0, 0x10]))
    });

    // A burst of saves ends with the image of the last one.
    let colours = [
        "#000010", "#000020", "#000030", "#000040", "#000050", "#000060",
    ];
    for c in colours {
        w.save(&scene(c));
        std::thread::sleep(Duration::from_millis(3));
    }
    wait_until("the last save's image", || {
        corner(&w.output()).is_some_and(|c| close(c, [0, 0, 0x60]))
    });
    // Settled: the full render of the last save done, nothing after it.
    std::thread::sleep(Duration::from_millis(400));
    let renders = w.full_renders();
    std::thread::sleep(Duration::from_millis(400));
    assert!(close(corner(&w.output()).unwrap(), [0, 0, 0x60]));
    assert_eq!(w.full_renders(), renders, "renders went on after the burst");
    // Every image was written atomically: no temporary file
    // (`.out.png.<pid>.tmp`) is left beside the output.
    let mut names: Vec<String> = std::fs::read_dir(&w.dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    assert_eq!(names, ["out.png", "scene.nes"]);
}

#[test]
fn a_change_to_an_imported_file_renders_again() {
    let text = "import \"lib/bg.nes\"\n\
        camera { position (-6, 0, 1) look_at (0, 0, 0) width 80 height 50 }\n\
        background bg\nobject sphere(1)\n";
    let w = Watch::start("imports", text, &[]);
    let lib = w.dir.join("lib");
    // The library's folder exists, its file not yet: an error, and the
    // file is watched for all that.
    std::fs::create_dir_all(&lib).unwrap();
    w.save(text);
    wait_until("the missing import", || w.stderr().contains("E0401"));
    std::fs::write(lib.join("bg.nes"), "let bg = #204060\n").unwrap();
    wait_until("the first image", || {
        corner(&w.output()).is_some_and(|c| close(c, [0x20, 0x40, 0x60]))
    });
    std::fs::write(lib.join("bg.nes"), "let bg = #806040\n").unwrap();
    wait_until("the library's new colour", || {
        corner(&w.output()).is_some_and(|c| close(c, [0x80, 0x60, 0x40]))
    });
    // A broken library: its diagnostic, in its own file, and the image kept.
    std::fs::write(lib.join("bg.nes"), "let bg = #80604\n").unwrap();
    wait_until("the library's diagnostic", || {
        w.stderr().contains("bg.nes:1:")
    });
    std::thread::sleep(Duration::from_millis(300));
    assert!(close(corner(&w.output()).unwrap(), [0x80, 0x60, 0x40]));
}

/// A GET request; the status code and the body (the server closes each
/// connection but the event stream).
fn get(addr: &str, path: &str) -> (u16, Vec<u8>) {
    let mut s = TcpStream::connect(addr).unwrap();
    write!(s, "GET {path} HTTP/1.1\r\nHost: {addr}\r\n\r\n").unwrap();
    let mut response = Vec::new();
    s.read_to_end(&mut response).unwrap();
    let head_end = response.windows(4).position(|w| w == b"\r\n\r\n").unwrap();
    let head = String::from_utf8_lossy(&response[..head_end]).to_string();
    let status = head.split_whitespace().nth(1).unwrap().parse().unwrap();
    (status, response[head_end + 4..].to_vec())
}

#[test]
fn the_preview_server_shows_each_save_on_loopback_only() {
    let w = Watch::start("serve", &scene("#204060"), &["--serve", "0"]);
    let mut addr = String::new();
    wait_until("the server's address", || {
        let out = w.stdout.lock().unwrap();
        match out.split("http://").nth(1) {
            Some(rest) => {
                addr = rest.trim_end().trim_end_matches('/').to_string();
                true
            }
            None => false,
        }
    });
    assert!(addr.starts_with("127.0.0.1:"), "{addr}");
    wait_until("the first full render", || w.full_renders() >= 1);

    let (status, page) = get(&addr, "/");
    assert_eq!(status, 200);
    assert!(String::from_utf8_lossy(&page).contains("EventSource(\"/events\")"));
    let (status, png) = get(&addr, "/image.png");
    assert_eq!(status, 200);
    assert_eq!(&png[..8], b"\x89PNG\r\n\x1a\n");
    // The image served is the scene's render: its size and background.
    let served = image::load_from_memory(&png).unwrap().to_rgb8();
    assert_eq!(served.dimensions(), (80, 50));
    assert!(close(served.get_pixel(0, 0).0, [0x20, 0x40, 0x60]));
    assert_eq!(get(&addr, "/scene.nes").0, 404);
    assert_eq!(get(&addr, "/../Cargo.toml").0, 404);

    // The event stream: the current image at once, then one per save.
    let mut next_event = event_stream(&addr);
    assert_eq!(next_event(), "image");
    w.save(&(scene("#ff0000") + "object sphre(1)\n"));
    assert_eq!(next_event(), "diagnostics");
    // A page opened while the scene is broken gets the last good image,
    // then the errors over it.
    let mut late = event_stream(&addr);
    assert_eq!(late(), "image");
    assert_eq!(late(), "diagnostics");
    w.save(&scene("#806040"));
    assert_eq!(next_event(), "image");
    assert_eq!(late(), "image");
    // The image the event announced is the new save's.
    wait_until("the served image of the new save", || {
        let (_, png) = get(&addr, "/image.png");
        image::load_from_memory(&png)
            .is_ok_and(|i| close(i.to_rgb8().get_pixel(0, 0).0, [0x80, 0x60, 0x40]))
    });

    // A scene with a warning: shown beside its image, and cleared by the
    // next save without one.
    drop(next_event);
    let mut with_data = event_stream_with_data(&addr);
    assert_eq!(with_data().0, "image");
    w.save(&(scene("#806040") + "object cube(0.5) rotate 1.5708 about z\n"));
    let warned = (0..3).map(|_| with_data()).find(|(e, _)| e == "warnings");
    assert!(
        warned.as_ref().is_some_and(|(_, d)| d.contains("W0001")),
        "{warned:?}"
    );
    w.save(&scene("#806040"));
    let cleared = (0..3).map(|_| with_data()).find(|(e, _)| e == "warnings");
    assert!(
        cleared.as_ref().is_some_and(|(_, d)| d.trim().is_empty()),
        "{cleared:?}"
    );

    // Bound to 127.0.0.1 itself, not to every address: on Linux all of
    // 127.0.0.0/8 reaches this machine, so a server listening on 0.0.0.0
    // would answer on 127.0.0.2 (this check needs no other interface).
    let port = addr.rsplit(':').next().unwrap();
    #[cfg(target_os = "linux")]
    {
        let other: std::net::SocketAddr = format!("127.0.0.2:{port}").parse().unwrap();
        assert!(
            TcpStream::connect_timeout(&other, Duration::from_secs(2)).is_err(),
            "the server answered on {other}"
        );
    }
    // Not reachable from another interface of this machine, if it has one.
    if let Some(ip) = outward_address() {
        let other = format!("{ip}:{port}");
        assert!(
            TcpStream::connect_timeout(&other.parse().unwrap(), Duration::from_secs(2)).is_err(),
            "the server answered on {other}"
        );
    }
}

/// Opens `/events`; the returned function reads the next event's name.
fn event_stream(addr: &str) -> impl FnMut() -> String {
    let mut events = event_stream_with_data(addr);
    move || events().0
}

/// Opens `/events`; the returned function reads the next event's name and
/// its data lines, joined.
fn event_stream_with_data(addr: &str) -> impl FnMut() -> (String, String) {
    let events = TcpStream::connect(addr).unwrap();
    events
        .set_read_timeout(Some(Duration::from_secs(20)))
        .unwrap();
    let mut writer = events.try_clone().unwrap();
    write!(writer, "GET /events HTTP/1.1\r\nHost: {addr}\r\n\r\n").unwrap();
    let mut lines = BufReader::new(events).lines();
    move || {
        let mut name = None;
        let mut data = String::new();
        loop {
            let line = lines.next().expect("the stream stays open").unwrap();
            if let Some(n) = line.strip_prefix("event: ") {
                name = Some(n.to_string());
            } else if let Some(d) = line.strip_prefix("data:") {
                data += d.trim_start();
                data.push('\n');
            } else if line.is_empty() {
                if let Some(n) = name.take() {
                    return (n, data);
                }
            }
        }
    }
}

/// This machine's address towards other hosts (no packet is sent), unless
/// it has only loopback.
fn outward_address() -> Option<std::net::IpAddr> {
    let socket = std::net::UdpSocket::bind("0.0.0.0:0").ok()?;
    socket.connect("10.255.255.255:9").ok()?;
    let ip = socket.local_addr().ok()?.ip();
    (!ip.is_loopback() && !ip.is_unspecified()).then_some(ip)
}

/// A save whose render would take minutes (every ray runs out of steps)
/// is cancelled by the next save, whose image appears at once; and a
/// signal in the middle of such a render ends the watch within a second
/// or two.
#[test]
fn a_pathological_save_is_cancelled_by_the_next_save_and_by_a_signal() {
    let slow = "camera { position (-6, 0, 1) look_at (0, 0, 0) width 400 height 250 }\n\
                background #ff00ff\n\
                shape stuck = atan2(1e300, x) - 1 + y\nobject stuck\n";
    let w = Watch::start("pathological", &scene("#204060"), &[]);
    wait_until("the first full render", || w.full_renders() >= 1);
    w.save(slow);
    // Let its render get going.
    std::thread::sleep(Duration::from_millis(500));
    w.save(&scene("#806040"));
    wait_until("the next save's image", || {
        corner(&w.output()).is_some_and(|c| close(c, [0x80, 0x60, 0x40]))
    });

    w.save(slow);
    std::thread::sleep(Duration::from_millis(500));
    let pid = w.child.id();
    assert!(Command::new("kill")
        .arg("-INT")
        .arg(pid.to_string())
        .status()
        .unwrap()
        .success());
    let asked = Instant::now();
    let mut w = w;
    loop {
        if w.child.try_wait().unwrap().is_some() {
            break;
        }
        assert!(
            asked.elapsed() < Duration::from_secs(3),
            "the watch went on after Ctrl-C"
        );
        std::thread::sleep(Duration::from_millis(20));
    }
}
