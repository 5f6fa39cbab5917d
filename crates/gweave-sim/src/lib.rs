//! The gweave virtual printer.
