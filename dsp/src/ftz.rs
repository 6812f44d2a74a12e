//! Flush-to-zero and denormals-are-zero for the audio thread.
//!
//! Resonator tails decay exponentially towards the subnormal range, where x86 arithmetic is
//! up to a hundred times slower. Voices are ended at −120 dBFS, and on top of that the audio
//! thread runs with FTZ and DAZ set for the duration of `process()`.

/// Sets FTZ and DAZ while alive and restores the previous mode when dropped.
///
/// # Realtime safety
/// Two register reads and writes; no allocation.
pub struct DenormalGuard {
    #[cfg(target_arch = "x86_64")]
    old: u32,
}

#[cfg(target_arch = "x86_64")]
const FTZ_DAZ: u32 = (1 << 15) | (1 << 6);

impl DenormalGuard {
    /// Enables FTZ and DAZ on this thread.
    #[allow(clippy::new_without_default)]
    pub fn new() -> Self {
        #[cfg(target_arch = "x86_64")]
        {
            let old = read_mxcsr();
            write_mxcsr(old | FTZ_DAZ);
            DenormalGuard { old }
        }
        #[cfg(not(target_arch = "x86_64"))]
        {
            DenormalGuard {}
        }
    }
}

impl Drop for DenormalGuard {
    fn drop(&mut self) {
        #[cfg(target_arch = "x86_64")]
        write_mxcsr(self.old);
    }
}

#[cfg(target_arch = "x86_64")]
fn read_mxcsr() -> u32 {
    let mut v: u32 = 0;
    // SAFETY: stmxcsr stores the 32-bit MXCSR register to the given valid address.
    unsafe { std::arch::asm!("stmxcsr [{}]", in(reg) &mut v, options(nostack)) };
    v
}

#[cfg(target_arch = "x86_64")]
fn write_mxcsr(v: u32) {
    // SAFETY: ldmxcsr loads MXCSR from a valid address; only the FTZ/DAZ bits differ from
    // the current value, which changes rounding of subnormals only.
    unsafe { std::arch::asm!("ldmxcsr [{}]", in(reg) &v, options(nostack, readonly)) };
}

#[cfg(test)]
mod tests {
    #[test]
    fn subnormals_flush_inside_the_guard() {
        let tiny = std::hint::black_box(f32::MIN_POSITIVE);
        {
            let _g = super::DenormalGuard::new();
            let x = std::hint::black_box(tiny) * std::hint::black_box(0.5f32);
            #[cfg(target_arch = "x86_64")]
            assert_eq!(x, 0.0);
            let _ = x;
        }
        let y = std::hint::black_box(tiny) * std::hint::black_box(0.5f32);
        assert!(y > 0.0);
    }
}
