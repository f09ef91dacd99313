//! The rigfit command line as a library: each subcommand's arguments and `run`. The
//! `rigfit` binary is a thin `main` over it; `rigfit batch` and the Python package run
//! takes through the same functions, so a take's outputs do not depend on who runs it.

pub mod commands;
