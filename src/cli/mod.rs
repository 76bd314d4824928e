//! The `nes` command: parse the arguments, run one subcommand, and report
//! any error once, here.

mod memory;
mod outputs;
mod overrides;
mod sharded;

use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::Instant;

use clap::{Parser, Subcommand};
use indicatif::{ProgressBar, ProgressStyle};
use miette::Diagnostic;

use crate::render::RenderOptions as TraceOptions;
use crate::scene::{Method, Scene};
use crate::space::SpaceKind;
use crate::trace::Tracer;
use outputs::Writes;
use overrides::{Checked, Overrides};

#[derive(Parser)]
#[command(
    name = "nes",
    version,
    about = "Ray trace implicit surfaces described in a .nes scene file"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
    /// Treat the scene's warnings (codes W....) as errors: report them and
    /// stop before any work, with a non-zero exit.
    #[arg(long, global = true)]
    deny_warnings: bool,
}

/// Set from `--deny-warnings`.
static DENY_WARNINGS: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);

/// Print a freshly compiled scene's warnings (each once per process, so an
/// animation does not repeat them every frame), or with `--deny-warnings`
/// turn them into the command's error.
fn report_warnings(name: &str, source: &str, scene: &Scene) -> Result<(), CliError> {
    report_panel_warnings(name, source, scene, None)
}

/// [`report_warnings`] for one panel of a side-by-side render: the
/// warnings not already shown, under a line naming the panel.
fn report_panel_warnings(
    name: &str,
    source: &str,
    scene: &Scene,
    panel: Option<&str>,
) -> Result<(), CliError> {
    use std::sync::Mutex;
    static SHOWN: Mutex<Vec<String>> = Mutex::new(Vec::new());
    if scene.warnings.is_empty() {
        return Ok(());
    }
    let report = crate::SceneError::new(name, source, scene.warnings.clone());
    if DENY_WARNINGS.load(std::sync::atomic::Ordering::SeqCst) {
        return Err(CliError::Scene(report));
    }
    let mut shown = SHOWN.lock().unwrap_or_else(|p| p.into_inner());
    let mut headed = panel.is_none();
    for (d, r) in report.diagnostics.iter().zip(report.reports()) {
        let key = format!("{}{:?}{}", d.code.as_str(), d.span(), d.message);
        if !shown.contains(&key) {
            if !headed {
                eprintln!("in the {} panel:", panel.unwrap_or_default());
                headed = true;
            }
            eprintln!("{r:?}");
            shown.push(key);
        }
    }
    Ok(())
}

#[derive(Subcommand)]
enum Command {
    /// Render a scene to a PNG image.
    Render {
        /// The scene file.
        scene: PathBuf,
        /// The image to write [default: the scene's name with .png].
        #[arg(short, long)]
        output: Option<PathBuf>,
        #[command(flatten)]
        overrides: Overrides,
        /// Worker threads [default: one per core].
        #[arg(long)]
        threads: Option<usize>,
        /// Render the scene in each of these spaces (comma-separated, in
        /// any case: euclidean, torus, sphere, s3, h3, metric) and write the
        /// panels side by side. A space the scene declares keeps its
        /// parameters; the others take the defaults (torus [-10, 10]^3 with
        /// 500 wraps, sphere R 25, S3 and H3 R 10, metric the flat one,
        /// integrated).
        #[arg(long, value_delimiter = ',')]
        space: Vec<String>,
        /// Print no progress bar and no summary line: only errors and warnings.
        #[arg(short, long)]
        quiet: bool,
        /// Render frames FIRST..END of an animation (END excluded, as a
        /// Rust range reads; FIRST..=LAST includes LAST). The scene's
        /// `frame` and `time` (frame / fps) change from frame to frame.
        /// Writes an animated PNG (-o out.png), a GIF (-o out.gif) or one
        /// PNG per frame (-o out-%04d.png).
        #[arg(long, value_name = "RANGE")]
        frames: Option<String>,
        /// Frames per second: sets `time` and the playback speed.
        #[arg(long, default_value_t = 24.0, allow_negative_numbers = true)]
        fps: f64,
        /// Render one frame of an animation as a still image.
        #[arg(long, conflicts_with = "frames", allow_negative_numbers = true)]
        frame: Option<u32>,
        /// Render only shard K of N (K from 0): a band of rows of a still,
        /// or a run of frames of an animation, cut so that the N shards
        /// cost about the same. Writes a shard file (-o, default
        /// SCENE.K-of-N.shard) that `nes stitch` puts together.
        #[arg(long, value_name = "K/N")]
        shard: Option<String>,
        /// With --shard: skip the render if the output already holds this
        /// shard, complete.
        #[arg(long, requires = "shard")]
        resume: bool,
    },
    /// Put the shard files of one render together into the image (or the
    /// animation) a single render would have written, byte for byte.
    Stitch {
        /// Every shard file of the render, in any order.
        #[arg(required = true)]
        shards: Vec<PathBuf>,
        /// The image or animation to write (.png, .gif, or a name with
        /// %04d for numbered frames).
        #[arg(short, long)]
        output: PathBuf,
    },
    /// Render, then render again on every save of the scene file: a quick
    /// preview first, then the full image. A broken save prints its
    /// diagnostics and keeps the last good image. Ctrl-C stops.
    Watch {
        /// The scene file.
        scene: PathBuf,
        /// The image to write [default: the scene's name with .png].
        #[arg(short, long)]
        output: Option<PathBuf>,
        #[command(flatten)]
        overrides: Overrides,
        /// Serve a page that shows each new image (and the errors of a
        /// broken save) as it happens. ADDR is a port or host:port; the
        /// default, and a bare port, listen on 127.0.0.1 only. The page
        /// answers to that address and to localhost, no other name.
        #[arg(long, value_name = "ADDR", num_args = 0..=1, default_missing_value = "8737")]
        serve: Option<String>,
    },
    /// Parse and compile a scene without rendering; print any diagnostics.
    Check {
        /// The scene file.
        scene: PathBuf,
    },
    /// Run time against error: render with every applicable method over a
    /// ladder of settings, and compare each pixel's hit with a reference
    /// rendered with the tightest settings.
    Accuracy {
        /// The scene file.
        scene: PathBuf,
        /// The plot to write, as PNG and beside it as SVG [default: the
        /// scene's name with -accuracy.png].
        #[arg(short, long)]
        output: Option<PathBuf>,
        /// Image width in pixels [default: 320, or the scene's if smaller].
        #[arg(long, allow_negative_numbers = true)]
        width: Option<i64>,
        /// Image height in pixels.
        #[arg(long, allow_negative_numbers = true)]
        height: Option<i64>,
    },
    /// Draw how rays travel: the paths of one pixel row or column, every
    /// k-th pixel, or listed pixels, with every point where the method
    /// evaluated an object, the hits, the shadow rays, and the objects'
    /// cross sections, seen from the side, from the top, or in any
    /// axis-aligned plane.
    Rays {
        /// The scene file.
        scene: PathBuf,
        /// The rays of this pixel row.
        #[arg(long, conflicts_with_all = ["column", "pixel"])]
        row: Option<u32>,
        /// The rays of this pixel column [default: the middle column].
        #[arg(long, conflicts_with = "pixel")]
        column: Option<u32>,
        /// The ray of this pixel (X,Y); repeat for more.
        #[arg(long, value_name = "X,Y")]
        pixel: Vec<String>,
        /// Every k-th pixel along the row or column, or of the whole image
        /// when no row, column or pixel is given [default: about 24 rays
        /// along a row or column].
        #[arg(long)]
        every: Option<u32>,
        /// The drawing plane: side (x-z), top (x-y), front (y-z), each
        /// through the camera, or a plane such as y=0.5.
        #[arg(long, default_value = "side")]
        view: String,
        /// The drawing to write: .svg, or .png [default: the scene's name
        /// with -rays.svg].
        #[arg(short, long)]
        output: Option<PathBuf>,
        /// Also render the scene to this PNG with the chosen pixels marked
        /// red (the report's figure 11).
        #[arg(long, value_name = "IMAGE.png")]
        mark: Option<PathBuf>,
        #[command(flatten)]
        overrides: Overrides,
    },
    /// Follow one pixel's ray: each object's function against distance
    /// along the path, where the method evaluated it, the roots, and where
    /// the ray stopped; printed as a table and drawn as a plot.
    Probe {
        /// The scene file.
        scene: PathBuf,
        /// The pixel, as X,Y from the image's top left.
        #[arg(long, value_name = "X,Y")]
        pixel: String,
        /// The plot to write, as PNG and beside it as SVG [default: the
        /// scene's name with -probe.png].
        #[arg(short, long)]
        output: Option<PathBuf>,
        /// How far along the path to show [default: half again the
        /// distance where the ray stopped, or the whole ray].
        #[arg(long)]
        distance: Option<f64>,
        #[command(flatten)]
        overrides: Overrides,
    },
    /// Print the render plan: per object its expression size, how its hits
    /// are found and its bound; what the renderer skips; the work per ray.
    Explain {
        /// The scene file.
        scene: PathBuf,
        /// Intersection method, overriding the scene.
        #[arg(long)]
        method: Option<String>,
    },
}

/// Everything that can stop the command, reported once in `main`.
#[derive(Debug, thiserror::Error, Diagnostic)]
enum CliError {
    #[error("cannot read the scene file {path}")]
    #[diagnostic(code(E0401), help("check the path and that the file is readable"))]
    Read {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error("{path} is not UTF-8 text: the byte at line {line}, column {column} is not UTF-8")]
    #[diagnostic(
        code(E0403),
        help(
            "save the scene file as UTF-8 (every editor can; in Notepad: Save as, Encoding UTF-8)"
        )
    )]
    NotText {
        path: PathBuf,
        line: usize,
        column: usize,
    },
    /// Stopped by Ctrl-C (exit code 130, as shells expect).
    #[error("interrupted")]
    #[diagnostic(code(E0502), help("{0}"))]
    Interrupted(&'static str),
    #[error(transparent)]
    Scene(crate::SceneError),
    #[error(transparent)]
    #[diagnostic(
        code(E0402),
        help("check that the folder exists and is writable, or choose another path with -o")
    )]
    Write(#[from] crate::output::WriteError),
    /// A command-line value that is malformed, out of range, or does not
    /// fit the scene.
    #[error("{message}")]
    #[diagnostic(code(E0501))]
    Argument {
        message: String,
        #[help]
        help: String,
    },
    /// The command could not be carried out (a port in use, a folder that
    /// cannot be watched, a plot that cannot be written, an interrupt).
    #[error("{message}")]
    #[diagnostic(code(E0502))]
    Failed {
        message: String,
        #[help]
        help: String,
    },
    #[error(transparent)]
    #[diagnostic(transparent)]
    Shard(#[from] crate::shard::ShardError),
    #[error("cannot start {0} worker threads")]
    #[diagnostic(
        code(E0501),
        help("give --threads a number from 1 to 256; the number of cores is the fastest")
    )]
    Threads(usize),
}

/// Set by the first Ctrl-C, SIGTERM or SIGHUP.
static INTERRUPTED: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);
/// Whether the running command stops by itself once [`INTERRUPTED`] is set
/// (renders, animations, watch); otherwise a signal ends the process at
/// once.
static STOPS_ITSELF: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);

/// Ctrl-C, SIGTERM and SIGHUP (a batch system's stop, a closed terminal):
/// every temporary file is removed and the process exits with 130, at once
/// or, for a command that stops by itself, at a second signal.
fn on_signals() {
    use std::sync::atomic::Ordering;
    let _ = ctrlc::set_handler(|| {
        if INTERRUPTED.swap(true, Ordering::SeqCst) || !STOPS_ITSELF.load(Ordering::SeqCst) {
            crate::output::remove_temporaries();
            eprintln!("interrupted; nothing half-written is left behind");
            std::process::exit(130);
        }
    });
}

/// A closed pipe on stdout or stderr ends a one-shot command quietly, as
/// it ends `cat`: Rust ignores SIGPIPE, so every print would panic instead
/// (`nes probe ... | head -1` exited 101). An output file is written to
/// a temporary name and renamed, so none is left half-written. Watch mode
/// keeps ignoring the signal: its server writes to sockets a browser may
/// close, and it must never die of that.
fn end_quietly_on_closed_pipes() {
    #[cfg(unix)]
    // SAFETY: sets a signal's disposition to its default, in `main`
    // before any other thread (the signal handler's, rayon's) starts.
    unsafe {
        libc::signal(libc::SIGPIPE, libc::SIG_DFL);
    }
}

/// Declares that the running command watches the returned flag and stops
/// by itself when a signal sets it.
fn stops_itself() -> &'static std::sync::atomic::AtomicBool {
    STOPS_ITSELF.store(true, std::sync::atomic::Ordering::SeqCst);
    &INTERRUPTED
}

/// Run the command line: parse the arguments, run one subcommand and
/// report any error once.
pub fn main() -> ExitCode {
    let cli = Cli::parse();
    if !matches!(cli.command, Command::Watch { .. }) {
        end_quietly_on_closed_pipes();
    }
    DENY_WARNINGS.store(cli.deny_warnings, std::sync::atomic::Ordering::SeqCst);
    on_signals();
    if let Some(v) = crate::expr::jit::unrecognised_setting() {
        eprintln!(
            "warning: NES_JIT is {v:?}, neither on (on, 1, true, yes) nor off (off, 0, false, no); formulas are compiled to native code as usual"
        );
    }
    // Parts of a compile run on the worker threads and recurse as deep as
    // the formula nests (a `min` of 100 000 terms overflowed their
    // default 2 MB). Under a tight address-space limit the largest stack
    // that fits, as the probe finds: a pool whose threads cannot start
    // leaves rayon with none at all, and a panic on first use (a trial's
    // `ulimit -v 150000`). Fails only if a pool exists already, which
    // then serves.
    let workers = std::thread::available_parallelism().map_or(2, |n| n.get());
    let stack = [crate::compile::WORKER_STACK_BYTES, 16 << 20, 2 << 20]
        .into_iter()
        .find(|&bytes| threads_can_start(workers, bytes))
        .unwrap_or(2 << 20);
    let _ = rayon::ThreadPoolBuilder::new()
        .stack_size(stack)
        .build_global();
    // Everything below on a thread with a large stack: parsing nests as
    // deep as the file does (15 000 unary minuses overflowed the main
    // thread's 8 MB while checking that the output is no source file).
    let command = cli.command;
    let result = crate::compile::on_large_stack("nes-main", move || match command {
        Command::Check { scene } => check(&scene),
        Command::Watch {
            scene,
            output,
            overrides,
            serve,
        } => watch(&scene, output, overrides, serve),
        Command::Explain { scene, method } => explain(&scene, method),
        Command::Rays {
            scene,
            row,
            column,
            pixel,
            every,
            view,
            output,
            mark,
            overrides,
        } => rays(
            &scene,
            RaySelection {
                row,
                column,
                pixels: pixel,
                every,
            },
            &view,
            output,
            mark,
            &overrides,
        ),
        Command::Probe {
            scene,
            pixel,
            output,
            distance,
            overrides,
        } => probe(&scene, &pixel, output, distance, &overrides),
        Command::Accuracy {
            scene,
            output,
            width,
            height,
        } => accuracy(&scene, output, width, height),
        Command::Stitch { shards, output } => stitch(&shards, &output),
        Command::Render {
            scene,
            output,
            overrides,
            threads,
            space,
            quiet,
            frames,
            fps,
            frame,
            shard,
            resume,
        } => {
            let run = || {
                let options = RenderOptions {
                    overrides: overrides.check()?,
                    spaces: space,
                    quiet,
                    fps,
                    frame,
                    shard: shard
                        .as_deref()
                        .map(crate::shard::ShardIndex::parse)
                        .transpose()
                        .map_err(|message| CliError::Argument {
                            message: format!("--shard: {message}"),
                            help: "give K/N: shard K (from 0) of N, e.g. --shard 3/7".into(),
                        })?,
                    resume,
                };
                match frames {
                    Some(range) => animate(&scene, output, &options, &range),
                    None => render(&scene, output, &options),
                }
            };
            match threads {
                Some(n) if n == 0 || n > MAX_THREADS => Err(CliError::Threads(n)),
                Some(n) => match rayon::ThreadPoolBuilder::new()
                    .num_threads(n)
                    .stack_size(crate::compile::WORKER_STACK_BYTES)
                    .build()
                {
                    Ok(pool) => pool.install(run),
                    Err(_) => Err(CliError::Threads(n)),
                },
                None => run(),
            }
        }
    });
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(CliError::Scene(e)) => {
            for report in e.reports() {
                eprintln!("{report:?}");
            }
            if e.unreported() > 0 {
                eprintln!("... and {} more errors", e.unreported());
            }
            eprintln!("{e}");
            ExitCode::FAILURE
        }
        Err(e @ CliError::Interrupted(_)) => {
            eprintln!("{:?}", miette::Report::new(e));
            ExitCode::from(130)
        }
        Err(e) => {
            eprintln!("{:?}", miette::Report::new(e));
            ExitCode::FAILURE
        }
    }
}

/// The scene at `path`, with `adjust` (the command line's overrides)
/// applied before its warnings are reported: some depend on the width and
/// the method.
fn load(
    path: &Path,
    adjust: impl FnOnce(&mut Scene) -> Result<(), CliError>,
) -> Result<Scene, CliError> {
    load_at(path, crate::scene::Clock::default(), adjust)
}

/// The scene file's text. Only a regular file is read (a FIFO would block
/// and a device never end), and no more of it than the size limit and a
/// few bytes: the parser reports a larger file with its span.
fn read_source(path: &Path) -> Result<String, CliError> {
    use std::io::Read;
    let failed = |source| CliError::Read {
        path: path.to_path_buf(),
        source,
    };
    let meta = std::fs::metadata(path).map_err(failed)?;
    if !meta.is_file() {
        return Err(failed(std::io::Error::other(
            "it is not a regular file (a folder, a device or a pipe)",
        )));
    }
    let limit = crate::syntax::MAX_SOURCE_BYTES as u64;
    let mut bytes = Vec::new();
    std::fs::File::open(path)
        .and_then(|f| f.take(limit + 4).read_to_end(&mut bytes))
        .map_err(failed)?;
    if bytes.len() as u64 > limit {
        // Cut where the text is whole, so the size is what gets reported.
        if let Err(e) = std::str::from_utf8(&bytes) {
            if e.error_len().is_none() {
                bytes.truncate(e.valid_up_to());
            }
        }
    }
    crate::syntax::decode(bytes).map_err(|(line, column)| CliError::NotText {
        path: path.to_path_buf(),
        line,
        column,
    })
}

/// The scene at one frame of an animation, adjusted as [`load`] does.
fn load_at(
    path: &Path,
    clock: crate::scene::Clock,
    adjust: impl FnOnce(&mut Scene) -> Result<(), CliError>,
) -> Result<Scene, CliError> {
    let source = read_source(path)?;
    let name = path.display().to_string();
    let mut scene = crate::compile_source_at(&name, &source, clock).map_err(CliError::Scene)?;
    adjust(&mut scene)?;
    report_warnings(&name, &source, &scene)?;
    Ok(scene)
}

fn check(path: &Path) -> Result<(), CliError> {
    let scene = load(path, |_| Ok(()))?;
    let count = |n: usize, what: &str| format!("{n} {what}{}", if n == 1 { "" } else { "s" });
    let warnings = match scene.warnings.len() {
        0 => String::new(),
        n => format!(", {}", count(n, "warning")),
    };
    println!(
        "{}: ok ({}, {}{warnings})",
        path.display(),
        count(scene.objects.len(), "object"),
        count(scene.lights.len(), "light"),
    );
    Ok(())
}

fn watch(
    path: &Path,
    output: Option<PathBuf>,
    overrides: Overrides,
    serve: Option<String>,
) -> Result<(), CliError> {
    use std::sync::atomic::{AtomicBool, Ordering};
    use std::sync::Arc;

    // Checked once here; each save then applies them, and a save whose
    // scene cannot take them (an integrating method in a space with
    // straight paths) is reported like a broken save.
    let checked = overrides.check()?;
    // A save whose image does not fit in memory is reported too, rather
    // than the allocation aborting the watch.
    let adjust = move |scene: &mut Scene| {
        checked
            .apply(scene)
            .and_then(|()| check_memory(scene.camera.width, scene.camera.height))
            .map_err(|e| format!("{:?}", miette::Report::new(e)))
    };
    let board = match serve {
        None => None,
        Some(addr) => {
            let addr = serve_address(&addr)?;
            let board = crate::live::serve::Board::new();
            let bound = crate::live::serve::start(addr, board.clone(), Default::default())
                .map_err(|e| CliError::Failed {
                    message: format!("cannot listen on {addr}: {e}"),
                    help: "choose another port with --serve PORT".into(),
                })?;
            println!("serving the live preview at http://{bound}/");
            Some(board)
        }
    };
    // The first signal ends the watch after the render in flight (which
    // it cancels); a second exits at once.
    let quit = Arc::new(AtomicBool::new(false));
    {
        let (quit, interrupted) = (quit.clone(), stops_itself());
        std::thread::spawn(move || {
            while !interrupted.load(Ordering::SeqCst) {
                std::thread::sleep(std::time::Duration::from_millis(20));
            }
            quit.store(true, Ordering::SeqCst);
        });
    }
    let output = output.unwrap_or_else(|| path.with_extension("png"));
    outputs::checked(&output, Some(path), &[Writes::Png])?;
    let options = crate::live::watch::WatchOptions {
        scene: path.to_path_buf(),
        output: output.clone(),
        adjust: &adjust,
        preview_divisor: 4,
        quit,
        board,
    };
    eprintln!("watching {} (Ctrl-C to stop)", path.display());
    let log = |line: &str| eprintln!("{line}");
    crate::live::watch::run(&options, &log).map_err(|e| CliError::Failed {
        message: format!("cannot watch {}: {e}", path.display()),
        help: "check that the scene's folder exists and is readable".into(),
    })?;
    eprintln!("stopped; the last good image is {}", output.display());
    Ok(())
}

/// `--serve`'s value: a port (on loopback) or a host:port.
fn serve_address(text: &str) -> Result<std::net::SocketAddr, CliError> {
    if let Ok(port) = text.parse::<u16>() {
        return Ok(std::net::SocketAddr::from(([127, 0, 0, 1], port)));
    }
    text.parse().map_err(|_| CliError::Argument {
        message: format!("--serve: `{text}` is not a port or an address"),
        help: "give a port (8737) or host:port (127.0.0.1:8737)".into(),
    })
}

fn accuracy(
    path: &Path,
    output: Option<PathBuf>,
    width: Option<i64>,
    height: Option<i64>,
) -> Result<(), CliError> {
    let scene = load(path, |scene| {
        // Small by default: every method renders the scene several times.
        let width = match (width, height) {
            (None, None) => Some(i64::from(scene.camera.width.min(320))),
            _ => width,
        };
        let overrides = Overrides {
            width,
            height,
            ..Overrides::default()
        };
        overrides.check()?.apply(scene)
    })?;
    let plot = plot_paths(path, output, "accuracy")?;
    eprintln!("measuring {} ...", path.display());
    let report = crate::tools::accuracy::measure(&scene);
    print!("{}: {}", path.display(), report);
    write_plot(plot, |png, svg| {
        crate::tools::accuracy::plot(&report, png, svg)
    })
}

/// Where a command's plot goes: `-o` (a `.png`, or an `.svg` whose PNG
/// goes beside it), or beside the scene as `NAME-KIND.png`; the PNG and
/// the SVG, both checked before any work is done.
fn plot_paths(
    scene: &Path,
    output: Option<PathBuf>,
    kind: &str,
) -> Result<(PathBuf, PathBuf), CliError> {
    let chosen = output.unwrap_or_else(|| beside(scene, kind, "png"));
    let (png, svg) = match outputs::checked(&chosen, Some(scene), &[Writes::Png, Writes::Svg])? {
        Writes::Svg => (chosen.with_extension("png"), chosen),
        _ => (chosen.with_extension("png"), chosen.with_extension("svg")),
    };
    outputs::checked(&png, Some(scene), &[Writes::Png])?;
    outputs::checked(&svg, Some(scene), &[Writes::Svg])?;
    Ok((png, svg))
}

/// Write a command's plot to the paths [`plot_paths`] chose, and say where.
fn write_plot(
    (png, svg): (PathBuf, PathBuf),
    write: impl FnOnce(&Path, &Path) -> Result<(), String>,
) -> Result<(), CliError> {
    write(&png, &svg).map_err(|e| cannot_draw(&png, e))?;
    eprintln!("plot: {} and {}", png.display(), svg.display());
    Ok(())
}

/// `examples/seed.nes` -> `examples/seed-KIND.EXTENSION`.
fn beside(scene: &Path, kind: &str, extension: &str) -> PathBuf {
    let stem = scene.file_stem().unwrap_or_default().to_string_lossy();
    scene.with_file_name(format!("{stem}-{kind}.{extension}"))
}

fn cannot_draw(path: &Path, e: String) -> CliError {
    // The plotting library wraps the system's words in its own.
    let e = e
        .trim_start_matches("backend error: ")
        .trim_start_matches("Drawing backend error: ");
    CliError::Failed {
        message: format!("cannot write {}: {e}", path.display()),
        help: "check that the folder exists and is writable, or choose another path with -o".into(),
    }
}

/// `X,Y`: a pixel.
fn parse_pixel(text: &str) -> Result<(u32, u32), CliError> {
    let bad = || CliError::Argument {
        message: format!("--pixel: `{text}` is not a pixel"),
        help: "write the column and the row from the top left, e.g. --pixel 320,200".into(),
    };
    let (x, y) = text.split_once(',').ok_or_else(bad)?;
    Ok((
        x.trim().parse().map_err(|_| bad())?,
        y.trim().parse().map_err(|_| bad())?,
    ))
}

struct RaySelection {
    row: Option<u32>,
    column: Option<u32>,
    pixels: Vec<String>,
    every: Option<u32>,
}

fn rays(
    path: &Path,
    selection: RaySelection,
    view: &str,
    output: Option<PathBuf>,
    mark: Option<PathBuf>,
    overrides: &Overrides,
) -> Result<(), CliError> {
    use crate::tools::rays::{Selection, View};
    if selection.every == Some(0) {
        return Err(CliError::Argument {
            message: "--every must be at least 1".into(),
            help: "give the spacing of the rays in pixels, e.g. --every 20".into(),
        });
    }
    let checked = overrides.check()?;
    let scene = load(path, |scene| checked.apply(scene))?;
    let cam = scene.camera;
    let along = |n: u32| selection.every.unwrap_or((n / 24).max(1));
    let chosen = if let Some(y) = selection.row {
        Selection::Row {
            y,
            every: along(cam.width),
        }
    } else if let Some(x) = selection.column {
        Selection::Column {
            x,
            every: along(cam.height),
        }
    } else if !selection.pixels.is_empty() {
        Selection::Pixels(
            selection
                .pixels
                .iter()
                .map(|p| parse_pixel(p))
                .collect::<Result<_, _>>()?,
        )
    } else if let Some(every) = selection.every {
        Selection::Grid { every }
    } else {
        Selection::Column {
            x: cam.width / 2,
            every: along(cam.height),
        }
    };
    let pixels = chosen
        .pixels(cam.width, cam.height)
        .map_err(|message| CliError::Argument {
            message,
            help:
                "pixels count from (0, 0) at the top left; --width/--height change the image size"
                    .into(),
        })?;
    // Each ray is a few hundred drawn points; beyond this a drawing is
    // unreadable and its SVG huge.
    const MOST_RAYS: usize = 5000;
    if pixels.len() > MOST_RAYS {
        return Err(CliError::Argument {
            message: format!(
                "{} rays are too many to draw (at most {MOST_RAYS})",
                pixels.len()
            ),
            help: "draw one row or column (--row, --column), or space the rays out with a larger --every"
                .into(),
        });
    }
    let view = View::parse(view, cam.position).map_err(|e| CliError::Argument {
        message: format!("--view: {e}"),
        help: "use side, top, front, 3d, or a plane such as y=0.5".into(),
    })?;
    let diagram = crate::tools::rays::diagram(&scene, &pixels, view);
    let out = output.unwrap_or_else(|| beside(path, "rays", "svg"));
    outputs::checked(&out, Some(path), &[Writes::Svg, Writes::Png])?;
    if let Some(marked) = &mark {
        outputs::checked(marked, Some(path), &[Writes::Png])?;
    }
    crate::tools::rays::draw(&diagram, &out).map_err(|e| cannot_draw(&out, e))?;
    if let Some(image_path) = mark {
        let (mut image, _) = crate::render(&scene);
        for &(x, y) in &pixels {
            image.pixels[(y * image.width + x) as usize] = glam::DVec3::new(1.0, 0.0, 0.0);
        }
        crate::output::write_png(&image, &image_path)?;
        eprintln!(
            "wrote {}: the render, its {} drawn pixels in red",
            image_path.display(),
            pixels.len()
        );
    }
    let hits = diagram.rays.iter().filter(|r| r.hit.is_some()).count();
    let samples: usize = diagram.rays.iter().map(|r| r.samples.len()).sum();
    eprintln!(
        "wrote {}: {} rays ({hits} hit), {samples} evaluation points drawn",
        out.display(),
        diagram.rays.len()
    );
    Ok(())
}

fn probe(
    path: &Path,
    pixel: &str,
    output: Option<PathBuf>,
    distance: Option<f64>,
    overrides: &Overrides,
) -> Result<(), CliError> {
    let (x, y) = parse_pixel(pixel)?;
    if let Some(d) = distance {
        if !(d.is_finite() && d > 0.0) {
            return Err(CliError::Argument {
                message: format!("--distance must be a positive number, got {d}"),
                help: "give how far along the ray to plot, e.g. --distance 12".into(),
            });
        }
    }
    let checked = overrides.check()?;
    let scene = load(path, |scene| checked.apply(scene))?;
    let plot = plot_paths(path, output, "probe")?;
    let probe =
        crate::tools::probe::probe(&scene, x, y, distance).map_err(|e| CliError::Argument {
            message: e.to_string(),
            help:
                "pixels count from (0, 0) at the top left; --width/--height change the image size"
                    .into(),
        })?;
    // The plot first: a reader that stops early (`| head -1`) ends the
    // command at the table, which must not cost the plot.
    let (png, svg) = plot;
    crate::tools::probe::plot(&probe, &png, &svg).map_err(|e| cannot_draw(&png, e))?;
    print!("{probe}");
    eprintln!("plot: {} and {}", png.display(), svg.display());
    Ok(())
}

fn explain(path: &Path, method: Option<String>) -> Result<(), CliError> {
    let overrides = Overrides {
        method,
        ..Overrides::default()
    };
    let checked = overrides.check()?;
    let scene = load(path, |scene| checked.apply(scene))?;
    println!(
        "{}: {}",
        path.display(),
        crate::tools::explain::plan(&scene)
    );
    Ok(())
}

/// What `nes render` was asked for besides the scene and the output.
struct RenderOptions {
    overrides: Checked,
    spaces: Vec<String>,
    quiet: bool,
    fps: f64,
    /// A still of this frame of an animation.
    frame: Option<u32>,
    /// Render only this shard, into a shard file.
    shard: Option<crate::shard::ShardIndex>,
    /// Skip a shard whose file is already complete.
    resume: bool,
}

/// The most worker threads `--threads` may ask for: more than the cores
/// only costs memory (each thread has its stack and scratch space).
const MAX_THREADS: usize = 256;

/// Whether one render of `width` x `rows` pixels fits the memory budget;
/// if not, how many shards would make it fit.
fn check_memory(width: u32, rows: u32) -> Result<(), CliError> {
    if crate::render::fits_in_memory(width, rows) {
        // Linear colours and sRGB bytes per pixel, and room for the rest.
        const BYTES_PER_PIXEL: u64 = 24 + 3;
        const SLACK: u64 = 64 << 20;
        let pixels = width as u64 * rows as u64 * BYTES_PER_PIXEL;
        let need = pixels + SLACK;
        let short = match memory::available() {
            Some((left, what)) if need > left => {
                Some(format!("{what} leaves {}", readable_bytes(left)))
            }
            _ if !memory::can_reserve(pixels) => Some(
                "this process may not allocate that much (an address-space limit, `ulimit -v`?)"
                    .into(),
            ),
            _ => None,
        };
        return match short {
            Some(why) => Err(CliError::Argument {
                message: format!(
                    "a {width} x {rows} image needs about {} of memory; {why}",
                    readable_bytes(need)
                ),
                help: "make it smaller (`--width`, `--height`), or render it in shards (`--shard K/N`) and stitch them with `nes stitch`; see docs/scale.md".into(),
            }),
            None => Ok(()),
        };
    }
    // Bands are cut by cost, and may hold up to twice the even share.
    let per_shard = (crate::render::MAX_PIXELS_IN_MEMORY / width as u64).max(1);
    let shards = 2 * (rows as u64).div_ceil(per_shard);
    Err(CliError::Argument {
        message: format!(
            "a {width} x {rows} image is more than one render may hold in memory ({} pixels at most)",
            crate::render::MAX_PIXELS_IN_MEMORY
        ),
        help: format!(
            "render it in shards and stitch them: `--shard K/{shards}` for K = 0..{} (or more shards), then `nes stitch`; see docs/scale.md",
            shards - 1
        ),
    })
}

/// Whether `count` threads with stacks of `bytes` can run at once: each
/// is started, and all are joined.
fn threads_can_start(count: usize, bytes: usize) -> bool {
    let started: Vec<_> = (0..count)
        .map(|_| std::thread::Builder::new().stack_size(bytes).spawn(|| ()))
        .collect();
    let mut all = true;
    for thread in started {
        match thread {
            Ok(t) => all &= t.join().is_ok(),
            Err(_) => all = false,
        }
    }
    all
}

/// `bytes` for a message: "1.5 GB", "640 MB".
fn readable_bytes(bytes: u64) -> String {
    let b = bytes as f64;
    if b >= 1e9 {
        format!("{:.1} GB", b / 1e9)
    } else {
        format!("{:.0} MB", (b / 1e6).max(1.0))
    }
}

fn check_fps(fps: f64) -> Result<(), CliError> {
    if fps.is_finite() && fps > 0.0 && fps <= 1000.0 {
        Ok(())
    } else {
        Err(CliError::Argument {
            message: format!(
                "--fps must be above 0 and at most 1000, got {}",
                crate::compile::readable(fps)
            ),
            help: "give the frames per second, e.g. --fps 24".into(),
        })
    }
}

/// `--frames`: `A..B` (B excluded) or `A..=B`, frame numbers from 0.
/// The most frames one command renders: over an hour at 24 frames per
/// second, decided before any work (an animation's file or its numbered
/// frames grow with every frame).
const MAX_FRAMES: u32 = 100_000;

fn parse_frames(text: &str) -> Result<std::ops::Range<u32>, CliError> {
    let bad = || CliError::Argument {
        message: format!("--frames: `{text}` is not a range of frames"),
        help: "write FIRST..END (END excluded), e.g. --frames 0..60, or FIRST..=LAST".into(),
    };
    let (a, b, inclusive) = if let Some((a, b)) = text.split_once("..=") {
        (a, b, true)
    } else if let Some((a, b)) = text.split_once("..") {
        (a, b, false)
    } else {
        return Err(bad());
    };
    let too_large = || CliError::Argument {
        message: format!("--frames: `{text}` names a frame past {}", u32::MAX - 1),
        help: format!("frames are numbered from 0 to {}", u32::MAX - 1),
    };
    let number = |s: &str| -> Result<u32, CliError> {
        let s = s.trim();
        match s.parse::<u32>() {
            Ok(n) => Ok(n),
            Err(_) if !s.is_empty() && s.bytes().all(|b| b.is_ascii_digit()) => Err(too_large()),
            Err(_) => Err(bad()),
        }
    };
    let a = number(a)?;
    let b = number(b)?;
    let end = if inclusive {
        b.checked_add(1).ok_or_else(too_large)?
    } else {
        b
    };
    if end <= a {
        return Err(CliError::Argument {
            message: format!("--frames {text} holds no frame"),
            help: "the end must come after the start: 0..60 is frames 0 to 59".into(),
        });
    }
    Ok(a..end)
}

/// Frame `frame` of an animation's scene, with the command line's
/// overrides applied.
fn frame_scene(
    name: &str,
    source: &str,
    frame: u32,
    opts: &RenderOptions,
) -> Result<Scene, CliError> {
    let clock = crate::scene::Clock::at_frame(frame, opts.fps);
    let mut scene = crate::compile_source_at(name, source, clock).map_err(|e| {
        eprintln!("frame {frame}:");
        CliError::Scene(e)
    })?;
    opts.overrides.apply(&mut scene)?;
    report_warnings(name, source, &scene)?;
    Ok(scene)
}

/// Every frame of an animation must have the first frame's size.
fn same_size(scene: &Scene, frame: u32, first: u32, size: (u32, u32)) -> Result<(), CliError> {
    let got = (scene.camera.width, scene.camera.height);
    if got == size {
        return Ok(());
    }
    Err(CliError::Argument {
        message: format!(
            "frame {frame} is {}x{}, frame {first} was {}x{}",
            got.0, got.1, size.0, size.1
        ),
        help: "an animation's frames must share one size: keep width and height constant".into(),
    })
}

fn animate(
    path: &Path,
    output: Option<PathBuf>,
    opts: &RenderOptions,
    range: &str,
) -> Result<(), CliError> {
    use crate::output::{AnimationFormat, AnimationWriter};

    let start = Instant::now();
    let frames = parse_frames(range)?;
    // One command renders at most MAX_FRAMES: all of them, or its shard's
    // share.
    let share = (frames.end - frames.start).div_ceil(opts.shard.map_or(1, |s| s.count));
    if share > MAX_FRAMES {
        return Err(CliError::Argument {
            message: format!(
                "--frames {range} gives one command {share} frames to render, more than {MAX_FRAMES}"
            ),
            help: "render it in runs of frames, or as more shards of frames (--shard K/N)".into(),
        });
    }
    check_fps(opts.fps)?;
    if !opts.spaces.is_empty() {
        return Err(CliError::Argument {
            message: "--space and --frames cannot be combined".into(),
            help: "render the animation once per space, with the space set in the scene".into(),
        });
    }
    if let Some(shard) = opts.shard {
        return sharded::animation(path, output, opts, frames, shard);
    }
    let output = output.unwrap_or_else(|| path.with_extension("png"));
    outputs::not_a_source(&output, path)?;
    let format =
        AnimationFormat::of(&output).ok_or_else(|| {
            CliError::Argument {
        message: format!("cannot tell how to write an animation to {}", output.display()),
        help: "end the name in .png (animated PNG) or .gif, or put one %04d in it for one PNG per frame"
            .into(),
    }
        })?;
    outputs::checked_animation(&output, Some(path), format, frames.clone())?;
    let source = read_source(path)?;
    let name = path.display().to_string();
    let scene_at = |frame: u32| frame_scene(&name, &source, frame, opts);
    let first = scene_at(frames.start)?;
    if !first.animated && !opts.quiet {
        eprintln!(
            "note: the scene uses neither `time` nor `frame`, so every frame is the same image"
        );
    }
    let (width, height) = (first.camera.width, first.camera.height);
    check_memory(width, height)?;
    let count = frames.end - frames.start;
    let mut writer = AnimationWriter::create(&output, format, count, opts.fps, width, height)?;

    // A signal stops the render between pixels and drops the writer, which
    // removes the unfinished file; a second one exits at once.
    let stop = stops_itself();
    let bar = if opts.quiet {
        ProgressBar::hidden()
    } else {
        ProgressBar::new(count as u64)
    };
    bar.set_style(
        ProgressStyle::with_template("{msg} [{bar:40}] {pos}/{len} frames {elapsed} (eta {eta})")
            .expect("valid template")
            .progress_chars("=> "),
    );
    let mut stats = crate::RenderStats::default();
    for frame in frames.clone() {
        bar.set_message(format!("frame {frame}"));
        let scene = if frame == frames.start {
            first.clone()
        } else {
            scene_at(frame)?
        };
        same_size(&scene, frame, frames.start, (width, height))?;
        let options = TraceOptions {
            cancel: Some(stop),
            ..TraceOptions::default()
        };
        let Ok((image, frame_stats)) = crate::render::render_with(&Tracer::new(&scene), &options)
        else {
            bar.finish_and_clear();
            eprintln!("stopped; nothing written");
            return Err(CliError::Interrupted(
                "run the command again to render the animation",
            ));
        };
        stats += frame_stats;
        writer.push(frame, &image)?;
        bar.inc(1);
    }
    writer.finish()?;
    bar.finish_and_clear();
    if !opts.quiet {
        let written = match crate::output::numbered_path(&output, frames.start) {
            Some(first) => format!(
                "{} .. {}",
                first.display(),
                crate::output::numbered_path(&output, frames.end - 1)
                    .unwrap_or_default()
                    .display()
            ),
            None => output.display().to_string(),
        };
        eprintln!(
            "wrote {}: {} frames ({}..{}) of {width}x{height} at {} fps, {} primary + {} shadow rays; {:.2} s",
            written,
            count,
            frames.start,
            frames.end,
            opts.fps,
            human(stats.primary_rays),
            human(stats.shadow_rays),
            start.elapsed().as_secs_f64()
        );
    }
    warn(&stats, &first.settings)
}

/// The render's untrusted pixels, if any, as warnings on stderr (printed
/// even with `--quiet`: they say the image may be wrong); with
/// `--deny-warnings` they fail the command, after the image is written
/// (it is whole, and says where the trouble is).
fn warn(
    stats: &crate::RenderStats,
    settings: &crate::scene::RenderSettings,
) -> Result<(), CliError> {
    let warnings = stats.warnings(settings);
    for warning in &warnings {
        eprintln!("{warning}");
    }
    if warnings.is_empty() || !DENY_WARNINGS.load(std::sync::atomic::Ordering::SeqCst) {
        return Ok(());
    }
    Err(CliError::Failed {
        message: format!(
            "the render gave {} warning{} about its pixels, denied by --deny-warnings",
            warnings.len(),
            if warnings.len() == 1 { "" } else { "s" }
        ),
        help: "the image was written, with the untrusted pixels as the warnings say; fix what they name, or drop --deny-warnings".into(),
    })
}

fn render(path: &Path, output: Option<PathBuf>, opts: &RenderOptions) -> Result<(), CliError> {
    let start = Instant::now();
    check_fps(opts.fps)?;
    let clock = match opts.frame {
        Some(k) => crate::scene::Clock::at_frame(k, opts.fps),
        None => crate::scene::Clock::default(),
    };
    if let Some(shard) = opts.shard {
        return sharded::still(path, output, opts, clock, shard);
    }
    let scene = load_at(path, clock, |scene| {
        if opts.spaces.is_empty() {
            opts.overrides.apply(scene)
        } else {
            // Each space's panel takes what its space can (see space_variants).
            opts.overrides.apply_size_and_settings(scene);
            opts.overrides.check_step(scene)
        }
    })?;
    let panels = opts.spaces.len().max(1) as u64;
    let side_by_side = scene.camera.width as u64 * panels;
    if side_by_side > crate::compile::limits::MAX_IMAGE_SIDE as u64 {
        return Err(CliError::Argument {
            message: format!(
                "{panels} panels of {} pixels side by side are {side_by_side} pixels wide, past the widest image, {}",
                scene.camera.width,
                crate::compile::limits::MAX_IMAGE_SIDE
            ),
            help: "name fewer spaces in --space, or give a smaller --width".into(),
        });
    }
    check_memory(side_by_side as u32, scene.camera.height)?;
    let compiled = Instant::now();
    let output = output.unwrap_or_else(|| path.with_extension("png"));
    outputs::checked(&output, Some(path), &[Writes::Png])?;

    let variants = space_variants(&scene, &opts.spaces, path, clock, &opts.overrides)?;
    let mut panels = Vec::new();
    let mut stats = crate::RenderStats::default();
    let mut panel_times = Vec::new();
    for (label, variant) in &variants {
        let panel_start = Instant::now();
        let (image, frame_stats) = trace_with_progress(variant, opts.quiet, label);
        panel_times.push((label.clone(), panel_start.elapsed().as_secs_f64()));
        stats += frame_stats;
        panels.push((label.clone(), image));
    }
    let image = if panels.len() == 1 {
        panels.pop().unwrap().1
    } else {
        crate::output::side_by_side(&panels)
    };
    let traced = Instant::now();
    crate::output::write_png(&image, &output)?;
    if !opts.quiet {
        let ms = |a: Instant, b: Instant| (b - a).as_secs_f64() * 1e3;
        let now = Instant::now();
        let line = format!(
            "wrote {}: {}x{}, {} primary + {} shadow rays, {} evaluations; {:.3} s (compile {:.0} ms, trace {:.0} ms, write {:.0} ms)",
            output.display(),
            image.width,
            image.height,
            human(stats.primary_rays),
            human(stats.shadow_rays),
            human(stats.evaluations),
            (now - start).as_secs_f64(),
            ms(start, compiled),
            ms(compiled, traced),
            ms(traced, now),
        );
        eprintln!("{line}");
        if panel_times.len() > 1 {
            eprintln!("{}", panel_times_line(&panel_times));
        }
        if let Some(r) = stats.integration {
            eprintln!("{}", r.summary());
        }
    }
    warn(&stats, &scene.settings)
}

/// Each panel's trace time, and its ratio to the first panel's: how the
/// spaces of a side-by-side render compare in cost, measured in one run.
fn panel_times_line(times: &[(String, f64)]) -> String {
    let first = times[0].1;
    let parts: Vec<String> = times
        .iter()
        .enumerate()
        .map(|(i, (label, secs))| {
            if i == 0 || first <= 0.0 {
                format!("{label} {secs:.3} s")
            } else {
                format!("{label} {secs:.3} s ({:.1}x)", secs / first)
            }
        })
        .collect();
    format!("panels: {}", parts.join(", "))
}

fn trace_with_progress(
    scene: &Scene,
    quiet: bool,
    label: &str,
) -> (crate::Image, crate::RenderStats) {
    let tracer = Tracer::new(scene);
    let bar = if quiet {
        ProgressBar::hidden()
    } else {
        ProgressBar::new(1)
    };
    bar.set_style(
        ProgressStyle::with_template(
            "{spinner} {msg} [{bar:40}] {percent:>3}% {elapsed} (eta {eta})",
        )
        .expect("valid template")
        .progress_chars("=> "),
    );
    bar.set_message(label.to_string());
    let progress = |done: usize, total: usize| {
        bar.set_length(total as u64);
        bar.set_position(done as u64);
    };
    let options = TraceOptions {
        progress: Some(&progress),
        ..TraceOptions::default()
    };
    let result = crate::render::render_with(&tracer, &options).expect("no cancel token");
    bar.finish_and_clear();
    result
}

/// The scene itself, or one copy per space asked for, each with a label.
fn space_variants(
    scene: &Scene,
    names: &[String],
    path: &Path,
    clock: crate::scene::Clock,
    overrides: &Checked,
) -> Result<Vec<(String, Scene)>, CliError> {
    if names.is_empty() {
        return Ok(vec![(scene.space.label(), scene.clone())]);
    }
    let mut out = Vec::new();
    for name in names {
        let name = name.trim();
        // In any case: panel labels write `S3` and `H3`.
        let name = SpaceKind::canonical_name(name).ok_or_else(|| CliError::Argument {
            message: format!("unknown space `{name}`"),
            help: format!(
                "choose from {}, separated by commas (in any case)",
                crate::space::SPACE_NAMES.join(", ")
            ),
        })?;
        let kind = if scene.space.name() == name {
            scene.space.clone()
        } else {
            SpaceKind::default_named(name).expect("every listed space has defaults")
        };
        // S3 and H3 place objects by their isometries, and a metric's
        // camera is aimed in its frame, so the scene is compiled again for
        // them (and for a flat space, from such a scene).
        let recompile = |k: &SpaceKind| k.places_objects() || k.aims_camera();
        let mut variant = if recompile(&kind) || recompile(&scene.space) {
            let source = read_source(path)?;
            let mut v = crate::compile::compile_source_in(
                &path.display().to_string(),
                &source,
                clock,
                kind.clone(),
            )
            .map_err(CliError::Scene)?;
            overrides.apply_size_and_settings(&mut v);
            // The scene's warnings as this space sees them (W0006 for a
            // bound that is the whole space, in S3).
            let name = path.display().to_string();
            report_panel_warnings(&name, &source, &v, Some(&kind.label()))?;
            v
        } else {
            scene.clone()
        };
        // An integrating method has no meaning where paths are straight.
        if variant.settings.method == Method::Ode && !kind.can_integrate() {
            variant.settings.method = Method::Auto;
        }
        let label = kind.label();
        variant.space = kind;
        crate::compile::compute_bounds(&mut variant);
        out.push((label, variant));
    }
    Ok(out)
}

/// `nes stitch`: check the shards, then write what a single render would
/// have.
fn stitch(paths: &[PathBuf], output: &Path) -> Result<(), CliError> {
    let start = Instant::now();
    let shards = paths
        .iter()
        .map(|p| crate::shard::ShardFile::open(p))
        .collect::<Result<Vec<_>, _>>()?;
    let shards = crate::shard::check_set(shards)?;
    match &shards[0].header.whole {
        crate::shard::Whole::Still => {
            outputs::checked(output, None, &[Writes::Png])?;
        }
        crate::shard::Whole::Animation { frames, .. } => {
            if let Some(format) = crate::output::AnimationFormat::of(output) {
                outputs::checked_animation(output, None, format, frames.clone())?;
            }
        }
    }
    crate::shard::stitch(&shards, output)?;
    let h = &shards[0].header;
    eprintln!(
        "wrote {}: {} shards of {} ({}x{}); {:.2} s",
        output.display(),
        shards.len(),
        h.source,
        h.width,
        h.height,
        start.elapsed().as_secs_f64()
    );
    Ok(())
}

fn human(n: u64) -> String {
    match n {
        n if n >= 1_000_000 => format!("{:.1} M", n as f64 / 1e6),
        n if n >= 1_000 => format!("{:.1} k", n as f64 / 1e3),
        n => n.to_string(),
    }
}
