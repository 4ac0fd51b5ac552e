//! Base: the network's arithmetic in the processor's widest vectors it has, with the same
//! bits as everywhere else.
//!
//! The network's loops (16 units, four samples side by side, tanh through plain arithmetic)
//! are written so that the compiler vectorises them. Built for the x86-64 baseline it has
//! 2-lane SSE2 registers; [`wide`] runs a piece of code through a copy of it compiled for
//! AVX2 (4 lanes) when the processor has that, found once at run time, so the one binary
//! runs on any x86-64 and uses what it is given.
//!
//! The result is the same to the bit: AVX2 adds wider registers, not other arithmetic. Rust
//! never fuses a multiply and an add on its own (FMA is not enabled here) nor reorders
//! floating-point sums, so each lane computes what SSE2 or a scalar unit computes in the same
//! order. A whole build for x86-64-v3 fitted the same model file byte for byte (README,
//! Performance), and a test below holds both paths to the same bits.
//!
//! The crate denies `unsafe` everywhere but here: calling a function compiled for a feature
//! the processor may lack is `unsafe` in Rust, and this is that one function and its one
//! call, after the check that makes it sound.

/// Runs `f` through a copy compiled for AVX2 when the processor has it, else as it is.
///
/// Only code inlined into the copy gets the wider vectors: pass `f` as an
/// `#[inline(always)]` closure and keep what it runs `#[inline(always)]`, as the network's
/// loops are. Anything left out of line (an iterator adapter's `fold` was, once) runs in the
/// plain build.
#[inline(always)]
pub fn wide<T>(f: impl FnOnce() -> T) -> T {
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx2") {
        #[allow(unsafe_code)]
        // SAFETY: `avx2` enables AVX2 alone, and the processor has it (checked above).
        return unsafe { avx2(f) };
    }
    f()
}

/// `f()` compiled with AVX2. An `unsafe fn` (not a safe one, which Rust allows a
/// `#[target_feature]` from 1.86 on) so that the crate builds with its stated 1.80.
///
/// # Safety
/// The processor must have AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
#[allow(unsafe_code)]
unsafe fn avx2<T>(f: impl FnOnce() -> T) -> T {
    f()
}

/// The plain build of the same code, for the test that both give the same bits.
#[cfg(test)]
pub(crate) fn narrow<T>(f: impl FnOnce() -> T) -> T {
    f()
}
