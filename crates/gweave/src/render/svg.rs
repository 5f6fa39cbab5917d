//! A [`Drawing`] as SVG: one `<path>` per run of strokes that join end to start with the same
//! colour, width and opacity (a polyline `M x y L x y ...`), so a perimeter is one element that
//! an editor can select. Coordinates are pixels with 0.01 px precision.

use std::fmt::Write;

use super::legend;
use super::view::{Drawing, Stroke};

/// Consecutive strokes that can be written as one polyline: `(first, last)` index pairs.
pub fn runs(strokes: &[Stroke]) -> Vec<(usize, usize)> {
    let mut out: Vec<(usize, usize)> = Vec::new();
    for (i, s) in strokes.iter().enumerate() {
        match out.last_mut() {
            Some((_, last)) if joins(&strokes[*last], s) => *last = i,
            _ => out.push((i, i)),
        }
    }
    out
}

fn joins(a: &Stroke, b: &Stroke) -> bool {
    a.to == b.from && a.colour == b.colour && a.width_px == b.width_px && a.alpha == b.alpha
}

fn hex(c: [u8; 3]) -> String {
    format!("#{:02x}{:02x}{:02x}", c[0], c[1], c[2])
}

/// XML-escapes text content.
fn escape(s: &str) -> String {
    s.replace('&', "&amp;").replace('<', "&lt;").replace('>', "&gt;")
}

/// The SVG document.
pub fn write_svg(d: &Drawing) -> String {
    let mut s = String::with_capacity(64 + d.strokes.len() * 24);
    let (w, h) = (d.width_px, d.height_px);
    // `write!` to a String cannot fail.
    let _ = writeln!(
        s,
        r#"<svg xmlns="http://www.w3.org/2000/svg" width="{w}" height="{h}" viewBox="0 0 {w} {h}">"#
    );
    let _ = writeln!(s, r#"<rect width="{w}" height="{h}" fill="{}"/>"#, hex(d.background));
    let _ = writeln!(s, r#"<g fill="none" stroke-linecap="round" stroke-linejoin="round">"#);
    for (first, last) in runs(&d.strokes) {
        let st = &d.strokes[first];
        let _ = write!(s, r#"<path d="M{:.2} {:.2}"#, st.from[0], st.from[1]);
        for p in &d.strokes[first..=last] {
            let _ = write!(s, "L{:.2} {:.2}", p.to[0], p.to[1]);
        }
        let _ = write!(s, r#"" stroke="{}" stroke-width="{:.2}""#, hex(st.colour), st.width_px);
        if st.alpha < 1.0 {
            let _ = write!(s, r#" stroke-opacity="{:.2}""#, st.alpha);
        }
        s.push_str("/>\n");
    }
    s.push_str("</g>\n");
    let text = r##"font-family="sans-serif" font-size="14" fill="#202020""##;
    for p in d.panels.iter().filter(|p| !p.title.is_empty()) {
        let _ = writeln!(s, r#"<text x="{}" y="{}" {text}>{}</text>"#, p.x_px + 12, h - 12, escape(&p.title));
    }
    // The box the PNG's legend takes, which the drawing is kept clear of (`render::legend`).
    if let Some([x, y, w, h]) = legend::legend_box(&d.legend) {
        let _ = writeln!(
            s,
            r##"<g class="legend"><rect x="{x}" y="{y}" width="{w}" height="{h}" fill="#ffffff" fill-opacity="0.85"/>"##,
        );
        let line = legend::line_px();
        for (i, e) in d.legend.iter().enumerate() {
            let y = 14 + line * i as u32;
            let c = [e.colour.r, e.colour.g, e.colour.b];
            let _ = writeln!(
                s,
                r##"<rect x="14" y="{}" width="14" height="14" fill="{}" stroke="#202020" stroke-opacity="0.5"/>"##,
                y + 2,
                hex(c)
            );
            let _ =
                writeln!(s, r#"<text x="{}" y="{}" {text}>{}</text>"#, 14 + line, y + 14, escape(&e.label));
        }
        s.push_str("</g>\n");
    }
    s.push_str("</svg>\n");
    s
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::render::view::BACKGROUND;

    fn st(from: [f32; 2], to: [f32; 2], colour: [u8; 3]) -> Stroke {
        Stroke { from, to, colour, width_px: 2.0, alpha: 1.0 }
    }

    #[test]
    fn chained_strokes_become_one_path() {
        let red = [255, 0, 0];
        let strokes = vec![
            st([0.0, 0.0], [10.0, 0.0], red),
            st([10.0, 0.0], [10.0, 10.0], red),
            st([20.0, 0.0], [30.0, 0.0], red),         // a gap: new path
            st([30.0, 0.0], [30.0, 5.0], [0, 0, 255]), // a colour change: new path
        ];
        assert_eq!(runs(&strokes), [(0, 1), (2, 2), (3, 3)]);
        let d = Drawing {
            width_px: 40,
            height_px: 20,
            background: BACKGROUND,
            strokes,
            legend: vec![],
            panels: vec![],
            layers_drawn: None,
        };
        let svg = write_svg(&d);
        assert_eq!(svg.matches("<path ").count(), 3);
        assert!(
            svg.contains(
                r##"<path d="M0.00 0.00L10.00 0.00L10.00 10.00" stroke="#ff0000" stroke-width="2.00"/>"##
            ),
            "{svg}"
        );
    }
}
