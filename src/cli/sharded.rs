//! `nes render --shard K/N`: one shard of a still or of an animation,
//! into a shard file (see [`crate::shard`]).
//!
//! Every shard estimates the whole render's cost the same way (a small
//! deterministic render per still, or per frame) and cuts it at the same
//! places, so N processes that never talk to each other render N parts
//! that tile the whole and cost about the same.

use std::ops::Range;
use std::path::{Path, PathBuf};
use std::time::Instant;

use super::{
    check_memory, frame_scene, human, outputs, read_source, same_size, CliError, RenderOptions,
};
use crate::render::{render_with, row_costs, RenderOptions as TraceOptions};
use crate::scene::{Clock, Scene};
use crate::shard::{self, Header, ShardIndex, ShardWriter, Whole};
use crate::trace::Tracer;

/// The longer side of the small render whose work per row (or per frame)
/// estimates the real one's.
const COST_SIDE: u32 = 256;
/// The same for each frame of an animation, where every frame is
/// estimated.
const FRAME_COST_SIDE: u32 = 48;

/// Where a shard goes without `-o`: `SCENE.K-of-N.shard` beside the scene.
fn default_output(scene: &Path, shard: ShardIndex) -> PathBuf {
    scene.with_extension(format!("{}-of-{}.shard", shard.index, shard.count))
}

/// Every setting that shapes the pixels beyond the source: the compiled
/// scene's after the command line's overrides, and the clock.
fn settings_text(scene: &Scene, clock: Option<Clock>) -> String {
    let s = &scene.settings;
    let mut text = format!(
        "width={} height={} samples={} method={} step={} epsilon={} max_distance={}",
        scene.camera.width,
        scene.camera.height,
        s.samples,
        s.method.name(),
        s.step,
        s.epsilon,
        s.max_distance
    );
    if let Some(c) = clock {
        text += &format!(" frame={} time={}", c.frame, c.time);
    }
    text
}

fn file_name(path: &Path) -> String {
    path.file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| path.display().to_string())
}

fn too_many(shard: ShardIndex, what: &str, have: u32) -> CliError {
    CliError::Argument {
        message: format!(
            "--shard {}/{}: the render has only {have} {what} to share among {} shards",
            shard.index, shard.count, shard.count
        ),
        help: format!("use at most {have} shards"),
    }
}

fn no_spaces(opts: &RenderOptions) -> Result<(), CliError> {
    if opts.spaces.is_empty() {
        Ok(())
    } else {
        Err(CliError::Argument {
            message: "--space and --shard cannot be combined".into(),
            help: "render one space per scene file, with the space set in the scene".into(),
        })
    }
}

/// Skip a shard already complete (`--resume`): whether it was skipped.
fn resumed(opts: &RenderOptions, output: &Path, header: &Header) -> bool {
    let done = opts.resume && shard::is_done(output, header);
    if done && !opts.quiet {
        eprintln!(
            "{}: shard {} of {} is complete; skipped",
            output.display(),
            header.shard.index,
            header.shard.count
        );
    }
    done
}

/// Shard `shard` of the still image of `path` at `clock`.
pub(super) fn still(
    path: &Path,
    output: Option<PathBuf>,
    opts: &RenderOptions,
    clock: Clock,
    shard: ShardIndex,
) -> Result<(), CliError> {
    let start = Instant::now();
    no_spaces(opts)?;
    let source = read_source(path)?;
    let name = path.display().to_string();
    let mut scene = crate::compile_source_at(&name, &source, clock).map_err(CliError::Scene)?;
    opts.overrides.apply(&mut scene)?;
    super::report_warnings(&name, &source, &scene)?;
    let output = output.unwrap_or_else(|| default_output(path, shard));
    outputs::checked(&output, Some(path), &[outputs::Writes::Shard])?;
    let height = scene.camera.height;
    // Each row also costs its share of memory and encoding: adding the
    // mean cost to every row keeps any band within about twice the even
    // share of rows, however cheap its rows are to trace.
    let mut costs = row_costs(&scene, COST_SIDE);
    let mean = costs.iter().sum::<u64>() / costs.len().max(1) as u64;
    costs.iter_mut().for_each(|c| *c += mean);
    let runs =
        shard::balanced_runs(&costs, shard.count).ok_or_else(|| too_many(shard, "rows", height))?;
    let rows = runs[shard.index as usize].clone();
    check_memory(scene.camera.width, rows.end - rows.start)?;
    let header = Header {
        scene: scene_identity(&source, &scene),
        source: file_name(path),
        settings: settings_text(&scene, opts.frame.map(|_| clock)),
        shard,
        whole: Whole::Still,
        width: scene.camera.width,
        height,
        part: rows.clone(),
    };
    if resumed(opts, &output, &header) {
        return Ok(());
    }
    let options = TraceOptions {
        rows: Some(rows.clone()),
        ..TraceOptions::default()
    };
    let (band, stats) =
        render_with(&Tracer::new(&scene), &options).expect("no cancel token, so no cancellation");
    let mut writer = ShardWriter::create(&output, &header)?;
    writer.push_image(&band)?;
    writer.finish()?;
    if !opts.quiet {
        eprintln!(
            "wrote {}: shard {} of {}, rows {}..{} of {}, {} primary + {} shadow rays; {:.2} s",
            output.display(),
            shard.index,
            shard.count,
            rows.start,
            rows.end,
            height,
            human(stats.primary_rays),
            human(stats.shadow_rays),
            start.elapsed().as_secs_f64()
        );
    }
    super::warn(&stats, &scene.settings)
}

/// Shard `shard` of the animation of `path` over `frames`.
pub(super) fn animation(
    path: &Path,
    output: Option<PathBuf>,
    opts: &RenderOptions,
    frames: Range<u32>,
    shard: ShardIndex,
) -> Result<(), CliError> {
    let start = Instant::now();
    no_spaces(opts)?;
    let source = read_source(path)?;
    let name = path.display().to_string();
    let scene_at = |frame: u32| frame_scene(&name, &source, frame, opts);
    let output = output.unwrap_or_else(|| default_output(path, shard));
    outputs::checked(&output, Some(path), &[outputs::Writes::Shard])?;
    let first = scene_at(frames.start)?;
    let (width, height) = (first.camera.width, first.camera.height);
    check_memory(width, height)?;
    let mut costs = Vec::with_capacity(frames.len());
    for frame in frames.clone() {
        let scene = if frame == frames.start {
            first.clone()
        } else {
            scene_at(frame)?
        };
        costs.push(row_costs(&scene, FRAME_COST_SIDE).iter().sum());
    }
    let count = frames.end - frames.start;
    let runs = shard::balanced_runs(&costs, shard.count)
        .ok_or_else(|| too_many(shard, "frames", count))?;
    let run = &runs[shard.index as usize];
    let part = frames.start + run.start..frames.start + run.end;
    let header = Header {
        scene: scene_identity(&source, &first),
        source: file_name(path),
        settings: settings_text(&first, None),
        shard,
        whole: Whole::Animation {
            frames: frames.clone(),
            fps: opts.fps,
        },
        width,
        height,
        part: part.clone(),
    };
    if resumed(opts, &output, &header) {
        return Ok(());
    }
    let mut writer = ShardWriter::create(&output, &header)?;
    let mut stats = crate::RenderStats::default();
    let mut settings = None;
    for frame in part.clone() {
        let scene = scene_at(frame)?;
        same_size(&scene, frame, frames.start, (width, height))?;
        let (image, frame_stats) = crate::render(&scene);
        stats += frame_stats;
        writer.push_image(&image)?;
        settings = Some(scene.settings);
    }
    let primary = stats.primary_rays;
    writer.finish()?;
    if !opts.quiet {
        eprintln!(
            "wrote {}: shard {} of {}, frames {}..{} of {}..{}, {} primary rays; {:.2} s",
            output.display(),
            shard.index,
            shard.count,
            part.start,
            part.end,
            frames.start,
            frames.end,
            human(primary),
            start.elapsed().as_secs_f64()
        );
    }
    if let Some(settings) = settings {
        super::warn(&stats, &settings)?;
    }
    Ok(())
}

/// The hash naming a scene's text and every file it imports, so that
/// shards rendered before and after a library changed are not stitched.
fn scene_identity(source: &str, scene: &Scene) -> String {
    let mut all = source.to_string();
    for path in &scene.imports {
        all.push('\0');
        all.push_str(&path.display().to_string());
        all.push('\0');
        all.push_str(&std::fs::read_to_string(path).unwrap_or_default());
    }
    shard::scene_hash(&all)
}
