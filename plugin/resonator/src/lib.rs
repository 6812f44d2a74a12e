//! Struck Resonator, the effect (CLAP and VST3): the track's input (stereo or mono) drives the object's
//! modes at the contact position (issue 16). Exports [`StruckResonator`] of `struck-core`; the
//! instrument is the `struck` package.

#![warn(missing_docs)]
use nice_plug::prelude::*;
use struck_core::StruckResonator;

nice_export_clap!(StruckResonator);
nice_export_vst3!(StruckResonator);
