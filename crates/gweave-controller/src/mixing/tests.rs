use super::*;

fn mixer(weights: &[f32]) -> Mixer {
    let mut m = Mixer::new(weights.len() as u8);
    for (k, &w) in weights.iter().enumerate() {
        m.set_weight(k, w).unwrap();
    }
    m.store(None).unwrap();
    m
}

#[test]
fn weights_normalise_to_units_summing_exactly() {
    assert_eq!(mixer(&[0.6, 0.4]).tool(0), [6000, 4000, 0, 0]);
    assert_eq!(mixer(&[60.0, 40.0]).tool(0), [6000, 4000, 0, 0], "only ratios matter");
    // gweave mix's 4-decimal ratios summing to 1 are kept exactly.
    assert_eq!(mixer(&[0.3333, 0.3333, 0.3334]).tool(0), [3333, 3333, 3334, 0]);
    // Thirds: the unit left over goes to the first largest remainder.
    assert_eq!(mixer(&[1.0, 1.0, 1.0]).tool(0), [3334, 3333, 3333, 0]);
    // A negative weight counts as 0 (Marlin's M163).
    assert_eq!(mixer(&[-1.0, 1.0, 0.0, 0.0]).tool(0), [0, 10000, 0, 0]);
    let mut m = Mixer::new(2);
    assert_eq!(m.store(Some(3)), Err(MixError::AllZero));
    assert_eq!(m.tool(3), [10000, 0, 0, 0], "a refused mix changes nothing");
    assert_eq!(m.set_weight(2, 1.0), Err(MixError::Input));
    assert_eq!(m.store(Some(MIX_TOOLS)), Err(MixError::Tool));
}

#[test]
fn the_power_on_tools_are_one_input_each_then_input_0() {
    let m = Mixer::new(3);
    assert_eq!(m.tool(0), [10000, 0, 0, 0]);
    assert_eq!(m.tool(2), [0, 0, 10000, 0]);
    assert_eq!(m.tool(3), [10000, 0, 0, 0]);
    assert_eq!(Mixer::new(1).inputs(), 0, "one input does not mix");
    assert_eq!(Mixer::new(9).inputs(), MIX_INPUTS);
}

#[test]
fn a_mixed_move_gives_each_input_its_exact_share() {
    let mut m = mixer(&[0.25, 0.75]);
    assert_eq!(m.split(1000), [250, 750, 0, 0]);
    assert_eq!(m.split(-400), [-100, -300, 0, 0], "a retraction takes back in the same ratio");
    // Thirds of 100: 33.34, 33.33, 33.33 rounded as prefix sums 33, 67, 100.
    let mut m = mixer(&[1.0, 1.0, 1.0]);
    assert_eq!(m.split(100), [33, 34, 33, 0]);
    // 10 moves of one step at 0.3/0.7: the inputs take turns, 3 and 7 in all.
    let mut m = mixer(&[0.3, 0.7]);
    let mut total = [0; MIX_INPUTS];
    for _ in 0..10 {
        let d = m.split(1);
        assert_eq!(d.iter().sum::<i32>(), 1, "each step to exactly one input");
        for k in 0..MIX_INPUTS {
            total[k] += d[k];
        }
    }
    assert_eq!(total, [3, 7, 0, 0]);
    // More E steps than MIX_UNITS in one move: the quotient path.
    let mut m = mixer(&[0.1234, 0.8766]);
    assert_eq!(m.split(1_000_000), [123_400, 876_600, 0, 0]);
    assert_eq!(m.split(-1_000_001), [-123_400, -876_601, 0, 0]);
}

#[test]
fn the_cumulative_split_stays_within_one_step_of_the_ideal_through_mix_changes() {
    // Moves of 1 to 37 steps both ways, the mix changing every 5 moves among 4 inputs: after
    // every move each input's total is within one step of its exact share (in units), and the
    // inputs' totals add up to the E steps.
    let mixes: [[f32; 4]; 3] = [[0.1, 0.2, 0.3, 0.4], [0.3333, 0.3333, 0.3334, 0.0], [0.7, 0.0, 0.0, 0.3]];
    let mut m = Mixer::new(4);
    let mut given = [0i64; 4];
    let mut ideal_units = [0i64; 4];
    let mut e_total = 0i64;
    for i in 0..3000i32 {
        if i % 5 == 0 {
            let mix = mixes[(i as usize / 5) % 3];
            for (k, &w) in mix.iter().enumerate() {
                m.set_weight(k, w).unwrap();
            }
            m.store(Some(2)).unwrap();
            m.select(2).unwrap();
        }
        let e = (i * 7919) % 37 + 1;
        let e = if i % 11 == 0 { -e } else { e };
        e_total += i64::from(e);
        let d = m.split(e);
        let tool = m.tool(2);
        for k in 0..4 {
            given[k] += i64::from(d[k]);
            ideal_units[k] += i64::from(tool[k]) * i64::from(e);
            let off = (given[k] * i64::from(MIX_UNITS) - ideal_units[k]).abs();
            assert!(off <= i64::from(MIX_UNITS), "move {i} input {k}: {off} units off");
        }
        assert_eq!(given.iter().sum::<i64>(), e_total);
    }
}

#[test]
fn tools_survive_eeprom_and_a_worn_byte_is_noticed() {
    struct Eeprom([u8; 512]);
    impl Io for Eeprom {
        fn send(&mut self, _: &[u8]) {}
        fn build_settings(&self) -> crate::Settings {
            crate::Settings::DEFAULT
        }
        fn eeprom_read(&mut self, addr: u16, buf: &mut [u8]) {
            buf.copy_from_slice(&self.0[usize::from(addr)..usize::from(addr) + buf.len()]);
        }
        fn eeprom_write(&mut self, addr: u16, data: &[u8]) {
            self.0[usize::from(addr)..usize::from(addr) + data.len()].copy_from_slice(data);
        }
    }
    let mut eeprom = Eeprom([0xFF; 512]);
    let mut m = mixer(&[0.25, 0.75]);
    m.store(Some(5)).unwrap();
    m.save(&mut eeprom);
    let mut back = Mixer::new(2);
    assert!(back.load(&mut eeprom));
    assert_eq!(back.tool(5), [2500, 7500, 0, 0]);
    assert_eq!(back.tool(1), [0, 10000, 0, 0]);
    eeprom.0[usize::from(EEPROM_AT) + 4 + 5 * 2 * MIX_INPUTS] ^= 1;
    let mut again = Mixer::new(2);
    assert!(!again.load(&mut eeprom));
    assert_eq!(again, Mixer::new(2));
    assert_eq!(EEPROM_BYTES, 134);
}
