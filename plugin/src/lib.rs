//! Struck, the instrument (CLAP and VST3): exports [`Struck`] of `struck-core`, whose items
//! this crate re-exports (the command line and the tests use them as `struck::…`). The effect
//! variant, *Struck Resonator*, is exported by the `struck-resonator` package.

#![warn(missing_docs)]
pub use struck_core::*;

use nice_plug::prelude::*;

nice_export_clap!(Struck);
nice_export_vst3!(Struck);
