//! The checks the fuzz targets run, one module per kind of input. The regression tests include
//! these files with `#[path]` and replay the kept corpus through them ([`replay`]).

pub mod controller;
pub mod gcode;
pub mod machine;
pub mod profiles;
pub mod replay;
