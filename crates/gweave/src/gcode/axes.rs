//! The machine's axes: their indices into a position, their letters, and a position on
//! every axis.

/// Axis indices into a position array.
pub const X: usize = 0;
/// Index of the Y axis.
pub const Y: usize = 1;
/// Index of the Z axis.
pub const Z: usize = 2;
/// Index of the extruder (E) axis.
pub const E: usize = 3;
/// Index of the A rotary axis.
pub const A: usize = 4;
/// Index of the B rotary axis.
pub const B: usize = 5;
/// Index of the C rotary axis.
pub const C: usize = 6;
/// Number of tracked axes: X Y Z E A B C.
pub const AXES: usize = 7;
/// The axis letters in index order.
pub const AXIS_LETTERS: [u8; AXES] = [b'X', b'Y', b'Z', b'E', b'A', b'B', b'C'];

/// The axis index of an (upper-case) word letter.
#[inline]
pub fn axis_of(letter: u8) -> Option<usize> {
    match letter {
        b'X' => Some(X),
        b'Y' => Some(Y),
        b'Z' => Some(Z),
        b'E' => Some(E),
        b'A' => Some(A),
        b'B' => Some(B),
        b'C' => Some(C),
        _ => None,
    }
}

/// A position on every axis, mm (degrees for rotary A/B/C).
pub type Position = [f64; AXES];
