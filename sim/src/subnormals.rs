//! Subnormal numbers flushed to zero while the solver runs.
//!
//! A flat cloth's matrix entries across its plane are round-off
//! (~1e-20). In the single-precision preconditioner their products are
//! subnormal (below 2⁻¹²⁶ ≈ 1.2e-38), and an x86 core takes each
//! operation on a subnormal through a microcode assist of ~100 cycles: a
//! flat 30² cloth falling freely spent a quarter of its run there (the
//! line factorisation and sweeps; section 1ab of docs/benchmarks.md).
//! Nothing below 2⁻¹²⁶ in single precision, or 2⁻¹⁰²² in double, carries
//! anything the solver uses: the smallest quantities it compares with
//! are tolerances and masses, many orders of magnitude above.
//!
//! The mode (MXCSR's flush-to-zero and denormals-are-zero bits) belongs
//! to a thread. The solver's helper threads set it for good
//! ([`set_for_thread`]); a step sets it on the calling thread for its
//! length ([`Flush`]) and puts the caller's mode back. Every thread of a
//! run computes alike, so frames stay the same for any thread count.
//! Elsewhere than x86-64 both are no-ops.

/// MXCSR's flush-to-zero (bit 15) and denormals-are-zero (bit 6).
#[cfg(target_arch = "x86_64")]
const FTZ_DAZ: u32 = 0x8040;

/// Reads MXCSR.
#[cfg(target_arch = "x86_64")]
#[allow(unsafe_code)]
fn mxcsr() -> u32 {
    let mut v: u32 = 0;
    // SAFETY: `stmxcsr` writes the 4-byte register to the given address,
    // a local of that size; it touches no other memory.
    unsafe {
        std::arch::asm!("stmxcsr [{}]", in(reg) &mut v, options(nostack, preserves_flags));
    }
    v
}

/// Writes MXCSR.
#[cfg(target_arch = "x86_64")]
#[allow(unsafe_code)]
fn set_mxcsr(v: u32) {
    // SAFETY: `ldmxcsr` loads the register from a local holding a value
    // read from it with only the rounding-neutral FTZ/DAZ bits changed,
    // so no reserved bit is set (which would fault) and no exception is
    // unmasked.
    unsafe {
        std::arch::asm!("ldmxcsr [{}]", in(reg) &v, options(nostack, readonly, preserves_flags));
    }
}

/// Flushes subnormals on this thread from now on (the solver's helpers).
pub fn set_for_thread() {
    #[cfg(target_arch = "x86_64")]
    set_mxcsr(mxcsr() | FTZ_DAZ);
}

/// Flushes subnormals on this thread until dropped, then restores the
/// mode it found.
#[derive(Debug)]
#[must_use = "the mode is restored when the guard drops"]
pub struct Flush {
    #[cfg(target_arch = "x86_64")]
    saved: u32,
}

impl Flush {
    /// Sets the mode.
    pub fn new() -> Self {
        #[cfg(target_arch = "x86_64")]
        {
            let saved = mxcsr();
            set_mxcsr(saved | FTZ_DAZ);
            Self { saved }
        }
        #[cfg(not(target_arch = "x86_64"))]
        Self {}
    }
}

impl Default for Flush {
    fn default() -> Self {
        Self::new()
    }
}

impl Drop for Flush {
    fn drop(&mut self) {
        #[cfg(target_arch = "x86_64")]
        set_mxcsr(self.saved);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Under the guard a subnormal product is zero; after it, the
    /// thread computes it again.
    #[test]
    fn subnormals_flush_under_the_guard_only() {
        let tiny = std::hint::black_box(1e-20f32);
        {
            let _g = Flush::new();
            assert_eq!(std::hint::black_box(tiny) * tiny, 0.0);
            let sub = std::hint::black_box(f64::MIN_POSITIVE / 4.0);
            assert_eq!(sub * 1.0, 0.0, "a subnormal input reads as zero");
        }
        let p = std::hint::black_box(tiny) * tiny;
        assert!(p > 0.0 && p < f32::MIN_POSITIVE, "{p}");
    }
}
