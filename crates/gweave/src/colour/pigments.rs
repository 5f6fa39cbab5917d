//! Reflectance spectra for the default filaments, fitted to published pigment mixing.
//!
//! A filament of any other colour gets the smoothest spectrum that shows its colour
//! (`super::reflectance`). The smoothest spectrum is a guess: a real cyan pigment
//! (copper phthalocyanine) keeps reflecting blue-green light into the green, where the
//! smoothest cyan falls off steadily from the violet, so its mixes with yellow come out too
//! dull (and a little of it turns magenta violet). For the default cyan, magenta, yellow and white filaments
//! ([`CMYW_FILAMENTS`]) we store spectra fitted once, offline: each is the
//! smoothest spectrum plus a sum of seven Gaussian bumps in the `tanh` domain (centres 400 to
//! 700 nm every 50 nm, width 35 nm), projected back onto the filament's exact colour, with the
//! bump weights minimising the squared CIEDE2000 between this model and Mixbox (S. Sochorová and
//! O. Jamriška, "Practical pigment mixing for digital painting", SIGGRAPH Asia 2021; pymixbox
//! 2.0, latent mixing) over 71 2-, 3- and 4-input blends of these filaments, plus a penalty on
//! the weights (2 × their sum of squares) that keeps the spectra smooth. Only these 144 numbers
//! come from that fit; no Mixbox data or code is in gweave. The accuracy this buys is in
//! `docs/mix.md` and, against an independent table, in the tests of `super::mixing`.

use super::reflectance::reflectance;
use super::spectrum::Spectrum;
use super::srgb::Srgb8;

/// Typical PLA filament colours for the seed's inputs with white on E3
/// (our estimate from vendor swatches; measure your own for accuracy).
pub const CMYW_FILAMENTS: [Srgb8; 4] =
    [Srgb8::new(0, 160, 224), Srgb8::new(224, 0, 122), Srgb8::new(255, 224, 0), Srgb8::new(245, 245, 240)];

/// (filament colour, its fitted reflectance at 380, 390, .. 730 nm).
const FITTED: [(Srgb8, Spectrum); 4] = [
    // cyan
    (
        CMYW_FILAMENTS[0],
        [
            0.7583037301768554,
            0.7588760336111214,
            0.7562875412154029,
            0.7524636466928907,
            0.7586337823355678,
            0.7694143538649857,
            0.7772118047024842,
            0.7584711434278799,
            0.7124054674483704,
            0.6300320471719366,
            0.540265721523063,
            0.46322306691676113,
            0.43187422457951735,
            0.431749422460064,
            0.4399048195073541,
            0.44383550101395325,
            0.41634547826808493,
            0.3731350728524374,
            0.3087360943677082,
            0.23985942939972937,
            0.17955990871727878,
            0.13210052761044666,
            0.10204971910541621,
            0.08453580695399127,
            0.07617376660236086,
            0.07375550964018257,
            0.07371455287756284,
            0.07574013377423244,
            0.0784729007934245,
            0.08170584642621731,
            0.08514407792690865,
            0.08858336801383487,
            0.09169942624534994,
            0.09445283170144297,
            0.0967800385025131,
            0.09863483670124745,
        ],
    ),
    // magenta
    (
        CMYW_FILAMENTS[1],
        [
            0.3367050954921674,
            0.33702668739567276,
            0.3374896882072972,
            0.3367957913327668,
            0.3305713001746615,
            0.3100309869219906,
            0.2669076921620538,
            0.20571451181213424,
            0.14410703653755463,
            0.09712847766970695,
            0.06576116282216793,
            0.04628743841701721,
            0.03346900148301557,
            0.025438310657440122,
            0.02118454112137036,
            0.0198124712540102,
            0.021511017257404563,
            0.026772688626585106,
            0.038924047599663114,
            0.06585189241782696,
            0.12771782026821893,
            0.2620838071361944,
            0.47534007830502795,
            0.6611780312776373,
            0.7616679478108158,
            0.8062660529651685,
            0.8272850365462685,
            0.8361799944686223,
            0.8413410444237981,
            0.8454795127724519,
            0.8497514121399409,
            0.8542267984699271,
            0.8588447878323475,
            0.8631285312121175,
            0.8668725565294939,
            0.8700419267407153,
        ],
    ),
    // yellow
    (
        CMYW_FILAMENTS[2],
        [
            0.048229506964782176,
            0.048912929352512624,
            0.049230999262529496,
            0.04880710251019221,
            0.04627773753016218,
            0.04342431283131931,
            0.042476052341780646,
            0.04816398949511441,
            0.06373302463348324,
            0.09859382966979546,
            0.1625864094005926,
            0.26502459717347965,
            0.3941273484882497,
            0.5282489826863249,
            0.6398831692897791,
            0.7166752926932514,
            0.7689275149605722,
            0.8027390646453676,
            0.8269544041471764,
            0.8449519616897064,
            0.8585939713315007,
            0.8723713264470914,
            0.8828437646635786,
            0.8932707427070847,
            0.9030870531972539,
            0.9116654586212223,
            0.917160171937103,
            0.920341627148143,
            0.9208111684581382,
            0.9191227423936721,
            0.9158034765521499,
            0.911493112404357,
            0.9067129528293496,
            0.9020225081217061,
            0.8977564785591128,
            0.894075191772705,
        ],
    ),
    // white
    (
        CMYW_FILAMENTS[3],
        [
            0.8644248317829077,
            0.8640681867281222,
            0.8639103857066012,
            0.8641390790846148,
            0.8653506205773727,
            0.8675226833709863,
            0.8705746262076504,
            0.8737689754426927,
            0.8773159388885654,
            0.8811201490821718,
            0.8855519966141301,
            0.8905471773674563,
            0.8957614593463173,
            0.9007416118383551,
            0.905408714414667,
            0.9095843936683403,
            0.9129269060825635,
            0.9153675321385273,
            0.9168503647771945,
            0.917459389158729,
            0.9173818530340031,
            0.9160941139198058,
            0.9144829417876561,
            0.9119925931827368,
            0.9088576322359073,
            0.9054461009811969,
            0.9028544647896947,
            0.9009789029245061,
            0.9002187003521842,
            0.9003696273021826,
            0.9011876331576651,
            0.9023751828840019,
            0.9037295991691641,
            0.9050475549303219,
            0.9062335636135784,
            0.9072528634683397,
        ],
    ),
];

/// The reflectance spectrum the mixing model uses for a filament of colour `c`.
pub(crate) fn spectrum(c: Srgb8) -> Spectrum {
    match FITTED.iter().find(|(colour, _)| *colour == c) {
        Some((_, r)) => *r,
        None => reflectance(c.into()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::colour::reflectance::RGB_MIN;
    use crate::colour::spectrum::{linear_rgb, wavelength_nm, BANDS};
    use palette::LinSrgb;

    #[test]
    fn fitted_spectra_show_their_filament_colours() {
        for (c, r) in FITTED {
            assert!(r.iter().all(|&x| x > 0.0 && x < 1.0), "{c}");
            let (got, want) = (linear_rgb(&r), LinSrgb::from(c));
            for (g, w) in [(got.red, want.red), (got.green, want.green), (got.blue, want.blue)] {
                assert!((g - w.clamp(RGB_MIN, 1.0 - RGB_MIN)).abs() < 1e-12, "{c}: {got:?}");
            }
            // As smooth as the smoothest spectrum of that colour, give or take: no band jumps
            // more than a quarter from the next (the smoothest magenta jumps by 0.2).
            assert!(r.windows(2).all(|w| (w[1] - w[0]).abs() < 0.25), "{c}: {r:?}");
        }
    }

    #[test]
    fn the_fitted_cyan_keeps_reflecting_into_the_green() {
        let at = |r: &Spectrum, nm: f64| r[(0..BANDS).find(|&i| wavelength_nm(i) == nm).unwrap()];
        let fitted = spectrum(CMYW_FILAMENTS[0]);
        let smoothest = reflectance(CMYW_FILAMENTS[0].into());
        assert!(at(&fitted, 550.0) > at(&smoothest, 550.0) + 0.05, "{fitted:?}");
        // Other colours get the smoothest spectrum.
        let orange = Srgb8::new(255, 136, 16);
        assert_eq!(spectrum(orange), reflectance(orange.into()));
    }
}
