//! The RAMPS 1.4 shield around the chip: stepper drivers moving axes, endstops closed by those
//! axes, heater MOSFETs feeding thermal plants, and the serial line.
//!
//! The pin map is the firmware's (`firmware/ramps/src/pins.rs`, after Marlin's
//! `pins_RAMPS.h`): a driver's STEP pin pulses once per microstep and its DIR pin says which
//! way; ENABLE is active low. Each axis is a counter of microsteps; X, Y and Z close their
//! minimum endstop at or below position 0, on the very step that gets there (the switch is
//! driven from inside the step's pin callback, so the firmware sees it as a real switch would).

use gweave_sim::{BetaThermistor, Heater, HeaterConfig, SensorFault};

use crate::inkshield::InkShield;
use crate::sim::{Drive, PortPin, Wires};

/// The driver sockets, in the order X, Y, Z, E0, E1, then E2 and E3 of a mixing hotend on
/// drivers wired to the AUX-2 header (the mixing image's; the base image leaves them alone).
pub const DRIVERS: usize = 7;
/// Axis names, in socket order.
pub const AXIS_NAMES: [&str; DRIVERS] = ["X", "Y", "Z", "E0", "E1", "E2", "E3"];

/// STEP, DIR, ENABLE of each socket (D54/D55/D38, D60/D61/D56, D46/D48/D62, D26/D28/D24,
/// D36/D34/D30; on AUX-2, D63/D40/D59 and D65/D42/D64).
pub const STEP_DIR_ENABLE: [[PortPin; 3]; DRIVERS] = [
    [PortPin::new(b'F', 0), PortPin::new(b'F', 1), PortPin::new(b'D', 7)],
    [PortPin::new(b'F', 6), PortPin::new(b'F', 7), PortPin::new(b'F', 2)],
    [PortPin::new(b'L', 3), PortPin::new(b'L', 1), PortPin::new(b'K', 0)],
    [PortPin::new(b'A', 4), PortPin::new(b'A', 6), PortPin::new(b'A', 2)],
    [PortPin::new(b'C', 1), PortPin::new(b'C', 3), PortPin::new(b'C', 7)],
    [PortPin::new(b'K', 1), PortPin::new(b'G', 1), PortPin::new(b'F', 5)],
    [PortPin::new(b'K', 3), PortPin::new(b'L', 7), PortPin::new(b'K', 2)],
];

/// Minimum endstops of X, Y, Z: D3, D14, D18.
pub const ENDSTOPS_MIN: [PortPin; 3] = [PortPin::new(b'E', 5), PortPin::new(b'J', 1), PortPin::new(b'D', 3)];

/// The three MOSFET outputs, in the order of [`Plant`]s: D10 (hotend), D8 (bed), D9 (fan on
/// "EFB", second hotend on "EEB").
pub const MOSFETS: [PortPin; 3] = [PortPin::new(b'B', 4), PortPin::new(b'H', 5), PortPin::new(b'H', 6)];

/// The thermistor inputs, in the same order: TEMP_0 on A13, TEMP_BED on A14, TEMP_1 on A15.
pub const THERMISTOR_ADC: [u8; 3] = [13, 14, 15];

/// Pin numbers reported by the chip (see [`crate::sim::Avr::watch`]).
pub const PIN_STEP: u32 = 0;
pub const PIN_DIR: u32 = PIN_STEP + DRIVERS as u32;
pub const PIN_ENABLE: u32 = PIN_DIR + DRIVERS as u32;
pub const PIN_MOSFET: u32 = PIN_ENABLE + DRIVERS as u32;
/// The InkShield's address lines, then its pulse lines ([`crate::inkshield`]).
pub const PIN_INK_ADDRESS: u32 = PIN_MOSFET + MOSFETS.len() as u32;
pub const PIN_INK_PULSE: u32 = PIN_INK_ADDRESS + crate::inkshield::ADDRESS.len() as u32;

/// What D9 drives.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum D9 {
    /// RAMPS "EFB": the part-cooling fan, blowing on hotend 0.
    Fan,
    /// RAMPS "EEB": the heater of a second hotend.
    Hotend1,
}

/// How the shield is wired and what hangs off it.
#[derive(Debug, Clone)]
pub struct Wiring {
    /// Where X, Y, Z start, in microsteps from their minimum endstop (a printer switched on
    /// with its head somewhere in the middle).
    pub start_steps: [i64; 3],
    /// An endstop reads high when triggered (a normally-closed switch to ground with the
    /// pull-up, or an optical endstop), as the default printer's.
    pub endstop_high_when_triggered: bool,
    /// A high DIR pin moves the axis towards +, per socket.
    pub dir_high_is_positive: [bool; DRIVERS],
    /// What D9 drives.
    pub d9: D9,
    /// The plants of hotend 0, the bed, hotend 1.
    pub plants: [HeaterConfig; 3],
    /// The thermistor on each input (Marlin type 1 by default: 100 kOhm, B 4092, 4.7 kOhm
    /// pull-up to 5 V).
    pub thermistor: BetaThermistor,
    /// Keep the cycle of every step of each socket (for timing tests; 8 bytes a step).
    pub record_steps: bool,
}

impl Default for Wiring {
    fn default() -> Self {
        Wiring {
            // 100, 100 and 20 mm from the switches at 80/80/400 steps/mm.
            start_steps: [8_000, 8_000, 8_000],
            endstop_high_when_triggered: true,
            dir_high_is_positive: [true; DRIVERS],
            d9: D9::Fan,
            plants: [HeaterConfig::hotend_40w(), HeaterConfig::bed_200w(), HeaterConfig::hotend_40w()],
            thermistor: BetaThermistor::default(),
            record_steps: false,
        }
    }
}

/// One stepper driver and the axis it moves.
#[derive(Debug, Clone, Default)]
pub struct Axis {
    /// Microsteps from the axis's zero (the endstop for X, Y, Z).
    pub position: i64,
    /// Steps taken towards + and towards -.
    pub steps_plus: u64,
    pub steps_minus: u64,
    /// Steps pulsed while the driver was disabled (the motor would not have moved).
    pub steps_while_disabled: u64,
    /// The shortest STEP high time seen, cycles (drivers need about 1 us: 16 cycles).
    pub min_pulse_cycles: Option<u64>,
    /// Cycle of each step, with +1 or -1, when recording.
    pub step_log: Vec<(u64, i8)>,
    dir_high: bool,
    enable_low: bool,
    step_high_since: Option<u64>,
}

impl Axis {
    /// Whether the driver holds its motor (ENABLE low).
    pub fn enabled(&self) -> bool {
        self.enable_low
    }
}

/// A heater MOSFET: how long it was on since the plant last advanced.
#[derive(Debug, Clone, Default)]
struct Mosfet {
    on_since: Option<u64>,
    on_cycles: u64,
}

/// A heater and its thermistor, as the firmware sees them.
#[derive(Debug, Clone)]
pub struct Plant {
    pub heater: Heater,
}

/// The shield: axes, endstops, MOSFETs, plants, and the serial bytes the firmware sent.
pub struct Shield {
    pub wiring: Wiring,
    pub axes: [Axis; DRIVERS],
    pub plants: [Plant; 3],
    /// Bytes the firmware sent, not yet taken.
    pub serial_out: Vec<u8>,
    /// The InkShield's decoder: the nozzle pulses of an inkjet build.
    pub inkshield: InkShield,
    mosfets: [Mosfet; 3],
    /// Cycle at which the plants last advanced.
    plant_cycle: u64,
    endstop_levels: [Option<bool>; 3],
}

impl Shield {
    /// A shield wired as `wiring` says, every plant at its ambient temperature.
    pub fn new(wiring: Wiring) -> Result<Self, gweave_sim::ThermalError> {
        let plant = |cfg: HeaterConfig| Heater::new(cfg).map(|heater| Plant { heater });
        let plants = [plant(wiring.plants[0])?, plant(wiring.plants[1])?, plant(wiring.plants[2])?];
        let mut axes: [Axis; DRIVERS] = Default::default();
        for (axis, start) in axes.iter_mut().zip(wiring.start_steps) {
            axis.position = start;
        }
        Ok(Shield {
            wiring,
            axes,
            plants,
            serial_out: Vec::new(),
            inkshield: InkShield::default(),
            mosfets: Default::default(),
            plant_cycle: 0,
            endstop_levels: [None; 3],
        })
    }

    /// The level each minimum endstop shows now.
    pub fn endstop_levels(&self) -> [bool; 3] {
        std::array::from_fn(|i| {
            let triggered = self.axes[i].position <= 0;
            triggered == self.wiring.endstop_high_when_triggered
        })
    }

    /// Forget the levels driven so far (a reset clears the chip's pin registers): the next
    /// [`Shield::drive_endstops`] drives them all.
    pub fn forget_endstops(&mut self) {
        self.endstop_levels = [None; 3];
    }

    /// Drive the endstops whose level changed (all of them the first time).
    pub fn drive_endstops(&mut self, mut drive: impl FnMut(PortPin, bool)) {
        for (i, level) in self.endstop_levels().into_iter().enumerate() {
            if self.endstop_levels[i] != Some(level) {
                self.endstop_levels[i] = Some(level);
                drive(ENDSTOPS_MIN[i], level);
            }
        }
    }

    /// Advance the plants to `cycle` at `hz`, each heated by its MOSFET's duty over the time
    /// since the last call, and return the thermistor voltages (mV) of the three inputs.
    pub fn advance_plants(&mut self, cycle: u64, hz: u32) -> [u32; 3] {
        let span = cycle.saturating_sub(self.plant_cycle);
        if span > 0 {
            let dt_s = span as f64 / f64::from(hz);
            let mut duty = [0.0; 3];
            for (d, m) in duty.iter_mut().zip(&mut self.mosfets) {
                let mut on = m.on_cycles;
                if let Some(since) = m.on_since {
                    on += cycle.saturating_sub(since.max(self.plant_cycle));
                    m.on_since = Some(cycle);
                }
                m.on_cycles = 0;
                *d = on as f64 / span as f64;
            }
            if self.wiring.d9 == D9::Fan {
                self.plants[0].heater.set_fan(duty[2]);
                duty[2] = 0.0;
            }
            for (p, d) in self.plants.iter_mut().zip(duty) {
                p.heater.step(d, dt_s);
            }
            self.plant_cycle = cycle;
        }
        // The divider's voltage in millivolts is the model's "ADC reading" of a 5000-count,
        // single-sample converter.
        let mv_model = BetaThermistor { adc_max: 5000, oversample: 1, ..self.wiring.thermistor };
        std::array::from_fn(|i| self.plants[i].heater.read_adc(&mv_model))
    }

    /// Break or short the thermistor of plant `i` (0 hotend, 1 bed, 2 hotend 1).
    pub fn fail_thermistor(&mut self, i: usize, fault: SensorFault) {
        self.plants[i].heater.inject(gweave_sim::HeaterFault::Sensor(fault));
    }
}

impl Wires for Shield {
    fn serial_out(&mut self, byte: u8, _cycle: u64) {
        self.serial_out.push(byte);
    }

    fn pin_changed(&mut self, index: u32, high: bool, cycle: u64, drive: &mut Drive) {
        let i = index as usize;
        match index {
            _ if index < PIN_DIR => {
                let axis = &mut self.axes[i];
                if !high {
                    if let Some(since) = axis.step_high_since.take() {
                        let width = cycle - since;
                        axis.min_pulse_cycles = Some(axis.min_pulse_cycles.map_or(width, |m| m.min(width)));
                    }
                    return;
                }
                // A step happens on the rising edge of STEP.
                axis.step_high_since = Some(cycle);
                let plus = axis.dir_high == self.wiring.dir_high_is_positive[i];
                if plus {
                    axis.position += 1;
                    axis.steps_plus += 1;
                } else {
                    axis.position -= 1;
                    axis.steps_minus += 1;
                }
                if !axis.enable_low {
                    axis.steps_while_disabled += 1;
                }
                if self.wiring.record_steps {
                    axis.step_log.push((cycle, if plus { 1 } else { -1 }));
                }
                if i < ENDSTOPS_MIN.len() {
                    self.drive_endstops(|pin, level| drive.pin(pin, level));
                }
            }
            _ if index < PIN_ENABLE => self.axes[i - DRIVERS].dir_high = high,
            _ if index < PIN_MOSFET => self.axes[i - 2 * DRIVERS].enable_low = !high,
            _ if index >= PIN_INK_PULSE => {
                let steps = std::array::from_fn(|a| self.axes[a].position);
                self.inkshield.pulse_changed((index - PIN_INK_PULSE) as usize, high, cycle, steps);
            }
            _ if index >= PIN_INK_ADDRESS => {
                self.inkshield.address_changed((index - PIN_INK_ADDRESS) as usize, high)
            }
            _ => {
                let m = &mut self.mosfets[i - 3 * DRIVERS];
                match (m.on_since, high) {
                    (None, true) => m.on_since = Some(cycle),
                    (Some(since), false) => {
                        m.on_cycles += cycle - since.max(self.plant_cycle);
                        m.on_since = None;
                    }
                    _ => {}
                }
            }
        }
    }
}
