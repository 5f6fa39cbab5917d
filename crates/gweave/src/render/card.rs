//! The calibration card's picture (`gweave mix --calibration-card --preview card.png`): the
//! card's G-code drawn from above in the colours the profile's filaments are predicted to make,
//! each swatch with its number, so the picture tells which printed swatch is which when you
//! measure them (the numbers are those of `card.json` and of the CSV `--fit` reads).

use std::path::Path;

use super::colour_by::ColourBy;
use super::mix_colour::MixColours;
use super::view::{Drawing, ViewKind, ViewOptions};
use super::{png_out, PreviewSettings, RenderError};
use crate::colour::{Lab, Srgb8};
use crate::pass::Quiet;
use crate::picture::{text, Image};
use crate::post::mix::card::Swatch;
use crate::post::mix::profile::CardConfig;

/// Number colour on a light swatch.
const DARK: [u8; 3] = [0x20, 0x20, 0x20];
/// Number colour on a dark swatch.
const LIGHT: [u8; 3] = [0xff, 0xff, 0xff];
/// Swatches lighter than this (CIE L*) get dark numbers: mid-grey is L* 50, and at 55 both
/// kinds of number contrast alike.
const LIGHT_SWATCH_L: f64 = 55.0;

/// The drawing of the card written to `card_gcode` (the card's top view, coloured by mix with
/// the filaments of `mix`, [`MixColours::from_profile`]) and the pixels of each swatch's
/// centre, in `swatches`' order.
pub fn card_drawing(
    card_gcode: &Path,
    swatches: &[Swatch],
    mix: MixColours,
    card: &CardConfig,
    size_px: [u32; 2],
) -> Result<(Drawing, Vec<[f32; 2]>), RenderError> {
    let [width_px, height_px] = size_px;
    let options = PreviewSettings {
        view: ViewOptions {
            kind: ViewKind::Top,
            width_px,
            height_px,
            colour_by: ColourBy::Mix,
            line_width_mm: card.line_mm as f32,
            ..ViewOptions::default()
        },
        mix: Some(mix),
        ..PreviewSettings::default()
    };
    options.check()?;
    let d = super::drawing(card_gcode, None, &options, &mut Quiet)?;
    let centres = match d.panels.first() {
        Some(p) => {
            swatches.iter().map(|s| p.projection.project([s.x_mm as f32, s.y_mm as f32, 0.0])).collect()
        }
        None => Vec::new(),
    };
    Ok((d, centres))
}

/// Size of a swatch's number: a third of the swatch's side, 10 to 40 px.
pub fn number_px(patch_mm: f64, scale_px_mm: f32) -> f32 {
    (patch_mm as f32 * scale_px_mm / 3.0).clamp(10.0, 40.0)
}

/// Where a swatch's number is drawn: the top left of the text centred on `centre`.
pub fn number_at(id: u32, centre: [f32; 2], size_px: f32) -> (i32, i32) {
    let label = id.to_string();
    let w = text::width(&label, size_px) as f32;
    let h = text::line_height(size_px) as f32;
    ((centre[0] - w / 2.0).round() as i32, (centre[1] - h / 2.0).round() as i32)
}

/// The colour a swatch's number is drawn in: dark on a light swatch, white on a dark one.
pub fn number_colour(swatch: &Swatch) -> [u8; 3] {
    let light = Srgb8::parse_hex(&swatch.predicted).map(|c| Lab::from(c).l > LIGHT_SWATCH_L).unwrap_or(true);
    if light {
        DARK
    } else {
        LIGHT
    }
}

/// The card's picture as PNG bytes: [`card_drawing`] with each swatch's number on it.
pub fn card_png(
    card_gcode: &Path,
    swatches: &[Swatch],
    mix: MixColours,
    card: &CardConfig,
    size_px: [u32; 2],
) -> Result<Vec<u8>, RenderError> {
    let (d, centres) = card_drawing(card_gcode, swatches, mix, card, size_px)?;
    let mut img: Image = png_out::rasterise(&d);
    if let Some(p) = d.panels.first() {
        let size = number_px(card.patch_mm, p.projection.scale_px_mm());
        for (s, c) in swatches.iter().zip(&centres) {
            let (x, y) = number_at(s.id, *c, size);
            img.text(x, y, &s.id.to_string(), size, number_colour(s));
        }
    }
    crate::picture::encode(&img).map_err(|e| RenderError::Encode(e.to_string()))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::post::mix::card::{calibration_card, CardReport};
    use crate::render::legend;
    use crate::render::view::BACKGROUND;

    /// The default profile's card written to a file of its own (removed when dropped), its
    /// report, and the picture `gweave preview card.gcode --view top --colour-by mix` draws.
    struct Card {
        path: std::path::PathBuf,
        report: CardReport,
        profile: MixProfile,
    }

    impl Card {
        fn new(name: &str) -> Card {
            Card::with(name, MixProfile::default())
        }

        fn with(name: &str, profile: MixProfile) -> Card {
            let (gcode, report) = calibration_card(&profile).unwrap();
            let path = std::env::temp_dir().join(format!("gweave-card-{}-{name}.gcode", std::process::id()));
            std::fs::write(&path, gcode).unwrap();
            Card { path, report, profile }
        }

        fn drawing(&self) -> (Drawing, Vec<[f32; 2]>) {
            self.drawing_at([1200, 900])
        }

        fn drawing_at(&self, size_px: [u32; 2]) -> (Drawing, Vec<[f32; 2]>) {
            let mix = MixColours::from_profile(&self.profile).unwrap();
            card_drawing(&self.path, &self.report.swatches, mix, &self.profile.card, size_px).unwrap()
        }

        /// A swatch's patch in the picture, px.
        fn patch_px(&self, d: &Drawing, s: &Swatch) -> legend::Rect {
            let p = &d.panels[0].projection;
            let half = (self.profile.card.patch_mm / 2.0) as f32;
            let a = p.project([s.x_mm as f32 - half, s.y_mm as f32 + half, 0.0]);
            let b = p.project([s.x_mm as f32 + half, s.y_mm as f32 - half, 0.0]);
            [a[0] as u32, a[1] as u32, (b[0] - a[0]).ceil() as u32, (b[1] - a[1]).ceil() as u32]
        }
    }

    impl Drop for Card {
        fn drop(&mut self) {
            let _ = std::fs::remove_file(&self.path);
        }
    }

    use crate::post::mix::profile::MixProfile;

    fn rgb(img: &Image, p: [f32; 2]) -> [u8; 3] {
        let px = img.pixel(p[0] as u32, p[1] as u32);
        [px[0], px[1], px[2]]
    }

    /// `got` is the colour `want` (`#rrggbb`) to within one unit a channel.
    fn assert_near(got: [u8; 3], want: &str, id: u32) {
        let w = Srgb8::parse_hex(want).unwrap();
        let off = [got[0].abs_diff(w.r), got[1].abs_diff(w.g), got[2].abs_diff(w.b)];
        assert!(off.iter().all(|&d| d <= 1), "swatch {id}: {got:?} is not {want}");
    }

    #[test]
    fn the_legend_covers_no_swatch_of_the_card() {
        // Issue 39: the legend lay over swatch 25, the far left of the back row, in pictures
        // that the card fills from side to side (1000 x 800, 800 x 600).
        let card = Card::new("legend");
        for size in [[1200, 900], [1000, 800], [800, 600]] {
            let (d, centres) = card.drawing_at(size);
            let legend = legend::legend_box(&d.legend).expect("the mix colouring has a legend");
            let img = png_out::rasterise(&d);
            for (s, c) in card.report.swatches.iter().zip(&centres) {
                let patch = card.patch_px(&d, s);
                assert!(
                    !legend::overlap(legend, patch),
                    "{size:?}: swatch {} at {patch:?} under {legend:?}",
                    s.id
                );
                // And the swatch shows in its predicted colour (the top layer, the chamber
                // washed to within a unit of 8 bits).
                assert_near(rgb(&img, *c), &s.predicted, s.id);
            }
        }
    }

    #[test]
    fn a_white_swatch_has_a_visible_border() {
        // Issue 39: the white filament's swatch (#f5f5ee) vanished on the off-white picture.
        // With the bands example, its first lines are still tinted by the swatch before.
        let bands = MixProfile::from_toml_str(include_str!("../../../../examples/mix/bands.toml")).unwrap();
        let card = Card::with("white", bands);
        let (d, centres) = card.drawing();
        let white = card.report.swatches.iter().position(|s| s.ratios == [0.0, 0.0, 0.0, 1.0]).unwrap();
        let img = png_out::rasterise(&d);
        let centre = centres[white];
        let patch = card.patch_px(&d, &card.report.swatches[white]);
        assert_near(rgb(&img, centre), &card.report.swatches[white].predicted, 4);
        // From the middle of the swatch out to the left, past its edge into the gap: a pixel
        // clearly darker than both the swatch and the background marks the edge.
        let y = centre[1];
        let darkest = (patch[0] - 6..centre[0] as u32).map(|x| rgb(&img, [x as f32, y])[0]).min().unwrap();
        assert!(darkest + 40 < BACKGROUND[0], "no visible edge: darkest red channel {darkest}");
        // Away from the edge, the gap is background: the rim is only round the swatch, not
        // across it where the washout's tint changes (a line at each change of tint, before).
        assert_eq!(rgb(&img, [patch[0] as f32 - 10.0, y]), BACKGROUND);
        let inside =
            (patch[1] + 4..patch[1] + patch[3] - 4).map(|y| rgb(&img, [centre[0] - 20.0, y as f32])[0]);
        let darkest_inside = inside.min().unwrap();
        assert!(darkest_inside + 20 > BACKGROUND[0], "a line across the swatch: {darkest_inside}");
    }

    /// Pixels of `img` in `r` darker than `below` on every channel, as a mask.
    fn ink(img: &Image, r: legend::Rect, below: u8) -> Vec<bool> {
        let mut m = Vec::new();
        for y in r[1]..r[1] + r[3] {
            for x in r[0]..r[0] + r[2] {
                m.push(img.pixel(x, y)[..3].iter().all(|&v| v < below));
            }
        }
        m
    }

    #[test]
    fn each_swatch_shows_its_number() {
        // Issue 39: the picture had no numbers; one counted swatches to find swatch 25.
        let card = Card::new("numbers");
        let mix = MixColours::from_profile(&card.profile).unwrap();
        let png = card_png(&card.path, &card.report.swatches, mix, &card.profile.card, [1200, 900]).unwrap();
        let img = crate::picture::decode(&png).unwrap();
        let (d, centres) = card.drawing();
        let size = number_px(card.profile.card.patch_mm, d.panels[0].projection.scale_px_mm());
        for (s, c) in card.report.swatches.iter().zip(&centres) {
            // The number's box, and what its digits alone look like on a white ground.
            let label = s.id.to_string();
            let (x, y) = number_at(s.id, *c, size);
            let r = [x as u32, y as u32, text::width(&label, size), text::line_height(size)];
            let mut alone = Image::new(r[0] + r[2], r[1] + r[3], [0xff; 3]);
            alone.text(x, y, &label, size, DARK);
            let want = ink(&alone, r, 0x80);
            assert!(want.iter().filter(|&&k| k).count() > 20, "{label} has ink");
            if number_colour(s) == DARK {
                // The digits where they should be, and no others: the same ink, pixel for pixel
                // (a few anti-aliased pixels of the edge may fall either side of the threshold).
                let got = ink(&img, r, 0x80);
                let differ = want.iter().zip(&got).filter(|(a, b)| a != b).count();
                assert!(
                    differ * 20 < want.len(),
                    "swatch {}: {differ} of {} pixels differ",
                    s.id,
                    want.len()
                );
            } else {
                // White digits on a dark swatch: light pixels where the digits' ink is.
                let lit = (0..want.len()).filter(|&i| {
                    let (px, py) = (r[0] + (i as u32 % r[2]), r[1] + (i as u32 / r[2]));
                    want[i] && img.pixel(px, py)[..3].iter().all(|&v| v > 0xc0)
                });
                assert!(lit.count() * 2 > want.iter().filter(|&&k| k).count(), "swatch {}", s.id);
            }
        }
    }
}
