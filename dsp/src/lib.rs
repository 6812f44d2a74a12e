//! Struck's real-time modal synthesis engine.
//!
//! Conventions: frequencies in Hz unless named `omega` (rad/s); eigenvalues λ in rad²/s²;
//! damping coefficients c in s⁻¹ with per-mode decay rate d = c/2 (amplitude ∝ e^(−d t));
//! audio is `f32`, mono inside the engine, control math `f64`.
//!
//! Nothing here allocates, locks or does I/O after construction: constructors (`new`)
//! allocate, everything documented "Realtime-safe" does not.
#![warn(missing_docs)]

pub mod contact;
pub mod damping;
pub mod engine;
pub mod exciter;
pub mod ftz;
pub mod residual;
pub mod resonator;
pub mod safety;

pub use damping::{Damping, DampingModel};
pub use engine::{Engine, NoteId, ObjectModes, SoundParams, Strike, Terminated};
