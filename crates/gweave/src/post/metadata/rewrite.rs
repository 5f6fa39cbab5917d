//! What the finishing copy writes for one line: the slicer's figures and the progress lines,
//! from [`Figures`](super::Figures), and nothing for any other line.

use memchr::memchr;

use super::{is_progress_line, prusa_duration, MetadataPass};

impl MetadataPass {
    /// The line `line` (without its end) as the copy writes it, or `None` to keep it. Only
    /// comments and `M73` are rewritten: any other line is kept without a look.
    ///
    /// Every line this rewrites holds an `M` or an `m`: `M73`, `;TIME_ELAPSED:`, `;TIME:`,
    /// `;PRINT.TIME:`, `;EXTRUDER_TRAIN.n.MATERIAL.VOLUME_USED:`, and `m` in each `filament`
    /// and `estimated` key. The copy finds its candidates by that byte
    /// ([`MetadataPass::copy`]); a key added here must keep the rule, which
    /// `every_rewritten_line_holds_an_m` checks.
    pub(super) fn rewritten(&mut self, line: &[u8]) -> Option<Vec<u8>> {
        match line.trim_ascii_start().first() {
            Some(b';' | b'M' | b'm') => self.rewrite(line),
            _ => None,
        }
    }

    /// The rewritten line, or `None` to keep it.
    pub(super) fn rewrite(&mut self, line: &[u8]) -> Option<Vec<u8>> {
        if is_progress_line(line) {
            let [t, t_silent] = self.figures.progress_s.get(self.progress).copied()?;
            self.progress += 1;
            return Some(self.progress_line(line, t, t_silent));
        }
        let text = line.trim_ascii_start().strip_prefix(b";")?;
        let f = &self.figures;
        let list =
            |v: &[f64], decimals: usize| v.iter().map(|x| format!("{x:.decimals$}")).collect::<Vec<_>>();
        let keep_key = |key_end: usize| line[..line.len() - text.len() + key_end].to_vec();
        // PrusaSlicer family: `; key = value`.
        if let Some((key, end)) = memchr(b'=', text).map(|i| (text[..i].trim_ascii(), i + 1)) {
            let value = match key {
                b"filament used [mm]" => {
                    self.wrote_filament = true;
                    list(&f.filament_mm, 2).join(", ")
                }
                b"filament used [cm3]" => list(&f.cm3(), 2).join(", "),
                b"filament used [g]" => list(&f.grams(), 2).join(", "),
                b"total filament used [g]" => format!("{:.2}", f.grams().iter().sum::<f64>()),
                b"total filament cost" => format!("{:.2}", f.cost()),
                b"estimated printing time (normal mode)" => prusa_duration(f.time_s[0]),
                b"estimated printing time (silent mode)" => prusa_duration(f.time_s[1]),
                b"estimated first layer printing time (normal mode)" => prusa_duration(f.first_layer_s[0]),
                b"estimated first layer printing time (silent mode)" => prusa_duration(f.first_layer_s[1]),
                b"filament used" => {
                    // Slic3r: one line per extruder.
                    let tool = self.slic3r_tool;
                    self.slic3r_tool += 1;
                    self.wrote_filament = true;
                    let mm = f.filament_mm.get(tool).copied().unwrap_or(0.0);
                    format!("{mm:.1}mm ({:.1}cm3)", mm * f.area_mm2() / 1000.0)
                }
                _ => return None,
            };
            let mut out = keep_key(end);
            out.push(b' ');
            out.extend_from_slice(value.as_bytes());
            return Some(out);
        }
        // Cura: `;KEY:value`.
        let (key, colon) = memchr(b':', text).map(|i| (&text[..i], i + 1))?;
        // Keep the space after the colon, if any (`;Filament used: 0m`, `;TIME:6666`).
        let end = colon + text[colon..].iter().take_while(|b| **b == b' ').count();
        let value = match key {
            b"Filament used" => {
                self.wrote_filament = true;
                f.filament_mm.iter().map(|mm| format!("{:.5}m", mm / 1000.0)).collect::<Vec<_>>().join(", ")
            }
            b"TIME" | b"PRINT.TIME" => format!("{:.0}", f.time_s[0]),
            _ => {
                // `EXTRUDER_TRAIN.<n>.MATERIAL.VOLUME_USED`, mm³.
                // The key's ends are ASCII: it is UTF-8 if what lies between them is.
                let tool = key.strip_prefix(b"EXTRUDER_TRAIN.")?.strip_suffix(b".MATERIAL.VOLUME_USED")?;
                let tool: usize = std::str::from_utf8(tool).ok()?.parse().ok()?;
                format!("{:.0}", f.filament_mm.get(tool).copied().unwrap_or(0.0) * f.area_mm2())
            }
        };
        let mut out = keep_key(end);
        out.extend_from_slice(value.as_bytes());
        Some(out)
    }

    /// `M73 P.. R..` (normal mode), `M73 Q.. S..` (silent mode) or `;TIME_ELAPSED:` at the
    /// estimated elapsed times `t_s` and `t_silent_s`: percent done and minutes left, both
    /// rounded, so they move monotonically to 100 and 0.
    fn progress_line(&self, line: &[u8], t_s: f64, t_silent_s: f64) -> Vec<u8> {
        let text = String::from_utf8_lossy(line);
        if text.trim_start().starts_with(";TIME_ELAPSED:") {
            let indent = &text[..text.len() - text.trim_start().len()];
            return format!("{indent};TIME_ELAPSED:{t_s:.6}").into_bytes();
        }
        let [total, total_silent] = self.figures.time_s;
        let percent =
            |t: f64, total: f64| if total > 0.0 { (100.0 * t / total).round().min(100.0) } else { 100.0 };
        let minutes_left = |t: f64, total: f64| ((total - t).max(0.0) / 60.0).round();
        let (code, comment) = match text.find(';') {
            Some(i) => (&text[..i], &text[i..]),
            None => (&text[..], ""),
        };
        let words: Vec<String> = code
            .split_whitespace()
            .map(|w| {
                let value = match w.as_bytes()[0].to_ascii_uppercase() {
                    b'P' => percent(t_s, total),
                    b'R' => minutes_left(t_s, total),
                    b'Q' => percent(t_silent_s, total_silent),
                    b'S' => minutes_left(t_silent_s, total_silent),
                    _ => return w.to_owned(),
                };
                format!("{}{value:.0}", &w[..1])
            })
            .collect();
        let mut out = words.join(" ");
        if !comment.is_empty() {
            out.push(' ');
            out.push_str(comment);
        }
        out.into_bytes()
    }
}
