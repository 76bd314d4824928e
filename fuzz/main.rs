//! The fuzz harness: `cargo run --release --example fuzz -- --checks N --renders M`.
//!
//! A supervisor spawns worker processes (this program with `--worker`,
//! under `prlimit` for a memory limit) and hands them chunks of input
//! numbers. A worker generates each input from (seed, stream, number,
//! attempt), runs it in-process through `nes::compile_source` (the check
//! stream) or through a compile and a 24 x 16 render (the render stream),
//! catching panics, and tells the supervisor on stdout what it is about to
//! run before it runs it. So the supervisor knows the input whenever a
//! worker dies (abort, stack overflow, out of memory) or stops advancing
//! for longer than the timeout (a hang: it kills the worker); it rebuilds
//! that input, saves it in `fuzz/found/`, and starts a new worker after
//! it. See fuzz/README.md.

mod grammar;
mod mutate;
mod rng;

use std::collections::{HashMap, VecDeque};
use std::io::{BufRead, BufReader, Read, Write};
use std::panic::AssertUnwindSafe;
use std::path::{Path, PathBuf};
use std::process::{Child, ChildStdin, Command, ExitCode, Stdio};
use std::sync::mpsc::{channel, Receiver, RecvTimeoutError, Sender};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use rng::Rng;

const USAGE: &str = "\
usage: cargo run --release --example fuzz -- [OPTIONS]

  --checks N       inputs through the check stream (parse + compile) [100000]
  --renders N      inputs through a compile and a 24x16 render [1000]
  --seed S         the campaign's seed; every input is a function of it [1]
  --jobs J         worker processes [2]
  --timeout SECS   a worker silent on one input for longer hangs [10]
  --memory GIB     address-space limit per worker, through prlimit [2]
  --minutes M      stop handing out work after M minutes
  --out DIR        where failing inputs are saved [fuzz/found]
  --replay FILE... run each file through check and render, report, exit 1 on failure
  --show STREAM I  print input I of a stream (check, render) as the workers see it
  --minimise FILE  shrink a failing file while it fails the same way (to DIR/min-*.nes)
";

/// The size a render input is drawn at.
const RENDER_WIDTH: u32 = 24;
const RENDER_HEIGHT: u32 = 16;
/// The work limit per ray and object during fuzz renders (the scene's own
/// value when smaller).
const RENDER_MAX_STEPS: u64 = 2000;
/// The samples per pixel during fuzz renders (the scene's own when fewer).
const RENDER_MAX_SAMPLES: u32 = 4;
/// A compiled scene is rendered only when it is this small.
const RENDER_MAX_OBJECTS: usize = 32;
const RENDER_MAX_LIGHTS: usize = 8;
const RENDER_MAX_SOURCE: usize = 64 << 10;
/// Candidates tried per render input before giving up on it.
const RENDER_ATTEMPTS: u64 = 200;

// ---------------------------------------------------------------- inputs --

/// Which generator an input comes from.
#[derive(Clone, Copy, PartialEq, Eq, Debug, Hash)]
enum Stream {
    Check,
    Render,
    File,
}

impl Stream {
    fn name(self) -> &'static str {
        match self {
            Stream::Check => "check",
            Stream::Render => "render",
            Stream::File => "file",
        }
    }
    fn parse(s: &str) -> Option<Stream> {
        match s {
            "check" => Some(Stream::Check),
            "render" => Some(Stream::Render),
            "file" => Some(Stream::File),
            _ => None,
        }
    }
}

/// The example scenes (every `examples/**/*.nes`) and the prelude, in a
/// fixed order: the material the mutator works on.
fn corpus() -> Vec<Vec<u8>> {
    fn walk(dir: &Path, out: &mut Vec<PathBuf>) {
        let Ok(entries) = std::fs::read_dir(dir) else {
            return;
        };
        for entry in entries.flatten() {
            let path = entry.path();
            if path.is_dir() {
                walk(&path, out);
            } else if path.extension().is_some_and(|e| e == "nes") {
                out.push(path);
            }
        }
    }
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut paths = Vec::new();
    walk(&root.join("examples"), &mut paths);
    paths.sort();
    paths.push(root.join("src/prelude.nes"));
    let files: Vec<Vec<u8>> = paths.iter().filter_map(|p| std::fs::read(p).ok()).collect();
    assert!(
        files.len() > 1,
        "no example scenes under {}",
        root.display()
    );
    files
}

/// Input `index` (candidate `attempt`) of a stream: the same bytes for the
/// same seed, every time.
fn generate(corpus: &[Vec<u8>], seed: u64, stream: Stream, index: u64, attempt: u64) -> Vec<u8> {
    let mut rng = Rng::for_input(seed, stream as u64, index, attempt);
    let mut bytes = match stream {
        Stream::Check | Stream::File => {
            if rng.chance(0.5) {
                mutate::mutate(&mut rng, corpus, false)
            } else {
                let wrong = *rng.pick(&[0.0, 0.0, 0.01, 0.05, 0.2]);
                grammar::Gen::new(&mut rng, wrong, 0.05)
                    .scene()
                    .into_bytes()
            }
        }
        Stream::Render => {
            if attempt >= 20 || rng.chance(0.5) {
                grammar::Gen::new(&mut rng, 0.0, 0.01).scene().into_bytes()
            } else {
                mutate::mutate(&mut rng, corpus, true)
            }
        }
    };
    bytes.truncate(mutate::MAX_INPUT);
    bytes
}

// ---------------------------------------------------------------- worker --

/// The first panic since the last [`take_panic`]: where and what.
static PANIC: Mutex<Option<String>> = Mutex::new(None);

fn take_panic() -> String {
    PANIC
        .lock()
        .unwrap_or_else(|e| e.into_inner())
        .take()
        .unwrap_or_else(|| "(no message)".into())
}

fn install_panic_hook() {
    std::panic::set_hook(Box::new(|info| {
        let payload = info.payload();
        let text = payload
            .downcast_ref::<&str>()
            .map(|s| s.to_string())
            .or_else(|| payload.downcast_ref::<String>().cloned())
            .unwrap_or_else(|| "(non-text payload)".into());
        let place = info
            .location()
            .map(|l| format!("{}:{}:{}", l.file(), l.line(), l.column()))
            .unwrap_or_else(|| "(unknown place)".into());
        let mut slot = PANIC.lock().unwrap_or_else(|e| e.into_inner());
        if slot.is_none() {
            *slot = Some(format!("{place}: {}", one_line(&text, 300)));
        }
    }));
}

/// `text` on one line, at most `most` characters.
fn one_line(text: &str, most: usize) -> String {
    let flat: String = text
        .chars()
        .map(|c| if c.is_control() { ' ' } else { c })
        .collect();
    flat.chars().take(most).collect()
}

/// A line to the supervisor, flushed at once: it must know what the
/// worker is doing before the worker does it.
fn say(line: &str) {
    let mut out = std::io::stdout().lock();
    let _ = writeln!(out, "@@ {line}");
    let _ = out.flush();
}

/// Parse and compile as `nes check` does, and lay out the diagnostics as
/// it prints them. `Ok(Some(scene))` when it compiles; `Err` on a panic.
fn check_bytes(bytes: Vec<u8>) -> Result<Option<nes::Scene>, String> {
    let run = std::panic::catch_unwind(AssertUnwindSafe(|| {
        let text = match nes::syntax::decode(bytes) {
            Ok(text) => text,
            Err((line, column)) => {
                std::hint::black_box((line, column));
                return None;
            }
        };
        match nes::compile_source("fuzz.nes", &text) {
            Ok(scene) => {
                std::hint::black_box(format!(
                    "ok ({} objects, {} lights)",
                    scene.objects.len(),
                    scene.lights.len()
                ));
                Some(scene)
            }
            Err(e) => {
                for report in e.reports() {
                    std::hint::black_box(format!("{report:?}"));
                }
                std::hint::black_box(e.to_string());
                std::hint::black_box(e.render_plain());
                None
            }
        }
    }));
    run.map_err(|_| take_panic())
}

fn small_enough_to_render(scene: &nes::Scene, source_len: usize) -> bool {
    scene.objects.len() <= RENDER_MAX_OBJECTS
        && scene.lights.len() <= RENDER_MAX_LIGHTS
        && source_len <= RENDER_MAX_SOURCE
}

/// A small render of `scene`, written to PNG in memory; `Err` on a panic.
fn render_scene(mut scene: nes::Scene) -> Result<(), String> {
    let run = std::panic::catch_unwind(AssertUnwindSafe(|| {
        scene.camera.width = RENDER_WIDTH;
        scene.camera.height = RENDER_HEIGHT;
        scene.settings.max_steps = scene.settings.max_steps.min(RENDER_MAX_STEPS);
        scene.settings.samples = scene.settings.samples.min(RENDER_MAX_SAMPLES);
        let (image, stats) = nes::render(&scene);
        std::hint::black_box(stats);
        std::hint::black_box(nes::output::encode_png(&image));
    }));
    run.map_err(|_| take_panic())
}

/// One input (one candidate of a render input), reported stage by stage.
/// Whether it was rendered.
fn run_one(bytes: Vec<u8>, render: bool) -> bool {
    let len = bytes.len();
    let compiled = check_bytes(bytes);
    let scene = match compiled {
        Ok(Some(scene)) => {
            say("C ok");
            scene
        }
        Ok(None) => {
            say("C error");
            say("E");
            return false;
        }
        Err(message) => {
            say(&format!("C panic {message}"));
            say("E");
            return false;
        }
    };
    if !render || !small_enough_to_render(&scene, len) {
        say("E");
        return false;
    }
    say("R");
    match render_scene(scene) {
        Ok(()) => say("P ok"),
        Err(message) => say(&format!("P panic {message}")),
    }
    say("E");
    true
}

/// The worker: read commands (`check A B`, `render A B`, `file I PATH`,
/// `quit`) and run them, saying before each input which one it is.
fn worker(seed: u64) -> ExitCode {
    install_panic_hook();
    // One thread per worker: the supervisor runs one worker per core.
    let _ = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build_global();
    let corpus = corpus();
    for line in std::io::stdin().lock().lines() {
        let Ok(line) = line else { break };
        let words: Vec<&str> = line.splitn(3, ' ').collect();
        match words.as_slice() {
            ["quit"] => break,
            [stream, a, b] if stream != &"file" => {
                let stream = Stream::parse(stream).expect("a stream");
                let (a, b): (u64, u64) = (a.parse().unwrap(), b.parse().unwrap());
                for index in a..b {
                    match stream {
                        Stream::Render => {
                            for attempt in 0..RENDER_ATTEMPTS {
                                say(&format!("B render {index} {attempt}"));
                                let bytes = generate(&corpus, seed, stream, index, attempt);
                                if run_one(bytes, true) {
                                    break;
                                }
                            }
                        }
                        _ => {
                            say(&format!("B {} {index} 0", stream.name()));
                            let bytes = generate(&corpus, seed, stream, index, 0);
                            run_one(bytes, false);
                        }
                    }
                }
                say("F");
            }
            ["file", index, path] => {
                let index: u64 = index.parse().unwrap();
                say(&format!("B file {index} 0"));
                let bytes = std::fs::read(path).unwrap_or_default();
                run_one(bytes, true);
                say("F");
            }
            _ => panic!("the worker does not understand `{line}`"),
        }
    }
    ExitCode::SUCCESS
}

// ------------------------------------------------------------ supervisor --

/// How one stage of one input ended.
#[derive(Clone, Debug, PartialEq)]
enum Res {
    Ok,
    /// Diagnostics (check), or not rendered (too big to render).
    Error,
    Panic(String),
    Abort(String),
    Hang(f64),
}

impl Res {
    fn failed(&self) -> bool {
        matches!(self, Res::Panic(_) | Res::Abort(_) | Res::Hang(_))
    }
    fn kind(&self) -> &'static str {
        match self {
            Res::Ok => "ok",
            Res::Error => "error",
            Res::Panic(_) => "panic",
            Res::Abort(_) => "abort",
            Res::Hang(_) => "hang",
        }
    }
    fn message(&self) -> String {
        match self {
            Res::Panic(m) | Res::Abort(m) => m.clone(),
            Res::Hang(s) => format!("no progress for {s:.1} s; killed"),
            _ => String::new(),
        }
    }
    fn parse(words: &str) -> Res {
        let (kind, rest) = words.split_once(' ').unwrap_or((words, ""));
        match kind {
            "ok" => Res::Ok,
            "panic" => Res::Panic(rest.to_string()),
            _ => Res::Error,
        }
    }
}

/// How one input (one candidate of a render input) ended.
#[derive(Clone, Debug)]
struct Outcome {
    stream: Stream,
    index: u64,
    attempt: u64,
    compile: Res,
    /// `None` when no render was tried.
    render: Option<Res>,
}

impl Outcome {
    /// The stage that failed, and how.
    fn failure(&self) -> Option<(&'static str, &Res)> {
        if self.compile.failed() {
            return Some(("check", &self.compile));
        }
        match &self.render {
            Some(r) if r.failed() => Some(("render", r)),
            _ => None,
        }
    }
}

/// What the campaign asks of its workers.
#[derive(Clone, Debug)]
struct Config {
    seed: u64,
    jobs: usize,
    timeout: f64,
    memory_gib: f64,
}

/// A run of work for one worker.
#[derive(Clone, Debug)]
enum Task {
    Gen { stream: Stream, next: u64, end: u64 },
    File { index: u64, path: PathBuf },
}

impl Task {
    fn command(&self) -> String {
        match self {
            Task::Gen { stream, next, end } => format!("{} {next} {end}", stream.name()),
            Task::File { index, path } => format!("file {index} {}", path.display()),
        }
    }
}

enum Msg {
    Line(usize, u64, String),
    Eof(usize, u64),
}

/// The input a worker is on.
struct Current {
    stream: Stream,
    index: u64,
    attempt: u64,
    in_render: bool,
    since: Instant,
    compile: Option<Res>,
    render: Option<Res>,
}

struct Worker {
    child: Child,
    stdin: ChildStdin,
    generation: u64,
    stderr: Arc<Mutex<Vec<u8>>>,
    stderr_thread: Option<std::thread::JoinHandle<()>>,
    task: Option<Task>,
    current: Option<Current>,
    quitting: bool,
}

/// Why a dead worker died, from the end of its stderr: the runtime's
/// last words (out of memory, stack overflow, a panic that could not
/// unwind) and the innermost frame of nes in the backtrace, if any.
fn death_notes(tail: &[u8]) -> String {
    let text = String::from_utf8_lossy(tail);
    let lines: Vec<&str> = text
        .lines()
        .map(str::trim)
        .filter(|l| !l.is_empty())
        .collect();
    let reasons = [
        "memory allocation of",
        "has overflowed its stack",
        "fatal runtime error",
        "panicked",
        "Aborted",
    ];
    let reason = lines
        .iter()
        .find(|l| reasons.iter().any(|r| l.contains(r)))
        .copied()
        .or(lines.last().copied())
        .unwrap_or("");
    // "5: <nes::space::torus::TorusSpace as nes::space::Space>::images"
    let frame = lines
        .iter()
        .filter_map(|l| l.split_once(": ").map(|(_, f)| f))
        .find(|f| f.contains("nes::") && !f.starts_with("fuzz::"));
    let notes = match frame {
        Some(f) => format!("{reason} (in {f})"),
        None => reason.to_string(),
    };
    one_line(&notes, 400)
}

fn prlimit_available() -> bool {
    std::env::var_os("PATH")
        .is_some_and(|paths| std::env::split_paths(&paths).any(|dir| dir.join("prlimit").is_file()))
}

/// Runs tasks on worker processes and reports each input's outcome.
struct Engine<'c> {
    config: &'c Config,
    tx: Sender<Msg>,
    rx: Receiver<Msg>,
    workers: Vec<Option<Worker>>,
    queue: VecDeque<Task>,
    next_generation: u64,
    deadline: Option<Instant>,
    /// Whether the deadline left work undone.
    stopped_early: bool,
    use_prlimit: bool,
    respawns: u64,
}

impl<'c> Engine<'c> {
    fn new(config: &'c Config, tasks: Vec<Task>) -> Self {
        let (tx, rx) = channel();
        Engine {
            config,
            tx,
            rx,
            workers: Vec::new(),
            queue: tasks.into(),
            next_generation: 0,
            deadline: None,
            stopped_early: false,
            use_prlimit: prlimit_available(),
            respawns: 0,
        }
    }

    fn spawn(&mut self, slot: usize) -> Worker {
        let exe = std::env::current_exe().expect("the harness's own path");
        let mut cmd = if self.use_prlimit {
            let bytes = (self.config.memory_gib * (1u64 << 30) as f64) as u64;
            let mut c = Command::new("prlimit");
            c.arg(format!("--as={bytes}"))
                .arg("--core=0")
                .arg("--")
                .arg(exe);
            c
        } else {
            Command::new(exe)
        };
        // A backtrace names the place of an abort (out of memory).
        cmd.args(["--worker", "--seed", &self.config.seed.to_string()])
            .env("RUST_BACKTRACE", "1")
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .stderr(Stdio::piped());
        let mut child = cmd.spawn().expect("spawning a worker");
        let generation = self.next_generation;
        self.next_generation += 1;
        let stdout = child.stdout.take().unwrap();
        let tx = self.tx.clone();
        std::thread::spawn(move || {
            for line in BufReader::new(stdout).lines() {
                let Ok(line) = line else { break };
                if let Some(rest) = line.strip_prefix("@@ ") {
                    if tx
                        .send(Msg::Line(slot, generation, rest.to_string()))
                        .is_err()
                    {
                        return;
                    }
                }
            }
            let _ = tx.send(Msg::Eof(slot, generation));
        });
        let stderr = Arc::new(Mutex::new(Vec::new()));
        let mut pipe = child.stderr.take().unwrap();
        let sink = stderr.clone();
        let stderr_thread = std::thread::spawn(move || {
            let mut buf = [0u8; 4096];
            while let Ok(n) = pipe.read(&mut buf) {
                if n == 0 {
                    break;
                }
                let mut tail = sink.lock().unwrap();
                tail.extend_from_slice(&buf[..n]);
                let excess = tail.len().saturating_sub(16 << 10);
                tail.drain(..excess);
            }
        });
        let stdin = child.stdin.take().unwrap();
        Worker {
            child,
            stdin,
            generation,
            stderr,
            stderr_thread: Some(stderr_thread),
            task: None,
            current: None,
            quitting: false,
        }
    }

    /// Give worker `slot` its next task, or tell it to quit.
    fn assign(&mut self, slot: usize) {
        let stop = self.deadline.is_some_and(|d| Instant::now() >= d);
        let task = if stop { None } else { self.queue.pop_front() };
        self.stopped_early |= stop && !self.queue.is_empty();
        let w = self.workers[slot].as_mut().unwrap();
        match task {
            Some(t) => {
                let _ = writeln!(w.stdin, "{}", t.command());
                let _ = w.stdin.flush();
                w.task = Some(t);
            }
            None => {
                let _ = writeln!(w.stdin, "quit");
                let _ = w.stdin.flush();
                w.task = None;
                w.quitting = true;
            }
        }
    }

    /// The worker in `slot` is gone (or killed): reap it, report the input
    /// it was on, and put the rest of its task back at the front.
    fn bury(&mut self, slot: usize, hang: Option<f64>, on_outcome: &mut dyn FnMut(Outcome)) {
        let mut w = self.workers[slot].take().unwrap();
        if hang.is_some() {
            let _ = w.child.kill();
        }
        let status = w.child.wait().ok();
        if let Some(t) = w.stderr_thread.take() {
            let _ = t.join();
        }
        let notes = death_notes(&w.stderr.lock().unwrap());
        if w.quitting && w.current.is_none() && hang.is_none() {
            return;
        }
        let how = match status {
            Some(s) => {
                use std::os::unix::process::ExitStatusExt;
                match (s.code(), s.signal()) {
                    (_, Some(sig)) => format!("signal {sig}"),
                    (Some(c), _) => format!("exit code {c}"),
                    _ => "unknown status".into(),
                }
            }
            None => "no status".into(),
        };
        let message = if notes.is_empty() {
            how
        } else {
            format!("{how}: {notes}")
        };
        let resume_at = match w.current.take() {
            Some(cur) => {
                let res = match hang {
                    Some(s) => Res::Hang(s),
                    None => Res::Abort(message.clone()),
                };
                let (compile, render) = if cur.in_render {
                    (cur.compile.unwrap_or(Res::Ok), Some(res))
                } else {
                    (res, None)
                };
                on_outcome(Outcome {
                    stream: cur.stream,
                    index: cur.index,
                    attempt: cur.attempt,
                    compile,
                    render,
                });
                Some(cur.index + 1)
            }
            None => {
                eprintln!("fuzz: a worker died between inputs ({message})");
                None
            }
        };
        if let Some(Task::Gen { stream, next, end }) = w.task.take() {
            let next = resume_at.unwrap_or(next).max(next);
            if next < end {
                self.queue.push_front(Task::Gen { stream, next, end });
            }
        }
        self.respawns += 1;
        if self.respawns > 100_000 {
            panic!("workers keep dying: {message}");
        }
        self.workers[slot] = Some(self.spawn(slot));
        self.assign(slot);
    }

    fn handle(&mut self, slot: usize, line: &str, on_outcome: &mut dyn FnMut(Outcome)) {
        let w = self.workers[slot].as_mut().unwrap();
        let (tag, rest) = line.split_once(' ').unwrap_or((line, ""));
        match tag {
            "B" => {
                let parts: Vec<&str> = rest.split(' ').collect();
                let index: u64 = parts[1].parse().unwrap();
                w.current = Some(Current {
                    stream: Stream::parse(parts[0]).unwrap(),
                    index,
                    attempt: parts[2].parse().unwrap(),
                    in_render: false,
                    since: Instant::now(),
                    compile: None,
                    render: None,
                });
                if let Some(Task::Gen { next, .. }) = &mut w.task {
                    *next = index;
                }
            }
            "C" => {
                if let Some(c) = w.current.as_mut() {
                    c.compile = Some(Res::parse(rest));
                }
            }
            "R" => {
                if let Some(c) = w.current.as_mut() {
                    c.in_render = true;
                    c.since = Instant::now();
                }
            }
            "P" => {
                if let Some(c) = w.current.as_mut() {
                    c.render = Some(Res::parse(rest));
                }
            }
            "E" => {
                if let Some(c) = w.current.take() {
                    on_outcome(Outcome {
                        stream: c.stream,
                        index: c.index,
                        attempt: c.attempt,
                        compile: c.compile.unwrap_or(Res::Error),
                        render: c.render,
                    });
                }
            }
            "F" => self.assign(slot),
            _ => eprintln!("fuzz: a worker said `{line}`"),
        }
    }

    /// Run every task; `on_outcome` sees each input as it ends, `tick`
    /// is called about once a second.
    fn run(&mut self, on_outcome: &mut dyn FnMut(Outcome), tick: &mut dyn FnMut(&Engine)) {
        let jobs = self.config.jobs.max(1).min(self.queue.len().max(1));
        for slot in 0..jobs {
            let w = self.spawn(slot);
            self.workers.push(Some(w));
            self.assign(slot);
        }
        let timeout = Duration::from_secs_f64(self.config.timeout);
        let mut last_tick = Instant::now();
        while self.workers.iter().any(Option::is_some) {
            match self.rx.recv_timeout(Duration::from_millis(100)) {
                Ok(Msg::Line(slot, generation, line)) => {
                    if self.workers[slot]
                        .as_ref()
                        .is_some_and(|w| w.generation == generation)
                    {
                        self.handle(slot, &line, on_outcome);
                    }
                }
                Ok(Msg::Eof(slot, generation)) => {
                    if self.workers[slot]
                        .as_ref()
                        .is_some_and(|w| w.generation == generation)
                    {
                        let done = self.workers[slot]
                            .as_ref()
                            .is_some_and(|w| w.quitting && w.current.is_none());
                        if done {
                            let mut w = self.workers[slot].take().unwrap();
                            let _ = w.child.wait();
                        } else {
                            self.bury(slot, None, on_outcome);
                        }
                    }
                }
                Err(RecvTimeoutError::Timeout) => {}
                Err(RecvTimeoutError::Disconnected) => break,
            }
            for slot in 0..self.workers.len() {
                let stuck = self.workers[slot]
                    .as_ref()
                    .and_then(|w| w.current.as_ref())
                    .map(|c| c.since.elapsed())
                    .filter(|e| *e > timeout);
                if let Some(e) = stuck {
                    self.bury(slot, Some(e.as_secs_f64()), on_outcome);
                }
            }
            if last_tick.elapsed() >= Duration::from_secs(1) {
                last_tick = Instant::now();
                tick(self);
            }
        }
    }
}

// -------------------------------------------------------------- campaign --

#[derive(Default)]
struct Counts {
    checks: u64,
    checks_ok: u64,
    checks_error: u64,
    candidates: u64,
    candidates_ok: u64,
    renders: u64,
    /// Render inputs none of whose candidates compiled small enough.
    no_candidate: u64,
    files: u64,
    /// (stage, kind) -> count.
    failures: HashMap<(&'static str, &'static str), u64>,
}

/// Failing inputs kept per distinct failure: the first few, then any that
/// is smaller than every one kept.
const KEEP_PER_SIGNATURE: usize = 5;

/// What identifies a failure for grouping: the stage, the kind and where
/// (a panic's source line; an abort's reason).
fn signature(stage: &str, res: &Res) -> String {
    let what = match res {
        Res::Panic(m) => {
            // "src/x.rs:12:5: message" -> "src/x.rs:12"
            let mut parts = m.splitn(3, ':');
            match (parts.next(), parts.next()) {
                (Some(f), Some(l)) => format!("{f}:{l}"),
                _ => m.clone(),
            }
        }
        Res::Abort(m) => {
            let known = [
                ("overflowed its stack", "stack overflow"),
                ("memory allocation", "out of memory"),
                ("cannot unwind", "panic that cannot unwind"),
                ("panicked while processing panic", "double panic"),
            ];
            let reason = known
                .iter()
                .find(|(k, _)| m.contains(k))
                .map(|(_, r)| r.to_string())
                .unwrap_or_else(|| m.split(':').next().unwrap_or("").to_string());
            // The innermost nes frame, without generic arguments.
            let frame = m
                .rsplit_once("(in ")
                .map(|(_, f)| f.trim_end_matches(')').to_string())
                .unwrap_or_default();
            format!("{reason} {frame}").trim().to_string()
        }
        _ => String::new(),
    };
    format!("{}-{stage} {what}", res.kind())
}

fn hash_hex(bytes: &[u8]) -> String {
    use sha2::{Digest, Sha256};
    let digest = Sha256::digest(bytes);
    digest.iter().take(8).map(|b| format!("{b:02x}")).collect()
}

struct Found {
    dir: PathBuf,
    /// Signature -> (occurrences, sizes of the inputs kept, one example
    /// message, the smallest kept file).
    seen: HashMap<String, (u64, Vec<usize>, String, PathBuf)>,
}

impl Found {
    fn record(&mut self, config: &Config, corpus: &[Vec<u8>], outcome: &Outcome) {
        let Some((stage, res)) = outcome.failure() else {
            return;
        };
        let sig = signature(stage, res);
        let bytes = generate(
            corpus,
            config.seed,
            outcome.stream,
            outcome.index,
            outcome.attempt,
        );
        let entry = self
            .seen
            .entry(sig.clone())
            .or_insert_with(|| (0, Vec::new(), res.message(), PathBuf::new()));
        entry.0 += 1;
        let smallest = entry.1.iter().copied().min().unwrap_or(usize::MAX);
        if entry.1.len() >= KEEP_PER_SIGNATURE && bytes.len() >= smallest {
            return;
        }
        let name = format!("{}-{}", res.kind(), hash_hex(&bytes));
        let path = self.dir.join(format!("{name}.nes"));
        if bytes.len() < smallest {
            entry.3 = path.clone();
            entry.2 = res.message();
        }
        entry.1.push(bytes.len());
        let _ = std::fs::create_dir_all(&self.dir);
        if path.exists() {
            return;
        }
        let _ = std::fs::write(&path, &bytes);
        let note = format!(
            "kind: {}\nstage: {stage}\nsignature: {sig}\nmessage: {}\nfound by: seed {}, stream {}, input {}, attempt {}\nsize: {} bytes\nreplay: cargo run --release --example fuzz -- --replay {}\n",
            res.kind(),
            res.message(),
            config.seed,
            outcome.stream.name(),
            outcome.index,
            outcome.attempt,
            bytes.len(),
            path.display(),
        );
        let _ = std::fs::write(self.dir.join(format!("{name}.txt")), note);
    }
}

fn count(counts: &mut Counts, outcome: &Outcome) {
    match outcome.stream {
        Stream::Check => {
            counts.checks += 1;
            match outcome.compile {
                Res::Ok => counts.checks_ok += 1,
                Res::Error => counts.checks_error += 1,
                _ => {}
            }
        }
        Stream::Render => {
            counts.candidates += 1;
            if outcome.compile == Res::Ok {
                counts.candidates_ok += 1;
            }
            if outcome.render.is_some() {
                counts.renders += 1;
            } else if outcome.attempt + 1 == RENDER_ATTEMPTS && !outcome.compile.failed() {
                counts.no_candidate += 1;
            }
        }
        Stream::File => counts.files += 1,
    }
    if let Some((stage, res)) = outcome.failure() {
        *counts.failures.entry((stage, res.kind())).or_default() += 1;
    }
}

/// Chunks of both streams, interleaved so that a campaign stopped early
/// has run both in proportion.
fn tasks(checks: u64, renders: u64) -> Vec<Task> {
    let chunk = |stream, total: u64, size: u64| -> Vec<Task> {
        (0..total.div_ceil(size))
            .map(|k| Task::Gen {
                stream,
                next: k * size,
                end: ((k + 1) * size).min(total),
            })
            .collect()
    };
    let a = chunk(Stream::Check, checks, 500);
    let b = chunk(Stream::Render, renders, 10);
    let (mut i, mut j) = (0, 0);
    let mut out = Vec::new();
    while i < a.len() || j < b.len() {
        let fa = i as f64 / a.len().max(1) as f64;
        let fb = j as f64 / b.len().max(1) as f64;
        if j >= b.len() || (i < a.len() && fa <= fb) {
            out.push(a[i].clone());
            i += 1;
        } else {
            out.push(b[j].clone());
            j += 1;
        }
    }
    out
}

/// The campaign's table: the final one, or with `running` a snapshot.
#[allow(clippy::too_many_arguments)]
fn summary(
    config: &Config,
    use_prlimit: bool,
    stopped_early: bool,
    running: bool,
    checks: u64,
    renders: u64,
    c: &Counts,
    found: &Found,
    wall: f64,
) -> String {
    use std::fmt::Write as _;
    let f = |stage: &'static str, kind: &'static str| {
        c.failures.get(&(stage, kind)).copied().unwrap_or(0)
    };
    let mut out = String::new();
    let _ = writeln!(
        out,
        "seed {}, {} jobs, timeout {} s, memory limit {} per worker{}",
        config.seed,
        config.jobs,
        config.timeout,
        if use_prlimit {
            format!("{} GiB", config.memory_gib)
        } else {
            "none".into()
        },
        if running {
            format!(
                " (running: a snapshot after {wall:.0} s of {checks} checks and {renders} renders)"
            )
        } else if stopped_early {
            format!(" (stopped early: asked for {checks} checks and {renders} renders)")
        } else {
            String::new()
        }
    );
    let row = |out: &mut String, name: &str, a: String, b: String| {
        let _ = writeln!(out, "{name:<28}{a:>12}{b:>12}");
    };
    row(&mut out, "", "check".into(), "render".into());
    row(
        &mut out,
        "inputs run",
        c.checks.to_string(),
        c.renders.to_string(),
    );
    row(
        &mut out,
        "  compiled",
        c.checks_ok.to_string(),
        String::new(),
    );
    row(
        &mut out,
        "  rejected with diagnostics",
        c.checks_error.to_string(),
        String::new(),
    );
    for (name, kind) in [("panics", "panic"), ("aborts", "abort")] {
        row(
            &mut out,
            name,
            f("check", kind).to_string(),
            f("render", kind).to_string(),
        );
    }
    row(
        &mut out,
        &format!("hangs (> {} s)", config.timeout),
        f("check", "hang").to_string(),
        f("render", "hang").to_string(),
    );
    let _ = writeln!(
        out,
        "render candidates compiled: {} of {} (their compile failures are in the check column); render inputs without a candidate: {}",
        c.candidates_ok, c.candidates, c.no_candidate
    );
    let _ = writeln!(
        out,
        "wall time {wall:.1} s ({:.0} checks/s, {:.1} renders/s)",
        c.checks as f64 / wall.max(1e-9),
        c.renders as f64 / wall.max(1e-9)
    );
    if found.seen.is_empty() {
        let _ = writeln!(out, "no failures");
    } else {
        let _ = writeln!(out, "distinct failures:");
        let mut seen: Vec<_> = found.seen.iter().collect();
        seen.sort_by_key(|s| (std::cmp::Reverse(s.1 .0), s.0.clone()));
        for (sig, (n, _, message, path)) in seen {
            let _ = writeln!(
                out,
                "  {n:>8} x {sig}\n             {message}\n             smallest kept: {}",
                path.display()
            );
        }
    }
    out
}

fn campaign(
    config: &Config,
    checks: u64,
    renders: u64,
    minutes: Option<f64>,
    out: PathBuf,
) -> ExitCode {
    let corpus = corpus();
    let start = Instant::now();
    let mut engine = Engine::new(config, tasks(checks, renders));
    engine.deadline = minutes.map(|m| start + Duration::from_secs_f64(m * 60.0));
    if !engine.use_prlimit {
        eprintln!("fuzz: prlimit not found; workers run without a memory limit");
    }
    eprintln!(
        "fuzz: seed {}, {} checks, {} renders, {} jobs, timeout {} s, memory {} GiB per worker{}",
        config.seed,
        checks,
        renders,
        config.jobs,
        config.timeout,
        config.memory_gib,
        minutes.map_or(String::new(), |m| format!(", stopping after {m} min"))
    );
    let snapshot = out.join("campaign.txt");
    let counts = std::cell::RefCell::new(Counts::default());
    let found = std::cell::RefCell::new(Found {
        dir: out,
        seen: HashMap::new(),
    });
    let mut last_report = Instant::now();
    engine.run(
        &mut |o| {
            count(&mut counts.borrow_mut(), &o);
            found.borrow_mut().record(config, &corpus, &o);
        },
        &mut |engine| {
            if last_report.elapsed() < Duration::from_secs(15) {
                return;
            }
            last_report = Instant::now();
            let c = counts.borrow();
            let t = start.elapsed().as_secs_f64();
            let failures: u64 = c.failures.values().sum();
            let share = (c.checks as f64 / checks.max(1) as f64)
                .min(c.renders as f64 / renders.max(1) as f64);
            let eta = if share > 0.0 { t / share - t } else { f64::NAN };
            eprintln!(
                "fuzz: {t:.0} s: {} checks ({:.0}/s), {} renders ({:.1}/s), {failures} failures, ~{eta:.0} s to go",
                c.checks,
                c.checks as f64 / t,
                c.renders,
                c.renders as f64 / t
            );
            // Should the campaign be stopped from outside, the figures so
            // far are in the snapshot.
            let text = summary(
                config,
                engine.use_prlimit,
                engine.stopped_early,
                true,
                checks,
                renders,
                &c,
                &found.borrow(),
                t,
            );
            let _ = std::fs::create_dir_all(&found.borrow().dir);
            let _ = std::fs::write(&snapshot, text);
        },
    );
    let wall = start.elapsed().as_secs_f64();
    let (c, found) = (counts.into_inner(), found.into_inner());
    let text = summary(
        config,
        engine.use_prlimit,
        engine.stopped_early,
        false,
        checks,
        renders,
        &c,
        &found,
        wall,
    );
    let _ = std::fs::create_dir_all(&found.dir);
    let _ = std::fs::write(&snapshot, &text);
    println!("\n{text}");
    if found.seen.is_empty() {
        ExitCode::SUCCESS
    } else {
        ExitCode::FAILURE
    }
}

// ---------------------------------------------------- replay, minimise --

/// Each file through check and render in a worker of its own.
fn run_files(config: &Config, files: &[PathBuf]) -> Vec<Outcome> {
    let tasks = files
        .iter()
        .enumerate()
        .map(|(i, p)| Task::File {
            index: i as u64,
            path: p.clone(),
        })
        .collect();
    let mut engine = Engine::new(config, tasks);
    let mut outcomes = Vec::new();
    engine.run(&mut |o| outcomes.push(o), &mut |_| {});
    outcomes.sort_by_key(|o| o.index);
    outcomes
}

fn describe(o: &Outcome) -> String {
    let stage = |r: &Res| match r {
        Res::Ok | Res::Error => r.kind().to_string(),
        _ => format!("{} ({})", r.kind().to_uppercase(), r.message()),
    };
    format!(
        "check {}; render {}",
        stage(&o.compile),
        o.render.as_ref().map_or("not run".into(), stage)
    )
}

fn replay(config: &Config, files: &[PathBuf]) -> ExitCode {
    let outcomes = run_files(config, files);
    let mut failed = 0;
    for o in &outcomes {
        let path = &files[o.index as usize];
        println!("{}: {}", path.display(), describe(o));
        failed += o.failure().is_some() as usize;
    }
    println!("{} of {} files fail", failed, files.len());
    if failed > 0 {
        ExitCode::FAILURE
    } else {
        ExitCode::SUCCESS
    }
}

/// The failure signature of `bytes`, run from a scratch file.
fn signature_of(config: &Config, bytes: &[u8], scratch: &Path) -> Option<String> {
    std::fs::write(scratch, bytes).ok()?;
    let o = run_files(config, &[scratch.to_path_buf()]).pop()?;
    o.failure().map(|(stage, res)| signature(stage, res))
}

/// Delta debugging: remove chunks of lines, then of tokens, then (for an
/// input of at most 1000 bytes by then) of bytes, keeping each removal
/// after which the input still fails the same way. Each try runs in a
/// fresh worker, so a try that hangs costs the timeout.
fn minimise(config: &Config, file: &Path, out: &Path) -> ExitCode {
    let Ok(mut bytes) = std::fs::read(file) else {
        eprintln!("cannot read {}", file.display());
        return ExitCode::FAILURE;
    };
    let scratch = std::env::temp_dir().join(format!("nes-fuzz-min-{}.nes", std::process::id()));
    let Some(want) = signature_of(config, &bytes, &scratch) else {
        println!("{} does not fail", file.display());
        return ExitCode::FAILURE;
    };
    println!("{}: {want}, {} bytes", file.display(), bytes.len());
    type Split = fn(&[u8]) -> Vec<(usize, usize)>;
    let by_lines: Split = |t| {
        let mut out = Vec::new();
        let mut start = 0;
        for (i, &b) in t.iter().enumerate() {
            if b == b'\n' {
                out.push((start, i + 1));
                start = i + 1;
            }
        }
        if start < t.len() {
            out.push((start, t.len()));
        }
        out
    };
    let by_tokens: Split = mutate::token_ranges;
    let by_bytes: Split = |t| (0..t.len()).map(|i| (i, i + 1)).collect();
    let mut runs = 0;
    for (name, split) in [
        ("lines", by_lines),
        ("tokens", by_tokens),
        ("bytes", by_bytes),
    ] {
        let mut pieces = split(&bytes);
        if name == "bytes" && pieces.len() > 1000 {
            continue;
        }
        let mut n = pieces.len().div_ceil(2).max(1);
        while n >= 1 && !pieces.is_empty() {
            let mut i = 0;
            let mut shrank = false;
            while i < pieces.len() {
                let end = (i + n).min(pieces.len());
                let (a, b) = (pieces[i].0, pieces[end - 1].1);
                let mut candidate = bytes[..a].to_vec();
                candidate.extend_from_slice(&bytes[b..]);
                runs += 1;
                if signature_of(config, &candidate, &scratch).as_deref() == Some(want.as_str()) {
                    bytes = candidate;
                    pieces = split(&bytes);
                    shrank = true;
                } else {
                    i += n;
                }
            }
            if !shrank {
                if n == 1 {
                    break;
                }
                n = n.div_ceil(2);
            }
        }
        println!("after removing {name}: {} bytes ({runs} runs)", bytes.len());
    }
    let _ = std::fs::remove_file(&scratch);
    let kind = want.split('-').next().unwrap_or("fail");
    let _ = std::fs::create_dir_all(out);
    let path = out.join(format!("min-{kind}-{}.nes", hash_hex(&bytes)));
    let _ = std::fs::write(&path, &bytes);
    println!("{want}\nwrote {} ({} bytes)", path.display(), bytes.len());
    ExitCode::SUCCESS
}

// ------------------------------------------------------------------ main --

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let mut config = Config {
        seed: 1,
        jobs: 2,
        timeout: 10.0,
        memory_gib: 2.0,
    };
    let (mut checks, mut renders) = (100_000u64, 1000u64);
    let mut minutes = None;
    let mut out = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("fuzz/found");
    let mut replay_files = Vec::new();
    let mut minimise_file = None;
    let mut is_worker = false;
    let mut i = 0;
    let value = |i: usize| -> &str {
        args.get(i + 1).map(String::as_str).unwrap_or_else(|| {
            eprint!("{} needs a value\n{USAGE}", args[i]);
            std::process::exit(2)
        })
    };
    fn num<T: std::str::FromStr>(flag: &str, v: &str) -> T {
        v.parse().unwrap_or_else(|_| {
            eprint!("{flag}: `{v}` is not a number\n{USAGE}");
            std::process::exit(2)
        })
    }
    while i < args.len() {
        let flag = args[i].as_str();
        match flag {
            "--worker" => {
                is_worker = true;
                i += 1;
                continue;
            }
            "--checks" => checks = num(flag, value(i)),
            "--renders" => renders = num(flag, value(i)),
            "--seed" => config.seed = num(flag, value(i)),
            "--jobs" => config.jobs = num(flag, value(i)),
            "--timeout" => config.timeout = num(flag, value(i)),
            "--memory" => config.memory_gib = num(flag, value(i)),
            "--minutes" => minutes = Some(num(flag, value(i))),
            "--out" => out = PathBuf::from(value(i)),
            "--minimise" | "--minimize" => minimise_file = Some(PathBuf::from(value(i))),
            "--show" => {
                let stream = Stream::parse(value(i)).unwrap_or(Stream::Check);
                let index: u64 = num(flag, args.get(i + 2).map_or("0", String::as_str));
                let attempt: u64 = num(flag, args.get(i + 3).map_or("0", String::as_str));
                let bytes = generate(&corpus(), config.seed, stream, index, attempt);
                let _ = std::io::stdout().write_all(&bytes);
                return ExitCode::SUCCESS;
            }
            "--replay" => {
                replay_files.extend(args[i + 1..].iter().map(PathBuf::from));
                break;
            }
            "-h" | "--help" => {
                print!("{USAGE}");
                return ExitCode::SUCCESS;
            }
            _ => {
                eprint!("unknown argument `{flag}`\n{USAGE}");
                return ExitCode::from(2);
            }
        }
        i += 2;
    }
    if is_worker {
        return worker(config.seed);
    }
    if let Some(file) = minimise_file {
        config.jobs = 1;
        return minimise(&config, &file, &out);
    }
    if !replay_files.is_empty() {
        return replay(&config, &replay_files);
    }
    campaign(&config, checks, renders, minutes, out)
}
