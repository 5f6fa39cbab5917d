//! Where a picture's legend lies, and the drawing kept clear of it.
//!
//! The legend is a box in the picture's top left corner, one line per colour. The drawing is
//! fitted into the picture first; when its extents would then run under the box (a calibration
//! card's far left swatch, a part in the top left), it is fitted instead into the larger of the
//! two strips the box leaves free, right of it or below it, so the legend never hides a move.

use super::colour_by::LegendEntry;
use crate::picture::text;

/// Size of legend text, px.
pub(crate) const TEXT_PX: f32 = 16.0;
/// Legend box's distance from the picture's edges, px.
const INSET_PX: u32 = 8;
/// Space kept between the legend box and the drawing, px.
const GAP_PX: u32 = 8;

/// A rectangle in the picture, px: left, top, width, height.
pub(crate) type Rect = [u32; 4];

/// Height of one legend line, px.
pub(crate) fn line_px() -> u32 {
    text::line_height(TEXT_PX) + 4
}

/// The legend's box (`None` without a legend).
pub(crate) fn legend_box(legend: &[LegendEntry]) -> Option<Rect> {
    if legend.is_empty() {
        return None;
    }
    let line = line_px();
    let longest = legend.iter().map(|e| text::width(&e.label, TEXT_PX)).max().unwrap_or(0);
    Some([INSET_PX, INSET_PX, 12 + line + longest + 8, 8 + line * legend.len() as u32 + 4])
}

/// Whether two rectangles share a pixel.
pub(crate) fn overlap(a: Rect, b: Rect) -> bool {
    a[0] < b[0] + b[2] && b[0] < a[0] + a[2] && a[1] < b[1] + b[3] && b[1] < a[1] + a[3]
}

/// The part of `panel` to fit the drawing into: `panel` itself when `drawn` (where the drawing
/// lands when fitted into the whole panel) is clear of `legend`, else the larger of the strips
/// right of and below the box (`larger` compares two candidate rectangles by the scale the
/// drawing gets in each, and says whether the first is better).
pub(crate) fn clear_of(
    panel: Rect,
    drawn: Rect,
    legend: Option<Rect>,
    larger: impl Fn(Rect, Rect) -> bool,
) -> Rect {
    let Some(b) = legend.filter(|b| overlap(*b, drawn)) else {
        return panel;
    };
    let [x, y, w, h] = panel;
    let right = (b[0] + b[2] + GAP_PX).clamp(x, x + w);
    let below = (b[1] + b[3] + GAP_PX).clamp(y, y + h);
    let beside = [right, y, x + w - right, h];
    let under = [x, below, w, y + h - below];
    if larger(beside, under) {
        beside
    } else {
        under
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_drawing_under_the_legend_moves_to_the_larger_free_strip() {
        let legend = Some([8, 8, 100, 60]);
        // Clear of the box: the whole panel.
        assert_eq!(clear_of([0, 0, 400, 300], [150, 100, 50, 50], legend, |_, _| true), [0, 0, 400, 300]);
        // Under it: right of the box, or below it, as the caller's scale says.
        assert_eq!(clear_of([0, 0, 400, 300], [20, 20, 50, 50], legend, |_, _| true), [116, 0, 284, 300]);
        assert_eq!(clear_of([0, 0, 400, 300], [20, 20, 50, 50], legend, |_, _| false), [0, 76, 400, 224]);
        assert!(!overlap([0, 0, 10, 10], [10, 0, 5, 5]), "touching edges share no pixel");
    }
}
