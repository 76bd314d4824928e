//! Shared plumbing of the plots nes draws (`nes accuracy`, `nes probe`,
//! `nes rays`): the font kept in the repository, the legend box, and
//! writing one drawing as PNG or SVG.
//!
//! Input: a [`Figure`] (anything that can draw itself on a plotters
//! drawing area). Output: image files.

use std::path::Path;

use plotters::coord::Shift;
use plotters::prelude::*;

/// The font the plots are drawn with, kept in the repository (DejaVu
/// Sans, under its own licence beside it) so that plotting needs no system
/// fonts.
static FONT: &[u8] = include_bytes!("../../assets/fonts/DejaVuSans.ttf");

/// Something that draws itself on any plotters backend.
pub(crate) trait Figure {
    fn draw<DB>(&self, root: DrawingArea<DB, Shift>) -> Result<(), String>
    where
        DB: DrawingBackend,
        DB::ErrorType: 'static;
}

/// Write `figure` at `size` to `path`: SVG if the name ends in `.svg`,
/// PNG otherwise. The font in `assets/fonts` is "sans-serif"; no system
/// font is looked up.
///
/// Drawn into a temporary file renamed into place, like every output, so
/// that a failed drawing never leaves half a file (a device or a pipe is
/// drawn into in place).
pub(crate) fn write(figure: &impl Figure, path: &Path, size: (u32, u32)) -> Result<(), String> {
    let _ = plotters::style::register_font("sans-serif", FontStyle::Normal, FONT);
    let svg = path
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("svg"));
    let special = crate::output::special_target(path).map_err(|e| e.to_string())?;
    // The temporary name keeps the extension: plotters picks the image
    // format by it.
    let extension = path.extension().unwrap_or_default();
    let target = if special {
        path.to_path_buf()
    } else {
        crate::output::register_temporary(
            crate::output::temp_name_beside(path).with_extension(extension),
        )
    };
    let drawn = if svg {
        figure.draw(SVGBackend::new(&target, size).into_drawing_area())
    } else {
        figure.draw(BitMapBackend::new(&target, size).into_drawing_area())
    };
    if special {
        return drawn;
    }
    let moved = drawn.and_then(|()| std::fs::rename(&target, path).map_err(|e| e.to_string()));
    if moved.is_err() {
        let _ = std::fs::remove_file(&target);
    }
    crate::output::settled(&target);
    moved
}

/// `figure` as PNG at `png` and as SVG at `svg`.
pub(crate) fn write_png_and_svg(
    figure: &impl Figure,
    png: &Path,
    svg: &Path,
    size: (u32, u32),
) -> Result<(), String> {
    write(figure, png, size)?;
    write(figure, svg, size)
}

/// The legend box every plot uses, at `position`.
pub(crate) fn legend<'a, DB, CT>(
    chart: &mut ChartContext<'a, DB, CT>,
    position: SeriesLabelPosition,
) -> Result<(), String>
where
    DB: DrawingBackend + 'a,
    DB::ErrorType: 'static,
    CT: plotters::coord::CoordTranslate,
{
    chart
        .configure_series_labels()
        .position(position)
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .label_font(("sans-serif", 14))
        .draw()
        .map_err(|e| e.to_string())
}
