//! Python bindings for gweave.
