//! The vector registers' upper halves after faer's matrix kernels.
//!
//! faer runs its products, QR and SVD on AVX-512 kernels where the processor has them,
//! and they return with the upper halves of the vector registers set. While they are
//! set, every SSE instruction pays a state transition: the C library's `exp`, `atan2`
//! and `sin_cos`, built for the baseline x86-64, then take about 150 ns a call instead
//! of 5 (measured on an AVX-512 Xeon; a thread started afterwards inherits the state).
//! [`clear`] zeroes them (`vzeroupper`); every routine that runs a faer decomposition or
//! product calls it before it returns. It changes no value.

/// Zeroes the upper halves of the vector registers where the processor has AVX (module
/// docs); nothing elsewhere.
#[inline]
pub fn clear() {
    #[cfg(target_arch = "x86_64")]
    if let Some(v3) = pulp::x86::V3::try_new() {
        v3.avx._mm256_zeroupper();
    }
}
