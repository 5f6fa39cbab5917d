//! The ATmega2560 in libsimavr, through the C shim (`csrc/shim.c`).
//!
//! [`Avr`] owns one simulated chip. What the chip does on its pins and serial port comes back
//! as calls of a [`Wires`] implementation, made while [`Avr::run`] runs, with the cycle at
//! which it happened; the same calls may drive input pins back (an endstop closing on the step
//! that reached it).

use std::ffi::{c_char, c_int, c_void, CString};
use std::path::Path;

/// Opaque board of the C shim.
#[repr(C)]
struct GwBoard {
    _private: [u8; 0],
}

type EventFn = extern "C" fn(user: *mut c_void, kind: u32, index: u32, value: u32, cycle: u64);

extern "C" {
    fn gw_board_new(path: *const c_char, hz: u32, event: EventFn, user: *mut c_void) -> *mut GwBoard;
    fn gw_board_free(b: *mut GwBoard);
    fn gw_board_reset(b: *mut GwBoard);
    fn gw_board_watch_pin(b: *mut GwBoard, port: c_char, bit: c_int, index: u32) -> c_int;
    fn gw_board_drive_pin(b: *mut GwBoard, port: c_char, bit: c_int, level: c_int);
    fn gw_board_set_adc_mv(b: *mut GwBoard, channel: u32, mv: u32);
    fn gw_board_rx_ready(b: *mut GwBoard) -> c_int;
    fn gw_board_uart_push(b: *mut GwBoard, byte: u8);
    fn gw_board_run(b: *mut GwBoard, until: u64) -> c_int;
    fn gw_board_cycle(b: *mut GwBoard) -> u64;
    fn gw_board_min_sp(b: *mut GwBoard) -> u16;
    fn gw_board_time_vector(b: *mut GwBoard, vector: u32);
    fn gw_board_isr_max_cycles(b: *mut GwBoard) -> u64;
    fn gw_board_isr_mean_cycles(b: *mut GwBoard) -> u64;
    fn gw_board_profile(b: *mut GwBoard, entries: *const u32, count: u32) -> c_int;
    fn gw_board_profile_counts(b: *mut GwBoard, inclusive: c_int) -> *const u32;
}

/// The flash words the program-counter profile covers (the ATmega2560's 256 KB).
pub const PROFILE_WORDS: usize = 128 * 1024;

/// What `gw_board_run` returns when the firmware stopped or crashed.
const RUN_DONE: c_int = 1;
const RUN_CRASHED: c_int = 2;

/// Event kinds of the shim (`GW_UART_OUT`, `GW_PIN`).
const EVENT_UART_OUT: u32 = 0;
const EVENT_PIN: u32 = 1;

/// A pin of the chip: its port letter (`b'A'..=b'L'`) and bit.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct PortPin {
    pub port: u8,
    pub bit: u8,
}

impl PortPin {
    pub const fn new(port: u8, bit: u8) -> Self {
        PortPin { port, bit }
    }
}

/// Drives input pins from inside a [`Wires`] call.
pub struct Drive {
    board: *mut GwBoard,
}

impl Drive {
    /// Hold an input pin high or low (it overrides the chip's pull-up).
    pub fn pin(&mut self, pin: PortPin, high: bool) {
        // SAFETY: `board` is the live board whose run called us; simavr allows raising an IRQ
        // from another IRQ's callback.
        unsafe { gw_board_drive_pin(self.board, pin.port as c_char, c_int::from(pin.bit), c_int::from(high)) }
    }
}

/// What the chip's outputs are connected to.
pub trait Wires {
    /// The firmware sent a byte on USART0.
    fn serial_out(&mut self, byte: u8, cycle: u64);
    /// Watched pin number `index` (see [`Avr::watch`]) changed to `high`.
    fn pin_changed(&mut self, index: u32, high: bool, cycle: u64, drive: &mut Drive);
}

/// Why a run stopped early.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Stopped {
    /// The firmware ran `sleep` with interrupts off, or returned from `main`.
    Done,
    /// simavr found an invalid instruction or address.
    Crashed,
}

/// The user data of the shim's callbacks: the wires and the board they may drive.
struct Callback<W> {
    wires: W,
    drive: Drive,
}

extern "C" fn on_event<W: Wires>(user: *mut c_void, kind: u32, index: u32, value: u32, cycle: u64) {
    // SAFETY: `user` is the `Callback<W>` boxed by `Avr::load`, alive for the board's life, and
    // only reached here while `Avr::run` (which holds `&mut Avr`) runs.
    let cb = unsafe { &mut *(user as *mut Callback<W>) };
    match kind {
        EVENT_UART_OUT => cb.wires.serial_out(value as u8, cycle),
        EVENT_PIN => cb.wires.pin_changed(index, value != 0, cycle, &mut cb.drive),
        _ => {}
    }
}

/// One simulated ATmega2560 running a firmware, wired to `W`.
pub struct Avr<W: Wires> {
    board: *mut GwBoard,
    callback: *mut Callback<W>,
}

/// The firmware could not be loaded.
#[derive(Debug, thiserror::Error)]
#[error("cannot load {path} as an ATmega2560 firmware: {why}")]
pub struct LoadError {
    pub path: String,
    pub why: &'static str,
}

/// `EM_AVR`, the ELF header's machine number of Atmel AVR code.
const EM_AVR: u16 = 83;

/// Why `elf` is not an AVR ELF file, if it is not (simavr's loader takes some other files, a
/// directory among them, for an empty firmware).
fn not_avr_elf(elf: &Path) -> Option<&'static str> {
    use std::io::Read;
    let Ok(mut file) = std::fs::File::open(elf) else { return Some("it cannot be opened") };
    if !file.metadata().is_ok_and(|m| m.is_file()) {
        return Some("it is not a file");
    }
    let mut header = [0u8; 20];
    if file.read_exact(&mut header).is_err() || &header[..4] != b"\x7fELF" {
        return Some("it is not an ELF file");
    }
    // e_machine, at byte 18 of the header; AVR ELF files are little-endian.
    if u16::from_le_bytes([header[18], header[19]]) != EM_AVR {
        return Some("it is not AVR code");
    }
    None
}

impl<W: Wires> Avr<W> {
    /// An ATmega2560 at `hz` running the ELF at `elf`, its outputs wired to `wires`.
    pub fn load(elf: &Path, hz: u32, wires: W) -> Result<Self, LoadError> {
        let err = |why| LoadError { path: elf.display().to_string(), why };
        if let Some(why) = not_avr_elf(elf) {
            return Err(err(why));
        }
        let path =
            CString::new(elf.as_os_str().as_encoded_bytes()).map_err(|_| err("its path holds a NUL"))?;
        let callback =
            Box::into_raw(Box::new(Callback { wires, drive: Drive { board: std::ptr::null_mut() } }));
        // SAFETY: the path is a valid C string; `callback` outlives the board (freed after it).
        let board = unsafe { gw_board_new(path.as_ptr(), hz, on_event::<W>, callback.cast()) };
        if board.is_null() {
            // SAFETY: made by Box::into_raw above and never shared.
            drop(unsafe { Box::from_raw(callback) });
            return Err(err("simavr refused it"));
        }
        // SAFETY: no run is going on, so nothing else holds the callback.
        unsafe { (*callback).drive.board = board };
        Ok(Avr { board, callback })
    }

    /// Report changes of `pin` to [`Wires::pin_changed`] as number `index`.
    pub fn watch(&mut self, pin: PortPin, index: u32) {
        // SAFETY: a live board; the shim checks the port letter and its table size.
        let ok = unsafe { gw_board_watch_pin(self.board, pin.port as c_char, c_int::from(pin.bit), index) };
        assert_eq!(ok, 0, "the shim's table of watched pins is full");
    }

    /// Hold an input pin high or low.
    pub fn drive(&mut self, pin: PortPin, high: bool) {
        // SAFETY: a live board.
        unsafe { gw_board_drive_pin(self.board, pin.port as c_char, c_int::from(pin.bit), c_int::from(high)) }
    }

    /// Set the voltage on analog input `channel` (0-15), in millivolts.
    pub fn set_adc_mv(&mut self, channel: u8, mv: u32) {
        // SAFETY: a live board; the shim ignores channels past 15.
        unsafe { gw_board_set_adc_mv(self.board, u32::from(channel), mv) }
    }

    /// Whether the serial receiver can take another byte now.
    pub fn serial_ready(&mut self) -> bool {
        // SAFETY: a live board.
        unsafe { gw_board_rx_ready(self.board) != 0 }
    }

    /// Put a byte on the serial line to the chip.
    pub fn serial_in(&mut self, byte: u8) {
        // SAFETY: a live board.
        unsafe { gw_board_uart_push(self.board, byte) }
    }

    /// Run until the cycle counter reaches `until`.
    pub fn run(&mut self, until: u64) -> Result<(), Stopped> {
        // SAFETY: a live board; callbacks reach `self.callback`, which nothing else borrows now.
        match unsafe { gw_board_run(self.board, until) } {
            RUN_DONE => Err(Stopped::Done),
            RUN_CRASHED => Err(Stopped::Crashed),
            _ => Ok(()),
        }
    }

    /// Reset the chip as its reset pin would (the Arduino's auto-reset when a host opens the
    /// port): registers to their reset values, outputs off, the firmware from the start.
    pub fn reset(&mut self) {
        // SAFETY: a live board.
        unsafe { gw_board_reset(self.board) }
    }

    /// Cycles run since start-up.
    pub fn cycle(&self) -> u64 {
        // SAFETY: a live board.
        unsafe { gw_board_cycle(self.board) }
    }

    /// The lowest stack pointer seen so far (the stack grows down from the top of RAM).
    pub fn min_stack_pointer(&self) -> u16 {
        // SAFETY: a live board.
        unsafe { gw_board_min_sp(self.board) }
    }

    /// Time the handler of interrupt number `vector` (17: Timer1 compare A, the step
    /// interrupt), from its vector to the `reti` that enables interrupts again.
    pub fn time_vector(&mut self, vector: u32) {
        // SAFETY: a live board.
        unsafe { gw_board_time_vector(self.board, vector) }
    }

    /// The longest run of the timed handler so far, cycles.
    pub fn isr_max_cycles(&self) -> u64 {
        // SAFETY: a live board.
        unsafe { gw_board_isr_max_cycles(self.board) }
    }

    /// The mean run of the timed handler so far, cycles.
    pub fn isr_mean_cycles(&self) -> u64 {
        // SAFETY: a live board.
        unsafe { gw_board_isr_mean_cycles(self.board) }
    }

    /// Count, from now on, the cycles the chip spends at each flash word and in each
    /// function with its callees, the functions starting at the byte addresses `entries` (the
    /// ELF's symbols); `None` stops.
    pub fn profile(&mut self, entries: Option<&[u32]>) {
        let (ptr, len) = entries.map_or((std::ptr::null(), 0), |e| (e.as_ptr(), e.len() as u32));
        // SAFETY: a live board; `ptr` is null or `len` valid addresses, read during the call.
        let failed = unsafe { gw_board_profile(self.board, ptr, len) } != 0;
        assert!(!failed, "no memory for the program counter's profile");
    }

    /// Since [`Avr::profile`] started: the cycles spent at each flash word (index: byte
    /// address / 2), or with `inclusive`, in the function starting at that word with what it
    /// called; empty when off.
    pub fn profile_counts(&self, inclusive: bool) -> Vec<u32> {
        // SAFETY: a live board; the shim's table, when on, has PROFILE_WORDS counters and
        // lives until the next `gw_board_profile` call, which needs `&mut self`.
        unsafe {
            let counts = gw_board_profile_counts(self.board, c_int::from(inclusive));
            if counts.is_null() {
                Vec::new()
            } else {
                std::slice::from_raw_parts(counts, PROFILE_WORDS).to_vec()
            }
        }
    }

    /// The wires, between runs.
    pub fn wires(&self) -> &W {
        // SAFETY: no run is going on while `&self` is held, so no callback holds it.
        unsafe { &(*self.callback).wires }
    }

    /// The wires, between runs.
    pub fn wires_mut(&mut self) -> &mut W {
        // SAFETY: as in `wires`, with `&mut self`.
        unsafe { &mut (*self.callback).wires }
    }
}

impl<W: Wires> Drop for Avr<W> {
    fn drop(&mut self) {
        // SAFETY: both were made in `load`; the board goes first, so no callback can follow.
        unsafe {
            gw_board_free(self.board);
            drop(Box::from_raw(self.callback));
        }
    }
}
