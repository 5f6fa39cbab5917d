//! The `gweave` command line, as a library so that the Python package can install the same CLI.
