//! Every fixed size of the core, in one place, with what it costs in RAM.
//!
//! The ATmega2560 has 8 KB of RAM; the budget of the whole firmware's static data is 4 KB
//! (issue 37), so each buffer here is as small as does the job.

/// A move whose axes all take fewer steps than this is not planned: its distance goes with the
/// next move (the planner's position stays). Marlin's `MIN_STEPS_PER_SEGMENT` (6, in
/// `Configuration_adv.h`): slicers' tiny segments would otherwise fill the planner with blocks
/// too short to plan speed through, and the virtual printer's Marlin model drops them the
/// same way, so a mixing hotend's shares of E fall on the same moves in both.
pub const MIN_STEPS_PER_SEGMENT: u32 = 6;

/// Inputs of a mixing hotend at most (E0-E3: RAMPS's E0 and E1 drivers, two more on its
/// auxiliary pins). Each is a motor of the step block: 4 bytes per step block and a Bresenham
/// counter of 4 bytes each.
pub const MIX_INPUTS: usize = 4;

/// Virtual tools of a mixing hotend (Marlin's `MIXING_VIRTUAL_TOOLS` default, 16). RAM and
/// EEPROM: `2 * MIX_INPUTS` bytes each (128).
pub const MIX_TOOLS: usize = 16;

/// Inkjet heads a build may wire (`M700 P0`, `P1`): each needs a pulse pin of its own (the
/// four address lines are shared), and the RAMPS build wires two (Steve Kelly's Marlin patch
/// allows six).
pub const INKJET_HEADS: usize = 2;

/// The longest line kept, in bytes: Marlin's `MAX_CMD_SIZE` (96) less its terminating NUL.
/// Longer lines are refused whole (`Error:Line too long`), never cut and run.
/// RAM: one line being received plus [`LINE_QUEUE`] complete ones.
pub const MAX_LINE: usize = 95;

/// Complete lines waiting for the machine, as Marlin's `BUFSIZE` (4): the host may send ahead
/// of the `ok`s by this many lines. RAM: `LINE_QUEUE * (MAX_LINE + 2)` bytes (388).
pub const LINE_QUEUE: usize = 4;

/// Moves in the look-ahead planner (GRBL keeps 16 on a 328p, Marlin 16 on AVR). More blocks
/// let the planner keep speed through more short segments. RAM: about 60 bytes each (960).
pub const PLANNER_BLOCKS: usize = 16;

/// Segments between the main loop and the step interrupt (GRBL: 6). Each is a few
/// milliseconds of motion, so this many segments cover the time the main loop may spend on a
/// slow command or a serial burst without the steppers running dry. RAM: 8 bytes each.
pub const SEGMENTS: usize = 8;

/// Steppers' per-block data referenced by the segments (one per segment is enough: a block
/// spans at least one segment). RAM: 24 bytes each.
pub const STEP_BLOCKS: usize = SEGMENTS;

/// Target duration of one segment, in seconds. The step rate is constant within a segment and
/// recomputed from the speed profile at each one (see [`crate::stepper::prep`]): 5 ms segments
/// make 200 speed updates a second, smooth enough for acceleration, cheap enough for the main
/// loop of an 8-bit board.
pub const SEGMENT_S: f32 = 0.005;

/// The step timer's rate: Timer1 of a 16 MHz AVR with prescaler 8 counts at 2 MHz.
pub const TICKS_PER_S: u32 = 2_000_000;

/// The highest step rate, step events per second (Marlin's `MAX_STEP_FREQUENCY`): the planner
/// lowers the speed of a move whose fastest motor would step faster
/// ([`crate::planner::Planner::add`]), so the step interrupt never takes more of the chip than
/// the main loop can spare (measured on the ATmega2560 in docs/firmware.md, "Budgets").
pub const MAX_STEP_HZ: u32 = 40_000;

/// The shortest step interval the core asks for, in timer ticks (25 µs: [`MAX_STEP_HZ`]).
pub const MIN_STEP_TICKS: u32 = TICKS_PER_S / MAX_STEP_HZ;

/// The shortest time between two step interrupts, in timer ticks (125 µs: 8 000 interrupts a
/// second at most). A segment whose step interval is shorter runs 2, 4 or 8 step events per
/// interrupt (multi-stepping, [`crate::stepper::Stepper::tick`]): on an 8-bit chip an
/// interrupt's entry and exit alone cost a hundred cycles or more. Measured on the emulated
/// ATmega2560: with 100 µs, X, Y and E at 20 000 steps/s each left the main loop too little
/// time and a segment came 240 µs late; 8 000 steps/s (the board's acceleration test) still
/// run one event per interrupt.
pub const MULTISTEP_TICKS: u32 = 250;

/// The most step events one interrupt makes, log2 (8 events).
pub const MAX_EVENTS_PER_TICK_LOG2: u8 = 3;

/// The longest interval a 16-bit timer holds, in ticks; longer waits are made of several
/// interrupts without a step.
pub const MAX_TIMER_TICKS: u32 = 65_535;

/// The interrupt's interval while there is nothing to step (250 µs): how soon a new segment is
/// seen. A queue that runs dry in the middle of a move (a main loop late with the next segment)
/// costs at most this much; an idle interrupt takes about a hundred cycles, so 4 000 a second
/// are 2.5 % of a 16 MHz AVR.
pub const IDLE_TICKS: u16 = 500;
