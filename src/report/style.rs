//! The one look of every figure: palette, line widths, dash patterns, marker shapes and type
//! sizes. No other module names a colour.
//!
//! Sizes are in PNG pixels at [`DPI`] pixels per printed inch. Single-panel figures are
//! [`COLUMN_PX`] wide, a journal column (3.4 in), and multi-panel ones (trace, corner) are
//! designed for a full page width ([`PAGE_PX`], 7 in), so at those print widths every text is
//! at least 8 pt ([`pt`]). SVGs use the same numbers as user units.
//!
//! Series colours are the Okabe & Ito (2008) palette, chosen to stay distinct under the common
//! colour-vision deficiencies; its yellow is left out (it vanishes on white). Series are also
//! told apart by dash pattern ([`dash`], period 4) and marker ([`marker`], period 6), so a
//! figure printed in grey keeps its meaning: the first 84 series differ in at least one of
//! colour, dash and marker, and the first 12 in all three.

use plotters::style::RGBColor;

/// Pixels per printed inch of the PNGs.
pub(crate) const DPI: f64 = 200.0;
/// Width of a single-column figure: 3.4 in.
pub(crate) const COLUMN_PX: u32 = inches(3.4);
/// Width of a full-page figure: 7 in.
pub(crate) const PAGE_PX: u32 = inches(7.0);

/// Pixels for `x` inches at [`DPI`], to the nearest pixel.
const fn inches(x: f64) -> u32 {
    (x * DPI + 0.5) as u32
}

/// Pixels for a length of `points` (1/72 in) at [`DPI`], rounded up so text never prints
/// below its nominal size.
pub(crate) const fn pt(points: f64) -> u32 {
    let px = points * DPI / 72.0;
    let r = px as u32;
    if (r as f64) < px { r + 1 } else { r }
}

/// Tick labels: 8 pt.
pub(crate) const TICK_PX: u32 = pt(8.0);
/// Axis titles: 9 pt.
pub(crate) const LABEL_PX: u32 = pt(9.0);
/// Figure titles: 9 pt.
pub(crate) const TITLE_PX: u32 = pt(9.0);
/// Legend entries: 8 pt.
pub(crate) const LEGEND_PX: u32 = pt(8.0);
/// Notes printed inside a plot (zone names, "no finite values"): 8 pt.
pub(crate) const NOTE_PX: u32 = pt(8.0);

/// Main lines (curves): about 1 pt.
pub(crate) const LINE_PX: u32 = 3;
/// Secondary lines (contours, chains, medians over bands): about 0.7 pt.
pub(crate) const THIN_PX: u32 = 2;
/// Hairlines (band edges, error bars, many overlapping chains).
pub(crate) const HAIR_PX: u32 = 1;

/// Okabe–Ito without yellow: blue, vermillion, bluish green, reddish purple, orange, sky blue,
/// black.
const OKABE_ITO: [RGBColor; 7] = [
    RGBColor(0, 114, 178),
    RGBColor(213, 94, 0),
    RGBColor(0, 158, 115),
    RGBColor(204, 121, 167),
    RGBColor(230, 159, 0),
    RGBColor(86, 180, 233),
    RGBColor(0, 0, 0),
];

/// Colour of series `i` (cycles with period 7).
pub(crate) fn colour(i: usize) -> RGBColor {
    OKABE_ITO[i % OKABE_ITO.len()]
}

/// Colour of chain `i` in a plot that also marks the truth: the palette without the truth's
/// vermillion and the MAP's black, so neither mark is mistaken for a chain, and with the
/// orange (close to vermillion) last (period 5).
pub(crate) fn chain_colour(i: usize) -> RGBColor {
    const CHAINS: [usize; 5] = [0, 2, 3, 5, 4];
    OKABE_ITO[CHAINS[i % CHAINS.len()]]
}

/// Dash pattern `(dash, gap)` in pixels for series `i`; `None` is a solid line. Period 4.
pub(crate) fn dash(i: usize) -> Option<(u32, u32)> {
    match i % 4 {
        0 => None,
        1 => Some((12, 6)),
        2 => Some((3, 5)),
        _ => Some((20, 5)),
    }
}

/// Marker outline for series `i` (pixels around the point): circle, square, triangle,
/// diamond, inverted triangle, four-pointed star, then again (period 6).
pub(crate) fn marker(i: usize) -> Vec<(i32, i32)> {
    match i % 6 {
        0 => (0..16)
            .map(|k| {
                let a = k as f64 * std::f64::consts::TAU / 16.0;
                (
                    (5.5 * a.cos()).round() as i32,
                    (5.5 * a.sin()).round() as i32,
                )
            })
            .collect(),
        1 => vec![(-5, -5), (5, -5), (5, 5), (-5, 5)],
        2 => vec![(0, -7), (6, 4), (-6, 4)],
        3 => vec![(0, -7), (7, 0), (0, 7), (-7, 0)],
        4 => vec![(0, 7), (6, -4), (-6, -4)],
        _ => vec![
            (0, -8),
            (2, -2),
            (8, 0),
            (2, 2),
            (0, 8),
            (-2, 2),
            (-8, 0),
            (-2, -2),
        ],
    }
}

/// The true value of a parameter: vermillion, solid, a star marker.
pub(crate) const TRUTH: RGBColor = OKABE_ITO[1];
/// The maximum a posteriori point: black, dashed, a diamond marker (unlike the truth in
/// colour, dash and shape).
pub(crate) const MAP: RGBColor = OKABE_ITO[6];
/// Dash of the MAP lines.
pub(crate) const MAP_DASH: (u32, u32) = (8, 5);

/// Canvas.
pub(crate) const BACKGROUND: RGBColor = RGBColor(255, 255, 255);
/// Grid lines.
pub(crate) const GRID: RGBColor = RGBColor(230, 230, 230);
/// Axis lines.
pub(crate) const AXIS: RGBColor = RGBColor(90, 90, 90);
/// Reference lines (ln B = 0, B = 1).
pub(crate) const REFERENCE: RGBColor = RGBColor(60, 60, 60);
/// Secondary text (zone names, notes).
pub(crate) const MUTED: RGBColor = RGBColor(95, 95, 95);
/// Shading of the burn-in region of a trace plot.
pub(crate) const BURN_IN: RGBColor = RGBColor(232, 232, 232);

/// Kass & Raftery (1995) grades in |ln B|: upper edge, label, shade. The weaker the grade the
/// darker the grey, so the eye goes to where the verdict is in doubt and a sweep that is
/// decisive over most of its range keeps a white background. The edges are those of
/// [`kass_raftery`](super::kass_raftery) (2 ln B = 2, 6, 10).
pub(crate) const ZONES: [(f64, &str, RGBColor); 4] = [
    (1.0, "bare mention", RGBColor(222, 222, 222)),
    (3.0, "positive", RGBColor(234, 234, 234)),
    (5.0, "strong", RGBColor(245, 245, 245)),
    (f64::INFINITY, "very strong", RGBColor(255, 255, 255)),
];

/// Missing cells of a heat map: mid grey with a darker hatch.
pub(crate) const NAN_FILL: RGBColor = RGBColor(175, 175, 175);
/// Hatch of missing heat-map cells.
pub(crate) const NAN_HATCH: RGBColor = RGBColor(95, 95, 95);

/// ColorBrewer RdBu (11 classes, red = negative), a diverging map safe for colour-vision
/// deficiencies; the heat map centres it on zero.
pub(crate) const RDBU: [(u8, u8, u8); 11] = [
    (103, 0, 31),
    (178, 24, 43),
    (214, 96, 77),
    (244, 165, 130),
    (253, 219, 199),
    (247, 247, 247),
    (209, 229, 240),
    (146, 197, 222),
    (67, 147, 195),
    (33, 102, 172),
    (5, 48, 97),
];

/// Matplotlib's viridis sampled at ninths of its range: perceptually uniform, and it prints
/// well in grey.
pub(crate) const VIRIDIS: [(u8, u8, u8); 9] = [
    (68, 1, 84),
    (72, 40, 120),
    (62, 74, 137),
    (49, 104, 142),
    (38, 130, 142),
    (31, 158, 137),
    (53, 183, 121),
    (109, 205, 89),
    (253, 231, 37),
];

/// `c` blended with white: `a = 1` is `c`, `a = 0` white. An opaque tint, so overlapping
/// shapes do not darken each other and the PNG and SVG agree.
pub(crate) fn tint(c: RGBColor, a: f64) -> RGBColor {
    let a = a.clamp(0.0, 1.0);
    let mix = |d: u8| (255.0 - a * (255.0 - d as f64)).round() as u8;
    RGBColor(mix(c.0), mix(c.1), mix(c.2))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn type_is_at_least_eight_points_at_print_width() {
        assert_eq!(pt(8.0), 23);
        assert_eq!(pt(9.0), 25);
        assert_eq!((COLUMN_PX, PAGE_PX), (680, 1400));
        for px in [TICK_PX, LEGEND_PX, NOTE_PX, LABEL_PX, TITLE_PX] {
            assert!(px as f64 * 72.0 / DPI >= 8.0, "{px} px");
        }
        assert_eq!(COLUMN_PX as f64 / DPI, 3.4);
        assert_eq!(PAGE_PX as f64 / DPI, 7.0);
    }

    #[test]
    fn palette_is_okabe_ito_and_cycles() {
        assert_eq!(colour(0), RGBColor(0, 114, 178));
        assert_eq!(colour(1), RGBColor(213, 94, 0));
        assert_eq!(colour(6), RGBColor(0, 0, 0));
        assert_eq!(colour(7), colour(0));
        // No Okabe–Ito yellow (240, 228, 66): it is invisible on white.
        assert!((0..OKABE_ITO.len()).all(|i| colour(i) != RGBColor(240, 228, 66)));
    }

    #[test]
    fn series_differ_in_colour_dash_or_marker() {
        let key = |i: usize| (colour(i), dash(i), marker(i));
        for i in 0..84 {
            for j in 0..i {
                assert_ne!(key(i), key(j), "series {i} and {j} look alike");
            }
        }
        // The first 12 differ in dash and marker alone (greyscale).
        for i in 0..12 {
            for j in 0..i {
                assert!(dash(i) != dash(j) || marker(i) != marker(j), "{i} vs {j}");
            }
        }
        assert_eq!(dash(0), None);
        assert_eq!(marker(1), vec![(-5, -5), (5, -5), (5, 5), (-5, 5)]);
        assert_ne!((TRUTH, None), (MAP, Some(MAP_DASH)));
    }

    #[test]
    fn chain_colours_avoid_the_truth_and_map_marks() {
        for i in 0..20 {
            assert_ne!(chain_colour(i), TRUTH);
            assert_ne!(chain_colour(i), MAP);
        }
        assert_eq!(chain_colour(0), colour(0));
        assert_eq!(chain_colour(1), colour(2));
        assert_eq!(chain_colour(5), chain_colour(0));
    }

    #[test]
    fn tint_blends_with_white() {
        assert_eq!(tint(RGBColor(0, 114, 178), 1.0), RGBColor(0, 114, 178));
        assert_eq!(tint(RGBColor(0, 114, 178), 0.0), RGBColor(255, 255, 255));
        assert_eq!(tint(RGBColor(0, 0, 0), 0.5), RGBColor(128, 128, 128));
        assert_eq!(tint(RGBColor(0, 0, 0), 7.0), RGBColor(0, 0, 0));
    }
}
