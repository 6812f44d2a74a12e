//! Struck's command line (`struck`), as a library the tests share: rendering notes and MIDI
//! files through the plugin's own `process()` ([`cli`]), material capture from recordings
//! ([`capture`]), the FEM bank builder's commands ([`banks`]) and a strict MIDI reader
//! ([`midi_file`]). The plugin itself links none of this (nor clap, midly or the FEM).

#![warn(missing_docs)]
pub mod banks;
pub mod capture;
pub mod cli;
pub mod midi_file;
