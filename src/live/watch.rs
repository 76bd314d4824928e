//! `nes watch`: render, then render again on every save.
//!
//! Input: a scene path, an output path and a way to adjust each compiled
//! scene (the command line's overrides). Output: the PNG, rewritten
//! atomically after each good save (a quick low-resolution preview, then
//! the full image), a status line per render, the diagnostics of each
//! broken save, and optionally the same on a [`crate::live::serve::Board`] for
//! the browser page. The scene's folder is watched, not the file, so
//! editors that save by writing a temporary file and renaming it, or that
//! delete and re-create the file, keep working. A new save cancels the
//! render in flight (the tracer checks the token between bands of rows).

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::mpsc;
use std::sync::Arc;
use std::time::{Duration, Instant};

use notify_debouncer_full::notify::event::ModifyKind;
use notify_debouncer_full::notify::{EventKind, RecursiveMode};
use notify_debouncer_full::{new_debouncer, DebounceEventResult};

use crate::live::serve::Board;
use crate::render::{render_with, RenderOptions};
use crate::scene::Scene;
use crate::trace::Tracer;

/// What to watch and where the image goes.
pub struct WatchOptions<'a> {
    /// The scene file; its folder is what is watched.
    pub scene: PathBuf,
    /// The PNG rewritten after each good save: first with the preview scaled
    /// up to full size, then with the full render.
    pub output: PathBuf,
    /// Applied to every compiled scene (size and method overrides); an
    /// error is reported like a broken save's.
    pub adjust: &'a (dyn Fn(&mut Scene) -> Result<(), String> + Sync),
    /// The preview's size is the image's divided by this.
    pub preview_divisor: u32,
    /// Set from outside (Ctrl-C) to stop after the render in flight.
    pub quit: Arc<AtomicBool>,
    /// Where to publish images and diagnostics for the browser, if served.
    pub board: Option<Arc<Board>>,
}

/// How long a burst of file events must be quiet before it counts as one
/// save: short, since the first preview should appear within ~100 ms.
const DEBOUNCE: Duration = Duration::from_millis(15);

/// Watches until `quit` is set. Status lines and diagnostics go to `log`.
pub fn run(opts: &WatchOptions, log: &(dyn Fn(&str) + Sync)) -> std::io::Result<()> {
    let scene_path = absolute(&opts.scene);
    let dir = scene_path
        .parent()
        .map(Path::to_path_buf)
        .unwrap_or_else(|| PathBuf::from("."));
    // The scene and every file it imports (absolute paths): a change to
    // any of them is a save. Imports are learnt from each compile, good
    // or broken, so fixing a broken library re-renders too.
    let files = Arc::new(std::sync::Mutex::new(vec![scene_path.clone()]));

    let cancel = Arc::new(AtomicBool::new(false));
    let saves = Arc::new(AtomicU64::new(0));
    let (tx, rx) = mpsc::channel::<()>();
    let mut debouncer = {
        let (cancel, saves, files) = (cancel.clone(), saves.clone(), files.clone());
        new_debouncer(DEBOUNCE, None, move |result: DebounceEventResult| {
            let Ok(events) = result else { return };
            // Content changes only: reading the scene (to render it) makes
            // access events, which must not trigger another render.
            let ours = events.iter().any(|e| {
                let change = matches!(
                    e.event.kind,
                    EventKind::Create(_)
                        | EventKind::Remove(_)
                        | EventKind::Modify(
                            ModifyKind::Data(_) | ModifyKind::Name(_) | ModifyKind::Any
                        )
                );
                let files = files.lock().unwrap_or_else(|p| p.into_inner());
                change
                    && e.event
                        .paths
                        .iter()
                        .any(|p| files.iter().any(|f| same_file(p, f)))
            });
            if ours {
                saves.fetch_add(1, Ordering::SeqCst);
                cancel.store(true, Ordering::SeqCst);
                let _ = tx.send(());
            }
        })
        .map_err(std::io::Error::other)?
    };
    debouncer
        .watch(&dir, RecursiveMode::NonRecursive)
        .map_err(std::io::Error::other)?;

    // Quitting cancels the render in flight.
    {
        let (quit, cancel) = (opts.quit.clone(), cancel.clone());
        std::thread::spawn(move || {
            while !quit.load(Ordering::SeqCst) {
                std::thread::sleep(Duration::from_millis(20));
            }
            cancel.store(true, Ordering::SeqCst);
        });
    }
    let mut watched_dirs = vec![dir];
    let mut watch_imports = |imports: Vec<PathBuf>, debouncer: &mut Debouncer| {
        let mut all = vec![scene_path.clone()];
        all.extend(imports.iter().map(|p| absolute(p)));
        for f in &all {
            let Some(d) = f.parent() else { continue };
            if !watched_dirs.iter().any(|w| w == d) {
                match debouncer.watch(d, RecursiveMode::NonRecursive) {
                    Ok(()) => watched_dirs.push(d.to_path_buf()),
                    Err(e) => log(&format!("cannot watch {} for changes: {e}", d.display())),
                }
            }
        }
        *files.lock().unwrap_or_else(|p| p.into_inner()) = all;
    };
    let mut last_seen = 0;
    let imports = render_once(opts, &scene_path, "start", &cancel, log);
    watch_imports(imports, &mut debouncer);
    while !opts.quit.load(Ordering::SeqCst) {
        match rx.recv_timeout(Duration::from_millis(100)) {
            Ok(()) => {
                // One render for however many saves arrived meanwhile.
                while rx.try_recv().is_ok() {}
                let now = saves.load(Ordering::SeqCst);
                let what = match now - last_seen {
                    1 => "saved".to_string(),
                    n => format!("saved {n} times"),
                };
                last_seen = now;
                if opts.quit.load(Ordering::SeqCst) {
                    break;
                }
                cancel.store(false, Ordering::SeqCst);
                let imports = render_once(opts, &scene_path, &what, &cancel, log);
                watch_imports(imports, &mut debouncer);
            }
            Err(mpsc::RecvTimeoutError::Timeout) => {}
            Err(mpsc::RecvTimeoutError::Disconnected) => break,
        }
    }
    Ok(())
}

type Debouncer = notify_debouncer_full::Debouncer<
    notify_debouncer_full::notify::RecommendedWatcher,
    notify_debouncer_full::RecommendedCache,
>;

/// Whether an event's path is the watched file `f` (both absolute; the
/// folder compared through symbolic links too).
fn same_file(p: &Path, f: &Path) -> bool {
    if p == f {
        return true;
    }
    let canonical = |d: Option<&Path>| d.and_then(|d| std::fs::canonicalize(d).ok());
    p.file_name() == f.file_name() && canonical(p.parent()) == canonical(f.parent())
}

fn absolute(p: &Path) -> PathBuf {
    std::path::absolute(p).unwrap_or_else(|_| p.to_path_buf())
}

fn clock() -> String {
    let secs = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map(|d| d.as_secs())
        .unwrap_or(0);
    format!(
        "{:02}:{:02}:{:02}",
        secs / 3600 % 24,
        secs / 60 % 60,
        secs % 60
    )
}

/// Compile, preview, render: each step reported; a broken scene or a
/// cancelled render leaves the last good image in place.
/// Returns the files the scene imports (read or not), to be watched too.
fn render_once(
    opts: &WatchOptions,
    path: &Path,
    what: &str,
    cancel: &AtomicBool,
    log: &(dyn Fn(&str) + Sync),
) -> Vec<PathBuf> {
    let mut imports = Vec::new();
    render_and_learn_imports(opts, path, what, cancel, log, &mut imports);
    imports
}

fn render_and_learn_imports(
    opts: &WatchOptions,
    path: &Path,
    what: &str,
    cancel: &AtomicBool,
    log: &(dyn Fn(&str) + Sync),
    imports: &mut Vec<PathBuf>,
) {
    let shown = opts.scene.display().to_string();
    let start = Instant::now();
    let source = match std::fs::read(path).map(crate::syntax::decode) {
        Ok(Ok(s)) => s,
        Ok(Err((line, column))) => {
            log(&format!(
                "{} {shown} {what}: not UTF-8 text (line {line}, column {column}); keeping the last image",
                clock()
            ));
            return;
        }
        Err(e) => {
            // Mid-rename, or deleted: the next event brings it back.
            log(&format!(
                "{} {shown} {what}: cannot read it ({e}); keeping the last image",
                clock()
            ));
            return;
        }
    };
    let mut scene = match crate::compile_source(&shown, &source) {
        Ok(s) => {
            imports.clone_from(&s.imports);
            s
        }
        Err(e) => {
            *imports = e.imported.iter().filter_map(|f| f.path.clone()).collect();
            for report in e.reports() {
                log(&format!("{report:?}"));
            }
            if e.unreported() > 0 {
                log(&format!("... and {} more errors", e.unreported()));
            }
            log(&format!(
                "{} {what}: {e}; keeping the last good image",
                clock()
            ));
            if let Some(board) = &opts.board {
                board.publish_diagnostics(e.render_plain());
            }
            return;
        }
    };
    if let Err(message) = (opts.adjust)(&mut scene) {
        log(&message);
        log(&format!(
            "{} {what}: not rendered as set (see above); keeping the last good image",
            clock()
        ));
        if let Some(board) = &opts.board {
            board.publish_diagnostics(message);
        }
        return;
    }
    // Warnings never stop a live render: it shows what it can. They are
    // judged on the scene as adjusted (the width decides W0004).
    let warnings = crate::SceneError::new(&shown, &source, scene.warnings.clone());
    for report in warnings.reports() {
        log(&format!("{report:?}"));
    }
    if let Some(board) = &opts.board {
        let text = if scene.warnings.is_empty() {
            String::new()
        } else {
            warnings.render_plain()
        };
        board.publish_warnings(text);
    }
    let compiled = start.elapsed();

    let mut preview = scene.clone();
    let d = opts.preview_divisor.max(1);
    preview.camera.width = (scene.camera.width / d).max(1);
    preview.camera.height = (scene.camera.height / d).max(1);
    preview.settings.samples = 1;
    let t = Instant::now();
    let Some(small) = trace(&preview, cancel, log, false) else {
        return;
    };
    let big = crate::output::upscale(&small, scene.camera.width, scene.camera.height);
    if !publish(opts, &big, log) {
        return;
    }
    let preview_time = t.elapsed();

    let t = Instant::now();
    let Some(image) = trace(&scene, cancel, log, true) else {
        log(&format!(
            "{} {shown} {what}: compile {} ms, preview {} ms; full render cancelled by a newer save",
            clock(),
            compiled.as_millis(),
            preview_time.as_millis()
        ));
        return;
    };
    if !publish(opts, &image, log) {
        return;
    }
    log(&format!(
        "{} {shown} {what}: compile {} ms, preview {} ms ({}x{}), full {} ms ({}x{}) -> {}",
        clock(),
        compiled.as_millis(),
        preview_time.as_millis(),
        preview.camera.width,
        preview.camera.height,
        t.elapsed().as_millis(),
        scene.camera.width,
        scene.camera.height,
        opts.output.display()
    ));
}

/// A render, or `None` when a newer save cancelled it or it failed (a
/// failure is reported; it must not end the watch). With `warn`, its
/// untrusted pixels are reported.
fn trace(
    scene: &Scene,
    cancel: &AtomicBool,
    log: &(dyn Fn(&str) + Sync),
    warn: bool,
) -> Option<crate::Image> {
    let result = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
        render_with(
            &Tracer::new(scene),
            &RenderOptions {
                cancel: Some(cancel),
                ..RenderOptions::default()
            },
        )
    }));
    match result {
        Ok(Ok((image, stats))) => {
            for warning in stats.warnings(&scene.settings).iter().filter(|_| warn) {
                log(&warning.to_string());
            }
            Some(image)
        }
        Ok(Err(_cancelled)) => None,
        Err(_) => {
            log("the render failed (an internal error); keeping the last good image");
            None
        }
    }
}

/// Writes the image (atomically) and shows it on the page. `false` when
/// the file cannot be written (reported).
fn publish(opts: &WatchOptions, image: &crate::Image, log: &(dyn Fn(&str) + Sync)) -> bool {
    let bytes = crate::output::encode_png(image);
    if let Err(e) = crate::output::write_atomically(&bytes, &opts.output, false) {
        log(&format!("cannot write {}: {e}", opts.output.display()));
        return false;
    }
    if let Some(board) = &opts.board {
        board.publish_image(bytes);
    }
    true
}
