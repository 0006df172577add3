//! Shared plotting machinery: the embedded font, rendering one figure to both PNG and SVG
//! atomically, and input-error helpers (colours and sizes are in [`super::style`]).

use super::axis::Axis;
use super::error::ReportError;
use super::style;
use crate::atomic;
use plotters::coord::Shift;
use plotters::coord::ranged1d::{DefaultFormatting, KeyPointHint, Ranged};
use plotters::coord::types::RangedCoordf64;
use plotters::prelude::*;
use std::ops::Range;
use std::path::{Path, PathBuf};
use std::sync::OnceLock;
use std::sync::atomic::{AtomicU64, Ordering};

/// Font family under which the embedded DejaVu Sans is registered.
pub(crate) const FONT: &str = "sans-serif";

/// Result of drawing on a backend `DB`.
pub(crate) type DrawResult<DB> =
    Result<(), DrawingAreaErrorKind<<DB as DrawingBackend>::ErrorType>>;

/// A figure that can draw itself on any plotters backend.
pub(crate) trait Figure {
    /// Canvas size in pixels (the SVG uses the same user units).
    fn size(&self) -> (u32, u32);
    /// Draws on a white canvas.
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> DrawResult<DB>;
}

/// plotters built without system fonts can only draw text after a font is registered, and
/// registering is global, so it happens once per process.
fn ensure_font() -> Result<(), ReportError> {
    static OK: OnceLock<bool> = OnceLock::new();
    let ok = *OK.get_or_init(|| {
        plotters::style::register_font(
            FONT,
            FontStyle::Normal,
            include_bytes!("../../assets/DejaVuSans.ttf"),
        )
        .is_ok()
    });
    if ok { Ok(()) } else { Err(ReportError::Font) }
}

/// `<dir>/<stem>.{png,svg}`, the name used in error messages about the figure as a whole.
pub(crate) fn figure_name(dir: &Path, stem: &str) -> PathBuf {
    dir.join(format!("{stem}.{{png,svg}}"))
}

/// An [`ReportError::InvalidInput`] for the figure `dir/stem`.
pub(crate) fn bad_input(
    dir: &Path,
    stem: &str,
    field: impl Into<String>,
    problem: impl Into<String>,
) -> ReportError {
    ReportError::InvalidInput {
        file: figure_name(dir, stem),
        field: field.into(),
        problem: problem.into(),
    }
}

/// Checks that an optional truth vector has one value per parameter.
pub(crate) fn check_truth(
    dir: &Path,
    stem: &str,
    truth: Option<&[f64]>,
    np: usize,
) -> Result<(), ReportError> {
    match truth {
        Some(t) if t.len() != np => Err(bad_input(
            dir,
            stem,
            "truth",
            format!(
                "has {} values but names has {np}; give one per parameter",
                t.len()
            ),
        )),
        _ => Ok(()),
    }
}

fn check_stem(dir: &Path, stem: &str) -> Result<(), ReportError> {
    if stem.is_empty() || stem.contains(['/', '\\']) || stem.starts_with('.') {
        return Err(bad_input(
            dir,
            stem,
            "stem",
            "must be a plain, non-empty file name without a leading dot or path separators",
        ));
    }
    Ok(())
}

/// Renders `fig` to `<dir>/<stem>.png` and `<dir>/<stem>.svg`, each through a temporary file in
/// `dir` renamed into place, so readers only ever see complete figures.
pub(crate) fn render<F: Figure>(dir: &Path, stem: &str, fig: &F) -> Result<(), ReportError> {
    check_stem(dir, stem)?;
    ensure_font()?;
    std::fs::create_dir_all(dir).map_err(|source| ReportError::Io {
        file: dir.to_path_buf(),
        source,
    })?;
    render_png(dir, stem, fig)?;
    render_svg(dir, stem, fig)
}

fn draw_err<E: std::error::Error + Send + Sync>(
    file: &Path,
) -> impl FnOnce(DrawingAreaErrorKind<E>) -> ReportError + '_ {
    move |e| ReportError::Draw {
        file: file.to_path_buf(),
        message: e.to_string(),
    }
}

fn render_png<F: Figure>(dir: &Path, stem: &str, fig: &F) -> Result<(), ReportError> {
    // plotters writes the PNG to a path itself, so the temporary must end in `.png` for it to
    // pick the encoder; the counter keeps concurrent renders of one stem apart.
    static COUNTER: AtomicU64 = AtomicU64::new(0);
    let n = COUNTER.fetch_add(1, Ordering::Relaxed);
    let file = dir.join(format!("{stem}.png"));
    let tmp = dir.join(format!(".{stem}.tmp-{}-{n}.png", std::process::id()));
    let result = (|| {
        {
            let root = BitMapBackend::new(&tmp, fig.size()).into_drawing_area();
            root.fill(&style::BACKGROUND).map_err(draw_err(&file))?;
            fig.draw(&root).map_err(draw_err(&file))?;
            root.present().map_err(draw_err(&file))?;
        }
        let io = |source| ReportError::Io {
            file: file.clone(),
            source,
        };
        std::fs::File::open(&tmp)
            .and_then(|f| f.sync_all())
            .map_err(io)?;
        std::fs::rename(&tmp, &file).map_err(io)
    })();
    if result.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    result
}

fn render_svg<F: Figure>(dir: &Path, stem: &str, fig: &F) -> Result<(), ReportError> {
    let file = dir.join(format!("{stem}.svg"));
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, fig.size()).into_drawing_area();
        root.fill(&style::BACKGROUND).map_err(draw_err(&file))?;
        fig.draw(&root).map_err(draw_err(&file))?;
        root.present().map_err(draw_err(&file))?;
    }
    atomic::write_bytes(&file, svg.as_bytes()).map_err(|source| ReportError::Io { file, source })
}

/// Text style of the given pixel size in the embedded font.
pub(crate) fn text(size: u32) -> TextStyle<'static> {
    (FONT, size).into_font().into()
}

/// The smallest a title is set at to fit its figure (px): the notes' size, so that a figure
/// scaled to a column still prints every text at 8 pt or more.
const TITLE_MIN_PX: u32 = style::NOTE_PX;

/// `title` and the style it fits `root`'s width in: [`style::TITLE_PX`] when it fits (every
/// title that did is drawn as before), else smaller down to the notes' 8 pt, else cut at the
/// end with "…" — a title centred wider than its figure lost both its ends (a
/// `bayes_factor.png` of two long model names).
pub(crate) fn fitted_title<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    title: &str,
) -> (String, TextStyle<'static>) {
    let (w, _) = root.dim_in_pixel();
    let room = w.saturating_sub(16);
    let fits = |t: &str, px: u32| {
        root.estimate_text_size(t, &text(px))
            .map_or(true, |(tw, _)| tw <= room)
    };
    let mut px = style::TITLE_PX;
    while px > TITLE_MIN_PX && !fits(title, px) {
        px -= 1;
    }
    let mut t = title.to_string();
    let mut chars: Vec<char> = title.chars().collect();
    while !fits(&t, px) && chars.len() > 1 {
        chars.pop();
        t = chars.iter().collect::<String>() + "…";
    }
    (t, text(px))
}

/// A linear plotters coordinate whose ticks are exactly those of an [`Axis`].
///
/// plotters' own `with_key_points` wrapper cannot be used for `f64` because it drops the
/// value formatter that `configure_mesh` requires; our labels come from [`Axis::label`]
/// anyway, so declaring the `Debug`-based default formatting is harmless.
pub(crate) struct Ticked {
    inner: RangedCoordf64,
    ticks: Vec<f64>,
}

impl Ticked {
    pub(crate) fn new(a: &Axis) -> Self {
        Ticked {
            inner: (a.lo..a.hi).into(),
            ticks: a.ticks.clone(),
        }
    }
}

impl Ranged for Ticked {
    type ValueType = f64;
    type FormatOption = DefaultFormatting;

    fn range(&self) -> Range<f64> {
        self.inner.range()
    }

    fn map(&self, value: &f64, limit: (i32, i32)) -> i32 {
        self.inner.map(value, limit)
    }

    fn key_points<H: KeyPointHint>(&self, hint: H) -> Vec<f64> {
        if hint.weight().allow_light_points() {
            Vec::new()
        } else {
            self.ticks.clone()
        }
    }
}

/// Chart coordinates with ticks chosen by [`Axis`].
pub(crate) type Coords = Cartesian2d<Ticked, Ticked>;

/// Pixel width needed for the tick labels of a vertical axis (DejaVu Sans averages about
/// 0.6 em per character), plus room for the rotated axis title.
pub(crate) fn y_label_area(y: &Axis, with_title: bool) -> u32 {
    let chars = y
        .ticks
        .iter()
        .map(|&t| y.label(t).chars().count())
        .max()
        .unwrap_or(1);
    (chars as f64 * 0.6 * style::TICK_PX as f64).ceil() as u32
        + 16
        + if with_title { style::LABEL_PX + 12 } else { 0 }
}

/// Builds a chart on `area` spanning the two axes, with an optional caption above it.
pub(crate) fn chart<'a, DB: DrawingBackend>(
    area: &'a DrawingArea<DB, Shift>,
    (x, y): (&Axis, &Axis),
    (x_area, y_area): (u32, u32),
    caption: Option<(&str, u32)>,
) -> Result<ChartContext<'a, DB, Coords>, DrawingAreaErrorKind<DB::ErrorType>> {
    let mut b = ChartBuilder::on(area);
    b.x_label_area_size(x_area).y_label_area_size(y_area);
    if let Some((c, size)) = caption {
        b.caption(c, text(size));
    }
    b.build_cartesian_2d(Ticked::new(x), Ticked::new(y))
}

/// What [`mesh`] prints around a chart.
#[derive(Debug, Default)]
pub(crate) struct MeshText {
    /// Horizontal axis title (already including any offset and power of ten).
    pub x_title: Option<String>,
    /// Vertical axis title.
    pub y_title: Option<String>,
    /// Print the horizontal tick labels.
    pub x_labels: bool,
    /// Print the vertical tick labels.
    pub y_labels: bool,
}

/// Draws grid, axes, tick labels and axis titles.
pub(crate) fn mesh<DB: DrawingBackend>(
    chart: &mut ChartContext<'_, DB, Coords>,
    (x, y): (&Axis, &Axis),
    t: &MeshText,
    label_size: u32,
) -> DrawResult<DB> {
    let fx = |v: &f64| {
        if t.x_labels {
            x.label(*v)
        } else {
            String::new()
        }
    };
    let fy = |v: &f64| {
        if t.y_labels {
            y.label(*v)
        } else {
            String::new()
        }
    };
    let mut m = chart.configure_mesh();
    m.x_label_formatter(&fx)
        .y_label_formatter(&fy)
        .label_style(text(label_size))
        .axis_desc_style(text(label_size + 2))
        .bold_line_style(style::GRID)
        .axis_style(style::AXIS);
    if let Some(d) = &t.x_title {
        m.x_desc(d.as_str());
    }
    if let Some(d) = &t.y_title {
        m.y_desc(d.as_str());
    }
    m.draw()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A title that fits keeps its size and text; one too wide is set smaller, then cut with
    /// "…", and then fits (before, it was centred past both edges).
    #[test]
    fn a_title_wider_than_its_figure_is_made_to_fit() {
        ensure_font().unwrap();
        let mut svg = String::new();
        let root = SVGBackend::with_string(&mut svg, (680, 400)).into_drawing_area();
        let short = "ln B(X/Y) along the reversible-jump run";
        let (t, _) = fitted_title(&root, short);
        assert_eq!(t, short);
        let size = |t: &str, px: u32| root.estimate_text_size(t, &text(px)).unwrap().0;
        assert!(size(short, style::TITLE_PX) <= 664);
        let long = format!(
            "ln B({}/{}) along the reversible-jump run",
            "springs_and_a_coupling_damper_between_the_masses",
            "springs_alone_with_the_damper_fixed_at_zero"
        );
        assert!(
            size(&long, style::TITLE_PX) > 664,
            "the case is not too wide"
        );
        let (t, style) = fitted_title(&root, &long);
        assert!(t.ends_with('…') && t.starts_with("ln B(springs_and"), "{t}");
        assert!(root.estimate_text_size(&t, &style).unwrap().0 <= 664);
        // a little too wide: smaller, not cut
        let (w_short, _) = root
            .estimate_text_size(short, &text(style::TITLE_PX))
            .unwrap();
        let slightly = format!(
            "{short} {}",
            "x".repeat(((664 - w_short) / 12 + 2) as usize)
        );
        assert!(size(&slightly, style::TITLE_PX) > 664);
        let (t, _) = fitted_title(&root, &slightly);
        assert_eq!(t, slightly, "shrinking alone makes it fit");
    }
}
